"""Tests of clearance_pin.kinematics.lie_casadi against Pinocchio and finite differences."""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from clearance_pin.errors import ArgumentError
from clearance_pin.kinematics import lie_casadi as lie

TOL = 1e-12

# --- compiled CasADi functions, built once -------------------------------------------------

_w = ca.SX.sym("w", 3)
_xi = ca.SX.sym("xi", 6)
_R_so3 = lie.so3_exp(_w)
_R_se3, _p_se3 = lie.se3_exp(_xi)
_se3_out = ca.vertcat(ca.vec(_R_se3), _p_se3)  # 12 outputs
SO3 = ca.Function("so3", [_w], [_R_so3])
SO3_JAC = ca.Function("so3_jac", [_w], [ca.jacobian(ca.vec(_R_so3), _w)])
SE3 = ca.Function("se3", [_xi], [_R_se3, _p_se3])
SE3_JAC = ca.Function("se3_jac", [_xi], [ca.jacobian(_se3_out, _xi)])
# Hessians of every scalar output, stacked: row k holds vec(d^2 out_k / d x^2).
SO3_HESS = ca.Function(
    "so3_hess", [_w], [ca.vertcat(*[ca.vec(ca.hessian(_R_so3[k], _w)[0]).T for k in range(9)])]
)
SE3_HESS = ca.Function(
    "se3_hess",
    [_xi],
    [ca.vertcat(*[ca.vec(ca.hessian(_se3_out[k], _xi)[0]).T for k in range(12)])],
)
QEXP = ca.Function("qexp", [_w], [lie.quat_exp3(_w)])
QEXP_JAC = ca.Function("qexp_jac", [_w], [ca.jacobian(lie.quat_exp3(_w), _w)])
_tw = ca.SX.sym("tw", 3)
SE2 = ca.Function("se2", [_tw], list(lie.se2_exp(_tw)))
_R2, _t2 = lie.se2_exp(_tw)
SE2_JAC = ca.Function("se2_jac", [_tw], [ca.jacobian(ca.vertcat(_R2[:, 0], _t2), _tw)])

SQRT_SMALL = np.sqrt(lie.SMALL_ANGLE_SQ)
ANGLES = [
    0.0,
    1e-12,
    1e-9,
    1e-7,
    1e-5,
    1e-3,
    0.99 * SQRT_SMALL,
    1.01 * SQRT_SMALL,
    0.3,
    1.0,
    2.5,
    np.pi - 1e-6,
    3.0 * np.pi / 2,
]


def _np(x) -> np.ndarray:
    return np.array(ca.DM(x))


def _unit(v: np.ndarray) -> np.ndarray:
    n = np.linalg.norm(v)
    return v / n if n > 1e-6 else np.array([0.0, 0.0, 1.0])


vectors3 = st.lists(st.floats(-1.0, 1.0), min_size=3, max_size=3).map(np.array)
angles = st.one_of(st.sampled_from(ANGLES), st.floats(0.0, 3.5))


@st.composite
def rotation_vectors(draw) -> np.ndarray:
    return draw(angles) * _unit(draw(vectors3))


# --- values --------------------------------------------------------------------------------


@settings(max_examples=300, deadline=None)
@given(rotation_vectors())
def test_so3_exp_matches_pin_exp3(w):
    """so3_exp(w) equals pin.exp3(w) to 1e-12 for angles 0, tiny (1e-12..1e-5), around the
    series/closed-form switch, and up to 3.5 rad."""
    assert np.abs(_np(SO3(w)) - pin.exp3(w)).max() < TOL


@settings(max_examples=300, deadline=None)
@given(rotation_vectors(), vectors3)
def test_se3_exp_matches_pin_exp6(w, v):
    """se3_exp((v, w)) equals pin.exp6(pin.Motion((v, w))) (rotation and translation) to 1e-12,
    for |v| <= sqrt(3) m (pin.exp6's own error reaches ~3e-13 * |v| near |w| ~ 1.5e-4 rad)."""
    xi = np.concatenate([v, w])
    R, p = SE3(xi)
    M = pin.exp6(pin.Motion(xi))
    assert np.abs(_np(R) - M.rotation).max() < TOL
    assert np.abs(_np(p).ravel() - M.translation).max() < TOL


def _se3_exp_longdouble(xi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Reference exp6 in numpy longdouble: closed form, or 5-term series below |w| = 1e-3."""
    ld = np.longdouble
    v, w = xi[:3].astype(ld), xi[3:].astype(ld)
    t2 = (w * w).sum()
    W = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]], dtype=ld)
    if t2 < ld(1e-6):
        fact = [ld(math.factorial(k)) for k in range(13)]
        A = sum((-t2) ** k / fact[2 * k + 1] for k in range(5))
        B = sum((-t2) ** k / fact[2 * k + 2] for k in range(5))
        C = sum((-t2) ** k / fact[2 * k + 3] for k in range(5))
    else:
        t = np.sqrt(t2)
        A, B, C = np.sin(t) / t, (1 - np.cos(t)) / t2, (t - np.sin(t)) / (t2 * t)
    eye = np.eye(3, dtype=ld)
    R = eye + A * W + B * (W @ W)
    p = (eye + B * W + C * (W @ W)) @ v
    return R.astype(float), p.astype(float)


@pytest.mark.skipif(np.finfo(np.longdouble).eps > 1e-18, reason="needs extended long double")
def test_se3_exp_matches_extended_precision_reference():
    """se3_exp agrees to 1e-14 with an extended-precision (80/128-bit) evaluation over angles
    1e-12..3 rad and |v| up to 5 m, including the 1e-4 rad region where pin.exp6 loses ~1e-12."""
    rng = np.random.default_rng(0)
    worst = 0.0
    for theta in np.concatenate([10 ** rng.uniform(-12, 0.5, 400), [0.0, 1.5e-4, SQRT_SMALL]]):
        w = theta * _unit(rng.normal(size=3))
        xi = np.concatenate([rng.uniform(-3, 3, size=3), w])
        R_ref, p_ref = _se3_exp_longdouble(xi)
        R, p = SE3(xi)
        worst = max(worst, np.abs(_np(R) - R_ref).max(), np.abs(_np(p).ravel() - p_ref).max())
    assert worst < 1e-14


@pytest.mark.parametrize("theta", ANGLES)
def test_exp_maps_fixed_angles(theta):
    """At every listed angle (incl. exactly 0) both maps equal Pinocchio's to 1e-12."""
    w = theta * _unit(np.array([0.3, -0.5, 0.8]))
    xi = np.concatenate([[0.4, -1.2, 0.7], w])
    M = pin.exp6(pin.Motion(xi))
    R, p = SE3(xi)
    assert np.abs(_np(SO3(w)) - pin.exp3(w)).max() < TOL
    assert np.abs(_np(R) - M.rotation).max() < TOL
    assert np.abs(_np(p).ravel() - M.translation).max() < TOL


# --- derivatives ---------------------------------------------------------------------------


def _central_jacobian(f, x: np.ndarray, h: float = 1e-6) -> np.ndarray:
    cols = []
    for k in range(x.size):
        e = np.zeros_like(x)
        e[k] = h
        cols.append((np.asarray(f(x + e)).ravel() - np.asarray(f(x - e)).ravel()) / (2 * h))
    return np.stack(cols, axis=1)


def _so3_flat(w):
    return _np(SO3(w)).ravel(order="F")


def _se3_flat(xi):
    R, p = SE3(xi)
    return np.concatenate([_np(R).ravel(order="F"), _np(p).ravel()])


DERIV_POINTS = [0.0, 1e-9, 1e-5, 0.5 * SQRT_SMALL, 0.999 * SQRT_SMALL, 1.001 * SQRT_SMALL, 0.7]


@pytest.mark.parametrize("theta", DERIV_POINTS)
def test_exp_jacobians_match_central_differences(theta):
    """Jacobians of so3_exp, se3_exp, quat_exp3 (w.r.t. all inputs) are finite and equal
    central finite differences (h = 1e-6, tolerance 1e-8) at omega = 0, tiny and small omega,
    and on both sides of the series switch."""
    w = theta * _unit(np.array([0.2, 0.9, -0.4]))
    xi = np.concatenate([[0.5, -0.3, 1.1], w])
    J = _np(SO3_JAC(w))
    assert np.all(np.isfinite(J))
    assert np.abs(J - _central_jacobian(_so3_flat, w)).max() < 1e-8
    J = _np(SE3_JAC(xi))
    assert np.all(np.isfinite(J))
    assert np.abs(J - _central_jacobian(_se3_flat, xi)).max() < 1e-8
    J = _np(QEXP_JAC(w))
    assert np.abs(J - _central_jacobian(lambda x: _np(QEXP(x)), w)).max() < 1e-8


@pytest.mark.parametrize("theta", DERIV_POINTS)
def test_exp_hessians_finite_and_match_differences_of_jacobian(theta):
    """Hessians of every output of so3_exp and se3_exp are finite (also at omega = 0 exactly)
    and equal central differences of the exact Jacobian to 1e-7."""
    w = theta * _unit(np.array([-0.6, 0.1, 0.7]))
    xi = np.concatenate([[0.2, 0.8, -0.5], w])
    for hess, jac, x, nout in ((SO3_HESS, SO3_JAC, w, 9), (SE3_HESS, SE3_JAC, xi, 12)):
        H = _np(hess(x))
        assert np.all(np.isfinite(H))
        n = x.size
        fd = _central_jacobian(lambda y, jac=jac: _np(jac(y)), x)  # (nout*n) x n
        for k in range(nout):
            Hk = H[k].reshape(n, n, order="F")
            fd_k = fd.reshape(nout, n, n)[k]  # rows of fd: output k, input i (row-major)
            assert np.abs(Hk - fd_k).max() < 1e-7


def test_exp_derivatives_at_zero_are_exact():
    """At omega = 0: dR/dw_k = [e_k]x, d^2R/dw_i dw_j = ([e_i]x[e_j]x + [e_j]x[e_i]x)/2,
    dp/dv = I and dp/dw = -[v]x / 2 (exact values of the series, to 1e-15)."""
    E = [_np(lie.skew(e)) for e in np.eye(3)]
    J = _np(SO3_JAC(np.zeros(3)))
    for k in range(3):
        assert np.abs(J[:, k].reshape(3, 3, order="F") - E[k]).max() < 1e-15
    H = _np(SO3_HESS(np.zeros(3)))
    for i in range(3):
        for j in range(3):
            expected = 0.5 * (E[i] @ E[j] + E[j] @ E[i])
            got = H[:, i + 3 * j].reshape(3, 3, order="F")
            assert np.abs(got - expected).max() < 1e-15
    v = np.array([0.5, -0.3, 1.1])
    J = _np(SE3_JAC(np.concatenate([v, np.zeros(3)])))[9:]
    assert np.abs(J[:, :3] - np.eye(3)).max() < 1e-15
    assert np.abs(J[:, 3:] + 0.5 * _np(lie.skew(v))).max() < 1e-15


def test_series_switch_is_continuous():
    """Values and Jacobians just below and just above theta^2 = SMALL_ANGLE_SQ differ by
    no more than their true variation (<1e-12 for values over a 1e-14 step, <1e-9 Jacobian)."""
    d = _unit(np.array([1.0, 2.0, 3.0]))
    lo, hi = (SQRT_SMALL - 1e-14) * d, (SQRT_SMALL + 1e-14) * d
    xi_lo, xi_hi = np.r_[1.0, 1.0, 1.0, lo], np.r_[1.0, 1.0, 1.0, hi]
    assert np.abs(_np(SO3(lo)) - _np(SO3(hi))).max() < 1e-12
    assert np.abs(_se3_flat(xi_lo) - _se3_flat(xi_hi)).max() < 1e-12
    assert np.abs(_np(SE3_JAC(xi_lo)) - _np(SE3_JAC(xi_hi))).max() < 1e-9


# --- other maps ----------------------------------------------------------------------------


@settings(max_examples=100, deadline=None)
@given(rotation_vectors())
def test_rotation_vee_antisym_is_sin_theta_axis(w):
    """rotation_vee_antisym(exp(w)) = sin(|w|) w/|w| (0 at w = 0) to 1e-12."""
    theta = np.linalg.norm(w)
    expected = np.zeros(3) if theta == 0 else np.sin(theta) * w / theta
    got = _np(lie.rotation_vee_antisym(pin.exp3(w))).ravel()
    assert np.abs(got - expected).max() < TOL


@pytest.mark.parametrize("seed", range(5))
def test_compose_inverse_act_match_pin_se3(seed):
    """compose, inverse, act on numpy input equal pin.SE3 *, inverse(), act() to 1e-12."""
    np.random.seed(seed)
    pin.seed(seed)
    A, B = pin.SE3.Random(), pin.SE3.Random()
    x = np.random.randn(3)
    R, p = lie.compose((A.rotation, A.translation), B)
    assert np.abs(_np(R) - (A * B).rotation).max() < TOL
    assert np.abs(_np(p).ravel() - (A * B).translation).max() < TOL
    Ri, pi = lie.inverse(A)
    assert np.abs(_np(Ri) - A.inverse().rotation).max() < TOL
    assert np.abs(_np(pi).ravel() - A.inverse().translation).max() < TOL
    assert np.abs(_np(lie.act(A, x)).ravel() - A.act(x)).max() < TOL


@pytest.mark.parametrize("seed", range(5))
def test_quaternion_helpers_match_pin(seed):
    """quat_to_rotation, quat_multiply, quat_exp3 agree with pin.Quaternion / pin.exp3."""
    np.random.seed(seed)
    qa = pin.Quaternion(pin.SE3.Random().rotation)
    qb = pin.Quaternion(pin.SE3.Random().rotation)
    assert np.abs(_np(lie.quat_to_rotation(qa.coeffs())) - qa.toRotationMatrix()).max() < TOL
    got = _np(lie.quat_multiply(qa.coeffs(), qb.coeffs())).ravel()
    assert np.abs(got - (qa * qb).coeffs()).max() < TOL
    w = np.random.randn(3) * [1.0, 1e-6, 0.0][seed % 3]
    qe = _np(QEXP(w)).ravel()
    assert abs(np.linalg.norm(qe) - 1) < TOL and qe[3] > 0
    assert np.abs(_np(lie.quat_to_rotation(qe)) - pin.exp3(w)).max() < TOL


@pytest.mark.parametrize("omega", [0.0, 1e-9, 1e-4, 0.5, -2.0])
def test_se2_exp(omega):
    """se2_exp(vx, vy, w) = (rot(w), int_0^1 rot(s w) (vx, vy) ds): compared with the planar
    block of pin.exp6((vx, vy, 0, 0, 0, w)) to 1e-12, Jacobian finite vs central differences."""
    tw = np.array([0.7, -0.4, omega])
    R, t = SE2(tw)
    M = pin.exp6(np.array([tw[0], tw[1], 0, 0, 0, omega]))
    assert np.abs(_np(R) - M.rotation[:2, :2]).max() < TOL
    assert np.abs(_np(t).ravel() - M.translation[:2]).max() < TOL
    fd = _central_jacobian(
        lambda x: np.concatenate([_np(SE2(x)[0])[:, 0], _np(SE2(x)[1]).ravel()]), tw
    )
    assert np.abs(_np(SE2_JAC(tw)) - fd).max() < 1e-8


def test_skew_vee_and_input_checks():
    """skew(w) u = w x u; vee(skew(w)) = w; numpy input gives SX; bad shapes raise ValueError,
    MX raises ArgumentError (the library's error for a bad argument, also a ValueError)."""
    w, u = np.array([0.3, -1.0, 2.0]), np.array([1.5, 0.2, -0.7])
    S = lie.skew(w)
    assert isinstance(S, ca.SX) and S.shape == (3, 3)
    assert np.abs(_np(S) @ u - np.cross(w, u)).max() < TOL
    assert np.abs(_np(lie.vee(S)).ravel() - w).max() == 0
    assert isinstance(lie.so3_exp(w), ca.SX)
    with pytest.raises(ValueError):
        lie.so3_exp(np.zeros(4))
    with pytest.raises(ValueError):
        lie.se3_exp(np.zeros(3))
    with pytest.raises(ValueError):
        lie.compose((np.eye(3),), (np.eye(3), np.zeros(3)))
    with pytest.raises(ArgumentError, match=r"casadi\.Function"):
        lie.skew(ca.MX.sym("m", 3))
