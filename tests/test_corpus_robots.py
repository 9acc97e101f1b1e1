"""Issue 10 corpus: the UR5 and Franka Panda URDFs of example-robot-data with play in every joint.

The vendor files are read from the installed package (test extra ``example-robot-data``, BSD-3) and
never edited: the ``<clearance_pin>`` block (docs/model-format.md) is inserted into the file's
text here. Every revolute joint is a journal: radial play 10 um, axial play 5 um, length 30 mm,
held by its drive; one force at the tool. Checks, all independent of the solver's code:

- closed form: with every joint driven and one tool force, each journal is its own problem (the
  work of the tool wrench is a sum over the joints of its work on each joint's torsor); the
  wrench at the joint centre gives each journal end's direction (derivation in
  ``journal_torsor``);
- per-body statics (tests/corpus_statics.py) from the reported contact forces;
- geometric admissibility in world coordinates: each journal end of the moving part, placed at the
  solved pose, lies within the radial play of the bore axis computed from the housing's own
  frame (parent body placement x URDF joint origin, axis read from the URDF text).
"""

from __future__ import annotations

import re
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from corpus_statics import reaction_residual, statics_residual

import clearance_pin
from clearance_pin import Equilibrium, PointForce, Torque

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "benchmarks"))
import arms  # benchmarks/arms.py: where the vendor files are

RADIAL, AXIAL, LENGTH = 1e-5, 5e-6, 0.03  # [m]
TOOL_FORCE = np.array([20.0, -30.0, -50.0])  # [N], world axes
TOOL_POINT = np.array([0.0, 0.0, 0.05])  # [m], tool frame

ROBOTS = {
    # vendor file, driven joints with their nominal values [rad] (inside the URDF limits), tool
    "ur5": (
        "ur_description/urdf/ur5_robot.urdf",
        {
            "shoulder_pan_joint": 0.3,
            "shoulder_lift_joint": -1.0,
            "elbow_joint": 1.2,
            "wrist_1_joint": -0.8,
            "wrist_2_joint": 0.6,
            "wrist_3_joint": 0.4,
        },
        "tool0",
    ),
    "panda": (
        "panda_description/urdf/panda.urdf",
        {
            "panda_joint1": 0.2,
            "panda_joint2": -0.4,
            "panda_joint3": 0.1,
            "panda_joint4": -2.0,
            "panda_joint5": 0.3,
            "panda_joint6": 1.6,
            "panda_joint7": 0.5,
        },
        "panda_hand_tcp",
    ),
}


def vendor_file(relative: str) -> Path:
    """Path of a file of the installed example-robot-data (benchmarks/arms.py finds it; skips
    when it is not installed)."""
    path = arms.vendor_file(relative)
    if path is None:
        pytest.skip(
            f"example-robot-data with {relative} is not installed (pip install clearance_pin[test])"
        )
    return path


def model_text(robot: str) -> str:
    """The vendor URDF with a <clearance_pin> block inserted before </robot>."""
    relative, joints, tool = ROBOTS[robot]
    text = vendor_file(relative).read_text()
    lines = [
        f'<joint name="{name}" type="revolute" radial_clearance="{RADIAL!r}" '
        f'axial_clearance="{AXIAL!r}" length="{LENGTH!r}" driven="true" q="{q!r}"/>'
        for name, q in joints.items()
    ]
    force = " ".join(repr(float(v)) for v in TOOL_FORCE)
    point = " ".join(repr(float(v)) for v in TOOL_POINT)
    lines.append(f'<force link="{tool}" point="{point}" value="{force}"/>')
    block = "<clearance_pin>\n  " + "\n  ".join(lines) + "\n</clearance_pin>\n"
    assert text.count("</robot>") == 1
    # the Panda's second finger mimics the first; clearance_pin refuses mimic joints (issue 10
    # finding 8) and the fingers are not studied here: drop the coupling (an independent finger)
    text = re.sub(r"<mimic[^>]*/>", "", text)
    return text.replace("</robot>", block + "</robot>")


def urdf_joints(robot: str) -> dict[str, dict]:
    """Joint origin (translation, rotation) and axis of every movable joint, read from the URDF
    text with ElementTree (not through Pinocchio or clearance_pin)."""
    root = ET.fromstring(vendor_file(ROBOTS[robot][0]).read_text())
    out = {}
    for joint in root.findall("joint"):
        if joint.get("type") == "fixed":
            continue
        origin = joint.find("origin")
        xyz = np.array([float(v) for v in (origin.get("xyz", "0 0 0")).split()])
        rpy = np.array([float(v) for v in (origin.get("rpy", "0 0 0")).split()])
        axis = np.array([float(v) for v in joint.find("axis").get("xyz").split()])
        out[joint.get("name")] = {
            "origin": pin.SE3(pin.rpy.rpyToMatrix(rpy), xyz),
            "axis": axis / np.linalg.norm(axis),
            "parent": joint.find("parent").get("link"),
        }
    return out


MECHANISMS: dict[str, clearance_pin.Mechanism] = {}


def mechanism(robot: str) -> clearance_pin.Mechanism:
    if robot not in MECHANISMS:
        MECHANISMS[robot] = clearance_pin.loads(model_text(robot))
    return MECHANISMS[robot]


def tool_loads(robot: str) -> list:
    return [PointForce(ROBOTS[robot][2], TOOL_FORCE, TOOL_POINT)]


def journal_torsor(force, moment, radial, axial, length) -> np.ndarray:
    r"""Closed-form torsor (u, v, w, alpha, beta, gamma) [m, rad] of a driven journal.

    Derivation (clearance frame, x = axis e): the child carries the external wrench (f, m) at the
    joint centre; the contact forces of the parent, r+ and r- at x = +/- L/2, balance it:
    r+ + r- = -P f and (L/2) e x (r+ - r-) = -P m, so r+/- = -P f / 2 -/+ (e x m) / L. A journal
    end is pushed against the bore opposite to its contact force, along
    a+/- = P f / 2 +/- (m x e) / L, and settles at delta+/- = c a / |a|. The potential
    -(f . V + m . Omega) is separable in (delta+, delta-, u), so these are the optimum; then
    V_radial = (delta+ + delta-) / 2, Omega = e x (delta+ - delta-) / L, u = c_a sign(f . e),
    alpha = 0 (driven).
    """
    e = np.array([1.0, 0.0, 0.0])
    projector = np.eye(3) - np.outer(e, e)
    ends = []
    for sign in (1.0, -1.0):
        a = projector @ force / 2.0 + sign * np.cross(moment, e) / length
        ends.append(radial * a / np.linalg.norm(a))
    plus, minus = ends
    translation = (plus + minus) / 2.0
    rotation = np.cross(e, plus - minus) / length
    return np.array([axial * np.sign(force[0]), translation[1], translation[2], 0.0, *rotation[1:]])


def nominal_placements(mech):
    data = mech.model.createData()
    pin.framesForwardKinematics(mech.model, data, mech.configure(None).q)
    return data


@pytest.mark.parametrize("robot", sorted(ROBOTS))
def test_loads_without_mesh_directory(robot):
    """Solving needs no mesh: the vendor text loads without a mesh directory or ROS_PACKAGE_PATH
    (issue 10 finding 8)."""
    assert clearance_pin.loads(model_text(robot)).solve(loads=tool_loads(robot)).ok


@pytest.mark.parametrize("robot", sorted(ROBOTS))
def test_clearance_frames_follow_the_urdf_axes(robot):
    """The clearance frame's x axis is the URDF <axis> (docs), read independently from the text."""
    mech = mechanism(robot)
    axes = urdf_joints(robot)
    for name in ROBOTS[robot][1]:
        rotation = mech.joint(name).rotation
        np.testing.assert_allclose(rotation[:, 0], axes[name]["axis"], atol=1e-12)
        np.testing.assert_allclose(rotation.T @ rotation, np.eye(3), atol=1e-12)


@pytest.mark.parametrize("robot", sorted(ROBOTS))
def test_every_journal_matches_its_closed_form(robot):
    mech = mechanism(robot)
    eq = mech.solve(loads=tool_loads(robot))
    assert eq.ok
    data = nominal_placements(mech)
    tool = mech.model.getFrameId(ROBOTS[robot][2])
    tool_point = data.oMf[tool].act(TOOL_POINT)
    for name in ROBOTS[robot][1]:
        joint = mech.joint(name)
        placement = data.oMi[joint.joint_id]
        rotation = placement.rotation @ joint.rotation  # clearance frame in the world
        force = rotation.T @ TOOL_FORCE
        moment = rotation.T @ np.cross(tool_point - placement.translation, TOOL_FORCE)
        expected = journal_torsor(force, moment, RADIAL, AXIAL, LENGTH)
        got = eq.torsor(name)
        np.testing.assert_allclose(got[:3], expected[:3], rtol=0, atol=1e-9 * RADIAL, err_msg=name)
        np.testing.assert_allclose(
            got[3:], expected[3:], rtol=0, atol=1e-9 * RADIAL / LENGTH, err_msg=name
        )


@pytest.mark.parametrize("robot", sorted(ROBOTS))
def test_a_torque_about_the_tool_axis_matches_the_closed_forms(robot):
    """1 N m about the tool frame's z axis, the last joint's axis up to the vendor rotations'
    round-off: the last journal carries 1e-13 of the load, left at the centre of its play (as the
    docs say of a joint with less than 1e-9 of the largest force), every other journal tilts to
    its closed form; the neglected share is reported in ``unblocked_load`` (before: stationarity
    3e-12 > 1e-12, SolverError on the UR5)."""
    mech = mechanism(robot)
    data = nominal_placements(mech)
    torque = data.oMf[mech.model.getFrameId(ROBOTS[robot][2])].rotation[:, 2].copy()
    eq = mech.solve(loads=[Torque(ROBOTS[robot][2], torque)], gravity=False)
    assert eq.ok and eq.residuals.unblocked_load <= 1e-9
    for name in ROBOTS[robot][1]:
        joint = mech.joint(name)
        rotation = data.oMi[joint.joint_id].rotation @ joint.rotation  # clearance frame, world
        moment = rotation.T @ torque
        if np.linalg.norm(np.cross(moment, [1.0, 0.0, 0.0])) <= 1e-9:  # about the axis: unloaded
            expected = np.zeros(6)
        else:
            expected = journal_torsor(np.zeros(3), moment, RADIAL, AXIAL, LENGTH)
        got = eq.torsor(name)
        np.testing.assert_allclose(got[:3], expected[:3], rtol=0, atol=1e-9 * RADIAL, err_msg=name)
        np.testing.assert_allclose(
            got[3:], expected[3:], rtol=0, atol=1e-9 * RADIAL / LENGTH, err_msg=name
        )
    batch = mech.solve_many([[Torque(ROBOTS[robot][2], k * torque)] for k in (1.0, 2.0, 3.0)])
    assert batch.ok.all() and set(batch.statuses) == {"closed form"}
    for name in ROBOTS[robot][1]:
        # the answer does not depend on the load's size (a triple torque, the same torsors)
        np.testing.assert_allclose(
            batch.torsors(name)[2], eq.torsor(name), rtol=0, atol=1e-12 * RADIAL
        )


@pytest.mark.parametrize("robot", sorted(ROBOTS))
def test_per_body_statics_from_contact_forces(robot):
    mech = mechanism(robot)
    loads = tool_loads(robot)
    eq = mech.solve(loads=loads)
    assert statics_residual(eq, loads) < 1e-10


@pytest.mark.parametrize("robot", sorted(ROBOTS))
def test_per_body_statics_from_reactions(robot):
    if not hasattr(Equilibrium, "reaction"):
        pytest.skip("Equilibrium.reaction does not exist yet (issue 10 finding 5)")
    mech = mechanism(robot)
    loads = tool_loads(robot)
    for exact in (False, True):
        eq = mech.solve(loads=loads, exact=exact)
        assert reaction_residual(eq, loads) < 1e-10, exact


def journal_end_gaps(mech, eq, robot) -> dict[str, tuple]:
    """Per joint: (radial distance [m] of the two journal ends of the moving part from the bore
    axis, axial offset [m]), at the solved pose, in world coordinates. The bore is built from
    the housing's frame: the solved placement of the parent body times the URDF joint origin
    (read from the text), along the URDF axis."""
    axes = urdf_joints(robot)
    model = mech.model
    out = {}
    for name in ROBOTS[robot][1]:
        i = model.getJointId(name)
        parent = model.parents[i]
        # the parent body's joint frame is its URDF link frame when that link is the parent link
        assert model.frames[model.getFrameId(axes[name]["parent"])].placement.isIdentity()
        housing = eq.body_placements[parent] * axes[name]["origin"]
        bore_axis = housing.rotation @ axes[name]["axis"]
        child = eq.body_placements[i]
        journal_axis = child.rotation @ axes[name]["axis"]  # the child's axis, in its own frame
        ends = [child.translation + s * LENGTH / 2 * journal_axis for s in (-1.0, 1.0)]
        radial = []
        for end in ends:
            offset = end - housing.translation
            radial.append(float(np.linalg.norm(offset - bore_axis * (bore_axis @ offset))))
        axial = float(bore_axis @ (child.translation - housing.translation))
        out[name] = (radial, axial)
    return out


@pytest.mark.parametrize("robot", sorted(ROBOTS))
def test_journal_ends_inside_their_bores_exact(robot):
    """Exact model: every journal end within the radial play of its bore and the axial play, and
    the loaded ends (every end here: every journal is loaded) on the boundary, to 1e-9 of the play."""
    mech = mechanism(robot)
    eq = mech.solve(loads=tool_loads(robot), exact=True)
    assert eq.formulation == "exact" and eq.ok
    for name, (radial, axial) in journal_end_gaps(mech, eq, robot).items():
        for distance in radial:
            assert distance == pytest.approx(RADIAL, abs=1e-9 * RADIAL), name
        assert abs(axial) == pytest.approx(AXIAL, abs=1e-9 * RADIAL), name


def first_order_end_gaps(mech, eq, robot) -> dict[str, tuple]:
    """Small-displacement model, the same question to first order: each body b moves a point p by
    v_b + omega_b x p (its twist at the world origin, ``body_twists``); the relative displacement
    of a journal end against the housing, projected across the nominal bore axis (URDF text), has
    norm <= c, and the relative displacement of the journal centre along the axis is <= c_a."""
    axes = urdf_joints(robot)
    model = mech.model
    data = nominal_placements(mech)
    twists = eq.body_twists
    out = {}
    for name in ROBOTS[robot][1]:
        i = model.getJointId(name)
        parent = model.parents[i]
        housing = data.oMi[parent] * axes[name]["origin"]
        axis = housing.rotation @ axes[name]["axis"]
        relative = twists[i] - twists[parent]
        radial = []
        for sign in (-1.0, 1.0):
            end = housing.translation + sign * LENGTH / 2 * axis
            moved = relative[:3] + np.cross(relative[3:], end)
            radial.append(float(np.linalg.norm(moved - axis * (axis @ moved))))
        centre = relative[:3] + np.cross(relative[3:], housing.translation)
        out[name] = (radial, float(axis @ centre))
    return out


@pytest.mark.parametrize("robot", sorted(ROBOTS))
def test_journal_ends_inside_their_bores_linear(robot):
    """Small-displacement model, first order (exact for that model): every end on its bore."""
    mech = mechanism(robot)
    eq = mech.solve(loads=tool_loads(robot))
    for name, (radial, axial) in first_order_end_gaps(mech, eq, robot).items():
        for distance in radial:
            assert distance == pytest.approx(RADIAL, abs=1e-9 * RADIAL), name
        assert abs(axial) == pytest.approx(AXIAL, abs=1e-9 * RADIAL), name


@pytest.mark.parametrize("robot", sorted(ROBOTS))
def test_linear_body_placements_are_second_order_close(robot):
    """The linear answer's ``body_placements`` (exp(xi_b) oM_b0) place the journal ends on their
    bores only up to second order in the rotations: measured up to 4 % of the axial play on the
    Panda (0.2 um; the exact model: 1e-9). Allowed: 10 % of the radial play."""
    mech = mechanism(robot)
    eq = mech.solve(loads=tool_loads(robot))
    for name, (radial, axial) in journal_end_gaps(mech, eq, robot).items():
        for distance in radial:
            assert distance == pytest.approx(RADIAL, abs=0.1 * RADIAL), name
        assert abs(axial) == pytest.approx(AXIAL, abs=0.1 * RADIAL), name


@pytest.mark.parametrize("robot", sorted(ROBOTS))
def test_exact_and_linear_agree_to_second_order(robot):
    """The tool point of the two formulations, placed independently (exact: solved placement;
    linear: p + v + omega x p from the body twist), differs at second order in the rotations:
    at most |omega|^2 / 2 times the tool's distance from the base, with |omega| the linear
    tool body's rotation (about 2.2e-3 rad here; measured 1.4 um on both arms)."""
    mech = mechanism(robot)
    eq = mech.solve(loads=tool_loads(robot), exact=True)
    assert eq.ok and eq.linear is not None
    data = nominal_placements(mech)
    frame = mech.model.getFrameId(ROBOTS[robot][2])
    body = mech.model.frames[frame].parentJoint
    point = data.oMf[frame].act(TOOL_POINT)
    local = data.oMi[body].actInv(point)
    exact_point = eq.body_placements[body].act(local)
    twist = np.asarray(eq.linear.body_twists[body])
    linear_point = point + twist[:3] + np.cross(twist[3:], point)
    rotation = float(np.linalg.norm(twist[3:]))
    bound = rotation**2 / 2 * float(np.linalg.norm(point - data.oMi[1].translation)) * 2.0
    difference = float(np.linalg.norm(exact_point - linear_point))
    assert 0.0 < difference < bound, (difference, bound)


def test_panda_finger_spin_is_held_by_the_ideal_prismatic_joint():
    """Issue 10 finding 3: an ideal URDF prismatic joint (no clearance given) constrains every
    motion but its slide; a torque about the finger axis is carried, not 'unbounded'."""
    mech = mechanism("panda")
    axes = urdf_joints("panda")
    data = nominal_placements(mech)
    finger = mech.model.getJointId("panda_finger_joint1")
    axis = data.oMi[finger].rotation @ axes["panda_finger_joint1"]["axis"]
    torque = clearance_pin.Torque("panda_leftfinger", 0.5 * axis)
    eq = mech.solve(loads=[torque])
    assert eq.ok
    assert np.abs(eq.torsor("panda_finger_joint1")).max() == 0.0
    assert statics_residual(eq, [torque]) < 1e-10


def test_panda_finger_slide_is_free():
    """The same joint leaves its slide free: a force along the finger axis has no equilibrium."""
    mech = mechanism("panda")
    axes = urdf_joints("panda")
    data = nominal_placements(mech)
    finger = mech.model.getJointId("panda_finger_joint1")
    axis = data.oMi[finger].rotation @ axes["panda_finger_joint1"]["axis"]
    with pytest.raises(clearance_pin.UnboundedLoadError):
        mech.solve(loads=[PointForce("panda_leftfinger", 5.0 * axis, [0.0, 0.0, 0.0])])


def test_tiny_force_with_a_tool_axis_torque_on_the_6r_arm():
    """A reviewer's case on the bundled 6R arm: 5 N m about the tool's axis plus 1e-8 N along the
    first joint's axis. Every motion is bounded, so an answer exists; the Newton polish does not
    converge, and the cone solver's answer, verified (statics residual 1.2e-9: the tiny force's
    share, within the 1e-8 tolerance), is returned unpolished (docs/method.md, the closed
    forms' limitation; backend="ipopt" still raises SolverError there)."""
    arm = clearance_pin.load(str(Path(__file__).resolve().parents[1] / "models" / "arm_6r.urdf"))
    loads = [
        clearance_pin.PointForce("tool", [0, 0, 1e-8]),
        clearance_pin.Torque("tool", [0, 0, 5.0]),
    ]
    eq = arm.solve(loads=loads, gravity=False)
    assert eq.ok and eq.residuals["statics"] <= 1e-8
