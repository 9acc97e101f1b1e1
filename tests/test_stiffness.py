"""Joint stiffness in the same energy as the play (issue 23 item 3). References are closed forms,
the statics of a rigid beam on springs and Pinocchio's own Jacobians, computed here without the
solver's code; the rigid limit compares the library with itself (stiff against rigid joints).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from test_backlash import cantilever as backlash_cantilever
from test_backlash import one_journal

import clearance_pin as cp
from clearance_pin import ModelError, PointForce, Torque
from clearance_pin.equilibrium.batch_reactions import PARTS

MODELS = Path(__file__).resolve().parent.parent / "models"
BACKLASH = 0.002  # [rad]
DRIVE = 1000.0  # [N m/rad]
ARM = 0.5  # [m]


def cantilever(attributes: str) -> cp.Mechanism:
    """test_backlash's driven journal about z carrying a 0.5 m cantilever along x, with these
    attributes on its joint."""
    return backlash_cantilever(backlash=attributes)


@pytest.mark.parametrize("torque", [2.0, -3.0])
@pytest.mark.parametrize("backend", ["auto", "ipopt"])
def test_a_driven_journal_turns_by_its_backlash_then_its_drive_compliance(torque, backend):
    """Closed form: the joint turns by sign(T) b/2 + T/k_drive, the tip moves ARM times that
    across the arm, and the stop (in series with the spring) holds -T."""
    mechanism = cantilever(f'backlash="{BACKLASH}" drive_stiffness="{DRIVE}"')
    answer = mechanism.solve([Torque("arm", [0.0, 0.0, torque])], gravity=False, backend=backend)
    turn = np.sign(torque) * BACKLASH / 2.0 + torque / DRIVE
    assert answer.ok and answer.residuals.statics < 1e-10
    assert answer.torsor("drive")[3] == pytest.approx(turn, abs=1e-12)
    tip = answer.frame_displacement("arm").linear + np.cross(
        answer.frame_displacement("arm").angular, [ARM, 0.0, 0.0]
    )
    assert tip[1] == pytest.approx(ARM * turn, abs=1e-12)
    stop = next(c for c in answer.contacts if c.point == "backlash")
    assert stop.active and stop.moment[0] == pytest.approx(-torque, abs=1e-9)
    # the potential: the load's work and the spring's energy, 1/2 k (T/k)^2
    elastic = torque / DRIVE
    assert answer.energy == pytest.approx(-torque * turn + 0.5 * DRIVE * elastic**2, rel=1e-12)


def test_bearing_compliance_adds_to_the_journal_play():
    """A moment across the journal: the play tilts it by c / (L/2), the tilt stiffness by M/k."""
    tilt = 2e4  # [N m/rad]
    mechanism = cantilever(f'tilt_stiffness="{tilt}" radial_stiffness="1e8"')
    answer = mechanism.solve([PointForce("arm", [0.0, 0.0, -20.0], [ARM, 0.0, 0.0])],
                             gravity=False)  # fmt: skip
    moment = 20.0 * ARM  # [N m] about the world y, a tilt of the journal about z
    assert answer.ok
    assert abs(answer.torsor("drive")[4]) == pytest.approx(1e-5 / 0.02 + moment / tilt, rel=1e-9)


# -- a rigid shaft on three equal self-aligning bearings -----------------------------------------
A, PLAY, K, F = 0.2, 1e-5, 2e7, 300.0  # [m], [m], [N/m], [N]


def three_bearings(stiffness: str = f'radial_stiffness="{K}"', middle: str | None = None):
    """A shaft along x on balls at x = -A (its tree joint), 0 and +A (loop joints); ``middle``:
    the middle bearing's stiffness attributes (default: ``stiffness``)."""
    middle = stiffness if middle is None else middle
    return cp.loads(f"""<?xml version="1.0"?>
<robot name="three_bearings">
  <link name="ground"/><link name="shaft"/>
  <link name="ground_mid"/><link name="shaft_mid"/><link name="ground_end"/><link name="shaft_end"/>
  <joint name="left" type="floating"><parent link="ground"/><child link="shaft"/>
    <origin xyz="{-A} 0 0"/></joint>
  <joint name="a_mid" type="fixed"><parent link="ground"/><child link="ground_mid"/></joint>
  <joint name="b_mid" type="fixed"><parent link="shaft"/><child link="shaft_mid"/>
    <origin xyz="{A} 0 0"/></joint>
  <joint name="a_end" type="fixed"><parent link="ground"/><child link="ground_end"/>
    <origin xyz="{A} 0 0"/></joint>
  <joint name="b_end" type="fixed"><parent link="shaft"/><child link="shaft_end"/>
    <origin xyz="{2 * A} 0 0"/></joint>
  <clearance_pin>
    <joint name="left" type="spherical" radial_clearance="{PLAY}" {stiffness}/>
    <loop_joint name="middle" frame_a="ground_mid" frame_b="shaft_mid" type="spherical"
                radial_clearance="{PLAY}" {middle}/>
    <loop_joint name="right" frame_a="ground_end" frame_b="shaft_end" type="spherical"
                radial_clearance="{PLAY}" {stiffness}/>
  </clearance_pin>
</robot>""")


@pytest.mark.parametrize("backend", ["auto", "ipopt"])
def test_a_shaft_on_three_stiff_bearings_splits_its_load_by_stiffness(backend):
    """Each bearing takes up its play, then the springs: a rigid beam on three equal springs at
    x = -a, 0, a under F at a/2 (statics: sum F_i = F, sum F_i x_i = F a/2, F_i linear in x_i)
    carries F/12, F/3, 7F/12, and deflects by c + F_i/k at each bearing."""
    load = PointForce("shaft", [0.0, F, 0.0], [1.5 * A, 0.0, 0.0])  # x = a/2 in the world
    answer = three_bearings().solve([load], gravity=False, backend=backend)
    assert answer.ok and answer.residuals.statics < 1e-10
    expected = {"left": F / 12, "middle": F / 3, "right": 7 * F / 12}
    for contact in answer.contacts:
        share = expected[contact.joint]
        assert contact.active
        assert contact.force == pytest.approx([0.0, -share, 0.0], abs=1e-9 * F)
        assert answer.torsor(contact.joint)[1] == pytest.approx(PLAY + share / K, rel=1e-9)


def test_unequal_bearings_split_the_load_by_their_stiffness():
    """A middle bearing 4x stiffer, F at the middle: the beam on springs k, 4k, k (F_i = k_i
    (p + theta x_i) beyond the play, two equations of statics for p and theta, solved here)
    carries F/6, 2F/3, F/6, where the rigid model returns the least-norm split F/3 each (equal
    springs give that split: minimum sum F_i^2 / 2k)."""
    load = PointForce("shaft", [0.0, F, 0.0], [A, 0.0, 0.0])  # x = 0 in the world
    springs = np.array([K, 4 * K, K])
    where = np.array([-A, 0.0, A])
    statics = np.array([[springs.sum(), springs @ where], [springs @ where, springs @ where**2]])
    shift, tilt = np.linalg.solve(statics, [F, 0.0])
    expected = springs * (shift + tilt * where)
    stiff = three_bearings(f'radial_stiffness="{K}"', f'radial_stiffness="{4 * K}"')
    answer = stiff.solve([load], gravity=False)
    rigid = three_bearings("").solve([load], gravity=False)
    assert answer.ok and rigid.ok
    order = {"left": 0, "middle": 1, "right": 2}
    carried = np.zeros(3)
    for contact in answer.contacts:
        carried[order[contact.joint]] = -contact.force[1]
    assert carried == pytest.approx(expected, rel=1e-9)
    least_norm = np.zeros(3)
    for contact in rigid.contacts:
        least_norm[order[contact.joint]] = -contact.force[1]
    assert carried == pytest.approx([F / 6, 2 * F / 3, F / 6], rel=1e-9)
    assert least_norm == pytest.approx([F / 3, F / 3, F / 3], rel=1e-9)
    assert not np.allclose(carried, least_norm, rtol=1e-2)


# -- the rigid limit -------------------------------------------------------------------------------
def _stiffened(text: str, k: float) -> str:
    full = " ".join(repr(k if i == j else 0.0) for i in range(6) for j in range(6))
    block = text[text.index("<clearance_pin>") :]
    stiff = re.sub(
        r"<(joint|loop_joint)(\s[^>]*?)(/?)>",
        lambda m: f'<{m.group(1)}{m.group(2)} stiffness="{full}"{m.group(3)}>',
        block,
    )
    return text.replace(block, stiff)


def _largest_difference(rigid, stiff, mechanism) -> float:
    length = mechanism.length_scale()
    return max(
        float(np.abs(rigid.torsor(j)[:3] - stiff.torsor(j)[:3]).max())
        + length * float(np.abs(rigid.torsor(j)[3:] - stiff.torsor(j)[3:]).max())
        for j in mechanism.joints
    )


@pytest.mark.parametrize(
    "name",
    ["younes_two_spheres", "younes_two_cylinders", "younes_sphere_cylinder", "four_bar",
     "slider_crank", "arm_6r", "double_pendulum"],
)  # fmt: skip
def test_the_rigid_limit(name):
    """Every joint at k = 1e15 and 1e18 in every direction: verified answers whose difference
    from the rigid answer is the springs' deflection, falling as 1/k (1000x from 1e15 to 1e18,
    to 1 %), below 1e-9 of the play at 1e18 (at 1e15 the paper's and bundled loads deflect the
    springs by up to 3e-8 of the play: W/k, checked joint by joint on the serial arm below;
    at 1e18 some differences are round-off of the rigid answer, so the fall is bounded, not
    measured as a ratio)."""
    text = (MODELS / f"{name}.urdf").read_text()
    mechanism = cp.loads(text)
    rigid = mechanism.solve()
    play = max(j.clearance.max_play for j in mechanism.joints.values())
    differences = []
    for k in (1e15, 1e18):
        stiff = cp.loads(_stiffened(text, k)).solve()
        assert stiff.ok and stiff.residuals.statics < 1e-10
        differences.append(_largest_difference(rigid, stiff, mechanism))
    assert differences[0] <= 1e-7 * play
    assert differences[1] <= 1e-9 * play
    assert differences[1] <= differences[0] / 100.0


def test_a_serial_arm_deflects_by_its_reactions_over_the_stiffness():
    """A tree: each joint's deflection adds to its play by its reaction over k (statics of the
    subtree, the virtual joint method), at k = 1e7 (deflections of about the play)."""
    text = (MODELS / "arm_6r.urdf").read_text()
    mechanism = cp.loads(text)
    rigid = mechanism.solve()
    stiff = cp.loads(_stiffened(text, 1e7)).solve()
    for joint in mechanism.joints:
        reaction = rigid.reaction(joint)
        wrench = np.concatenate([reaction.force, reaction.moment])
        # the spring is in series: it carries the joint's reaction, minus what the parent exerts
        assert stiff.torsor(joint) - rigid.torsor(joint) == pytest.approx(
            -wrench / 1e7, rel=1e-9, abs=1e-17
        )


# -- a vendor robot: the virtual joint method against Pinocchio's Jacobian --------------------------
UR5_JOINTS = [f"{j}_joint" for j in ("shoulder_pan", "shoulder_lift", "elbow")] + [
    f"wrist_{i}_joint" for i in (1, 2, 3)
]
UR5_POSE = np.array([0.3, -1.2, 1.4, -0.8, 1.1, 0.4])  # [rad]


def ur5_with_drives(stiffness: np.ndarray) -> tuple[str, cp.Mechanism]:
    """The UR5 of example-robot-data as shipped (its URDF text) and the mechanism of it with
    every joint driven at UR5_POSE with these drive stiffnesses [N m/rad], no play."""
    from test_auto_bound import example_robot_urdf

    urdf = example_robot_urdf("ur_description/urdf/ur5_robot.urdf")
    block = "".join(
        f'<joint name="{j}" driven="true" q="{float(v)!r}" drive_stiffness="{float(k)!r}"/>'
        for j, k, v in zip(UR5_JOINTS, stiffness, UR5_POSE)
    )
    clearances = f"<clearance_pin>{block}</clearance_pin></robot>"
    return urdf, cp.loads(urdf.replace("</robot>", clearances))


def test_ur5_drive_compliance_matches_the_virtual_joint_method():
    """The UR5 as shipped, every joint driven with drive_stiffness only (no play): the tool's
    deflection under a force F at tool0 is J K^-1 J^T F (Pinocchio's own frame Jacobian,
    LOCAL_WORLD_ALIGNED, sharing no code with the solver)."""
    stiffness = np.array([2e5, 2e5, 1e5, 3e4, 3e4, 3e4])  # [N m/rad]
    urdf, mechanism = ur5_with_drives(stiffness)
    joints, q = UR5_JOINTS, UR5_POSE
    force = np.array([30.0, -20.0, 50.0])
    answer = mechanism.solve([PointForce("tool0", force, [0.0, 0.0, 0.0])], gravity=False)
    assert answer.ok

    model = pin.buildModelFromXML(urdf)
    data = model.createData()
    configuration = pin.neutral(model)
    for name, value in zip(joints, q):
        configuration[model.joints[model.getJointId(name)].idx_q] = value
    frame = model.getFrameId("tool0")
    jacobian = pin.computeFrameJacobian(model, data, configuration, frame, pin.LOCAL_WORLD_ALIGNED)[
        :3
    ]
    columns = [model.joints[model.getJointId(name)].idx_v for name in joints]
    jacobian = jacobian[:, columns]
    expected = jacobian @ ((jacobian.T @ force) / stiffness)
    moved = answer.frame_displacement("tool0").linear
    assert moved == pytest.approx(expected, rel=1e-9, abs=1e-15)

    # the accuracy map of a 2 kg payload: all of it drive compliance, J K^-1 J^T m g
    weight = np.array([0.0, 0.0, -2.0 * 9.80665])
    amap = mechanism.accuracy("tool0", configurations=[configuration], payloads=[2.0])
    assert amap.translation[0, 0] == pytest.approx(
        jacobian @ ((jacobian.T @ weight) / stiffness), rel=1e-9, abs=1e-15
    )
    assert set(amap.contributions) == {"drive compliance"}


# -- input ---------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "attributes, message",
    [
        ('drive_stiffness="1e3"', "not driven"),
        ('driven="true" drive_stiffness="-5"', "a finite number > 0"),
        ('axial_stiffness="nan"', "finite"),
        ('stiffness="1 2 3"', "36"),
        ('stiffness="' + " ".join(["1"] + ["0.5"] + ["0"] * 34) + '"', "symmetric"),
        ('stiffness="' + " ".join(str(-1.0 if i == j else 0.0) for i in range(6) for j in range(6))
         + '"', "positive semi-definite"),
    ],
)  # fmt: skip
def test_bad_stiffness_is_refused_naming_the_joint(attributes, message):
    with pytest.raises(ModelError, match=message) as error:
        cp.loads(one_journal(attributes))
    assert "'j'" in str(error.value)


def test_a_stiffness_the_kind_cannot_take_is_refused():
    with pytest.raises(ModelError, match="axial_stiffness does not apply to a spherical joint"):
        three_bearings('axial_stiffness="1e6"')


@pytest.mark.parametrize("torque", [2.0, -3.0])
def test_the_exact_model_turns_a_driven_journal_by_its_backlash_and_spring(torque):
    """Exact model: the couple T does the work T sin(theta) (docs/method.md section 4) and the
    spring stores k e^2 / 2, theta = sign(T) b/2 + e, so -T cos(theta) + k e = 0, solved here by
    fixed-point iteration; exact="auto" runs the exact model (no second-order estimate with
    stiffness)."""
    mechanism = cantilever(f'backlash="{BACKLASH}" drive_stiffness="{DRIVE}"')
    loads = [Torque("arm", [0.0, 0.0, torque])]
    spring = torque / DRIVE
    for _ in range(60):
        spring = torque * np.cos(np.sign(torque) * BACKLASH / 2 + spring) / DRIVE
    for exact in (True, "auto"):
        answer = mechanism.solve(loads, gravity=False, exact=exact)
        assert answer.formulation == "exact" and answer.ok
        assert answer.deflection("drive")[3] == pytest.approx(spring, rel=1e-12)
        assert answer.torsor("drive")[3] == pytest.approx(
            np.sign(torque) * BACKLASH / 2 + spring, rel=1e-12
        )


def test_the_exact_model_of_three_stiff_bearings_differs_at_second_order():
    """The shaft's rotations are 2e-5 rad: the exact forces are the beam's F/12, F/3, 7F/12 to
    1e-8 of F, and its statics (springs included) hold."""
    load = PointForce("shaft", [0.0, F, 0.0], [1.5 * A, 0.0, 0.0])
    answer = three_bearings().solve([load], gravity=False, exact=True)
    assert answer.ok and answer.residuals.statics < 1e-10
    expected = {"left": F / 12, "middle": F / 3, "right": 7 * F / 12}
    for contact in answer.contacts:
        assert -contact.force[1] == pytest.approx(expected[contact.joint], abs=1e-8 * F)
        assert answer.deflection(contact.joint)[1] == pytest.approx(
            expected[contact.joint] / K, rel=1e-6
        )


def test_the_envelope_says_it_leaves_stiffness_out():
    mechanism = cantilever(f'drive_stiffness="{DRIVE}" backlash="{BACKLASH}"')
    with pytest.warns(cp.StiffnessLeftOutWarning, match="drive"):
        mechanism.envelope("arm", kinds=("rotation",))


def test_stiffness_from_a_toml_clearance_file(tmp_path):
    """A TOML clearance file beside the URDF: a 6x6 matrix as a list of 36 numbers, always SI
    whatever the file's unit, and drive_stiffness by default for a joint type."""
    (tmp_path / "arm.urdf").write_text("""<?xml version="1.0"?>
<robot name="arm"><link name="base"/><link name="arm"/>
  <joint name="drive" type="revolute"><parent link="base"/><child link="arm"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="1"/></joint>
</robot>""")
    full = [[2e6 if i == j else 0.0 for j in range(6)] for i in range(6)]
    (tmp_path / "arm.toml").write_text(
        'unit = "mm"\n[defaults.revolute]\ndriven = true\ndrive_stiffness = 500.0\n'
        '[joints.drive]\ntype = "revolute"\nradial_clearance = 0.01\nlength = 40\n'
        f"stiffness = {[v for row in full for v in row]}\n"
    )
    mechanism = cp.load(tmp_path / "arm.urdf", clearances=tmp_path / "arm.toml")
    answer = mechanism.solve([Torque("arm", [0.0, 0.0, 3.0])], gravity=False)
    assert answer.ok
    assert answer.torsor("drive")[3] == pytest.approx(3.0 / (500.0 + 2e6), rel=1e-9)


def test_springs_decide_a_hyperstatic_linkage_s_rigid_reactions():
    """The planar four-bar is hyperstatic out of its plane (every pin holds the tilts and the
    axial slide). With pin_B's tilts and slide elastic and the rest rigid, pin_B's spring does
    not deflect (crank, coupler and rocker are held out of plane by rigid pivots), so it carries
    nothing out of plane: statics of the rocker (its pivot then carries no out-of-plane load)
    and of crank plus coupler (the crank pivot carries the whole 30 N across the plane). The
    least-norm split of the rigid model shares it between the two paths instead."""
    text = (MODELS / "four_bar.urdf").read_text()
    elastic = text.replace(
        'axis="0 0 1"/>', 'axis="0 0 1" tilt_stiffness="1e4" axial_stiffness="1e7"/>'
    )
    across = PointForce("coupler", [0.0, 0.0, 30.0], [0.09, 0.0, 0.0])
    for source, shared in ((elastic, False), (text, True)):
        mechanism = cp.loads(source)
        answer = mechanism.solve([*mechanism.loads, across], gravity=False)
        assert answer.ok
        pin_b, rocker = answer.reaction("pin_B"), answer.reaction("rocker_pivot")
        crank = answer.reaction("crank_pivot")
        # clearance frames: x along the pins' axes, the world z
        out_of_plane = np.array([pin_b.force[0], *pin_b.moment[1:], rocker.force[0]])
        if shared:
            assert np.abs(out_of_plane).max() > 1.0
        else:
            assert answer.deflection("pin_B") == pytest.approx(np.zeros(6), abs=1e-15)
            assert out_of_plane == pytest.approx(np.zeros(4), abs=1e-9)
            assert crank.force[0] == pytest.approx(-30.0, abs=1e-9)
            assert pin_b.residual < 1e-12


def test_the_engineer_reads_the_springs_part_in_the_report_and_the_json(tmp_path, capsys):
    """The text report adds the springs' part of each torsor; the solve document gives it as
    spring_translation_m / spring_rotation_rad and follows its schema."""
    import json

    jsonschema = pytest.importorskip("jsonschema")
    from clearance_pin.cli import main
    from clearance_pin.json_documents import schema

    attributes = f'backlash="{BACKLASH}" drive_stiffness="{DRIVE}"'
    urdf = tmp_path / "cantilever.urdf"
    urdf.write_text(f"""<?xml version="1.0"?>
<robot name="cantilever"><link name="base"/><link name="arm"/>
  <joint name="drive" type="revolute"><parent link="base"/><child link="arm"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="1"/></joint>
  <clearance_pin>
    <joint name="drive" type="revolute" radial_clearance="1e-5" length="0.04" driven="true"
           {attributes}/>
    <torque link="arm" value="0 0 2"/>
  </clearance_pin>
</robot>""")
    assert main(["solve", str(urdf)]) == 0
    assert "of which springs" in capsys.readouterr().out
    assert main(["solve", str(urdf), "--json"]) == 0
    document = json.loads(capsys.readouterr().out)
    jsonschema.validate(document, schema("solve"))
    torsor = document["equilibrium"]["torsors"]["drive"]
    assert torsor["spring_rotation_rad"][0] == pytest.approx(2.0 / DRIVE, rel=1e-12)
    assert torsor["rotation_rad"][0] == pytest.approx(BACKLASH / 2 + 2.0 / DRIVE, rel=1e-12)


def test_with_springs_the_envelope_of_a_load_set_is_the_accuracy_map_at_one_pose():
    """A shaft on three stiff bearings, loads of 300 N across it at x = a/2 in four directions:
    the map at the nominal pose gives each case's displacement of the frame shaft_end (at the
    right bearing, x = a): by the beam on springs, each bearing moves by c + F_i/k along the
    load, on a line: from the left bearing's c + F/12/k, its slope (7F/12 - F/12)/k over 2a,
    times 2a."""
    mechanism = three_bearings()
    cases = [
        [PointForce("shaft", force, [1.5 * A, 0.0, 0.0])]
        for force in ([0, F, 0], [0, -F, 0], [0, 0, F], [0, 0, -F])
    ]
    amap = mechanism.accuracy("shaft_end", configurations=[mechanism.q_nominal], payloads=cases)
    assert amap.ok.all()
    left = PLAY + F / 12 / K
    tilt = (7 * F / 12 - F / 12) / K / (2 * A)  # [rad]
    reach = left + tilt * 2 * A  # the right bearing is 2a from the left one
    expected = [[0, reach, 0], [0, -reach, 0], [0, 0, reach], [0, 0, -reach]]
    assert amap.translation[0] == pytest.approx(np.array(expected), abs=1e-12)
    largest, _, _ = amap.largest()
    assert largest == pytest.approx(reach, rel=1e-9)


def test_ur5_soft_drives_exact_model_against_pinocchio_fixed_point():
    """The UR5 as shipped, soft drives only (no play: 2e3 .. 3e2 N m/rad, rotations of 0.03 rad),
    a force F at tool0: the exact model's spring deflections e solve K e = J(q + e)^T F (dead
    load at the moved tool, Pinocchio's own Jacobian at the deflected pose, fixed-point iteration
    here), and its tool position is Pinocchio's at q + e; the linear answer is off by 0.5 mm.
    No play: the springs alone answer (closed form), not 'no load'."""
    stiffness = np.array([2e3, 2e3, 1e3, 3e2, 3e2, 3e2])
    urdf, mechanism = ur5_with_drives(stiffness)
    joints, q = UR5_JOINTS, UR5_POSE
    force = np.array([30.0, -20.0, 50.0])
    loads = [PointForce("tool0", force, [0.0, 0.0, 0.0])]
    linear = mechanism.solve(loads, gravity=False)
    assert linear.status == "optimal" and linear.method is cp.Method.CLOSED_FORM
    exact = mechanism.solve(loads, gravity=False, exact=True)
    assert exact.ok

    model = pin.buildModelFromXML(urdf)
    data = model.createData()
    columns = [model.joints[model.getJointId(name)].idx_v for name in joints]
    frame = model.getFrameId("tool0")

    def placed(offsets):
        configuration = pin.neutral(model)
        for name, value in zip(joints, q + offsets):
            configuration[model.joints[model.getJointId(name)].idx_q] = value
        return configuration

    springs = np.zeros(6)
    for _ in range(200):
        jacobian = pin.computeFrameJacobian(
            model, data, placed(springs), frame, pin.LOCAL_WORLD_ALIGNED
        )[:3, columns]
        springs = (jacobian.T @ force) / stiffness
    pin.framesForwardKinematics(model, data, placed(springs))
    tool = data.oMf[frame].translation.copy()
    solved = np.array([exact.deflection(name)[3] for name in joints])
    assert solved == pytest.approx(springs, rel=1e-8, abs=1e-14)
    assert exact.method is cp.Method.EXACT_NEWTON  # nothing touches: Newton on the springs alone
    assert exact.frame_placement("tool0").translation == pytest.approx(tool, abs=1e-10)
    pin.framesForwardKinematics(model, data, placed(np.zeros(6)))
    moved = linear.frame_displacement("tool0").linear
    assert np.linalg.norm(data.oMf[frame].translation + moved - tool) > 1e-4


def test_the_coal_check_reads_the_contacts_on_the_play_side_of_the_springs():
    """The journal sits on the play's side of its springs: coal measures it at the child frame
    less the spring's deflection, so an exact answer with a tilting spring (1 mrad, 20 um at
    the journal's ends) checks ok, its contacts on the bore (it read them 20 um inside)."""
    mechanism = cantilever('tilt_stiffness="1e4" radial_stiffness="1e7"')
    loads = [Torque("arm", [0.0, 0.0, 2.0]), PointForce("arm", [0, 10, -20], [ARM, 0, 0])]
    answer = mechanism.solve(loads, gravity=False, exact=True)
    assert abs(answer.deflection("drive")[4]) > 5e-4  # the spring tilts the arm
    report = answer.check()
    assert report.ok
    for point in report.joints["drive"].points:
        if point.point.startswith("end"):
            assert abs(point.distance) < 1e-9


def _subtree_statics(arm, poses, loads, gravity) -> dict:
    """Reference written here with Pinocchio alone: each tree joint's reaction (the parent's
    wrench on the child, clearance frame, about the joint centre) at every pose, minus the loads
    on the subtree it carries, its weight from Pinocchio's subtree mass and centre of mass
    (pin.centerOfMass), the point forces and torques at their links (pin.framesForwardKinematics)."""
    model = arm.model
    data = model.createData()
    out = {joint.name: [] for joint in arm.tree_joints}
    for pose in poses:
        pin.framesForwardKinematics(model, data, pose)
        pin.centerOfMass(model, data, pose, True)
        for joint in arm.tree_joints:
            k = joint.joint_id
            subtree = {k} | {
                j
                for j in range(k + 1, model.njoints)
                if model.parents[j] >= k and _under(model, j, k)
            }
            force, moment = np.zeros(3), np.zeros(3)  # the loads on the subtree, world origin
            weight = data.mass[k] * gravity
            force += weight
            moment += np.cross(data.oMi[k].act(data.com[k]), weight)
            for load in loads:
                frame = arm.link_frames[load.link]
                if model.frames[frame].parentJoint not in subtree:
                    continue
                if isinstance(load, PointForce):
                    point = data.oMf[frame].act(np.asarray(load.point))
                    force += load.force
                    moment += np.cross(point, load.force)
                else:
                    moment += load.torque
            centre = data.oMi[k] * pin.SE3(joint.rotation, np.zeros(3))
            axes, origin = centre.rotation, centre.translation
            out[joint.name].append(
                np.hstack([axes.T @ -force, axes.T @ -(moment - np.cross(origin, force))])
            )
    return {name: np.array(rows) for name, rows in out.items()}


def _under(model, j: int, k: int) -> bool:
    """Body j lies in the subtree rooted at body k."""
    while j > k:
        j = model.parents[j]
    return j == k


def test_a_tree_s_reactions_from_its_subtrees_equal_the_batch_s_least_squares():
    """A tree's batch reactions (read from the statics of each joint's subtree, load rows summed
    leaf to root) and the sum of their parts (solved from the contact forces) both equal the
    statics written here with Pinocchio's subtree centres of mass (independent), to 1e-9 of the
    largest, with gravity and a payload."""
    arm = cp.load(str(MODELS / "arm_6r.urdf"))
    poses = arm.q_nominal + np.random.default_rng(1).uniform(-0.5, 0.5, (20, arm.model.nq))
    link, point = arm.link_point("tool")
    loads = [PointForce(link, [3.0, -2.0, -40.0], point), Torque(link, [0.5, 0.0, 0.2])]
    batch = arm.solve_many([loads] * len(poses), configurations=poses, gravity=True)
    reference = _subtree_statics(arm, poses, loads, np.array([0.0, 0.0, -9.81]))
    for joint in arm.tree_joints:
        whole = batch.reactions(joint.name)
        parts = sum(batch.reactions(joint.name, "joint", part) for part in PARTS)
        scale = float(np.abs(reference[joint.name]).max())
        assert whole == pytest.approx(reference[joint.name], abs=1e-9 * scale)
        assert parts == pytest.approx(reference[joint.name], abs=1e-9 * scale)
