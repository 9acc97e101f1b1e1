"""exact='auto': the estimate of exact - linear at the outputs decides whether the exact runs."""

from __future__ import annotations

import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

import clearance_pin as cp
from clearance_pin.equilibrium.second_order import boundary_errors

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "validation"))
from younes2013 import build  # noqa: E402

CASES = {
    c["id"]: c
    for c in tomllib.loads((ROOT / "validation" / "younes2013_cases.toml").read_text())["case"]
}


@pytest.mark.parametrize("case_id", sorted(CASES))
def test_estimate_does_not_underestimate_the_exact_difference(case_id):
    """On every paper case the estimate at each output is at least the true |exact - linear|
    difference there (the exact model is an independent CasADi solve)."""
    mechanism = build(CASES[case_id])
    auto = mechanism.solve(exact="auto", accuracy=1.0)  # never runs exact: the estimate alone
    assert auto.formulation == "linear"
    exact = mechanism.solve(exact=True)
    for name, (translation, _) in exact.difference["outputs"].items():
        assert auto.difference_bound["outputs"][name][0] >= np.linalg.norm(translation)


def test_auto_runs_exact_for_large_play_and_says_why():
    """6.1.6.1b (3 mm spherical play): the linear answer is micrometres off, auto runs exact."""
    result = build(CASES["6.1.6.1b"]).solve(exact="auto", accuracy=1e-9)
    assert result.formulation == "exact"
    assert "exact model run" in result.note and result.ok


def test_auto_keeps_linear_for_pure_translation():
    """6.2.2 (pure translation): the linear model is exact, auto keeps it and says so."""
    result = build(CASES["6.2.2"]).solve(exact="auto", accuracy=1e-9)
    assert result.formulation == "linear"
    assert "kept" in result.note
    # the estimate is the verification floor, 1e-9 of the 0.15 mm play
    assert result.residuals["second_order_m"] <= 1e-9 * 1.5e-4 * 1.01


def test_exact_solution_sits_on_the_boundary():
    """The exact model's contacts sit on the true boundaries (errors at round-off)."""
    exact = build(CASES["6.1.6.1b"]).solve(exact=True)
    assert max(boundary_errors(exact).values()) < 1e-14
    assert max(boundary_errors(exact.linear).values()) > 1e-7  # the linear one is micrometres off


def test_flat_optimum_reported_and_minimum_norm():
    """The 6R arm's radially loaded journals leave axial plays unloaded: reported, and set to 0."""
    arm = cp.load(ROOT / "models" / "arm_6r.urdf")
    result = arm.solve()
    flat = [m for m in result.free_motions if m.startswith("bounded but not loaded")]
    assert any("'wrist_1' u" in m for m in flat)
    assert abs(result.torsor("wrist_1")[0]) < 1e-15  # round-off of a 5 um play
    cold = arm.solve(warm_start=False)
    assert abs(cold.torsor("wrist_1")[0]) < 1e-15
