r"""The configuration-dependent part of a tree's equilibrium: the load's gradient at joint centres.

A mechanism without loop joints has one reduced geometry for all its configurations
(:func:`.prepared._reduced`): only the load's gradient :math:`g` changes along a trajectory or
from one load to the next. On the unknowns of tree joint k it is minus the wrench of everything
the joint carries (the loads on the bodies of its child subtree), about its centre, in its
clearance frame :math:`(R_c, p_c) = (R_k C_k, t_k)` (docs/method.md 2.1:
:math:`g = -\sum_b J_b^T W_b`). With the body wrenches :math:`(F_b, M_b)` about each body's own
origin :math:`t_b` (world axes, :mod:`.load_table`: :math:`M_b = \sum (R_b p) \times F + C`) and
the lever arms :math:`d_{kb} = t_b - t_k` taken from the positions,

.. math::  \bar F_k = \sum_{b \in subtree(k)} F_b, \qquad
           \bar M_k = \sum_{b \in subtree(k)} \big(M_b + d_{kb} \times F_b\big), \qquad
           g_k = -B_k^T \begin{pmatrix} R_c^T \bar F_k \\ R_c^T \bar M_k \end{pmatrix}
           \quad [J\ per\ unit\ of\ t_k].

So every moment is formed about the joint's own centre, :math:`\sum (p - c) \times F + C`, from
lever arms of the size of the loaded parts' distance to the joint: never as a moment about the
world origin with :math:`c \times \bar F` subtracted afterwards, whose round-off
(:math:`\epsilon\, |c|\, |\bar F|`) may exceed the moment about the joint a hundredfold at a joint
near the tool and tilt a lightly loaded journal end by as much (issue 12). At one configuration
the map from the body wrenches to g is one constant matrix (:func:`centre_map`: load cases and
single solves). Along a trajectory (:func:`tree_gradients`) the same sums are formed from the
leaves to the root, every point at once (arrays (N, ...)): each body's subtree wrench about its
own origin is its own plus its children's, moved by the lever from it to each child,

.. math::  \bar M_b = M_b + \sum_{c \in children(b)} \big(\bar M_c + (t_c - t_b) \times
           \bar F_c\big), \qquad \bar F_b = F_b + \sum_{c \in children(b)} \bar F_c,

and joint k reads its child body's: no maps, reductions or SVDs per point. The objective terms
follow as :meth:`.prepared.PreparedGeometry.objectives` forms them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, cast

import numpy as np

from ..model.couplings import driven
from ..numerics import Array, Index, Mask
from .reduction import ROUND_OFF_WORK, UNBOUNDED_FRACTION, ReducedGeometry
from .small_displacement import tree_joint_basis

if TYPE_CHECKING:
    from ..model.mechanism_parts import MechanismParts as Mechanism
    from .prepared import PreparedGeometry


@dataclass(frozen=True)
class TreeMaps:
    """The configuration-independent terms of a tree's gradient.

    Attributes:
        joint_ids: Pinocchio index of every tree joint (in the unknowns' order), (J,).
        rotations: C_k, the clearance frame in each joint frame, (J, 3, 3).
        subtree: (bodies, bodies), 1.0 where body b is in the subtree of body i.
        carried: (J, bodies), the rows of ``subtree`` of the tree joints: 1.0 where joint k
            carries body b.
        parents: the parent body of every body (Pinocchio's order: a parent before its
            children), (bodies,).
        selection: (6 J, n), the blocks B_k: g = -(local wrenches (N, 6 J)) @ selection; a
            follower's motion row also reads m times its leader's (:mod:`..model.couplings`).
    """

    joint_ids: Index
    rotations: Array
    subtree: Array
    carried: Array
    parents: Index
    selection: Array


def tree_maps(mechanism: Mechanism, geometry: ReducedGeometry | None = None) -> TreeMaps:
    """The :class:`TreeMaps` of a mechanism without loop joints; memoised on its tree
    ``geometry`` when given (the one reduced geometry of all its configurations)."""
    if geometry is not None:
        cached = geometry.__dict__.get("_tree_maps")
        if cached is None:
            cached = tree_maps(mechanism)
            # frozen dataclass: a derived, private cache (as blocks.block_structure)
            object.__setattr__(geometry, "_tree_maps", cached)
        return cast(TreeMaps, cached)
    model = mechanism.model
    bodies = model.njoints
    subtree = np.zeros((bodies, bodies))
    for body in range(1, bodies):
        ancestor = body
        while ancestor > 0:
            subtree[ancestor, body] = 1.0
            ancestor = model.parents[ancestor]
    joints = mechanism.tree_joints
    bases = [tree_joint_basis(joint) for joint in joints]
    selection = np.zeros((6 * len(joints), sum(b.shape[1] for b in bases)))
    column = 0
    for k, basis in enumerate(bases):
        selection[6 * k : 6 * k + 6, column : column + basis.shape[1]] = basis
        column += basis.shape[1]
    row = {joint.name: 6 * k for k, joint in enumerate(joints)}
    by_name = {joint.name: joint for joint in joints}
    for coupling in driven(mechanism.couplings, by_name):  # a follower moves with its leader
        follower, leader = by_name[coupling.follower], by_name[coupling.leader]
        selection[row[follower.name] + cast(int, follower.motion_component)] += (
            coupling.multiplier * selection[row[leader.name] + cast(int, leader.motion_component)]
        )
    ids = np.array([joint.joint_id for joint in joints], dtype=np.intp)
    return TreeMaps(
        joint_ids=ids,
        rotations=np.array([joint.rotation for joint in joints]).reshape(-1, 3, 3),
        subtree=subtree,
        carried=subtree[ids],
        parents=np.array(model.parents, dtype=np.intp),
        selection=selection,
    )


def _levers(maps: TreeMaps, translations: Array) -> Array:
    """Lever arms :math:`d_{kb} = t_b - t_k` [m] from each joint centre to the origin of every
    body it carries (0 for the others), (..., J, bodies, 3), from body origins (..., bodies, 3)."""
    centres = translations[..., maps.joint_ids, None, :]
    levers: Array = (translations[..., None, :, :] - centres) * maps.carried[..., None]
    return levers


def centre_map(maps: TreeMaps, rotations: Array, translations: Array) -> Array:
    r"""The gradient map G (6 bodies, n) at one configuration: :math:`g = W G` for the body
    wrenches W (..., 6 bodies) [N, N m] about the body origins, stacked (F_b, M_b) per body
    (module docstring); body rotations (bodies, 3, 3) and origins (bodies, 3) [m].

    As row vectors, joint k's local force is :math:`\sum_b s_{kb} F_b^T R_c` and its local
    moment :math:`\sum_b s_{kb} (M_b^T - F_b^T [d_{kb}]_\times) R_c` (:math:`(d \times F)^T =
    -F^T [d]_\times`; :math:`s_{kb}` = ``carried``), so G holds, per body and joint, the blocks
    :math:`s_{kb} R_c` (force to force, moment to moment) and :math:`-[d_{kb}]_\times R_c`
    (force to moment), times :math:`-B_k`."""
    bodies, count = rotations.shape[0], maps.joint_ids.size
    frames = rotations[maps.joint_ids] @ maps.rotations  # R_c (J, 3, 3)
    d = _levers(maps, translations)  # (J, bodies, 3)
    skew = np.zeros((*d.shape, 3))  # [d]_x (J, bodies, 3, 3)
    skew[..., 0, 1], skew[..., 0, 2] = -d[..., 2], d[..., 1]
    skew[..., 1, 0], skew[..., 1, 2] = d[..., 2], -d[..., 0]
    skew[..., 2, 0], skew[..., 2, 1] = -d[..., 1], d[..., 0]
    turned = maps.carried[:, :, None, None] * frames[:, None]  # s_kb R_c (J, bodies, 3, 3)
    block = np.zeros((bodies, 2, 3, count, 2, 3))
    block[:, 0, :, :, 0] = block[:, 1, :, :, 1] = turned.transpose(1, 2, 0, 3)
    block[:, 0, :, :, 1] = -(skew @ frames[:, None]).transpose(1, 2, 0, 3)
    gradient_map: Array = -(block.reshape(6 * bodies, 6 * count) @ maps.selection)
    return gradient_map


def tree_gradients(maps: TreeMaps, rotations: Array, translations: Array, wrenches: Array) -> Array:
    """The x-space gradients g (N, n) [J per unit] (module docstring) from the body placements
    (K, bodies, 3, 3), (K, bodies, 3) [m] and the body wrenches (N, bodies, 6) [N, N m] about the
    body origins (:func:`.load_table.body_wrenches`), K = N (a trajectory: the sums from the
    leaves to the root with the lever arms of every point) or 1 (one configuration: one product
    with :func:`centre_map`)."""
    count, ids = len(wrenches), maps.joint_ids
    if rotations.shape[0] == 1:
        return wrenches.reshape(count, -1) @ centre_map(maps, rotations[0], translations[0])
    # from the leaves to the root, each body's subtree wrench about its own origin: its own plus
    # each child's, moved by the lever d = t_child - t_body (a position difference) [m]
    total = wrenches.copy()  # (N, bodies, 6)
    for body in range(total.shape[1] - 1, 0, -1):
        parent = maps.parents[body]
        if parent > 0:
            force = total[:, body, :3]
            lever = translations[:, body] - translations[:, parent]
            total[:, parent, :3] += force
            total[:, parent, 3:] += total[:, body, 3:] + np.cross(lever, force)
    carried = total[:, ids].reshape(count, len(ids), 2, 3)  # about each joint's centre
    # R_c^T v = C^T (R^T v): R^T v as row vectors times R, then each joint's constant C
    turned = carried @ rotations[:, ids]  # (N, J, 2, 3)
    local = np.empty((count, len(ids), 2, 3))
    for k in range(len(ids)):
        local[:, k] = (turned[:, k].reshape(-1, 3) @ maps.rotations[k]).reshape(count, 2, 3)
    return -(local.reshape(count, -1) @ maps.selection)


@dataclass(frozen=True)
class Objectives:
    """The reduced objectives of N loads (:meth:`.prepared.PreparedGeometry.objectives`).

    Attributes:
        objectives: f (N, r); sigmas: sigma (N,) [J]; gradients: g (N, n) [J per unit];
        load_sizes: (N,) [J]; shares: the load's share along unblocked motions (N,);
        regular: (N,) False where the load works on an unblocked motion or on none (those go to
        a single solve, which raises or reports them).
    """

    objectives: Array
    sigmas: Array
    gradients: Array
    load_sizes: Array
    shares: Array
    regular: Mask


def objectives_of(
    prepared: PreparedGeometry, gradients: Array, wrenches: Array, moments: Array
) -> Objectives:
    """The objective terms of N loads from their gradients g (N, n), body wrenches
    (N, bodies, 6) and the bodies' moments about the world origin (N, bodies, 3)
    (:func:`.load_table.body_wrenches`), as :meth:`.prepared.PreparedGeometry.objectives` forms
    them (the scaled gradient Z g, its reduced part Q^T Z g and its part along the free motions
    K^T Z g; the load sizes from the forces and the moments about the world origin)."""
    geometry = prepared.geometry
    scaled = gradients * geometry.scale
    free = geometry.free_scaled
    # a tree without free motions keeps the identity as its basis (reduction.reduce_geometry)
    plain = not free.shape[1] and np.array_equal(geometry.basis, np.eye(scaled.shape[1]))
    reduced = scaled if plain else scaled @ geometry.basis
    along_free = scaled @ free
    force = wrenches[..., :3]
    forces = np.sqrt(np.einsum("nbk,nbk->nb", force, force))
    sizes = np.sqrt(np.einsum("nbk,nbk->nb", moments, moments))
    load_sizes = prepared.terms.play * (
        forces.sum(axis=1) + sizes.sum(axis=1) / max(prepared.length, 1e-300)
    )
    references = np.maximum(np.sqrt(np.einsum("ni,ni->n", scaled, scaled)), load_sizes)
    free_sizes = np.sqrt(np.einsum("ni,ni->n", along_free, along_free))
    sigmas = np.sqrt(np.einsum("ni,ni->n", reduced, reduced))
    regular = (free_sizes <= UNBOUNDED_FRACTION * references) & (
        sigmas > ROUND_OFF_WORK * references
    )
    return Objectives(
        objectives=reduced / np.where(sigmas > 0.0, sigmas, 1.0)[:, None],
        sigmas=sigmas,
        gradients=gradients,
        load_sizes=load_sizes,
        shares=free_sizes / np.where(references > 0.0, references, 1.0),
        regular=regular,
    )


__all__ = [
    "Objectives",
    "TreeMaps",
    "centre_map",
    "objectives_of",
    "tree_gradients",
    "tree_maps",
]
