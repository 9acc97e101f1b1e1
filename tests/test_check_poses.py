"""Clearance frames at a solved pose: the parent's and the child's, joint by joint."""

from __future__ import annotations

import dataclasses
import sys
import tomllib
from functools import cache
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import clearance_pin as cp
from clearance_pin.check.poses import clearance_frames, joint_links

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "validation"))
from younes2013 import build  # noqa: E402

CASES = {
    c["id"]: c
    for c in tomllib.loads((ROOT / "validation" / "younes2013_cases.toml").read_text())["case"]
}
MODELS = sorted(p.name for p in (ROOT / "models").glob("*.urdf"))


@cache
def _exact(source: str):
    mechanism = build(CASES[source]) if source in CASES else cp.load(ROOT / "models" / source)
    return mechanism.solve(exact=True)


@pytest.mark.parametrize("source", ["6.1.6.1b", "6.3.2", *MODELS])
def test_relative_placement_is_the_exponential_of_the_torsor(source):
    """Exact model: the child's clearance frame in the parent's is exp6 of the joint's torsor
    (tree joints: the motion the solver applied; loop joints: the motion it read), to 1e-15 m."""
    equilibrium = _exact(source)
    frames = clearance_frames(equilibrium)
    for name, torsor in equilibrium.torsors.items():
        expected = pin.exp6(pin.Motion(torsor))
        relative = frames[name].relative
        assert np.allclose(relative.translation, expected.translation, rtol=0, atol=1e-15), name
        assert np.allclose(relative.rotation, expected.rotation, rtol=0, atol=1e-13), name


@pytest.mark.parametrize("source", ["6.1.6.1a", *MODELS])
def test_frames_coincide_at_the_nominal_pose(source):
    """With every body at its nominal placement, both clearance frames of every joint coincide."""
    equilibrium = _exact(source)
    nominal = dataclasses.replace(equilibrium, body_placements=tuple(equilibrium.configuration.oMi))
    for name, frames in clearance_frames(nominal).items():
        assert frames.relative.isIdentity(1e-12), name


@settings(max_examples=25, deadline=None)
@given(
    st.lists(st.floats(-3.0, 3.0), min_size=3, max_size=3),
    st.lists(st.floats(-2.0, 2.0), min_size=3, max_size=3),
)
def test_rigid_motion_of_everything_changes_no_relative_placement(rotation, translation):
    """Moving the whole mechanism rigidly (every body, the ground included) leaves every joint's
    relative placement unchanged (to 1e-15 m, 1e-13 rad)."""
    equilibrium = _exact("four_bar.urdf")
    motion = pin.SE3(pin.exp3(np.array(rotation)), np.array(translation))
    moved_configuration = dataclasses.replace(
        equilibrium.configuration, oMi=tuple(motion * m for m in equilibrium.configuration.oMi)
    )
    moved = dataclasses.replace(
        equilibrium,
        body_placements=tuple(motion * m for m in equilibrium.body_placements),
        configuration=moved_configuration,
    )
    before, after = clearance_frames(equilibrium), clearance_frames(moved)
    for name in before:
        a, b = before[name].relative, after[name].relative
        assert np.allclose(a.translation, b.translation, rtol=0, atol=1e-15), name
        assert np.allclose(a.rotation, b.rotation, rtol=0, atol=1e-13), name


def test_joint_links_name_the_two_parts():
    """Tree joint: the link it hangs from and the link it carries; loop joint: the links of its
    two frames."""
    mechanism = build(CASES["6.1.6.1a"])
    frames = mechanism.model.frames
    names = {j: tuple(frames[i].name for i in joint_links(mechanism, j)) for j in ("I1", "I2")}
    assert names == {"I1": ("ground", "shaft"), "I2": ("ground_I2", "shaft_I2")}
    four_bar = cp.load(ROOT / "models" / "four_bar.urdf")
    frames = four_bar.model.frames
    assert tuple(frames[i].name for i in joint_links(four_bar, "pin_A")) == ("crank", "coupler")
    assert tuple(frames[i].name for i in joint_links(four_bar, "pin_B")) == (
        "rocker_B",
        "coupler_B",
    )


def test_wrong_number_of_placements_is_refused():
    """A pose with the wrong number of body placements is refused, saying how many are needed."""
    equilibrium = _exact("6.1.6.1a")
    broken = dataclasses.replace(equilibrium, body_placements=equilibrium.body_placements[:1])
    with pytest.raises(ValueError, match=r"body_placements: expected 2 placements"):
        clearance_frames(broken)
