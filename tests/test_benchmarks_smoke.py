"""Smoke test of the benchmarks: each runs on one small case with few repetitions and writes JSON
of the documented shape (benchmarks/README.md). Timings are not checked, only that they exist."""

from __future__ import annotations

import importlib.util
import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
BENCHMARKS = ROOT / "benchmarks"

pytest.importorskip("clarabel")
pytest.importorskip("cvxpy")
pytest.importorskip("scipy")


def _run_script(script, arguments: list[str]) -> int:
    """Run benchmarks/<script>.py with ``arguments`` in a fresh interpreter; its exit code."""
    name = script.__file__ if hasattr(script, "__file__") else str(script)
    completed = subprocess.run([sys.executable, name, *arguments], check=False, timeout=600)
    return completed.returncode


def _module(name: str):
    """Import benchmarks/<name>.py (a script directory, not a package)."""
    if str(BENCHMARKS) not in sys.path:
        sys.path.insert(0, str(BENCHMARKS))
    spec = importlib.util.spec_from_file_location(f"benchmark_{name}", BENCHMARKS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up while the class is built
    spec.loader.exec_module(module)
    return module


def test_work_precision_json_shape(tmp_path):
    """One paper case, 4 loads: every method of ours and every peer reports a positive median time,
    a finite error and its peer flag under cases/<id>/<method>; the ratio table has every pair;
    the floor of the case and a short run of the 6R arm (10 trajectory points, 40 load cases)
    report times and errors against the closed form."""
    pytest.importorskip("matplotlib")  # --plots
    work_precision = _module("work_precision")
    out = tmp_path / "wp.json"
    code = _run_script(  # in its own process: the benchmarks set process-wide state
        work_precision,
        [
            "--quick",
            "--cases",
            "6.1.6.1a",
            "--loads",
            "4",
            "--budget",
            "0",
            "--json",
            str(out),
            "--plots",
            str(tmp_path),
            "--arms",
            "arm_6r",
            "--arm-points",
            "10",
            "--arm-loads",
            "40",
        ],
    )
    assert code == 0
    document = json.loads(out.read_text())
    methods = document["cases"]["6.1.6.1a"]
    ours = set(work_precision.OURS)
    theirs = set(work_precision.peers.PEERS)
    assert set(methods) == ours | theirs
    for name, entry in methods.items():
        assert entry["peer"] is (name in theirs)
        assert isinstance(entry["median_s"], float) and entry["median_s"] > 0.0
        assert isinstance(entry["error_mm"], float) and math.isfinite(entry["error_mm"])
        assert entry["sweep"], name
    # the linear paths reproduce the published reference values of this case
    for name in ("clearance_pin_default", "clearance_pin_resolve", "clearance_pin_ipopt"):
        assert methods[name]["error_nominal_mm"] < 1e-9
    ratios = document["ratios"]["6.1.6.1a"]
    assert set(ratios) == ours and all(set(row) == theirs for row in ratios.values())
    assert set(document["ratio_ranges"]["peers"]) <= ours
    floor = document["floor"]["6.1.6.1a"]
    if floor["measured"]:
        assert floor["single_s"] > 0.0 and floor["vectorised_per_load_s"] > 0.0
        assert floor["error_mm"] < 1e-9
    arm = document["arms"]["arm_6r"]
    for run in ("trajectory", "loads"):
        for path in ("solve_many", "solve_loop", "clarabel_prebuilt", "clarabel_prebuilt_default"):
            entry = arm[run][path]
            assert math.isfinite(entry["error_rel_play"]), (run, path)
            if not path.startswith("clarabel"):  # ours: verified, and on the closed form
                assert entry["ok"] > 0 and entry["error_rel_play"] < 1e-9, (run, path)
    assert arm["trajectory"]["points"] == 10 and arm["loads"]["solve_many"]["cases"] == 40
    assert (tmp_path / "work_precision.png").stat().st_size > 0


def test_scaling_json_shape(tmp_path):
    """Two sizes of two generated families: times, memory and a fitted exponent per family."""
    scaling = _module("scaling")
    out = tmp_path / "scaling.json"
    code = _run_script(
        scaling,
        [
            "--quick",
            "--sizes",
            "1",
            "8",
            "--families",
            "planar_chain",
            "four_bar_ladder",
            "--exact-max",
            "1",
            "--json",
            str(out),
            "--no-plots",
        ],
    )
    assert code == 0
    document = json.loads(out.read_text())
    assert set(document["families"]) == {"planar_chain", "four_bar_ladder"}
    for family in document["families"].values():
        assert len(family["points"]) == 2
        for point in family["points"]:
            assert point["cold_s"] > 0.0 and point["resolve_s"] > 0.0
            assert point["tracemalloc_peak_bytes"] > 0
            assert point["batch_ok"] == 16
        assert isinstance(family["exponents_all_sizes"]["cold_s"], float)


def test_paired_json_shape(tmp_path):
    """One paper case, 6 loads, 2 batch repeats: per path and peer a median ratio and both
    medians, positive, and the worst ratio over the cases."""
    paired = _module("paired")
    out = tmp_path / "paired.json"
    arguments = ["--cases", "6.1.6.1a", "--loads", "6", "--repeats", "2", "--json", str(out)]
    assert _run_script(paired, arguments) == 0
    document = json.loads(out.read_text())
    row = document["cases"]["6.1.6.1a"]
    for path in ("resolve", "resolver", "cold", "batch"):
        for peer in ("clarabel_prebuilt_default", "clarabel_prebuilt"):
            entry = row[path][peer]
            assert entry["ratio_median"] > 0.0 and entry["ours_us"] > 0.0 and entry["peer_us"] > 0.0
            assert document["worst"][path][peer] == entry["ratio_median"]


@pytest.mark.parametrize("builder", ["planar_chain", "revolute_chain", "four_bar_ladder"])
def test_generated_models_load_and_solve(builder):
    """The generated scaling models are valid model files with a verified equilibrium."""
    import clearance_pin

    scaling = _module("scaling")
    mechanism = clearance_pin.loads(getattr(scaling, builder)(3), source=builder)
    equilibrium = mechanism.solve()
    assert equilibrium.ok and equilibrium.active_contacts
