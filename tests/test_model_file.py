"""The model-file reader: URDF + a <clearance_pin> block.

Good files give the mechanism they describe; bad ones raise ModelError naming the source, the
element and the problem, and nothing else ever escapes the reader.
"""

from __future__ import annotations

import warnings
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from conftest import MODEL_FILES, MODELS

import clearance_pin as cp
from clearance_pin.model.clearance import Clearance

SHAFT = (MODELS / "younes_sphere_cylinder.urdf").read_text()
FOUR_BAR = (MODELS / "four_bar.urdf").read_text()
URDF_ERRORS_UNNAMED = (
    "errors found by urdfdom (a joint without <child>, a child link never declared, an origin "
    "that is not numbers) are reported as element '<robot>', 'The XML stream does not contain a "
    "valid URDF model'; the offending joint is only printed on stderr by urdfdom"
)


def edit(text: str, old: str, new: str) -> str:
    """``text`` with the first ``old`` replaced by ``new`` (which must be there)."""
    assert old in text, old
    return text.replace(old, new, 1)


# -- good files -------------------------------------------------------------------------------------
def test_shaft_file_reads_as_described():
    """models/younes_sphere_cylinder.urdf: I1 a spherical tree joint (c = 0.1 mm), I2 a
    cylindrical loop joint (c = 0.1 mm, L = 40 mm) between ground_I2 and shaft_I2, one force
    (1, 1, 1) N at (0.3, 0, 0) m of the shaft and a zero torque; no gravity."""
    mechanism = cp.load(MODELS / "younes_sphere_cylinder.urdf")
    (tree,) = mechanism.tree_joints
    (loop,) = mechanism.loop_joints
    assert tree.name == "I1" and tree.clearance == Clearance("spherical", 1e-4)
    assert loop.name == "I2" and loop.clearance == Clearance("cylindrical", 1e-4, length=0.04)
    assert mechanism.model.frames[loop.frame_a].name == "ground_I2"
    assert mechanism.model.frames[loop.frame_b].name == "shaft_I2"
    force, torque = mechanism.loads
    np.testing.assert_array_equal(force.force, [1.0, 1.0, 1.0])
    np.testing.assert_array_equal(force.point, [0.3, 0.0, 0.0])
    np.testing.assert_array_equal(torque.torque, [0.0, 0.0, 0.0])
    assert mechanism.gravity is None
    assert mechanism.source.endswith("younes_sphere_cylinder.urdf")


def test_diametral_and_radial_clearances_are_the_same_play():
    """diametral_clearance J and radial_clearance J/2 describe the same joint."""
    radial = edit(
        SHAFT,
        'type="spherical" diametral_clearance="0.0002"',
        'type="spherical" radial_clearance="0.0001"',
    )
    a = cp.loads(SHAFT).solve()
    b = cp.loads(radial).solve()
    for name in a.torsors:
        np.testing.assert_array_equal(a.torsor(name), b.torsor(name))


def test_joints_not_declared_are_ideal():
    """A URDF joint not named in the block is ideal: a revolute joint without play (only its own
    rotation free); its torsor stays zero whatever the load."""
    text = edit(
        FOUR_BAR,
        '<joint name="pin_A" type="planar_revolute" radial_clearance="5e-05" q="-0.6598498407116411"/>',
        "",
    )
    mechanism = cp.loads(text)
    pin_a = mechanism.joint("pin_A")
    assert pin_a.clearance.kind == "revolute" and pin_a.clearance.max_play == 0.0
    assert not pin_a.driven
    result = mechanism.solve()
    assert result.ok
    np.testing.assert_array_equal(result.torsor("pin_A")[:3], 0.0)


def test_driven_joint_and_nominal_value():
    """driven="true" locks the joint's own motion, q sets its nominal value [rad]."""
    mechanism = cp.loads(FOUR_BAR)
    crank = mechanism.joint("crank_pivot")
    assert crank.driven and crank.locked_components == (3,)
    assert mechanism.q_nominal[0] == pytest.approx(np.pi / 3)
    assert not mechanism.joint("pin_A").driven


def test_gravity_element():
    """<gravity> switches gravity on (default value (0, 0, -9.81) m/s^2); enabled="false" and
    no element leave it off."""
    on = cp.loads(edit(SHAFT, "</clearance_pin>", "<gravity/></clearance_pin>"))
    np.testing.assert_array_equal(on.gravity.acceleration, [0.0, 0.0, -9.81])
    off = cp.loads(
        edit(SHAFT, "</clearance_pin>", '<gravity value="0 0 -1" enabled="false"/></clearance_pin>')
    )
    assert off.gravity is None and cp.loads(SHAFT).gravity is None


def test_a_file_that_cannot_be_read(tmp_path):
    """A missing file: ModelError for the path, element '<file>'."""
    path = tmp_path / "absent.urdf"
    with pytest.raises(cp.ModelError) as caught:
        cp.load(path)
    assert caught.value.source == str(path) and caught.value.element == "<file>"


def test_source_names_the_file(tmp_path):
    """Errors from cp.load carry the file path as source and start the message with it."""
    path = tmp_path / "bad.urdf"
    path.write_text(edit(SHAFT, 'force link="shaft"', 'force link="nope"'))
    with pytest.raises(cp.ModelError) as caught:
        cp.load(path)
    assert caught.value.source == str(path) and str(caught.value).startswith(str(path))


# -- bad files ---------------------------------------------------------------------------------------
CYLINDER = 'type="cylindrical" diametral_clearance="0.0002" length="0.04" axis="1.0 0.0 0.0"'
BAD_FILES = {
    # id: (text, element named, words of the problem)
    "malformed XML": (SHAFT[:-40], "<xml>", ["malformed XML"]),
    "empty text": ("", "<xml>", ["malformed XML"]),
    "root is not robot": ("<model/>", "<model>", ["root element", "<robot>"]),
    "unknown link in a force": (
        edit(SHAFT, 'force link="shaft"', 'force link="shaft_x"'),
        "<force link='shaft_x'>",
        ["unknown link", "'shaft_x'", "shaft_I2"],
    ),
    "unknown link in a torque": (
        edit(SHAFT, 'torque link="shaft"', 'torque link="arm"'),
        "<torque link='arm'>",
        ["unknown link", "'arm'"],
    ),
    "unknown frame in a loop_joint": (
        edit(SHAFT, 'frame_b="shaft_I2"', 'frame_b="shaft_I3"'),
        "<loop_joint name='I2'>",
        ["unknown frame", "'shaft_I3'", "frame_b"],
    ),
    "negative clearance": (
        edit(SHAFT, CYLINDER, CYLINDER.replace('"0.0002"', '"-0.0002"')),
        "<loop_joint name='I2'>",
        ["diametral_clearance", "-0.0002", ">= 0"],
    ),
    "negative radial clearance on a tree joint": (
        edit(
            SHAFT,
            'type="spherical" diametral_clearance="0.0002"',
            'type="spherical" radial_clearance="-1e-4"',
        ),
        "<joint name='I1'>",
        ["radial_clearance", ">= 0"],
    ),
    "NaN clearance": (
        edit(SHAFT, CYLINDER, CYLINDER.replace('"0.0002"', '"nan"')),
        "<loop_joint name='I2'>",
        ["diametral_clearance", "finite"],
    ),
    "infinite clearance": (
        edit(SHAFT, CYLINDER, CYLINDER.replace('"0.0002"', '"inf"')),
        "<loop_joint name='I2'>",
        ["diametral_clearance", "finite"],
    ),
    "clearance not a number": (
        edit(SHAFT, CYLINDER, CYLINDER.replace('"0.0002"', '"0.2mm"')),
        "<loop_joint name='I2'>",
        ["diametral_clearance", "not a number"],
    ),
    "cylindrical joint without length": (
        edit(SHAFT, ' length="0.04"', ""),
        "<loop_joint name='I2'>",
        ["cylindrical", "length > 0"],
    ),
    "cylindrical joint of zero length": (
        edit(SHAFT, ' length="0.04"', ' length="0"'),
        "<loop_joint name='I2'>",
        ["cylindrical", "length > 0"],
    ),
    "prismatic joint without length": (
        edit(SHAFT, CYLINDER, 'type="prismatic" radial_clearance="1e-4"'),
        "<loop_joint name='I2'>",
        ["prismatic", "length"],
    ),
    "zero axis on a loop joint": (
        edit(SHAFT, CYLINDER, CYLINDER.replace('axis="1.0 0.0 0.0"', 'axis="0 0 0"')),
        "<loop_joint name='I2'>",
        ["axis", "zero length"],
    ),
    "zero axis on a tree joint": (
        edit(
            SHAFT,
            'diametral_clearance="0.0002" axis="1.0 0.0 0.0"',
            'diametral_clearance="0.0002" axis="0 0 0"',
        ),
        "<joint name='I1'>",
        ["axis", "zero length"],
    ),
    "axis of two numbers": (
        edit(SHAFT, CYLINDER, CYLINDER.replace('axis="1.0 0.0 0.0"', 'axis="1 0"')),
        "<loop_joint name='I2'>",
        ["axis", "3 finite numbers"],
    ),
    "loop frames on the same body": (
        edit(SHAFT, 'frame_a="ground_I2" frame_b="shaft_I2"', 'frame_a="shaft" frame_b="shaft_I2"'),
        "<loop_joint name='I2'>",
        ["same body"],
    ),
    "loop frame on the ground twice": (
        edit(SHAFT, 'frame_b="shaft_I2"', 'frame_b="ground"'),
        "<loop_joint name='I2'>",
        ["same body"],
    ),
    "loop written as a second URDF joint": (
        edit(
            SHAFT,
            "<clearance_pin>",
            '<joint name="I2" type="floating"><parent link="ground"/><child link="shaft"/>'
            "</joint>\n  <clearance_pin>",
        ),
        "<joint name='I2'>",
        ["'shaft'", "already the child", "'I1'", "<loop_joint>"],
    ),
    "fixed URDF joint with a clearance": (
        edit(
            SHAFT,
            "<loop_joint",
            '<joint name="ground_I2_mount" type="spherical" diametral_clearance="1e-4"/>\n    <loop_joint',
        ),
        "<joint name='ground_I2_mount'>",
        ["fixed", "cannot carry play"],
    ),
    "unknown attribute on a joint": (
        edit(SHAFT, 'type="spherical"', 'type="spherical" colour="red"'),
        "<joint name='I1'>",
        ["unknown attribute", "colour", "allowed"],
    ),
    "unknown attribute on a loop joint": (
        edit(SHAFT, 'frame_a="ground_I2"', 'frame_a="ground_I2" clearance="1e-4"'),
        "<loop_joint name='I2'>",
        ["unknown attribute", "clearance"],
    ),
    "unknown attribute on a force": (
        edit(SHAFT, 'point="0.3 0.0 0.0"', 'point="0.3 0.0 0.0" unit="mm"'),
        "<force link='shaft'>",
        ["unknown attribute", "unit"],
    ),
    "unknown element in the block": (
        edit(SHAFT, "<clearance_pin>", '<clearance_pin>\n    <spring link="shaft"/>'),
        "<spring>",
        ["unknown element", "<clearance_pin>"],
    ),
    "unknown clearance type": (
        edit(SHAFT, 'type="spherical"', 'type="ball"'),
        "<joint name='I1'>",
        ["unknown type", "'ball'", "spherical"],
    ),
    "block names a joint the URDF lacks": (
        edit(SHAFT, '<joint name="I1" type="spherical"', '<joint name="I9" type="spherical"'),
        "<joint name='I9'>",
        ["no URDF joint", "'I9'"],
    ),
    "two blocks": (
        edit(SHAFT, "</robot>", "<clearance_pin/></robot>"),
        "<clearance_pin>",
        ["only one"],
    ),
    "loop joint without type": (
        edit(SHAFT, ' type="cylindrical"', ""),
        "<loop_joint name='I2'>",
        ["needs a type"],
    ),
    "loop joint named like a tree joint": (
        edit(SHAFT, 'loop_joint name="I2"', 'loop_joint name="I1"'),
        "<loop_joint name='I1'>",
        ["exists already"],
    ),
    "joint declared twice": (
        edit(
            SHAFT,
            "<loop_joint",
            '<joint name="I1" type="spherical" radial_clearance="1e-4"/>\n    <loop_joint',
        ),
        "<joint name='I1'>",
        ["declared twice"],
    ),
    "radial and diametral clearance": (
        edit(
            SHAFT,
            'type="spherical" diametral_clearance="0.0002"',
            'type="spherical" diametral_clearance="0.0002" radial_clearance="1e-4"',
        ),
        "<joint name='I1'>",
        ["radial_clearance or diametral_clearance"],
    ),
    "clearance kind without clearance": (
        edit(SHAFT, 'type="spherical" diametral_clearance="0.0002"', 'type="spherical"'),
        "<joint name='I1'>",
        ["needs radial_clearance or diametral_clearance"],
    ),
    "clearance without a kind": (
        edit(
            SHAFT, 'type="spherical" diametral_clearance="0.0002"', 'diametral_clearance="0.0002"'
        ),
        "<joint name='I1'>",
        ["need a type"],
    ),
    "force of two numbers": (
        edit(SHAFT, 'value="1.0 1.0 1.0"', 'value="1 1"'),
        "<force link='shaft'>",
        ["value", "3 finite numbers"],
    ),
    "force with NaN": (
        edit(SHAFT, 'value="1.0 1.0 1.0"', 'value="nan 1 1"'),
        "<force link='shaft'>",
        ["value", "finite"],
    ),
    "force without value": (
        edit(SHAFT, ' value="1.0 1.0 1.0"', ""),
        "<force link='shaft'>",
        ["needs value"],
    ),
    "driven floating joint": (
        edit(SHAFT, 'type="spherical"', 'type="spherical" driven="true"'),
        "<joint name='I1'>",
        ["floating", "drive"],
    ),
    "driven neither true nor false": (
        edit(FOUR_BAR, 'driven="true"', 'driven="maybe"'),
        "<joint name='crank_pivot'>",
        ["driven", "'maybe'"],
    ),
    "axis on a revolute joint": (
        edit(FOUR_BAR, 'driven="true"', 'driven="true" axis="0 0 1"'),
        "<joint name='crank_pivot'>",
        ["axis", "URDF joint's <axis>"],
    ),
    "URDF planar joint": (
        edit(SHAFT, 'type="floating"', 'type="planar"'),
        "<joint name='I1'>",
        ["'planar'", "not supported"],
    ),
    "duplicate URDF joint": (
        edit(SHAFT, 'joint name="ground_I2_mount"', 'joint name="I1"'),
        "<joint name='I1'>",
        ["duplicate"],
    ),
    "gravity of two numbers": (
        edit(SHAFT, "</clearance_pin>", '<gravity value="0 -9.81"/></clearance_pin>'),
        "<gravity>",
        ["value", "3 finite numbers"],
    ),
}


@pytest.mark.parametrize(("text", "element", "words"), BAD_FILES.values(), ids=BAD_FILES.keys())
def test_bad_file_raises_model_error_naming_element_and_problem(text, element, words):
    """A bad model file raises ModelError (and nothing else) with the source, the offending
    element and the problem in its attributes and its message."""
    with pytest.raises(cp.ModelError) as caught:
        cp.loads(text, source="bad.urdf")
    error = caught.value
    assert type(error) is cp.ModelError
    assert error.source == "bad.urdf" and error.element == element
    for word in words:
        assert word in error.problem, (word, error.problem)
    assert str(error) == f"bad.urdf: {element}: {error.problem}"


@pytest.mark.parametrize(
    "text",
    [
        edit(
            SHAFT, '<child link="shaft"/><origin xyz="0.0 0.0 0.0"/>', '<origin xyz="0.0 0.0 0.0"/>'
        ),
        edit(
            SHAFT,
            '<child link="shaft"/><origin xyz="0.0 0.0 0.0"/>',
            '<child link="ghost"/><origin xyz="0.0 0.0 0.0"/>',
        ),
        edit(SHAFT, '<origin xyz="0.0 0.0 0.0"/>', '<origin xyz="0.0 zero 0.0"/>'),
    ],
    ids=["joint without child", "child link not declared", "origin not numbers"],
)
def test_urdf_errors_name_the_joint(text):
    """Errors in the URDF part name the offending joint, as those of the block do."""
    with pytest.raises(cp.ModelError) as caught:
        cp.loads(text)
    assert caught.value.element == "<joint name='I1'>"


URDF_ZERO_AXIS = (
    "a URDF revolute joint with <axis xyz='0 0 0'> loads (Pinocchio builds a RevoluteUnaligned "
    "joint with a zero axis; joints.rotation_x_to divides by 0 and the clearance frame is NaN); "
    "the arm then solves 'ok' with that joint's torsor 0, and the exact model fails with "
    "Invalid_Number_Detected. The block's own axis='0 0 0' is rejected."
)


def test_urdf_zero_axis_is_a_model_error():
    """A URDF joint axis of zero length (models/arm_6r.urdf, shoulder_pan <axis xyz="0 0 0"/>)
    raises ModelError naming the joint, as axis="0 0 0" in the block does."""
    text = edit((MODELS / "arm_6r.urdf").read_text(), '<axis xyz="0 0 1"/>', '<axis xyz="0 0 0"/>')
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        with pytest.raises(cp.ModelError) as caught:
            cp.loads(text)
    assert caught.value.element.startswith("<joint name='shoulder_pan'>")  # may add ' <axis>'
    assert "axis" in caught.value.problem


NASTY_VALUES = (
    "",
    "-1",
    "nan",
    "inf",
    "-inf",
    "1e400",
    "0",
    "abc",
    "1 2",
    "1 2 3 4",
    "0 0 0",
    "true",
    "1e-300",
    " ",
)


def mutations(count: int, seed: int):
    """``count`` model files, each a bundled model with one attribute replaced by a nasty value,
    deleted, or suffixed with junk (fixed seed)."""
    rng = np.random.default_rng(seed)
    for _ in range(count):
        path = MODEL_FILES[rng.integers(len(MODEL_FILES))]
        root = ET.fromstring(path.read_text())
        candidates = [e for e in root.iter() if e.attrib]
        element = candidates[rng.integers(len(candidates))]
        key = sorted(element.attrib)[rng.integers(len(element.attrib))]
        operation = rng.integers(3)
        if operation == 0:
            element.set(key, NASTY_VALUES[rng.integers(len(NASTY_VALUES))])
        elif operation == 1:
            del element.attrib[key]
        else:
            element.set(key, element.get(key) + "x")
        yield (
            f"{path.stem}: <{element.tag}> {key} -> {element.get(key)!r}",
            ET.tostring(root, encoding="unicode"),
        )


def test_nothing_but_model_error_escapes_the_reader():
    """400 corrupted model files (seed 0): each either loads or raises ModelError; those that load
    either solve or raise a ClearancePinError (never a bare Pinocchio, CasADi or NumPy error)."""
    outcomes = {"ModelError": 0, "loaded": 0}
    for label, text in mutations(400, seed=0):
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", RuntimeWarning)  # see test_urdf_zero_axis
                mechanism = cp.loads(text)
        except cp.ModelError:
            outcomes["ModelError"] += 1
            continue
        except Exception as exc:  # pragma: no cover - the failure message names the mutation
            pytest.fail(f"{label}: {type(exc).__name__}: {exc}")
        outcomes["loaded"] += 1
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                mechanism.solve()
        except cp.ClearancePinError:
            pass
        except Exception as exc:  # pragma: no cover
            pytest.fail(f"{label}: solve: {type(exc).__name__}: {exc}")
    # both outcomes occur (the reader also checks inertials and URDF structure, so fewer load)
    assert outcomes["ModelError"] > 200 and outcomes["loaded"] > 25, outcomes


@pytest.mark.parametrize("path", MODEL_FILES, ids=lambda p: p.stem)
def test_text_and_file_give_the_same_mechanism(path):
    """cp.load(path) and cp.loads(text) read the same joints, loads and nominal configuration."""
    a, b = cp.load(path), cp.loads(path.read_text())
    assert [j.name for j in a.tree_joints] == [j.name for j in b.tree_joints]
    assert [j.clearance for j in a.joints.values()] == [j.clearance for j in b.joints.values()]
    np.testing.assert_array_equal(a.q_nominal, b.q_nominal)
    assert len(a.loads) == len(b.loads)
