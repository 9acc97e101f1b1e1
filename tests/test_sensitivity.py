"""Tests of clearance_pin.tolerance.sensitivity: S = -Phi_q^-1 Phi_d from Pinocchio Jacobians."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import clearance_pin
from clearance_pin.errors import ClearancePinError, ModelError
from clearance_pin.tolerance.dimensions import with_deviations
from clearance_pin.tolerance.sensitivity import (
    loop_passive_indices,
    output_deviations,
    parse_output,
    sensitivities,
)
from clearance_pin.tolerance.sweep import closed_configuration, driven_joint

MODELS = Path(__file__).resolve().parent.parent / "models"
R2, R3 = 0.050, 0.120


@pytest.fixture(scope="module")
def slider_crank():
    return clearance_pin.load(MODELS / "slider_crank.urdf")


@pytest.fixture(scope="module")
def four_bar():
    """The bundled four-bar with a length on every link and an angle on the coupler."""
    text = (MODELS / "four_bar.urdf").read_text()
    return clearance_pin.loads(
        text.replace("</clearance_pin>", FOUR_BAR_DIMENSIONS), source="four_bar+dimensions"
    )


def _four_bar_dimensions() -> str:
    import xml.etree.ElementTree as ET

    root = ET.fromstring((MODELS / "four_bar.urdf").read_text())
    movable = [j.get("name") for j in root.findall("joint") if j.get("type") != "fixed"]
    fixed = [j.get("name") for j in root.findall("joint") if j.get("type") == "fixed"]
    lines = [
        f'<dimension name="L{k}" joint="{name}" direction="1 0 0" tolerance="1e-4"/>'
        for k, name in enumerate(movable[1:] + fixed)
    ]
    lines.append(
        f'<dimension name="a" joint="{movable[-1]}" rotation_axis="0 0 1" tolerance="1e-3"/>'
    )
    lines.append(f'<dimension name="h" joint="{movable[1]}" direction="0 1 0" tolerance="1e-4"/>')
    return "\n".join(lines) + "\n</clearance_pin>"


FOUR_BAR_DIMENSIONS = _four_bar_dimensions()


def at_phi(mechanism, phi_deg: float) -> np.ndarray:
    """Closed slider-crank configuration at crank angle phi from TDC (theta2 = -phi)."""
    joint = driven_joint(mechanism)
    q = mechanism.configure().q
    return closed_configuration(mechanism, joint, -math.radians(phi_deg), q)


def closed_form(phi_deg: float) -> np.ndarray:
    """[[dx4/dr2, dx4/dr3], [dtheta3/dr2, dtheta3/dr3]] of the in-line slider-crank, from
    x4 = r2 cos t2 + sqrt(r3^2 - r2^2 sin^2 t2) and r2 sin t2 + r3 sin t3 = 0 (t2 = -phi)."""
    t2 = -math.radians(phi_deg)
    s = math.sqrt(R3**2 - R2**2 * math.sin(t2) ** 2)  # = r3 cos t3
    return np.array(
        [
            [math.cos(t2) - R2 * math.sin(t2) ** 2 / s, R3 / s],
            [-math.sin(t2) / s, R2 * math.sin(t2) / (R3 * s)],
        ]
    )


def finite_differences(mechanism, q, outputs, h: float = 1e-7) -> np.ndarray:
    """Central differences of the exact closure: perturbed joint placements, loops re-closed."""
    columns = []
    for k in range(len(mechanism.dimensions)):
        dd = np.zeros(len(mechanism.dimensions))
        ends = []
        for sign in (1.0, -1.0):
            dd[k] = sign * h
            moved = with_deviations(mechanism, dd)
            q_moved = moved.configure(q).q
            ends.append(output_deviations(mechanism.model, q, moved.model, q_moved, outputs))
        columns.append((ends[0] - ends[1]) / (2 * h))
    return np.array(columns).T


@settings(max_examples=30, deadline=None, derandomize=True)
@given(st.floats(0.0, 360.0))
def test_slider_crank_matches_closed_form(slider_crank, phi):
    """dx4/dr2, dx4/dr3, dtheta3/dr2, dtheta3/dr3 from the Jacobians equal the derivatives of
    the closed-form slider-crank at any crank angle (1e-10)."""
    q = at_phi(slider_crank, phi)
    result = sensitivities(slider_crank, ["x4=slider.x", "theta3=rod.rz"], q, closed=True)
    assert result.values[0] == pytest.approx(
        R2 * math.cos(math.radians(phi))
        + math.sqrt(R3**2 - (R2 * math.sin(math.radians(phi))) ** 2),
        abs=1e-13,
    )
    assert np.allclose(result.matrix, closed_form(phi), atol=1e-10)


def test_dead_centres(slider_crank):
    """At TDC both x4 sensitivities are 1, at BDC -1 and 1; theta3 does not move (Flores)."""
    tdc = sensitivities(
        slider_crank, ["slider.x", "rod.rz"], at_phi(slider_crank, 0.0), closed=True
    )
    bdc = sensitivities(
        slider_crank, ["slider.x", "rod.rz"], at_phi(slider_crank, 180.0), closed=True
    )
    assert np.allclose(tdc.matrix, [[1.0, 1.0], [0.0, 0.0]], atol=1e-12)
    assert np.allclose(bdc.matrix, [[-1.0, 1.0], [0.0, 0.0]], atol=1e-12)
    assert tdc.worst_case()[0] == pytest.approx(120e-6, abs=1e-15)
    assert tdc.rss()[0] == pytest.approx(math.hypot(50e-6, 70e-6), abs=1e-15)


@pytest.mark.parametrize("phi", [10.0, 75.0, 160.0, 250.0])
def test_slider_crank_matches_finite_differences(slider_crank, phi):
    """S agrees with central differences of the exact closure (perturbed pin.Model, re-closed
    with close_loops) for a frame position, a frame orientation and joint coordinates."""
    q = at_phi(slider_crank, phi)
    outputs = ["slider.x", "rod.rz", "pin_A", "pin_B", "crank_pivot"]
    result = sensitivities(slider_crank, outputs, q, closed=True)
    fd = finite_differences(slider_crank, result.q, result.outputs)
    assert np.allclose(result.matrix, fd, atol=1e-7)
    assert np.allclose(result.matrix[-1], 0.0)  # the driven joint holds


def test_four_bar_with_angles_and_fixed_joints_matches_finite_differences(four_bar):
    """A loop with lengths on movable and fixed joints, an angle and a transverse offset:
    the virtual-joint columns give the same S as finite differences of the exact closure."""
    names = [f.name for f in four_bar.model.frames]
    body_frames = [n for n in names if four_bar.model.existBodyName(n)]
    outputs = [f"{body}.{c}" for body in body_frames for c in ("x", "y", "rz")]
    result = sensitivities(four_bar, outputs)
    fd = finite_differences(four_bar, result.q, result.outputs)
    assert np.allclose(result.matrix, fd, atol=2e-7)
    assert result.conditioning > 1e-3


def test_double_pendulum_is_an_open_chain():
    """Without loops S is the virtual-joint Jacobian itself: dP/dl1 = u1, dP/dl2 = u2 (link
    directions), dP/da2 = e_z x (P - A) for the elbow's angular offset."""
    mechanism = clearance_pin.load(MODELS / "double_pendulum.urdf")
    t1, t2 = math.radians(30.0), math.radians(45.0)
    result = sensitivities(mechanism, ["tip.x", "tip.y", "link2.rz"])
    u1 = np.array([math.cos(t1), math.sin(t1)])
    u2 = np.array([math.cos(t1 + t2), math.sin(t1 + t2)])
    expected = np.column_stack([u1, u2, 0.2 * np.array([-u2[1], u2[0]])])
    assert np.allclose(result.matrix[:2], expected, atol=1e-14)
    assert np.allclose(result.matrix[2], [0.0, 0.0, 1.0])
    assert result.passive.shape == (0, 3) and result.conditioning == 1.0
    fd = finite_differences(mechanism, result.q, result.outputs)
    assert np.allclose(result.matrix, fd, atol=1e-8)


def test_out_of_plane_dimension_of_a_planar_loop_is_refused(slider_crank):
    """A z offset of a pin in the planar slider-crank cannot be followed by the passive joints
    (the loop is overconstrained in z): ModelError naming the dimension."""
    text = (
        (MODELS / "slider_crank.urdf")
        .read_text()
        .replace(
            "</clearance_pin>",
            '<dimension name="z" joint="pin_B" direction="0 0 1" tolerance="1e-4"/></clearance_pin>',
        )
    )
    mechanism = clearance_pin.loads(text, source="sc+z")
    with pytest.raises(ModelError, match=r"name='z'.*cannot follow"):
        sensitivities(mechanism, ["slider.x"])


def test_singular_position_is_refused():
    """A slider-crank with r3 = r2 folds at 90 deg (rod vertical, B on the crank pivot):
    Phi_q is rank-deficient there and the sensitivities are refused."""
    text = (MODELS / "slider_crank.urdf").read_text().replace('xyz="0.12 0 0"', 'xyz="0.05 0 0"')
    mechanism = clearance_pin.loads(text, source="sc-folded")
    q = np.array([-math.pi / 2, math.pi, -math.pi / 2])  # closed exactly: B = O
    with pytest.raises(ClearancePinError, match="singular"):
        sensitivities(mechanism, ["slider.x"], q, closed=True)


def test_passive_joints_outside_loops_keep_their_value():
    """loop_passive_indices keeps only the passive joints that carry a loop frame."""
    mechanism = clearance_pin.load(MODELS / "slider_crank.urdf")
    assert loop_passive_indices(mechanism) == [1, 2]


def test_output_specs():
    """Output specs: NAME=FRAME.comp, FRAME.comp, joint names; errors list the choices."""
    mechanism = clearance_pin.load(MODELS / "slider_crank.urdf")
    x4 = parse_output(mechanism.model, "x4=slider.x")
    assert (x4.name, x4.kind, x4.target, x4.component, x4.unit) == (
        "x4",
        "position",
        "slider",
        0,
        "m",
    )
    assert parse_output(mechanism.model, "rod.rz").kind == "orientation"
    assert parse_output(mechanism.model, "pin_A").kind == "joint"
    with pytest.raises(ClearancePinError, match="the frames are"):
        parse_output(mechanism.model, "nothing.x")
    with pytest.raises(ClearancePinError, match="no toleranced dimension"):
        sensitivities(clearance_pin.load(MODELS / "four_bar.urdf"), ["crank.x"])
