r"""Close the loops of a mechanism at its nominal configuration (position analysis).

Given the driven joints' values, find the passive joints' values such that every loop joint's
two frames coincide in all the components that the joint constrains (everything but its free
motions). Gauss-Newton with Pinocchio frame Jacobians (spatial, ``pin.WORLD``):

.. math::  \delta T = \mathrm{Ad}(oM_c)^{-1} (J_b - J_a)\, \delta v, \qquad
           q \leftarrow q \oplus \delta v, \quad \delta v = -(S \, \delta T / \delta v)^+ r(q)

with r the constrained components of the relative placement of the loop frames (translations
[m] and rotation-vector components [rad]) and the pseudo-inverse giving minimum-norm steps.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from ..errors import ModelError
from ..model.clearance import ALPHA


def passive_velocity_indices(mechanism) -> list[int]:
    """Velocity indices of the 1-DOF tree joints that are neither driven nor locked by play."""
    model = mechanism.model
    indices = []
    for joint in mechanism.tree_joints:
        pin_joint = model.joints[joint.joint_id]
        if joint.driven or joint.motion_component is None or pin_joint.nv != 1:
            continue
        indices.append(pin_joint.idx_v)
    return indices


def closure_residual(mechanism, data: pin.Data) -> tuple[np.ndarray, list]:
    """Constrained components of every loop's frame mismatch, and their selection rows."""
    values, selections = [], []
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


def close_loops(
    mechanism, q: np.ndarray, tol: float = 1e-15, max_iterations: int = 60
) -> np.ndarray:
    """Solve the passive joints so that every loop closes; returns the closed configuration.

    Iterates until the residual is below ``tol`` times the length scale or stops halving (the
    round-off floor), so that a closed configuration is exact to round-off.

    Raises:
        ModelError: the loops cannot be closed (the Gauss-Newton residual stalls above ``tol``
            times the mechanism's length scale).
    """
    model = mechanism.model
    data = model.createData()
    passive = passive_velocity_indices(mechanism)
    length = mechanism.length_scale()
    q = np.array(q, dtype=float)
    residual_norm = np.inf
    stalled = 0
    for _ in range(max_iterations):
        pin.framesForwardKinematics(model, data, q)
        residual, selections = closure_residual(mechanism, data)
        weights = (
            np.concatenate([_weights(rows, length) for _, rows, _ in selections])
            if selections
            else np.zeros(0)
        )
        previous, residual_norm = (
            residual_norm,
            float(np.max(np.abs(residual * weights), initial=0.0)),
        )
        stalled = stalled + 1 if residual_norm > 0.5 * previous else 0
        if residual_norm <= tol * max(length, 1.0) or not passive or stalled >= 3:
            break
        pin.computeJointJacobians(model, data, q)
        jacobian = []
        for loop, rows, oMc in selections:
            j_a = pin.getFrameJacobian(model, data, loop.frame_a, pin.WORLD)
            j_b = pin.getFrameJacobian(model, data, loop.frame_b, pin.WORLD)
            jacobian.append((oMc.inverse().action @ (j_b - j_a))[rows][:, passive])
        step = np.linalg.lstsq(np.vstack(jacobian), -residual, rcond=None)[0]
        v = np.zeros(model.nv)
        v[passive] = step
        q = pin.integrate(model, q, v)
    if residual_norm > 1e-9 * max(length, 1.0):
        worst = max(
            zip(selections, _split(residual, selections)),
            key=lambda item: float(np.max(np.abs(item[1]), initial=0.0)),
        )[0][0]
        raise ModelError(
            mechanism.source,
            f"<loop_joint name='{worst.name}'>",
            f"the loops cannot be closed at this configuration (residual "
            f"{residual_norm:.3e} m after Gauss-Newton on the passive joints); check "
            "the driven values and the link lengths",
        )
    return q


def _split(residual: np.ndarray, selections) -> list[np.ndarray]:
    """The residual cut into one piece per loop joint."""
    pieces, start = [], 0
    for _, rows, _ in selections:
        pieces.append(residual[start : start + len(rows)])
        start += len(rows)
    return pieces


def _weights(rows: list[int], length: float) -> np.ndarray:
    return np.array([1.0 if c < ALPHA else length for c in rows])


def follow_branch(
    mechanism, start: np.ndarray, target: np.ndarray, step: float = 0.05
) -> np.ndarray:
    """Close the loops at ``target``'s driven values by continuation from the closed ``start``.

    The driven joints move from their values in ``start`` to those in ``target`` in equal steps of
    at most ``step`` [rad, or that fraction of the length scale for prismatic joints]; each step is
    closed from the previous one, so the passive joints stay on ``start``'s assembly branch (a
    direct Gauss-Newton from far away may land on the other branch of a four-bar or a
    slider-crank).
    """
    driven, scales = driven_coordinates(mechanism)
    if not driven:
        return close_loops(mechanism, target)
    span = float(np.max(np.abs(target[driven] - start[driven]) / scales, initial=0.0))
    count = max(1, int(np.ceil(span / step)))
    q = start.copy()
    for k in range(1, count + 1):
        q = q.copy()
        q[driven] = start[driven] + (target[driven] - start[driven]) * (k / count)
        q = close_loops(mechanism, q)
    return q


def driven_coordinates(mechanism) -> tuple[list[int], np.ndarray]:
    """Configuration indices of the driven joints' values, and their step scales (1 [rad] for
    revolute joints, the mechanism's length scale [m] for prismatic ones)."""
    indices, scales = [], []
    for joint in mechanism.tree_joints:
        if not joint.driven:
            continue
        pin_joint = mechanism.model.joints[joint.joint_id]
        scale = mechanism.length_scale() if joint.motion_component == 0 else 1.0
        for index in range(pin_joint.idx_q, pin_joint.idx_q + pin_joint.nq):
            indices.append(index)
            scales.append(scale)
    return indices, np.array(scales)
