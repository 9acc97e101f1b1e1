r"""Small-displacement maps of a mechanism at a nominal configuration (Pinocchio numbers).

Unknowns: for every tree joint k, the coordinates :math:`t_k` of its torsor in a basis
:math:`B_k` (6 x n_k) of the components that may move (free or bounded by play; rigid ones and
those a drive locks are left out), :math:`T_k = B_k t_k`. Stacked: :math:`x = (t_1, ..., t_m)`.

Spatial twists (at the world origin, world axes, Pinocchio's (v, omega) order) add along the tree:

.. math::  \xi_i = \sum_{k \in \mathrm{support}(i)} \mathrm{Ad}(oM_k\, jM_{c,k})\, B_k\, t_k

which is how a Pinocchio joint Jacobian is built, with the 6-D clearance torsor in place of the
joint's motion subspace. A loop joint between frames a and b has the torsor
:math:`T = \mathrm{Ad}(oM_a\, aM_c)^{-1} (\xi_b - \xi_a)` at its centre, in its clearance frame:
the difference of the two parts' twists transported to the joint centre (docs/method.md section 2,
closure holds by construction). The point P of body i moves by :math:`v_i + \omega_i \times p`.

A joint with stiffness (:mod:`clearance_pin.model.stiffness`) adds elastic unknowns :math:`e_k`
in series with its play: its relative motion is :math:`B_k t_k + D_k e_k` (D_k: the directions
of :math:`K_k` that deflect, orthonormal, with stiffnesses :math:`k_i`) and its contacts read the
play part alone, :math:`B_k t_k` for a tree joint, the relative motion minus :math:`D_k e_k` for
a loop joint. The elastic energy is :math:`\tfrac12 \sum_i k_i x_i^2` over the elastic unknowns
(``SmallDisplacementMaps.stiffness``).

A follower of a driven leader (:mod:`clearance_pin.model.couplings`) moves m times its leader's
whole motion about (along) its axis besides its own: :math:`T_f = B_f t_f + D_f e_f +
m\, a_f\, (a_l \cdot T_l)`, :math:`a` the motion component; its contacts read its own play.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin

from ..model.couplings import Coupling, coupled_motions
from ..model.joints import LoopJoint, TreeJoint
from ..model.stiffness import elastic, elastic_at
from ..numerics import null_space


@dataclass(frozen=True)
class SmallDisplacementMaps:
    """Linear maps of the mechanism at one configuration.

    Attributes:
        body_twist: per Pinocchio joint index i, the map x -> spatial twist of body i, (6, n).
        joint_torsor: per joint name (tree and loop), the map x -> torsor in its clearance frame, (6, n).
        joint_centre: per joint name, the clearance frame placement oM_c in the world (pin.SE3).
        variable_joint: per variable, the name of the tree joint it belongs to.
        variable_basis: per variable, its basis vector in that joint's torsor, (6,).
        eccentricity: per loop joint, its child clearance frame in its parent one at this
            configuration (identity when aligned; a misaligned housing otherwise).
        play_torsor: per joint name, the map x -> its play torsor, what its contacts read
            (``joint_torsor`` less the elastic deflection; the same array without stiffness).
        stiffness: per variable, its stiffness k_i [N/m or N m/rad] (0: a play or free unknown),
            (n,); the elastic energy is 1/2 sum_i k_i x_i^2.
    """

    body_twist: list[np.ndarray]
    joint_torsor: dict[str, np.ndarray]
    joint_centre: dict[str, pin.SE3]
    variable_joint: tuple[str, ...]
    variable_basis: tuple[np.ndarray, ...]
    eccentricity: dict[str, pin.SE3]
    play_torsor: dict[str, np.ndarray]
    stiffness: np.ndarray

    @property
    def elastic(self) -> bool:
        """Whether any joint deflects elastically (some k_i > 0)."""
        return bool(self.stiffness.any())

    @property
    def size(self) -> int:
        """Number of unknowns n."""
        return len(self.variable_joint)


def tree_joint_basis(joint: TreeJoint) -> np.ndarray:
    """Basis (6, n_k) of the torsor components of a tree joint that may move (memoised on the
    joint, which is immutable).

    Components are removed when rigid, locked by the drive, or held by a contact point with zero
    clearance (the rows of that contact point vanish on the basis).
    """
    cached = joint.__dict__.get("_basis")
    if cached is None:
        cached = _basis(joint)
        cached.setflags(write=False)
        object.__setattr__(joint, "_basis", cached)  # frozen dataclass: a derived, private cache
    return cached


def _basis(joint: TreeJoint) -> np.ndarray:
    clearance = joint.clearance
    fixed_rows = [np.eye(6)[c] for c in clearance.rigid_components + joint.locked_components]
    for contact in clearance.contacts:
        if contact.bound == 0.0:
            fixed_rows.extend(contact.linear_rows())
    if not fixed_rows:
        return np.eye(6)
    basis = null_space(np.array(fixed_rows))
    return _align_to_axes(basis)


def build_maps(
    model: pin.Model,
    data: Any,
    tree_joints: tuple[TreeJoint, ...],
    loop_joints: tuple[LoopJoint, ...],
    configuration: Any = None,
    couplings: tuple[Coupling, ...] = (),
) -> SmallDisplacementMaps:
    """Build the maps at the configuration already placed in ``data`` (oMi and oMf up to date:
    a ``pin.Data``, or a :class:`~clearance_pin.mechanism.Configuration`).

    ``configuration``: the :class:`~clearance_pin.mechanism.Configuration` placed in ``data``:
    a loop joint's torsor is taken at its child-side clearance frame (``bMc``, where the journal,
    block or ball is) and its contacts start from its eccentricity; default: at ``frame_a``,
    aligned. ``couplings``: those of driven leaders, in order (:func:`~..model.couplings.driven`):
    a follower's joint torsor gains m times its leader's whole motion along its own motion
    (its play torsor, which its contacts read, does not).
    """
    variable_joint: list[str] = []
    variable_basis: list[np.ndarray] = []
    stiffness: list[float] = []
    columns_of: dict[int, tuple[int, int]] = {}
    bases: dict[int, np.ndarray] = {}
    plays: dict[
        int, int
    ] = {}  # per tree joint: how many of its columns are play (the rest deflect)
    loop_columns: dict[str, tuple[int, np.ndarray]] = {}  # loop joint -> (first column, D)

    def add_columns(name: str, basis: np.ndarray, values: Any) -> int:
        start = len(variable_joint)
        variable_joint.extend([name] * basis.shape[1])
        variable_basis.extend(basis.T)
        stiffness.extend(values)
        return start

    for joint in tree_joints:
        basis = tree_joint_basis(joint)
        deflections, values = elastic_at(joint, model, data.oMi)  # K in its frame at q
        start = add_columns(joint.name, basis, np.zeros(basis.shape[1]))
        add_columns(joint.name, deflections, values)
        columns_of[joint.joint_id] = (start, len(variable_joint))
        bases[joint.joint_id] = np.hstack([basis, deflections])
        plays[joint.joint_id] = basis.shape[1]
    for loop in loop_joints:
        deflections, values = elastic(loop.clearance)
        if values.size:
            loop_columns[loop.name] = (add_columns(loop.name, deflections, values), deflections)
    n = len(variable_joint)

    body_twist = [np.zeros((6, n)) for _ in range(model.njoints)]
    joint_torsor: dict[str, np.ndarray] = {}
    play_torsor: dict[str, np.ndarray] = {}
    joint_centre: dict[str, pin.SE3] = {}
    eccentricity: dict[str, pin.SE3] = {}
    for joint in tree_joints:
        start, stop = columns_of[joint.joint_id]
        torsor = np.zeros((6, n))
        torsor[:, start:stop] = bases[joint.joint_id]
        joint_torsor[joint.name] = torsor
        if stop - start > plays[joint.joint_id]:
            play = torsor.copy()
            play[:, start + plays[joint.joint_id] : stop] = 0.0
            play_torsor[joint.name] = play
    if couplings:  # a follower moves with its leader's whole motion (model.couplings)
        by_name = {joint.name: joint for joint in tree_joints}
        for name, torsor in coupled_motions(joint_torsor, couplings, by_name).items():
            play_torsor.setdefault(name, joint_torsor[name])  # its contacts read its own play
            joint_torsor[name] = torsor
    by_id = {joint.joint_id: joint for joint in tree_joints}
    for i in range(1, model.njoints):
        joint = by_id[i]
        oMc = data.oMi[i] * pin.SE3(joint.rotation, np.zeros(3))
        body_twist[i] = body_twist[model.parents[i]] + oMc.action @ joint_torsor[joint.name]
        joint_centre[joint.name] = oMc

    for loop in loop_joints:
        frame_a, frame_b = model.frames[loop.frame_a], model.frames[loop.frame_b]
        if configuration is None:
            oMc = data.oMf[loop.frame_a] * pin.SE3(loop.rotation, np.zeros(3))
            offset = pin.SE3.Identity()
        else:
            # at the child's clearance frame: the contact points are on the child, where it is
            # (a spin of a journal about its own axis must not read as a translation at a
            # misaligned housing's centre)
            oMc = data.oMf[loop.frame_b] * configuration.bMc[loop.name]
            offset = configuration.eccentricity(loop)
        relative = body_twist[frame_b.parentJoint] - body_twist[frame_a.parentJoint]
        joint_torsor[loop.name] = oMc.inverse().action @ relative
        joint_centre[loop.name] = oMc
        eccentricity[loop.name] = offset
        if loop.name in loop_columns:
            first, deflections = loop_columns[loop.name]
            play = joint_torsor[loop.name].copy()
            play[:, first : first + deflections.shape[1]] -= deflections
            play_torsor[loop.name] = play
    return SmallDisplacementMaps(
        body_twist,
        joint_torsor,
        joint_centre,
        tuple(variable_joint),
        tuple(variable_basis),
        eccentricity,
        {name: play_torsor.get(name, torsor) for name, torsor in joint_torsor.items()},
        np.array(stiffness, dtype=float),
    )


def _align_to_axes(basis: np.ndarray) -> np.ndarray:
    """Replace a basis by coordinate vectors when it spans coordinate axes (the usual case)."""
    support = np.flatnonzero(np.linalg.norm(basis, axis=1) > 1e-12)
    if support.size == basis.shape[1]:
        return np.eye(6)[:, support]
    return basis
