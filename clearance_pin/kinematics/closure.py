r"""Close the loops of a mechanism at its nominal configuration (position analysis).

Given the driven joints' values, find the passive joints' values such that every loop joint's
two frames coincide in all the components that the joint constrains (everything but its free
motions). The unknowns are the *passive motions* (:func:`passive_motions`): the free components
of every tree joint that carries a loop frame, minus those its drive locks (a revolute joint's
spin, a prismatic joint's slide, the three rotations of a URDF floating joint carrying a
``spherical`` kind, ...), as columns :math:`B` of Pinocchio's velocity space. Gauss-Newton with
Pinocchio frame Jacobians (spatial, ``pin.WORLD``):

.. math::  A = W\,[\mathrm{Ad}(oM_c)^{-1} (J_b - J_a)]_{rows}\, B D, \qquad
           \delta s = -A^+ W r(q) + N y, \qquad q \leftarrow q \oplus B D\, \delta s

with r the constrained components of the relative placement of the loop frames (translations
[m] and rotation-vector components [rad]), W the row weights (1 on translations, the length
scale L on rotations), D the unknowns' scales (1 on rotations, L on translations) and the
pseudo-inverse giving least-squares, minimum-norm steps. :math:`N` spans the null space of
:math:`A`: the *idle* motions that no loop sees (the spin of an RSSR coupler about the line of
its two ball centres). They are held nearest to a reference configuration (the nominal one):
:math:`y = \arg\min_y \| S\,(q_{ref} \ominus (q \oplus B D (\delta s)))\|` to first order
(S: 1/L on translations), so that a closed configuration depends on the driven values and the
assembly branch only, not on the path that led there.

The iteration stops at a stationary point. A residual left there that is not zero is a nominal
eccentricity (a misaligned housing): accepted when
:func:`~clearance_pin.kinematics.loop_frames.eccentricity_problems` finds it inside the play,
refused otherwise.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, TypeAlias

import numpy as np
import pinocchio as pin

from ..errors import ArgumentError, ModelError
from ..model.clearance import ALPHA, U
from ..model.joints import LoopJoint

if TYPE_CHECKING:
    from ..model.mechanism_parts import MechanismParts as Mechanism

#: per loop joint of a residual: the joint, its constrained torsor components, its clearance
#: frame in the world (:func:`closure_residual`)
Selection: TypeAlias = tuple[LoopJoint, list[int], pin.SE3]

#: singular values of the scaled closure Jacobian below this fraction of the largest are idle
IDLE_TOLERANCE = 1e-12
#: a Gauss-Newton step (scaled: [rad], [m / length scale]) below this is stationary
STATIONARY_STEP = 1e-13
#: a residual whose part in the range of the closure Jacobian is below this fraction of its norm
#: is stationary (least-squares optimality); what is left is an eccentricity to judge
STATIONARY_ANGLE = 1e-7


@dataclass(frozen=True)
class PassiveMotion:
    """One passive direction of a tree joint: an elementary motion of its child in its frame.

    Attributes:
        joint_id: Pinocchio joint id.
        component: the clearance-torsor component it is (``U`` .. ``GAMMA``).
        kind: ``"revolute"`` (rotation about ``axis`` through the joint origin) or
            ``"prismatic"`` (translation along ``axis``).
        axis: unit axis in the Pinocchio joint frame, (3,).
        column: the motion as a vector of Pinocchio's velocity space, (nv,) [rad or m per unit].
    """

    joint_id: int
    component: int
    kind: str
    axis: tuple[float, float, float]
    column: np.ndarray


def passive_motions(mechanism: Mechanism, in_loops_only: bool = True) -> tuple[PassiveMotion, ...]:
    """The passive motions of the tree joints (the unknowns of the loop closure).

    A 1-DOF joint contributes its own motion unless driven. A URDF floating joint contributes
    the free components of its clearance kind (spherical: the three rotations about the joint
    centre; cylindrical: the slide and the spin along its axis; free: all six), mapped through
    its clearance frame (``TreeJoint.rotation``): Pinocchio's free-flyer velocity is
    (v, omega) in the joint frame, so a rotation about the clearance axis k is
    ``omega = R e_k`` and a slide along it ``v = R e_k``. Components bounded by play are never
    passive: the nominal sits at the centre of the play.

    Args:
        mechanism: :class:`~clearance_pin.mechanism.Mechanism`.
        in_loops_only: only the joints on the path to a loop frame (the others keep their
            values whatever the closure does).
    """
    model = mechanism.model
    supporting = _loop_supports(mechanism) if in_loops_only else None
    motions: list[PassiveMotion] = []
    for joint in mechanism.tree_joints:
        if supporting is not None and joint.joint_id not in supporting:
            continue
        pin_joint = model.joints[joint.joint_id]
        free = set(joint.clearance.free_components) - set(joint.locked_components)
        if pin_joint.nv == 1:
            if joint.driven or joint.motion_component not in free:
                continue
            column = np.zeros(model.nv)
            column[pin_joint.idx_v] = 1.0
            kind = "prismatic" if joint.motion_component == U else "revolute"
            axis = _triple(joint.rotation[:, 0])
            motions.append(
                PassiveMotion(joint.joint_id, joint.motion_component, kind, axis, column)
            )
            continue
        if pin_joint.nv != 6:  # only free-flyers (URDF floating joints) have several motions
            continue
        for component in sorted(free):
            direction = np.asarray(joint.rotation[:, component % 3], dtype=float)
            column = np.zeros(model.nv)
            start = pin_joint.idx_v + (0 if component < ALPHA else 3)
            column[start : start + 3] = direction
            kind = "prismatic" if component < ALPHA else "revolute"
            motions.append(
                PassiveMotion(joint.joint_id, component, kind, _triple(direction), column)
            )
    return tuple(motions)


def _triple(vector: np.ndarray) -> tuple[float, float, float]:
    return (float(vector[0]), float(vector[1]), float(vector[2]))


def passive_basis(
    mechanism: Mechanism, motions: Sequence[PassiveMotion] | None = None
) -> np.ndarray:
    """The passive motions as columns of Pinocchio's velocity space, shape (nv, n_passive)."""
    motions = passive_motions(mechanism) if motions is None else motions
    if not motions:
        return np.zeros((mechanism.model.nv, 0))
    return np.column_stack([m.column for m in motions])


def passive_velocity_indices(mechanism: Mechanism) -> list[int]:
    """Velocity indices of the 1-DOF tree joints that are neither driven nor locked by play
    (the 1-DOF passive joints; :func:`passive_motions` gives all the passive motions)."""
    model = mechanism.model
    indices: list[int] = []
    for joint in mechanism.tree_joints:
        pin_joint = model.joints[joint.joint_id]
        if joint.driven or joint.motion_component is None or pin_joint.nv != 1:
            continue
        indices.append(pin_joint.idx_v)
    return indices


def _loop_supports(mechanism: Mechanism) -> set[int]:
    """Ids of the joints on the paths from the root to every loop frame."""
    model = mechanism.model
    supporting: set[int] = set()
    for loop in mechanism.loop_joints:
        for frame in (loop.frame_a, loop.frame_b):
            supporting.update(int(j) for j in model.supports[model.frames[frame].parentJoint])
    supporting.discard(0)
    return supporting


def closure_residual(mechanism: Mechanism, data: pin.Data) -> tuple[np.ndarray, list[Selection]]:
    """Constrained components of every loop's frame mismatch, and their selection rows."""
    values: list[np.ndarray] = []
    selections: list[Selection] = []
    for loop in mechanism.loop_joints:
        rotation = pin.SE3(loop.rotation, np.zeros(3))
        oMc = data.oMf[loop.frame_a] * rotation
        oMb = data.oMf[loop.frame_b] * rotation
        relative = oMc.inverse() * oMb
        error = np.concatenate([relative.translation, pin.log3(relative.rotation)])
        free = set(loop.clearance.free_components)
        rows = [c for c in range(6) if c not in free]
        if ALPHA in free:
            # only the axis must line up: a free spin leaves the x-rotation component open
            error[3:] = np.concatenate([[0.0], _axis_error(relative.rotation)])
        values.append(error[rows])
        selections.append((loop, rows, oMc))
    return (np.concatenate(values) if values else np.zeros(0)), selections


def _axis_error(rotation: np.ndarray) -> np.ndarray:
    """Rotation (about y, z) [rad] that takes the moved x axis back onto x."""
    moved = rotation[:, 0]
    return np.array([-np.arctan2(moved[2], moved[0]), np.arctan2(moved[1], moved[0])])


def closure_jacobian(
    mechanism: Mechanism, data: pin.Data, selections: Sequence[Selection], basis: np.ndarray
) -> np.ndarray:
    r"""Derivative of the residual rows by the passive motions, :math:`[\mathrm{Ad}(oM_c)^{-1}
    (J_b - J_a)]_{rows} B`, shape (n_rows, n_passive) [m or rad per unit motion] (first order,
    as the Gauss-Newton step needs); needs ``pin.computeJointJacobians`` in ``data``."""
    model = mechanism.model
    blocks = []
    for loop, rows, oMc in selections:
        # (6, nv) also when nv = 1 (the binding returns a vector then)
        j_a = pin.getFrameJacobian(model, data, loop.frame_a, pin.WORLD).reshape(6, model.nv)
        j_b = pin.getFrameJacobian(model, data, loop.frame_b, pin.WORLD).reshape(6, model.nv)
        blocks.append((oMc.inverse().action @ (j_b - j_a))[rows] @ basis)
    return np.vstack(blocks) if blocks else np.zeros((0, basis.shape[1]))


def idle_motion_count(mechanism: Mechanism) -> int:
    """Number of idle passive motions (seen by no loop), counted at the nominal configuration:
    the structural null space of the closure Jacobian (a rod between two ball joints spins
    freely). A configuration whose closure Jacobian loses more rank than this is singular."""
    owner = (mechanism.model, mechanism.tree_joints, mechanism.loop_joints)
    cached: tuple[tuple[object, ...], int] | None = mechanism.cache.idle_motions
    if cached is not None and all(a is b for a, b in zip(cached[0], owner)):
        return cached[1]
    data = mechanism.cache.data  # this thread's: no second Pinocchio data (cubic in nv)
    motions = passive_motions(mechanism)
    length = max(mechanism.length_scale(), 1e-300)
    jacobian, _ = _scaled_jacobian(mechanism, data, mechanism.q_nominal, motions, length)
    count = int(_gauss_newton_step(jacobian, np.zeros(jacobian.shape[0]))[1].shape[1])
    # kept with what the mechanism's solves build (its cache), for the joints it was counted on
    mechanism.cache.idle_motions = (owner, count)
    return count


def _scaled_jacobian(
    mechanism: Mechanism,
    data: pin.Data,
    q: np.ndarray,
    motions: Sequence[PassiveMotion],
    length: float,
) -> tuple[np.ndarray, np.ndarray]:
    """The dimensionless closure Jacobian A (rows weighted, unknowns scaled, divided by L) and
    the dimensionless residual at ``q``; needs nothing in ``data``."""
    model = mechanism.model
    pin.framesForwardKinematics(model, data, q)
    pin.computeJointJacobians(model, data, q)
    residual, selections = closure_residual(mechanism, data)
    basis = _scaled_basis(mechanism, motions, length)
    if not selections:
        return np.zeros((0, basis.shape[1])), residual
    weights = np.concatenate([_weights(rows, length) for _, rows, _ in selections]) / length
    jacobian = closure_jacobian(mechanism, data, selections, basis) * weights[:, None]
    return jacobian, residual * weights


def _scaled_basis(
    mechanism: Mechanism, motions: Sequence[PassiveMotion], length: float
) -> np.ndarray:
    """B D: the passive motions per unit scaled unknown ([rad], or [L] for translations)."""
    basis = passive_basis(mechanism, motions)
    scaled: np.ndarray = basis * np.array(
        [length if m.kind == "prismatic" else 1.0 for m in motions]
    )
    return scaled


def _velocity_scales(mechanism: Mechanism, length: float) -> np.ndarray:
    """Per velocity index: 1 / L for translations, 1 for rotations (dimensionless distances)."""
    model = mechanism.model
    scales = np.ones(model.nv)
    for joint in mechanism.tree_joints:
        pin_joint = model.joints[joint.joint_id]
        if pin_joint.nv == 6:
            scales[pin_joint.idx_v : pin_joint.idx_v + 3] = 1.0 / length
        elif pin_joint.nv == 1 and joint.motion_component == U:
            scales[pin_joint.idx_v] = 1.0 / length
    return scales


def close_loops(
    mechanism: Mechanism,
    q: np.ndarray,
    tol: float = 1e-15,
    max_iterations: int = 60,
    reference: np.ndarray | None = None,
) -> np.ndarray:
    """Solve the passive motions so that every loop closes; returns the closed configuration.

    Iterates to a stationary point of the least-squares residual: the residual below ``tol``
    times the length scale (or its part that the passive motions can remove vanishing), with a
    step below round-off or no longer halving, so that a closed configuration is exact to
    round-off. Idle motions (seen by no loop) are held nearest to ``reference``.

    Args:
        mechanism: :class:`~clearance_pin.mechanism.Mechanism`.
        q: start configuration (nq,); the driven joints keep their values.
        tol: closure tolerance, a fraction of the length scale.
        max_iterations: Gauss-Newton iterations.
        reference: configuration (nq,) the idle motions stay nearest to (default: the
            mechanism's nominal configuration).

    Raises:
        ModelError: the loops cannot be closed: the residual left at the stationary point is
            not an admissible eccentricity (outside the play, or in a rigid direction), or the
            iteration did not settle.
    """
    model = mechanism.model
    data = mechanism.cache.data  # this thread's (its caller places it again after the walk)
    motions = passive_motions(mechanism)
    length = max(mechanism.length_scale(), 1e-300)
    scaled_basis = _scaled_basis(mechanism, motions, length)
    velocity_scale = _velocity_scales(mechanism, length)
    reference = mechanism.q_nominal if reference is None else np.asarray(reference, float)
    q = np.array(q, dtype=float)
    residual_norm, previous, stalled, stationary = np.inf, np.inf, 0, not motions
    for _ in range(max_iterations):
        jacobian, scaled = _scaled_jacobian(mechanism, data, q, motions, length)
        residual_norm = float(np.max(np.abs(scaled), initial=0.0)) * length
        if not motions or not scaled.size:
            stationary = True
            break
        step, idle, in_range = _gauss_newton_step(jacobian, scaled)
        gauge = np.zeros_like(step)
        if idle.shape[1]:
            gauge = idle @ _idle_correction(
                model, reference, q, scaled_basis, velocity_scale, step, idle
            )
        closed = residual_norm <= tol * max(length, 1.0)
        stationary = closed or bool(in_range <= STATIONARY_ANGLE * np.linalg.norm(scaled))
        # closed: only the idle motions may still move; else the least-squares step must vanish
        size = float(np.max(np.abs(gauge if closed else step + gauge), initial=0.0))
        if stationary and size <= STATIONARY_STEP:
            break
        stalled = stalled + 1 if size > 0.5 * previous else 0
        if stalled >= 3:  # the round-off floor
            break
        previous = size
        q = pin.integrate(model, q, scaled_basis @ (step + gauge))
    if residual_norm > 1e-9 * max(length, 1.0):
        pin.framesForwardKinematics(model, data, q)
        _refuse_or_accept(mechanism, data, residual_norm, stationary)
    return q


def _gauss_newton_step(
    jacobian: np.ndarray, residual: np.ndarray
) -> tuple[np.ndarray, np.ndarray, float]:
    """Least-squares minimum-norm step ``-A^+ r``, the idle basis N (null space of A, columns)
    and the norm of the residual's part in the range of A (zero at a stationary point)."""
    n = jacobian.shape[1]
    if jacobian.shape[0] == 0:
        return np.zeros(n), np.eye(n), 0.0
    u, s, vt = np.linalg.svd(jacobian, full_matrices=True)
    rank = int(np.sum(s > IDLE_TOLERANCE * s[0])) if s.size and s[0] > 0.0 else 0
    projected = u[:, :rank].T @ residual
    step = -vt[:rank].T @ (projected / s[:rank])
    return step, vt[rank:].T, float(np.linalg.norm(projected))


def _idle_correction(
    model: pin.Model,
    reference: np.ndarray,
    q: np.ndarray,
    scaled_basis: np.ndarray,
    velocity_scale: np.ndarray,
    step: np.ndarray,
    idle: np.ndarray,
) -> np.ndarray:
    r"""Idle coordinates y minimising :math:`\|S (q_{ref} \ominus (q \oplus B D (s + N y)))\|`
    to first order (``pin.dDifference``), so that idle motions stay nearest the reference."""
    gap = velocity_scale * pin.difference(model, reference, q)
    derivative = pin.dDifference(model, reference, q, pin.ArgumentPosition.ARG1)
    g = velocity_scale[:, None] * (derivative @ scaled_basis)
    correction: np.ndarray = np.linalg.lstsq(g @ idle, -(gap + g @ step), rcond=None)[0]
    return correction


def _refuse_or_accept(
    mechanism: Mechanism, data: pin.Data, residual_norm: float, stationary: bool
) -> None:
    """Accept a residual left at a stationary point when it is an admissible eccentricity
    (inside the play); raise ModelError naming the loop otherwise."""
    residual, selections = closure_residual(mechanism, data)
    worst = max(
        zip(selections, _split(residual, selections)),
        key=lambda item: float(np.max(np.abs(item[1]), initial=0.0)),
    )[0][0]
    if not stationary:
        raise ModelError(
            mechanism.source,
            f"<loop_joint name='{worst.name}'>",
            f"the loops cannot be closed at this configuration (residual "
            f"{residual_norm:.3e} m, Gauss-Newton on the passive joints did not settle); check "
            "the driven values and the link lengths",
        )
    from .loop_frames import eccentricity_problems

    problems = eccentricity_problems(mechanism, data.oMf)
    if not problems:
        return  # a nominal eccentricity inside the play (a misaligned housing)
    named = [loop for loop in mechanism.loop_joints if f"{loop.name!r}" in problems[0]]
    loop = named[0] if named else worst
    raise ModelError(
        mechanism.source,
        f"<loop_joint name='{loop.name}'>",
        f"the loops cannot be closed at this configuration (residual {residual_norm:.3e} m at "
        f"the least-squares point of the passive joints): {problems[0]}; check the driven "
        "values and the link lengths",
    )


def _split(residual: np.ndarray, selections: Sequence[Selection]) -> list[np.ndarray]:
    """The residual cut into one piece per loop joint."""
    pieces: list[np.ndarray] = []
    start = 0
    for _, rows, _ in selections:
        pieces.append(residual[start : start + len(rows)])
        start += len(rows)
    return pieces


def _weights(rows: list[int], length: float) -> np.ndarray:
    return np.array([1.0 if c < ALPHA else length for c in rows])


def follow_branch(
    mechanism: Mechanism, start: np.ndarray, target: np.ndarray, step: float = 0.05
) -> np.ndarray:
    """Close the loops at ``target``'s driven values by continuation from the closed ``start``.

    The driven joints move from their values in ``start`` to those in ``target`` in equal steps of
    at most ``step`` [rad, or that fraction of the length scale for prismatic joints]; each step is
    closed from the previous one, so the passive joints stay on ``start``'s assembly branch (a
    direct Gauss-Newton from far away may land on the other branch of a four-bar or a
    slider-crank). Idle motions are held nearest the nominal configuration at every step.

    A revolute driven joint walks the shorter way round: to the value of ``target`` minus a whole
    number of turns nearest its start (the same pose), the last step closing at ``target``'s own
    value (q = 1e6 rad walked 2e7 steps before, for hours). A walk of more than
    :data:`MOST_WALK_STEPS` steps (a prismatic drive 100 length scales away) is refused.

    Raises:
        ArgumentError: a driven value farther than :data:`MOST_WALK_STEPS` steps, naming the joint.
    """
    driven, scales = driven_coordinates(mechanism)
    if not driven:
        return close_loops(mechanism, target)
    goal = target[driven].astype(float)
    revolute = _revolute_coordinates(mechanism)
    for position, index in enumerate(driven):
        if index in revolute:
            goal[position] = start[index] + math.remainder(
                target[index] - start[index], 2 * math.pi
            )
    distances = np.abs(goal - start[driven]) / scales
    span = float(np.max(distances, initial=0.0))
    count = max(1, int(np.ceil(span / step)))
    if count > MOST_WALK_STEPS:
        far = driven[int(np.argmax(distances))]
        model = mechanism.model
        name = next(
            str(model.names[j])
            for j in range(1, model.njoints)
            if far - model.idx_qs[j] in range(model.nqs[j])
        )
        raise ArgumentError(
            "q",
            f"driven values within {MOST_WALK_STEPS * step:g} length scales "
            f"({MOST_WALK_STEPS * step * mechanism.length_scale():.6g} m) of a closed "
            "configuration (the loops are closed by continuation from there)",
            float(target[far]),
            f"joint {name!r} is {float(np.max(distances)):.3g} length scales away",
        )
    q = start.copy()
    for k in range(1, count + 1):
        q = q.copy()
        if k < count:
            q[driven] = start[driven] + (goal - start[driven]) * (k / count)
        else:  # target's own values: whole turns apart from goal, closed without round-off
            q[driven] = target[driven]
        q = close_loops(mechanism, q)
    return q


#: the most steps :func:`follow_branch` walks (100 rad, or 100 length scales, at 0.05 a step)
MOST_WALK_STEPS = 2000


def _revolute_coordinates(mechanism: Mechanism) -> set[int]:
    """Configuration indices of the driven revolute joints' angles (one value each, 2 pi
    periodic; a continuous joint's (cos, sin) pair is not one)."""
    model = mechanism.model
    return {
        int(model.joints[joint.joint_id].idx_q)
        for joint in mechanism.tree_joints
        if joint.driven and joint.motion_component == ALPHA and model.joints[joint.joint_id].nq == 1
    }


def driven_coordinates(mechanism: Mechanism) -> tuple[list[int], np.ndarray]:
    """Configuration indices of the driven joints' values, and their step scales (1 [rad] for
    revolute joints, the mechanism's length scale [m] for prismatic ones)."""
    indices: list[int] = []
    scales: list[float] = []
    for joint in mechanism.tree_joints:
        if not joint.driven:
            continue
        pin_joint = mechanism.model.joints[joint.joint_id]
        scale = mechanism.length_scale() if joint.motion_component == 0 else 1.0
        for index in range(pin_joint.idx_q, pin_joint.idx_q + pin_joint.nq):
            indices.append(index)
            scales.append(scale)
    return indices, np.array(scales)
