"""The skeleton behind the pictures (clearance_pin.plot.skeleton), checked against the model files'
own numbers: joint centres from the URDF origins, the play's geometry, contact forces turned to
world axes, and the planar / spatial decision from the joint axes and the settled motion."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import MODELS

import clearance_pin
from clearance_pin import PointForce
from clearance_pin.plot.skeleton import magnify, plane_axes, play_outlines, skeleton
from clearance_pin.plot.style import nice_ceil, nice_floor, nice_round


@pytest.fixture(scope="module")
def four_bar():
    return clearance_pin.load(MODELS / "four_bar.urdf").solve()


@pytest.fixture(scope="module")
def arm():
    return clearance_pin.load(MODELS / "arm_6r.urdf").solve()


def test_four_bar_joint_centres_are_the_urdf_geometry(four_bar):
    bones = skeleton(four_bar)
    joints = {j.name: j for j in bones.joints}
    assert set(joints) == {"crank_pivot", "pin_A", "rocker_pivot", "pin_B"}
    # ground 200 mm, crank 60 mm at 60 deg (the file's nominal crank angle)
    np.testing.assert_allclose(joints["crank_pivot"].housing, [0, 0, 0], atol=1e-12)
    np.testing.assert_allclose(joints["rocker_pivot"].housing, [0.2, 0, 0], atol=1e-12)
    np.testing.assert_allclose(
        joints["pin_A"].housing, [0.06 * np.cos(np.pi / 3), 0.06 * np.sin(np.pi / 3), 0], atol=1e-9
    )
    # the loop is closed: coupler 180 mm from pin A, rocker 120 mm from its pivot
    b = joints["pin_B"].housing
    assert np.linalg.norm(b - joints["pin_A"].housing) == pytest.approx(0.18, abs=1e-9)
    assert np.linalg.norm(b - joints["rocker_pivot"].housing) == pytest.approx(0.12, abs=1e-9)
    assert joints["pin_B"].loop and not joints["pin_A"].loop
    assert joints["crank_pivot"].driven
    for joint in joints.values():
        np.testing.assert_allclose(joint.axis, [0, 0, 1], atol=1e-12)
        assert joint.radial == pytest.approx(5e-5)
        # each journal centre stays inside its play around the housing centre
        relative = np.linalg.norm(joint.journal_moved - joint.housing_moved)
        assert relative <= joint.radial * (1 + 1e-9)


def test_four_bar_links_join_each_part(four_bar):
    bones = skeleton(four_bar)
    for a, b in bones.links:
        assert bones.bodies[a] == bones.bodies[b]
    # ground (the two pivots), crank, coupler (pin A, load point, pin B) and rocker
    assert len(bones.links) == 5
    ground = [(a, b) for a, b in bones.links if bones.bodies[a] == 0]
    ((a, b),) = ground
    assert np.linalg.norm(bones.points[a] - bones.points[b]) == pytest.approx(0.2)
    assert np.all(bones.moved[bones.bodies == 0] == bones.points[bones.bodies == 0])


def test_contact_forces_in_world_axes_balance_the_parts(four_bar):
    """The crank carries no load but its drive torque: the two pins' forces on it cancel."""
    bones = skeleton(four_bar)
    forces = {c.joint: c.force for c in bones.active_contacts}
    assert len(bones.active_contacts) == len(four_bar.active_contacts) == 4
    # crank: the ground on the crank (crank_pivot) and the coupler on the crank (-pin_A's force)
    np.testing.assert_allclose(forces["crank_pivot"] - forces["pin_A"], 0.0, atol=1e-9)
    for contact in bones.active_contacts:
        assert contact.force[2] == pytest.approx(0.0, abs=1e-12)  # in the plane
        assert np.linalg.norm(contact.force) == pytest.approx(
            next(c.force_magnitude for c in four_bar.contacts if c.label == contact.label)
        )
    loads = {load.label: load for load in bones.loads}
    np.testing.assert_allclose(loads["coupler@[0.09 0 0]"].force, [0, -40, 0])
    assert bones.torques == ("rocker",) and not bones.gravity


def test_planar_and_spatial(four_bar, arm):
    np.testing.assert_allclose(np.abs(skeleton(four_bar).plane()), [0, 0, 1])
    slider = clearance_pin.load(MODELS / "slider_crank.urdf").solve()
    np.testing.assert_allclose(np.abs(skeleton(slider).plane()), [0, 0, 1])
    assert skeleton(arm).plane() is None  # axes along z and y
    # an out-of-plane load tilts nothing in planar pins (u, beta, gamma rigid): still planar
    mechanism = clearance_pin.load(MODELS / "four_bar.urdf")
    tilted = mechanism.solve(loads=[PointForce("coupler", [0, -40, 5], [0.09, 0, 0])])
    assert skeleton(tilted).plane() is not None
    # journals with play let the same load move the coupler out of the plane: spatial
    younes = clearance_pin.load(MODELS / "younes_sphere_cylinder.urdf").solve()
    assert skeleton(younes).plane() is None  # a spherical joint


def test_plane_axes_are_right_handed():
    for normal in (np.array([0, 0, 1.0]), np.array([0, 0, -1.0]), np.array([1.0, 0, 0]),
                   np.array([1.0, 2.0, 3.0]) / np.sqrt(14)):  # fmt: skip
        e1, e2, _, _ = plane_axes(normal)
        np.testing.assert_allclose(np.cross(e1, e2), normal, atol=1e-12)
    assert plane_axes(np.array([0, 0, 1.0]))[2:] == ("x", "y")


def test_default_magnification_draws_the_largest_displacement_at_a_few_percent(four_bar, arm):
    for equilibrium in (four_bar, arm):
        bones = skeleton(equilibrium)
        m = bones.default_magnification()
        drawn = m * bones.largest_displacement() / bones.size()
        assert 0.03 <= drawn <= 0.08
        assert m == nice_round(m)
    assert nice_floor(87.0) == 50.0 and nice_ceil(87.0) == 100.0 and nice_round(87.0) == 100.0
    assert nice_round(3.0) == 2.0 and nice_round(4.0) == 5.0


def test_magnified_play_circle_holds_the_magnified_journal(four_bar):
    """Magnifying every point by m magnifies the motion inside each joint by m: a pin in contact
    lies on its play circle of radius m c around the magnified housing centre."""
    bones = skeleton(four_bar)
    m = 100.0
    for joint in bones.joints:
        housing = magnify(joint.housing, joint.housing_moved, m)
        journal = magnify(joint.journal, joint.journal_moved, m)
        (ring,) = play_outlines(joint, m)
        np.testing.assert_allclose(np.linalg.norm(ring - housing, axis=1), m * joint.radial)
        assert np.linalg.norm(journal - housing) == pytest.approx(m * joint.radial, rel=1e-6)


def test_journal_play_outlines(arm):
    bones = skeleton(arm)
    joint = bones.joints[0]
    rings = play_outlines(joint, 10.0)
    assert len(rings) == 2  # the journal's two ends
    centre = magnify(joint.housing, joint.housing_moved, 10.0)
    for ring, side in zip(rings, (-1, 1)):
        along = (ring - centre) @ joint.axis
        np.testing.assert_allclose(along, side * joint.length / 2, atol=1e-12)
        across = ring - centre - np.outer(along, joint.axis)
        np.testing.assert_allclose(np.linalg.norm(across, axis=1), 10.0 * joint.radial)
