r"""The accuracy map (:mod:`clearance_pin.accuracy`): solve every pose and payload, then split the
output's displacement by joint and source from each joint's torsor and Pinocchio's placements.

.. math::  \delta p_{ik} = \sum_j R_j(q_i) v_{jik} + (R_j(q_i) \omega_{jik}) \times
           (p(q_i) - c_j(q_i)), \qquad \delta\theta_{ik} = \sum_j R_j(q_i) \omega_{jik}
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from ..equilibrium.elastic_tree import play_twin, spring_deflections
from ..errors import ArgumentError, NotFoundError
from ..kinematics.joint_shares import joint_levers, moved_by
from ..model.couplings import coupled
from ..model.frames import frame_id as find_frame
from ..model.joints import TreeJoint
from ..model.loads import Gravity, PointForce, Torque
from ..model.stiffness import stiff_joints

if TYPE_CHECKING:
    from ..mechanism import Mechanism

STANDARD_GRAVITY = 9.80665  # [m/s^2], a payload mass's weight
SOURCES = ("play", "backlash", "bearing compliance", "drive compliance")


@dataclass(frozen=True)
class AccuracyMap:
    """Where the output settles over poses and payloads (:func:`accuracy_map`).

    Attributes:
        output: the Pinocchio frame whose displacement is mapped.
        configurations: the poses q, (Q, nq).
        payloads: each payload's label (``"2 kg"``, or the load case's loads written out).
        translation: displacement of the output frame's origin [m], world axes, (Q, P, 3).
        rotation: its rotation vector [rad], world axes, (Q, P, 3).
        contributions: source (``"play"``, ``"backlash"``, ``"bearing compliance"``,
            ``"drive compliance"``) -> joint -> its share of :attr:`translation` [m], (Q, P, 3);
            the shares sum to the translation. Sources no joint has are left out.
        rotation_contributions: the same for :attr:`rotation` [rad].
        ok: every answer verified, (Q, P).
        solve_time: wall time of the solves and the split [s].
    """

    output: str
    configurations: np.ndarray
    payloads: tuple[str, ...]
    translation: np.ndarray
    rotation: np.ndarray
    contributions: dict[str, dict[str, np.ndarray]]
    rotation_contributions: dict[str, dict[str, np.ndarray]]
    ok: np.ndarray
    solve_time: float = field(default=0.0, compare=False)

    def largest(self) -> tuple[float, int, int]:
        """(the largest output displacement [m], its pose index, its payload index)."""
        norms = np.linalg.norm(self.translation, axis=2)
        pose, payload = np.unravel_index(int(np.nanargmax(norms)), norms.shape)
        return float(norms[pose, payload]), int(pose), int(payload)

    def ranking(self) -> list[tuple[str, str, float]]:
        """Contributors, largest first: (source, joint, the largest norm of its share of the
        output's displacement over the map [m]); contributors that never move it are left
        out."""
        rows = [
            (source, joint, float(np.nanmax(np.linalg.norm(share, axis=2))))
            for source, shares in self.contributions.items()
            for joint, share in shares.items()
        ]
        return sorted((row for row in rows if row[2] > 0.0), key=lambda row: -row[2])

    def to_dict(self, poses: bool = False) -> dict[str, Any]:
        """A JSON-ready summary: the largest displacement and where, per payload its largest and
        median, the ranked contributors; ``poses``: every pose's translation and rotation."""
        largest, pose, payload = self.largest()
        norms = np.linalg.norm(self.translation, axis=2)
        summary: dict[str, Any] = {
            "output": self.output,
            "poses": int(self.configurations.shape[0]),
            "payloads": list(self.payloads),
            "largest_translation_m": largest,
            "largest_at": {"pose": pose, "payload": self.payloads[payload]},
            "per_payload": {
                label: {
                    "largest_translation_m": float(np.nanmax(norms[:, k])),
                    "median_translation_m": float(np.nanmedian(norms[:, k])),
                    "largest_rotation_rad": float(
                        np.nanmax(np.linalg.norm(self.rotation[:, k], axis=1))
                    ),
                }
                for k, label in enumerate(self.payloads)
            },
            "contributors": [
                {"source": source, "joint": joint, "largest_translation_m": value}
                for source, joint, value in self.ranking()
            ],
            "all_verified": bool(self.ok.all()),
        }
        if poses:  # a failed case is NaN here, null in JSON
            summary["frame"] = "world"
            summary["configurations"] = self.configurations.tolist()
            summary["translation_m"] = _nulls(self.translation)
            summary["rotation_rad"] = _nulls(self.rotation)
        return summary


def _nulls(values: np.ndarray) -> list[Any]:
    """``values`` as nested lists, NaN as None (JSON has no NaN)."""
    cells = values.astype(object)
    cells[~np.isfinite(values)] = None
    nested: list[Any] = cells.tolist()
    return nested


def accuracy_map(
    mechanism: Mechanism,
    output: str,
    configurations: Any,
    payloads: Sequence[Any] = (0.0,),
    gravity: Any = None,
) -> AccuracyMap:
    """The accuracy map of ``output`` over ``configurations`` and ``payloads`` (module docstring).

    Args:
        mechanism: the robot (its driven joints hold each pose).
        output: a Pinocchio frame name (the tool).
        configurations: poses q, (Q, nq) (the driven joints' commands).
        payloads: each a mass [kg] hung at the output frame's origin (its weight along world -z,
            9.80665 m/s^2) or a load case (a list of PointForce / Torque); default one payload
            of 0 kg.
        gravity: the robot's own weight: None as the model says, True / False / a Gravity.

    Returns:
        :class:`AccuracyMap`.
    """
    started = time.perf_counter()
    model = mechanism.model
    frame = find_frame(model, output)
    if frame is None:
        raise NotFoundError("frame", output, [f.name for f in model.frames], mechanism.name)
    poses = _configurations(configurations, model.nq)
    cases, labels = _payload_cases(mechanism, output, payloads)
    count, joints = len(poses), mechanism.tree_joints
    translation = np.zeros((count, len(cases), 3))
    rotation = np.zeros((count, len(cases), 3))
    shares = {
        source: {j.name: np.zeros((count, len(cases), 3)) for j in joints} for source in SOURCES
    }
    turns = {
        source: {j.name: np.zeros((count, len(cases), 3)) for j in joints} for source in SOURCES
    }
    ok = np.zeros((count, len(cases)), dtype=bool)
    levers = joint_levers(model, mechanism.tree_joints, frame, poses)
    # a tree's springs add to its play (:mod:`..equilibrium.elastic_tree`): the rigid twin's
    # batch (closed forms over the poses) and each spring's deflection from its reaction, the
    # statics of the subtree it carries (one kinematics per pose for every payload)
    superposed = bool(stiff_joints(mechanism.joints)) and not mechanism.loop_joints
    solver = play_twin(mechanism) if superposed else mechanism
    statics = pose_terms(mechanism, poses) if superposed else None
    for k, loads in enumerate(cases):
        if not mechanism.resolve_loads(loads, False if gravity is False else gravity):
            ok[:, k] = True  # no load at all: every pose stays at its nominal place
            continue
        batch = solver.solve_many(
            [loads] * count, configurations=poses, gravity=gravity, errors="return"
        )
        ok[:, k] = batch.ok
        first = batch[0]
        if not ok[:, k].any() and isinstance(first, Exception):
            raise first  # no pose solves: a fault of the model or the payload, said once
        springs = {} if statics is None else subtree_reactions(mechanism, statics, loads, gravity)
        for joint in joints:
            if joint.name not in levers:
                continue  # not between the ground and the output: it does not move it
            axes, arms = levers[joint.name]
            torsor = batch.torsors(joint.name)  # (Q, 6) [m, rad], clearance frame
            deflection = None
            if joint.clearance.stiffness and superposed:
                deflection = spring_deflections(joint, springs[joint.name])
                torsor = torsor + deflection
            elif joint.clearance.stiffness:
                deflection = batch.deflections(joint.name)
            for source, part in _by_source(joint, torsor, deflection).items():
                moved, turned = moved_by(axes, arms, part)
                shares[source][joint.name][:, k] = moved
                turns[source][joint.name][:, k] = turned
        translation[:, k] = sum(s[:, k] for by in shares.values() for s in by.values())
        rotation[:, k] = sum(s[:, k] for by in turns.values() for s in by.values())
        failed = ~batch.ok
        translation[failed, k] = np.nan
        rotation[failed, k] = np.nan
    shares = {source: {j: s for j, s in by.items() if np.any(s)} for source, by in shares.items()}
    turns = {source: {j: t for j, t in by.items() if np.any(t)} for source, by in turns.items()}
    return AccuracyMap(
        output,
        poses,
        labels,
        translation,
        rotation,
        {source: by for source, by in shares.items() if by},
        {source: by for source, by in turns.items() if by},
        ok,
        time.perf_counter() - started,
    )


@dataclass(frozen=True)
class PoseTerms:
    """What a tree's subtree statics need at every pose, once for every payload.

    Attributes:
        joints: the tree joints, in order.
        carried: per joint, the Pinocchio joints (bodies) of the subtree it carries.
        masses: per pose and joint, the subtree's mass [kg], (Q, J).
        centres: per pose and joint, the subtree's centre of mass in the world [m], (Q, J, 3).
        frames: per pose and joint, its clearance frame: rotation (Q, J, 3, 3), origin (Q, J, 3).
        links: link name -> its frame's rotation (Q, 3, 3) and origin (Q, 3) in the world.
    """

    joints: tuple[TreeJoint, ...]
    carried: tuple[np.ndarray, ...]
    masses: np.ndarray
    centres: np.ndarray
    frames: tuple[np.ndarray, np.ndarray]
    links: dict[str, tuple[np.ndarray, np.ndarray]]


def pose_terms(mechanism: Mechanism, poses: np.ndarray) -> PoseTerms:
    """The :class:`PoseTerms` of a tree at ``poses`` (Q, nq): one forward kinematics and one
    ``pin.centerOfMass`` (subtree masses and centres) per pose."""
    model = mechanism.model
    data = model.createData()
    joints = mechanism.tree_joints
    count = len(poses)
    masses = np.zeros((count, len(joints)))
    centres = np.zeros((count, len(joints), 3))
    rotations = np.zeros((count, len(joints), 3, 3))
    origins = np.zeros((count, len(joints), 3))
    links = {
        name: (np.zeros((count, 3, 3)), np.zeros((count, 3))) for name in mechanism.link_frames
    }
    for i, pose in enumerate(poses):
        q = coupled(model, mechanism.couplings, pose)  # followers from their leaders
        pin.framesForwardKinematics(model, data, q)
        pin.centerOfMass(model, data, q, True)  # subtree masses, centres in their joint's frame
        for n, joint in enumerate(joints):
            k = joint.joint_id
            masses[i, n] = data.mass[k]
            centres[i, n] = data.oMi[k].act(data.com[k])
            centre = data.oMi[k] * pin.SE3(joint.rotation, np.zeros(3))
            rotations[i, n], origins[i, n] = centre.rotation, centre.translation
        for name, frame in mechanism.link_frames.items():
            links[name][0][i], links[name][1][i] = (
                data.oMf[frame].rotation,
                data.oMf[frame].translation,
            )
    carried = tuple(np.array(_subtree(model, j.joint_id)) for j in joints)
    return PoseTerms(joints, carried, masses, centres, (rotations, origins), links)


def subtree_reactions(
    mechanism: Mechanism, terms: PoseTerms, loads: Sequence[Any], gravity: Any
) -> dict[str, np.ndarray]:
    r"""Per tree joint of a tree, its reaction (the parent part's wrench on the child) at every
    pose of ``terms``, (Q, 6) [N, N m], its clearance frame, moment about the joint centre, from
    the statics of the subtree it carries: :math:`W_j = -\sum_{b \in \mathrm{subtree}(j)} L_b`
    (the contact forces inside the subtree are internal), the weights from Pinocchio's subtree
    masses and centres of mass, the point forces and torques at their links. The reactions of
    :meth:`~clearance_pin.equilibrium.batch.EquilibriumBatch.reactions` without their least
    squares: what a tree's springs carry (tests compare the two)."""
    model = mechanism.model
    resolved = mechanism.resolve_loads(loads, False if gravity is False else gravity)
    acceleration = sum(
        (np.asarray(g.acceleration, dtype=float) for g in resolved if isinstance(g, Gravity)),
        np.zeros(3),
    )
    count = terms.masses.shape[0]
    applied = []  # (body, wrench at the world origin (Q, 6))
    for load in resolved:
        if isinstance(load, Gravity):
            continue
        body = model.frames[mechanism.link_frames[load.link]].parentJoint
        wrench = np.zeros((count, 6))
        if isinstance(load, PointForce):
            rotation, origin = terms.links[load.link]
            point = rotation @ np.asarray(load.point, dtype=float) + origin
            force = np.broadcast_to(np.asarray(load.force, dtype=float), (count, 3))
            wrench[:, :3], wrench[:, 3:] = force, np.cross(point, force)
        else:
            wrench[:, 3:] = load.torque
        applied.append((body, wrench))
    rotations, origins = terms.frames
    out = {}
    for n, joint in enumerate(terms.joints):
        total = np.zeros((count, 6))
        for body, wrench in applied:
            if body in terms.carried[n]:
                total += wrench
        weight = terms.masses[:, n, None] * acceleration  # (Q, 3)
        total[:, :3] += weight
        total[:, 3:] += np.cross(terms.centres[:, n], weight)
        # the parent's wrench on the child, in the joint's clearance frame about its centre
        force, moment = -total[:, :3], -total[:, 3:]
        local_force = np.einsum("qji,qj->qi", rotations[:, n], force)
        local_moment = np.einsum(
            "qji,qj->qi", rotations[:, n], moment - np.cross(origins[:, n], force)
        )
        out[joint.name] = np.hstack([local_force, local_moment])
    return out


def _subtree(model: pin.Model, root: int) -> list[int]:
    """The Pinocchio joints (bodies) of the subtree rooted at ``root``, itself included."""
    found = [root]
    for j in range(root + 1, model.njoints):  # parents come before their children
        if model.parents[j] in found:
            found.append(j)
    return found


def _configurations(configurations: Any, nq: int) -> np.ndarray:
    poses = np.asarray(configurations, dtype=float)
    if poses.ndim == 1 and poses.size == nq:
        poses = poses[None]
    if poses.ndim != 2 or poses.shape[1] != nq or not poses.shape[0]:
        raise ArgumentError(
            "configurations", f"poses q shaped (Q, {nq}), at least one", np.shape(configurations)
        )
    if not np.isfinite(poses).all():
        raise ArgumentError("configurations", "finite joint values", "a NaN or infinity")
    return poses


def _payload_cases(
    mechanism: Mechanism, output: str, payloads: Any
) -> tuple[list[list[Any]], tuple[str, ...]]:
    """Each payload as a load case and its label; a mass [kg] hangs at the output's origin."""
    if isinstance(payloads, (int, float, PointForce, Torque)):
        payloads = [payloads]
    cases, labels = [], []
    for index, payload in enumerate(payloads):
        if isinstance(payload, bool) or not isinstance(payload, (int, float, list, tuple)):
            raise ArgumentError(
                f"payloads[{index}]", "a mass [kg] or a list of PointForce / Torque", payload
            )
        if isinstance(payload, (int, float)):
            if not (np.isfinite(payload) and payload >= 0.0):
                raise ArgumentError(f"payloads[{index}]", "a mass >= 0 [kg]", payload)
            link, point = mechanism.link_point(output)
            weight = [0.0, 0.0, -STANDARD_GRAVITY * float(payload)]
            cases.append([PointForce(link, weight, point)] if payload else [])
            labels.append(f"{float(payload):g} kg")
            continue
        loads = list(payload)
        for load in loads:
            if not isinstance(load, (PointForce, Torque, Gravity)):
                raise ArgumentError(f"payloads[{index}]", "PointForce, Torque or Gravity", load)
        cases.append(loads)
        labels.append(", ".join(_describe(load) for load in loads) or "no load")
    if not cases:
        raise ArgumentError("payloads", "at least one payload", payloads)
    return cases, tuple(labels)


def _describe(load: Any) -> str:
    if isinstance(load, PointForce):
        return f"{np.linalg.norm(load.force):.4g} N on {load.link}"
    if isinstance(load, Torque):
        return f"{np.linalg.norm(load.torque):.4g} N m on {load.link}"
    return "gravity"


def _by_source(
    joint: TreeJoint, torsor: np.ndarray, deflection: np.ndarray | None = None
) -> dict[str, np.ndarray]:
    """A joint's torsors (Q, 6) split by source: its elastic ``deflection`` (Q, 6) (None: a
    rigid joint) on the component its drive turns or slides (``"drive compliance"``) and on the
    others (``"bearing compliance"``); the rest, its play, on the drive's component
    (``"backlash"``) and on the others (``"play"``)."""
    elastic = np.zeros_like(torsor) if deflection is None else deflection
    play = torsor - elastic
    on_drive = np.zeros(6, dtype=bool)
    if joint.driven and joint.motion_component is not None:
        on_drive[joint.motion_component] = True
    return {
        "play": np.where(on_drive, 0.0, play),
        "backlash": np.where(on_drive, play, 0.0),
        "bearing compliance": np.where(on_drive, 0.0, elastic),
        "drive compliance": np.where(on_drive, elastic, 0.0),
    }


__all__ = ["STANDARD_GRAVITY", "AccuracyMap", "accuracy_map"]
