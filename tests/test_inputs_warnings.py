"""Unit mistakes are warned about (issue 10, finding 7).

A clearance typed in mm, an angle in degrees or a tolerance as wide as its size is a valid number:
the model loads, with a SuspectValueWarning (a ClearancePinWarning) that names the element and the
numbers. The expected numbers are read off the model files by hand (the distance between two pivots
of the four-bar is its ground link, 200 mm; 60 deg is pi/3 rad), not computed by the library; the
thresholds (5 % of the part's size, 10 % of the nominal size, the URDF limits) are the documented
ones of clearance_pin.model.plausibility, so these tests check the model against its own stated rule.
"""

from __future__ import annotations

import re
import warnings

import numpy as np
import pytest
from conftest import MODEL_FILES, MODELS

import clearance_pin as cp


def _text(name: str) -> str:
    return (MODELS / f"{name}.urdf").read_text()


def _messages(record) -> list[str]:
    return [str(w.message) for w in record if issubclass(w.category, cp.ClearancePinWarning)]


def test_every_warning_derives_from_clearance_pin_warning():
    """ClearancePinWarning is a UserWarning; the library's warnings derive from it; ArgumentError
    is a ClearancePinError and a ValueError."""
    assert issubclass(cp.ClearancePinWarning, UserWarning)
    assert issubclass(cp.ConditioningWarning, cp.ClearancePinWarning)
    assert issubclass(cp.SuspectValueWarning, cp.ClearancePinWarning)
    assert issubclass(cp.ArgumentError, cp.ClearancePinError)
    assert issubclass(cp.ArgumentError, ValueError)


@pytest.mark.parametrize("path", MODEL_FILES, ids=lambda p: p.stem)
def test_bundled_models_do_not_warn(path):
    """None of the bundled models gives a ClearancePinWarning on loading."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", cp.ClearancePinWarning)
        cp.load(path)


def test_clearance_typed_in_mm_warns():
    """The four-bar with its 50 um plays typed as 0.05 (mm meant, m read): every joint warns,
    naming the joint, 0.05 m and the part's size. crank_pivot joins the ground, whose pivots are
    200 mm apart (ground link of the file), and the crank (60 mm): 0.05 / 0.2 = 25 %."""
    text = _text("four_bar").replace('radial_clearance="5e-05"', 'radial_clearance="0.05"')
    with pytest.warns(cp.SuspectValueWarning) as record:
        cp.loads(text, source="four_bar_mm.urdf")
    messages = _messages(record)
    assert len(messages) == 4
    crank = next(m for m in messages if "'crank_pivot'" in m)
    assert "four_bar_mm.urdf" in crank
    assert "0.05 m" in crank and "25 %" in crank and "0.2 m" in crank
    # pin_A joins the crank (60 mm) and the coupler (180 mm between pin A and pin B)
    pin_a = next(m for m in messages if "'pin_A'" in m)
    assert "0.18 m" in pin_a and "27.8 %" in pin_a


@pytest.mark.parametrize(("radial", "warns"), [("0.0099", False), ("0.0101", True)])
def test_clearance_threshold_is_five_percent_of_the_part(radial, warns):
    """The threshold: 5 % of 200 mm is 10 mm. 9.9 mm on crank_pivot is silent, 10.1 mm warns
    (the other joints keep their 50 um)."""
    text = _text("four_bar").replace(
        'name="crank_pivot" type="planar_revolute" radial_clearance="5e-05"',
        f'name="crank_pivot" type="planar_revolute" radial_clearance="{radial}"',
    )
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        cp.loads(text)
    messages = _messages(record)
    assert bool(messages) is warns
    assert all("'crank_pivot'" in m for m in messages)


def test_journal_length_counts_as_the_part_size():
    """Younes' two cylinders: J = 0.2 typed for 0.2 mm is a 0.1 m radial play on a 40 mm journal
    whose joint centres are 100 mm apart: 100 % of 0.1 m, warned for both joints."""
    text = _text("younes_two_cylinders").replace(
        'diametral_clearance="0.0002"', 'diametral_clearance="0.2"'
    )
    with pytest.warns(cp.SuspectValueWarning) as record:
        cp.loads(text)
    messages = _messages(record)
    assert {re.search(r"joint '(\w+)'", m).group(1) for m in messages} == {"I1", "I2"}
    assert all("0.1 m is 100 %" in m for m in messages)


def test_nominal_value_in_degrees_warns_in_the_file():
    """q="60" (degrees meant) on the double pendulum's shoulder, URDF limits [-7, 7] rad: the
    warning names the joint, 60 rad, the limits and 60 deg = 1.0472 rad."""
    text = _text("double_pendulum").replace('q="0.5235987755982988"', 'q="60"')
    with pytest.warns(cp.SuspectValueWarning) as record:
        cp.loads(text, source="pendulum.urdf")
    (message,) = _messages(record)
    assert "pendulum.urdf" in message and "'shoulder'" in message
    assert "60 rad" in message and "[-7, 7]" in message and "1.0472 rad" in message


def test_nominal_value_outside_the_limits_warns_in_the_api():
    """solve(q=...) with a joint outside its URDF limits warns, naming q and the joint, and
    still solves (the value is valid, only suspect)."""
    mechanism = cp.load(MODELS / "double_pendulum.urdf")
    q = mechanism.q_nominal.copy()
    q[1] = 45.0
    with pytest.warns(cp.SuspectValueWarning, match=r"q: joint 'elbow': nominal value 45 rad"):
        result = mechanism.solve(q=q)
    assert result.ok
    with warnings.catch_warnings():
        warnings.simplefilter("error", cp.ClearancePinWarning)
        mechanism.solve(q=mechanism.q_nominal)  # inside the limits: silent


def test_more_than_a_turn_warns_without_limits():
    """A continuous joint has no limits; q="90" on it is more than a turn and warns."""
    text = """<robot name="wheel">
  <link name="ground"/><link name="wheel"/>
  <joint name="axle" type="continuous">
    <parent link="ground"/><child link="wheel"/><axis xyz="0 0 1"/>
  </joint>
  <clearance_pin><joint name="axle" driven="true" q="90"/></clearance_pin>
</robot>"""
    with pytest.warns(cp.SuspectValueWarning, match=r"'axle': nominal value 90 rad is more than"):
        cp.loads(text)


def test_limit_without_a_range_is_not_judged():
    """A <limit> with only effort and velocity has lower = upper = 0 (URDF defaults): no range,
    so q = 1 rad does not warn."""
    text = """<robot name="lever">
  <link name="ground"/><link name="lever"/>
  <joint name="pivot" type="revolute">
    <parent link="ground"/><child link="lever"/><axis xyz="0 0 1"/>
    <limit effort="1" velocity="1"/>
  </joint>
  <clearance_pin><joint name="pivot" driven="true" q="1"/></clearance_pin>
</robot>"""
    with warnings.catch_warnings():
        warnings.simplefilter("error", cp.ClearancePinWarning)
        cp.loads(text)


def _pendulum_with(dimension: str) -> str:
    """The double pendulum with a probe 10 mm along link 2 and one more dimension."""
    text = _text("double_pendulum")
    text = text.replace(
        '<link name="tip"/>',
        '<link name="tip"/><link name="probe"/>\n  <joint name="probe_mount" type="fixed">'
        '<parent link="link2"/><child link="probe"/><origin xyz="0.01 0 0"/></joint>',
    )
    return text.replace("  </clearance_pin>", f"    {dimension}\n  </clearance_pin>")


def test_tolerance_as_wide_as_its_size_warns():
    """+/- 50 mm on the 10 mm probe offset: 500 % of its nominal size, warned with the numbers."""
    text = _pendulum_with(
        '<dimension name="p" joint="probe_mount" direction="1 0 0" half_tolerance="0.05"/>'
    )
    with pytest.warns(cp.SuspectValueWarning) as record:
        cp.loads(text, source="probe.urdf")
    (message,) = _messages(record)
    assert "probe.urdf" in message and "dimension 'p'" in message
    assert "+/- 0.05 m" in message and "500 %" in message and "0.01 m" in message


@pytest.mark.parametrize(
    ("dimension", "warns"),
    [
        ('<dimension name="p" joint="probe_mount" direction="1 0 0" tolerance="0.0019"/>', False),
        ('<dimension name="p" joint="probe_mount" direction="1 0 0" tolerance="0.0021"/>', True),
        ('<dimension name="a" joint="probe_mount" rotation_axis="0 0 1" tolerance="0.19"/>', False),
        ('<dimension name="a" joint="probe_mount" rotation_axis="0 0 1" tolerance="0.21"/>', True),
    ],
)
def test_tolerance_thresholds(dimension, warns):
    """Thresholds: half tolerance 10 % of the nominal size (1 mm of 10 mm: T = 1.9 mm silent,
    2.1 mm warns); an angle 0.1 rad (T = 0.19 rad silent, 0.21 rad warns)."""
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        cp.loads(_pendulum_with(dimension))
    assert bool(_messages(record)) is warns


def test_offset_tolerance_is_judged_against_the_length_scale():
    """A zero nominal (an offset across link 2) has no size of its own: +/- 50 mm is judged
    against the mechanism's length scale, 0.3 m (the elbow's distance from the root), 16.7 %."""
    text = _pendulum_with(
        '<dimension name="e" joint="probe_mount" direction="0 1 0" half_tolerance="0.05"/>'
    )
    with pytest.warns(cp.SuspectValueWarning, match=r"16\.7 % of the mechanism's length scale"):
        mechanism = cp.loads(text)
    assert np.isclose(mechanism.length_scale(), 0.3)


def test_a_universal_joint_cross_is_no_size():
    """Two revolutes whose centres meet (a universal joint's cross) have no distance between
    them: the play is judged against nothing rather than a round-off size (which read
    "4.5e+11 % of its part's size 2.2e-16 m"); no warning."""
    text = """<?xml version="1.0"?>
<robot name="ujoint">
  <link name="ground"/>
  <link name="cross"><inertial><mass value="0.1"/>
    <inertia ixx="1e-5" iyy="1e-5" izz="1e-5" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="arm"><inertial><mass value="1"/>
    <inertia ixx="1e-3" iyy="1e-3" izz="1e-3" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="u1" type="revolute"><parent link="ground"/><child link="cross"/>
    <origin xyz="0.1 0.2 0.3"/><axis xyz="1 0 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="u2" type="revolute"><parent link="cross"/><child link="arm"/>
    <origin xyz="1e-17 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <clearance_pin>
    <joint name="u1" type="planar_revolute" radial_clearance="1e-06" driven="true"/>
    <joint name="u2" type="planar_revolute" radial_clearance="1e-06" driven="true"/>
  </clearance_pin>
</robot>
"""
    from clearance_pin.loading import loads

    with warnings.catch_warnings():
        warnings.simplefilter("error", cp.ClearancePinWarning)
        loads(text, source="ujoint")
