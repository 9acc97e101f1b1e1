"""A coupling ties the actual joint values (issue 33 item 1): a driven leader's lost motion and
drive deflection reach its follower, the follower's own deadband and stiffness sit in series,
the motor of a chain's root carries every follower's torque. References from Pinocchio's own
Jacobians and virtual work, no solver code: with Q = J^T F the loads' generalised forces, the
motor's coordinate q_l carries G = Q_l + m Q_f, turns by sign(G) b/2 + G/k inside its drive, and
the tool moves by (J_l + m J_f) dq_l (+ J_f times the follower's own deadband and deflection).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import clearance_pin as cp

MULTIPLIER, OFFSET = 0.5, 0.1  # j2 = 0.5 j1 + 0.1 [rad]: a belt between the two joints
BACKLASH = 2e-4  # the leader's drive [rad]
TOOL = np.array([0.3, 0.0, 0.0])  # on link2 [m]


def belt_arm(leader: str = f'backlash="{BACKLASH}"', follower: str = "", extra: str = "") -> str:
    """A planar two-link arm about z, link lengths 0.4 and 0.3 m, its elbow driven through a belt
    from the shoulder's motor (a <mimic>); journals without play, so that only the drives move."""
    return f"""<?xml version="1.0"?>
<robot name="belt_arm">
  <link name="base"/><link name="link1"/><link name="link2"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="link1"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="link1"/><child link="link2"/>
    <origin xyz="0.4 0 0"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="1"/>
    <mimic joint="j1" multiplier="{MULTIPLIER}" offset="{OFFSET}"/></joint>
  {extra}
  <clearance_pin>
    <joint name="j1" type="revolute" radial_clearance="0" axial_clearance="0" length="0.02"
           driven="true" q="0.3" {leader}/>
    <joint name="j2" type="revolute" radial_clearance="0" axial_clearance="0" length="0.02"
           {follower}/>
  </clearance_pin>
</robot>"""


def point_jacobians(mechanism, frame: str, point: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(world position of ``point`` on ``frame`` [m], its translation Jacobian (3, nv)) at the
    nominal configuration, from Pinocchio alone."""
    model = mechanism.model
    data = model.createData()
    q = mechanism.q_nominal
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    fid = model.getFrameId(frame)
    placement = data.oMf[fid]
    jacobian = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
    lever = placement.rotation @ point
    return placement.act(point), jacobian[:3] - pin.skew(lever) @ jacobian[3:]


def moved(answer, frame: str, point: np.ndarray) -> np.ndarray:
    """The displacement [m] of ``point`` (in ``frame``) from the answer's output ``frame``:
    t + omega x (R point), world axes (a rigid body's small motion)."""
    model, data = answer.mechanism.model, answer.mechanism.model.createData()
    pin.framesForwardKinematics(model, data, answer.mechanism.q_nominal)
    translation, rotation = answer.outputs[frame]
    lever = data.oMf[model.getFrameId(frame)].rotation @ point
    return translation + np.cross(rotation, lever)


def velocity_index(mechanism, joint: str) -> int:
    return mechanism.model.joints[mechanism.model.getJointId(joint)].idx_v


@pytest.mark.parametrize(
    "force", [np.array([3.0, -40.0, 0.0]), np.array([-25.0, 10.0, 0.0])], ids=["down", "back"]
)
def test_a_leader_s_backlash_reaches_its_follower(force):
    """The tool moves by (J_1 + m J_2) sign(G) b/2, G = Q_1 + m Q_2 (virtual work); the motor
    holds -G, each joint's drive torque is minus its own generalised force; the exact model
    agrees to second order (the backlash's rotation times the tool's displacement)."""
    arm = cp.loads(belt_arm())
    load = [cp.PointForce("link2", force, TOOL)]
    answer = arm.solve(load, gravity=False, outputs=["link2"])
    assert answer.ok
    _, jacobian = point_jacobians(arm, "link2", TOOL)
    i1, i2 = velocity_index(arm, "j1"), velocity_index(arm, "j2")
    generalised = jacobian.T @ force
    motor = generalised[i1] + MULTIPLIER * generalised[i2]
    turn = np.sign(motor) * BACKLASH / 2
    expected = (jacobian[:, i1] + MULTIPLIER * jacobian[:, i2]) * turn
    assert np.allclose(
        moved(answer, "link2", TOOL), expected, atol=1e-12 * np.linalg.norm(expected)
    )
    assert answer.torsor("j2")[3] == pytest.approx(MULTIPLIER * turn, abs=1e-15)
    assert answer.motor_torques()["j1"] == pytest.approx(-motor, rel=1e-10)
    assert answer.drive_torque("j1") == pytest.approx(-generalised[i1], rel=1e-10)
    assert answer.drive_torque("j2") == pytest.approx(-generalised[i2], rel=1e-10)
    assert answer.residuals["statics"] < 1e-10
    exact = arm.solve(load, gravity=False, outputs=["link2"], exact=True)
    assert exact.ok
    second_order = BACKLASH * np.linalg.norm(expected)
    assert np.allclose(moved(exact, "link2", TOOL), expected, atol=3 * second_order)
    # the follower's exact torsor holds its coupled turn too (found by a new user: it was 0)
    assert exact.torsor("j2")[3] == pytest.approx(MULTIPLIER * turn, abs=BACKLASH**2)
    assert exact.difference["torsor_rotation_rad"] < BACKLASH**2


def test_a_force_through_the_leader_s_axis_moves_the_tool_through_the_coupling():
    """A force whose line crosses j1's axis does no work on j1 (Q_1 = 0) but turns the elbow:
    the motor still holds m Q_2 and its backlash moves the tool (it stood still when the
    follower was held at the leader's command)."""
    arm = cp.loads(belt_arm())
    model, data = arm.model, arm.model.createData()
    pin.framesForwardKinematics(model, data, arm.q_nominal)
    on_axis = data.oMf[model.getFrameId("link2")].actInv(np.zeros(3))  # j1's axis in link2
    force = np.array([0.0, 0.0, 0.0])
    force[:2] = [-0.6, 0.8]  # any direction in the plane; its line passes the world origin
    force *= 30.0
    answer = arm.solve([cp.PointForce("link2", force, on_axis)], gravity=False, outputs=["link2"])
    _, jacobian = point_jacobians(arm, "link2", on_axis)
    generalised = jacobian.T @ force
    i1, i2 = velocity_index(arm, "j1"), velocity_index(arm, "j2")
    assert abs(generalised[i1]) < 1e-12 * abs(generalised[i2])  # no work on j1 by itself
    motor = MULTIPLIER * generalised[i2]
    assert answer.motor_torques()["j1"] == pytest.approx(-motor, rel=1e-10)
    _, tool = point_jacobians(arm, "link2", TOOL)
    expected = (tool[:, i1] + MULTIPLIER * tool[:, i2]) * np.sign(motor) * BACKLASH / 2
    assert np.linalg.norm(expected) > 5e-5  # tens of um
    value = moved(answer, "link2", TOOL)
    assert np.allclose(value, expected, atol=1e-12 * np.linalg.norm(expected))


@pytest.mark.parametrize("exact", [False, True])
def test_the_follower_s_deadband_and_stiffness_sit_in_series(exact):
    """Leader: backlash b1 and drive stiffness k1; follower: deadband b2 and stiffness k2 in
    the coupling: dq_1 = sign(G) b1/2 + G/k1, dq_2 = m dq_1 + sign(Q_2) b2/2 + Q_2/k2."""
    k1, k2, b2 = 2e5, 5e4, 4e-4
    arm = cp.loads(
        belt_arm(
            leader=f'backlash="{BACKLASH}" drive_stiffness="{k1}"',
            follower=f'backlash="{b2}" drive_stiffness="{k2}"',
        )
    )
    force = np.array([3.0, -40.0, 0.0])
    answer = arm.solve(
        [cp.PointForce("link2", force, TOOL)], gravity=False, outputs=["link2"], exact=exact
    )
    assert answer.ok
    _, jacobian = point_jacobians(arm, "link2", TOOL)
    i1, i2 = velocity_index(arm, "j1"), velocity_index(arm, "j2")
    generalised = jacobian.T @ force
    motor = generalised[i1] + MULTIPLIER * generalised[i2]
    dq1 = np.sign(motor) * BACKLASH / 2 + motor / k1
    dq2 = MULTIPLIER * dq1 + np.sign(generalised[i2]) * b2 / 2 + generalised[i2] / k2
    expected = jacobian[:, i1] * dq1 + jacobian[:, i2] * dq2
    # linear: to round-off; exact: to second order (the turns times the displacement)
    tolerance = 1e-12 if not exact else 3 * (abs(dq1) + abs(dq2))
    value = moved(answer, "link2", TOOL)
    assert np.allclose(value, expected, atol=tolerance * np.linalg.norm(expected))
    assert answer.motor_torques()["j1"] == pytest.approx(-motor, rel=1e-9 if not exact else 1e-3)


def test_a_mimic_chain_s_motor_carries_every_follower():
    """j3 follows j2 follows j1 (a second belt): the motor holds -(Q_1 + m2 Q_2 + m2 m3 Q_3)
    (virtual work through the chain) and every joint turns with the motor's backlash."""
    m3 = -2.0
    third = f"""<link name="link3"/>
    <joint name="j3" type="revolute"><parent link="link2"/><child link="link3"/>
    <origin xyz="0.3 0 0"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="1"/>
    <mimic joint="j2" multiplier="{m3}" offset="0"/></joint>"""
    text = belt_arm(extra=third).replace(
        "</clearance_pin>",
        '<joint name="j3" type="revolute" radial_clearance="0" axial_clearance="0"'
        ' length="0.02"/></clearance_pin>',
    )
    arm = cp.loads(text)
    point = np.array([0.2, 0.05, 0.0])
    force = np.array([10.0, -30.0, 0.0])
    answer = arm.solve([cp.PointForce("link3", force, point)], gravity=False, outputs=["link3"])
    assert answer.ok
    _, jacobian = point_jacobians(arm, "link3", point)
    q1, q2, q3 = (velocity_index(arm, name) for name in ("j1", "j2", "j3"))
    generalised = jacobian.T @ force
    motor = generalised[q1] + MULTIPLIER * generalised[q2] + MULTIPLIER * m3 * generalised[q3]
    assert answer.motor_torques()["j1"] == pytest.approx(-motor, rel=1e-10)
    turn = np.sign(motor) * BACKLASH / 2
    assert answer.torsor("j3")[3] == pytest.approx(m3 * MULTIPLIER * turn, abs=1e-15)
    for name, index in (("j1", q1), ("j2", q2), ("j3", q3)):
        assert answer.drive_torque(name) == pytest.approx(-generalised[index], rel=1e-9)
    assert answer.reaction("j2").residual < 1e-12


def test_batches_and_resolvers_give_the_single_solves():
    """solve_many and the resolver of the coupled arm with springs give each single solve's
    outputs, drive torques and motor torques."""
    arm = cp.loads(
        belt_arm(
            leader=f'backlash="{BACKLASH}" drive_stiffness="2e5"',
            follower='backlash="4e-4" drive_stiffness="5e4"',
        )
    )
    rng = np.random.default_rng(3)
    loads = [
        [cp.PointForce("link2", [fx, fy, 0.0], TOOL)] for fx, fy in rng.normal(size=(6, 2)) * 30
    ]
    batch = arm.solve_many(loads, gravity=False, outputs=["link2"])
    drives = batch.drive_torques()
    for k, load in enumerate(loads):
        single = arm.solve(load, gravity=False, outputs=["link2"])
        assert np.allclose(batch[k].outputs["link2"][0], single.outputs["link2"][0], atol=1e-15)
        assert drives["j1"][k] == pytest.approx(single.drive_torque("j1"), rel=1e-9)
        assert batch[k].motor_torques()["j1"] == pytest.approx(
            single.motor_torques()["j1"], rel=1e-9
        )


@pytest.mark.parametrize(
    "mimics", [("j1", "j1"), ("j2", "j3", "j3", "j2")], ids=["itself", "cycle"]
)
def test_cycles_of_couplings_are_refused_by_name(mimics):
    """A joint mimicking itself, or two joints mimicking each other, is refused naming them."""
    links = "".join(f'<link name="l{k}"/>' for k in range(4))
    joints = ""
    for k, name in enumerate(("j1", "j2", "j3")):
        follow = dict(zip(mimics[::2], mimics[1::2])).get(name)
        mimic = f'<mimic joint="{follow}"/>' if follow else ""
        joints += f"""<joint name="{name}" type="revolute"><parent link="l{k}"/>
          <child link="l{k + 1}"/><origin xyz="0.2 0 0"/><axis xyz="0 0 1"/>
          <limit lower="-3" upper="3" effort="1" velocity="1"/>{mimic}</joint>"""
    text = f"""<robot name="loop">{links}{joints}<clearance_pin>
      <default joint_type="revolute" type="revolute" radial_clearance="1e-5" length="0.02" driven="true"/>
    </clearance_pin></robot>"""
    with pytest.raises(cp.ModelError, match=r"cycle \((j\d -> )+j\d"):
        cp.loads(text)


def test_the_accuracy_map_credits_a_coupled_turn_to_its_leader():
    """The elbow turns with the shoulder's drive: the map's shares name the shoulder's backlash
    and drive compliance, (J_1 + m J_2) sign(G) b/2 and (J_1 + m J_2) G/k at the tool (found by
    a new user: it credited them to the elbow, as backlash), and sum to the tool's motion."""
    k1 = 2e5
    arm = cp.loads(belt_arm(leader=f'backlash="{BACKLASH}" drive_stiffness="{k1}"'))
    force = np.array([3.0, -40.0, 0.0])
    _, jacobian = point_jacobians(arm, "link2", TOOL)
    i1, i2 = velocity_index(arm, "j1"), velocity_index(arm, "j2")
    generalised = jacobian.T @ force
    motor = generalised[i1] + MULTIPLIER * generalised[i2]
    _, origin = point_jacobians(arm, "link2", np.zeros(3))  # the map's output: link2's origin
    column = origin[:, i1] + MULTIPLIER * origin[:, i2]
    amap = arm.accuracy(
        "link2", [arm.q_nominal], payloads=[[cp.PointForce("link2", force, TOOL)]], gravity=False
    )
    shares = dict(((source, joint), value) for source, joint, value in amap.ranking())
    backlash = np.linalg.norm(column) * BACKLASH / 2
    compliance = np.linalg.norm(column) * abs(motor) / k1
    assert shares[("backlash", "j1")] == pytest.approx(backlash, rel=1e-9)
    assert shares[("drive compliance", "j1")] == pytest.approx(compliance, rel=1e-9)
    assert all(value < 1e-9 * backlash for (_, joint), value in shares.items() if joint == "j2")


def test_a_lock_or_a_drive_term_a_coupling_cannot_hold_is_refused_by_name():
    """Found by a new user: a lock on a follower whose leader moves was silently ignored (the
    follower moved with its leader), and backlash on the follower of a passive leader asked for
    driven="true", which the next error then refused. Both now say what holds the follower."""
    locked = belt_arm().replace("</clearance_pin>", '<lock joint="j2"/></clearance_pin>')
    locked = locked.replace(
        '<joint name="j2" type="revolute" radial_clearance="0" axial_clearance="0" length="0.02"\n'
        "           />",
        "",
    )
    with pytest.raises(cp.ModelError, match=r"lock joint='j2'.*follows 'j1'.*lock the leader"):
        cp.loads(locked)
    passive = belt_arm(leader="", follower='backlash="4e-4"').replace('driven="true"', "")
    with pytest.raises(cp.ModelError, match=r"j2.*backlash belong to a drive.*follows 'j1'"):
        cp.loads(passive)


def test_a_follower_put_out_of_its_limits_by_its_leader_is_said_so():
    """Found by a new user (the PR2's parallel gripper joints): a follower whose mimic puts it
    outside its URDF limits was warned with a degrees-for-radians hint; the warning now says
    that its leader's value puts it there."""
    arm = cp.loads(
        belt_arm().replace(
            '<axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="1"/>\n'
            '    <mimic joint="j1"',
            '<axis xyz="0 0 1"/><limit lower="0" upper="0.2" effort="10" velocity="1"/>\n'
            '    <mimic joint="j1"',
        )
    )
    q = arm.q_nominal.copy()
    q[arm.model.joints[arm.model.getJointId("j1")].idx_q] = 0.4  # j2 = 0.5 x 0.4 + 0.1 = 0.3
    with pytest.warns(cp.SuspectValueWarning, match=r"'j2'.*follows 'j1' through its <mimic>"):
        arm.solve_many(configurations=[q], gravity=False)
