r"""The accuracy map of a tree of independent joint blocks, every pose and payload at once.

The general route (:func:`.accuracy_map.accuracy_map` without this module) calls
:meth:`~clearance_pin.mechanism.Mechanism.solve_many` once per payload, so each payload repeats
the poses' checks and kinematics. For a mechanism without loop joints or couplings whose joints
are independent blocks (:func:`~clearance_pin.equilibrium.blocks.block_structure`: journals,
balls, pins, slabs of axial play and backlash), the same answers come from the same closed forms
with the kinematics of each pose computed once and the payloads as columns:

1. body placements of every pose, once (:func:`~clearance_pin.equilibrium.batch_kinematics.
   body_placements`);
2. the body wrenches of the robot's weight and of each payload :math:`P_k` at every pose
   (:func:`~clearance_pin.equilibrium.load_table.body_wrenches`), each once: the loads enter
   linearly, a mass payload is a multiple of the 1 kg case; stacked as N = P Q cases;
3. the gradients :math:`g = -\sum_b J_b^T W_b` by the subtree statics about each joint centre
   (:func:`~clearance_pin.equilibrium.tree_trajectory.tree_gradients`), the closed forms and their
   verification (:func:`~clearance_pin.equilibrium.blocks.closed_forms`,
   :func:`~clearance_pin.equilibrium.block_verify.verify`), exactly as ``solve_many`` forms them;
4. a spring's deflection :math:`e_j = -K_j^{+} R_j` from joint j's reaction
   :math:`R_j = -\sum_{b \in subtree(j)} W_b` about its centre, clearance frame (the superposition of
   :mod:`~clearance_pin.equilibrium.elastic_batch`).

Every answer is verified as ``solve_many`` verifies a closed form (the KKT conditions of the cone
programme, :func:`~clearance_pin.equilibrium.block_verify.verify`: an optimum of a convex
programme); a case that does not verify, or whose loads work on an unblocked motion, is solved by
``solve_many`` (the general route). One departure: where the closed forms' uniqueness test is
inconclusive (``decided`` False: a journal end carrying a sliver of the load, a contact between
5e-10 and 2e-9 of the largest load) ``solve_many`` solves the case alone by its cone solver,
whose answer is the same optimum on the robots tested (tests/test_accuracy_reach.py compares those
cases with single solves to 1e-12 of the largest deviation); here the verified closed form is
kept, at a hundredth of the time, and a group between loaded and unloaded (at most 2e-9 of the
largest multiplier) counts as free for the reach. The groups each case leaves unloaded (every
contact at most 5e-10 of the largest multiplier: the general path's flat directions, which a
single solve lists among its ``free_motions``) are returned for the reach (:mod:`.reach`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..equilibrium.batch_kinematics import body_placements
from ..equilibrium.block_verify import verify
from ..equilibrium.blocks import (
    LOADED_SHARE,
    BlockStructure,
    block_structure,
    closed_forms,
    reduced_unknowns,
)
from ..equilibrium.elastic_tree import play_twin, spring_deflections
from ..equilibrium.load_table import body_wrenches, load_table, repeated
from ..equilibrium.prepared import PreparedGeometry, prepared_geometry
from ..equilibrium.tree_trajectory import objectives_of, tree_gradients, tree_maps
from ..model.loads import Gravity
from ..model.stiffness import elastic

if TYPE_CHECKING:
    from ..model.mechanism_parts import MechanismParts as Mechanism

CHUNK = 1024  # cases per closed-form pass (as the block batch: its arrays stay in the cache)


@dataclass(frozen=True)
class TreeCases:
    """Every pose and payload of a tree's map, N = P Q cases, payload-major (case k Q + i).

    Attributes:
        prepared: the rigid twin's geometry (its contacts, maps and bounds).
        structure: its block structure.
        torsors: joint -> its torsor, play and spring, (N, 6) [m, rad], clearance frame.
        deflections: joint -> its spring's deflection (N, 6) (stiff joints only).
        ok: verified answer per case (N,).
        unloaded: per case and group, the group is unloaded: its motion is free (N, G).
        undecided: per case, answered by its verified closed form where ``solve_many`` would
            have solved it alone (module docstring), (N,).
    """

    prepared: PreparedGeometry
    structure: BlockStructure
    torsors: dict[str, np.ndarray]
    deflections: dict[str, np.ndarray]
    ok: np.ndarray
    unloaded: np.ndarray
    undecided: np.ndarray


def blocks_of(mechanism: Mechanism) -> tuple[PreparedGeometry, BlockStructure] | None:
    """The rigid twin's geometry and block structure, or None where this route does not apply
    (loop joints, couplings, joints that are not independent blocks)."""
    if mechanism.loop_joints or mechanism.couplings:
        return None
    prepared = prepared_geometry(play_twin(mechanism))
    if not prepared.geometry.contacts:
        return None
    structure = block_structure(prepared.geometry, False)
    return None if structure is None else (prepared, structure)


def placements(mechanism: Mechanism, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every body's placement at every pose, once: rotations (Q, bodies, 3, 3) and origins
    (Q, bodies, 3) [m], world axes (:func:`~clearance_pin.equilibrium.batch_kinematics.
    body_placements`)."""
    return body_placements(play_twin(mechanism), list(poses))


def levers(
    mechanism: Mechanism,
    frame: int,
    placed: tuple[np.ndarray, np.ndarray],
    point: np.ndarray | None = None,
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """:func:`~clearance_pin.kinematics.joint_shares.joint_levers` from the placements
    ``placed`` (:func:`placements`): per tree joint between the ground and ``frame``, its
    clearance axes :math:`R_j C_j` (Q, 3, 3) and the arm :math:`p - c_j` (Q, 3) [m], p the
    frame's origin or ``point`` (3,) [m] in the frame."""
    rotations, translations = placed
    model = mechanism.model
    at = model.frames[frame]
    body = at.parentJoint
    local = at.placement.translation if point is None else at.placement.act(point)
    point = rotations[:, body] @ local + translations[:, body]
    chain = set()
    while body:
        chain.add(body)
        body = model.parents[body]
    return {
        joint.name: (
            rotations[:, joint.joint_id] @ joint.rotation,
            point - translations[:, joint.joint_id],
        )
        for joint in mechanism.tree_joints
        if joint.joint_id in chain
    }


def tree_cases(
    mechanism: Mechanism,
    found: tuple[PreparedGeometry, BlockStructure],
    poses: np.ndarray,
    cases: list[list[Any]],
    gravity: Any,
    placements: tuple[np.ndarray, np.ndarray],
    masses: Sequence[float | None] | None = None,
    unit: list[Any] | None = None,
) -> TreeCases:
    r"""Solve every pose of ``poses`` (Q, nq) under every load case of ``cases`` (module
    docstring); ``found``: :func:`blocks_of`'s answer; ``placements``: :func:`placements`'.

    The loads enter linearly: the body wrenches, the gradients and the springs' reactions of a
    case are the robot's weight's plus its payload's, each formed once per pose, and a payload
    ``cases[k]`` that is ``masses[k]`` times the load case ``unit`` (a 1 kg mass) is that
    multiple of its terms: :math:`g_{ik} = g^{weight}_i + m_k\, g^{unit}_i`.
    """
    prepared, structure = found
    twin = play_twin(mechanism)
    count = len(poses)
    rotations, translations = placements
    maps = tree_maps(twin, prepared.geometry)

    def terms_of(loads: list[Any], weight: Any) -> Terms:
        """Body wrenches, moments, validity, gradients and springs of ``loads`` at every pose."""
        table = repeated(load_table(twin, [loads], weight), count)
        wrenches, moments = body_wrenches(table, rotations, translations, prepared.bodies, True)
        gradients = tree_gradients(maps, rotations, translations, wrenches)
        springs = _springs(mechanism, wrenches, rotations, translations)
        return Terms(wrenches, moments, table.valid, gradients, springs)

    weight = terms_of([], gravity)  # the robot's own weight (zero without gravity)
    scaled = None if unit is None else terms_of(unit, False)
    parts: list[Terms] = []
    for k, loads in enumerate(cases):
        mass = None if masses is None else masses[k]
        if mass is not None and scaled is not None:
            parts.append(weight.plus(scaled.times(mass)))
        elif any(isinstance(load, Gravity) for load in loads):  # its own weight: as a whole
            parts.append(terms_of(loads, gravity))
        else:
            parts.append(weight.plus(terms_of(loads, False)))
    wrenches = np.concatenate([part.wrenches for part in parts])  # (N, bodies, 6), payload-major
    moments = np.concatenate([part.moments for part in parts])
    valid = np.concatenate([part.valid for part in parts])
    gradients = np.concatenate([part.gradients for part in parts])
    terms = objectives_of(prepared, gradients, wrenches, moments)
    size = len(terms.sigmas)
    x = np.empty((size, structure.size_x))
    unloaded = np.zeros((size, len(structure.group_rows)), dtype=bool)
    done = np.zeros(size, dtype=bool)
    undecided = np.zeros(size, dtype=bool)
    for start in range(0, size, CHUNK):
        part = slice(start, start + CHUNK)
        closed = closed_forms(structure, terms.gradients[part], terms.sigmas[part])
        check = verify(
            prepared,
            structure,
            terms.objectives[part],
            reduced_unknowns(structure, closed.x),
            closed.x,
            closed.multipliers,
            closed.signs,
            terms.sigmas[part],
            terms.gradients[part],
            terms.load_sizes[part],
            closed.unloaded,
        )
        x[part] = closed.x
        # a group neither surely loaded nor surely unloaded: its contacts may sit anywhere
        largest = closed.multipliers.max(axis=1, initial=0.0)[:, None]
        light = (closed.multipliers <= LOADED_SHARE * largest) @ structure.members > 0
        unloaded[part] = closed.unloaded | light
        done[part] = check.verified
        undecided[part] = ~closed.decided
    done &= terms.regular & valid
    torsors = {
        name: x @ prepared.maps.joint_torsor[name].T for name in mechanism.joints
    }  # the play's
    deflections = {
        name: np.concatenate([part.springs[name] for part in parts]) for name in weight.springs
    }
    for name, spring in deflections.items():
        torsors[name] = torsors[name] + spring
    ok = done.copy()
    rest = np.flatnonzero(~done)
    if rest.size:  # the general route, as solve_many would take these cases
        _solve_rest(mechanism, poses, cases, gravity, rest, torsors, deflections, ok)
    return TreeCases(prepared, structure, torsors, deflections, ok, unloaded, undecided & done)


@dataclass(frozen=True)
class Terms:
    """The load terms of one payload at every pose (Q rows): body wrenches (Q, bodies, 6) and
    moments about the world origin (Q, bodies, 3) [N, N m] (:func:`~clearance_pin.equilibrium.
    load_table.body_wrenches`), validity (Q,), gradients g (Q, n) [J per unit] and the springs'
    deflections, joint -> (Q, 6) [m, rad]: each linear in the loads."""

    wrenches: np.ndarray
    moments: np.ndarray
    valid: np.ndarray
    gradients: np.ndarray
    springs: dict[str, np.ndarray]

    def plus(self, other: Terms) -> Terms:
        """The terms of both loads together."""
        return Terms(
            self.wrenches + other.wrenches,
            self.moments + other.moments,
            self.valid & other.valid,
            self.gradients + other.gradients,
            {name: spring + other.springs[name] for name, spring in self.springs.items()},
        )

    def times(self, factor: float) -> Terms:
        """The terms of the loads scaled by ``factor``."""
        return Terms(
            factor * self.wrenches,
            factor * self.moments,
            self.valid,
            factor * self.gradients,
            {name: factor * spring for name, spring in self.springs.items()},
        )


def _springs(
    mechanism: Mechanism, wrenches: np.ndarray, rotations: np.ndarray, translations: np.ndarray
) -> dict[str, np.ndarray]:
    r"""Each stiff joint's deflection :math:`e_j = -K_j^{+} R_j` (N, 6) [m, rad], with
    :math:`R_j` the parent's wrench on the child, clearance frame, about the joint centre: minus
    the body wrenches (N, bodies, 6) [N, N m] (about the body origins, world axes) of the subtree
    it carries, summed from the leaves to the root with the levers between body origins."""
    stiff = [joint for joint in mechanism.tree_joints if elastic(joint.clearance)[1].size]
    if not stiff:
        return {}
    model = mechanism.model
    total = wrenches.copy()
    for body in range(total.shape[1] - 1, 0, -1):
        parent = model.parents[body]
        if parent > 0:
            force = total[:, body, :3]
            lever = translations[:, body] - translations[:, parent]
            total[:, parent, :3] += force
            total[:, parent, 3:] += total[:, body, 3:] + np.cross(lever, force)
    out = {}
    for joint in stiff:
        axes = rotations[:, joint.joint_id] @ joint.rotation  # the clearance frame, (N, 3, 3)
        carried = total[:, joint.joint_id].reshape(-1, 2, 3)
        local = (carried @ axes).reshape(-1, 6)  # R^T v as row vectors
        out[joint.name] = spring_deflections(joint, -local)
    return out


def _solve_rest(
    mechanism: Mechanism,
    poses: np.ndarray,
    cases: list[list[Any]],
    gravity: Any,
    rest: np.ndarray,
    torsors: dict[str, np.ndarray],
    deflections: dict[str, np.ndarray],
    ok: np.ndarray,
) -> None:
    """The cases ``rest`` (payload-major indices) by ``solve_many``, written into the arrays in
    place; a payload none of whose poses solves raises its first pose's error (a fault of the
    model or the payload, said once, as the general route does)."""
    count = len(poses)
    batch = mechanism.solve_many(
        [cases[k // count] for k in rest.tolist()],
        configurations=[poses[k % count] for k in rest.tolist()],
        gravity=gravity,
        errors="return",
    )
    ok[rest] = batch.ok
    for payload in range(len(cases)):
        mine = np.flatnonzero(rest // count == payload)
        if mine.size == count and not ok[rest[mine]].any():
            first = batch[int(mine[0])]
            if isinstance(first, Exception):
                raise first
    for name, values in torsors.items():
        values[rest] = batch.torsors(name)
    for name, values in deflections.items():
        values[rest] = batch.deflections(name)


__all__ = ["TreeCases", "blocks_of", "levers", "placements", "tree_cases"]
