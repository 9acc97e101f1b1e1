r"""The configuration-dependent part of a tree's equilibrium for many configurations at once.

A mechanism without loop joints has one reduced geometry for all its configurations
(:func:`.prepared._reduced`): only the load's gradient :math:`g` changes along a trajectory. With
the body placements :math:`(R_b, t_b)` of every point (Pinocchio's forward kinematics, per point)
and the body wrenches :math:`W_b` at the world origin (:mod:`.load_table`), the gradient on the
unknowns of tree joint k is minus the wrench of everything the joint carries, at its centre, in
its clearance frame :math:`(R_c, p_c) = (R_k C_k, t_k)` (docs/method.md 2.1:
:math:`g = -\sum_b J_b^T W_b` with :math:`J_b = \sum_{k \in support(b)} Ad(oM_k C_k) B_k`):

.. math::  \bar W_k = \sum_{b \in subtree(k)} W_b = (\bar F, \bar M), \qquad
           g_k = -B_k^T \begin{pmatrix} R_c^T \bar F \\ R_c^T (\bar M - p_c \times \bar F) \end{pmatrix}
           \quad [J\ per\ unit\ of\ t_k],

for every point at once (arrays (N, ...)): no maps, reductions or SVDs per point. The objective
terms follow as :meth:`.prepared.PreparedGeometry.objectives` forms them.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .blocks import Array, Index, Mask
from .reduction import ROUND_OFF_WORK, UNBOUNDED_FRACTION
from .small_displacement import tree_joint_basis

if TYPE_CHECKING:
    from ..mechanism import Mechanism
    from .prepared import PreparedGeometry


@dataclass(frozen=True)
class TreeMaps:
    """The configuration-independent terms of a tree's gradient.

    Attributes:
        joint_ids: Pinocchio index of every tree joint (in the unknowns' order), (J,).
        rotations: C_k, the clearance frame in each joint frame, (J, 3, 3).
        subtree: (bodies, bodies), 1.0 where body b is in the subtree of body i.
        selection: (6 J, n), the blocks B_k: g = -(local wrenches (N, 6 J)) @ selection.
    """

    joint_ids: Index
    rotations: Array
    subtree: Array
    selection: Array


def tree_maps(mechanism: Mechanism) -> TreeMaps:
    """The :class:`TreeMaps` of a mechanism without loop joints."""
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
    return TreeMaps(
        joint_ids=np.array([joint.joint_id for joint in joints], dtype=np.intp),
        rotations=np.array([joint.rotation for joint in joints]).reshape(-1, 3, 3),
        subtree=subtree,
        selection=selection,
    )


def tree_gradients(maps: TreeMaps, rotations: Array, translations: Array, wrenches: Array) -> Array:
    """The x-space gradients g (N, n) [J per unit] (module docstring) from the body placements
    and the body wrenches (N, bodies, 6) at the world origin."""
    count, ids = len(wrenches), maps.joint_ids
    carried = np.moveaxis(
        (maps.subtree @ np.moveaxis(wrenches, 1, 0).reshape(wrenches.shape[1], -1)).reshape(
            wrenches.shape[1], count, 6
        ),
        0,
        1,
    )[:, ids]  # (N, J, 6): the wrench each joint carries (its subtree's)
    force = carried[..., :3]
    moment = carried[..., 3:] - np.cross(translations[:, ids], force)
    # R_c^T v = C^T (R^T v): R^T v as row vectors times R, then each joint's constant C
    body = rotations[:, ids]
    turned = np.concatenate([force[..., None, :] @ body, moment[..., None, :] @ body], axis=2)
    local = np.empty((count, len(ids), 2, 3))
    for k in range(len(ids)):
        local[:, k] = (turned[:, k].reshape(-1, 3) @ maps.rotations[k]).reshape(count, 2, 3)
    return -(local.reshape(len(wrenches), -1) @ maps.selection)


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


def objectives_of(prepared: PreparedGeometry, gradients: Array, wrenches: Array) -> Objectives:
    """The objective terms of N loads from their gradients g (N, n) and body wrenches
    (N, bodies, 6), as :meth:`.prepared.PreparedGeometry.objectives` forms them (the scaled
    gradient Z g, its reduced part Q^T Z g and its part along the free motions K^T Z g)."""
    geometry = prepared.geometry
    scaled = gradients * geometry.scale
    free = geometry.free_scaled
    # a tree without free motions keeps the identity as its basis (reduction.reduce_geometry)
    plain = not free.shape[1] and np.array_equal(geometry.basis, np.eye(scaled.shape[1]))
    reduced = scaled if plain else scaled @ geometry.basis
    along_free = scaled @ free
    halves = wrenches.reshape(len(wrenches), -1, 2, 3)
    sizes = np.sqrt(np.einsum("nbhk,nbhk->nbh", halves, halves))  # |F_b|, |M_b|
    load_sizes = prepared.terms.play * (
        sizes[:, :, 0].sum(axis=1) + sizes[:, :, 1].sum(axis=1) / max(prepared.length, 1e-300)
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
    "objectives_of",
    "tree_gradients",
    "tree_maps",
]
