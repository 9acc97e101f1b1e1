r"""Joint reactions of every case of a batch at once (small-displacement model).

The same recovery as :func:`.reactions.joint_reactions` for one answer, on stacked arrays: per
case, the contact forces of each joint (:func:`.batch_answers.contact_forces`) applied at their
contact points, and the rigid and drive parts :math:`(\mu, \tau)` from the statics of every moving
body b (world axes, moments about its origin :math:`o_b`, divided by :math:`L_{ref}`)

.. math::  L_b + \sum_{j:\ \mathrm{child}(j) = b} W_j - \sum_{j:\ \mathrm{parent}(j) = b} W_j = 0

solved by least squares with the item's column scaling: one factorisation for all cases at one
configuration (the matrix depends on the configuration only), one per case along a trajectory.
The joint frames are the frames of the items' reactions: the child-side clearance frame at the
nominal pose of each case (:mod:`.poses`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin

from ..errors import ArgumentError, NotFoundError
from ..model.couplings import leader_stops, passive
from ..numerics import Array
from .batch_answers import StackedAnswers, contact_forces
from .load_table import body_wrenches, load_table
from .poses import ClearanceFrames
from .reactions import FRAMES, _generators, frames_at

# the frames _generators is given where only its local wrenches are read (placed per case here)
_UNPLACED = ClearanceFrames(pin.SE3.Identity(), pin.SE3.Identity(), 0, 0)

PARTS = ("contact", "rigid", "drive", "held")


@dataclass(frozen=True)
class StackedReactions:
    """Every joint's reaction parts in every case, wrenches at the world origin, world axes.

    Attributes:
        names: the joints, in the mechanism's order (J,).
        parts: part (``"contact"``, ``"rigid"``, ``"drive"``, ``"held"``) -> (N, J, 6)
            [N, N m] (force, moment about the world origin); NaN rows for the cases not stacked.
        rotations, translations: world placement of each joint's frame (``frame="joint"``),
            (K, J, 3, 3) and (K, J, 3) [m], K = 1 or N.
    """

    names: tuple[str, ...]
    parts: dict[str, Array]
    rotations: Array
    translations: Array

    def reaction(self, joint: str, frame: str = "joint", part: str | None = None) -> Array:
        """(force, moment) (N, 6) [N, N m] of ``joint`` in ``frame`` (``"joint"``: its frame's
        axes, moment about its centre; ``"world"``: world axes, moment about the origin), the
        sum of the parts or the one ``part`` (:class:`.reactions.Reaction`)."""
        if joint not in self.names:
            raise NotFoundError("joint", joint, self.names)
        if frame not in FRAMES:
            raise ArgumentError("frame", "'joint' or 'world'", frame)
        if part is not None and part not in PARTS:
            raise ArgumentError("part", f"None or one of {', '.join(PARTS)}", part)
        j = self.names.index(joint)
        chosen = [self.parts[p][:, j] for p in (PARTS if part is None else (part,))]
        if frame == "joint":  # placement.actInv(Force): (R^T f, R^T (m - t x f)) per part
            rotation, origin = self.rotations[:, j], self.translations[:, j]
            local = []
            for wrench in chosen:
                force, moment = wrench[:, :3], wrench[:, 3:]
                local.append(
                    np.concatenate(
                        [
                            np.einsum("nji,nj->ni", rotation, force),
                            np.einsum("nji,nj->ni", rotation, moment - np.cross(origin, force)),
                        ],
                        axis=1,
                    )
                )
            chosen = local
        total = chosen[0].copy()
        for wrench in chosen[1:]:
            total += wrench
        return total


def tree_reactions(
    mechanism: Any, load_column: Any, gravity: Any, rotations: Array, translations: Array
) -> dict[str, Array]:
    r"""Per tree joint of a tree, its reaction in every case (the parent part's wrench on the
    child), (N, 6) [N, N m], its clearance frame, moment about the joint centre, from the statics
    of the subtree it carries, :math:`R_j = -\sum_{b \in \mathrm{subtree}(j)} L_b` (the contact
    forces inside the subtree are internal): the loads of every case as rows
    (:func:`.load_table.load_table`), summed per body about the world origin
    (:func:`.load_table.body_wrenches`), then from the leaves to the root. Body placements (K,
    bodies, 3, 3), (K, bodies, 3) [m], K = N (a trajectory) or 1; the cases' loads
    ``load_column`` (None: the model's) with the solve's ``gravity`` option. A joint's entry is
    its reaction where :func:`subtree_statics_hold` (a passive coupling across its subtree
    carries torque between its joints, a loop closes through its joint)."""
    model = mechanism.model
    table = load_table(mechanism, load_column, gravity)
    wrenches, about = body_wrenches(
        table, rotations, translations, model.njoints, per_case=len(rotations) > 1
    )
    force, moment = wrenches[..., :3].copy(), about.copy()  # (N, bodies, 3), world origin
    for i in range(model.njoints - 1, 0, -1):  # a child before its parent
        force[:, model.parents[i]] += force[:, i]
        moment[:, model.parents[i]] += moment[:, i]
    out = {}
    for joint in mechanism.tree_joints:
        i = joint.joint_id
        axes = rotations[:, i] @ joint.rotation  # the clearance frame's (K, 3, 3)
        centre = translations[:, i]
        carried = -force[:, i]
        turning = -(moment[:, i] - np.cross(centre, force[:, i]))  # about the joint centre
        local = np.empty((len(force), 6))
        local[:, :3] = (np.swapaxes(axes, 1, 2) @ carried[:, :, None])[..., 0]
        local[:, 3:] = (np.swapaxes(axes, 1, 2) @ turning[:, :, None])[..., 0]
        out[joint.name] = local
    return out


def whole_tree_reaction(answers: StackedAnswers, joint: str, frame: str) -> Array | None:
    """The whole reaction (N, 6) of ``joint`` in every stacked case of a tree,
    from the statics of its subtree (:func:`tree_reactions`; the same wrench as the contact,
    rigid, drive and held parts summed, without solving for them): ``frame="joint"`` its
    clearance frame about the joint centre, ``"world"`` world axes about the world origin. None
    where the subtree's statics do not give it (:func:`subtree_statics_hold`)."""
    mechanism = answers.mechanism
    if not subtree_statics_hold(mechanism, joint):
        return None
    cached: dict[str, Array] | None = answers.__dict__.get("_tree_reactions")
    if cached is None:
        cached = answers.__dict__["_tree_reactions"] = tree_reactions(
            mechanism, answers.load_column, answers.gravity, answers.rotations,
            answers.translations,
        )  # fmt: skip
    return in_frame(mechanism, joint, cached[joint], frame, answers.rotations, answers.translations)


def subtree_statics_hold(mechanism: Any, joint: str) -> bool:
    """Whether the statics of the subtree ``joint`` carries give its whole reaction: a tree (no
    loop joints) in which no passive coupling (its leader not driven: it carries a torque
    between its two joints; a driven leader's follower is held as a drive is) has one of its
    joints in that subtree (``joint`` itself included) and the other outside. A coupling with
    both inside acts between parts of the subtree: its torques cancel there, as every internal
    force does (a gripper's coupled fingers under an arm joint)."""
    if mechanism.loop_joints:
        return False
    couplings = passive(mechanism.couplings, mechanism.joints)
    if not couplings:
        return True
    model = mechanism.model
    root = model.getJointId(joint)

    def inside(name: str) -> bool:
        index = model.getJointId(name)
        while index > root:  # a parent's index is below its child's
            index = model.parents[index]
        return bool(index == root)

    return all(inside(c.leader) == inside(c.follower) for c in couplings)


def in_frame(
    mechanism: Any, joint: str, local: Array, frame: str, rotations: Array, translations: Array
) -> Array:
    """A tree joint's reactions (N, 6) given in its clearance frame about its centre, in
    ``frame``: ``"joint"`` as given, ``"world"`` world axes about the world origin; body
    placements (K, bodies, 3, 3), (K, bodies, 3) [m], K = N or 1."""
    if frame == "joint":
        return local
    tree_joint = next(j for j in mechanism.tree_joints if j.name == joint)
    axes = rotations[:, tree_joint.joint_id] @ tree_joint.rotation
    force = (axes @ local[:, :3, None])[..., 0]
    moment = (axes @ local[:, 3:, None])[..., 0]
    centre = translations[:, tree_joint.joint_id]
    world: Array = np.concatenate([force, moment + np.cross(centre, force)], axis=1)
    return world


def stacked_reactions(answers: StackedAnswers) -> StackedReactions:
    """The :class:`StackedReactions` of every stacked case of ``answers`` (module docstring)."""
    cached: StackedReactions | None = answers.__dict__.get("_reactions")
    if cached is not None:
        return cached
    mechanism = answers.mechanism
    model = mechanism.model
    names = tuple(mechanism.joints)
    count, bodies = len(answers.y), model.njoints
    rotations, translations = answers.rotations, answers.translations
    if leader_stops(mechanism.couplings, mechanism.joints):  # what it passes on: per case
        empty = {part: np.full((count, len(names), 6), np.nan) for part in PARTS}
        shape = (1, len(names))
        return StackedReactions(names, empty, np.zeros((*shape, 3, 3)), np.zeros((*shape, 3)))
    if answers.along:  # a tree: joint k's child-side clearance frame is oM_k C_k
        by_name = {joint.name: joint for joint in mechanism.tree_joints}
        tree = [by_name[name] for name in names]  # a trajectory is a tree's: all tree joints
        ids = np.array([joint.joint_id for joint in tree], dtype=np.intp)
        turns = np.array([joint.rotation for joint in tree])
        frame_rotations = rotations[:, ids] @ turns[None]
        frame_origins = translations[:, ids]
        ends = [(int(model.parents[k]), k) for k in ids.tolist()]
    else:
        frames = frames_at(mechanism, answers.prepared.configuration, tuple(_se3(answers)))
        frame_rotations = np.array([[frames[name].child.rotation for name in names]])
        frame_origins = np.array([[frames[name].child.translation for name in names]])
        ends = [(frames[name].parent_body, frames[name].child_body) for name in names]
    index = {name: j for j, name in enumerate(names)}

    def placed(local: Array, j: int) -> Array:
        """Wrenches (P, 6) or (6,) in joint j's frame -> world origin, (P or K, 6)."""
        local = local.reshape(-1, 6)
        rotation = frame_rotations[:, j]
        force = (rotation @ local[:, :3, None])[..., 0]
        moment = (rotation @ local[:, 3:, None])[..., 0]
        return np.concatenate([force, moment + np.cross(frame_origins[:, j], force)], axis=-1)

    length = mechanism.length_scale()

    def at_body(wrench: Array, body: int) -> Array:
        """(F, (M - o_b x F) / L): the wrench about body b's origin, moments over L_ref."""
        origin = translations[:, body]
        force = wrench[..., :3]
        return np.concatenate([force, (wrench[..., 3:] - np.cross(origin, force)) / length], -1)

    # contact part: each contact force at its contact point, in its joint's frame
    forces = contact_forces(answers)
    contact = np.zeros((count, len(names), 6))
    for k, constraint in enumerate(answers.prepared.geometry.contacts):
        point, lever = np.array(constraint.contact.point), constraint.contact.lever
        if lever:  # a drive's backlash stop: a moment about the axis, no force
            local = np.concatenate([np.zeros_like(forces[:, k]), lever * forces[:, k]], axis=1)
        else:
            local = np.concatenate([forces[:, k], np.cross(point, forces[:, k])], axis=1)
        contact[:, index[constraint.joint]] += placed(local, index[constraint.joint])

    # generator columns (rigid directions, drives) in each joint's frame, placed per case
    columns, owners = [], []
    for name in names:
        joint = mechanism.joints[name]
        for part, local, _ in _generators(joint, _UNPLACED, False):
            for column in local.T:
                columns.append(placed(column, index[name]))  # (K, 6)
                owners.append((index[name], part))

    def scatter(wrench: Array, j: int) -> Array:
        """The wrench of joint j on its child (+) and parent (-) body equations, (..., rows)."""
        out = np.zeros((*wrench.shape[:-1], 6 * bodies))
        parent, child = ends[j]
        out[..., 6 * child : 6 * child + 6] += at_body(wrench, child)
        out[..., 6 * parent : 6 * parent + 6] -= at_body(wrench, parent)
        return out[..., 6:]

    table = load_table(mechanism, answers.load_column, answers.gravity)
    per_case = answers.along and len(rotations) == count
    sums, moments = body_wrenches(table, rotations, translations, bodies, per_case)
    loads = np.concatenate([sums[..., :3], moments], axis=-1)  # about the world origin
    known = np.zeros((count, 6 * bodies))
    for body in range(1, bodies):
        known[:, 6 * body : 6 * body + 6] += at_body(loads[:, body], body)
    known = known[:, 6:]
    for j in range(len(names)):
        known += scatter(contact[:, j], j)

    solved = answers.stacked & table.valid
    solution = np.full((count, len(columns)), np.nan)
    if columns:
        matrix = np.stack([scatter(column, j) for column, (j, _) in zip(columns, owners)], -1)
        sizes = np.linalg.norm(matrix, axis=1)  # (K, C)
        sizes[sizes == 0.0] = 1.0
        scaled = matrix / sizes[:, None, :]
        chosen = np.flatnonzero(solved)
        if len(matrix) == 1:  # one configuration: one factorisation, every case a right side
            answer = np.linalg.lstsq(scaled[0], -known[chosen].T, rcond=None)[0]
            solution[chosen] = answer.T / sizes[0]
        elif chosen.size:  # one least squares per configuration, in one batched SVD
            solution[chosen] = _least_squares(scaled[chosen], -known[chosen]) / sizes[chosen]
    else:
        solution = np.zeros((count, 0))
    parts = {part: np.zeros((count, len(names), 6)) for part in PARTS}
    parts["contact"] = contact
    for k, (j, part) in enumerate(owners):
        parts[part][:, j] += solution[:, k, None] * columns[k]
    for part in PARTS:
        parts[part][~solved] = np.nan
    reactions = StackedReactions(names, parts, frame_rotations, frame_origins)
    answers.__dict__["_reactions"] = reactions
    return reactions


def _least_squares(matrices: np.ndarray, rights: np.ndarray) -> np.ndarray:
    """The minimum-norm least-squares solutions (N, n) of N systems ``matrices`` (N, m, n) x =
    ``rights`` (N, m), by one batched SVD with numpy.linalg.lstsq's rank rule (singular values
    above eps * max(m, n) of the largest count)."""
    u, singular, vt = np.linalg.svd(matrices, full_matrices=False)
    floor = np.finfo(float).eps * max(matrices.shape[1:]) * singular[:, :1]
    inverse = np.where(singular > floor, 1.0 / np.where(singular > 0.0, singular, 1.0), 0.0)
    projected = np.einsum("nmk,nm->nk", u, rights) * inverse
    solutions: np.ndarray = np.einsum("nkj,nk->nj", vt, projected)
    return solutions


def _se3(answers: StackedAnswers) -> Any:
    """The body placements of the one configuration as pin.SE3 (its Configuration's own)."""
    return answers.prepared.configuration.oMi


__all__ = [
    "PARTS",
    "StackedReactions",
    "stacked_reactions",
    "subtree_statics_hold",
    "tree_reactions",
    "whole_tree_reaction",
]
