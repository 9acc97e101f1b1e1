"""Tests of clearance_pin.tolerance.monte_carlo: batched exact closure, Monte Carlo, exact
worst case."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import clearance_pin
from clearance_pin.errors import ClearancePinError, SolverError
from clearance_pin.tolerance import sampling_error_of_3sigma
from clearance_pin.tolerance.dimensions import with_deviations
from clearance_pin.tolerance.monte_carlo import BatchClosure, exact_worst_case, monte_carlo
from clearance_pin.tolerance.sensitivity import output_deviations
from clearance_pin.tolerance.sweep import closed_configuration, driven_joint

MODELS = Path(__file__).resolve().parent.parent / "models"
R2, R3, H2, H3 = 0.050, 0.120, 50e-6, 70e-6
OFFSET = '<dimension name="e" joint="guide_mount" direction="0 1 0" tolerance="2e-4"/>'


@pytest.fixture(scope="module")
def slider_crank():
    return clearance_pin.load(MODELS / "slider_crank.urdf")


@pytest.fixture(scope="module")
def offset_crank():
    """The slider-crank with a toleranced offset of the guide (a fixed joint), +/- 100 um."""
    text = (MODELS / "slider_crank.urdf").read_text()
    return clearance_pin.loads(
        text.replace("</clearance_pin>", OFFSET + "</clearance_pin>"), source="slider_crank+e"
    )


def at_phi(mechanism, phi_deg: float) -> np.ndarray:
    return closed_configuration(
        mechanism, driven_joint(mechanism), -math.radians(phi_deg), mechanism.configure().q
    )


def exact_by_close_loops(mechanism, q, outputs, dd: np.ndarray) -> np.ndarray:
    """Reference: the perturbed pin.Model re-closed by clearance_pin.kinematics.closure."""
    moved = with_deviations(mechanism, dd)
    return output_deviations(mechanism.model, q, moved.model, moved.configure(q).q, outputs)


@pytest.mark.parametrize("phi", [0.0, 50.0, 135.0, 290.0])
def test_batch_closure_equals_close_loops(offset_crank, phi):
    """For large deviations (mm), the batched Newton closure gives the same outputs as
    close_loops on the perturbed model (1e-12 m, 1e-11 rad)."""
    q = at_phi(offset_crank, phi)
    closure = BatchClosure(offset_crank, ["slider.x", "rod.rz", "pin_B"], q)
    rng = np.random.default_rng(7)
    dd = rng.uniform(-1.0, 1.0, (4, 3)) * np.array([2e-3, 3e-3, 4e-3])
    batch = closure.solve(dd)
    for k in range(len(dd)):
        reference = exact_by_close_loops(offset_crank, closure.q, closure.outputs, dd[k])
        assert np.allclose(batch[k], reference, atol=1e-11)


def test_batch_closure_four_bar_with_angle_dimension():
    """A four-bar (loop joint between two fixed-joint frames) with lengths, an angle on the
    coupler and a transverse offset: batch closure equals close_loops."""
    text = (
        (MODELS / "four_bar.urdf")
        .read_text()
        .replace(
            "</clearance_pin>",
            """
      <dimension name="crank" joint="pin_A" direction="1 0 0" tolerance="1e-4"/>
      <dimension name="coupler" joint="coupler_B_mount" direction="1 0 0" tolerance="1e-4"/>
      <dimension name="bend" joint="pin_A" rotation_axis="0 0 1" tolerance="1e-3"/>
      <dimension name="base" joint="rocker_pivot" direction="0.6 0.8 0" tolerance="1e-4"/>
    </clearance_pin>""",
        )
    )
    mechanism = clearance_pin.loads(text, source="four_bar+dims")
    closure = BatchClosure(mechanism, ["coupler.x", "coupler.y", "rocker.rz", "pin_A"])
    dd = np.random.default_rng(3).uniform(-1.0, 1.0, (4, 4)) * np.array([1e-3, 1e-3, 1e-2, 1e-3])
    batch = closure.solve(dd)
    for k in range(len(dd)):
        reference = exact_by_close_loops(mechanism, closure.q, closure.outputs, dd[k])
        assert np.allclose(batch[k], reference, atol=1e-11)


def test_batch_closure_matches_the_slider_crank_formula(slider_crank):
    """Independent check: x4 and theta3 of 2000 manufactured slider-cranks from the closed form
    x4 = r2 cos t2 + sqrt(r3^2 - r2^2 sin^2 t2), sin t3 = -r2 sin t2 / r3 (1e-13)."""
    phi = 70.0
    closure = BatchClosure(slider_crank, ["slider.x", "rod.rz"], at_phi(slider_crank, phi))
    dd = np.random.default_rng(11).uniform(-1.0, 1.0, (2000, 2)) * np.array([H2, H3])
    batch = closure.solve(dd, chunk=512)
    t2 = -math.radians(phi)
    r2, r3 = R2 + dd[:, 0], R3 + dd[:, 1]
    x4 = r2 * np.cos(t2) + np.sqrt(r3**2 - (r2 * np.sin(t2)) ** 2)
    x4_0 = R2 * np.cos(t2) + math.sqrt(R3**2 - (R2 * math.sin(t2)) ** 2)
    t3 = -np.arcsin(r2 * np.sin(t2) / r3)
    t3_0 = -math.asin(R2 * math.sin(t2) / R3)
    assert np.allclose(batch[:, 0], x4 - x4_0, atol=1e-14)
    assert np.allclose(batch[:, 1], t3 - t3_0, atol=1e-13)


def test_double_pendulum_open_chain():
    """Without loops the batch kinematics is plain forward kinematics: equals the perturbed
    model's frames, angle dimension included."""
    mechanism = clearance_pin.load(MODELS / "double_pendulum.urdf")
    closure = BatchClosure(mechanism, ["tip.x", "tip.y", "tip.rz"])
    dd = np.array([[1e-3, -2e-3, 1e-2], [-5e-4, 0.0, -3e-2]])
    batch = closure.solve(dd)
    for k in range(2):
        assert np.allclose(
            batch[k], exact_by_close_loops(mechanism, closure.q, closure.outputs, dd[k]), atol=1e-14
        )


@pytest.mark.parametrize("phi", [0.0, 90.0, 150.0])
def test_worst_case_bounds_every_uniform_sample(offset_crank, phi):
    """The exact worst case over the tolerance box bounds every uniform Monte Carlo sample
    (seed 1, 20000 samples), for every output."""
    closure = BatchClosure(offset_crank, ["slider.x", "rod.rz"], at_phi(offset_crank, phi))
    worst = exact_worst_case(offset_crank, None, closure=closure)
    run = monte_carlo(
        offset_crank, None, samples=20_000, distribution="uniform", seed=1, closure=closure
    )
    assert np.all(run.minimum >= worst.lower - 1e-15)
    assert np.all(run.maximum <= worst.upper + 1e-15)
    # and the linear worst case is close to the exact one (second-order difference)
    assert np.allclose(worst.half_band, worst.linear, rtol=2e-3)


def test_exact_worst_case_finds_an_interior_optimum(offset_crank):
    """At TDC x4 = r2 + sqrt(r3^2 - e^2): its maximum over the box has the offset e = 0
    (interior), its minimum e = +/- 100 um; the projected Newton finds both exactly."""
    closure = BatchClosure(offset_crank, ["slider.x"], at_phi(offset_crank, 0.0))
    worst = exact_worst_case(offset_crank, None, closure=closure)
    assert worst.upper[0] == pytest.approx(H2 + H3, abs=1e-13)
    assert abs(worst.argmax[0, 2]) < 1e-7
    low = (R2 - H2) + math.sqrt((R3 - H3) ** 2 - 1e-4**2) - R2 - R3
    assert worst.lower[0] == pytest.approx(low, abs=1e-13)
    assert abs(worst.argmin[0, 2]) == pytest.approx(1e-4)
    # a dense grid of the box never beats it
    grid = np.linspace(-1.0, 1.0, 21)
    box = np.array(np.meshgrid(grid, grid, grid)).reshape(3, -1).T * np.array([H2, H3, 1e-4])
    values = closure.solve(box)[:, 0]
    assert values.max() <= worst.upper[0] + 1e-16 and values.min() >= worst.lower[0] - 1e-16


@pytest.mark.parametrize("phi", [0.0, 60.0, 120.0])
def test_rss_matches_normal_monte_carlo(slider_crank, phi):
    """With sigma_j = T_j/6 the sample 3 s of the exact outputs matches the RSS band within 4
    sampling errors (statistics.sampling_error_of_3sigma), seed 2, 40000 samples."""
    closure = BatchClosure(slider_crank, ["slider.x", "rod.rz"], at_phi(slider_crank, phi))
    n = 40_000
    run = monte_carlo(slider_crank, None, samples=n, distribution="normal", seed=2, closure=closure)
    rss = closure.linear.rss()
    error = sampling_error_of_3sigma(n)
    for i in range(2):
        if rss[i] > 1e-12:
            assert abs(run.three_sigma[i] / rss[i] - 1.0) < 4 * error
        else:
            assert run.three_sigma[i] < 1e-12
    assert np.all(np.abs(run.mean) < 4 * run.std / math.sqrt(n) + 1e-15)


def test_monte_carlo_is_reproducible(slider_crank):
    """The same seed gives the same statistics, whatever the number of threads; another seed
    differs."""
    closure = BatchClosure(slider_crank, ["slider.x"])
    a = monte_carlo(slider_crank, None, samples=3000, seed=5, closure=closure, chunk=700, workers=1)
    b = monte_carlo(slider_crank, None, samples=3000, seed=5, closure=closure, chunk=700, workers=3)
    c = monte_carlo(slider_crank, None, samples=3000, seed=6, closure=closure, chunk=700)
    assert np.array_equal(a.std, b.std) and np.array_equal(a.maximum, b.maximum)
    assert not np.array_equal(a.std, c.std)
    assert a.samples == 3000 and a.points.shape == (2000, 1) and a.distribution == "uniform"


def test_impossible_deviation_raises(slider_crank):
    """A rod shorter than the crank's reach cannot close at 90 deg: SolverError, not garbage."""
    closure = BatchClosure(slider_crank, ["slider.x"], at_phi(slider_crank, 90.0))
    with pytest.raises(SolverError):
        closure.solve(np.array([[0.0, -0.08]]))
    with pytest.raises(ClearancePinError, match="shape"):
        closure.solve(np.zeros((3, 5)))


def test_progress_bar_on_request(slider_crank, capsys):
    """progress=True draws a bar on stderr; by default (not a terminal) nothing is drawn."""
    closure = BatchClosure(slider_crank, ["slider.x"])
    monte_carlo(slider_crank, None, samples=2000, closure=closure, progress=True, chunk=500)
    assert "Monte Carlo" in capsys.readouterr().err
    monte_carlo(slider_crank, None, samples=2000, closure=closure)
    assert capsys.readouterr().err == ""
