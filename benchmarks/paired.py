r"""Paired timing of ours against prebuilt Clarabel: the two solve the same load one after the other.

On a shared machine the speed drifts by up to 2x within seconds, so two methods timed one after
the other over 200 loads each (work_precision.py) can see different machines. Here every load is
solved by ours and by the peer back to back, in alternating order (ours first on even loads), and
each load gives one ratio peer time / our time; the per-case figure is the median of those ratios,
the drift cancels in each pair. Timed per paper case:

Ours runs as a user writes it: default settings, and the load objects built inside each timed
call from the case's vectors (a planner builds its loads in its loop); the peer is given its
cost vector, as a prebuilt optimiser takes it.

- ``resolve``: ``mechanism.solve(loads)`` (warm start from the nearest recent answer) against
  ``peers.ClarabelPrebuilt(...).solve`` (built once with the case's load, ``update(q=...)``), at
  Clarabel's default tolerances and at 1e-12, and ``peers.QocoPrebuilt`` (built once,
  ``update_vector_data(c=...)``) at QOCO's defaults when QOCO is installed;
- ``resolver``: ``mechanism.resolver(loads).solve(vector)``, the planner's re-solve built once
  and given the new force and torque vectors (the like of the peer's ``update(q=...)``), against
  the same peers;
- ``cold``: ``mechanism.solve(loads, warm_start=False)`` against the same peers;
- ``batch``: ``mechanism.solve_many`` over the loads in a new random order against a loop of the
  peer over the same order, ``repeats`` times alternating, a ratio per repeat;
- ``arrays``: ``resolver.solve_many(vectors)`` (the same loads as one array (N, k, 3), no load
  object built) against the same loop of the peer, per case.

At the end one Markdown table gives per case the median time of ours, Clarabel built once (its
default tolerances and 1e-12), QOCO built once and the floor, with the ratios (peer / ours: above
1, ours is faster).

Beside them, the floor of each case (floor.py, in the same process after the pairs): Newton on
the KKT system of a known active set: the compiled kernel alone on one load
(``floor_compiled_us``: no Python around the step), NumPy on a stack of loads
(``floor_vectorised_us``, per load) and NumPy one load at a time (``floor_single_us``: each step a
Python call), the cost below which no re-solve of this algorithm goes.

The kernel is loaded first, as a planner does (``fast_path.load_kernel()``); the loads are
work_precision.py's (same seed, same perturbation). Errors are not measured here (see
work_precision.py: the same paths on the same loads).

Usage: ``python benchmarks/paired.py [--cases ID ...] [--loads N] [--json out/paired.json]``.
JSON: ``{"cases": {id: {"resolve": {peer: {"ratio_median", "ratio_p10", "ratio_p90", "ours_us",
"peer_us"}}, "resolver": ..., "cold": ..., "batch": ..., "arrays": ...}}, "worst": {path: {peer: worst median
ratio}},
"settings": ...}``.
"""

from __future__ import annotations

import argparse
import gc
import json
import time
import zlib
from pathlib import Path

import floor
import numpy as np
import peers
import work_precision as wp

from clearance_pin import PointForce, Torque
from clearance_pin.equilibrium import fast_path

# name: (the peer built once, its tolerance: None for its defaults); QOCO when installed (the
# peers extra) at its defaults only: at 1e-10 and below it ends SOLVED_INACCURATE (2e-8 mm off)
PEERS = {
    "clarabel_prebuilt_default": (peers.ClarabelPrebuilt, None),
    "clarabel_prebuilt": (peers.ClarabelPrebuilt, 1e-12),
    **({"qoco_prebuilt_default": (peers.QocoPrebuilt, None)} if peers.qoco_available() else {}),
}
PATHS = ("resolve", "resolver", "cold", "batch", "arrays")


def _pair(ours, peer, first_ours: bool) -> tuple[float, float]:
    """Wall times [s] of ``ours()`` and ``peer()`` run back to back, in the given order."""
    first, second = (ours, peer) if first_ours else (peer, ours)
    t0 = time.perf_counter()
    first()
    t1 = time.perf_counter()
    second()
    t2 = time.perf_counter()
    return (t1 - t0, t2 - t1) if first_ours else (t2 - t1, t1 - t0)


def _summary(ours: list[float], peer: list[float]) -> dict:
    ratios = np.array(peer) / np.array(ours)
    return {
        "ratio_median": float(np.median(ratios)),
        "ratio_p10": float(np.percentile(ratios, 10)),
        "ratio_p90": float(np.percentile(ratios, 90)),
        "ours_us": float(np.median(ours) * 1e6),
        "peer_us": float(np.median(peer) * 1e6),
        "pairs": len(ratios),
    }


def paired_case(case: wp.Case, repeats: int, seed: int) -> dict:
    """The four paired runs of one paper case (module docstring)."""
    mechanism, loads = case.mechanism, case.perturbed
    peer_loads = [wp.peer_load(x) for x in loads]
    nominal = wp.peer_load(case.nominal)
    resolver = mechanism.resolver(case.nominal)
    vectors = [wp.load_vector(x) for x in loads]
    nominal_vector = wp.load_vector(case.nominal)
    template = [load for load in loads[0] if isinstance(load, (PointForce, Torque))]

    def built(vector: np.ndarray) -> list:
        """The case's load objects from its vector (3 k,), as a planner builds them."""
        return [
            PointForce(load.link, vector[3 * k : 3 * k + 3], load.point)
            if isinstance(load, PointForce)
            else Torque(load.link, vector[3 * k : 3 * k + 3])
            for k, load in enumerate(template)
        ]

    calls = {  # path: (untimed call building the structure, a call per load)
        "resolve": (
            lambda: mechanism.solve(case.nominal),
            [lambda v=v: mechanism.solve(built(v)) for v in vectors],
        ),
        "resolver": (
            lambda: resolver.solve(nominal_vector),
            [lambda v=v: resolver.solve(v) for v in vectors],
        ),
        "cold": (
            lambda: mechanism.solve(case.nominal, warm_start=False),
            [lambda v=v: mechanism.solve(built(v), warm_start=False) for v in vectors],
        ),
    }
    array = np.array(vectors)

    def objects(order: np.ndarray) -> None:
        result = mechanism.solve_many([loads[i] for i in order], progress=False)
        for joint in case.joints:
            result.torsors(joint)

    def arrays(order: np.ndarray) -> None:
        result = resolver.solve_many(array[order], progress=False)
        for joint in case.joints:
            result.torsors(joint)

    out: dict = {path: {} for path in PATHS}
    for name, (peer, tol) in PEERS.items():
        prebuilt = peer(case.shaft, nominal, tol)
        prebuilt.solve(*nominal)
        for path, (build, ours) in calls.items():
            build()
            wp.forget_answers(mechanism)  # the pool holds no answer of these loads
            gc.collect()
            times: tuple[list[float], list[float]] = ([], [])
            for i, (call, peer_load) in enumerate(zip(ours, peer_loads)):
                pair = _pair(
                    call, lambda p=peer_load, solver=prebuilt: solver.solve(*p), i % 2 == 0
                )
                times[0].append(pair[0])
                times[1].append(pair[1])
            out[path][name] = _summary(*times)
        for path, ours in (("batch", objects), ("arrays", arrays)):
            out[path][name] = _batch_pairs(
                mechanism, ours, lambda i, p=prebuilt: p.solve(*peer_loads[i]), len(loads),
                repeats, seed,
            )  # fmt: skip
    out["floor"] = _floor(case)
    return out


def _batch_pairs(mechanism, ours, peer, count: int, repeats: int, seed: int) -> dict:
    """``ours(order)`` (a whole batch in a new random order) against ``peer(i)`` in a loop over
    the same order, ``repeats`` times alternating which runs first; per-case times."""
    rng = np.random.default_rng(seed)
    times: tuple[list[float], list[float]] = ([], [])
    for k in range(repeats):
        order = rng.permutation(count)
        wp.forget_answers(mechanism)
        gc.collect()

        def loop(order=order):
            for i in order:
                peer(i)

        pair = _pair(lambda order=order: ours(order), loop, k % 2 == 0)
        times[0].append(pair[0] / count)
        times[1].append(pair[1] / count)
    return _summary(*times)


def _floor(case: wp.Case) -> dict:
    """floor.py's single and vectorised Newton on a known active set of the case's loads
    (timings only: the answers are checked against references in work_precision.py)."""
    from clearance_pin.equilibrium.prepared import prepared_geometry

    mechanism = case.mechanism
    prepared = prepared_geometry(mechanism)
    resolved = [mechanism.resolve_loads(loads) for loads in case.perturbed]
    problems = [prepared.problem(loads) for loads in resolved]
    found = floor.floor_case(
        prepared,
        problems,
        prepared.problem(mechanism.resolve_loads(case.nominal)),
        lambda x: x,
        [None] * len(problems),
        peers.ReducedClarabel(1e-10),
        lambda vector, reference: (0.0, 0.0, 0.0),
        rows=2000,
        loads=resolved,
    )
    if not found.get("measured"):
        return {"measured": False}
    return {
        "measured": True,
        "floor_compiled_us": 1e6 * found["compiled_s"] if "compiled_s" in found else None,
        "floor_single_us": 1e6 * found["single_s"],
        "floor_vectorised_us": 1e6 * found["vectorised_per_load_s"],
        "loads_on_known_set": found["loads_on_known_set"],
    }


def markdown_table(results: dict) -> str:
    """One row per case: medians [us] of ours (re-solve, resolver, from arrays), of the peers
    built once and of the floor, and the ratios peer / ours of the re-solve (above 1: ours is
    faster)."""
    qoco = "qoco_prebuilt_default" in PEERS
    head = (
        "| case | ours solve | ours resolver | ours arrays /case | Clarabel once | "
        "Clarabel once 1e-12 | " + ("QOCO once | " if qoco else "") + "floor compiled | "
        "Clarabel / ours (solve, resolver, arrays) | " + ("QOCO / ours (solve) |" if qoco else "")
    )
    lines = [head, "|" + " --- |" * (head.count("|") - 1)]
    for case_id, row in results.items():
        default, tight = (
            row["resolve"]["clarabel_prebuilt_default"],
            row["resolve"]["clarabel_prebuilt"],
        )
        floor_row = row["floor"]
        compiled = floor_row.get("floor_compiled_us") if floor_row.get("measured") else None
        cells = [
            case_id,
            f"{default['ours_us']:.0f}",
            f"{row['resolver']['clarabel_prebuilt_default']['ours_us']:.0f}",
            f"{row['arrays']['clarabel_prebuilt_default']['ours_us']:.1f}",
            f"{default['peer_us']:.0f}",
            f"{tight['peer_us']:.0f}",
        ]
        if qoco:
            cells.append(f"{row['resolve']['qoco_prebuilt_default']['peer_us']:.0f}")
        cells.append("-" if compiled is None else f"{compiled:.1f}")
        cells.append(
            ", ".join(
                f"{row[path]['clarabel_prebuilt_default']['ratio_median']:.2f}"
                for path in ("resolve", "resolver", "arrays")
            )
        )
        if qoco:
            cells.append(f"{row['resolve']['qoco_prebuilt_default']['ratio_median']:.2f}")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", nargs="*", help="paper case ids (default: all)")
    parser.add_argument("--loads", type=int, default=200, help="loads per case")
    parser.add_argument("--repeats", type=int, default=7, help="batch repeats per peer")
    parser.add_argument("--json", type=Path, help="write the results to this JSON file")
    args = parser.parse_args(argv)
    settings = wp.RunSettings()
    fast_path.load_kernel()
    results = {}
    for case in wp.load_cases(args.cases):
        if case.shaft is None:  # the bundled models have no prebuilt peer
            continue
        rng = np.random.default_rng([settings.seed, zlib.crc32(case.id.encode())])
        case.nominal = tuple(
            load for load in case.mechanism.loads if isinstance(load, (PointForce, Torque))
        )
        case.perturbed = wp.perturbed_loads(case.mechanism, args.loads, settings.perturbation, rng)
        results[case.id] = paired_case(case, args.repeats, settings.seed + 1)
        row = results[case.id]
        floor_row = row["floor"]
        floor_text = "; floor not measured"
        if floor_row.get("measured"):
            compiled = floor_row["floor_compiled_us"]
            floor_text = (
                f"; floor {'-' if compiled is None else f'{compiled:.1f}'} us compiled, "
                f"{floor_row['floor_vectorised_us']:.2f} us vectorised NumPy, "
                f"{floor_row['floor_single_us']:.0f} us NumPy one by one"
            )
        print(
            f"{case.id}: "
            + "; ".join(
                f"{path} {row[path]['clarabel_prebuilt_default']['ratio_median']:.2f} / "
                f"{row[path]['clarabel_prebuilt']['ratio_median']:.2f} "
                f"({row[path]['clarabel_prebuilt_default']['ours_us']:.0f} us ours)"
                for path in PATHS
            )
            + floor_text,
            flush=True,
        )
    worst = {
        path: {name: min(r[path][name]["ratio_median"] for r in results.values()) for name in PEERS}
        for path in PATHS
    }
    print("worst median ratio over the cases (peer / ours, default tol / 1e-12):")
    for path, row in worst.items():
        print(f"  {path}: {row['clarabel_prebuilt_default']:.2f} / {row['clarabel_prebuilt']:.2f}")
    print()
    print(markdown_table(results))
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        document = {"cases": results, "worst": worst, "settings": vars(args) | {"json": None}}
        args.json.write_text(json.dumps(document, indent=1))
        print(f"wrote {args.json}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
