"""clearance_pin.from_model (issue 14): a mechanism on a pin.Model a planner already holds.

Self-consistency: the model built by Pinocchio from the URDF (``pin.buildModelFromUrdf``) with
the clearances as a Python dict (SI) or a clearance file, loop joints, loads and nominal values as
arguments, gives bitwise the answer of the model file that says the same (the file's answers are
checked independently elsewhere: tests/test_corpus_robots.py for the UR5's journals,
validation/ and the oracle for the bundled models). Arguments given twice (in the clearance file
and as an argument) are refused, and bad entries name the entry and the problem.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin
import pytest
from conftest import ROOT
from test_clearance_file import (
    UR5_JOINTS,
    assert_same_answer,
    assert_same_mechanism,
    split,
    ur5_clearance_file,
)

import clearance_pin as cp
from clearance_pin import PointForce, Torque

FOUR_BAR = ROOT / "models" / "four_bar.urdf"
UR5_DEFAULT = {
    "type": "revolute",
    "radial_clearance": 1e-5,
    "axial_clearance": 5e-6,
    "length": 0.03,
    "driven": True,
}
UR5_FORCE = PointForce("tool0", [20.0, -30.0, -50.0], [0.0, 0.0, 0.05])


def ur5_model() -> tuple[pin.Model, object]:
    import test_corpus_robots as corpus

    path = corpus.vendor_file(corpus.ROBOTS["ur5"][0])
    return pin.buildModelFromUrdf(str(path)), corpus


@pytest.mark.parametrize("spelling", ["dict", "dict of joints", "clearance file"])
def test_ur5_model_in_memory_gives_the_corpus_answer(spelling, tmp_path):
    model, corpus = ur5_model()
    if spelling == "dict":
        mechanism = cp.from_model(
            model,
            clearances={"defaults": {"revolute": UR5_DEFAULT}},
            loads=[UR5_FORCE],
            q=UR5_JOINTS,
        )
    elif spelling == "dict of joints":
        clearances = {name: {**UR5_DEFAULT, "q": q} for name, q in UR5_JOINTS.items()}
        mechanism = cp.from_model(model, clearances=clearances, loads=[UR5_FORCE])
    else:
        mechanism = cp.from_model(model, clearances=ur5_clearance_file(tmp_path, "toml_um"))
    expected = corpus.mechanism("ur5")
    assert_same_mechanism(mechanism, expected)
    for exact in (False, True):
        assert_same_answer(
            mechanism.solve(exact=exact),
            expected.solve(loads=corpus.tool_loads("ur5"), exact=exact),
            UR5_JOINTS,
        )


def four_bar_arguments() -> dict:
    """The block of models/four_bar.urdf as from_model's arguments."""
    return {
        "clearances": {
            "crank_pivot": {"type": "planar_revolute", "radial_clearance": 5e-05, "driven": True},
            "pin_A": {"type": "planar_revolute", "radial_clearance": 5e-05},
            "rocker_pivot": {"type": "planar_revolute", "radial_clearance": 5e-05},
        },
        "loop_joints": {
            "pin_B": {
                "type": "planar_revolute",
                "frame_a": "rocker_B",
                "frame_b": "coupler_B",
                "radial_clearance": 5e-05,
                "axis": np.array([0.0, 0.0, 1.0]),
            }
        },
        "loads": [PointForce("coupler", [0, -40, 0], [0.09, 0, 0]), Torque("rocker", [0, 0, -2])],
        "q": {
            "crank_pivot": 1.0471975511965976,
            "pin_A": -0.6598498407116411,
            "rocker_pivot": 1.5985953109212792,
        },
    }


def test_four_bar_with_a_loop_joint_in_memory_gives_the_files_answer():
    bare, _ = split(FOUR_BAR.read_text())
    model = pin.buildModelFromXML(bare)
    mechanism = cp.from_model(model, **four_bar_arguments())
    expected = cp.load(FOUR_BAR)
    assert_same_mechanism(mechanism, expected)
    for exact in (False, True):
        assert_same_answer(
            mechanism.solve(exact=exact), expected.solve(exact=exact), expected.joints
        )
    assert mechanism.source == "<api>"


def test_a_configuration_array_is_the_nominal_one():
    bare, _ = split(FOUR_BAR.read_text())
    model = pin.buildModelFromXML(bare)
    arguments = four_bar_arguments()
    expected = cp.from_model(model, **arguments)
    arguments["q"] = expected.q_nominal
    assert_same_mechanism(cp.from_model(model, **arguments), expected)


def test_gravity_switched_on_by_the_argument():
    bare, _ = split(FOUR_BAR.read_text())
    model = pin.buildModelFromXML(bare)
    arguments = four_bar_arguments()
    on = cp.from_model(model, **arguments, gravity=True)
    np.testing.assert_array_equal(on.gravity.acceleration, [0.0, 0.0, -9.81])
    assert cp.from_model(model, **arguments, gravity=[0, -9.81, 0]).gravity.acceleration[1] == -9.81
    assert cp.from_model(model, **arguments, gravity=False).gravity is None


def test_the_model_is_copied():
    """Editing the planner's model afterwards does not reach the mechanism."""
    bare, _ = split(FOUR_BAR.read_text())
    model = pin.buildModelFromXML(bare)
    mechanism = cp.from_model(model, **four_bar_arguments())
    before = mechanism.solve().torsor("pin_B")
    model.jointPlacements[2] = pin.SE3(np.eye(3), np.array([0.07, 0.0, 0.0]))
    assert mechanism.model is not model
    # the second solve may take the compiled path: equal to round-off (the edit moves pin_B mm)
    np.testing.assert_allclose(mechanism.solve().torsor("pin_B"), before, rtol=1e-12, atol=1e-18)


def test_an_ideal_model_on_purpose():
    """clearances={}: every joint ideal, asked for (as a URDF with an empty block)."""
    model, _ = ur5_model()
    mechanism = cp.from_model(model, clearances={})
    assert all(j.clearance.max_play == 0.0 for j in mechanism.tree_joints)
    assert mechanism.name == model.name


def test_no_clearances_at_all_is_refused():
    """No clearances and no loop joints: every answer would be zero (issue 33 item 6.1); the
    error says how to give them."""
    model, _ = ur5_model()
    with pytest.raises(cp.ModelError, match="no clearances given") as caught:
        cp.from_model(model)
    assert caught.value.element == "clearances"
    assert "clearances={}" in caught.value.problem


# -- refusals --------------------------------------------------------------------------------------
@pytest.mark.parametrize("argument", ["loads", "gravity", "q", "loop_joints"])
def test_a_value_in_the_file_and_as_an_argument_is_refused(argument, tmp_path):
    """Not merged: the file's and the argument's loads (gravity, nominal values, loop joints)."""
    bare, block = split(FOUR_BAR.read_text())  # its loads, nominal values and loop joint
    block.append(ET.Element("gravity"))
    clearances = tmp_path / "four_bar_play.xml"
    clearances.write_text(ET.tostring(block, encoding="unicode"))
    given = {
        "loads": [Torque("rocker", [0, 0, -1])],
        "gravity": True,
        "q": {"pin_A": -0.6},
        "loop_joints": four_bar_arguments()["loop_joints"],
    }
    with pytest.raises(cp.ArgumentError) as caught:
        cp.from_model(
            pin.buildModelFromXML(bare), clearances=clearances, **{argument: given[argument]}
        )
    assert caught.value.argument == argument
    assert "not both" in caught.value.expected
    assert str(clearances) in str(caught.value)


BAD_DICTS = {
    # id: (clearances, element named, words of the problem)
    "unknown joint lists the model's joints": (
        {"elbow": {"type": "revolute", "radial_clearance": 1e-5, "length": 0.03}},
        "clearances['elbow']",
        ["no model joint is called 'elbow'", "shoulder_pan_joint", "wrist_3_joint"],
    ),
    "a number as a string": (
        {"elbow_joint": {"type": "revolute", "radial_clearance": "1e-5", "length": 0.03}},
        "clearances['elbow_joint']",
        ["radial_clearance = '1e-5' must be a number"],
    ),
    "a boolean as a number": (
        {"elbow_joint": {"type": "revolute", "radial_clearance": True, "length": 0.03}},
        "clearances['elbow_joint']",
        ["must be a number"],
    ),
    "a joint's attributes not a dict": (
        {"elbow_joint": 1e-5},
        "clearances['elbow_joint']",
        ["must be a table"],
    ),
    "a unit": ({"unit": "mm"}, "clearances['unit']", ["SI units"]),
    "a default for a type the model has not": (
        {"defaults": {"prismatic": {"type": "prismatic", "radial_clearance": 1e-5, "length": 0.1}}},
        "clearances['defaults']['prismatic']",
        ["prismatic joints", "has none"],
    ),
    "a fixed joint": (
        {"ee_fixed_joint": {"type": "spherical", "radial_clearance": 1e-5}},
        "clearances['ee_fixed_joint']",
        ["fixed", "cannot carry play"],
    ),
    "a negative play": (
        {"elbow_joint": {"type": "revolute", "radial_clearance": -1e-5, "length": 0.03}},
        "clearances['elbow_joint']",
        [">= 0"],
    ),
}


@pytest.mark.parametrize(
    ("clearances", "element", "words"), BAD_DICTS.values(), ids=BAD_DICTS.keys()
)
def test_a_bad_dict_names_the_entry_and_the_problem(clearances, element, words):
    model, _ = ur5_model()
    with pytest.raises(cp.ModelError) as caught:
        cp.from_model(model, clearances=clearances)
    assert caught.value.source == "<api>" and caught.value.element == element
    for word in words:
        assert word in caught.value.problem, (word, caught.value.problem)


def test_a_bad_loop_joint_names_it():
    bare, _ = split(FOUR_BAR.read_text())
    arguments = four_bar_arguments()
    arguments["loop_joints"]["pin_B"]["frame_b"] = "coupler_C"
    with pytest.raises(cp.ModelError) as caught:
        cp.from_model(pin.buildModelFromXML(bare), **arguments)
    assert caught.value.source == "<api>"
    assert caught.value.element == "loop_joints['pin_B']"
    assert "unknown frame 'coupler_C'" in caught.value.problem


def test_bad_arguments():
    bare, _ = split(FOUR_BAR.read_text())
    model = pin.buildModelFromXML(bare)
    with pytest.raises(cp.ArgumentError, match="model"):
        cp.from_model(bare)
    with pytest.raises(cp.NotFoundError, match="'slider'"):
        cp.from_model(model, loads=[PointForce("slider", [1, 0, 0])], clearances={})
    with pytest.raises(cp.ArgumentError, match=r"loads\[0\]"):
        cp.from_model(model, loads=[(1, 0, 0)], clearances={})
    with pytest.raises(cp.ArgumentError, match="q"):
        cp.from_model(model, q=[0.0, 1.0], clearances={})
    with pytest.raises(cp.NotFoundError, match="'pin_Z'"):
        cp.from_model(model, q={"pin_Z": 0.1}, clearances={})
    with pytest.raises(cp.ArgumentError, match="gravity"):
        cp.from_model(model, gravity="on", clearances={})
    with pytest.raises(cp.ArgumentError, match="loop_joints"):
        cp.from_model(model, loop_joints=[("pin_B", {})], clearances={})


def test_the_docs_example_runs(monkeypatch):
    """docs/model-format.md's from_model example, from the repository's root with the files it
    names (the vendor UR5 of example-robot-data, models/ur5_play.toml, the four-bar's URDF):
    the UR5 built from a pin.Model and its clearance file is the one clearance_pin.load reads
    from the URDF and the same file."""
    _, corpus = ur5_model()
    urdf = corpus.vendor_file(corpus.ROBOTS["ur5"][0])
    text = (ROOT / "docs" / "model-format.md").read_text()
    code = text.split("## From Python, without files")[1].split("```python\n")[1].split("```")[0]
    monkeypatch.chdir(ROOT)
    namespace: dict = {"pin": pin, "clearance_pin": cp}
    exec(code, namespace)
    four_bar, ur5 = namespace["four_bar"], namespace["ur5"]
    assert four_bar.solve().ok and ur5.solve().ok
    assert four_bar.joint("pin_B").clearance == cp.model.Clearance("planar_revolute", 5e-5)
    assert_same_mechanism(ur5, cp.load(str(urdf), clearances="models/ur5_play.toml"))


def test_load_takes_a_dict_of_clearances_too(tmp_path):
    """clearance_pin.load(urdf, clearances={...}): the dict of from_model beside a file."""
    urdf = tmp_path / "four_bar_tree.urdf"
    urdf.write_text(split(FOUR_BAR.read_text())[0])
    clearances = {
        name: {
            "type": "planar_revolute",
            "radial_clearance": 5e-05,
            "driven": name == "crank_pivot",
        }
        for name in ("crank_pivot", "pin_A", "rocker_pivot")
    }
    mechanism = cp.load(urdf, clearances=clearances)
    assert mechanism.source == str(urdf)
    expected = cp.load(FOUR_BAR)
    for joint in expected.tree_joints:
        assert mechanism.joint(joint.name).clearance == joint.clearance
        assert mechanism.joint(joint.name).driven == joint.driven
    with pytest.raises(cp.ModelError) as caught:
        cp.load(urdf, clearances={"pin_Z": {"type": "planar_revolute", "radial_clearance": 1e-5}})
    assert caught.value.source == "<api>" and caught.value.element == "clearances['pin_Z']"
