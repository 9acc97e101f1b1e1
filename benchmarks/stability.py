"""Numerical stability stress run: random mechanisms, scale sweep, degenerate cases, fuzzing.

The full version of the CI tests tests/test_random_mechanisms.py, tests/test_stability.py and
tests/test_fuzz_model_file.py (which it imports), with many more examples::

    python benchmarks/stability.py --json stability.json            # 2000 mechanisms, 2000 fuzz inputs
    python benchmarks/stability.py --examples 200 --fuzz 200        # a quick look

Metrics (written with ``--json``):

- ``random_mechanisms``: random mechanisms judged against the independent oracle
  (tests/oracle.py); ``max_rel_error``: the largest relative error among those that agree
  (energy, torsors in loaded directions relative to the largest clearance, penetration, statics);
  ``details.random_outcomes``: every verdict kind (``FAIL-*`` are disagreements, ``known-*``,
  ``no-work-*`` and ``ambiguous-closure`` are known library issues, ``diagnosed`` is a SolverError,
  ``refused-load`` a LoadError for loads beyond double precision (hypothesis draws subnormals);
  ``agree-flat`` / ``agree-certified`` include answers that the oracle could not match to 1e-8 in
  energy but verified by a KKT certificate in its own formulation, tests/test_corpus_oracle.py);
- ``scale_sweep``: per clearance/length ratio, the largest relative error of the closed forms (both
  formulations) and of the paper cases (oracle and homogeneity);
- ``degenerate_cases`` / ``degenerate_diagnosed``: degenerate mechanisms run, and how many were
  answered by a diagnosis (an error or a conditioning warning) rather than a verified answer;
  ``details.degenerate_wrong`` counts wrong answers (must be 0);
- ``fuzzed_inputs`` / ``unhandled_exceptions``: model-file texts fed to ``clearance_pin.loads`` (and
  solved when they load), and how many let a non-ClearancePinError escape (known issues included;
  ``details.fuzz_outcomes`` splits them).

Limitations: the oracle solves the same small-displacement model (a different formulation and
solver, not a different physics); cases the oracle cannot polish are judged on energy only.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

TESTS = Path(__file__).resolve().parent.parent / "tests"
sys.path.insert(0, str(TESTS))

import test_fuzz_model_file as fuzz
import test_stability as stability
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import seed as hypothesis_seed
from hypothesis import strategies as st
from mechanism_strategies import mechanisms
from oracle import Oracle, bounded_loads, judge

import clearance_pin

ERROR_KEYS = ("energy", "violation", "torsor_report", "statics", "library_statics")


def random_mechanisms(examples: int, seed: int) -> dict:
    """Judge ``examples`` random mechanisms; outcome counts, worst agreeing error, failures."""
    outcomes: dict[str, int] = {}
    failures: list[dict] = []
    worst = {"value": 0.0, "spec": None}

    @hypothesis_seed(seed)
    @settings(
        max_examples=examples,
        deadline=None,
        database=None,
        phases=[Phase.generate],
        suppress_health_check=list(HealthCheck),
    )
    @given(spec=mechanisms(), project=st.integers(0, 3).map(bool))
    def run(spec, project):
        try:
            mechanism = clearance_pin.loads(spec.urdf())
            loads = mechanism.resolve_loads(None, None)
            if project:
                loads = bounded_loads(Oracle(mechanism), loads)
            verdict = judge(mechanism, loads)
            kind = verdict.kind
        except Exception as exc:
            kind, verdict = f"EXCEPTION {type(exc).__name__}", None
        outcomes[kind] = outcomes.get(kind, 0) + 1
        if kind in ("agree", "agree-flat", "agree-energy", "agree-certified"):
            errors = [verdict.errors[k] for k in ERROR_KEYS]
            if kind == "agree":
                errors.append(verdict.errors["torsor"])
            if max(errors) > worst["value"]:
                worst.update(value=float(max(errors)), spec=repr(spec), project=project)
        if kind.startswith(("FAIL", "EXCEPTION")) and len(failures) < 20:
            failures.append(
                {
                    "kind": kind,
                    "spec": repr(spec),
                    "project": project,
                    "detail": verdict.detail if verdict else "",
                }
            )

    run()
    return {
        "count": examples,
        "outcomes": dict(sorted(outcomes.items())),
        "worst": worst,
        "failures": failures,
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--json", type=Path, help="write the figures to this file")
    parser.add_argument("--examples", type=int, default=2000, help="random mechanisms")
    parser.add_argument("--fuzz", type=int, default=500, help="inputs per fuzz strategy (x4)")
    parser.add_argument("--seed", type=int, default=20261122)
    args = parser.parse_args(argv)
    times = {}

    started = time.perf_counter()
    random = random_mechanisms(args.examples, args.seed)
    times["random_mechanisms_s"] = time.perf_counter() - started
    print(f"random mechanisms: {random['count']} in {times['random_mechanisms_s']:.0f} s")
    for kind, count in random["outcomes"].items():
        print(f"  {kind:<28}{count:>6}")
    print(f"  worst relative error among agreeing cases: {random['worst']['value']:.2e}")

    started = time.perf_counter()
    sweep = stability.scale_sweep()
    times["scale_sweep_s"] = time.perf_counter() - started
    print("scale sweep (closed forms, both formulations; paper cases vs oracle and homogeneity):")
    for row in sweep:
        print(f"  c/L = {row['ratio']:.0e}: max relative error {row['max_rel_error']:.2e}")
    units = {
        path.stem: stability.unit_change_error(path.read_text(), 1e3) for path in stability.MODELS
    }
    lengths = {
        f"{factor:g}": stability.unit_change_error(
            stability.paper_case_text(stability.CASES["6.1.6.1a"]), factor
        )
        for factor in (1e-6, 1e-3, 1e1)
    }
    print(
        f"  m vs mm (bundled models): max {max(units.values()):.2e}; "
        f"um..10 m: max {max(lengths.values()):.2e}"
    )

    started = time.perf_counter()
    catalogue = stability.degenerate_catalogue()
    toggle = stability.toggle_sweep()
    angles = stability.angle_sweep()
    agreement = {path.stem: stability.agreement_figures(path) for path in stability.MODELS}
    times["degenerate_s"] = time.perf_counter() - started
    diagnosed = sum(1 for _, kind in catalogue if kind == "diagnosed")
    wrong = [name for name, kind in catalogue if kind == "WRONG"]
    print(f"degenerate cases: {len(catalogue)}, diagnosed {diagnosed}, wrong {len(wrong)} {wrong}")
    for angle, kind, value in angles:
        print(f"  force {angle:.0e} rad towards a free slide: {kind} ({value:.2e})")
    for row in toggle:
        print(
            f"  four-bar {row['delta']:.0e} rad from toggle: {row['outcome']}, conditioning "
            f"{row.get('conditioning', float('nan')):.1e}, warning {row['warning']}, "
            f"largest rotation {row.get('max_rotation_rad', float('nan')):.2e} rad"
        )
    worst_agreement = {
        key: max(a[key] for a in agreement.values())
        for key in ("warm_vs_cold", "batch_vs_single", "repeated")
    }
    print(f"  agreement (relative to the largest clearance): {worst_agreement}")

    started = time.perf_counter()
    counts = fuzz.fuzz_counts(args.fuzz, args.seed)
    times["fuzz_s"] = time.perf_counter() - started
    inputs = sum(counts.values())
    unhandled = sum(n for k, n in counts.items() if k.startswith(("UNHANDLED", "known")))
    print(f"fuzzed inputs: {inputs}, unhandled exceptions: {unhandled}")
    for kind, count in sorted(counts.items()):
        print(f"  {kind:<80}{count:>6}")

    agreeing = sum(n for k, n in random["outcomes"].items() if k.startswith("agree"))
    figures = {
        "random_mechanisms": random["count"],
        "max_rel_error": random["worst"]["value"],
        "scale_sweep": sweep,
        "degenerate_cases": len(catalogue),
        "degenerate_diagnosed": diagnosed,
        "fuzzed_inputs": inputs,
        "unhandled_exceptions": unhandled,
        "details": {
            "random_outcomes": random["outcomes"],
            "random_agreeing": agreeing,
            "random_worst_case": random["worst"],
            "random_failures": random["failures"],
            "units_m_vs_mm": units,
            "lengths_um_to_10m": lengths,
            "degenerate": [{"case": name, "outcome": kind} for name, kind in catalogue],
            "degenerate_wrong": len(wrong),
            "toggle": toggle,
            "angle_sweep": [{"angle_rad": a, "outcome": k, "value": v} for a, k, v in angles],
            "agreement": agreement,
            "fuzz_outcomes": counts,
            "times_s": times,
        },
    }
    if args.json:
        args.json.write_text(json.dumps(figures, indent=2, default=float))
        print(f"written {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
