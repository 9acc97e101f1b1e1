"""Tolerances and the clearance envelope along a motion; the Monte Carlo of contact modes.

Independent references: at the slider-crank's top dead centre (models/slider_crank.urdf: crank
50 mm +/- 50 um, rod 120 mm +/- 70 um, 50 um play in the three pins and the guide) the slider's
x moves by the sum of the three pins' plays along the line of the crank and the rod, +/- 150 um
(each pin's eccentricity along that line changes the length O-B one for one; the guide's play is
across it), and its dimensional worst case is 50 + 70 = 120 um (P. Flores 2011, the bands of
validation/flores2011.py): +/- 270 um together. The contact modes of a symmetric envelope come in
opposite pairs (the state under -d is minus the state under d), which the sampled modes must show.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import clearance_pin
from clearance_pin.envelope import envelope
from clearance_pin.envelope.tolerances import contact_modes, motion_envelope

ROOT = Path(__file__).resolve().parent.parent
SLIDER_CRANK = ROOT / "models" / "slider_crank.urdf"


@pytest.fixture(scope="module")
def slider_crank() -> clearance_pin.Mechanism:
    return clearance_pin.load(SLIDER_CRANK)


@pytest.fixture(scope="module")
def motion(slider_crank):
    return motion_envelope(
        slider_crank, ["x4=slider.x"], positions=5, start=0.0, stop=math.pi, clockwise=True
    )


def test_top_dead_centre_clearance_and_tolerances_add(motion):
    assert motion.phi[0] == 0.0
    assert motion.clearance[0, 0] == pytest.approx([-150e-6, 150e-6], rel=1e-9)
    assert motion.tolerance[0, 0] == pytest.approx(120e-6, rel=1e-9)
    assert motion.combined[0, 0] == pytest.approx([-270e-6, 270e-6], rel=1e-9)
    # bottom dead centre too: the crank and the rod on one line again
    assert motion.phi[-1] == pytest.approx(math.pi)
    assert motion.clearance[-1, 0] == pytest.approx([-150e-6, 150e-6], rel=1e-9)


def test_clearance_column_is_the_envelope_at_each_position(slider_crank, motion):
    for k in (1, 2, 3):
        q = motion.configurations[k]
        env = envelope(slider_crank, "slider", q=q, kinds=("translation",))
        assert motion.clearance[k, 0] == pytest.approx(env.range([1, 0, 0]), rel=1e-9)
        assert motion.combined[k, 0, 1] == pytest.approx(
            motion.clearance[k, 0, 1] + motion.tolerance[k, 0], rel=1e-12
        )
    phi, widest = motion.largest("x4")
    assert widest == pytest.approx(np.max(np.abs(motion.combined[:, 0])), rel=1e-12)
    assert 0.0 <= phi <= math.pi


def test_exact_motion_envelope_is_second_order_close(slider_crank):
    result = motion_envelope(
        slider_crank, ["x4=slider.x"], positions=2, start=0.3, stop=1.2, clockwise=True, exact=True
    )
    assert result.combined_exact is not None
    difference = np.abs(result.combined_exact - result.combined)
    assert np.all(difference <= 1e-2 * np.abs(result.combined))


def test_contact_modes_come_in_opposite_pairs(slider_crank, motion):
    modes = contact_modes(
        slider_crank,
        "slider",
        configurations=motion.configurations[:3],
        phi=motion.phi[:3],
        directions=24,
        tolerances=False,
    )
    assert modes.mode.shape == (3, 24)
    assert np.allclose(modes.probabilities().sum(axis=1), 1.0)
    for k in range(3):
        for j in range(12):
            d, opposite = modes.directions[k, j], modes.directions[k, j + 12]
            assert np.allclose(d, -opposite, atol=1e-12)
            assert np.allclose(modes.deviations[k, j], -modes.deviations[k, j + 12], atol=1e-15)
            mine = modes.modes[modes.mode[k, j]]
            mirrored = tuple(sorted(_flip(label) for label in mine))
            assert modes.modes[modes.mode[k, j + 12]] == mirrored
    # the guide's side switches with the load: two modes, half the circle each
    assert len(modes.modes) == 2
    assert np.allclose(modes.probabilities(), 0.5)


def test_contact_modes_with_tolerances_stay_near_the_envelope(slider_crank):
    modes = contact_modes(slider_crank, "slider", mechanisms=2, directions=8, seed=4)
    top = envelope(slider_crank, "slider", kinds=("translation",)).max_translation.upper
    assert modes.mode.shape == (1, 16)
    assert np.any(modes.dimensions != 0.0)
    # a manufactured mechanism's envelope moves by the tolerances' share of the geometry
    assert np.all(np.linalg.norm(modes.deviations, axis=2) <= top * (1 + 1e-2))
    with pytest.raises(clearance_pin.ArgumentError, match="mechanisms"):
        contact_modes(slider_crank, "slider", mechanisms=0)


def _flip(label: str) -> str:
    """The same contact on the other side of its slab (a disc contact is its own mirror)."""
    if label.endswith("[+]"):
        return label[:-3] + "[-]"
    if label.endswith("[-]"):
        return label[:-3] + "[+]"
    return label
