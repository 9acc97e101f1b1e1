"""A tolerance sweep against a spec (issue 24): contributors ranked by their share of the worst
band, pass or fail, and the share of manufactured mechanisms out of spec. References: the
slider-crank's closed-form sensitivities (x4 = r2 cos phi + sqrt(r3^2 - r2^2 sin^2 phi),
differentiated here) and a first-order sampling written here, not the library's closure."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

import clearance_pin as cp
from clearance_pin.cli import main
from clearance_pin.tolerance.spec import contributors, parse_spec, verdict
from clearance_pin.tolerance.sweep import sweep

MODEL = Path(__file__).resolve().parent.parent / "models" / "slider_crank.urdf"


def test_contributors_are_each_dimension_s_largest_share_of_the_worst_band():
    """d x4 / d r2 = cos phi - r2 sin^2 phi / w, d x4 / d r3 = r3 / w, w = sqrt(r3^2 - r2^2
    sin^2 phi): over 0 .. 360 deg the shares |S| T/2 are largest at phi = 0 (r2: 1 x T/2) and at
    phi = 90 deg (r3: r3 / sqrt(r3^2 - r2^2) x T/2)."""
    mechanism = cp.load(MODEL)
    half = {d.name: d.half_tolerance for d in mechanism.dimensions}
    r2, r3 = (d.nominal for d in mechanism.dimensions)
    result = sweep(mechanism, ["slider.x"], positions=25)
    ranked = {c.dimension: c for c in contributors(result, 0)}
    assert ranked["r2"].share == pytest.approx(half["r2"], rel=1e-9)
    assert result.phi[ranked["r2"].position] == pytest.approx(0.0, abs=1e-12)
    lever = r3 / math.sqrt(r3**2 - r2**2)
    assert ranked["r3"].share == pytest.approx(lever * half["r3"], rel=1e-9)
    assert math.degrees(result.phi[ranked["r3"].position]) % 180 == pytest.approx(90.0)
    band = result.worst[ranked["r3"].position, 0]
    assert ranked["r3"].fraction == pytest.approx(lever * half["r3"] / band, rel=1e-9)


def test_the_monte_carlo_share_out_of_spec_matches_a_first_order_sampling():
    """At phi = 40 deg, a limit at 70 % of the worst band: the share of uniform samples beyond it
    against the same count of sum_j S_j d_j with d_j uniform in +/- T_j/2 (first order, drawn
    here), to 4 binomial standard deviations."""
    mechanism = cp.load(MODEL)
    phi = math.radians(40.0)
    probe = sweep(mechanism, ["slider.x"], positions=1, start=phi, stop=phi)
    limit = 0.7 * probe.worst[0, 0]
    samples = 20_000
    result = sweep(mechanism, ["slider.x"], positions=1, start=phi, stop=phi, samples=samples,
                   limits=[limit])  # fmt: skip
    judged = verdict(result, 0, limit)
    half = np.array([d.half_tolerance for d in mechanism.dimensions])
    draws = np.random.default_rng(7).uniform(-1.0, 1.0, (400_000, half.size)) * half
    expected = float(np.mean(np.abs(draws @ result.matrix[0, 0]) > limit))
    spread = 4.0 * math.sqrt(expected * (1.0 - expected) / samples) + 1e-3
    assert judged.uniform_share == pytest.approx(expected, abs=spread)
    assert not judged.worst_case_passes and judged.rss_passes == (result.rss[0, 0] <= limit)


def test_spec_on_the_command_line_passes_or_fails_with_its_exit_status(tmp_path, capsys):
    """The worst band of x4 peaks at 120.21 um (Flores): 130 um passes (exit 0), 100 um fails
    (exit 1, 'out of tolerance'); the JSON carries the verdict and the ranked contributors."""
    common = ["tolerance", str(MODEL), "--samples", "200", "--positions", "13"]
    out = tmp_path / "spec.json"
    assert main([*common, "--spec", "slider.x=130um", "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "spec slider.x: |deviation| <= 130 um: worst case PASS" in text
    assert "what moves slider.x most" in text
    document = json.loads(out.read_text())
    entry = document["outputs"]["slider.x"]
    assert entry["spec"]["limit_m"] == pytest.approx(130e-6)
    assert entry["spec"]["worst_case_passes"] is True
    assert [c["dimension"] for c in entry["contributors"]] == ["r3", "r2"]
    picture = tmp_path / "spec.png"
    assert main([*common, "--spec", "slider.x=0.1mm", "--plot", str(picture)]) == 1
    assert "worst case FAIL" in capsys.readouterr().out
    if pytest.importorskip("matplotlib"):  # the bands, the limits and the histogram beside
        assert picture.stat().st_size > 20_000


@pytest.mark.parametrize(
    "text, message",
    [
        ("slider.x", "NAME=LIMIT"),
        ("x4=50um", "unknown output 'x4'"),
        ("slider.x=50furlong", "a unit of"),
        ("slider.x=0.1deg", "in m units"),
        ("slider.x=-5um", "a finite limit > 0"),
    ],
)
def test_a_bad_spec_is_named(text, message):
    from clearance_pin.tolerance.sensitivity import parse_output

    outputs = (parse_output(cp.load(MODEL).model, "slider.x"),)
    with pytest.raises(cp.ClearancePinError, match=message):
        parse_spec(text, outputs)
