"""Clearance files beside an unmodified URDF (issue 14): the <clearance_pin> block as its own XML
or TOML file, lengths in the unit the file states, defaults by joint type.

Checks:

- self-consistency: every bundled model and every tests/data URDF, split into the URDF without
  its block and the block as a clearance file (XML in m, XML in mm, TOML in um; the values
  rescaled here in decimal arithmetic), reads as the same mechanism and gives bitwise the same
  answers as the file with its block. This compares the library with itself; it shows the three
  spellings and the unit conversion change nothing, not that the answers are right;
- the real UR5 of example-robot-data with a clearance file (defaults by type, in mm or um) gives
  the answer of tests/test_corpus_robots.py's block-in-text construction, whose journals are
  checked there against a closed form; the UR5 example of docs/model-format.md is that file;
- independent: one driven journal loaded above its end, written in mm and in um, against its
  closed form (derived in ``test_single_journal_matches_its_closed_form``);
- bad clearance files raise ModelError naming the file, the element and the problem.
"""

from __future__ import annotations

import json
import re
import xml.etree.ElementTree as ET
from decimal import Decimal
from pathlib import Path

import numpy as np
import pytest
from conftest import MODEL_FILES, ROOT

import clearance_pin as cp

DATA_FILES = sorted((ROOT / "tests" / "data").glob("*.urdf"))
BLOCK = re.compile(r"\s*<clearance_pin>.*?</clearance_pin>", re.S)
LENGTHS = {
    "radial_clearance",
    "diametral_clearance",
    "axial_clearance",
    "play_z",
    "length",
    "width",
    "height",
}
VECTORS = {"axis", "point", "value", "direction", "rotation_axis"}
STRINGS = {"type", "frame_a", "frame_b", "link", "joint", "grade"}
BOOLEANS = {"driven", "enabled"}
POWER = {"m": 0, "mm": 3, "um": 6}  # the file's number = metres x 10**POWER


# -- helpers: a model file split into an unmodified URDF and its clearance file ---------------------
def split(text: str) -> tuple[str, ET.Element]:
    """(the URDF text without its block, the block), the URDF otherwise unchanged."""
    block = ET.fromstring(text).find("clearance_pin")
    assert block is not None
    bare, count = BLOCK.subn("", text)
    assert count == 1
    return bare, block


def rescaled(text: str, power: int) -> str:
    """A number's text times 10**power, exactly (decimal)."""
    return format(Decimal(text).scaleb(power), "f") if power else text


def in_unit(block: ET.Element, urdf: str, unit: str) -> ET.Element:
    """The block with every length in ``unit``: clearances and lengths, force points, nominal
    values of prismatic joints, tolerances of length dimensions (angles and forces unchanged)."""
    power = POWER[unit]
    prismatic = {
        j.get("name") for j in ET.fromstring(urdf).findall("joint") if j.get("type") == "prismatic"
    }
    out = ET.Element("clearance_pin", {"unit": unit} if unit != "m" else {})
    for element in block:
        attributes = dict(element.attrib)
        for key, value in attributes.items():
            if key in LENGTHS or (key == "q" and element.get("name") in prismatic):
                attributes[key] = rescaled(value, power)
            elif key == "point":
                attributes[key] = " ".join(rescaled(v, power) for v in value.split())
            elif key in ("tolerance", "half_tolerance") and element.get("direction"):
                attributes[key] = rescaled(value, power)
        out.append(ET.Element(element.tag, attributes))
    return out


def toml_text(block: ET.Element) -> str:
    """The block as a TOML clearance file (numbers written as their text)."""
    tables = {
        "joint": "joints",
        "loop_joint": "loop_joints",
        "dimension": "dimensions",
        "default": "defaults",
    }
    lines = [f"unit = {json.dumps(block.get('unit'))}"] if block.get("unit") else []
    for element in block:
        attributes = dict(element.attrib)
        if element.tag in tables:
            key = attributes.pop("joint_type" if element.tag == "default" else "name")
            lines.append(f"[{tables[element.tag]}.{json.dumps(key)}]")
        elif element.tag == "gravity":
            lines.append("[gravity]")
        else:
            lines.append(f"[[{element.tag}s]]")
        for key, text in attributes.items():
            if key in VECTORS:
                value = "[" + ", ".join(text.split()) + "]"
            elif key in BOOLEANS:
                value = text.lower()
            elif key in STRINGS:
                value = json.dumps(text)
            else:
                value = text  # a number: its text is TOML
            lines.append(f"{key} = {value}")
    return "\n".join(lines) + "\n"


def write_forms(block: ET.Element, urdf: str, directory: Path) -> dict[str, Path]:
    """The block as clearance files: XML in m, XML in mm, TOML in um."""
    files = {
        "xml_m": directory / "play_m.xml",
        "xml_mm": directory / "play_mm.xml",
        "toml_um": directory / "play_um.toml",
    }
    files["xml_m"].write_text(ET.tostring(in_unit(block, urdf, "m"), encoding="unicode"))
    files["xml_mm"].write_text(ET.tostring(in_unit(block, urdf, "mm"), encoding="unicode"))
    files["toml_um"].write_text(toml_text(in_unit(block, urdf, "um")))
    return files


def assert_same_mechanism(got: cp.Mechanism, expected: cp.Mechanism) -> None:
    """The same joints, clearances, loops, nominal configuration, loads and dimensions, bitwise."""
    assert [j.name for j in got.tree_joints] == [j.name for j in expected.tree_joints]
    for a, b in zip(got.tree_joints, expected.tree_joints):
        assert (a.joint_id, a.clearance, a.motion_component, a.driven) == (
            b.joint_id,
            b.clearance,
            b.motion_component,
            b.driven,
        ), a.name
        np.testing.assert_array_equal(a.rotation, b.rotation)
    assert len(got.loop_joints) == len(expected.loop_joints)
    for a, b in zip(got.loop_joints, expected.loop_joints):
        assert (a.name, a.frame_a, a.frame_b, a.clearance) == (
            b.name,
            b.frame_a,
            b.frame_b,
            b.clearance,
        )
        np.testing.assert_array_equal(a.rotation, b.rotation)
    np.testing.assert_array_equal(got.q_nominal, expected.q_nominal)
    assert len(got.loads) == len(expected.loads)
    for a, b in zip(got.loads, expected.loads):
        assert type(a) is type(b) and a.link == b.link
        for field in ("force", "point", "torque"):
            if hasattr(a, field):
                np.testing.assert_array_equal(getattr(a, field), getattr(b, field))
    assert (got.gravity is None) == (expected.gravity is None)
    if got.gravity is not None:
        np.testing.assert_array_equal(got.gravity.acceleration, expected.gravity.acceleration)
    assert got.dimensions == expected.dimensions


def assert_same_answer(got: cp.Equilibrium, expected: cp.Equilibrium, joints) -> None:
    assert got.ok and expected.ok
    for name in joints:
        np.testing.assert_array_equal(got.torsor(name), expected.torsor(name), err_msg=name)
    assert [c.label for c in got.active_contacts] == [c.label for c in expected.active_contacts]


# -- self-consistency: every model file, its block inside or beside it -----------------------------
@pytest.mark.parametrize("form", ["xml_m", "xml_mm", "toml_um"])
@pytest.mark.parametrize("path", MODEL_FILES + DATA_FILES, ids=lambda p: p.stem)
def test_model_reads_the_same_with_its_block_beside_it(path, form, tmp_path):
    """Self-consistency (see the module docstring): same mechanism, bitwise the same linear
    answer; the bundled models' exact answers too."""
    text = path.read_text()
    bare, block = split(text)
    urdf = tmp_path / path.name
    urdf.write_text(bare)
    clearances = write_forms(block, text, tmp_path)[form]
    expected = cp.load(path)
    got = cp.load(urdf, clearances=clearances)
    assert_same_mechanism(got, expected)
    assert got.source == f"{urdf} + {clearances}"
    assert got.name == expected.name
    joints = list(expected.joints)
    assert_same_answer(got.solve(), expected.solve(), joints)
    if path in MODEL_FILES:
        assert_same_answer(got.solve(exact=True), expected.solve(exact=True), joints)


def test_text_of_a_urdf_with_a_clearance_file(tmp_path):
    """clearance_pin.loads takes the clearance file as load does."""
    path = ROOT / "models" / "four_bar.urdf"
    bare, block = split(path.read_text())
    files = write_forms(block, path.read_text(), tmp_path)
    got = cp.loads(bare, source="four_bar", clearances=files["toml_um"])
    assert_same_mechanism(got, cp.load(path))


# -- the real UR5 ----------------------------------------------------------------------------------
UR5_JOINTS = {
    "shoulder_pan_joint": 0.3,
    "shoulder_lift_joint": -1.0,
    "elbow_joint": 1.2,
    "wrist_1_joint": -0.8,
    "wrist_2_joint": 0.6,
    "wrist_3_joint": 0.4,
}


def ur5_clearance_file(directory: Path, form: str) -> Path:
    """tests/test_corpus_robots.py's block (radial 10 um, axial 5 um, length 30 mm, every joint
    driven, its nominal values, 50 N at the tool), written with a default by joint type."""
    if form == "toml_um":
        lines = [
            'unit = "um"',
            "[defaults.revolute]",
            'type = "revolute"',
            "radial_clearance = 10",
            "axial_clearance = 5",
            "length = 30_000",
            "driven = true",
        ]
        for name, q in UR5_JOINTS.items():
            lines += [f"[joints.{name}]", f"q = {q!r}"]
        lines += [
            "[[forces]]",
            'link = "tool0"',
            "point = [0, 0, 50_000]",
            "value = [20.0, -30.0, -50.0]",
        ]
        path = directory / "ur5_play.toml"
        path.write_text("\n".join(lines) + "\n")
        return path
    lines = [
        '<clearance_pin unit="mm">',
        '  <default joint_type="revolute" type="revolute" radial_clearance="0.010"',
        '           axial_clearance="0.005" length="30" driven="true"/>',
        *(f'  <joint name="{name}" q="{q!r}"/>' for name, q in UR5_JOINTS.items()),
        '  <force link="tool0" point="0 0 50" value="20 -30 -50"/>',
        "</clearance_pin>",
    ]
    path = directory / "ur5_play.xml"
    path.write_text("\n".join(lines) + "\n")
    return path


def docs_example(language: str) -> str:
    """The UR5 clearance file of docs/model-format.md (the fenced block after its marker)."""
    text = (ROOT / "docs" / "model-format.md").read_text()
    marker = f"<!-- ur5 clearance file: {language} -->"
    assert marker in text, marker
    after = text.split(marker, 1)[1]
    match = re.search(r"```\w*\n(.*?)```", after, re.S)
    assert match is not None
    return match.group(1)


@pytest.mark.parametrize("form", ["xml_mm", "toml_um", "docs_xml", "docs_toml"])
def test_ur5_with_a_clearance_file_gives_the_corpus_answer(form, tmp_path):
    """The unmodified UR5 URDF + a clearance file = tests/test_corpus_robots.py's construction
    (the block inserted into the URDF text), bitwise, both formulations."""
    import test_corpus_robots as corpus

    urdf = corpus.vendor_file(corpus.ROBOTS["ur5"][0])
    if form.startswith("docs_"):
        language = form.split("_")[1]
        clearances = tmp_path / f"ur5_play.{language}"
        clearances.write_text(docs_example(language))
    else:
        clearances = ur5_clearance_file(tmp_path, form)
    got = cp.load(urdf, clearances=clearances)
    expected = corpus.mechanism("ur5")
    assert_same_mechanism(got, expected)
    for exact in (False, True):
        assert_same_answer(
            got.solve(exact=exact),
            expected.solve(loads=corpus.tool_loads("ur5"), exact=exact),
            UR5_JOINTS,
        )


# -- independent check: one journal against its closed form ----------------------------------------
PENDULUM = """<robot name="journal">
  <link name="ground"/>
  <link name="arm"/>
  <joint name="pivot" type="revolute">
    <parent link="ground"/><child link="arm"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/>
  </joint>
</robot>
"""


@pytest.mark.parametrize(
    ("unit", "radial", "axial", "length", "height"),
    [("mm", "0.025", "0.01", "40", "40"), ("um", "25", "10", "40000", "40000")],
)
def test_single_journal_matches_its_closed_form(unit, radial, axial, length, height, tmp_path):
    r"""A driven journal (axis z, radial play c = 25 um, axial play c_a = 10 um, length
    L = 40 mm) carries a force F at the point (0, 0, h), h = L above its centre, written in mm
    and in um.

    Closed form (clearance frame x = z): the contact forces r+ and r- at z = +/- L/2 balance the
    load: r+ + r- = -F_perp and (L/2) e x (r+ - r-) = -m_perp, with m = h e x F the load's moment
    about the centre, so r+/- = -F_perp / 2 -/+ (e x m) / L and each end is pushed (opposite to
    its contact force) along a+/- = F_perp (1/2 +/- h/L) = F_perp (3/2, -1/2). The potential is
    separable in the two ends and the slide, so the upper end settles at +c F_perp / |F_perp|, the
    lower one at -c F_perp / |F_perp| (a tilt about the centre, no translation across): a point
    at height z moves by 2 c z / L F_perp / |F_perp| across the axis, and the journal slides by
    c_a sign(F_z). Checked on the world displacement v + omega x p of the arm's points (small
    displacements) and on the solved placement of its ends (exact model)."""
    urdf = tmp_path / "journal.urdf"
    urdf.write_text(PENDULUM)
    clearances = tmp_path / "play.xml"
    clearances.write_text(
        f'<clearance_pin unit="{unit}">\n'
        f'  <joint name="pivot" type="revolute" radial_clearance="{radial}"\n'
        f'         axial_clearance="{axial}" length="{length}" driven="true"/>\n'
        f'  <force link="arm" point="0 0 {height}" value="30 -40 7"/>\n'
        "</clearance_pin>\n"
    )
    c, c_a, L = 25e-6, 10e-6, 0.04
    force = np.array([30.0, -40.0, 7.0])
    across = np.array([force[0], force[1], 0.0]) / np.hypot(force[0], force[1])
    mechanism = cp.load(urdf, clearances=clearances)
    assert mechanism.loads[0].point[2] == L
    body = mechanism.model.getJointId("pivot")
    axial = np.array([0.0, 0.0, c_a * np.sign(force[2])])
    linear = mechanism.solve()
    assert linear.ok
    twist = np.asarray(linear.body_twists[body])  # small displacement: v + omega x p
    for z in (-L / 2, 0.0, L / 2, L):
        point = np.array([0.0, 0.0, z])
        moved = twist[:3] + np.cross(twist[3:], point)
        np.testing.assert_allclose(moved, 2 * c * z / L * across + axial, rtol=0, atol=1e-12 * c)
    # exact model: the ends, placed by the solved placement, lie on the bore at +/- c across,
    # the centre slid by c_a (their axial shift differs at second order only)
    exact = mechanism.solve(exact=True)
    assert exact.ok and exact.formulation == "exact"
    placement = exact.body_placements[body]
    for z in (-L / 2, L / 2):
        moved = placement.act(np.array([0.0, 0.0, z]))
        np.testing.assert_allclose(moved[:2], 2 * c * z / L * across[:2], rtol=0, atol=1e-9 * c)
    centre = placement.act(np.zeros(3))
    assert centre[2] == pytest.approx(c_a * np.sign(force[2]), abs=1e-9 * c)


# -- defaults by joint type ------------------------------------------------------------------------
TWO_JOINTS = """<robot name="two">
  <link name="ground"/><link name="a"/><link name="b"/>
  <joint name="bounded" type="revolute"><parent link="ground"/><child link="a"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="endless" type="continuous"><parent link="a"/><child link="b"/>
    <origin xyz="0.2 0 0"/><axis xyz="0 0 1"/></joint>
</robot>
"""


def load_two(tmp_path: Path, block: str) -> cp.Mechanism:
    urdf = tmp_path / "two.urdf"
    urdf.write_text(TWO_JOINTS)
    clearances = tmp_path / "play.xml"
    clearances.write_text(block)
    return cp.load(urdf, clearances=clearances)


def test_a_revolute_default_covers_continuous_joints_and_joints_override_it(tmp_path):
    mechanism = load_two(
        tmp_path,
        '<clearance_pin unit="um">'
        '<default joint_type="revolute" type="revolute" radial_clearance="10" '
        'axial_clearance="5" length="30000" driven="true"/>'
        '<joint name="endless" radial_clearance="20"/>'
        "</clearance_pin>",
    )
    bounded, endless = mechanism.tree_joints
    assert bounded.clearance == cp.model.Clearance("revolute", 1e-5, length=0.03, axial=5e-6)
    assert endless.clearance == cp.model.Clearance("revolute", 2e-5, length=0.03, axial=5e-6)
    assert bounded.driven and endless.driven


def test_a_continuous_default_wins_over_the_revolute_one(tmp_path):
    mechanism = load_two(
        tmp_path,
        '<clearance_pin><default joint_type="revolute" type="revolute" radial_clearance="1e-5" '
        'length="0.03"/><default joint_type="continuous" type="planar_revolute" '
        'radial_clearance="2e-5"/></clearance_pin>',
    )
    bounded, endless = mechanism.tree_joints
    assert bounded.clearance == cp.model.Clearance("revolute", 1e-5, length=0.03)
    assert endless.clearance == cp.model.Clearance("planar_revolute", 2e-5)


def test_another_type_than_the_default_inherits_only_driven(tmp_path):
    """A joint naming another clearance type is a fresh clearance: the default's length and
    axial play do not slip into it."""
    mechanism = load_two(
        tmp_path,
        '<clearance_pin><default joint_type="revolute" type="revolute" radial_clearance="1e-5" '
        'axial_clearance="5e-6" length="0.03" driven="true"/>'
        '<joint name="bounded" type="planar_revolute" diametral_clearance="6e-5"/>'
        "</clearance_pin>",
    )
    bounded, _ = mechanism.tree_joints
    assert bounded.clearance == cp.model.Clearance("planar_revolute", 3e-5)
    assert bounded.driven


def test_a_radial_clearance_replaces_the_defaults_diametral_one(tmp_path):
    mechanism = load_two(
        tmp_path,
        '<clearance_pin><default joint_type="revolute" type="revolute" '
        'diametral_clearance="2e-5" length="0.03"/>'
        '<joint name="bounded" radial_clearance="4e-5"/></clearance_pin>',
    )
    bounded, endless = mechanism.tree_joints
    assert bounded.clearance.radial == 4e-5 and endless.clearance.radial == 1e-5


# -- units -----------------------------------------------------------------------------------------
def test_units_convert_lengths_only(tmp_path):
    """unit="mm": clearances, lengths, force points, prismatic nominal values and length
    tolerances in mm; revolute nominal values and angle tolerances stay in rad, forces in N."""
    path = ROOT / "models" / "slider_crank.urdf"
    bare, block = split(path.read_text())
    urdf = tmp_path / "slider.urdf"
    urdf.write_text(bare)
    extra = (
        '<dimension name="e" joint="guide_mount" direction="0 1 0" tolerance="{t}"/>'
        '<dimension name="a" joint="pin_B" rotation_axis="0 0 1" half_tolerance="0.002"/>'
    )
    si = ET.tostring(block, encoding="unicode").replace(
        "</clearance_pin>", extra.format(t="0.0002") + "</clearance_pin>"
    )
    mm = ET.tostring(in_unit(block, path.read_text(), "mm"), encoding="unicode").replace(
        "</clearance_pin>", extra.format(t="0.2") + "</clearance_pin>"
    )
    (tmp_path / "si.xml").write_text(si)
    (tmp_path / "mm.xml").write_text(mm)
    assert 'point="60 0 0"' in mm and 'q="-1.0471975511965976"' in mm
    expected = cp.load(urdf, clearances=tmp_path / "si.xml")
    got = cp.load(urdf, clearances=tmp_path / "mm.xml")
    assert_same_mechanism(got, expected)
    e, a = got.dimensions[-2:]
    assert (e.tolerance, a.tolerance) == (0.0002, 0.004)


def test_a_prismatic_nominal_value_is_a_length(tmp_path):
    """The Stewart platform's legs (prismatic, driven, q about 0.22 m) written in mm."""
    path = ROOT / "tests" / "data" / "stewart_6ups.urdf"
    bare, block = split(path.read_text())
    (tmp_path / "s.urdf").write_text(bare)
    mm = ET.tostring(in_unit(block, path.read_text(), "mm"), encoding="unicode")
    assert 'q="219.35220607318606"' in mm
    (tmp_path / "mm.xml").write_text(mm)
    assert_same_mechanism(
        cp.load(tmp_path / "s.urdf", clearances=tmp_path / "mm.xml"), cp.load(path)
    )


def test_a_micro_sign_is_a_micrometre(tmp_path):
    mechanism = load_two(
        tmp_path,
        '<clearance_pin unit="\u00b5m"><joint name="bounded" type="planar_revolute" '
        'radial_clearance="15"/></clearance_pin>',
    )
    assert mechanism.tree_joints[0].clearance.radial == 1.5e-5


# -- refusals --------------------------------------------------------------------------------------
def test_a_urdf_with_its_own_block_and_a_clearance_file_is_refused(tmp_path):
    path = ROOT / "models" / "four_bar.urdf"
    _, block = split(path.read_text())
    clearances = tmp_path / "play.xml"
    clearances.write_text(ET.tostring(block, encoding="unicode"))
    with pytest.raises(cp.ModelError) as caught:
        cp.load(path, clearances=clearances)
    error = caught.value
    assert error.source == str(path) and error.element == "<clearance_pin>"
    for words in ("not merged", "remove the block from the URDF", str(clearances)):
        assert words in error.problem


UR5_BAD_XML = {
    # id: (clearance file text, element named, words of the problem)
    "unknown joint lists the URDF joints": (
        '<clearance_pin><joint name="elbow" type="revolute" radial_clearance="1e-5" '
        'length="0.03"/></clearance_pin>',
        "<joint name='elbow'>",
        ["no URDF joint is called 'elbow'", "shoulder_pan_joint", "elbow_joint", "wrist_3_joint"],
    ),
    "unknown unit": (
        '<clearance_pin unit="inch"/>',
        "<clearance_pin>",
        ["unit='inch'", "m, mm, um"],
    ),
    "default for a joint type the URDF has not": (
        '<clearance_pin><default joint_type="prismatic" type="prismatic" '
        'radial_clearance="1e-5" length="0.03"/></clearance_pin>',
        "<default joint_type='prismatic'>",
        ["prismatic joints", "has none", "shoulder_pan_joint (revolute)"],
    ),
    "default for an MJCF word": (
        '<clearance_pin><default joint_type="hinge" type="revolute" radial_clearance="1e-5" '
        'length="0.03"/></clearance_pin>',
        "<default joint_type='hinge'>",
        ["'hinge'", "revolute, continuous, prismatic, floating", "is 'revolute' here"],
    ),
    "default without joint_type": (
        '<clearance_pin><default type="revolute"/></clearance_pin>',
        "<default>",
        ["needs joint_type"],
    ),
    "default given twice": (
        '<clearance_pin><default joint_type="revolute"/><default joint_type="revolute"/>'
        "</clearance_pin>",
        "<default joint_type='revolute'>",
        ["declared twice"],
    ),
    "default with a nominal value": (
        '<clearance_pin><default joint_type="revolute" q="0.1"/></clearance_pin>',
        "<default joint_type='revolute'>",
        ["unknown attribute", "'q'"],
    ),
    "a bad default value is named with the joint": (
        '<clearance_pin><default joint_type="revolute" type="revolute" radial_clearance="-1" '
        'length="0.03"/></clearance_pin>',
        "<default joint_type='revolute'> for joint 'shoulder_pan_joint'",
        ["radial_clearance='-1'", ">= 0"],
    ),
    "a bad merge is named with the joint and its default": (
        '<clearance_pin><default joint_type="revolute" type="revolute" radial_clearance="1e-5"/>'
        '<joint name="shoulder_pan_joint" driven="true"/></clearance_pin>',
        "<joint name='shoulder_pan_joint'> with <default joint_type='revolute'>",
        ["length > 0 [m]"],
    ),
    "a fixed joint": (
        '<clearance_pin><joint name="ee_fixed_joint" type="spherical" radial_clearance="1e-5"/>'
        "</clearance_pin>",
        "<joint name='ee_fixed_joint'>",
        ["fixed", "cannot carry play"],
    ),
    "a URDF given as the clearance file": (
        '<robot name="x"><link name="a"/></robot>',
        "<robot>",
        ["a URDF, not a clearance file"],
    ),
    "another root element": ("<clearances/>", "<clearances>", ["root element", "<clearance_pin>"]),
    "malformed XML": ("<clearance_pin>", "<xml>", ["malformed XML"]),
    "unknown element": (
        '<clearance_pin><spring link="tool0"/></clearance_pin>',
        "<spring>",
        ["unknown element"],
    ),
    "unit on a force": (
        '<clearance_pin><force link="tool0" value="1 0 0" unit="mm"/></clearance_pin>',
        "<force link='tool0'>",
        ["unknown attribute", "'unit'"],
    ),
}

UR5_BAD_TOML = {
    "unknown joint lists the URDF joints": (
        '[joints.elbow]\ntype = "revolute"\nradial_clearance = 1e-5\nlength = 0.03\n',
        "[joints.elbow]",
        ["no URDF joint is called 'elbow'", "shoulder_pan_joint", "wrist_3_joint"],
    ),
    "unknown unit": ('unit = "cm"\n', "unit", ["unit='cm'", "m, mm, um"]),
    "unit not a string": ("unit = 1e-3\n", "unit", ["must be a string"]),
    "default for a joint type the URDF has not": (
        '[defaults.continuous]\ntype = "revolute"\nradial_clearance = 1e-5\nlength = 0.03\n',
        "[defaults.continuous]",
        ["continuous joints", "has none"],
    ),
    "a number written as a string": (
        '[joints.elbow_joint]\ntype = "revolute"\nradial_clearance = "0.01"\nlength = 0.03\n',
        "[joints.elbow_joint]",
        ["radial_clearance = '0.01' must be a number"],
    ),
    "a string written as a number": (
        "[joints.elbow_joint]\ntype = 3\n",
        "[joints.elbow_joint]",
        ["type = 3 must be a string"],
    ),
    "driven not a boolean": (
        '[joints.elbow_joint]\ndriven = "yes"\n',
        "[joints.elbow_joint]",
        ["driven = 'yes' must be true or false"],
    ),
    "a vector not an array": (
        '[[forces]]\nlink = "tool0"\nvalue = "1 0 0"\n',
        "[[forces]] number 1",
        ["value = '1 0 0' must be 3 numbers"],
    ),
    "a vector of two numbers": (
        '[[forces]]\nlink = "tool0"\nvalue = [1, 0]\n',
        "[[forces]] number 1",
        ["value='1 0'", "3 finite numbers"],
    ),
    "an unknown key": (
        '[joints.elbow_joint]\ncolour = "red"\n',
        "[joints.elbow_joint]",
        ["unknown attribute", "'colour'"],
    ),
    "a name beside its key": (
        '[joints.elbow_joint]\nname = "elbow_joint"\n',
        "[joints.elbow_joint]",
        ["name is given by the key"],
    ),
    "an unknown table": ("[springs.a]\nk = 1\n", "[springs]", ["unknown table"]),
    "forces as a table": ('[forces]\nlink = "tool0"\n', "[[forces]]", ["array of tables"]),
    "malformed TOML": ("[joints\n", "<toml>", ["malformed TOML"]),
    "a negative play in um": (
        'unit = "um"\n[joints.elbow_joint]\ntype = "revolute"\nradial_clearance = -10\n'
        "length = 30_000\n",
        "[joints.elbow_joint]",
        ["radial_clearance='-10'", ">= 0"],
    ),
}


def ur5_urdf() -> Path:
    import test_corpus_robots as corpus

    return corpus.vendor_file(corpus.ROBOTS["ur5"][0])


def check_error(caught: pytest.ExceptionInfo, source: Path, element: str, words: list[str]) -> None:
    error = caught.value
    assert error.source == str(source), error
    assert error.element == element, error
    for word in words:
        assert word in error.problem, (word, error.problem)
    assert str(error) == f"{source}: {element}: {error.problem}"


@pytest.mark.parametrize(("text", "element", "words"), UR5_BAD_XML.values(), ids=UR5_BAD_XML.keys())
def test_bad_xml_clearance_file_names_file_element_and_problem(text, element, words, tmp_path):
    clearances = tmp_path / "play.xml"
    clearances.write_text(text)
    with pytest.raises(cp.ModelError) as caught:
        cp.load(ur5_urdf(), clearances=clearances)
    check_error(caught, clearances, element, words)


@pytest.mark.parametrize(
    ("text", "element", "words"), UR5_BAD_TOML.values(), ids=UR5_BAD_TOML.keys()
)
def test_bad_toml_clearance_file_names_file_element_and_problem(text, element, words, tmp_path):
    clearances = tmp_path / "play.toml"
    clearances.write_text(text)
    with pytest.raises(cp.ModelError) as caught:
        cp.load(ur5_urdf(), clearances=clearances)
    check_error(caught, clearances, element, words)


def test_a_missing_clearance_file(tmp_path):
    with pytest.raises(cp.ModelError) as caught:
        cp.load(ROOT / "models" / "four_bar.urdf", clearances=tmp_path / "nowhere.toml")
    assert caught.value.element == "<file>" and "cannot be read" in caught.value.problem


def test_clearances_of_the_wrong_kind():
    with pytest.raises(cp.ArgumentError, match="clearances"):
        cp.load(ROOT / "models" / "four_bar.urdf", clearances=3)


def test_a_file_without_suffix_is_read_by_its_first_character(tmp_path):
    xml = tmp_path / "play"
    xml.write_text(
        '<clearance_pin><joint name="pivot" type="planar_revolute" radial_clearance="1e-5"/></clearance_pin>'
    )
    toml = tmp_path / "play2"
    toml.write_text('[joints.pivot]\ntype = "planar_revolute"\nradial_clearance = 1e-5\n')
    urdf = tmp_path / "j.urdf"
    urdf.write_text(PENDULUM)
    a = cp.load(urdf, clearances=xml)
    b = cp.load(urdf, clearances=toml)
    assert (
        a.tree_joints[0].clearance
        == b.tree_joints[0].clearance
        == cp.model.Clearance("planar_revolute", 1e-5)
    )


def test_a_block_inside_the_urdf_may_state_its_unit():
    """The unit is the block's, wherever it is: the four-bar's own block in mm."""
    path = ROOT / "models" / "four_bar.urdf"
    text = path.read_text()
    bare, block = split(text)
    mm = ET.tostring(in_unit(block, text, "mm"), encoding="unicode")
    inside = bare.replace("</robot>", mm + "\n</robot>")
    assert_same_mechanism(cp.loads(inside), cp.load(path))
