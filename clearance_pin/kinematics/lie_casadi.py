"""SO(3) / SE(3) maps as CasADi ``SX`` expressions.

Conventions (identical to Pinocchio):

* a *placement* is a tuple ``(R, p)``: ``R`` an SX 3x3 rotation, ``p`` an SX 3x1
  translation [m]; it maps coordinates in the child frame to the parent frame,
  ``x_parent = R @ x_child + p``;
* a *twist* is the 6-vector ``xi = (v, omega)``, linear part first [m], angular part
  last [rad], so that ``se3_exp(xi)`` equals ``pin.exp6(pin.Motion(xi))``;
* a quaternion is stored ``(x, y, z, w)``, as in Pinocchio configuration vectors.

All maps accept ``casadi.SX`` or anything convertible by ``numpy.asarray`` and return
``SX``. The exponential maps are written so that their values and their first and
second derivatives are finite (no NaN, no Inf) everywhere, including exactly at
``omega = 0``: for ``theta^2 = |omega|^2 < SMALL_ANGLE_SQ`` a Taylor series in
``theta^2`` (terms up to ``theta^6``) is used, and the closed form otherwise, with
``theta = sqrt(theta^2 + [theta^2 < SMALL_ANGLE_SQ])`` so that the (always evaluated)
closed-form branch never divides by zero.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, TypeAlias

import casadi as ca
import numpy as np
from numpy.typing import ArrayLike

from ..errors import ArgumentError

if TYPE_CHECKING:
    import pinocchio as pin

Placement = tuple[ca.SX, ca.SX]
#: what the maps accept for a vector or matrix: an SX, a DM or anything numpy.asarray converts
SXLike: TypeAlias = ca.SX | ca.DM | ArrayLike
#: what the placement maps accept: a pin.SE3 or an (R, p) pair
PlacementLike: TypeAlias = "pin.SE3 | tuple[SXLike, SXLike]"

#: Threshold on theta^2 [rad^2] below which the series are used. The first neglected
#: series term is ~theta^8 / 9! < 3e-18; the closed forms lose ~eps / theta^2 < 2e-13
#: relative accuracy above it.
SMALL_ANGLE_SQ = 1e-3

# Series coefficients in theta^2, each for terms theta^0, theta^2, theta^4, theta^6.
_SIN_OVER_T = (1.0, -1.0 / 6.0, 1.0 / 120.0, -1.0 / 5040.0)  # sin(t)/t
_ONE_MINUS_COS_OVER_T2 = (0.5, -1.0 / 24.0, 1.0 / 720.0, -1.0 / 40320.0)  # (1-cos t)/t^2
_T_MINUS_SIN_OVER_T3 = (1.0 / 6.0, -1.0 / 120.0, 1.0 / 5040.0, -1.0 / 362880.0)  # (t-sin t)/t^3
_SIN_HALF_OVER_T = (0.5, -1.0 / 48.0, 1.0 / 3840.0, -1.0 / 645120.0)  # sin(t/2)/t
_COS_HALF = (1.0, -1.0 / 8.0, 1.0 / 384.0, -1.0 / 46080.0)  # cos(t/2)


def as_sx(x: SXLike, shape: tuple[int, int] | None = None) -> ca.SX:
    """Convert ``x`` (SX, DM, numpy array, list, float) to ``SX``.

    A 1-D input of length n becomes an n x 1 column. If ``shape`` is given the result
    must have exactly that shape (an :class:`~clearance_pin.ArgumentError`, also a
    ``ValueError``, is raised otherwise).
    """
    if isinstance(x, ca.MX):
        raise ArgumentError(
            "x",
            "a casadi.SX, DM, numpy array, list or float",
            x,
            "lie_casadi works on casadi.SX; wrap the SX expression in a casadi.Function "
            "to evaluate it on MX",
        )
    if isinstance(x, ca.SX):
        out = x
    elif isinstance(x, ca.DM):
        out = ca.SX(x)
    else:
        arr = np.asarray(x, dtype=float)
        if arr.ndim == 0:
            arr = arr.reshape(1, 1)
        elif arr.ndim == 1:
            arr = arr.reshape(-1, 1)
        elif arr.ndim != 2:
            raise ArgumentError(
                "x", "a scalar, vector or matrix", x, f"an array of shape {arr.shape}"
            )
        out = ca.SX(ca.DM(arr))
    if shape is not None and out.shape != shape:
        raise ArgumentError("x", f"shape {shape}", x, f"shape {out.shape}")
    return out


def as_placement(M: PlacementLike) -> Placement:
    """Convert a ``pin.SE3`` or an ``(R, p)`` pair to an SX placement ``(R, p)``."""
    if hasattr(M, "rotation") and hasattr(M, "translation"):
        return as_sx(M.rotation, (3, 3)), as_sx(M.translation, (3, 1))
    try:
        R, p = M
    except (TypeError, ValueError) as exc:
        raise ArgumentError("M", "a placement: a pin.SE3 or an (R, p) pair", M) from exc
    return as_sx(R, (3, 3)), as_sx(p, (3, 1))


def _poly(t2: ca.SX, coeffs: tuple[float, ...]) -> ca.SX:
    """Horner evaluation of sum_k coeffs[k] * t2**k (two coefficients or more)."""
    out = coeffs[-2] + t2 * coeffs[-1]
    for c in reversed(coeffs[:-2]):
        out = c + t2 * out
    return out


def _guarded_theta(theta2: ca.SX) -> tuple[ca.SX, ca.SX]:
    """Return ``(small, theta)`` where ``theta`` is safe to divide by on both branches."""
    small = theta2 < SMALL_ANGLE_SQ
    return small, ca.sqrt(theta2 + small)


def skew(w: SXLike) -> ca.SX:
    """Cross-product matrix ``[w]x`` (3x3) of a 3-vector ``w``: ``[w]x @ u = w x u``."""
    w = as_sx(w, (3, 1))
    return ca.vertcat(
        ca.horzcat(0, -w[2], w[1]),
        ca.horzcat(w[2], 0, -w[0]),
        ca.horzcat(-w[1], w[0], 0),
    )


def vee(S: SXLike) -> ca.SX:
    """Inverse of :func:`skew` for a skew-symmetric 3x3 matrix: ``(S[2,1], S[0,2], S[1,0])``."""
    S = as_sx(S, (3, 3))
    return ca.vertcat(S[2, 1], S[0, 2], S[1, 0])


def _exp_coefficients(omega: ca.SX) -> tuple[ca.SX, ca.SX, ca.SX]:
    """``(sin t / t, (1 - cos t) / t^2, (t - sin t) / t^3)`` with ``t = |omega|``, smooth."""
    theta2 = ca.dot(omega, omega)
    small, theta = _guarded_theta(theta2)
    s, c = ca.sin(theta), ca.cos(theta)
    t2 = theta * theta  # equals theta2 on the closed-form branch, >= 1 on the other one
    a = ca.if_else(small, _poly(theta2, _SIN_OVER_T), s / theta)
    b = ca.if_else(small, _poly(theta2, _ONE_MINUS_COS_OVER_T2), (1 - c) / t2)
    d = ca.if_else(small, _poly(theta2, _T_MINUS_SIN_OVER_T3), (theta - s) / (t2 * theta))
    return a, b, d


def so3_exp(omega: SXLike) -> ca.SX:
    """Rotation matrix ``exp([omega]x)`` (Rodrigues), omega [rad] a 3-vector.

    ``R = I + A [w]x + B [w]x^2`` with ``A = sin(t)/t``, ``B = (1 - cos t)/t^2``,
    ``t = |omega|``. Equals ``pin.exp3(omega)``.
    """
    omega = as_sx(omega, (3, 1))
    a, b, _ = _exp_coefficients(omega)
    W = skew(omega)
    return ca.SX.eye(3) + a * W + b * (W @ W)


def se3_exp(twist: SXLike) -> Placement:
    """Placement ``exp(xi)`` of a twist ``xi = (v [m], omega [rad])`` (Pinocchio order).

    ``R = so3_exp(omega)``, ``p = V v`` with ``V = I + B [w]x + C [w]x^2``,
    ``B = (1 - cos t)/t^2``, ``C = (t - sin t)/t^3``. Equals ``pin.exp6(pin.Motion(xi))``.
    """
    twist = as_sx(twist, (6, 1))
    v, omega = twist[:3], twist[3:]
    a, b, d = _exp_coefficients(omega)
    W = skew(omega)
    W2 = W @ W
    R = ca.SX.eye(3) + a * W + b * W2
    V = ca.SX.eye(3) + b * W + d * W2
    return R, V @ v


def se2_exp(twist: SXLike) -> tuple[ca.SX, ca.SX]:
    """Planar exponential of ``(vx, vy, omega)``: returns ``(R 2x2, t 2x1)``.

    ``R = rot(omega)``, ``t = [[A, -B], [B, A]] (vx, vy)`` with ``A = sin(w)/w``,
    ``B = (1 - cos w)/w``; the same map as Pinocchio's SE(2) Lie group ``exp``.
    """
    twist = as_sx(twist, (3, 1))
    w = twist[2]
    w2 = w * w
    small = w2 < SMALL_ANGLE_SQ
    w_safe = w + small  # nonzero on the series branch (the branch itself is discarded)
    s, c = ca.sin(w), ca.cos(w)
    a = ca.if_else(small, _poly(w2, _SIN_OVER_T), s / w_safe)
    b = ca.if_else(small, w * _poly(w2, _ONE_MINUS_COS_OVER_T2), (1 - c) / w_safe)
    R = ca.vertcat(ca.horzcat(c, -s), ca.horzcat(s, c))
    t = ca.vertcat(a * twist[0] - b * twist[1], b * twist[0] + a * twist[1])
    return R, t


def rotation_vee_antisym(R: SXLike) -> ca.SX:
    """``vee((R - R^T) / 2)`` = ``sin(theta) * axis`` for a rotation of angle theta.

    A smooth (polynomial) rotation measure, equal to the rotation vector to first order.
    """
    R = as_sx(R, (3, 3))
    return 0.5 * ca.vertcat(R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1])


def axis_angle_rotation(axis: SXLike, cos_value: SXLike, sin_value: SXLike) -> ca.SX:
    """``R = c I + s [a]x + (1 - c) a a^T`` for a unit axis ``a`` (Pinocchio's
    ``toRotationMatrix(axis, cos, sin)``; no normalisation of ``(c, s)``)."""
    a = as_sx(axis, (3, 1))
    c, s = as_sx(cos_value, (1, 1)), as_sx(sin_value, (1, 1))
    return c * ca.SX.eye(3) + s * skew(a) + (1 - c) * (a @ a.T)


def quat_to_rotation(quat: SXLike) -> ca.SX:
    """Rotation matrix of a quaternion stored ``(x, y, z, w)``.

    Same polynomial as Eigen's ``Quaternion::toRotationMatrix`` (used by Pinocchio's
    free-flyer and spherical joints); no normalisation, so it is a rotation only for
    unit quaternions.
    """
    q = as_sx(quat, (4, 1))
    x, y, z, w = q[0], q[1], q[2], q[3]
    return ca.vertcat(
        ca.horzcat(1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)),
        ca.horzcat(2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)),
        ca.horzcat(2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)),
    )


def quat_multiply(q1: SXLike, q2: SXLike) -> ca.SX:
    """Hamilton product ``q1 * q2`` of quaternions stored ``(x, y, z, w)``."""
    a, b = as_sx(q1, (4, 1)), as_sx(q2, (4, 1))
    va, vb = a[:3], b[:3]
    wa, wb = a[3], b[3]
    return ca.vertcat(wa * vb + wb * va + ca.cross(va, vb), wa * wb - ca.dot(va, vb))


def quat_exp3(omega: SXLike) -> ca.SX:
    """Unit quaternion ``(x, y, z, w)`` of ``so3_exp(omega)``:
    ``(sin(t/2)/t * omega, cos(t/2))``, smooth at ``omega = 0``."""
    omega = as_sx(omega, (3, 1))
    theta2 = ca.dot(omega, omega)
    small, theta = _guarded_theta(theta2)
    s = ca.if_else(small, _poly(theta2, _SIN_HALF_OVER_T), ca.sin(theta / 2) / theta)
    c = ca.if_else(small, _poly(theta2, _COS_HALF), ca.cos(theta / 2))
    return ca.vertcat(s * omega, c)


def identity() -> Placement:
    """The identity placement ``(I, 0)``."""
    return ca.SX.eye(3), ca.SX.zeros(3, 1)


def compose(A: PlacementLike, B: PlacementLike) -> Placement:
    """``A * B`` for placements ``(R, p)``: ``(R_a R_b, R_a p_b + p_a)``."""
    Ra, pa = as_placement(A)
    Rb, pb = as_placement(B)
    return Ra @ Rb, Ra @ pb + pa


def inverse(A: PlacementLike) -> Placement:
    """``A^-1 = (R^T, -R^T p)`` (assumes ``R`` orthonormal)."""
    R, p = as_placement(A)
    return R.T, -(R.T @ p)


def act(A: PlacementLike, point: SXLike) -> ca.SX:
    """``R @ point + p``: a point [m] given in A's child frame, expressed in its parent."""
    R, p = as_placement(A)
    return R @ as_sx(point, (3, 1)) + p
