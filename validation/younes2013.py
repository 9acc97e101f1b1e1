"""Reproduce every numerical case of section 6 of Younes, Dal Santo & Potiron with both formulations.

Source: M. Younes, P. Dal Santo, A. Potiron, "Three-dimensional study for the relative positioning
of mechanical elements in mechanisms constituted by parallel joints with clearances" (section 6).
Inputs: validation/younes2013_cases.toml (SI). The paper's units (mm, rad, N mm) are used only at
this script's edge: the printed table and the JSON.

Usage:
    python validation/younes2013.py [--json FILE] [--check]

JSON (contract of the shared case file): {"cases": {id: {"linear": {...}, "exact": {...}}}} with
"T1", "T2" (u, v, w [mm], alpha, beta, gamma [rad]), "energy" [N mm], "contacts" (names
``joint:point``: ``I1:ball`` the ball centre on its sphere, ``I2:end-`` / ``I2:end+`` the journal
axis end at x = centre -/+ L/2 on the bore, ``I2:axial`` a revolute's axial stop), "solve_time_s".
Exit status 1 if a case with reference values is off by more than 1e-9 mm or 1e-11 rad.
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
from clearance_pin.model.builders import JointSpec, shaft_urdf

MM = 1e3
TOLERANCE_MM = 1e-9
TOLERANCE_RAD = 1e-11


def build(case: dict):
    """The case's mechanism, from its SI inputs."""
    joints = [
        JointSpec(
            j["name"],
            j["kind"],
            tuple(j["center_m"]),
            j["diametral_clearance_m"],
            j.get("length_m", 0.0),
            tuple(j.get("axis", (1.0, 0.0, 0.0))),
        )
        for j in case["joint"]
    ]
    load = case["load"]
    text = shaft_urdf(
        joints[0], joints[1], load["point_m"], load["force_N"], load["torque_Nm"], name=case["id"]
    )
    return clearance_pin.loads(text, source=f"younes2013 case {case['id']}")


def to_paper_units(torsor: np.ndarray) -> list[float]:
    """(u, v, w) m -> mm; rotations stay in rad."""
    return [float(v * MM) for v in torsor[:3]] + [float(v) for v in torsor[3:]]


def summary(equilibrium, seconds: float) -> dict:
    """The JSON record of one formulation of one case."""
    return {
        "T1": to_paper_units(equilibrium.torsor("I1")),
        "T2": to_paper_units(equilibrium.torsor("I2")),
        "energy": equilibrium.energy * MM,
        "contacts": [c.label for c in equilibrium.active_contacts],
        "solve_time_s": seconds,
        "ok": equilibrium.ok,
        "residuals": equilibrium.residuals.to_dict(),
    }


def matching_digits(computed: float, published: float) -> int:
    """Number of leading significant digits on which two values agree (16 if equal)."""
    if computed == published:
        return 16
    scale = max(abs(published), abs(computed))
    if scale < 1e-12:
        return 16 if abs(computed - published) < 1e-12 else 0
    return max(0, math.floor(-math.log10(abs(computed - published) / scale)))


def solve_case(case: dict, check: bool) -> dict:
    mechanism = build(case)
    record = {}
    started = time.perf_counter()
    linear = mechanism.solve()
    linear_time = time.perf_counter() - started
    started = time.perf_counter()
    exact = mechanism.solve(exact=True)
    exact_time = time.perf_counter() - started  # includes the linear solve that seeds it
    record["linear"] = summary(linear, linear_time)
    record["exact"] = summary(exact, exact_time)
    if check:
        for name, eq in (("linear", linear), ("exact", exact)):
            record[name]["check"] = eq.check(pose="as_solved").to_dict(length=MM)
    record["exact_minus_linear"] = {
        "translation_mm": exact.difference["torsor_translation_m"] * MM,
        "rotation_rad": exact.difference["torsor_rotation_rad"],
    }
    return record


def largest_departure(check: dict) -> float:
    """Largest |coal distance - model gap| over every point of a check's JSON [its length unit]."""
    worst = 0.0
    for joint in check["joints"].values():
        gaps = next(v for k, v in joint.items() if k.startswith("model_gap"))
        readings = next(v for k, v in joint.items() if k.startswith("coal_distance"))
        worst = max([worst, *(abs(r - g) for r, g in zip(readings, gaps))])
    return worst


def compare(case: dict, record: dict) -> list[str]:
    """Lines of the published-vs-computed table, and failures (prefixed with FAIL)."""
    lines = []
    expected = case.get("expected_mm")
    lin = record["linear"]
    for joint in ("T1", "T2"):
        computed = lin[joint]
        lines.append(f"  {joint} linear  " + " ".join(f"{v:+.10f}" for v in computed))
        if expected:
            lines.append(f"  {joint} ref     " + " ".join(f"{v:+.10f}" for v in expected[joint]))
            paper = expected[f"paper_{joint}"]
            digits = [
                matching_digits(c, p) if abs(p) > 1e-200 else 0 for c, p in zip(computed, paper)
            ]
            lines.append(
                f"  {joint} paper   "
                + " ".join(f"{v:+.10g}" for v in paper)
                + f"   digits: {digits}"
            )
            error_mm = max(abs(c - e) for c, e in zip(computed[:3], expected[joint][:3]))
            error_rad = max(abs(c - e) for c, e in zip(computed[3:], expected[joint][3:]))
            verdict = "ok" if error_mm <= TOLERANCE_MM and error_rad <= TOLERANCE_RAD else "FAIL"
            lines.append(f"  {joint} error   {error_mm:.2e} mm, {error_rad:.2e} rad  {verdict}")
        lines.append(f"  {joint} exact   " + " ".join(f"{v:+.10f}" for v in record["exact"][joint]))
    energy = f"  energy linear {lin['energy']:.12f} N mm, exact {record['exact']['energy']:.12f}"
    if expected:
        energy += f", ref {expected['energy']:.12f}"
    lines.append(energy)
    lines.append(
        f"  contacts {lin['contacts']}  exact - linear: "
        f"{record['exact_minus_linear']['translation_mm']:.3e} mm, "
        f"{record['exact_minus_linear']['rotation_rad']:.3e} rad"
    )
    lines.append(
        f"  solve {lin['solve_time_s'] * 1e3:.2f} ms (linear, incl. first build), "
        f"{record['exact']['solve_time_s'] * 1e3:.2f} ms (exact, incl. build)"
    )
    if "check" in lin:
        exact_check = record["exact"]["check"]
        lines.append(
            f"  coal check: exact ok={exact_check['ok']} "
            f"(check {exact_check.get('check_time_s', float('nan')) * 1e6:.0f} us); linear ok="
            f"{lin['check']['ok']}, its pose is {largest_departure(lin['check']):.3e} mm off "
            "the real boundaries (the small-displacement model's own error)"
        )
    return lines


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", type=Path, help="write the results to this JSON file")
    parser.add_argument("--check", action="store_true", help="also run the coal geometry check")
    parser.add_argument("--cases", type=Path, default=HERE / "younes2013_cases.toml")
    args = parser.parse_args(argv)
    cases = tomllib.loads(args.cases.read_text())["case"]
    results, failures = {}, 0
    for case in cases:
        record = solve_case(case, args.check)
        results[case["id"]] = record
        print(f"case {case['id']}: {case['section']}")
        lines = compare(case, record)
        failures += sum("FAIL" in line for line in lines)
        print("\n".join(lines))
    if args.json:
        args.json.write_text(json.dumps({"cases": results}, indent=2))
        print(f"wrote {args.json}")
    print(f"{len(cases)} cases, {failures} failures against the reference values")
    return 1 if failures else 0


if __name__ == "__main__":
    raise SystemExit(main())
