"""Units that cannot be forgotten silently (issue 21, item 2).

Every length of a clearance file is judged against the mechanism's own geometry (the distances
between its joint centres and frames in the URDF), not against the file's other numbers
(clearance_pin/model/length_check.py). The matrix: every length field of the block, written in
each of m, mm and um, in a file that declares each unit. A mis-declared field (written in one
unit, read in another) must give a ModelError or a SuspectValueWarning naming the field and its
element; a correct declaration none at all.

The reference values are physical, not the library's: a 10 um radial play, 5 um axial play,
30-60 mm journals and blocks, a force 50-300 mm from its link frame, a 0.1 mm tolerance, a 0.2 m
slide position. The mechanisms: the bundled 6R arm and slider-crank, a carriage on a rail written
here, and the UR5 of example-robot-data (untouched vendor URDF, skipped when not installed).
"""

from __future__ import annotations

import re
import sys
import warnings
from dataclasses import dataclass
from decimal import Decimal
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from conftest import MODELS, ROOT

import clearance_pin as cp

sys.path.insert(0, str(ROOT / "benchmarks"))
import arms  # benchmarks/arms.py: where the vendor files are

UNITS = {"m": 0, "mm": -3, "um": -6}


@dataclass(frozen=True)
class Mechanism:
    """A model file and a clearance file template whose fields {name} hold lengths [m]."""

    name: str
    urdf: str  # the URDF's text, without a block of its own
    template: str  # XML clearance file; {unit} and one {field} per length
    values: dict[str, float]  # field -> its true value [m]
    elements: dict[str, str]  # field -> the name of the element that carries it


def _without_block(text: str) -> str:
    return re.sub(r"<clearance_pin>.*?</clearance_pin>", "", text, flags=re.S)


ARM_6R = Mechanism(
    "arm_6r",
    _without_block((MODELS / "arm_6r.urdf").read_text()),
    """<clearance_pin unit="{unit}">
  <joint name="shoulder_pan" type="revolute" radial_clearance="{radial_clearance}"
         axial_clearance="{axial_clearance}" length="{length}" driven="true"/>
  <joint name="elbow" type="revolute" diametral_clearance="{diametral_clearance}"
         axial_clearance="5" length="30000" driven="true" q="1.2"/>
  <force link="tool" point="0 0 {point}" value="0 0 -50"/>
  <dimension name="upper_arm" joint="elbow" direction="1 0 0" tolerance="{tolerance}"/>
</clearance_pin>""",
    {
        "radial_clearance": 1e-5,
        "axial_clearance": 5e-6,
        "length": 0.03,
        "diametral_clearance": 2e-5,
        "point": 0.05,
        "tolerance": 1e-4,
    },
    {
        "radial_clearance": "shoulder_pan",
        "axial_clearance": "shoulder_pan",
        "length": "shoulder_pan",
        "diametral_clearance": "elbow",
        "point": "tool",
        "tolerance": "upper_arm",
    },
)

SLIDER_CRANK = Mechanism(
    "slider_crank",
    _without_block((MODELS / "slider_crank.urdf").read_text()),
    """<clearance_pin unit="{unit}">
  <joint name="crank_pivot" type="planar_revolute" radial_clearance="50" driven="true"
         q="-1.0471975511965976"/>
  <joint name="pin_A" type="planar_revolute" radial_clearance="50" q="1.41637017008474"/>
  <joint name="pin_B" type="planar_revolute" radial_clearance="50" q="-0.3691726188881423"/>
  <loop_joint name="slide" type="prismatic" frame_a="guide" frame_b="slider"
              radial_clearance="{radial_clearance}" play_z="{play_z}" length="{length}"
              width="{width}" height="{height}" axis="1 0 0"/>
  <dimension name="r2" joint="pin_A" direction="1 0 0" tolerance="{tolerance}"/>
  <force link="slider" value="-100 0 0"/>
  <force link="rod" point="{point} 0 0" value="0 -20 0"/>
</clearance_pin>""",
    {
        "radial_clearance": 5e-5,
        "play_z": 5e-5,
        "length": 0.04,
        "width": 0.02,
        "height": 0.01,
        "tolerance": 1e-4,
        "point": 0.06,
    },
    {
        "radial_clearance": "slide",
        "play_z": "slide",
        "length": "slide",
        "width": "slide",
        "height": "slide",
        "tolerance": "r2",
        "point": "rod",
    },
)

CARRIAGE = Mechanism(
    "carriage",
    """<?xml version="1.0"?>
<robot name="carriage">
  <link name="base"/>
  <link name="carriage"><inertial><mass value="2"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="arm"><inertial><mass value="1"/><origin xyz="0.15 0 0"/>
    <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="tool"/>
  <joint name="rail" type="prismatic">
    <parent link="base"/><child link="carriage"/><axis xyz="1 0 0"/>
    <limit lower="0" upper="0.5" effort="100" velocity="1"/>
  </joint>
  <joint name="pivot" type="revolute">
    <parent link="carriage"/><child link="arm"/><origin xyz="0 0 0.1"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="100" velocity="1"/>
  </joint>
  <joint name="tool_mount" type="fixed">
    <parent link="arm"/><child link="tool"/><origin xyz="0.3 0 0"/>
  </joint>
</robot>""",
    """<clearance_pin unit="{unit}">
  <joint name="rail" type="prismatic" radial_clearance="{radial_clearance}" play_z="{play_z}"
         length="{length}" width="{width}" height="{height}" driven="true" q="{q}"/>
  <joint name="pivot" type="revolute" radial_clearance="10" axial_clearance="5"
         length="30000" driven="true" q="0.5"/>
  <force link="arm" point="{point} 0 0" value="0 -10 0"/>
</clearance_pin>""",
    {
        "radial_clearance": 2e-5,
        "play_z": 3e-5,
        "length": 0.06,
        "width": 0.04,
        "height": 0.02,
        "q": 0.2,
        "point": 0.3,
    },
    {
        "radial_clearance": "rail",
        "play_z": "rail",
        "length": "rail",
        "width": "rail",
        "height": "rail",
        "q": "rail",
        "point": "arm",
    },
)

UR5_URDF = "ur_description/urdf/ur5_robot.urdf"
UR5 = Mechanism(
    "ur5",
    "",  # the vendor file, read as installed
    """<clearance_pin unit="{unit}">
  <joint name="shoulder_pan_joint" type="revolute" radial_clearance="{radial_clearance}"
         axial_clearance="{axial_clearance}" length="{length}" driven="true" q="0.3"/>
  <joint name="elbow_joint" type="revolute" diametral_clearance="{diametral_clearance}"
         axial_clearance="5" length="30000" driven="true" q="1.2"/>
  <force link="tool0" point="0 0 {point}" value="20 -30 -50"/>
  <dimension name="upper_arm" joint="elbow_joint" direction="0 0 1" tolerance="{tolerance}"/>
</clearance_pin>""",
    ARM_6R.values,
    {
        "radial_clearance": "shoulder_pan_joint",
        "axial_clearance": "shoulder_pan_joint",
        "length": "shoulder_pan_joint",
        "diametral_clearance": "elbow_joint",
        "point": "tool0",
        "tolerance": "upper_arm",
    },
)

MECHANISMS = (ARM_6R, SLIDER_CRANK, CARRIAGE, UR5)
# the fixed numbers of the templates are in um (radial 50, length 30000): they are rewritten
# into the declared unit with the fields
FIXED_UM = ("50", "5", "10", "30000")


def _in_unit(value_m: float, unit: str) -> str:
    """The decimal text of a length [m] in ``unit`` (exact: 1e-05 m is 10 um)."""
    return format(Decimal(repr(value_m)).scaleb(-UNITS[unit]).normalize(), "f")


def clearance_text(mechanism: Mechanism, declared: str, field: str, written: str) -> str:
    """The mechanism's clearance file declaring ``declared``, every length in that unit except
    ``field``, whose number is written in ``written``."""
    values = {name: _in_unit(v, declared) for name, v in mechanism.values.items()}
    values[field] = _in_unit(mechanism.values[field], written)
    text = mechanism.template

    def fixed(match: re.Match[str]) -> str:  # the template's fixed lengths (in um)
        key, number = match.group(1), match.group(2)
        return f'{key}="{_in_unit(float(number) * 1e-6, declared)}"'

    text = re.sub(r'(radial_clearance|axial_clearance|length)="(\d+)"', fixed, text)
    return text.format(unit=declared, **values)


def model_path(mechanism: Mechanism, directory: Path) -> Path:
    if mechanism.name == "ur5":
        path = arms.vendor_file(UR5_URDF)
        if path is None:
            pytest.skip("example-robot-data is not installed (pip install clearance_pin[test])")
        return path
    path = directory / f"{mechanism.name}.urdf"
    path.write_text(mechanism.urdf)
    return path


def outcome(model: Path, clearances: Path, field: str, element: str) -> tuple[str, list[str]]:
    """("error" | "warning" | "silent", messages): what loading says, counting only messages
    that name the field and its element."""
    pattern = re.compile(rf"(?<![\w]){re.escape(field)}(?![\w])")
    try:
        with warnings.catch_warnings(record=True) as record:
            warnings.simplefilter("always")
            cp.load(model, clearances=clearances)
    except cp.ModelError as error:
        named = pattern.search(error.problem) and element in str(error)
        return ("error" if named else "unnamed error", [str(error)])
    messages = [str(w.message) for w in record if issubclass(w.category, cp.ClearancePinWarning)]
    if any(pattern.search(m) and element in m for m in messages):
        return "warning", messages
    return ("silent" if not messages else "unnamed warning"), messages


CELLS = [
    (mechanism, field, written, declared)
    for mechanism in MECHANISMS
    for field in mechanism.values
    for written in UNITS
    for declared in UNITS
]


@pytest.mark.parametrize(
    ("mechanism", "field", "written", "declared"),
    CELLS,
    ids=[f"{m.name}-{f}-{w}-read-{d}" for m, f, w, d in CELLS],
)
def test_unit_matrix(mechanism, field, written, declared, tmp_path):
    """Written in one unit and read in another: refused or warned, naming the field and its
    element. Written and read in the same unit: no warning and no error."""
    model = model_path(mechanism, tmp_path)
    clearances = tmp_path / "play.xml"
    clearances.write_text(clearance_text(mechanism, declared, field, written))
    result, messages = outcome(model, clearances, field, mechanism.elements[field])
    if written == declared:
        assert (result, messages) == ("silent", [])
    else:
        assert result in ("error", "warning"), (result, messages)


UNSTATED = [
    (mechanism, field, written)
    for mechanism in MECHANISMS
    for field in mechanism.values
    for written in UNITS
]


@pytest.mark.parametrize(
    ("mechanism", "field", "written"),
    UNSTATED,
    ids=[f"{m.name}-{f}-{w}-no-unit-line" for m, f, w in UNSTATED],
)
def test_a_file_without_a_unit_line_is_read_in_metres(mechanism, field, written, tmp_path):
    """A clearance file without a unit line is read in metres: a field written in m loads
    silently, one written in mm or um (1000x or 1e6x too large) is refused, naming it."""
    model = model_path(mechanism, tmp_path)
    clearances = tmp_path / "play.xml"
    text = clearance_text(mechanism, "m", field, written)
    clearances.write_text(text.replace(' unit="m"', ""))
    result, messages = outcome(model, clearances, field, mechanism.elements[field])
    if written == "m":
        assert (result, messages) == ("silent", [])
    else:
        assert result == "error", (result, messages)
        assert "no unit line" in messages[0]


# -- files without a unit line, single-field mistakes, the other routes ------------------------


def _docs_ur5(language: str) -> str:
    """The UR5 clearance file of docs/model-format.md (the fenced block after its marker)."""
    text = (ROOT / "docs" / "model-format.md").read_text()
    after = text.split(f"<!-- ur5 clearance file: {language} -->", 1)[1]
    match = re.search(r"```\w*\n(.*?)```", after, re.S)
    assert match is not None
    return match.group(1)


def test_the_docs_ur5_toml_without_its_unit_line_is_refused(tmp_path):
    """Issue 21: the docs' UR5 TOML with ``unit = "um"`` deleted solved to a 25.6 m tool
    displacement with ok=True. Its 10 (um) radial play read as 10 m is 73.6x the part of
    shoulder_pan_joint: the shoulder link, whose joint centres are 0.13585 m apart in the vendor
    URDF (shoulder_lift_joint's origin xyz="0.0 0.13585 0.0"); read in um it would be normal."""
    urdf = model_path(UR5, tmp_path)
    text = _docs_ur5("toml")
    assert 'unit = "um"' in text
    clearances = tmp_path / "ur5_play.toml"
    clearances.write_text(text.replace('unit = "um"', ""))
    with pytest.raises(cp.ModelError) as caught:
        cp.load(urdf, clearances=clearances)
    problem = caught.value.problem
    assert "shoulder_pan_joint" in caught.value.element
    assert "radial_clearance 10 m is 73.6x the part it joins (0.13585 m" in problem
    assert "was it written in um?" in problem and "no unit line" in problem


def test_the_docs_ur5_xml_without_its_unit_attribute_is_refused(tmp_path):
    """The XML form in mm without unit="mm": its plays (0.010 m) are 7x the normal band only,
    but its 30 (mm) journal read as 30 m is 221x the 0.13585 m part: refused, naming length
    and mm."""
    urdf = model_path(UR5, tmp_path)
    text = _docs_ur5("xml")
    assert '<clearance_pin unit="mm">' in text
    clearances = tmp_path / "ur5_play.xml"
    clearances.write_text(text.replace('<clearance_pin unit="mm">', "<clearance_pin>"))
    with pytest.raises(cp.ModelError, match=r"length 30 m is 221x the part it joins") as caught:
        cp.load(urdf, clearances=clearances)
    assert "was it written in mm?" in caught.value.problem


@pytest.mark.parametrize("language", ["xml", "toml"])
def test_the_docs_ur5_files_load_silently(language, tmp_path):
    """With their unit line, both docs files load with no warning."""
    urdf = model_path(UR5, tmp_path)
    clearances = tmp_path / f"ur5_play.{language}"
    clearances.write_text(_docs_ur5(language))
    with warnings.catch_warnings():
        warnings.simplefilter("error", cp.ClearancePinWarning)
        cp.load(urdf, clearances=clearances)


def test_a_journal_length_in_mm_in_a_metre_urdf_block_warns():
    """arm_6r.urdf's own block (SI) with one journal typed length="30" (mm meant): 30 m is 221x
    shoulder_pan's part (the shoulder, 0.136 m between its joint centres in the file), a
    warning naming the joint, length and mm (a URDF is SI: a block inside one is only warned
    unless the value is out by 1000x)."""
    text = (MODELS / "arm_6r.urdf").read_text()
    old = '<joint name="shoulder_pan" type="revolute" radial_clearance="1e-05" length="0.03"'
    assert old in text
    with pytest.warns(cp.SuspectValueWarning) as record:
        cp.loads(text.replace(old, old.replace('length="0.03"', 'length="30"')))
    messages = [str(w.message) for w in record if "length 30 m" in str(w.message)]
    assert len(messages) == 1
    assert "<joint name='shoulder_pan'>" in messages[0]
    assert "221x the part it joins (0.136 m" in messages[0]
    assert "was it written in mm?" in messages[0]


def test_a_journal_length_in_mm_in_a_file_without_a_unit_line_is_refused(tmp_path):
    """The same journal in a clearance file that states no unit: refused."""
    model = model_path(ARM_6R, tmp_path)
    text = clearance_text(ARM_6R, "m", "length", "mm").replace(' unit="m"', "")
    clearances = tmp_path / "play.xml"
    clearances.write_text(text)
    with pytest.raises(cp.ModelError, match=r"length 30 m is 221x") as caught:
        cp.load(model, clearances=clearances)
    assert "no unit line" in caught.value.problem


def test_a_whole_file_in_the_wrong_unit_is_refused_naming_the_unit(tmp_path):
    """arm_6r's file written in um but declaring mm: every length is 1000x too large. Each
    journal alone (30 m, 221x its 0.136 m part) would be a warning in a file that states its
    unit, but both journals of the file are out of proportion and both would be normal in um:
    the unit line is wrong, refused."""
    model = model_path(ARM_6R, tmp_path)
    values = {name: _in_unit(v, "um") for name, v in ARM_6R.values.items()}
    clearances = tmp_path / "play.xml"
    clearances.write_text(ARM_6R.template.format(unit="mm", **values))
    with pytest.raises(cp.ModelError) as caught:
        cp.load(model, clearances=clearances)
    problem = caught.value.problem
    assert "length 30 m is 221x the part it joins (0.136 m" in problem
    assert "every journal and block length of the file is out of proportion" in problem
    assert problem.endswith("its lengths are likely in um")


def test_one_journal_in_the_wrong_unit_is_only_warned(tmp_path):
    """The same file with one journal in um and the other in mm, as declared: a warning naming
    the one, no refusal (a typo in a unit the file means)."""
    model = model_path(ARM_6R, tmp_path)
    clearances = tmp_path / "play.xml"
    clearances.write_text(clearance_text(ARM_6R, "mm", "length", "um"))
    with pytest.warns(cp.SuspectValueWarning, match=r"length 30 m is 221x .* written in um\?"):
        cp.load(model, clearances=clearances)


def test_a_dict_in_micrometres_is_refused():
    """from_model's dict is SI: a 10 (um meant) radial play on arm_6r's shoulder_pan is 73.5x
    its 0.136 m part, 7350x beyond the normal 1e-2: refused, whatever the source."""
    model = cp.load(MODELS / "arm_6r.urdf").model
    clearances = {
        "shoulder_pan": {"type": "revolute", "radial_clearance": 10, "length": 0.03},
    }
    with pytest.raises(cp.ModelError, match=r"radial_clearance 10 m is 73\.5x") as caught:
        cp.from_model(model, clearances=clearances)
    assert "a dict of clearances is in metres" in caught.value.problem


def test_an_mjcf_model_is_judged_by_its_own_placements(tmp_path):
    """Beside an MJCF file the reference is the MJCF's geometry: the two-link arm of
    tests/test_mjcf.py (its upper arm a capsule from the shoulder to the elbow 0.3 m away,
    radius 0.02 m: 0.34 m end to end) with its clearance file, written in mm, declaring m: the
    25 (mm) journal of its default, read as 25 m on both joints, is 73.5x the upper arm; both
    journals agree on mm: refused. Declaring mm, as written: silent."""
    from test_mjcf import ARM_MJCF, ARM_PLAY

    model = tmp_path / "arm.xml"
    model.write_text(ARM_MJCF)
    clearances = tmp_path / "play.xml"
    clearances.write_text(ARM_PLAY.replace('unit="mm"', 'unit="m"'))
    with pytest.raises(cp.ModelError, match=r"length 25 m is 73\.5x the part it joins \(0\.34 m"):
        cp.load(model, clearances=clearances)
    clearances.write_text(ARM_PLAY)
    with warnings.catch_warnings():
        warnings.simplefilter("error", cp.ClearancePinWarning)
        cp.load(model, clearances=clearances)


PENDULUM = """<?xml version="1.0"?>
<robot name="pendulum">
  <link name="base"/>
  <link name="rod">
    <inertial><mass value="1"/><origin xyz="0 0 -0.25"/>
      <inertia ixx="0.02" iyy="0.02" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial>
    <collision><origin xyz="0 0 -0.25"/><geometry><box size="0.02 0.02 0.5"/></geometry></collision>
  </link>
  <joint name="axle" type="revolute">
    <parent link="base"/><child link="rod"/><axis xyz="0 1 0"/>
    <limit lower="-3" upper="3" effort="10" velocity="1"/>
  </joint>
  <clearance_pin>
    <joint name="axle" type="revolute" radial_clearance="1e-05" axial_clearance="5e-06"
           length="LENGTH" driven="true"/>
  </clearance_pin>
</robot>
"""


def test_a_lone_joint_is_judged_by_its_link_geometry():
    """A pendulum on one axle has a single joint centre, so no distance between joint centres
    gives its size: its 0.5 m collision box does (diagonal sqrt(0.02^2 + 0.02^2 + 0.5^2) =
    0.5008 m). A 30 mm journal typed as 30 (m) is 59.9x that: warned, naming mm. Without the
    box the journal cannot be judged; only the play measured against it looks odd."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", cp.ClearancePinWarning)
        cp.loads(PENDULUM.replace("LENGTH", "0.03"))
    with pytest.warns(cp.SuspectValueWarning, match=r"length 30 m is 59\.9x the part it joins"):
        cp.loads(PENDULUM.replace("LENGTH", "30"))
    without_box = re.sub(r"<collision>.*?</collision>", "", PENDULUM)
    with pytest.warns(cp.SuspectValueWarning) as record:
        cp.loads(without_box.replace("LENGTH", "30"))
    messages = [str(w.message) for w in record]
    assert not any("length 30 m is" in m for m in messages)
    assert any("radial_clearance 1e-05 m is 3.33e-07 of its own length" in m for m in messages)


@pytest.mark.parametrize("name", ["arm_6r", "slider_crank", "younes_two_spheres"])
def test_world_placements_are_pinocchios_forward_kinematics(name):
    """The extent's placements, composed joint by joint without a pin.Data (which takes 2 s to
    build for a 300-joint chain), equal pinocchio.forwardKinematics to round-off."""
    from clearance_pin.model.reference_sizes import world_placements

    mechanism = cp.load(MODELS / f"{name}.urdf")
    model = mechanism.model
    q = pin.randomConfiguration(model, -np.ones(model.nq), np.ones(model.nq))
    data = model.createData()
    pin.forwardKinematics(model, data, q)
    for expected, got in zip(data.oMi, world_placements(model, q), strict=True):
        np.testing.assert_allclose(got.homogeneous, expected.homogeneous, rtol=0, atol=1e-14)


PENDULUM_MJCF = """<mujoco model="pendulum">
  <worldbody>
    <body name="bob">
      <joint name="axle" type="hinge" axis="0 1 0" range="-3 3" limited="true"/>
      <geom type="capsule" fromto="0 0 0 0 0 -0.5" size="0.02"/>
    </body>
  </worldbody>
</mujoco>
"""


def test_a_lone_mjcf_joint_is_judged_by_its_geoms(tmp_path):
    """The MJCF pendulum: one hinge, no other joint or site, so only its geom gives a size: a
    capsule from the axle 0.5 m down, radius 0.02 m (MuJoCo's size), 0.54 m end to end. A 30 mm
    journal written as 30 in a metre file is 55.6x that: refused (no unit line), naming mm."""
    model = tmp_path / "pendulum.xml"
    model.write_text(PENDULUM_MJCF)
    clearances = tmp_path / "play.toml"
    play = 'type = "revolute"\nradial_clearance = 1e-5\nlength = {}\ndriven = true\n'
    clearances.write_text("[joints.axle]\n" + play.format("0.03"))
    with warnings.catch_warnings():
        warnings.simplefilter("error", cp.ClearancePinWarning)
        cp.load(model, clearances=clearances)
    clearances.write_text("[joints.axle]\n" + play.format("30"))
    with pytest.raises(cp.ModelError, match=r"length 30 m is 55\.6x the part it joins \(0\.54 m"):
        cp.load(model, clearances=clearances)


def test_loop_joints_given_as_a_dict_are_judged_too():
    """from_model(loop_joints=...) is a dict in SI like the clearances: the slider-crank's slide
    with a 40 (mm meant) block length read as 40 m. The slider and the guide carry one joint
    centre each, so the reference is the mechanism's extent at the drawn configuration (crank
    and rod in line along x: 0.05 + 0.12 = 0.17 m): 235x, a warning naming mm (refused only from
    1000x beyond the normal 3: a dict states its unit by the API)."""
    mechanism = cp.load(MODELS / "slider_crank.urdf")
    slide = {
        "type": "prismatic",
        "frame_a": "guide",
        "frame_b": "slider",
        "radial_clearance": 5e-5,
        "length": 40,
        "axis": [1, 0, 0],
    }
    expected = r"length 40 m is 235x the mechanism's extent \(0\.17 m.* written in mm\?"
    with pytest.warns(cp.SuspectValueWarning, match=expected):
        cp.from_model(mechanism.model, loop_joints={"slide": slide})
