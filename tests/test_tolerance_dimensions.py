"""Tests of clearance_pin.tolerance.dimensions: the <dimension> elements and exact deviations."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import clearance_pin
from clearance_pin.errors import ModelError
from clearance_pin.model.dimensions import Dimension
from clearance_pin.tolerance import tolerance_m
from clearance_pin.tolerance.dimensions import affected_frames, apply_deviations, with_deviations

MODELS = Path(__file__).resolve().parent.parent / "models"

ARM = """<?xml version="1.0"?>
<robot name="arm">
  <link name="base"/><link name="l1"/><link name="bracket"/><link name="l2"/><link name="tool"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="mount" type="fixed"><parent link="l1"/><child link="bracket"/>
    <origin xyz="0.1 0.02 0" rpy="0 0 0.3"/></joint>
  <joint name="j2" type="revolute"><parent link="bracket"/><child link="l2"/>
    <origin xyz="0.2 0 0.05" rpy="0.1 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="tool_mount" type="fixed"><parent link="l2"/><child link="tool"/>
    <origin xyz="0.15 0 0"/></joint>
  <clearance_pin>
    {dimensions}
  </clearance_pin>
</robot>
"""


def arm(dimensions: str):
    return clearance_pin.loads(ARM.format(dimensions=dimensions), source="arm.urdf")


def test_slider_crank_dimensions_from_iso_grades():
    """The bundled slider-crank carries r2 and r3 with IT10: T = 100 um and 140 um, the
    nominal sizes are the joint origins along x (50 mm, 120 mm)."""
    mechanism = clearance_pin.load(MODELS / "slider_crank.urdf")
    r2, r3 = mechanism.dimensions
    assert (r2.name, r2.joint, r2.kind, r2.grade) == ("r2", "pin_A", "length", "IT10")
    assert r2.nominal == pytest.approx(0.05) and r3.nominal == pytest.approx(0.12)
    assert r2.tolerance == pytest.approx(100e-6) and r3.half_tolerance == pytest.approx(70e-6)
    assert r2.tolerance == tolerance_m("IT10", 0.05)


def test_three_ways_to_give_a_tolerance():
    """tolerance (full width T), half_tolerance (T/2) and grade give the same Dimension width."""
    mechanism = arm("""
      <dimension name="a" joint="j2" direction="1 0 0" tolerance="1e-4"/>
      <dimension name="b" joint="j2" direction="2 0 0" half_tolerance="5e-5"/>
      <dimension name="c" joint="tool_mount" direction="1 0 0" grade="it9"/>""")
    a, b, c = mechanism.dimensions
    assert a.tolerance == b.tolerance == pytest.approx(1e-4)
    assert b.axis == (1.0, 0.0, 0.0)  # normalised
    assert c.grade == "IT9" and c.tolerance == pytest.approx(tolerance_m("IT9", 0.15))


def test_nominal_is_the_urdf_origin_in_the_parent_link_frame():
    """With a fixed joint between (merged by Pinocchio), the nominal length is still the URDF
    <origin xyz> component along the direction, not the placement in the parent joint."""
    mechanism = arm("""
      <dimension name="x" joint="j2" direction="1 0 0" tolerance="1e-4"/>
      <dimension name="z" joint="j2" direction="0 0 1" tolerance="1e-4"/>
      <dimension name="m" joint="mount" direction="0 1 0" tolerance="1e-4"/>""")
    x, z, m = mechanism.dimensions
    assert x.nominal == pytest.approx(0.2) and z.nominal == pytest.approx(0.05)
    assert m.nominal == pytest.approx(0.02)
    # the direction is turned by the bracket's rpy into the parent joint (j1) frame
    expected = pin.rpy.rpyToMatrix(0, 0, 0.3) @ np.array([1.0, 0.0, 0.0])
    assert np.allclose(x.axis_in_parent_joint, expected)
    assert x.parent_joint_id == mechanism.model.getJointId("j1")


@pytest.mark.parametrize(
    ("element", "fragment"),
    [
        ('<dimension name="d" joint="nope" direction="1 0 0" tolerance="1e-4"/>', "no URDF joint"),
        ('<dimension name="d" joint="j2" direction="0 0 0" tolerance="1e-4"/>', "zero length"),
        ('<dimension name="d" joint="j2" direction="1 0" tolerance="1e-4"/>', "3 finite numbers"),
        ('<dimension name="d" joint="j2" direction="1 0 0" tolerance="-1e-4"/>', ">= 0"),
        ('<dimension name="d" joint="j2" direction="1 0 0" tolerance="nan"/>', ">= 0"),
        ('<dimension name="d" joint="j2" direction="1 0 0" tolerance="abc"/>', "not a number"),
        ('<dimension name="d" joint="j2" direction="1 0 0" grade="IT19"/>', "unknown ISO 286"),
        ('<dimension name="d" joint="j2" direction="0 1 0" grade="IT7"/>', "(0, 0.5] m"),
        (
            '<dimension name="d" joint="j2" direction="1 0 0" tolerance="1e-4" grade="IT7"/>',
            "exactly one of tolerance",
        ),
        ('<dimension name="d" joint="j2" direction="1 0 0"/>', "exactly one of tolerance"),
        (
            '<dimension name="d" joint="j2" direction="1 0 0" rotation_axis="0 0 1" tolerance="1"/>',
            "exactly one of direction",
        ),
        ('<dimension name="d" joint="j2" rotation_axis="0 0 1" grade="IT7"/>', "not to angles"),
        (
            '<dimension name="d" joint="j2" direction="1 0 0" tolerance="1" colour="red"/>',
            "unknown attribute",
        ),
        ('<dimension joint="j2" direction="1 0 0" tolerance="1e-4"/>', "needs a name"),
        ('<dimension name="d" direction="1 0 0" tolerance="1e-4"/>', "needs joint"),
        (
            '<dimension name="d" joint="j2" direction="1 0 0" tolerance="1e-4"/>'
            '<dimension name="d" joint="j1" direction="1 0 0" tolerance="1e-4"/>',
            "duplicate",
        ),
    ],
)
def test_invalid_dimension_is_named(element, fragment):
    """Every invalid <dimension> raises ModelError naming the file, the element and the problem."""
    with pytest.raises(ModelError) as info:
        arm(element)
    assert info.value.source == "arm.urdf"
    assert info.value.element.startswith("<dimension")
    assert fragment in info.value.problem


def test_grade_on_a_size_above_500_mm_is_refused():
    """ISO 286 grades stop at 500 mm: a 0.6 m length with a grade is an error naming the size."""
    text = ARM.format(dimensions='<dimension name="d" joint="j2" direction="1 0 0" grade="IT7"/>')
    text = text.replace('xyz="0.2 0 0.05"', 'xyz="0.6 0 0.05"')
    with pytest.raises(ModelError, match="600 mm"):
        clearance_pin.loads(text, source="arm.urdf")


def test_dimension_value_type_is_validated():
    """Dimension refuses a negative tolerance or a non-unit axis on construction."""
    args = dict(
        name="d",
        joint="j",
        frame_id=1,
        parent_joint_id=0,
        kind="length",
        axis=(1.0, 0.0, 0.0),
        axis_in_parent_joint=(1.0, 0.0, 0.0),
        point_in_parent_joint=(0.0, 0.0, 0.0),
        nominal=0.0,
        tolerance=1e-4,
    )
    Dimension(**args)
    with pytest.raises(ValueError):
        Dimension(**{**args, "tolerance": -1.0})
    with pytest.raises(ValueError):
        Dimension(**{**args, "axis_in_parent_joint": (2.0, 0.0, 0.0)})
    with pytest.raises(ValueError):
        Dimension(**{**args, "kind": "area"})


def test_affected_frames_are_the_subtree():
    """A dimension on the fixed joint 'mount' moves the bracket, j2, l2 and the tool, not l1."""
    mechanism = arm('<dimension name="m" joint="mount" direction="0 1 0" tolerance="1e-4"/>')
    model = mechanism.model
    mask = affected_frames(model, mechanism.dimensions[0])
    moved = {model.frames[int(i)].name for i in np.flatnonzero(mask)}
    assert moved == {"mount", "bracket", "j2", "l2", "tool_mount", "tool"}
    assert mechanism.dimensions[0].nominal == pytest.approx(0.02)


@settings(max_examples=25, deadline=None, derandomize=True)
@given(
    st.floats(-1e-3, 1e-3),
    st.floats(-1e-3, 1e-3),
    st.floats(-1e-2, 1e-2),
    st.floats(-3.0, 3.0),
    st.floats(-3.0, 3.0),
)
def test_length_deviation_translates_the_subtree(d_mount, d_tool, angle, q1, q2):
    """Exactness of apply_deviations: a length deviation dd translates the world position of
    every frame of its subtree by dd times the direction (world), whatever q; an angle
    deviation about the joint origin rotates the subtree about that point."""
    mechanism = arm("""
      <dimension name="m" joint="mount" direction="0 1 0" tolerance="1e-4"/>
      <dimension name="t" joint="tool_mount" direction="1 0 0" tolerance="1e-4"/>
      <dimension name="a" joint="j2" rotation_axis="0 0 1" tolerance="1e-3"/>""")
    model = mechanism.model
    q = np.array([q1, q2])
    nominal = model.createData()
    pin.framesForwardKinematics(model, nominal, q)
    tool, bracket, l1 = (model.getFrameId(name) for name in ("tool", "bracket", "l1"))
    # length on the mount: everything from the bracket on moves by the same world vector,
    # the direction being in the parent link (l1) frame
    moved = apply_deviations(model, mechanism.dimensions, np.array([d_mount, 0.0, 0.0]))
    data = moved.createData()
    pin.framesForwardKinematics(moved, data, q)
    shift = nominal.oMf[l1].rotation @ np.array([0.0, d_mount, 0.0])
    for frame in (bracket, tool):
        assert np.allclose(
            data.oMf[frame].translation - nominal.oMf[frame].translation, shift, atol=1e-15
        )
    # length on the tool mount: along the tool's own x axis
    moved = apply_deviations(model, mechanism.dimensions, np.array([0.0, d_tool, 0.0]))
    data = moved.createData()
    pin.framesForwardKinematics(moved, data, q)
    shift = nominal.oMf[tool].rotation @ np.array([d_tool, 0.0, 0.0])
    assert np.allclose(
        data.oMf[tool].translation - nominal.oMf[tool].translation, shift, atol=1e-15
    )
    # angle at j2: the tool turns about the j2 origin, the bracket stays
    moved = apply_deviations(model, mechanism.dimensions, np.array([0.0, 0.0, angle]))
    data = moved.createData()
    pin.framesForwardKinematics(moved, data, q)
    j2 = model.getFrameId("j2")
    centre = nominal.oMf[j2].translation
    before = nominal.oMf[tool].translation - centre
    after = data.oMf[tool].translation - centre
    assert np.allclose(data.oMf[bracket].translation, nominal.oMf[bracket].translation)
    assert math.isclose(np.linalg.norm(before), np.linalg.norm(after), rel_tol=1e-12)
    axis = nominal.oMf[bracket].rotation @ mechanism.dimensions[2].axis
    turned = pin.exp3(axis * angle) @ before
    assert np.allclose(after, turned, atol=1e-14)


def test_zero_deviation_leaves_the_model_unchanged():
    """apply_deviations with zeros returns a model with the same placements (and copies it)."""
    mechanism = clearance_pin.load(MODELS / "slider_crank.urdf")
    moved = apply_deviations(mechanism.model, mechanism.dimensions, np.zeros(2))
    for a, b in zip(moved.jointPlacements, mechanism.model.jointPlacements):
        assert a.isApprox(b, 0.0)
    changed = with_deviations(mechanism, np.array([1e-3, 0.0]))
    assert changed.model.jointPlacements[2].translation[0] == pytest.approx(0.051)
    assert mechanism.model.jointPlacements[2].translation[0] == pytest.approx(0.05)
    with pytest.raises(ValueError):
        apply_deviations(mechanism.model, mechanism.dimensions, np.zeros(3))


def test_double_pendulum_model_loads():
    """models/double_pendulum.urdf has l1, l2 (IT9, l2 on the fixed tip joint) and an angle."""
    mechanism = clearance_pin.load(MODELS / "double_pendulum.urdf")
    l1, l2, a2 = mechanism.dimensions
    assert (l1.nominal, l2.nominal) == pytest.approx((0.3, 0.2))
    assert l2.joint == "tip_mount" and a2.kind == "angle" and a2.unit == "rad"
    assert l1.tolerance == tolerance_m("IT9", 0.3)
