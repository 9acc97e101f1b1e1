"""Tests of the Flores (2011) validation, the sweep over the crank cycle and the CLI command."""

from __future__ import annotations

import json
import math
import runpy
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

import clearance_pin
from clearance_pin.cli import main as cli_main
from clearance_pin.errors import ClearancePinError
from clearance_pin.tolerance import sampling_error_of_3sigma
from clearance_pin.tolerance.command import default_outputs
from clearance_pin.tolerance.sweep import clearance_budget, plot_sweep, sweep

ROOT = Path(__file__).resolve().parent.parent
CASE = tomllib.loads((ROOT / "validation" / "flores2011_case.toml").read_text())
SAMPLES = 4000
CONTRACT = {
    "slider_crank": {
        "phi_deg",
        "x4",
        "theta3",
        "dx4_dr2",
        "dx4_dr3",
        "dtheta3_dr2",
        "dtheta3_dr3",
        "x4_worst",
        "x4_rss",
        "theta3_worst",
        "theta3_rss",
        "x4_worst_max",
        "x4_rss_max",
        "x4_worst_max_phi_deg",
        "x4_rss_max_phi_deg",
        "mc_normal_x4_3sigma",
        "mc_uniform_x4_maxabs",
        "mc_samples",
    },
    "gamma": {"p", "gamma"},
    "example": {"gamma_it10_admissible_55um", "rss_it9_um", "gamma_it9_admissible_55um"},
}


@pytest.fixture(scope="module")
def document(tmp_path_factory):
    """The validation script run once, with a small Monte Carlo."""
    path = tmp_path_factory.mktemp("flores") / "flores.json"
    namespace = runpy.run_path(str(ROOT / "validation" / "flores2011.py"))
    status = namespace["main"](["--json", str(path), "--samples", str(SAMPLES), "--seed", "3"])
    assert status == 0
    return json.loads(path.read_text())


def test_json_is_exactly_the_contract(document):
    """The JSON has exactly the keys of the contract, 25 positions, 13 ISO ranges per grade."""
    assert set(document) == {*CONTRACT, "iso286_um"}
    for key, keys in CONTRACT.items():
        assert set(document[key]) == keys
    sc = document["slider_crank"]
    for key, value in sc.items():
        if isinstance(value, list):
            assert len(value) == 25, key
    assert sc["phi_deg"] == [15.0 * k for k in range(25)]
    assert sc["mc_samples"] == SAMPLES
    iso = document["iso286_um"]
    assert len(iso) == 21 and iso["ranges_mm"][5] == [30, 50]
    assert all(len(v) == 13 for v in iso.values())


def test_published_values(document):
    """Flores's numbers: x4 = 170 mm at TDC, both sensitivities 1, bands 120 um and
    sqrt(50^2 + 70^2) = 86.0233 um at both dead centres, theta3 band 0, gammas, example."""
    sc = document["slider_crank"]
    published = CASE["slider_crank"]["published"]
    assert sc["x4"][0] == pytest.approx(published["x4_tdc_m"], abs=1e-15)
    for k, sign in ((0, 1.0), (12, -1.0), (24, 1.0)):
        assert sc["dx4_dr2"][k] == pytest.approx(sign, abs=1e-12)
        assert sc["dx4_dr3"][k] == pytest.approx(1.0, abs=1e-12)
        assert sc["x4_worst"][k] == pytest.approx(120e-6, abs=1e-15)
        assert sc["x4_rss"][k] == pytest.approx(86.0233e-6, abs=1e-10)
        assert sc["theta3"][k] == pytest.approx(0.0, abs=1e-12)
        assert sc["theta3_worst"][k] == pytest.approx(0.0, abs=1e-12)
    gamma = dict(zip(document["gamma"]["p"], document["gamma"]["gamma"]))
    assert gamma[0.95] == pytest.approx(1.959964, abs=1e-6)
    for p, paper in zip(CASE["confidence"]["p"], CASE["confidence"]["published_gamma"]):
        assert abs(gamma[p] - paper) < 0.01
    example = document["example"]
    assert example["gamma_it10_admissible_55um"] == pytest.approx(3 * 55 / 86.0233, abs=1e-4)
    assert round(example["gamma_it10_admissible_55um"], 2) == 1.92
    assert example["rss_it9_um"] == pytest.approx(math.hypot(31.0, 43.5), abs=1e-9)
    assert example["gamma_it9_admissible_55um"] == pytest.approx(165 / math.hypot(31, 43.5))
    iso = document["iso286_um"]
    assert (iso["IT10"][5], iso["IT10"][8], iso["IT9"][5], iso["IT9"][8]) == (100, 160, 62, 100)
    assert iso["IT10"][7] == 140 and iso["IT9"][7] == 87  # 120 mm is in (80, 120]


def _closed_form_bands(phi: np.ndarray, h2: float, h3: float):
    t2 = -phi
    s = np.sqrt(0.12**2 - (0.05 * np.sin(t2)) ** 2)
    d2 = np.cos(t2) - 0.05 * np.sin(t2) ** 2 / s
    d3 = 0.12 / s
    return h2 * np.abs(d2) + h3 * np.abs(d3), np.hypot(h2 * d2, h3 * d3)


def test_cycle_maxima_match_the_closed_form(document):
    """The maxima of the x4 bands over the continuous cycle and where they occur agree with
    a dense search on the closed-form sensitivities (refined with scipy)."""
    from scipy.optimize import minimize_scalar

    sc = document["slider_crank"]
    phi = np.linspace(0.0, math.pi, 200_001)
    for index, key in ((0, "x4_worst"), (1, "x4_rss")):
        values = _closed_form_bands(phi, 50e-6, 70e-6)[index]
        k = int(np.argmax(values))

        def negative(a, index=index):
            return -_closed_form_bands(np.array([a]), 50e-6, 70e-6)[index][0]

        best = minimize_scalar(
            negative, bounds=(phi[k - 1], phi[k + 1]), method="bounded", options={"xatol": 1e-12}
        )
        assert sc[f"{key}_max"] == pytest.approx(-best.fun, rel=1e-12)
        assert sc[f"{key}_max_phi_deg"] == pytest.approx(math.degrees(best.x), abs=1e-4)
    assert sc["x4_worst_max"] > 120e-6  # the maximum is not at a dead centre
    assert 90.0 < sc["x4_worst_max_phi_deg"] < 180.0


def test_monte_carlo_agrees(document):
    """Normal MC 3 s matches the RSS band within 4.5 sampling errors at every position; the
    largest uniform deviation stays under the worst-case band plus its second-order excess."""
    sc = document["slider_crank"]
    error = sampling_error_of_3sigma(SAMPLES)
    ratio = np.array(sc["mc_normal_x4_3sigma"]) / np.array(sc["x4_rss"])
    assert np.all(np.abs(ratio - 1.0) < 4.5 * error)
    assert np.all(np.array(sc["mc_uniform_x4_maxabs"]) <= np.array(sc["x4_worst"]) * (1 + 1e-3))
    assert np.all(np.array(sc["mc_uniform_x4_maxabs"]) > 0.9 * np.array(sc["x4_worst"]))


def test_sweep_budget_and_plot(tmp_path):
    """The sweep of the bundled model (crank from its nominal 60 deg to the cycle), the
    clearance budget of the equilibrium engine beside the bands, and the PNG plot."""
    mechanism = clearance_pin.load(ROOT / "models" / "slider_crank.urdf")
    result = sweep(
        mechanism,
        ["x4=slider.x", "theta3=rod.rz"],
        positions=5,
        stop=math.pi,
        clockwise=True,
        samples=500,
        exact=True,
    )
    assert result.values[0, 0] == pytest.approx(0.170) and result.values[-1, 0] == pytest.approx(
        0.07
    )
    assert result.worst[0, 0] == pytest.approx(120e-6)
    budget = clearance_budget(mechanism, result, "x4")
    # the gas force pushes the slider towards the crank: at TDC through three pins in line with
    # 50 um radial play each (the rod's side load tilts the contacts a little); mid-stroke the
    # inclined rod adds the transverse play
    assert np.all(budget.clearance < 0) and np.all(np.abs(budget.clearance) < 400e-6)
    assert 140e-6 < -budget.clearance[0] <= 150e-6
    assert np.allclose(budget.total_worst, np.abs(budget.clearance) + result.worst[:, 0])
    pytest.importorskip("matplotlib")  # the plot (the extra clearance_pin[plot])
    path = tmp_path / "bands.png"
    plot_sweep(result, path, budget, title="test")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_plot_without_matplotlib_names_the_extra(tmp_path, monkeypatch):
    """Without matplotlib the plot raises ClearancePinError naming pip install clearance_pin[plot]."""
    mechanism = clearance_pin.load(ROOT / "models" / "slider_crank.urdf")
    result = sweep(mechanism, ["slider.x"], positions=2, stop=math.pi, clockwise=True)
    monkeypatch.setitem(sys.modules, "matplotlib", None)
    with pytest.raises(ClearancePinError, match=r"pip install clearance_pin\[plot\]"):
        plot_sweep(result, tmp_path / "x.png")


def test_command_writes_table_plot_and_json(tmp_path, capsys):
    """clearance-pin tolerance prints the table and writes the plot and the JSON (SI)."""
    pytest.importorskip("matplotlib")  # --plot needs the extra clearance_pin[plot]
    png, out = tmp_path / "b.png", tmp_path / "b.json"
    status = cli_main(
        [
            "tolerance",
            str(ROOT / "models" / "slider_crank.urdf"),
            "--clockwise",
            "--output",
            "x4=slider.x",
            "--output",
            "theta3=rod.rz",
            "--positions",
            "7",
            "--stop",
            "180",
            "--samples",
            "300",
            "--exact",
            "--budget",
            "x4",
            "--plot",
            str(png),
            "--json",
            str(out),
        ]
    )
    assert status == 0
    text = capsys.readouterr().out
    assert "max worst band over the cycle" in text and "S_r2" in text
    document = json.loads(out.read_text())
    x4 = document["outputs"]["x4"]
    assert x4["worst_m"][0] == pytest.approx(120e-6)
    assert x4["worst_max_m"] == pytest.approx(120.21025e-6, rel=1e-6)
    assert {"mc_uniform_max_abs_m", "exact_upper_m", "clearance_deviation_m"} <= set(x4)
    assert png.exists()


def test_command_errors_and_defaults(capsys):
    """Default outputs are the moved coordinates of the leaf links; a model with two driven
    joints needs --joint; a model without dimensions is an error (exit status 2)."""
    slider = clearance_pin.load(ROOT / "models" / "slider_crank.urdf")
    assert [o.name for o in default_outputs(slider)] == ["slider.x"]
    pendulum = clearance_pin.load(ROOT / "models" / "double_pendulum.urdf")
    assert [o.name for o in default_outputs(pendulum)] == ["tip.x", "tip.y", "tip.rz"]
    status = cli_main(
        [
            "tolerance",
            str(ROOT / "models" / "double_pendulum.urdf"),
            "--samples",
            "0",
            "--positions",
            "3",
            "--no-maxima",
        ]
    )
    assert status == 2 and "driven joints" in capsys.readouterr().err
    status = cli_main(
        [
            "tolerance",
            str(ROOT / "models" / "double_pendulum.urdf"),
            "--joint",
            "elbow",
            "--samples",
            "0",
            "--positions",
            "3",
            "--no-maxima",
        ]
    )
    assert status == 0 and "tip.x" in capsys.readouterr().out
    status = cli_main(["tolerance", str(ROOT / "models" / "four_bar.urdf")])
    assert status == 2 and "no <dimension>" in capsys.readouterr().err
