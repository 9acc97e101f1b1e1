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

from ..errors import ArgumentError, NotFoundError
from ..kinematics.joint_shares import joint_levers, moved_by
from ..model.frames import frame_id as find_frame
from ..model.joints import TreeJoint
from ..model.loads import Gravity, PointForce, Torque

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
    # a tree's springs add to its play: solve_many gives the rigid twin's batch and each
    # spring's deflection from its reaction, the statics of its subtree (.equilibrium.elastic_batch)
    for k, loads in enumerate(cases):
        if not mechanism.resolve_loads(loads, False if gravity is False else gravity):
            ok[:, k] = True  # no load at all: every pose stays at its nominal place
            continue
        batch = mechanism.solve_many(
            [loads] * count, configurations=poses, gravity=gravity, errors="return"
        )
        ok[:, k] = batch.ok
        if not ok[:, k].any() and isinstance(first := batch[0], Exception):
            raise first  # no pose solves: a fault of the model or the payload, said once
        for joint in joints:
            if joint.name not in levers:
                continue  # not between the ground and the output: it does not move it
            axes, arms = levers[joint.name]
            torsor = batch.torsors(joint.name)  # (Q, 6) [m, rad], clearance frame, with springs
            deflection = batch.deflections(joint.name) if joint.clearance.stiffness else None
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
