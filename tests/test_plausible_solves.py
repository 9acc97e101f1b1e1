"""Answers of values that are valid but unlikely to be meant (issue 33 item 5): a spring of the
wrong unit deflecting far beyond any play warns after the solve (single solves and batches, once
per call, naming the joint and the deflection); a configuration that moves a locked joint off its
lock is refused, naming the joint and the lock's value.

The deflection named is checked against the statics computed here: a drive spring in series
with its joint turns by tau_j / k, tau_j the joint's load torque from Pinocchio's own frame
Jacobian and generalized gravity (no solver code).
"""

from __future__ import annotations

import re
import warnings

import numpy as np
import pinocchio as pin
import pytest

import clearance_pin as cp
from clearance_pin import ArgumentError, PointForce
from clearance_pin.errors import SuspectValueWarning

FORCE = np.array([20.0, -30.0, -50.0])  # [N] at the flange, world axes
POSE = np.array([0.3, -1.0, 1.2, -0.8, 1.1, 0.4])  # [rad]


def ur5(tmp_path, stiffness: float):
    """The UR5 of example-robot-data as shipped with 10 um of play and drives of
    ``stiffness`` [N m/rad] in a TOML clearance file, at POSE."""
    from test_auto_bound import example_robot_urdf

    urdf = tmp_path / "ur5.urdf"
    urdf.write_text(example_robot_urdf("ur_description/urdf/ur5_robot.urdf"))
    play = tmp_path / "play.toml"
    joints = "".join(
        f"[joints.{name}]\nq = {float(value)!r}\n"
        for name, value in zip(
            ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint"]
            + [f"wrist_{i}_joint" for i in (1, 2, 3)],
            POSE,
        )
    )
    play.write_text(
        f"""[defaults.revolute]
type = "revolute"
radial_clearance = 1e-5
axial_clearance = 5e-6
length = 0.03
driven = true
drive_stiffness = {stiffness!r}
{joints}"""
    )
    return cp.load(str(urdf), clearances=str(play))


def drive_turns(mechanism) -> np.ndarray:
    """Each drive's spring turn tau_j / k under FORCE at tool0 [rad] per unit of 1/k: the load
    torque J^T F (Pinocchio's frame Jacobian, LOCAL_WORLD_ALIGNED)."""
    model = mechanism.model
    data = model.createData()
    jacobian = pin.computeFrameJacobian(
        model, data, POSE, model.getFrameId("tool0"), pin.LOCAL_WORLD_ALIGNED
    )
    torques: np.ndarray = jacobian[:3].T @ FORCE
    return torques


def test_a_drive_stiffness_typed_in_kn_m_per_rad_warns_after_the_solve(tmp_path):
    """drive_stiffness = 40 (40 kN m/rad typed as N m/rad): the most loaded drive turns by
    |tau| / 40 rad, and the warning names that joint and that turn."""
    mechanism = ur5(tmp_path, 40.0)
    torques = drive_turns(mechanism)
    largest = int(np.argmax(np.abs(torques)))
    name = mechanism.model.names[largest + 1]
    turn = abs(torques[largest]) / 40.0
    assert turn > 0.1
    with pytest.warns(SuspectValueWarning) as caught:
        answer = mechanism.solve([PointForce("tool0", FORCE, [0, 0, 0])], gravity=False)
    assert len(caught) == 1 and caught[0].filename == __file__  # the caller's line
    message = str(caught[0].message)
    assert f"joint {name!r}" in message and "drive_stiffness=4e4" in message
    found = float(re.search(r"deflects by ([0-9.e+-]+) rad", message).group(1))
    assert found == pytest.approx(turn, rel=1e-5)  # the message's 6 digits
    assert answer.ok  # the answer stands: the warning says it is unlikely to be meant
    assert abs(answer.deflection(name)[3]) == pytest.approx(turn, rel=1e-9)


def test_a_sane_drive_stiffness_does_not_warn(tmp_path):
    mechanism = ur5(tmp_path, 4e4)
    with warnings.catch_warnings():
        warnings.simplefilter("error", SuspectValueWarning)
        assert mechanism.solve([PointForce("tool0", FORCE, [0, 0, 0])], gravity=False).ok
        cases = [[PointForce("tool0", FORCE * s, [0, 0, 0])] for s in (0.5, 1.0, 2.0)]
        assert mechanism.solve_many(cases, gravity=False).ok.all()


def test_a_batch_warns_once_naming_the_case(tmp_path):
    """drive_stiffness = 1e-3: every case's drives turn by kilo-radians; one warning for the
    call, naming the largest (the heaviest case)."""
    mechanism = ur5(tmp_path, 1e-3)
    cases = [[PointForce("tool0", FORCE * s, [0, 0, 0])] for s in (0.5, 2.0, 1.0)]
    with pytest.warns(SuspectValueWarning) as caught:
        batch = mechanism.solve_many(cases, gravity=False)
    assert len(caught) == 1 and caught[0].filename == __file__
    message = str(caught[0].message)
    torques = drive_turns(mechanism)
    name = mechanism.model.names[int(np.argmax(np.abs(torques))) + 1]
    assert f"joint {name!r}" in message and "in case 1" in message
    over = int(np.sum(2.0 * np.abs(torques) / 1e-3 > 0.1))  # wrist 3: no torque about tool0
    assert f"{over - 1} more joints too" in message
    found = float(re.search(r"deflects by ([0-9.e+-]+) rad", message).group(1))
    assert found == pytest.approx(2.0 * np.abs(torques).max() / 1e-3, rel=1e-5)
    assert batch.ok.all()


def test_the_resolver_warns_as_the_solves_do(tmp_path):
    """A resolver's re-solve and its batch warn like solve and solve_many (once per call)."""
    mechanism = ur5(tmp_path, 40.0)
    resolver = mechanism.resolver([PointForce("tool0", FORCE, [0, 0, 0])], gravity=False)
    with pytest.warns(SuspectValueWarning, match="joint 'shoulder_lift_joint'") as caught:
        resolver.solve([FORCE])
    assert len(caught) == 1 and caught[0].filename == __file__
    with pytest.warns(SuspectValueWarning, match="in case 1") as caught:
        resolver.solve_many(np.array([[FORCE * 0.5], [FORCE * 2.0]]))
    assert len(caught) == 1


def test_a_bearing_spring_moving_by_more_than_its_part_warns():
    """radial_stiffness = 1 N/m (1 N/um meant as 1e6): a 20 N load moves the journal by 20 m,
    far beyond 5 % of its part's size (its 0.04 m length: no other joint centre)."""
    from test_backlash import cantilever

    mechanism = cantilever(backlash="", extra='radial_stiffness="1"')
    with pytest.warns(SuspectValueWarning, match=r"joint 'drive'.* by 20 m .*part's size 0.04 m"):
        mechanism.solve([PointForce("arm", [0.0, 20.0, 0.0], [0.0, 0.0, 0.0])], gravity=False)


# -- locks -----------------------------------------------------------------------------------------
def locked_arm(lock: str = 'q="0.3"'):
    return cp.loads(f"""<?xml version="1.0"?>
<robot name="two">
  <link name="base"/><link name="upper"/><link name="lower"/>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="1"/></joint>
  <joint name="elbow" type="revolute"><parent link="upper"/><child link="lower"/>
    <origin xyz="0.3 0 0"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="1"/></joint>
  <clearance_pin>
    <joint name="shoulder" type="revolute" radial_clearance="1e-5" length="0.02" driven="true"/>
    <lock joint="elbow" {lock}/>
    <force link="lower" point="0.2 0 0" value="0 -10 0"/>
  </clearance_pin>
</robot>""")


def test_a_configuration_moving_a_locked_joint_is_refused():
    arm = locked_arm()
    assert arm.q_nominal[1] == 0.3 and arm.joint("elbow").locked
    assert arm.solve(q=[0.7, 0.3]).ok  # the locked joint at its lock: solved
    message = r"'elbow' at its lock's value 0.3 rad.*elbow=0.5 rad"
    with pytest.raises(ArgumentError, match=r"^q: expected " + message):
        arm.solve(q=[0.7, 0.5])
    with pytest.raises(ArgumentError, match=r"^configurations\[1\]: expected " + message):
        arm.solve_many(configurations=[[0.1, 0.3], [0.2, 0.5]], loads=[None, None])
    with pytest.raises(ArgumentError, match=message):
        arm.configure(np.array([0.7, 0.5]))
    with pytest.raises(ArgumentError, match=message):
        arm.resolver(q=[0.7, 0.5])
    resolver = arm.resolver([PointForce("lower", [0.0, -10.0, 0.0], [0.2, 0.0, 0.0])])
    with pytest.raises(ArgumentError, match=r"^configurations\[1\]: expected " + message):
        resolver.solve_many(np.array([[[0.0, -5.0, 0.0]]]), [[0.1, 0.3], [0.7, 0.5]])
    batch = arm.solve_many(configurations=[[0.1, 0.3], [0.2, 0.3 + 1e-12]], loads=[None, None])
    assert batch.ok.all()  # round-off from an interpolation is no other value


def test_a_lock_without_a_value_holds_the_nominal_one_and_a_free_joint_is_not_held():
    arm = locked_arm(lock="")
    with pytest.raises(ArgumentError, match=r"'elbow' at its lock's value 0 rad"):
        arm.solve(q=[0.0, 0.2])
    assert not arm.joint("shoulder").locked
    assert arm.solve(q=[1.0, 0.0]).ok  # the shoulder is driven, not locked: it moves


def test_the_accuracy_command_keeps_locked_joints_on_their_locks():
    """clearance-pin accuracy draws random commands of the driven joints: a locked joint (held
    as a driven one) keeps its lock's value, so its poses solve."""
    from clearance_pin.accuracy.command import random_poses

    arm = locked_arm()
    poses = random_poses(arm, 5, 0.5, 0)
    assert np.all(poses[:, 1] == 0.3) and np.ptp(poses[:, 0]) > 0.0
    assert arm.solve_many(configurations=poses, loads=[None] * 5).ok.all()
