r"""The accuracy map (:mod:`clearance_pin.accuracy`): solve every pose and payload, then split the
output's displacement by joint and source from each joint's torsor and Pinocchio's placements.

.. math::  \delta p_{ik} = \sum_j R_j(q_i) v_{jik} + (R_j(q_i) \omega_{jik}) \times
           (p(q_i) - c_j(q_i)), \qquad \delta\theta_{ik} = \sum_j R_j(q_i) \omega_{jik}
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from ..arguments import check_load_magnitudes
from ..errors import ArgumentError, NotFoundError
from ..kinematics.joint_shares import joint_levers
from ..model import plausibility
from ..model.couplings import coupled_joint, driven
from ..model.frames import frame_id as find_frame
from ..model.frames import parse_point
from ..model.joints import TreeJoint
from ..model.loads import Gravity, PointForce, Torque
from .reach import reach, row_directions
from .tree_map import blocks_of, placements, tree_cases
from .tree_map import levers as tree_levers

if TYPE_CHECKING:
    from ..model.mechanism_parts import MechanismParts as Mechanism

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
        reach: the largest distance of the output from its nominal place [m], (Q, P), over the
            settled state and every motion the load leaves free (:mod:`.reach`; >= the norm of
            :attr:`translation`); NaN where not computed (mechanisms with loop joints or
            couplings, joints that are not independent blocks) or the case failed.
        free_motions: ``"joint: motion"`` (``backlash``, ``axial play``, ``radial play``) ->
            (Q, P) True where that motion is free (unloaded): the joints responsible for the
            band between :attr:`translation` and :attr:`reach`.
        payload_point: where a mass payload hangs, (3,) [m] in the output frame (None: its
            origin).
        free_spread: how far the free motions alone can move the output from its settled place
            [m], (Q, P) (0 where none is free; NaN where the reach is not computed).
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
    reach: np.ndarray | None = None
    free_motions: dict[str, np.ndarray] = field(default_factory=dict)
    payload_point: np.ndarray | None = None
    free_spread: np.ndarray | None = None

    def largest_reach(self) -> tuple[float, int, int]:
        """(the largest reach [m], its pose index, its payload index); NaN, -1, -1 where the
        reach was not computed."""
        if self.reach is None or not np.isfinite(self.reach).any():
            return float("nan"), -1, -1
        pose, payload = np.unravel_index(int(np.nanargmax(self.reach)), self.reach.shape)
        return float(self.reach[pose, payload]), int(pose), int(payload)

    def responsible(self, pose: int, payload: int) -> list[str]:
        """The free motions (``"joint: motion"``) of one case: what can move the output from
        its settled place to its reach."""
        return [name for name, mask in self.free_motions.items() if mask[pose, payload]]

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
        reach, at, case = self.largest_reach()
        if np.isfinite(reach):
            assert self.reach is not None
            summary["largest_reach_m"] = reach
            summary["largest_reach_at"] = {
                "pose": at,
                "payload": self.payloads[case],
                "free_motions": self.responsible(at, case),
            }
            for k, label in enumerate(self.payloads):
                summary["per_payload"][label]["largest_reach_m"] = float(
                    np.nanmax(self.reach[:, k])
                )
            if self.free_spread is not None:
                summary["largest_free_spread_m"] = float(np.nanmax(self.free_spread))
            summary["free_motions"] = [
                {"motion": name, "cases": int(mask.sum())}
                for name, mask in self.free_motions.items()
            ]
        if self.payload_point is not None:
            summary["payload_point_m"] = [float(v) for v in self.payload_point]
        if poses:  # a failed case is NaN here, null in JSON
            summary["frame"] = "world"
            summary["configurations"] = self.configurations.tolist()
            summary["translation_m"] = _nulls(self.translation)
            summary["rotation_rad"] = _nulls(self.rotation)
            if self.reach is not None:
                summary["reach_m"] = _nulls(self.reach)
            if self.free_spread is not None:
                summary["free_spread_m"] = _nulls(self.free_spread)
        return summary

    def to_csv(self, path: str | Path, joint_names: Sequence[str] | None = None) -> None:
        """Write one row per pose and payload: the joint values q (``joint_names``, else
        q0, q1, ...) [rad or m], the payload, the translation (world axes) and its norm [m], the
        reach [m] (empty where not computed), each (source, joint)'s share of the translation,
        its norm [m], and the free motions (``;``-separated)."""
        import csv

        names = list(joint_names or [f"q{i}" for i in range(self.configurations.shape[1])])
        if len(names) != self.configurations.shape[1]:
            raise ArgumentError("joint_names", f"{self.configurations.shape[1]} names", names)
        contributors = [(s, j) for s, by in self.contributions.items() for j in by]
        header = [*(f"{n}" for n in names), "payload", "x_m", "y_m", "z_m", "translation_m",
                  "reach_m", *(f"{s} {j}_m" for s, j in contributors), "free_motions"]  # fmt: skip
        norms = np.linalg.norm(self.translation, axis=2)
        with open(path, "w", newline="") as stream:
            writer = csv.writer(stream)
            writer.writerow(header)
            for i, q in enumerate(self.configurations):
                for k, label in enumerate(self.payloads):
                    reach = "" if self.reach is None else _cell(self.reach[i, k])
                    writer.writerow([
                        *map(repr, q.tolist()), label, *map(_cell, self.translation[i, k]),
                        _cell(float(norms[i, k])), reach,
                        *(_cell(float(np.linalg.norm(self.contributions[s][j][i, k])))
                          for s, j in contributors),
                        "; ".join(self.responsible(i, k)),
                    ])  # fmt: skip


def _cell(value: float) -> str:
    """A CSV cell of a number [SI]: its repr, empty for NaN."""
    return repr(float(value)) if np.isfinite(value) else ""


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
    payload_point: Any = None,
) -> AccuracyMap:
    """The accuracy map of ``output`` over ``configurations`` and ``payloads`` (module docstring).

    Args:
        mechanism: the robot (its driven joints hold each pose).
        output: a Pinocchio frame name (the tool).
        configurations: poses q, (Q, nq) (the driven joints' commands).
        payloads: each a mass [kg] hung at ``payload_point`` (its weight along world -z,
            9.80665 m/s^2) or a load case (a list of PointForce / Torque); default one payload
            of 0 kg.
        gravity: the robot's own weight: None as the model says, True / False / a Gravity.
        payload_point: where a mass hangs, (3,) [m] in the output frame; None: its origin.

    Returns:
        :class:`AccuracyMap`.
    """
    started = time.perf_counter()
    model = mechanism.model
    frame_name, at = _output_point(mechanism, output)
    frame = find_frame(model, frame_name)
    if frame is None:
        raise NotFoundError("frame", output, [f.name for f in model.frames], mechanism.name)
    poses = _configurations(configurations, model.nq)
    point = _payload_point(payload_point)
    if at is not None:  # a point of a link: the payload hangs there, or payload_point from it
        point = at if point is None else at + point
    cases, labels = _payload_cases(mechanism, frame_name, payloads, point)
    loaded = [
        bool(mechanism.resolve_loads(loads, False if gravity is False else gravity))
        for loads in cases
    ]
    found = blocks_of(mechanism)
    if found is not None:
        masses = [_mass(payload) for payload in _listed(payloads)]
        link, where = _hanging_point(mechanism, frame_name, point)
        unit = [PointForce(link, [0.0, 0.0, -STANDARD_GRAVITY], where)]  # 1 kg
        solved = _tree_route(
            mechanism, found, (frame, at), poses, cases, loaded, gravity, masses, unit
        )
    else:
        levers = joint_levers(model, mechanism.tree_joints, frame, poses, at)
        solved = _general_route(mechanism, poses, cases, loaded, gravity, levers)
    translation, rotation, shares, turns, ok, (reached, spread), free = solved
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
        reached,
        free,
        point,
        spread,
    )


Levers = dict[str, tuple[np.ndarray, np.ndarray]]
Solved = tuple[
    np.ndarray,
    np.ndarray,
    dict[str, dict[str, np.ndarray]],
    dict[str, dict[str, np.ndarray]],
    np.ndarray,
    tuple[np.ndarray, np.ndarray],
    dict[str, np.ndarray],
]


def _tree_route(
    mechanism: Mechanism,
    found: Any,
    target: tuple[int, np.ndarray | None],
    poses: np.ndarray,
    cases: list[list[Any]],
    loaded: list[bool],
    gravity: Any,
    masses: list[float | None],
    unit: list[Any],
) -> Solved:
    """Every pose and loaded payload at once (:mod:`.tree_map`), the reach from the groups each
    case leaves unloaded (:mod:`.reach`); a payload without any load leaves every group free."""
    count, payloads = len(poses), len(cases)
    prepared, structure = found
    # as solve_many: one warning for the poses outside the joints' limits (stacklevel 4: the
    # caller of Mechanism.accuracy)
    plausibility.warn_configurations(mechanism, poses, stacklevel=4)
    placed = placements(mechanism, poses)  # the kinematics of each pose, once
    levers = tree_levers(mechanism, target[0], placed, target[1])  # (frame, point on it)
    solved = [k for k in range(payloads) if loaded[k]]
    chosen = [cases[k] for k in solved]
    answers = (
        tree_cases(
            mechanism, found, poses, chosen, gravity, placed, [masses[k] for k in solved], unit
        )
        if solved
        else None
    )
    groups = len(structure.group_rows)
    unloaded = np.ones((payloads, count, groups), dtype=bool)
    ok = np.ones((payloads, count), dtype=bool)
    zeros = np.zeros((payloads, count, 6))
    torsors = {j.name: zeros.copy() for j in mechanism.tree_joints}
    springs = {j.name: zeros.copy() for j in mechanism.tree_joints if j.clearance.stiffness}
    if answers is not None:
        unloaded[solved] = answers.unloaded.reshape(len(solved), count, groups)
        ok[solved] = answers.ok.reshape(len(solved), count)
        for name, values in answers.torsors.items():
            if name in torsors:
                torsors[name][solved] = values.reshape(len(solved), count, 6)
        for name, values in answers.deflections.items():
            if name in springs:
                springs[name][solved] = values.reshape(len(solved), count, 6)
    shares, turns = _split(mechanism, torsors, springs, levers, count, payloads)
    translation, rotation = _total(shares), _total(turns)
    failed = ~ok.T
    translation[failed] = np.nan
    rotation[failed] = np.nan
    # the reach over the free rows: each row's unknowns, its joint's torsor, the output's lever
    units = {name: structure.rows_to_x @ prepared.maps.joint_torsor[name].T for name in levers}
    directions = row_directions(units, levers)  # (Q, R, 3)
    row_group = structure.contact_group[structure.row_contact]
    free_rows = unloaded[:, :, row_group].transpose(1, 0, 2).reshape(count * payloads, -1)
    pose = np.repeat(np.arange(count), payloads)  # the cases in (Q, P) order
    reached, spread = reach(
        translation.reshape(-1, 3), directions, pose, structure.row_bound, free_rows
    )
    contacts = prepared.geometry.contacts
    free = {}
    for g in range(groups):
        members = np.flatnonzero(structure.members[:, g])
        label = f"{contacts[members[0]].joint}: " + _motion(contacts[members[0]].contact.name)
        mask = unloaded[:, :, g].T & ok.T
        if mask.any():
            free[label] = mask
    shape = (count, payloads)
    return (translation, rotation, shares, turns, ok.T.copy(),
            (reached.reshape(shape), spread.reshape(shape)), free)  # fmt: skip


def _general_route(
    mechanism: Mechanism,
    poses: np.ndarray,
    cases: list[list[Any]],
    loaded: list[bool],
    gravity: Any,
    levers: Levers,
) -> Solved:
    """One ``solve_many`` per payload (loop joints, couplings, joints that are not independent
    blocks); the reach is not computed there (NaN)."""
    count, payloads = len(poses), len(cases)
    ok = np.ones((count, payloads), dtype=bool)
    zeros = np.zeros((payloads, count, 6))
    torsors = {j.name: zeros.copy() for j in mechanism.tree_joints}
    springs = {j.name: zeros.copy() for j in mechanism.tree_joints if j.clearance.stiffness}
    for k, loads in enumerate(cases):
        if not loaded[k]:
            continue  # no load at all: every pose stays at its nominal place
        batch = mechanism.solve_many(
            [loads] * count, configurations=poses, gravity=gravity, errors="return"
        )
        ok[:, k] = batch.ok
        if not ok[:, k].any() and isinstance(first := batch[0], Exception):
            raise first  # no pose solves: a fault of the model or the payload, said once
        leaders = {c.leader for c in driven(mechanism.couplings, mechanism.joints)}
        for name in {*levers, *leaders}:  # a leader's motion also moves its followers
            torsors[name][k] = batch.torsors(name)
            if name in springs:
                springs[name][k] = batch.deflections(name)
    shares, turns = _split(mechanism, torsors, springs, levers, count, payloads)
    translation, rotation = _total(shares), _total(turns)
    translation[~ok] = np.nan
    rotation[~ok] = np.nan
    unknown = np.full((count, payloads), np.nan)
    return translation, rotation, shares, turns, ok, (unknown, unknown.copy()), {}


def _split(
    mechanism: Mechanism,
    torsors: dict[str, np.ndarray],
    springs: dict[str, np.ndarray],
    levers: Levers,
    count: int,
    payloads: int,
) -> tuple[dict[str, dict[str, np.ndarray]], dict[str, dict[str, np.ndarray]]]:
    """Each joint's share of the output's translation and rotation (Q, P, 3) by source, from
    its torsors (P, Q, 6) and its springs' deflections (P, Q, 6)."""
    shape = (count, payloads, 3)
    shares = {s: {j.name: np.zeros(shape) for j in mechanism.tree_joints} for s in SOURCES}
    turns = {s: {j.name: np.zeros(shape) for j in mechanism.tree_joints} for s in SOURCES}
    coupled = _coupled_sources(mechanism, torsors, springs)
    for joint in mechanism.tree_joints:
        if joint.name not in levers:
            continue  # not between the ground and the output: it does not move it
        axes, arms = levers[joint.name]
        deflection = springs.get(joint.name)
        torsor = torsors[joint.name]
        inherited = coupled.get(joint.name, {})
        parts: list[tuple[str, str, np.ndarray]] = []
        if inherited:  # a follower's coupled turn is its leaders' backlash and compliance
            motion = cast(int, joint.motion_component)
            torsor = torsor.copy()
            for (origin, source), amount in inherited.items():
                torsor[..., motion] -= amount
                part = np.zeros_like(torsor)
                part[..., motion] = amount
                parts.append((source, origin, part))
        for source, part in _by_source(joint, torsor, deflection).items():
            parts.append((source, joint.name, part))
        for source, owner, part in parts:
            if not part.any():
                continue  # a source this joint does not have
            turned = _rotated(axes, part[..., 3:])
            moved = _rotated(axes, part[..., :3])
            shares[source][owner] = shares[source][owner] + moved + np.cross(turned, arms[:, None])
            turns[source][owner] = turns[source][owner] + turned
    return shares, turns


def _coupled_sources(
    mechanism: Mechanism, torsors: dict[str, np.ndarray], springs: dict[str, np.ndarray]
) -> dict[str, dict[tuple[str, str], np.ndarray]]:
    r"""Per follower of a driven leader, its coupled turn (P, Q) [rad or m] by where it comes
    from, (joint, source) -> amount: :math:`m\,(\beta_l + e_l)` from its leader's backlash and
    drive compliance, and m times what its leader inherits from its own (a chain)
    (:mod:`..model.couplings`)."""
    coupled: dict[str, dict[tuple[str, str], np.ndarray]] = {}
    for coupling in driven(mechanism.couplings, mechanism.joints):  # leaders first
        leader = coupled_joint(mechanism.joints, coupling.leader)
        along = cast(int, leader.motion_component)
        inherited = coupled.get(leader.name, {})
        own = torsors[leader.name][..., along] - sum(inherited.values(), 0.0)
        spring = springs.get(leader.name)
        elastic = 0.0 * own if spring is None else spring[..., along]
        m = coupling.multiplier
        parts = {(leader.name, "backlash"): m * (own - elastic)}
        parts[(leader.name, "drive compliance")] = m * elastic
        parts.update({key: m * amount for key, amount in inherited.items()})
        coupled[coupling.follower] = {key: a for key, a in parts.items() if np.any(a)}
    return coupled


def _rotated(axes: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    """:math:`R_q v_{kq}` (Q, P, 3): axes (Q, 3, 3), vectors (P, Q, 3)."""
    out: np.ndarray = vectors.transpose(1, 0, 2) @ axes.transpose(0, 2, 1)
    return out


def _total(parts: dict[str, dict[str, np.ndarray]]) -> np.ndarray:
    """The sum of every source's and joint's share, (Q, P, 3)."""
    arrays = [share for by in parts.values() for share in by.values()]
    total: np.ndarray = np.sum(arrays, axis=0)
    return total


def _motion(contact: str) -> str:
    """What a contact's free motion is, in words: its drive's backlash, its axial play, the
    radial play of a journal end, or the contact's name."""
    if contact == "backlash":
        return "backlash"
    if contact == "axial":
        return "axial play"
    if contact.startswith("end"):
        return "radial play"
    return contact


def _payload_point(point: Any) -> np.ndarray | None:
    if point is None:
        return None
    values = np.asarray(point, dtype=float) if _numbers(point) else None
    if values is None or values.shape != (3,) or not np.isfinite(values).all():
        raise ArgumentError("payload_point", "a point (x, y, z) [m] in the output frame", point)
    return values


def _numbers(values: Any) -> bool:
    try:
        return np.asarray(values).dtype.kind in "iuf"
    except (TypeError, ValueError):
        return False


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


def _listed(payloads: Any) -> list[Any]:
    """The payloads as a list (one given alone: a list of it)."""
    return [payloads] if isinstance(payloads, (int, float, PointForce, Torque)) else list(payloads)


def _mass(payload: Any) -> float | None:
    """A payload's mass [kg], None for a load case."""
    return float(payload) if isinstance(payload, (int, float)) else None


def _payload_cases(
    mechanism: Mechanism, output: str, payloads: Any, point: np.ndarray | None = None
) -> tuple[list[list[Any]], tuple[str, ...]]:
    """Each payload as a load case and its label; a mass [kg] hangs at ``point`` (the output
    frame [m]; None: its origin)."""
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
            link, where = _hanging_point(mechanism, output, point)
            weight = [0.0, 0.0, -STANDARD_GRAVITY * float(payload)]
            cases.append([PointForce(link, weight, where)] if payload else [])
            check_load_magnitudes(cases[-1], f"payloads[{index}]")
            labels.append(f"{float(payload):g} kg")
            continue
        loads = list(payload)
        for load in loads:
            if not isinstance(load, (PointForce, Torque, Gravity)):
                raise ArgumentError(f"payloads[{index}]", "PointForce, Torque or Gravity", load)
        check_load_magnitudes(loads, f"payloads[{index}]")  # what double precision carries
        cases.append(loads)
        labels.append(", ".join(_describe(load) for load in loads) or "no load")
    if not cases:
        raise ArgumentError("payloads", "at least one payload", payloads)
    return cases, tuple(labels)


def _hanging_point(
    mechanism: Mechanism, output: str, point: np.ndarray | None
) -> tuple[str, np.ndarray]:
    r"""(the link the output moves with, ``point`` (output frame [m]; None: its origin) in that
    link's frame [m]): :math:`p_{link} = {}^{link}M_{output}\, p`."""
    link, origin = mechanism.link_point(output)
    if point is None:
        return link, origin
    model = mechanism.model
    placed = model.frames[find_frame(model, output)].placement
    at = model.frames[mechanism.link_frames[link]].placement
    return link, (at.inverse() * placed).act(point)


def _output_point(mechanism: Mechanism, output: str) -> tuple[str, np.ndarray | None]:
    """(the frame the output is on, the point (3,) [m] on it, or None for its origin): a
    Pinocchio frame's name, or a point of a link, ``link@[x y z]`` [m] in the link's frame."""
    parsed = parse_point(output) if isinstance(output, str) else None
    if parsed is None:
        return output, None
    link, local = parsed
    if link not in mechanism.link_frames:
        raise NotFoundError("link", link, tuple(mechanism.link_frames), mechanism.name)
    if local.shape != (3,) or not np.all(np.isfinite(local)):
        raise ArgumentError("output", "link@[x y z]: 3 finite numbers [m], link frame", output)
    return link, local


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
