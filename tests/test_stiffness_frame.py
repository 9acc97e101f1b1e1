"""The frame a joint's stiffness matrix is fixed in (issue 33 item 4): the housing's (the
parent's side, default) or the part's (the child's side, turning with the joint's angle). The
reference is the spring's deflection computed here by hand in the chosen frame, e = K^-1 W, the
frame placed by Pinocchio's own forward kinematics (the housing's frame is the joint's frame at
its zero angle, the part's at q); no solver code.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import clearance_pin as cp
from clearance_pin import ModelError, PointForce, Torque

ANGLE = 0.5  # [rad] the joint's nominal angle
ARM = np.array([0.4, 0.1, -0.05])  # [m] where the force acts, in the arm's frame
FORCE = np.array([30.0, -80.0, 55.0])  # [N] world axes
TORQUE = np.array([-4.0, 6.0, 2.5])  # [N m] world axes


def full_stiffness() -> np.ndarray:
    """A symmetric positive definite 6x6 K far from symmetric about the axis x: different
    stiffnesses along y and z and about y and z, and couplings [N/m, N, N m/rad]."""
    rng = np.random.default_rng(7)
    a = rng.normal(size=(6, 6))
    scale = np.diag([1e4, 3e3, 1e4, 1e2, 30.0, 2e2])  # sqrt of the stiffnesses
    matrix: np.ndarray = scale @ (a @ a.T + 6.0 * np.eye(6)) @ scale
    return matrix


def tilted_joint(frame: str | None, extra: str = "") -> cp.Mechanism:
    """A driven ideal revolute joint (no play) with the full K, its axis tilted off the world
    axes, at ANGLE; ``frame``: its stiffness_frame attribute (None: left out)."""
    attribute = "" if frame is None else f'stiffness_frame="{frame}"'
    return cp.loads(_with_matrix(full_stiffness(), f"{attribute} {extra}"))


def _with_matrix(matrix: np.ndarray, attributes: str = 'stiffness_frame="part"') -> str:
    """The URDF of :func:`tilted_joint` with the stiffness ``matrix`` and ``attributes``."""
    k = " ".join(repr(float(v)) for v in matrix.ravel())
    return f"""<?xml version="1.0"?>
<robot name="tilted">
  <link name="base"/><link name="arm"/>
  <joint name="j" type="revolute"><parent link="base"/><child link="arm"/>
    <origin xyz="0.1 -0.2 0.3" rpy="0.3 -0.2 0.7"/>
    <axis xyz="0.2 0.3 0.9"/><limit lower="-3" upper="3" effort="10" velocity="1"/></joint>
  <clearance_pin>
    <joint name="j" driven="true" q="{ANGLE}" stiffness="{k}" {attributes}/>
  </clearance_pin>
</robot>"""


def clearance_frame(mechanism: cp.Mechanism, q: np.ndarray) -> pin.SE3:
    """The joint's clearance frame in the world at ``q`` (x along the axis; Pinocchio's forward
    kinematics and the URDF axis, not the library's frames)."""
    model = mechanism.model
    data = model.createData()
    pin.forwardKinematics(model, data, q)
    axis = np.array([0.2, 0.3, 0.9]) / np.linalg.norm([0.2, 0.3, 0.9])
    # the library's convention for the frame's y and z: the smallest rotation taking x onto the
    # axis (docs/method.md section 1), written out here
    x = np.array([1.0, 0.0, 0.0])
    v, c = np.cross(x, axis), float(x @ axis)
    skew = pin.skew(v)
    rotation = np.eye(3) + skew + skew @ skew / (1.0 + c)
    return data.oMi[model.getJointId("j")] * pin.SE3(rotation, np.zeros(3))


def by_hand(mechanism: cp.Mechanism, frame: str) -> np.ndarray:
    """The arm's deflection (translation of the joint centre, rotation) [m, rad] in world axes:
    e = K^-1 W in the frame K is fixed in, W the load's wrench about the joint centre."""
    q = mechanism.q_nominal
    zero = q.copy()
    zero[mechanism.model.joints[mechanism.model.getJointId("j")].idx_q] = 0.0
    at_q = clearance_frame(mechanism, q)
    fixed = clearance_frame(mechanism, zero) if frame == "housing" else at_q
    model = mechanism.model
    data = model.createData()
    pin.forwardKinematics(model, data, q)
    point = data.oMi[model.getJointId("j")].act(ARM)  # world
    moment = np.cross(point - at_q.translation, FORCE) + TORQUE  # about the joint centre
    R = fixed.rotation
    wrench = np.concatenate([R.T @ FORCE, R.T @ moment])  # in the frame K is fixed in
    e = np.linalg.solve(full_stiffness(), wrench)
    return np.concatenate([R @ e[:3], R @ e[3:]])


def solved(mechanism: cp.Mechanism, q: np.ndarray | None = None) -> np.ndarray:
    """The solver's deflection of the joint in world axes [m, rad]."""
    answer = mechanism.solve(
        [PointForce("arm", FORCE, ARM), Torque("arm", TORQUE)], gravity=False, q=q
    )
    assert answer.ok
    R = clearance_frame(mechanism, answer.configuration.q).rotation
    e = answer.deflection("j")
    return np.concatenate([R @ e[:3], R @ e[3:]])


@pytest.mark.parametrize("frame", ["housing", "part"])
def test_deflection_is_k_inverse_w_in_the_chosen_frame(frame):
    mechanism = tilted_joint(frame)
    expected = by_hand(mechanism, frame)
    found = solved(mechanism)
    scale = np.abs(expected).max()
    assert found == pytest.approx(expected, rel=0.0, abs=1e-9 * scale)


def test_the_default_is_the_housing_and_the_two_differ():
    """Left out, the frame is the housing's; at q = 0.5 the two frames' deflections differ by
    a sizeable share (the K is far from symmetric about the axis)."""
    housing, part = solved(tilted_joint(None)), solved(tilted_joint("part"))
    assert housing == pytest.approx(by_hand(tilted_joint(None), "housing"), rel=1e-9, abs=1e-15)
    apart = np.linalg.norm(housing - part) / np.linalg.norm(housing)
    assert apart > 0.05


def test_at_zero_angle_the_frames_agree_and_a_batch_turns_k_per_case():
    """At the joint's zero the housing's frame is the part's; along a sweep, solve_many turns
    K at each case as a single solve does."""
    housing, part = tilted_joint("housing"), tilted_joint("part")
    zero = housing.q_nominal * 0.0
    assert solved(housing, zero) == pytest.approx(solved(part, zero), rel=1e-12, abs=1e-18)
    angles = [-1.0, 0.0, 0.5, 2.0]
    loads = [[PointForce("arm", FORCE, ARM), Torque("arm", TORQUE)]] * len(angles)
    batch = housing.solve_many(loads, configurations=[[a] for a in angles], gravity=False)
    assert type(batch).__name__ == "ElasticTreeBatch"  # the arrays' lane, K turned per case
    deflections = batch.deflections("j")
    moved = batch.frame_displacements("arm")
    for n, (answer, angle) in enumerate(zip(batch, angles)):
        single = housing.solve(loads[0], gravity=False, q=[angle])
        expected = single.deflection("j")
        tight = {"rel": 0.0, "abs": 1e-9 * np.abs(expected).max()}
        assert answer.deflection("j") == pytest.approx(expected, **tight)
        assert deflections[n] == pytest.approx(expected, **tight)
        translation, rotation = single.frame_displacement("arm")
        assert moved[0][n] == pytest.approx(
            translation, rel=0.0, abs=1e-9 * np.abs(translation).max()
        )
        assert moved[1][n] == pytest.approx(rotation, rel=0.0, abs=1e-9 * np.abs(rotation).max())
        assert batch.energy[n] == pytest.approx(single.energy, rel=1e-9)
        if angle == ANGLE:  # the nominal angle: against the hand computation as well
            expected = by_hand(housing, "housing")
            R = clearance_frame(housing, answer.configuration.q).rotation
            e = answer.deflection("j")
            world = np.concatenate([R @ e[:3], R @ e[3:]])
            assert world == pytest.approx(expected, rel=0.0, abs=1e-9 * np.abs(expected).max())


def test_the_exact_model_reads_the_housing_k_turned_at_q():
    """The exact model fixes its springs' directions in the part: a housing K is turned into the
    part's frame at q for it. Reference: the part-frame K computed here by hand, G^T K G with G
    from Pinocchio's placements at 0 and at q, given as stiffness_frame="part"; and the
    small-displacement deflection K^-1 W, which the exact one matches to first order."""
    loads = [PointForce("arm", FORCE, ARM), Torque("arm", TORQUE)]
    housing = tilted_joint("housing")
    zero = housing.q_nominal * 0.0
    turn = (
        clearance_frame(housing, zero).rotation.T
        @ clearance_frame(housing, housing.q_nominal).rotation
    )
    G = np.kron(np.eye(2), turn)  # the part's axes in the housing's: diag(R, R)
    in_part = G.T @ full_stiffness() @ G
    by_hand_part = cp.loads(_with_matrix(in_part))
    exact = housing.solve(loads, gravity=False, exact=True)
    reference = by_hand_part.solve(loads, gravity=False, exact=True)
    assert exact.ok and exact.formulation == "exact" and exact.mechanism is housing
    e, expected = exact.deflection("j"), reference.deflection("j")
    assert e == pytest.approx(expected, rel=0.0, abs=1e-9 * np.abs(expected).max())
    linear = housing.solve(loads, gravity=False).deflection("j")
    assert e == pytest.approx(linear, rel=0.0, abs=5e-3 * np.abs(linear).max())
    part = tilted_joint("part").solve(loads, gravity=False, exact=True).deflection("j")
    assert np.linalg.norm(part - e) > 0.05 * np.linalg.norm(e)


def test_an_axisymmetric_k_is_the_same_in_both_frames():
    """The attributes (radial, axial, tilt, drive) give a K symmetric about the axis: turned by
    the joint's angle it is unchanged, so the frame makes no difference."""
    text = 'radial_stiffness="2e7" axial_stiffness="5e7" tilt_stiffness="3e4" drive_stiffness="1e4"'

    def joint(frame: str) -> cp.Mechanism:
        return cp.loads(f"""<?xml version="1.0"?>
<robot name="r"><link name="base"/><link name="arm"/>
  <joint name="j" type="revolute"><parent link="base"/><child link="arm"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="1"/></joint>
  <clearance_pin><joint name="j" driven="true" q="{ANGLE}" {text} stiffness_frame="{frame}"/>
  </clearance_pin></robot>""")

    loads = [PointForce("arm", FORCE, ARM), Torque("arm", TORQUE)]
    housing = joint("housing").solve(loads, gravity=False)
    part = joint("part").solve(loads, gravity=False)
    assert housing.deflection("j") == pytest.approx(part.deflection("j"), rel=1e-12, abs=1e-18)


def test_bad_frames_are_refused_naming_the_joint(tmp_path):
    with pytest.raises(ModelError, match=r"joint.*'j'.*stiffness_frame='child'.*housing, part"):
        tilted_joint("child")
    loop = """<?xml version="1.0"?>
<robot name="shaft"><link name="ground"/><link name="shaft"/>
  <joint name="left" type="floating"><parent link="ground"/><child link="shaft"/></joint>
  <clearance_pin>
    <joint name="left" type="spherical" radial_clearance="1e-5"/>
    <loop_joint name="right" frame_a="ground" frame_b="shaft" type="spherical"
                radial_clearance="1e-5" radial_stiffness="1e7" stiffness_frame="part"/>
  </clearance_pin></robot>"""
    with pytest.raises(ModelError, match=r"right.*stiffness_frame=\"part\" on a loop joint"):
        cp.loads(loop)


def test_the_toml_clearance_file_reads_the_frame(tmp_path):
    """A TOML clearance file: stiffness_frame is a string, the matrix 36 numbers."""
    urdf = tmp_path / "r.urdf"
    urdf.write_text("""<?xml version="1.0"?>
<robot name="r"><link name="base"/><link name="arm"/>
  <joint name="j" type="revolute"><parent link="base"/><child link="arm"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="1"/></joint></robot>""")
    play = tmp_path / "play.toml"
    values = [float(v) for v in full_stiffness().ravel()]
    play.write_text(f'[joints.j]\ndriven = true\nstiffness = {values}\nstiffness_frame = "part"\n')
    mechanism = cp.load(str(urdf), clearances=str(play))
    assert mechanism.joint("j").clearance.stiffness_frame == "part"
    play.write_text(f"[joints.j]\ndriven = true\nstiffness = {values}\nstiffness_frame = 1\n")
    with pytest.raises(ModelError, match="stiffness_frame = 1 must be a string"):
        cp.load(str(urdf), clearances=str(play))
