"""Memory benchmark (issue 21, item 9): what a read trajectory and a long chain keep.

Each figure is measured in a fresh interpreter (this script run again with ``--child``):

- ``trajectory``: bytes per point held after a trajectory of the 6R arm (models/arm_6r.urdf,
  every joint swept by 1 mrad per point) is solved by ``solve_many`` and every point's torsor,
  tool displacement and ``ok`` are read (tracemalloc, after a warm-up batch); and the bytes per
  point when the caller keeps every answer;
- ``chain``: a serial chain of n driven revolute journals (benchmarks/scaling.py's
  ``revolute_chain``): the growth of the peak resident set size (``ru_maxrss``) over loading,
  and over loading and the first solve [MB].

Usage:
    python benchmarks/memory.py [--points N] [--chains N ...] [--json FILE]
"""

from __future__ import annotations

import os

if __name__ == "__main__":
    for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(_variable, "1")

import argparse
import gc
import json
import resource
import subprocess
import sys
import tracemalloc
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent


def _maxrss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # Linux: kB


def trajectory(points: int) -> dict:
    """Bytes per point of a read trajectory, held by the batch and kept by the caller."""
    import clearance_pin

    arm = clearance_pin.load(ROOT / "models" / "arm_6r.urdf")
    sweep = [arm.q_nominal + np.full(arm.model.nq, 1e-3 * k) for k in range(points)]
    warm = arm.solve_many(configurations=sweep[:8])
    for item in warm:
        item.torsor(arm.tree_joints[0].name), item.frame_displacement("tool")
    del warm
    gc.collect()
    tracemalloc.start()
    start = tracemalloc.get_traced_memory()[0]
    batch = arm.solve_many(configurations=sweep)
    kept = []
    for item in batch:
        item.torsor(arm.tree_joints[0].name), item.frame_displacement("tool"), item.ok
        kept.append(item)
    gc.collect()
    with_answers = tracemalloc.get_traced_memory()[0] - start
    del kept, item
    gc.collect()
    held = tracemalloc.get_traced_memory()[0] - start
    tracemalloc.stop()
    return {
        "points": points,
        "bytes_per_point_held": held / points,
        "bytes_per_point_answers_kept": with_answers / points,
    }


def chain(joints: int) -> dict:
    """Peak RSS growth [MB] over loading a chain of ``joints`` joints and its first solve."""
    sys.path.insert(0, str(HERE))
    from scaling import revolute_chain

    import clearance_pin

    text = revolute_chain(joints)
    before = _maxrss_mb()
    mechanism = clearance_pin.loads(text, source=f"revolute_chain_{joints}")
    loaded = _maxrss_mb()
    ok = bool(mechanism.solve().ok)
    solved = _maxrss_mb()
    return {
        "joints": joints,
        "load_mb": loaded - before,
        "load_and_solve_mb": solved - before,
        "ok": ok,
    }


def _child(kind: str, size: int) -> dict:
    completed = subprocess.run(
        [sys.executable, __file__, "--child", kind, str(size)],
        check=True,
        capture_output=True,
        text=True,
        timeout=3600,
    )
    result: dict = json.loads(completed.stdout.strip().splitlines()[-1])
    return result


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", type=int, default=2000)
    parser.add_argument("--chains", type=int, nargs="*", default=[50, 100, 300])
    parser.add_argument("--json", type=Path)
    parser.add_argument("--child", nargs=2, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        kind, size = args.child[0], int(args.child[1])
        print(json.dumps(trajectory(size) if kind == "trajectory" else chain(size)))
        return 0
    document = {
        "trajectory": _child("trajectory", args.points),
        "chains": [_child("chain", n) for n in args.chains],
    }
    read = document["trajectory"]
    print(
        f"trajectory of {read['points']} points: {read['bytes_per_point_held']:.0f} B per point "
        f"held by the batch, {read['bytes_per_point_answers_kept']:.0f} B with every answer kept"
    )
    for entry in document["chains"]:
        print(
            f"chain of {entry['joints']} joints: load +{entry['load_mb']:.0f} MB, "
            f"load and first solve +{entry['load_and_solve_mb']:.0f} MB (ok={entry['ok']})"
        )
    if args.json:
        args.json.write_text(json.dumps(document, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
