"""Issue 33 item 6, "the first minute with a vendor file": what a new user met on unmodified
vendor files (example-robot-data's UR5), each refused with its cause instead of a zero or a
wrong answer.

The checks are on the messages' facts (which file, which element, which numbers), the numbers
computed here by hand from the files' text, not from the library's reading of them.
"""

from __future__ import annotations

import re
import subprocess
import sys
import warnings
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from conftest import MODELS, one_line, run_command
from test_corpus_robots import vendor_file

import clearance_pin as cp

UR5 = "ur_description/urdf/ur5_robot.urdf"

# docs/model-format.md's UR5 clearance file (TOML) in a given unit, its plays and journal
# length as given (the docs' file is unit = "um" with 10, 5 and 30_000)
UR5_PLAY = """unit = "{unit}"

[defaults.revolute]
type = "revolute"
radial_clearance = {radial}
axial_clearance = {axial}
length = {length}
driven = true

[joints.shoulder_lift_joint]
q = -1.0
[joints.elbow_joint]
q = 1.2

[[forces]]
link = "tool0"
point = [0, 0, {point}]
value = [20.0, -30.0, -50.0]
"""


def ur5() -> Path:
    return vendor_file(UR5)


def play_file(tmp_path: Path, unit: str, radial, axial, length, point) -> Path:
    path = tmp_path / f"ur5_play_{unit}.toml"
    path.write_text(
        UR5_PLAY.format(unit=unit, radial=radial, axial=axial, length=length, point=point)
    )
    return path


# -- 1. no clearance read at all -------------------------------------------------------------------
def test_a_vendor_urdf_without_clearances_is_refused():
    """The UR5 as shipped, no block and no clearance file: it solved to 'indeterminate, ok=True,
    energy 0 J' with every table zero. Now a ModelError saying how to add clearances."""
    with pytest.raises(cp.ModelError) as caught:
        cp.load(ur5())
    assert caught.value.source == str(ur5())
    assert caught.value.element == "<clearance_pin>"
    assert "no clearances" in caught.value.problem
    assert "--clearances FILE" in caught.value.problem


@pytest.mark.parametrize(
    "command", [["solve"], ["accuracy", "--output", "tool0", "--poses", "3"], ["envelope"]]
)
def test_the_command_line_refuses_a_vendor_urdf_without_clearances(capsys, command):
    """exit 2, one line naming the file and how to add clearances (solve exited 0 with zeros,
    accuracy spoke of an unblocked motion)."""
    status, _, err = run_command(capsys, command[0], ur5(), *command[1:])
    assert status == 2
    line = one_line(err)
    assert str(ur5()) in line and "no clearances" in line and "--clearances FILE" in line


def test_an_mjcf_file_without_clearances_is_refused():
    text = """<mujoco model="arm"><worldbody><body name="upper"><joint name="j1" axis="0 0 1"/>
      <geom type="capsule" size="0.02" fromto="0 0 0 0.3 0 0"/></body></worldbody></mujoco>"""
    with pytest.raises(cp.ModelError, match="no clearances: the MJCF file") as caught:
        cp.loads(text, source="arm.xml")
    assert caught.value.source == "arm.xml"
    assert "<clearance_pin> block to the URDF" not in caught.value.problem  # MJCF: a file only
    # an explicit empty clearance set is a model of ideal joints, on purpose
    assert cp.loads(text, source="arm.xml", clearances={}).tree_joints[0].clearance.max_play == 0


def test_a_block_without_plays_is_still_read():
    """A block that states only a drive stiffness (no play) is clearance information: read."""
    text = (
        ur5()
        .read_text()
        .replace(
            "</robot>",
            '<clearance_pin><default joint_type="revolute" driven="true" drive_stiffness="3e4"/>'
            "</clearance_pin></robot>",
        )
    )
    mechanism = cp.loads(text)
    assert all(j.clearance.max_play == 0.0 for j in mechanism.tree_joints)


# -- 2. units mixed ----------------------------------------------------------------------------------
def test_plays_typed_in_um_in_a_file_stating_mm_are_refused(tmp_path):
    """unit = "mm", journal 30 (mm, right), plays 10 and 5 typed in um: it solved with ok=True
    and the tool moving 1.09 m. Every play is 5/30 = 16.7 % .. 10/30 = 33.3 % of its journal (by
    hand), far beyond any fit: refused, naming the unit the plays are normal in."""
    clearances = play_file(tmp_path, "mm", 10, 5, 30, 50)
    with pytest.raises(cp.ModelError) as caught:
        cp.load(ur5(), clearances=clearances)
    assert caught.value.source == str(clearances)
    problem = caught.value.problem
    assert "16.7 .. 33.3 % of its journal" in problem
    assert "plays are likely in um" in problem
    # the same file with the plays in mm is read
    cp.load(ur5(), clearances=play_file(tmp_path, "mm", 0.010, 0.005, 30, 50))


def test_one_loose_play_in_a_file_stating_its_unit_is_not_refused(tmp_path):
    """One joint with a 3 % play (0.9 mm on its 30 mm journal: a loose guide may be meant), the
    others normal: read, and silent (3 % is within 10x of the normal 1 %). The refusal needs
    every play of the file beyond 2 %."""
    text = UR5_PLAY.format(unit="mm", radial=0.010, axial=0.005, length=30, point=50)
    text += "[joints.wrist_3_joint]\nradial_clearance = 0.9\n"
    path = tmp_path / "one_loose.toml"
    path.write_text(text)
    with warnings.catch_warnings():
        warnings.simplefilter("error", cp.ClearancePinWarning)
        mechanism = cp.load(ur5(), clearances=path)
    assert mechanism.joints["wrist_3_joint"].clearance.max_play == pytest.approx(0.9e-3)


def _ur5_in_mm(tmp_path: Path) -> Path:
    """The UR5 as a URDF exported in mm: every origin's xyz times 1000 (ElementTree)."""
    tree = ET.parse(ur5())
    for origin in tree.getroot().iter("origin"):
        if origin.get("xyz"):
            origin.set("xyz", " ".join(repr(1e3 * float(v)) for v in origin.get("xyz").split()))
    path = tmp_path / "ur5_mm.urdf"
    tree.write(path)
    return path


def test_a_urdf_exported_in_mm_is_refused_naming_the_urdf(tmp_path):
    """Origins 1000x, the docs' right clearance file (um): it solved with ok=True, the tool
    moving 0.796 m (862 um right), the warnings blaming the clearance file. Now refused naming
    the URDF and its likely unit. The first journal joins shoulder_pan_joint's parts: the
    shoulder link's two joint origins 0.089159 m apart in the URDF text (shoulder_lift_joint's
    origin xyz="0.0 0.13585 0.0" makes it 0.13585 m), times 1000."""
    urdf = _ur5_in_mm(tmp_path)
    clearances = play_file(tmp_path, "um", 10, 5, "30_000", "50_000")
    with pytest.raises(cp.ModelError) as caught:
        cp.load(urdf, clearances=clearances)
    assert caught.value.source == str(urdf)
    assert caught.value.element == "<robot>"
    problem = caught.value.problem
    assert "1000x too large" in problem and "exported in mm" in problem
    assert str(clearances) in problem
    part = float(re.search(r"length 0\.03 m is \S+ of (\S+) m", problem).group(1))
    assert part == pytest.approx(135.85, rel=1e-9)


def test_a_urdf_exported_in_mm_with_a_clearance_file_in_proportion_is_warned(tmp_path):
    """The same URDF beside the file in "mm" (plays 10 mm, journals 30 m: in proportion with
    the 1000x parts): it solved to 1.36 m with ok=True and no warning. Now the URDF is warned
    of; the largest part, by hand from the URDF text: the upper arm between shoulder_lift_joint
    and elbow_joint, elbow_joint's origin xyz="0.0 -0.1197 0.425" (norm 0.44154 m), x1000."""
    urdf = _ur5_in_mm(tmp_path)
    clearances = play_file(tmp_path, "mm", 10, 5, "30_000", "50_000")
    with pytest.warns(cp.SuspectValueWarning) as record:
        cp.load(urdf, clearances=clearances)
    assert len(record) == 1
    message = str(record[0].message)
    assert message.startswith(f"{urdf}: <robot>: the model's largest part is")
    assert record[0].filename == __file__  # the caller's line
    assert "exported in mm" in message
    largest = float(re.search(r"largest part is (\S+) m", message).group(1))
    assert largest == pytest.approx(1e3 * np.hypot(0.1197, 0.425), rel=1e-5)


def test_a_serial_arm_turned_beyond_validity_is_not_said_near_a_toggle():
    """A block inside the URDF is SI by the URDF's rules: plays typed in mm (unit="mm" with
    10 and 5) on a 30 mm journal are warned, not refused. The solve's validity warning named a
    toggle position, which a serial arm has not; it names the plays."""
    block = (
        '<clearance_pin unit="mm"><default joint_type="revolute" type="revolute" '
        'radial_clearance="10" axial_clearance="5" length="30" driven="true"/>'
        '<force link="tool0" point="0 0 50" value="20 -30 -50"/></clearance_pin>'
    )
    text = ur5().read_text().replace("</robot>", block + "</robot>")
    with pytest.warns(cp.SuspectValueWarning) as warned:
        mechanism = cp.loads(text, source="ur5_mm_plays.urdf")
    # every play beyond 1 % of its 30 mm journal (length_check), and beyond 5 % of the parts
    # of the three shoulder and wrist joints (plausibility)
    suspect = [str(w.message) for w in warned]
    assert all("of its own length" in m or "of its part's size" in m for m in suspect)
    assert sum("of its part's size" in m for m in suspect) == 3
    with pytest.warns(cp.ConditioningWarning) as record:
        mechanism.solve()
    messages = [str(w.message) for w in record if issubclass(w.category, cp.ConditioningWarning)]
    assert messages and all("toggle" not in m for m in messages)
    assert any("plays are large for their journals" in m for m in messages)


# -- 4. no joints, too deep a tree ---------------------------------------------------------------
def test_a_urdf_without_joints_exits_2(tmp_path, capsys):
    """One link, no joint (a block, so that clearances are given): it exited 4 with NumPy's
    'need at least one array to concatenate'."""
    path = tmp_path / "one_link.urdf"
    path.write_text('<robot name="r"><link name="base"/><clearance_pin/></robot>')
    status, _, err = run_command(capsys, "solve", path)
    assert status == 2
    line = one_line(err)
    assert "no joints" in line and "1 link(s), 0 fixed joint(s)" in line


def test_an_mjcf_file_without_joints_is_refused():
    text = '<mujoco><worldbody><body name="b"><geom size="0.1"/></body></worldbody></mujoco>'
    with pytest.raises(cp.ModelError, match="no joints"):
        cp.loads(text, source="b.xml", clearances={})


def _chain(joints: int) -> str:
    links = ['<robot name="chain"><link name="l0"/>']
    for i in range(1, joints + 1):
        links.append(
            f'<link name="l{i}"/><joint name="j{i}" type="continuous"><parent link="l{i - 1}"/>'
            f'<child link="l{i}"/><origin xyz="0.1 0 0"/><axis xyz="0 0 1"/></joint>'
        )
    return "".join(links) + "<clearance_pin/></robot>"


def test_a_5000_joint_chain_is_refused_before_pinocchio_reads_it(tmp_path):
    """Pinocchio's URDF reader crashed the process (SIGSEGV) on it. Run in a subprocess, so that
    a regression fails this test instead of killing the suite."""
    path = tmp_path / "chain.urdf"
    path.write_text(_chain(5000))
    done = subprocess.run(
        [sys.executable, "-m", "clearance_pin", "solve", str(path)],
        capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip
    assert done.returncode == 2, done.stderr
    line = one_line(done.stderr)
    assert "5000 joints deep" in line and "at most 1000" in line


def test_a_chain_at_the_limit_is_read():
    mechanism = cp.loads(_chain(1000))
    assert len(mechanism.tree_joints) == 1000


def test_mjcf_bodies_nested_too_deep_are_refused():
    """Pinocchio's MJCF reader's memory grows faster than the square of the depth (a load took
    1.8 GB at 300 bodies, 13.8 GB at 600)."""
    depth = 201
    bodies = "".join(f'<body name="b{i}"><joint name="j{i}"/>' for i in range(depth))
    text = f"<mujoco><worldbody>{bodies}{'</body>' * depth}</worldbody></mujoco>"
    with pytest.raises(cp.ModelError, match="nested more than 200 deep") as caught:
        cp.loads(text, source="deep.xml", clearances={})
    assert caught.value.element == "<body name='b200'>"


# -- 5. counts bounded, outputs never an input ---------------------------------------------------
@pytest.mark.parametrize(
    ("options", "words"),
    [
        (["--poses", "100000000000"], "--poses: expected an integer from 1 to 1000000"),
        (["--poses", "0"], "--poses: expected an integer from 1 to 1000000"),
        (["--seed", "-1"], "--seed: expected an integer >= 0"),
    ],
)
def test_accuracy_counts_are_bounded(capsys, options, words):
    """--poses 1e11 printed NumPy's 4.37 TiB allocation traceback (exit 1); --seed -1 NumPy's
    'expected non-negative integer' traceback."""
    status, _, err = run_command(
        capsys, "accuracy", MODELS / "arm_6r.urdf", "--output", "tool", *options
    )
    assert status == 2
    assert words in one_line(err)


@pytest.mark.parametrize("option", ["--json", "--plot"])
@pytest.mark.parametrize("input_file", ["model", "clearances"])
def test_an_output_file_that_is_an_input_is_refused_before_any_work(
    tmp_path, capsys, option, input_file
):
    """`envelope m.urdf --json m.urdf` overwrote the model. The path is given another way
    (through its folder's '..'), compared resolved; the file is left as it was."""
    from test_cli import _beside

    urdf, clearances = _beside(tmp_path, MODELS / "arm_6r.urdf")
    target = urdf if input_file == "model" else clearances
    before = target.read_bytes()
    same = tmp_path / ".." / tmp_path.name / target.name
    status, _, err = run_command(
        capsys, "envelope", urdf, "--clearances", clearances, "--output", "tool", option, same
    )
    assert status == 2
    line = one_line(err)
    what = "the model file" if input_file == "model" else "the clearance file"
    assert f"{option}: expected a file other than the inputs" in line and what in line
    assert target.read_bytes() == before


def test_accuracy_json_onto_its_configurations_file_is_refused(tmp_path, capsys):
    configurations = tmp_path / "poses.txt"
    configurations.write_text("0 0 0 0 0 0\n")
    status, _, err = run_command(
        capsys, "accuracy", MODELS / "arm_6r.urdf", "--output", "tool",
        "--configurations", configurations, "--json", configurations,
    )  # fmt: skip
    assert status == 2
    assert "the --configurations file" in one_line(err)
    np.testing.assert_array_equal(np.loadtxt(configurations), np.zeros(6))  # left unwritten


# -- 6. each thing listed once -------------------------------------------------------------------
def test_an_unknown_frame_lists_each_frame_once():
    """The 6R arm's links wrist_1 .. wrist_3 share their names with their joints: two Pinocchio
    frames each, listed twice. Counted against the frame names themselves (Pinocchio)."""
    mechanism = cp.load(MODELS / "arm_6r.urdf")
    names = [frame.name for frame in mechanism.model.frames]
    assert len(set(names)) < len(names)  # the case: names shared by two frames
    with pytest.raises(cp.ArgumentError) as caught:
        mechanism.solve(outputs=["nope"])
    listed = re.search(r"a frame of '[^']+' \(([^)]*)\)", str(caught.value)).group(1)
    assert sorted(listed.split(", ")) == sorted(set(names))
    with pytest.raises(cp.NotFoundError) as missing:
        mechanism.accuracy("nope", mechanism.q_nominal[None, :])
    assert sorted(missing.value.valid) == sorted(set(names))
    listed = str(missing.value).split("are: ", 1)[1].split(", ")
    assert sorted(listed) == sorted(set(names))


def test_free_motions_sharing_their_joints_are_listed_once():
    """Nine free motions of the same joints (as the exact model's refusal met them: each
    motion described by its components, largest first): each component once."""
    components = [f"joint 'j{k}' alpha (spin about the joint axis)" for k in range(6)]
    motions = [
        "; ".join([*components[i % 3 :], "and 2 smaller components (under 20 % of the largest)"])
        for i in range(9)
    ]
    listed = cp.errors.motions_listed_once(motions)
    assert listed.split("; ") == [
        *components,
        "and 2 smaller components (under 20 % of the largest)",
    ]
    error = cp.UnboundedLoadError(motions, 0.5, "at the exact model's solved pose")
    assert str(error).count("joint 'j0' alpha") == 1
    assert error.motions == motions  # the attribute keeps every motion


# -- 7. couplings read from files ----------------------------------------------------------------
def test_a_mimic_on_a_fixed_joint_is_ignored_naming_the_urdf(tmp_path):
    """TALOS's left arm as shipped: its gripper's fixed joints carry <mimic> (they refused the
    whole file, naming the clearance file). Now one warning naming the URDF and those joints
    (found here with ElementTree)."""
    urdf = vendor_file("talos_data/robots/talos_left_arm.urdf")
    root = ET.parse(urdf).getroot()
    fixed = [
        j.get("name")
        for j in root.findall("joint")
        if j.get("type") == "fixed" and j.find("mimic") is not None
    ]
    assert fixed
    clearances = tmp_path / "talos_play.toml"
    clearances.write_text(
        'unit = "um"\n[defaults.revolute]\ntype = "revolute"\nradial_clearance = 10\n'
        "axial_clearance = 5\nlength = 30_000\ndriven = true\n"
    )
    with pytest.warns(cp.SuspectValueWarning) as record:
        mechanism = cp.load(urdf, clearances=clearances)
    assert len(record) == 1
    message = str(record[0].message)
    assert message.startswith(f"{urdf}: <mimic> of fixed joint(s)")
    assert record[0].filename == __file__  # the caller's line
    assert all(message.count(repr(name)) == 1 for name in fixed)
    assert not any(joint.name in fixed for joint in mechanism.tree_joints)


def test_a_one_joint_mjcf_equality_hints_the_lock_where_mujoco_holds_the_joint():
    """<equality><joint joint1="j1" polycoef="0.2 0 0 0 0"/> on a hinge with ref="30" (degrees):
    the hint said q="0.2". MuJoCo holds the joint at qpos0 + a0: its constraint residual is
    zero there (checked with MuJoCo itself), and the hint says that value."""
    mujoco = pytest.importorskip("mujoco")
    text = """<mujoco><worldbody><body name="a"><joint name="j1" axis="0 0 1" ref="30"/>
      <geom size="0.1"/><body name="b" pos="0.3 0 0"><joint name="j2" axis="0 0 1"/>
      <geom size="0.1"/></body></body></worldbody>
      <equality><joint joint1="j1" polycoef="0.2 0 0 0 0"/></equality></mujoco>"""
    with pytest.raises(cp.ModelError) as caught:
        cp.loads(text, source="eq.xml", clearances={})
    hinted = float(re.search(r'<lock joint="j1" q="([^"]+)"/>', caught.value.problem).group(1))
    model = mujoco.MjModel.from_xml_string(text)
    data = mujoco.MjData(model)
    data.qpos[:] = model.qpos0
    data.qpos[0] = hinted
    mujoco.mj_forward(model, data)
    assert data.nefc == 1
    assert abs(data.efc_pos[0]) < 1e-12
    assert hinted == pytest.approx(np.radians(30.0) + 0.2, rel=1e-12)  # ref [deg] + a0 [rad]


# -- 3. MJCF default classes on joints -----------------------------------------------------------
CLASSED_ARM = """<mujoco>
  <default>
    <default class="arm"><joint axis="0 1 0"/></default>
    <default class="other"><joint damping="1"/></default>
  </default>
  <worldbody>
    <body name="base" childclass="arm"><joint name="j1"/><geom size="0.05"/>
      <body name="fore" pos="0.3 0 0"><joint name="j2" class="other"/><geom size="0.05"/>
      </body>
    </body>
  </worldbody>
</mujoco>"""


def test_a_joint_with_its_own_class_takes_that_class_axis_as_mujoco():
    """j2 names class 'other' (no axis; its parent is main: MuJoCo's z) inside a childclass
    'arm' that gives y: MuJoCo reads z (its jnt_axis); it was refused (Pinocchio's reader took
    the childclass's y)."""
    mujoco = pytest.importorskip("mujoco")
    from test_mjcf_orientation import AGREE, disagreement, pinocchio_model

    reference = mujoco.MjModel.from_xml_string(CLASSED_ARM)
    np.testing.assert_array_equal(reference.jnt_axis, [[0, 1, 0], [0, 0, 1]])
    model = pinocchio_model(CLASSED_ARM)
    assert disagreement(CLASSED_ARM, model) < AGREE
    assert disagreement(CLASSED_ARM, model, {"j1": 0.4, "j2": -0.7}) < AGREE


def _classed_mjcf(rng: np.random.Generator) -> str:
    """A chain of 1 to 4 bodies, each maybe with a childclass, its hinge or slide maybe with a
    class of its own and maybe an axis of its own; classes nested (b inside a), some giving a
    joint axis, pos or type, some not."""

    def vector(scale: float) -> str:
        return " ".join(f"{v:.6g}" for v in rng.uniform(-scale, scale, 3))

    def joint_default() -> str:
        attributes = []
        if rng.random() < 0.6:
            attributes.append(f'axis="{vector(1.0)}"')
        if rng.random() < 0.3:
            attributes.append(f'pos="{vector(0.1)}"')
        if rng.random() < 0.3:
            attributes.append(f'type="{rng.choice(["hinge", "slide"])}"')
        return f"<joint {' '.join(attributes)}/>" if attributes else ""

    classes = ["a", "b", "c"]
    defaults = (
        f'<default>{joint_default()}<default class="a">{joint_default()}'
        f'<default class="b">{joint_default()}</default></default>'
        f'<default class="c">{joint_default()}</default></default>'
    )

    def pick() -> str | None:
        return str(rng.choice(classes)) if rng.random() < 0.6 else None

    count = int(rng.integers(1, 5))
    text = ""
    for index in reversed(range(count)):
        childclass, own = pick(), pick()
        attributes = [f'name="j{index}"']
        if own is not None:
            attributes.append(f'class="{own}"')
        if rng.random() < 0.25:
            attributes.append(f'axis="{vector(1.0)}"')
        body = f'<body name="b{index}" pos="{vector(0.3)}"'
        body += f' childclass="{childclass}">' if childclass else ">"
        text = f'{body}<joint {" ".join(attributes)}/><geom size="0.02"/>{text}</body>'
    return f"<mujoco>{defaults}<worldbody>{text}</worldbody></mujoco>"


def test_random_classed_joints_are_placed_as_mujoco():
    """200 random chains whose joints take their axis, pos and type through classes and
    childclasses: every one read, every joint where MuJoCo puts it (world axis and anchor, at
    qpos0 and at a random configuration). Before, files whose joint named a class inside
    another childclass were refused."""
    pytest.importorskip("mujoco")
    from test_mjcf_orientation import AGREE, disagreement, pinocchio_model

    rng = np.random.default_rng(33)
    worst = 0.0
    for _ in range(200):
        text = _classed_mjcf(rng)
        model = pinocchio_model(text)  # a refusal fails the test
        names = [model.names[j] for j in range(1, model.njoints)]
        qpos = {n: float(rng.uniform(-1, 1)) for n in names}
        worst = max(worst, disagreement(text, model), disagreement(text, model, qpos))
    assert worst < AGREE


def test_a_mimic_of_a_fixed_leader_is_refused_naming_the_urdf(tmp_path):
    """A revolute joint mimicking a fixed one: refused naming the URDF and the mimic (it named
    the clearance file beside it)."""
    urdf = tmp_path / "pair.urdf"
    urdf.write_text(
        '<robot name="pair"><link name="base"/><link name="a"/><link name="b"/>'
        '<joint name="weld" type="fixed"><parent link="base"/><child link="a"/></joint>'
        '<joint name="hinge" type="revolute"><parent link="a"/><child link="b"/>'
        '<origin xyz="0.1 0 0"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" '
        'velocity="1"/><mimic joint="weld"/></joint></robot>'
    )
    clearances = tmp_path / "pair_play.xml"
    clearances.write_text('<clearance_pin unit="m"/>')
    with pytest.raises(cp.ModelError) as caught:
        cp.load(urdf, clearances=clearances)
    assert caught.value.source == str(urdf)
    assert caught.value.element == "<joint name='hinge'> <mimic joint='weld'>"
    assert "its leader is a fixed joint" in caught.value.problem
