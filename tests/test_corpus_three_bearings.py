"""Issue 10 corpus: a shaft on three journal bearings, aligned and misaligned (finding 6).

Written from docs/model-format.md: the shaft's first bearing is a URDF floating joint carrying
a cylindrical clearance, the other two are cylindrical loop joints between a ground frame and a
shaft frame. Radial play c = 30 um, journals L = 20 mm long, 100 mm apart; two radial forces.
The misaligned variant puts the middle housing 20 um off the common axis (inside the play).

Independent checks (world coordinates, no solver code): every journal end of the shaft, placed at
the solved pose, lies within c of its own housing's bore axis; the reported contact forces and the
loads balance the shaft; each force acts only at an end that touches its bore and pushes it back
towards the axis. With feasibility these are the KKT conditions of the convex small-displacement
problem, so together they certify the optimum without the solver's formulation.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest

import clearance_pin
from clearance_pin import PointForce

RADIAL, LENGTH, PITCH = 30e-6, 0.02, 0.1  # [m]
MISALIGNMENT = 20e-6  # [m], middle housing along +y
BEARINGS = ("A", "B", "C")  # at x = 0, 0.1, 0.2 m
LOADS = [
    PointForce("shaft", [0.0, -100.0, 0.0], [0.05, 0.0, 0.0]),
    PointForce("shaft", [0.0, -100.0, 30.0], [0.17, 0.0, 0.0]),
]


def model_text(offset_y: float) -> str:
    return f"""<?xml version="1.0"?>
<robot name="three_bearing_shaft">
  <link name="ground"/>
  <link name="shaft"/>
  <link name="housing_B"/><link name="journal_B"/>
  <link name="housing_C"/><link name="journal_C"/>
  <joint name="A" type="floating"><parent link="ground"/><child link="shaft"/></joint>
  <joint name="housing_B_mount" type="fixed"><parent link="ground"/><child link="housing_B"/>
    <origin xyz="{PITCH!r} {offset_y!r} 0"/></joint>
  <joint name="journal_B_mount" type="fixed"><parent link="shaft"/><child link="journal_B"/>
    <origin xyz="{PITCH!r} 0 0"/></joint>
  <joint name="housing_C_mount" type="fixed"><parent link="ground"/><child link="housing_C"/>
    <origin xyz="{2 * PITCH!r} 0 0"/></joint>
  <joint name="journal_C_mount" type="fixed"><parent link="shaft"/><child link="journal_C"/>
    <origin xyz="{2 * PITCH!r} 0 0"/></joint>
  <clearance_pin>
    <joint name="A" type="cylindrical" radial_clearance="{RADIAL!r}" length="{LENGTH!r}"
           axis="1 0 0"/>
    <loop_joint name="B" type="cylindrical" frame_a="housing_B" frame_b="journal_B"
                radial_clearance="{RADIAL!r}" length="{LENGTH!r}" axis="1 0 0"/>
    <loop_joint name="C" type="cylindrical" frame_a="housing_C" frame_b="journal_C"
                radial_clearance="{RADIAL!r}" length="{LENGTH!r}" axis="1 0 0"/>
  </clearance_pin>
</robot>
"""


def bores(offset_y: float) -> dict[str, np.ndarray]:
    """A point of each housing's bore axis (world); every bore runs along x."""
    return {
        "A": np.zeros(3),
        "B": np.array([PITCH, offset_y, 0.0]),
        "C": np.array([2 * PITCH, 0.0, 0.0]),
    }


def journal_ends(name: str) -> dict[str, np.ndarray]:
    """The shaft's journal ends of bearing ``name`` in the shaft frame (docs: end-/end+ at
    x = -/+ L/2 of the joint centre)."""
    centre = PITCH * BEARINGS.index(name)
    return {
        "end-": np.array([centre - LENGTH / 2, 0.0, 0.0]),
        "end+": np.array([centre + LENGTH / 2, 0.0, 0.0]),
    }


def radial_offset(point, bore_point) -> np.ndarray:
    offset = np.asarray(point) - bore_point
    return np.array([0.0, offset[1], offset[2]])


def assert_no_spin(eq) -> None:
    """The spin about the shaft's axis is a free motion (nothing bounds it, the loads do not
    work on it): left at zero (docs: minimum-norm optimum). Any tilt is below ~ 2 c / pitch."""
    if eq.formulation == "exact":
        rotation = pin.log3(eq.body_placements[1].rotation)
    else:
        rotation = np.asarray(eq.body_twists[1][3:])
    assert abs(rotation[0]) < 1e-12, rotation
    assert np.linalg.norm(rotation) < 10 * RADIAL / PITCH, rotation


def check_settled_shaft(eq, offset_y: float, moved) -> None:
    """Feasibility, statics, complementarity and force directions; ``moved(p)`` places a shaft
    point p (shaft frame = world at the nominal pose) at the solved pose."""
    assert_no_spin(eq)
    contacts = {c.label: c for c in eq.contacts}
    total = np.zeros(6)
    for load in LOADS:
        total += np.concatenate([load.force, np.cross(load.point, load.force)])
    largest = max(float(np.linalg.norm(c.force)) for c in eq.contacts)
    for name, bore in bores(offset_y).items():
        assert np.allclose(eq.mechanism.joint(name).rotation, np.eye(3), atol=1e-12)
        for end, point in journal_ends(name).items():
            delta = radial_offset(moved(point), bore)
            reach = float(np.linalg.norm(delta))
            assert reach <= RADIAL * (1 + 1e-9), (name, end, reach)
            force = np.asarray(contacts[f"{name}:{end}"].force)  # housing on shaft, x = world x
            size = float(np.linalg.norm(force))
            if size > 1e-9 * largest:
                assert reach == pytest.approx(RADIAL, rel=1e-9), (name, end)
                # pushes back towards the bore axis
                assert force @ delta == pytest.approx(-size * reach, rel=1e-7), (name, end)
            total += np.concatenate([force, np.cross(point, force)])
    assert np.abs(total).max() < 1e-10 * 100.0


@pytest.fixture(scope="module")
def aligned():
    return clearance_pin.loads(model_text(0.0))


def test_aligned_shaft_linear(aligned):
    eq = aligned.solve(loads=LOADS)
    assert eq.ok
    v, w = np.asarray(eq.body_twists[1][:3]), np.asarray(eq.body_twists[1][3:])
    check_settled_shaft(eq, 0.0, lambda p: p + v + np.cross(w, p))


def test_aligned_shaft_exact(aligned):
    eq = aligned.solve(loads=LOADS, exact=True)
    assert eq.formulation == "exact" and eq.ok
    contacts_only_geometry(eq, 0.0, eq.body_placements[1].act)


def contacts_only_geometry(eq, offset_y, moved) -> None:
    """Every journal end within its bore, and the loaded ones on it (exact model)."""
    assert_no_spin(eq)
    contacts = {c.label: c for c in eq.contacts}
    largest = max(float(np.linalg.norm(c.force)) for c in eq.contacts)
    for name, bore in bores(offset_y).items():
        for end, point in journal_ends(name).items():
            reach = float(np.linalg.norm(radial_offset(moved(point), bore)))
            assert reach <= RADIAL * (1 + 1e-9), (name, end, reach)
            if np.linalg.norm(contacts[f"{name}:{end}"].force) > 1e-9 * largest:
                assert reach == pytest.approx(RADIAL, rel=1e-9), (name, end)


def test_misaligned_shaft_linear():
    mech = clearance_pin.loads(model_text(MISALIGNMENT))
    eq = mech.solve(loads=LOADS)
    assert eq.ok
    v, w = np.asarray(eq.body_twists[1][:3]), np.asarray(eq.body_twists[1][3:])
    check_settled_shaft(eq, MISALIGNMENT, lambda p: p + v + np.cross(w, p))


def test_misaligned_shaft_exact():
    mech = clearance_pin.loads(model_text(MISALIGNMENT))
    eq = mech.solve(loads=LOADS, exact=True)
    assert eq.formulation == "exact" and eq.ok
    contacts_only_geometry(eq, MISALIGNMENT, eq.body_placements[1].act)


def test_misalignment_beyond_the_play_is_refused():
    with pytest.raises(clearance_pin.ModelError):
        clearance_pin.loads(model_text(2 * RADIAL)).solve(loads=LOADS)
