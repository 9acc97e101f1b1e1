"""Figures of the clearance envelope (issue 13): gaps, directions and timings on every model.

    python benchmarks/envelope_figures.py [--json FILE]

For every bundled model (models/*.urdf) and every test-data model (tests/data/*.urdf), the
envelope of its first two leaf links (translation and rotation): the certified largest deviation,
its relative gap, what closed it, the support evaluations it took and the wall time of each kind
(after the model's first solve, so loading is not counted). Then the 6R arm's tool frame, the
target of issue 13 (translation and rotation certified in under 1 s), timed five times.
"""

from __future__ import annotations

import argparse
import json
import time
import warnings
from pathlib import Path

import clearance_pin
from clearance_pin.envelope import envelope
from clearance_pin.equilibrium.outputs import leaf_links

ROOT = Path(__file__).resolve().parent.parent


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", type=Path, help="write the figures as JSON")
    args = parser.parse_args()
    rows = []
    files = sorted((ROOT / "models").glob("*.urdf")) + sorted((ROOT / "tests/data").glob("*.urdf"))
    for path in files:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", clearance_pin.ClearancePinWarning)
            mechanism = clearance_pin.load(path)
            mechanism.solve()
        for leaf in leaf_links(mechanism.model)[:2]:
            result = envelope(mechanism, leaf)
            for kind, part in result.kinds.items():
                top = part.maximum
                row = {
                    "model": str(path.relative_to(ROOT)),
                    "output": leaf,
                    "kind": kind,
                    "span": part.dimension,
                    "free": part.free.shape[1],
                    "lower": top.lower,
                    "upper": top.upper,
                    "gap": top.gap,
                    "method": top.method,
                    "directions": top.directions,
                    "seconds": result.timings[kind],
                }
                rows.append(row)
                scale, unit = (1e6, "um") if kind == "translation" else (1e6, "urad")
                print(
                    f"{row['model']:40s} {leaf:14s} {kind:11s} k={part.dimension} "
                    f"max {top.lower * scale:12.6f} {unit:4s} gap {top.gap:.1e} "
                    f"{top.method:14s} {top.directions:5d} dirs {result.timings[kind]:.3f} s"
                )
    arm = clearance_pin.load(ROOT / "models" / "arm_6r.urdf")
    arm.solve()
    times = []
    for _ in range(5):
        start = time.perf_counter()
        result = envelope(arm, "tool")
        times.append(time.perf_counter() - start)
    print(
        f"arm_6r tool frame, translation + rotation certified: best {min(times):.3f} s, "
        f"median {sorted(times)[2]:.3f} s of 5 (gaps {result.max_translation.gap:.1e}, "
        f"{result.max_rotation.gap:.1e})"
    )
    if args.json:
        args.json.write_text(json.dumps({"envelopes": rows, "arm_6r_tool_s": times}, indent=1))


if __name__ == "__main__":
    main()
