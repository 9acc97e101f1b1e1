"""Reproduce the tolerance example of Flores (2011): published values beside ours.

Source: P. Flores, "A methodology for quantifying the kinematic position errors due to
manufacturing and assembly tolerances", Strojniski vestnik - J. Mech. Eng. (2011) [F].
Inputs: validation/flores2011_case.toml (SI). The in-line slider-crank (crank r2 = 50 mm,
rod r3 = 120 mm, +/- 50 um and +/- 70 um, IT10) is built from those numbers as a model file
with two ``<dimension>`` elements; the sensitivities come from Pinocchio's frame Jacobians
(:mod:`clearance_pin.tolerance.sensitivity`), the bands from
:mod:`clearance_pin.tolerance.statistics`, the Monte Carlo runs close the loop exactly for every
sample (:mod:`clearance_pin.tolerance.monte_carlo`). Micrometres appear only at this edge.

Usage:
    python validation/flores2011.py [--json FILE] [--samples N] [--seed S]

JSON: exactly the contract of the shared case file (SI units unless a key says ``_um``):
{"slider_crank": {"phi_deg", "x4", "theta3", "dx4_dr2", "dx4_dr3", "dtheta3_dr2",
"dtheta3_dr3", "x4_worst", "x4_rss", "theta3_worst", "theta3_rss" (25 each), "x4_worst_max",
"x4_rss_max", "x4_worst_max_phi_deg", "x4_rss_max_phi_deg", "mc_normal_x4_3sigma",
"mc_uniform_x4_maxabs" (25 each), "mc_samples"}, "gamma": {"p", "gamma"}, "example":
{"gamma_it10_admissible_55um", "rss_it9_um", "gamma_it9_admissible_55um"}, "iso286_um":
{"ranges_mm", "IT01", ..., "IT18"}}.
Exit status 1 if a published value is not reproduced to the digits the paper prints, or a Monte
Carlo check fails.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
import tomllib
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

import clearance_pin
from clearance_pin.tolerance import (
    GRADES,
    ISO286_RANGES_MM,
    gamma_for_admissible,
    gamma_from_confidence,
    rss_band,
    sampling_error_of_3sigma,
    table_um,
    tolerance_m,
)
from clearance_pin.tolerance.monte_carlo import BatchClosure, exact_worst_case, monte_carlo
from clearance_pin.tolerance.sweep import cycle_maximum, sweep

UM = 1e6


def slider_crank_urdf(case: dict) -> str:
    """Model file of the in-line slider-crank at top dead centre, with its two dimensions."""
    r2, r3 = case["r2"], case["r3"]
    return f"""<?xml version="1.0"?>
<robot name="flores2011_slider_crank">
  <link name="ground"/><link name="crank"/><link name="rod"/><link name="slider"/><link name="guide"/>
  <joint name="crank_pivot" type="continuous">
    <parent link="ground"/><child link="crank"/><axis xyz="0 0 1"/></joint>
  <joint name="pin_A" type="continuous">
    <parent link="crank"/><child link="rod"/><origin xyz="{r2!r} 0 0"/><axis xyz="0 0 1"/></joint>
  <joint name="pin_B" type="continuous">
    <parent link="rod"/><child link="slider"/><origin xyz="{r3!r} 0 0"/><axis xyz="0 0 1"/></joint>
  <joint name="guide_mount" type="fixed"><parent link="ground"/><child link="guide"/></joint>
  <clearance_pin>
    <joint name="crank_pivot" driven="true" q="0"/>
    <loop_joint name="slide" type="prismatic" frame_a="guide" frame_b="slider"
                radial_clearance="0" length="0.04" axis="1 0 0"/>
    <dimension name="r2" joint="pin_A" direction="1 0 0" half_tolerance="{case["half_tolerance_r2"]!r}"/>
    <dimension name="r3" joint="pin_B" direction="1 0 0" half_tolerance="{case["half_tolerance_r3"]!r}"/>
  </clearance_pin>
</robot>
"""


def compute(inputs: dict, samples: int, seed: int) -> tuple[dict, dict]:
    """The JSON document of the contract, and extra numbers for the printed report."""
    case = inputs["slider_crank"]
    mechanism = clearance_pin.loads(slider_crank_urdf(case), source="flores2011 slider-crank")
    outputs = [f"{name}={spec}" for name, spec in case["outputs"].items()]
    positions = int(case["positions"])
    stop = math.radians(case["step_deg"] * (positions - 1))
    started = time.perf_counter()
    result = sweep(mechanism, outputs, positions=positions, stop=stop, clockwise=True)
    sweep_seconds = time.perf_counter() - started
    x4, theta3 = result.index("x4"), result.index("theta3")
    r2, r3 = (result.dimensions[0], result.dimensions[1])
    if (r2.name, r3.name) != ("r2", "r3"):
        raise RuntimeError("the model's dimensions must be r2 and r3, in that order")

    started = time.perf_counter()
    fine = sweep(mechanism, result.outputs, result.joint, 361, 0.0, stop, True)
    worst_max, worst_phi = cycle_maximum(mechanism, result, "x4", "worst", fine=fine)
    rss_max, rss_phi = cycle_maximum(mechanism, result, "x4", "rss", fine=fine)
    maxima_seconds = time.perf_counter() - started

    started = time.perf_counter()
    normal, uniform, exact = [], [], []
    for k, q in enumerate(result.configurations):
        closure = BatchClosure(mechanism, result.outputs, q)
        for runs, law in ((normal, "normal"), (uniform, "uniform")):
            runs.append(
                monte_carlo(
                    mechanism,
                    None,
                    samples=samples,
                    distribution=law,
                    seed=seed + k,
                    closure=closure,
                )
            )
        exact.append(exact_worst_case(mechanism, None, closure=closure))
    mc_seconds = time.perf_counter() - started

    p = inputs["confidence"]["p"]
    example = inputs["example"]
    admissible = example["admissible_half_um"] / UM
    tdc = result.matrix[0, x4]  # (dx4/dr2, dx4/dr3) at top dead centre
    rss_it10 = float(rss_band(tdc, [r2.half_tolerance, r3.half_tolerance]))
    half_it9 = np.array([tolerance_m(example["grade_tighter"], d.nominal) / 2 for d in (r2, r3)])
    rss_it9 = float(rss_band(tdc, half_it9))
    table = table_um()
    document = {
        "slider_crank": {
            "phi_deg": [case["step_deg"] * k for k in range(positions)],
            "x4": result.values[:, x4].tolist(),
            "theta3": result.values[:, theta3].tolist(),
            "dx4_dr2": result.matrix[:, x4, 0].tolist(),
            "dx4_dr3": result.matrix[:, x4, 1].tolist(),
            "dtheta3_dr2": result.matrix[:, theta3, 0].tolist(),
            "dtheta3_dr3": result.matrix[:, theta3, 1].tolist(),
            "x4_worst": result.worst[:, x4].tolist(),
            "x4_rss": result.rss[:, x4].tolist(),
            "theta3_worst": result.worst[:, theta3].tolist(),
            "theta3_rss": result.rss[:, theta3].tolist(),
            "x4_worst_max": worst_max,
            "x4_rss_max": rss_max,
            "x4_worst_max_phi_deg": _first_half_deg(worst_phi),
            "x4_rss_max_phi_deg": _first_half_deg(rss_phi),
            "mc_normal_x4_3sigma": [float(r.three_sigma[x4]) for r in normal],
            "mc_uniform_x4_maxabs": [float(r.max_abs[x4]) for r in uniform],
            "mc_samples": int(samples),
        },
        "gamma": {"p": list(p), "gamma": [gamma_from_confidence(v) for v in p]},
        "example": {
            "gamma_it10_admissible_55um": gamma_for_admissible(admissible, rss_it10),
            "rss_it9_um": rss_it9 * UM,
            "gamma_it9_admissible_55um": gamma_for_admissible(admissible, rss_it9),
        },
        "iso286_um": {
            "ranges_mm": [[_number(lo), _number(hi)] for lo, hi in ISO286_RANGES_MM],
            **{grade: [_number(v) for v in table[grade]] for grade in GRADES},
        },
    }
    extra = {
        "exact_x4": [(w.lower[x4], w.upper[x4]) for w in exact],
        "exact_theta3": [(w.lower[theta3], w.upper[theta3]) for w in exact],
        "half_it9": half_it9,
        "rss_it10": rss_it10,
        "sweep_s": sweep_seconds,
        "maxima_s": maxima_seconds,
        "mc_s": mc_seconds,
        "dimensions": (r2, r3),
    }
    return document, extra


def _first_half_deg(phi: float) -> float:
    """Angle [deg] folded into the first half-cycle (the in-line slider-crank is symmetric)."""
    degrees = math.degrees(phi) % 360.0
    return 360.0 - degrees if degrees > 180.0 else degrees


def _number(v: float):
    return int(v) if float(v).is_integer() else float(v)


def report(inputs: dict, document: dict, extra: dict) -> int:
    """Print published vs computed values; returns the number of failed checks."""
    case, sc = inputs["slider_crank"], document["slider_crank"]
    published = case["published"]
    failures = 0

    def line(label: str, paper, ours, ok: bool | None = None) -> None:
        nonlocal failures
        mark = "" if ok is None else ("  ok" if ok else "  DIFFERS")
        failures += ok is False
        print(f"  {label:<46} {paper!s:>16} {ours!s:>22}{mark}")

    r2, r3 = extra["dimensions"]
    print("Flores (2011), in-line slider-crank: r2 = 50 mm +/- 50 um, r3 = 120 mm +/- 70 um (IT10)")
    print(
        f"  ISO 286 check: IT10 at 50 mm -> +/- {tolerance_m(case['grade'], r2.nominal) / 2 * UM:g} "
        f"um, at 120 mm -> +/- {tolerance_m(case['grade'], r3.nominal) / 2 * UM:g} um"
    )
    print()
    print(f"  {'quantity':<46} {'published':>16} {'computed':>22}")
    line(
        "x4 at TDC [mm]",
        published["x4_tdc_m"] * 1e3,
        f"{sc['x4'][0] * 1e3:.9f}",
        abs(sc["x4"][0] - published["x4_tdc_m"]) < 1e-12,
    )
    line(
        "dx4/dr2, dx4/dr3 at TDC [-]",
        "1, 1",
        f"{sc['dx4_dr2'][0]:.12f}, {sc['dx4_dr3'][0]:.12f}",
        abs(sc["dx4_dr2"][0] - 1) < 1e-9 and abs(sc["dx4_dr3"][0] - 1) < 1e-9,
    )
    line(
        "dx4/dr2, dx4/dr3 at BDC [-]",
        "-1, 1",
        f"{sc['dx4_dr2'][12]:.12f}, {sc['dx4_dr3'][12]:.12f}",
        abs(sc["dx4_dr2"][12] + 1) < 1e-9 and abs(sc["dx4_dr3"][12] - 1) < 1e-9,
    )
    for label, key, k in (
        ("x4 worst band at TDC [um]", "x4_worst_tdc_um", 0),
        ("x4 worst band at BDC [um]", "x4_worst_tdc_um", 12),
    ):
        line(
            label,
            published[key],
            f"{sc['x4_worst'][k] * UM:.6f}",
            abs(sc["x4_worst"][k] * UM - published[key]) < 5e-3,
        )
    for label, k in (("x4 RSS band at TDC [um]", 0), ("x4 RSS band at BDC [um]", 12)):
        line(
            label,
            published["x4_rss_tdc_um"],
            f"{sc['x4_rss'][k] * UM:.6f}",
            abs(sc["x4_rss"][k] * UM - published["x4_rss_tdc_um"]) < 5e-3,
        )
    line(
        "theta3 worst band at TDC [urad]",
        published["theta3_worst_tdc_um"],
        f"{sc['theta3_worst'][0] * UM:.3g}",
        abs(sc["theta3_worst"][0]) < 1e-9,
    )
    line(
        "max x4 worst band over the cycle [um]",
        "-",
        f"{sc['x4_worst_max'] * UM:.6f} @ {sc['x4_worst_max_phi_deg']:.4f} deg",
    )
    line(
        "max x4 RSS band over the cycle [um]",
        "-",
        f"{sc['x4_rss_max'] * UM:.6f} @ {sc['x4_rss_max_phi_deg']:.4f} deg",
    )
    print()
    print("  gamma (two-sided normal quantile), computed:")
    for p, paper, ours in zip(
        document["gamma"]["p"], inputs["confidence"]["published_gamma"], document["gamma"]["gamma"]
    ):
        line(f"gamma at p = {p:.1%}", paper, f"{ours:.6f}", abs(ours - paper) < 0.01)
    example = document["example"]
    pub = inputs["example"]
    line(
        "gamma, IT10, admissible +/- 55 um",
        pub["published_gamma_it10"],
        f"{example['gamma_it10_admissible_55um']:.6f}",
        round(example["gamma_it10_admissible_55um"], 2) == pub["published_gamma_it10"],
    )
    half_it9 = extra["half_it9"] * UM
    line(
        "IT9 half tolerances [um]",
        ", ".join(f"{v:g}" for v in pub["published_it9_half_um"]),
        ", ".join(f"{v:g}" for v in half_it9),
        all(abs(a - b) <= 0.5 for a, b in zip(half_it9, pub["published_it9_half_um"])),
    )
    rounded = math.hypot(*pub["published_it9_half_um"])
    line(
        f"RSS band with IT9 [um] (paper's 31, 44 -> {rounded:.2f})",
        pub["published_rss_it9_um"],
        f"{example['rss_it9_um']:.6f}",
        round(rounded) == pub["published_rss_it9_um"]
        and abs(example["rss_it9_um"] - pub["published_rss_it9_um"]) < 1.0,
    )
    line("gamma, IT9, admissible +/- 55 um", "-", f"{example['gamma_it9_admissible_55um']:.6f}")
    print()

    n = sc["mc_samples"]
    error = sampling_error_of_3sigma(n) if n > 1 else math.inf
    print(
        f"  Monte Carlo, {n} samples per position and law, loop closed exactly per sample; "
        f"exact worst case by optimisation over the box"
    )
    print(
        f"  {'phi':>5} {'x4 [mm]':>10} {'dx4/dr2':>9} {'dx4/dr3':>9} {'worst':>8} {'exact':>8} "
        f"{'MC max':>8} {'RSS':>8} {'MC 3s':>8} {'z':>6} {'th3 worst':>10} {'th3 exact':>10}"
    )
    mc_ok = True
    for k, phi in enumerate(sc["phi_deg"]):
        low, high = extra["exact_x4"][k]
        exact_half = max(abs(low), abs(high))
        z = (sc["mc_normal_x4_3sigma"][k] / sc["x4_rss"][k] - 1.0) / error
        inside = sc["mc_uniform_x4_maxabs"][k] <= exact_half * (1 + 1e-12)
        mc_ok &= inside and abs(z) < 4.5
        t_low, t_high = extra["exact_theta3"][k]
        print(
            f"  {phi:5.0f} {sc['x4'][k] * 1e3:10.5f} {sc['dx4_dr2'][k]:9.5f} "
            f"{sc['dx4_dr3'][k]:9.5f} {sc['x4_worst'][k] * UM:8.3f} {exact_half * UM:8.3f} "
            f"{sc['mc_uniform_x4_maxabs'][k] * UM:8.3f} {sc['x4_rss'][k] * UM:8.3f} "
            f"{sc['mc_normal_x4_3sigma'][k] * UM:8.3f} {z:6.2f} "
            f"{sc['theta3_worst'][k] * UM:10.3f} {max(abs(t_low), abs(t_high)) * UM:10.3f}"
        )
    print(
        f"  (bands in um and urad; z = (MC 3s / RSS - 1) / sampling error "
        f"{error:.2e}; uniform samples inside the exact worst case: "
        f"{'yes' if mc_ok else 'NO'})"
    )
    failures += not mc_ok
    print(
        f"  times: sweep {extra['sweep_s']:.3f} s, maxima {extra['maxima_s']:.2f} s, "
        f"Monte Carlo + exact worst case {extra['mc_s']:.2f} s"
    )
    return failures


def main(argv: list[str] | None = None) -> int:
    """Run the validation; returns the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", type=Path, help="write the results (JSON contract) to FILE")
    parser.add_argument(
        "--samples",
        type=int,
        default=200_000,
        help="Monte Carlo samples per position and law (default 200000)",
    )
    parser.add_argument("--seed", type=int, default=2011, help="Monte Carlo seed")
    args = parser.parse_args(argv)
    inputs = tomllib.loads((HERE / "flores2011_case.toml").read_text())
    document, extra = compute(inputs, args.samples, args.seed)
    failures = report(inputs, document, extra)
    if args.json:
        args.json.write_text(json.dumps(document, indent=1))
        print(f"JSON written to {args.json}")
    return 1 if failures else 0


if __name__ == "__main__":
    raise SystemExit(main())
