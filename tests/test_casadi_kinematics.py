"""Tests of clearance_pin.kinematics.casadi_kinematics against Pinocchio (pin 4.x)."""

from __future__ import annotations

from functools import cache

import casadi as ca
import numpy as np
import pinocchio as pin
import pytest

from clearance_pin.kinematics import (
    SUPPORTED_JOINTS,
    CasadiKinematics,
    casadi_function,
    rotation_vee_antisym,
    se3_exp,
)

TOL = 1e-12
N_CONFIGS = 20
LIM = 'effort="1" velocity="1"'

SERIAL_6R = f"""
<robot name="serial6r">
  <link name="base"/><link name="l1"/><link name="l2"/><link name="l3"/>
  <link name="l4"/><link name="l5"/><link name="l6"/><link name="tool"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <origin xyz="0.1 -0.2 0.3" rpy="0.3 -0.2 0.7"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" {LIM}/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>
    <origin xyz="0 0.05 0.4" rpy="1.5707963 0 0.1"/><axis xyz="0.3 0.4 -0.5"/>
    <limit lower="-2" upper="2" {LIM}/></joint>
  <joint name="j3" type="revolute"><parent link="l2"/><child link="l3"/>
    <origin xyz="0.45 0 0.02" rpy="0 0.4 -1.1"/><axis xyz="0 0 -1"/>
    <limit lower="-2.5" upper="2.5" {LIM}/></joint>
  <joint name="j4" type="revolute"><parent link="l3"/><child link="l4"/>
    <origin xyz="0.1 0.3 0" rpy="-0.5 0.25 0.125"/><axis xyz="1 0 0"/>
    <limit lower="-3" upper="3" {LIM}/></joint>
  <joint name="j5" type="revolute"><parent link="l4"/><child link="l5"/>
    <origin xyz="0 0 0.2" rpy="0.9 -1.3 0.2"/><axis xyz="1 1 1"/>
    <limit lower="-2" upper="2" {LIM}/></joint>
  <joint name="j6" type="revolute"><parent link="l5"/><child link="l6"/>
    <origin xyz="0.02 -0.01 0.08" rpy="0 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-3" upper="3" {LIM}/></joint>
  <joint name="tool_fixed" type="fixed"><parent link="l6"/><child link="tool"/>
    <origin xyz="0 0.1 0.15" rpy="0.2 0.3 0.4"/></joint>
</robot>
"""

MIXED = f"""
<robot name="mixed">
  <link name="world"/><link name="body"/><link name="wheel"/><link name="wheel2"/>
  <link name="slider"/><link name="slider2"/><link name="cart"/><link name="arm"/>
  <link name="marker"/>
  <joint name="float" type="floating"><parent link="world"/><child link="body"/>
    <origin xyz="0.5 0.1 0.2" rpy="0.1 0.2 0.3"/></joint>
  <joint name="wheel_cont" type="continuous"><parent link="body"/><child link="wheel"/>
    <origin xyz="0 0.3 0" rpy="0.2 0 0.5"/><axis xyz="0 1 0"/></joint>
  <joint name="wheel2_cont" type="continuous"><parent link="wheel"/><child link="wheel2"/>
    <origin xyz="0.1 0 0.05" rpy="0 -0.3 0"/><axis xyz="0.2 -0.6 0.3"/></joint>
  <joint name="slide_x" type="prismatic"><parent link="body"/><child link="slider"/>
    <origin xyz="0 0 0.1" rpy="0.4 0.1 -0.2"/><axis xyz="1 0 0"/>
    <limit lower="-0.5" upper="0.5" {LIM}/></joint>
  <joint name="slide_u" type="prismatic"><parent link="slider"/><child link="slider2"/>
    <origin xyz="0.2 0 0" rpy="0 0 0.3"/><axis xyz="1 -2 0.5"/>
    <limit lower="-0.3" upper="0.4" {LIM}/></joint>
  <joint name="plane" type="planar"><parent link="slider2"/><child link="cart"/>
    <origin xyz="0 0.2 0.1" rpy="0.3 -0.2 0.1"/><axis xyz="0 0 1"/></joint>
  <joint name="arm_rev" type="revolute"><parent link="cart"/><child link="arm"/>
    <origin xyz="0.05 0 0.3" rpy="0 0.5 0"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" {LIM}/></joint>
  <joint name="marker_fixed" type="fixed"><parent link="arm"/><child link="marker"/>
    <origin xyz="0.3 0.1 -0.2" rpy="1 2 3"/></joint>
</robot>
"""

TREE = f"""
<robot name="tree">
  <link name="root"/><link name="trunk"/><link name="a1"/><link name="a2"/><link name="b1"/>
  <link name="b2"/><link name="c1"/><link name="sensor"/><link name="a3"/>
  <joint name="trunk_j" type="revolute"><parent link="root"/><child link="trunk"/>
    <origin xyz="0 0 0.5" rpy="0 0 0.3"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" {LIM}/></joint>
  <joint name="a1_j" type="revolute"><parent link="trunk"/><child link="a1"/>
    <origin xyz="0.2 0 0" rpy="0.5 0 0"/><axis xyz="0 1 1"/>
    <limit lower="-2" upper="2" {LIM}/></joint>
  <joint name="a2_j" type="prismatic"><parent link="a1"/><child link="a2"/>
    <origin xyz="0.3 0 0" rpy="0 0.2 0"/><axis xyz="0 0 1"/>
    <limit lower="-0.1" upper="0.2" {LIM}/></joint>
  <joint name="a3_j" type="continuous"><parent link="a2"/><child link="a3"/>
    <origin xyz="0.1 0.1 0" rpy="0 0 0"/><axis xyz="-1 0 0"/></joint>
  <joint name="b1_j" type="revolute"><parent link="trunk"/><child link="b1"/>
    <origin xyz="-0.2 0 0" rpy="-0.5 0 3.1"/><axis xyz="0 1 0"/>
    <limit lower="-2" upper="2" {LIM}/></joint>
  <joint name="b2_j" type="revolute"><parent link="b1"/><child link="b2"/>
    <origin xyz="0 0.3 0" rpy="0 0.7 0"/><axis xyz="1 0 0"/>
    <limit lower="-2" upper="2" {LIM}/></joint>
  <joint name="c1_j" type="continuous"><parent link="root"/><child link="c1"/>
    <origin xyz="1 0 0" rpy="0 0 0"/><axis xyz="0 0 1"/></joint>
  <joint name="sensor_j" type="fixed"><parent link="trunk"/><child link="sensor"/>
    <origin xyz="0 0 0.4" rpy="0.1 0.1 0.1"/></joint>
</robot>
"""


def _programmatic() -> pin.Model:
    """Joints the URDF parser does not produce as used here: spherical, RUBX/RUBZ, PY/PZ,
    RX, a free-flyer below another joint; plus extra OP_FRAMEs on several joints."""
    model = pin.Model()
    rng = np.random.default_rng(7)

    def rand_se3() -> pin.SE3:
        return pin.SE3(pin.exp3(rng.normal(size=3)), rng.normal(size=3))

    joints = [
        pin.JointModelRX(),
        pin.JointModelSpherical(),
        pin.JointModelRUBX(),
        pin.JointModelPY(),
        pin.JointModelFreeFlyer(),
        pin.JointModelRUBZ(),
        pin.JointModelPZ(),
        pin.JointModelRevoluteUnaligned(np.array([0.6, 0.0, -0.8])),
        pin.JointModelPrismaticUnaligned(np.array([0.0, 0.6, 0.8])),
    ]
    parent = 0
    for k, joint in enumerate(joints):
        parent = model.addJoint(
            parent if k != 5 else 2,
            joint,
            rand_se3(),
            f"j{k}",
            np.ones(joint.nv) * 10,
            np.ones(joint.nv) * 10,  # max effort, max velocity
            -np.ones(joint.nq) * 2,
            np.ones(joint.nq) * 2,
        )
        model.addFrame(pin.Frame(f"op{k}", parent, rand_se3(), pin.FrameType.OP_FRAME))
    return model


def _finite_limits(model: pin.Model) -> pin.Model:
    model.lowerPositionLimit = np.maximum(model.lowerPositionLimit, -1.5)
    model.upperPositionLimit = np.minimum(model.upperPositionLimit, 1.5)
    return model


def _from_urdf(text: str, root: pin.JointModel | None = None) -> pin.Model:
    model = pin.buildModelFromXML(text) if root is None else pin.buildModelFromXML(text, root)
    return _finite_limits(model)


MODEL_BUILDERS = {
    "serial6r": lambda: _from_urdf(SERIAL_6R),
    "mixed": lambda: _from_urdf(MIXED),
    "tree": lambda: _from_urdf(TREE),
    "tree_spherical_root": lambda: _from_urdf(TREE, pin.JointModelSpherical()),
    "programmatic": lambda: _finite_limits(_programmatic()),
}
MODELS = list(MODEL_BUILDERS)


@cache
def _setup(name: str):
    """Model, CasadiKinematics and compiled functions, built once per model."""
    model = MODEL_BUILDERS[name]()
    kin = CasadiKinematics(model)
    fk = casadi_function(model)
    q = ca.SX.sym("q", model.nq)
    v = ca.SX.sym("v", model.nv)
    oMi = kin.joint_placements(kin.integrate(q, v))
    oMf = kin.frame_placements(oMi)
    flat = ca.vertcat(*[ca.vertcat(p, ca.vec(R)) for R, p in oMf])  # 12 rows per frame
    jac_v = ca.Function("jac_v", [q, v], [flat, ca.jacobian(flat, v)])
    integrate = ca.Function("integrate", [q, v], [kin.integrate(q, v)])
    return model, kin, fk, jac_v, integrate


def _configs(model: pin.Model, seed: int) -> list[np.ndarray]:
    pin.seed(seed)
    return [pin.randomConfiguration(model) for _ in range(N_CONFIGS)]


def _unstack(M: ca.DM, k: int) -> tuple[np.ndarray, np.ndarray]:
    block = np.array(M[:, 4 * k : 4 * k + 4])
    return block[:, :3], block[:, 3]


def _vee(S: np.ndarray) -> np.ndarray:
    """(S[2,1], S[0,2], S[1,0]) of a (skew-symmetric) numeric 3x3 matrix."""
    return np.array([S[2, 1], S[0, 2], S[1, 0]])


def _se3_err(R: np.ndarray, p: np.ndarray, M: pin.SE3) -> float:
    return max(np.abs(R - M.rotation).max(), np.abs(p - M.translation).max())


def test_joint_types_are_recognised():
    """The test models together contain every supported joint type (so the tests below cover
    them all), and RevoluteUnboundedUnaligned's axis (no `axis` binding in pin 4.1) is read
    correctly from its motion subspace."""
    kinds = set()
    for name in MODELS:
        kinds |= {spec.kind for spec in _setup(name)[1].joints}
    assert kinds == SUPPORTED_JOINTS
    _, kin, *_ = _setup("mixed")
    spec = next(s for s in kin.joints if s.name == "wheel2_cont")
    assert spec.kind == "JointModelRevoluteUnboundedUnaligned"
    expected = np.array([0.2, -0.6, 0.3]) / np.linalg.norm([0.2, -0.6, 0.3])
    assert np.abs(spec.axis - expected).max() < 1e-15


@pytest.mark.parametrize("name", MODELS)
def test_forward_kinematics_matches_pin(name):
    """For 20 random configurations, oMi of every joint and oMf of every frame equal
    pin.forwardKinematics + pin.updateFramePlacements to 1e-12."""
    model, _, fk, _, _ = _setup(name)
    data = model.createData()
    for q in _configs(model, 1):
        pin.forwardKinematics(model, data, q)
        pin.updateFramePlacements(model, data)
        oMi, oMf = fk(q)
        for i in range(model.njoints):
            assert _se3_err(*_unstack(oMi, i), data.oMi[i]) < TOL, (i, model.names[i])
        for f in range(model.nframes):
            assert _se3_err(*_unstack(oMf, f), data.oMf[f]) < TOL, model.frames[f].name


@pytest.mark.parametrize("name", MODELS)
def test_integrate_matches_pin(name):
    """CasadiKinematics.integrate(q, v) equals pin.integrate(model, q, v) to 1e-12 for random q
    and v of scale 3 (rotations past pi: quaternion sign flip), 1e-3 and 1e-9 (covers
    SO(2), SO(3), SE(2), SE(3) joints)."""
    model, _, _, _, integrate = _setup(name)
    rng = np.random.default_rng(3)
    for k, q in enumerate(_configs(model, 2)):
        v = rng.normal(size=model.nv) * [3.0, 1e-3, 1e-9][k % 3]
        got = np.array(integrate(q, v)).ravel()
        assert np.abs(got - pin.integrate(model, q, v)).max() < TOL


@pytest.mark.parametrize("name", MODELS)
def test_non_normalized_configurations_mirror_pin(name):
    """With quaternion / (cos, sin) components scaled by 1 + 1e-4 (not unit), FK and integrate
    still equal Pinocchio's to 1e-12: both use the same polynomials (Eigen quaternion matrix,
    unnormalised cos/sin, first-order renormalisation in integrate)."""
    model, kin, fk, _, integrate = _setup(name)
    data = model.createData()
    rng = np.random.default_rng(5)
    for q in _configs(model, 6)[:5]:
        for spec in kin.joints:
            if spec.nq != spec.nv:
                start = spec.idx_q + (3 if spec.kind == "JointModelFreeFlyer" else 0)
                q[start : spec.idx_q + spec.nq] *= 1 + 1e-4
        v = rng.normal(size=model.nv)
        assert np.abs(np.array(integrate(q, v)).ravel() - pin.integrate(model, q, v)).max() < TOL
        pin.framesForwardKinematics(model, data, q)
        _, oMf = fk(q)
        for f in range(model.nframes):
            assert _se3_err(*_unstack(oMf, f), data.oMf[f]) < TOL


@pytest.mark.parametrize("name", MODELS)
def test_frame_jacobians_match_pin_local_world_aligned(name):
    """d/dv of every frame placement oMf(integrate(q, v)) at v = 0, mapped to the tangent space
    (linear: dp/dv; angular: vee(dR/dv_k R^T)), equals pin.getFrameJacobian(...,
    LOCAL_WORLD_ALIGNED) after pin.computeJointJacobians, to 1e-12, for all joint types
    (nq != nv joints through the CasADi mirror of pin.integrate)."""
    model, _, _, jac_v, _ = _setup(name)
    data = model.createData()
    zero = np.zeros(model.nv)
    for q in _configs(model, 4)[:8]:
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        flat, J = (np.array(x) for x in jac_v(q, zero))
        for f in range(model.nframes):
            rows = slice(12 * f, 12 * f + 12)
            R = flat[rows][3:].reshape(3, 3, order="F")
            Jf = J[rows]
            ang = np.stack(
                [_vee(Jf[3:, k].reshape(3, 3, order="F") @ R.T) for k in range(model.nv)],
                axis=1,
            )
            ours = np.vstack([Jf[:3], ang])
            ref = pin.getFrameJacobian(model, data, f, pin.LOCAL_WORLD_ALIGNED)
            assert np.abs(ours - ref).max() < TOL, model.frames[f].name


def test_jacobian_wrt_q_for_nq_equal_nv():
    """For a model with nq == nv (serial 6R), the plain Jacobian of the tool frame w.r.t. q
    equals pin's LOCAL_WORLD_ALIGNED frame Jacobian (angular part through vee(dR/dq_k R^T))."""
    model, kin, *_ = _setup("serial6r")
    q = ca.SX.sym("q", model.nq)
    fid = model.getFrameId("tool")
    R, p = kin.frame_placement(kin.joint_placements(q), fid)
    f = ca.Function("f", [q], [R, ca.jacobian(p, q), ca.jacobian(ca.vec(R), q)])
    data = model.createData()
    for qn in _configs(model, 5)[:5]:
        Rn, Jp, JR = (np.array(x) for x in f(qn))
        ang = np.stack(
            [_vee(JR[:, k].reshape(3, 3, order="F") @ Rn.T) for k in range(model.nv)], axis=1
        )
        pin.computeJointJacobians(model, data, qn)
        ref = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
        assert np.abs(np.vstack([Jp, ang]) - ref).max() < TOL


def _fk_with_delta(model: pin.Model, q: np.ndarray, joint: int, delta: pin.SE3):
    """Reference with pin.SE3 products: pin FK on a copy of the model in which everything
    attached to joint `joint` (child joint placements, frames whose parentJoint is `joint`) is
    left-multiplied by `delta`; the joint's own placement is data.oMi[joint] * delta."""
    moved = model.copy()
    for c in range(1, model.njoints):
        if model.parents[c] == joint:
            moved.jointPlacements[c] = delta * model.jointPlacements[c]
    for f in range(model.nframes):
        frame = moved.frames[f]
        if frame.parentJoint == joint:
            frame.placement = delta * frame.placement
            moved.frames[f] = frame
    data = moved.createData()
    pin.framesForwardKinematics(moved, data, q)
    oMi = [pin.SE3(M) for M in data.oMi]
    oMi[joint] = data.oMi[joint] * delta
    return oMi, [pin.SE3(M) for M in data.oMf]


@pytest.mark.parametrize("name", MODELS)
def test_deltas_match_moved_model(name):
    """With deltas={j: D} (D a numeric pin.SE3, or se3_exp of a symbolic twist evaluated at a
    random value), oMi of all joints and oMf of all frames equal pin FK on a model where
    joint j's child frames are right-multiplied by D, to 1e-12."""
    model, kin, *_ = _setup(name)
    rng = np.random.default_rng(11)
    q_sym = ca.SX.sym("q", model.nq)
    xi = ca.SX.sym("xi", 6)
    for j in range(1, model.njoints):
        oMi = kin.joint_placements(q_sym, deltas={j: se3_exp(xi)})
        oMf = kin.frame_placements(oMi)
        f = ca.Function(
            "f",
            [q_sym, xi],
            [
                ca.horzcat(*[ca.horzcat(R, p) for R, p in oMi]),
                ca.horzcat(*[ca.horzcat(R, p) for R, p in oMf]),
            ],
        )
        for q in _configs(model, 20 + j)[:3]:
            xin = rng.normal(size=6) * 0.5
            delta = pin.exp6(xin)
            ref_i, ref_f = _fk_with_delta(model, q, j, delta)
            got_i, got_f = f(q, xin)
            for i in range(model.njoints):
                assert _se3_err(*_unstack(got_i, i), ref_i[i]) < TOL, (j, i)
            for k in range(model.nframes):
                assert _se3_err(*_unstack(got_f, k), ref_f[k]) < TOL, (j, model.frames[k].name)
    # numeric pin.SE3 and (R, p) numpy tuples are accepted as deltas
    q = _configs(model, 99)[0]
    D = pin.SE3.Random()
    ref_i, _ = _fk_with_delta(model, q, model.njoints - 1, D)
    for delta in (D, (D.rotation, D.translation)):
        R, p = kin.joint_placements(q, deltas={model.njoints - 1: delta})[-1]
        assert _se3_err(np.array(ca.DM(R)), np.array(ca.DM(p)).ravel(), ref_i[-1]) < TOL


def test_delta_gradient_is_finite_at_identity():
    """The gradient and Hessian of a frame position and of rotation_vee_antisym(frame
    rotation) w.r.t. a delta twist are finite at the identity delta (xi = 0)."""
    model, kin, *_ = _setup("mixed")
    xi = ca.SX.sym("xi", 6)
    q = _configs(model, 5)[0]
    R, p = kin.frame_placement(
        kin.joint_placements(q, {2: se3_exp(xi)}), model.getFrameId("marker")
    )
    g = ca.vertcat(p, rotation_vee_antisym(R))
    s = ca.sum1(g * ca.DM(np.arange(1.0, 7.0)))
    f = ca.Function("f", [xi], [ca.jacobian(g, xi), ca.hessian(s, xi)[0]])
    for x in f(np.zeros(6)):
        assert np.all(np.isfinite(np.array(x)))


def test_unsupported_joint_and_bad_arguments_raise():
    """An unsupported joint type raises a ValueError naming the joint and its type; wrong q
    size, a delta on the universe (index 0) and an unknown frame id raise ValueError."""
    model = pin.Model()
    model.addJoint(0, pin.JointModelRX(), pin.SE3.Identity(), "ok")
    model.addJoint(1, pin.JointModelSphericalZYX(), pin.SE3.Identity(), "zyx_joint")
    with pytest.raises(ValueError, match=r"zyx_joint.*JointModelSphericalZYX"):
        CasadiKinematics(model)
    model, kin, *_ = _setup("serial6r")
    with pytest.raises(ValueError):
        kin.joint_placements(np.zeros(model.nq + 1))
    with pytest.raises(ValueError):
        kin.joint_placements(np.zeros(model.nq), deltas={0: pin.SE3.Identity()})
    with pytest.raises(ValueError):
        kin.frame_placement(kin.joint_placements(np.zeros(model.nq)), model.nframes)
