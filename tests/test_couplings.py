"""Coupled joints (issue 23 item 2): a URDF <mimic> read as shipped, the follower held through
its driven leader; <lock> holds a joint the study leaves out. References by hand (statics of a
lever) and Pinocchio's own kinematics, no solver code.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import clearance_pin as cp

MULTIPLIER, OFFSET = -0.5, 0.1  # follower = -0.5 x leader + 0.1 [rad]
LEVER, FORCE = 0.2, 30.0  # [m], [N]


def gear_pair(leader_q: float = 0.4, leader: str = 'driven="true"', extra: str = "") -> str:
    """Two shafts about z, 0.3 m apart; the follower mimics the leader and carries a lever
    along its x axis with a force along y at its tip."""
    return f"""<?xml version="1.0"?>
<robot name="gears">
  <link name="base"/>
  <link name="pinion"/>
  <link name="wheel"/>
  <joint name="leader" type="revolute"><parent link="base"/><child link="pinion"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="1"/></joint>
  <joint name="follower" type="revolute"><parent link="base"/><child link="wheel"/>
    <origin xyz="0.3 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="10" velocity="1"/>
    <mimic joint="leader" multiplier="{MULTIPLIER}" offset="{OFFSET}"/></joint>
  <clearance_pin>
    <joint name="leader" type="revolute" radial_clearance="1e-5" length="0.02" {leader}
           q="{leader_q}"/>
    <joint name="follower" type="revolute" radial_clearance="1e-5" length="0.02" {extra}/>
    <force link="wheel" point="{LEVER} 0 0" value="0 {FORCE} 0"/>
  </clearance_pin>
</robot>"""


def test_the_follower_is_held_through_its_leader():
    """q_follower = m q_leader + o at the nominal pose, after configure and along solve_many;
    the coupling holds the follower against the lever's moment -F r (by hand: a force F along
    the follower's y at r along its x makes F r about z; the parent holds its opposite)."""
    gears = cp.loads(gear_pair())
    model = gears.model
    leader = model.joints[model.getJointId("leader")].idx_q
    follower = model.joints[model.getJointId("follower")].idx_q
    assert gears.q_nominal[follower] == pytest.approx(MULTIPLIER * 0.4 + OFFSET, abs=1e-15)
    q = gears.q_nominal.copy()
    q[leader] = 1.1
    assert gears.configure(q).q[follower] == pytest.approx(MULTIPLIER * 1.1 + OFFSET, abs=1e-15)
    answer = gears.solve(gravity=False)
    assert answer.ok
    angle = MULTIPLIER * 0.4 + OFFSET  # the force is along world y: its lever arm turns with q
    moment = LEVER * FORCE * np.cos(angle)
    drive = answer.reaction("follower").drive
    assert drive[3] == pytest.approx(-moment, rel=1e-12)
    assert answer.reaction("leader").drive[3] == pytest.approx(0.0, abs=1e-12)
    # the leader's motor carries m times the coupling's torque (module docstring)
    assert answer.drive_torque("follower") == pytest.approx(-moment, rel=1e-12)
    assert answer.motor_torques() == pytest.approx({"leader": MULTIPLIER * -moment}, rel=1e-12)
    assert "motor of leader" in answer.table()
    turns = [q.copy() for q in np.tile(gears.q_nominal, (5, 1))]
    for k, pose in enumerate(turns):
        pose[leader] = 0.2 * k
    batch = gears.solve_many(configurations=turns, gravity=False)
    for k in range(5):
        placed = batch[k].configuration.q
        assert placed[follower] == pytest.approx(MULTIPLIER * 0.2 * k + OFFSET, abs=1e-15)


def test_a_coupling_deadband_is_the_followers_backlash():
    """backlash on the follower: the coupling's deadband; the lever's moment turns the follower
    by +b/2 (its moment about z is positive)."""
    gears = cp.loads(gear_pair(extra='backlash="0.004"'))
    answer = gears.solve(gravity=False)
    assert answer.ok and answer.torsor("follower")[3] == pytest.approx(0.002, abs=1e-12)


@pytest.mark.parametrize("exact", [False, True])
def test_a_passive_leader_ties_two_free_joints(exact):
    """Leader and follower both free, tied by the coupling dq_f = m dq_l: the lever's moment M
    on the follower is balanced through the coupling by a torque T = -m M on the leader's body
    (virtual work T dq_l + M m dq_l = 0, by hand); the coupling holds -M on the follower and
    m M on the leader (its reaction: mu and -m mu, mu = -M). An unbalanced torque works along
    the tied motion: no equilibrium."""
    angle = MULTIPLIER * 0.4 + OFFSET
    moment = LEVER * FORCE * np.cos(angle)  # the follower's lever, about z
    balance = f'<torque link="pinion" value="0 0 {float(-MULTIPLIER * moment)!r}"/>'
    gears = cp.loads(gear_pair(leader="").replace("</clearance_pin>", balance + "</clearance_pin>"))
    assert not any(j.driven for j in gears.tree_joints)
    answer = gears.solve(gravity=False, exact=exact)
    assert answer.ok
    assert answer.reaction("follower").drive[3] == pytest.approx(-moment, rel=1e-9)
    assert answer.reaction("leader").drive[3] == pytest.approx(MULTIPLIER * moment, rel=1e-9)
    assert answer.reaction("follower").residual < 1e-12
    assert answer.motor_torques() == {}  # no motor: both joints passive
    # the tied motion keeps the coupling (its play aside): both turn together or not at all
    spin_f, spin_l = answer.torsor("follower")[3], answer.torsor("leader")[3]
    assert spin_f == pytest.approx(MULTIPLIER * spin_l, abs=1e-12)
    unbalanced = gear_pair(leader="").replace(
        "</clearance_pin>", '<torque link="pinion" value="0 0 1.0"/></clearance_pin>'
    )
    with pytest.raises(cp.UnboundedLoadError, match=r"leader|follower"):
        cp.loads(unbalanced).solve(gravity=False)


def test_a_passive_leader_s_driven_follower_and_a_contradicting_q_are_refused():
    with pytest.raises(cp.ModelError, match="leader 'leader' is not driven, so it is not"):
        cp.loads(gear_pair(leader="", extra='driven="true"'))
    with pytest.raises(cp.ModelError, match="differs from its <mimic>"):
        cp.loads(gear_pair(extra='q="0.7"'))


def test_the_panda_as_shipped_with_its_fingers_locked(tmp_path):
    """The Panda URDF of example-robot-data unmodified (its second finger mimics the first),
    a TOML clearance file beside it locking the first finger: it loads, both fingers stay where
    the lock and the mimic put them, and every body balances (statics from the reported
    reactions, tests/corpus_statics.py)."""
    corpus = pytest.importorskip("test_corpus_robots")
    statics = pytest.importorskip("corpus_statics")
    urdf = corpus.vendor_file(corpus.ROBOTS["panda"][0])
    play = tmp_path / "panda_play.toml"
    play.write_text(
        """unit = "mm"
[defaults.revolute]
type = "revolute"
radial_clearance = 0.010
axial_clearance = 0.005
length = 30
driven = true
[locks.panda_finger_joint1]
q = 20
[[forces]]
link = "panda_hand_tcp"
point = [0, 0, 0]
value = [10.0, -5.0, -20.0]
"""
    )
    panda = cp.load(str(urdf), clearances=str(play))
    model = panda.model
    for finger in ("panda_finger_joint1", "panda_finger_joint2"):
        assert panda.q_nominal[model.joints[model.getJointId(finger)].idx_q] == 0.02
    answer = panda.solve(gravity=True)
    assert answer.ok
    assert statics.reaction_residual(answer, answer.loads) <= 1e-10


def test_bad_locks_are_named(tmp_path):
    model = gear_pair().replace(
        '<joint name="follower" type="revolute" radial_clearance="1e-5" length="0.02" />',
        '<lock joint="nowhere"/>',
    )
    with pytest.raises(cp.ModelError, match="joint= must name a movable"):
        cp.loads(model)
    both = gear_pair().replace("</clearance_pin>", '<lock joint="leader"/></clearance_pin>')
    with pytest.raises(cp.ModelError, match="both locked and given"):
        cp.loads(both)


MJCF_GEARS = """<mujoco model="gears">
  <compiler angle="radian"/>
  <worldbody>
    <body name="base">
      <body name="pinion">
        <joint name="leader" type="hinge" axis="0 0 1" range="-3 3" ref="0.2"/>
        <geom type="cylinder" size="0.02 0.01" mass="0.1"/>
      </body>
      <body name="wheel" pos="0.3 0 0">
        <joint name="follower" type="hinge" axis="0 0 1" range="-3 3" ref="0.3"/>
        <geom type="capsule" fromto="0 0 0 0.2 0 0" size="0.01" mass="0.2"/>
      </body>
    </body>
  </worldbody>
  <equality>
    <joint joint1="follower" joint2="leader" polycoef="0.1 -0.5 0 0 0"/>
  </equality>
</mujoco>"""
MJCF_PLAY = {
    "leader": {"type": "revolute", "radial_clearance": 1e-5, "length": 0.02, "driven": True,
               "q": 0.7},
    "follower": {"type": "revolute", "radial_clearance": 1e-5, "length": 0.02},
}  # fmt: skip


def test_an_mjcf_joint_equality_is_read_as_mujoco_means_it(tmp_path):
    """<equality><joint polycoef> about MuJoCo's reference pose (each joint at its ref): the
    follower is placed where MuJoCo's own constraint residual is zero (MuJoCo's reading, not the
    library's); a coupling beyond linear is refused."""
    mujoco = pytest.importorskip("mujoco")
    path = tmp_path / "gears.xml"
    path.write_text(MJCF_GEARS)
    gears = cp.load(str(path), clearances=MJCF_PLAY)
    model = gears.model
    q = gears.q_nominal
    leader = q[model.joints[model.getJointId("leader")].idx_q]
    follower = q[model.joints[model.getJointId("follower")].idx_q]
    reference = mujoco.MjModel.from_xml_string(MJCF_GEARS)
    data = mujoco.MjData(reference)
    data.qpos[:] = [leader, follower]  # MuJoCo's qpos is Pinocchio's q here (hinges)
    mujoco.mj_forward(reference, data)
    assert leader == 0.7 and abs(data.efc_pos[: data.ne][0]) <= 1e-15
    assert gears.solve(gravity=True).ok
    cubic = MJCF_GEARS.replace('polycoef="0.1 -0.5 0 0 0"', 'polycoef="0.1 -0.5 0.2 0 0"')
    path.write_text(cubic)
    with pytest.raises(cp.ModelError, match="beyond linear"):
        cp.load(str(path), clearances=MJCF_PLAY)


def test_a_pinocchio_mimic_model_reads_as_its_urdf():
    """from_model on a pin.Model built with mimic=True (issue 23): its mimic joint becomes the
    prismatic joint it moves along, tied to its leader; the same answer as the URDF read with its
    <mimic> by clearance_pin.load, and the same kinematics as Pinocchio's own mimic=False model
    (the reference); a q of the mimic model's size is read by joint name."""
    gripper = """<robot name="gripper">
  <link name="palm"/><link name="left"/><link name="right"/>
  <joint name="left_finger" type="prismatic"><parent link="palm"/><child link="left"/>
    <axis xyz="0 1 0"/><limit lower="0" upper="0.04" effort="20" velocity="0.2"/></joint>
  <joint name="right_finger" type="prismatic"><parent link="palm"/><child link="right"/>
    <origin xyz="0 0.02 0"/><axis xyz="0 -1 0"/>
    <limit lower="0" upper="0.04" effort="20" velocity="0.2"/>
    <mimic joint="left_finger" multiplier="0.5" offset="0.001"/></joint>
</robot>"""
    clearances = {
        "left_finger": {"driven": True, "type": "prismatic", "radial_clearance": 1e-5,
                        "length": 0.02, "width": 0.01, "height": 0.01},
        "right_finger": {"type": "prismatic", "radial_clearance": 2e-5, "length": 0.02,
                         "width": 0.01, "height": 0.01},
    }  # fmt: skip
    mimic_model = pin.buildModelFromXML(gripper, mimic=True)
    assert mimic_model.nq == 1
    mechanism = cp.from_model(mimic_model, clearances=clearances, q=np.array([0.03]))
    reference = pin.buildModelFromXML(gripper)  # Pinocchio's, without the mimic
    q = mechanism.q_nominal
    assert q[reference.joints[reference.getJointId("right_finger")].idx_q] == pytest.approx(
        0.5 * 0.03 + 0.001
    )
    model, data, expected = mechanism.model, mechanism.model.createData(), reference.createData()
    pin.framesForwardKinematics(model, data, q)
    pin.framesForwardKinematics(reference, expected, q)
    for frame in ("left", "right"):
        placed = data.oMf[model.getFrameId(frame)].homogeneous
        assert placed == pytest.approx(expected.oMf[reference.getFrameId(frame)].homogeneous)
    loads = [cp.PointForce("right", [0.0, 0.0, -5.0], [0.0, 0.0, 0.0])]
    answer = mechanism.solve(loads, gravity=False)
    read = cp.loads(gripper, clearances=clearances).solve(loads, q=q, gravity=False)
    assert answer.ok and answer.torsor("right_finger") == pytest.approx(
        read.torsor("right_finger"), abs=1e-15
    )
