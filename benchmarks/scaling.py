"""Scaling benchmark: solve time and memory of clearance_pin against the number of joints.

Generated mechanisms (URDF text with a ``<clearance_pin>`` block, SI units):

- ``planar_chain``: n driven revolute joints in the plane, each with a planar revolute play
  (radial clearance 50 um), links of 100 mm, a force at the tip: 2 unknowns per joint;
- ``revolute_chain``: a 3-D serial arm of n driven revolute joints with axes cycling z, y, x,
  journal bearings (10 um radial, 5 um axial play, 30 mm long), a 3-D force at the tip:
  5 unknowns per joint;
- ``four_bar_ladder``: n four-bar loops stacked as a ladder (each level: a driven post, a passive
  post, a rung, and a loop joint closing the parallelogram), planar revolute play in all 4n joints,
  a force on the top rung.

For each size: load time, first solve (builds the geometry and the optimiser), median cold solve
(``warm_start=False``), median warm re-solve (each load different), solve_many time per case,
the exact model's build + solve (up to ``--exact-max`` joints), the tracemalloc peak of one cold
solve and of the solve_many call, and the growth of the resident set size (RSS) over loading and
the first solve. Wall and process CPU times are both kept. The exponent p of
time ~ joints^p is the least-squares slope in log-log over the sizes >= ``--fit-from`` joints.

Usage:
    python benchmarks/scaling.py [--json FILE] [--plots DIR] [--quick] [--sizes N ...]
"""

from __future__ import annotations

import os

if __name__ == "__main__":
    # One BLAS thread unless the caller says otherwise: the matrices are small, and multi-threaded
    # OpenBLAS on a busy machine makes them many times slower (README, "Metrics"). Must precede
    # the first import of numpy.
    for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(_variable, "1")

import argparse
import gc
import json
import math
import sys
import time
import tracemalloc
import warnings
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))

import clearance_pin

LINK = 0.1  # [m]


# -- generated models ----------------------------------------------------------------------------
def _inertial() -> str:
    return (
        '<inertial><mass value="0.1"/><origin xyz="0 0 0"/>'
        '<inertia ixx="1e-4" iyy="1e-4" izz="1e-4" ixy="0" ixz="0" iyz="0"/></inertial>'
    )


def _revolute(name, parent, child, xyz, axis) -> str:
    return (
        f'  <joint name="{name}" type="revolute"><parent link="{parent}"/><child link="{child}"/>'
        f'<origin xyz="{xyz}"/><axis xyz="{axis}"/>'
        '<limit lower="-7" upper="7" effort="100" velocity="10"/></joint>\n'
    )


def planar_chain(n: int) -> str:
    """n driven revolute joints about z with planar revolute play, tip force; URDF text."""
    links = "".join(
        f'  <link name="link_{k}">{_inertial() if k else ""}</link>\n' for k in range(n + 1)
    )
    joints, clearances = "", ""
    for k in range(1, n + 1):
        xyz = "0 0 0" if k == 1 else f"{LINK} 0 0"
        joints += _revolute(f"j{k}", f"link_{k - 1}", f"link_{k}", xyz, "0 0 1")
        q = 0.4 if k == 1 else (-0.3 if k % 2 else 0.25)
        clearances += (
            f'    <joint name="j{k}" type="planar_revolute" radial_clearance="5e-05" '
            f'driven="true" q="{q}"/>\n'
        )
    return (
        f'<?xml version="1.0"?>\n<robot name="planar_chain_{n}">\n{links}{joints}'
        f"  <clearance_pin>\n{clearances}"
        f'    <force link="link_{n}" point="{LINK} 0 0" value="-10 -20 0"/>\n'
        "  </clearance_pin>\n</robot>\n"
    )


def revolute_chain(n: int) -> str:
    """n driven revolute joints with axes cycling z, y, x, journal-bearing play; URDF text."""
    axes = ("0 0 1", "0 1 0", "1 0 0")
    offsets = (f"{LINK} 0 0", f"0 {LINK} 0", f"0 0 {LINK}")
    links = "".join(
        f'  <link name="link_{k}">{_inertial() if k else ""}</link>\n' for k in range(n + 1)
    )
    joints, clearances = "", ""
    for k in range(1, n + 1):
        xyz = "0 0 0" if k == 1 else offsets[k % 3]
        joints += _revolute(f"j{k}", f"link_{k - 1}", f"link_{k}", xyz, axes[k % 3])
        q = 0.3 * (-1) ** k
        clearances += (
            f'    <joint name="j{k}" type="revolute" radial_clearance="1e-05" '
            f'length="0.03" axial_clearance="5e-06" driven="true" q="{q}"/>\n'
        )
    return (
        f'<?xml version="1.0"?>\n<robot name="revolute_chain_{n}">\n{links}{joints}'
        f"  <clearance_pin>\n{clearances}"
        f'    <force link="link_{n}" point="{LINK} 0 0" value="10 -20 30"/>\n'
        "  </clearance_pin>\n</robot>\n"
    )


def four_bar_ladder(loops: int, angle: float = math.pi / 3, height: float = 0.08) -> str:
    """``loops`` parallelogram four-bars stacked; 4 joints per loop (3 tree + 1 loop joint).

    Level k: ``post_l_k`` (driven) and ``post_r_k`` (passive) stand on ``rung_{k-1}`` at x = 0
    and x = LINK; ``rung_k`` hangs on the top of ``post_l_k`` (passive); the loop joint ``loop_k``
    joins the top of ``post_r_k`` and the right end of ``rung_k``.
    """
    links, joints, clearances = '  <link name="rung_0"/>\n', "", ""
    for k in range(1, loops + 1):
        below = f"rung_{k - 1}"
        for name in (f"post_l_{k}", f"post_r_{k}", f"rung_{k}"):
            links += f'  <link name="{name}">{_inertial()}</link>\n'
        links += f'  <link name="post_r_{k}_top"/>\n  <link name="rung_{k}_right"/>\n'
        joints += _revolute(f"left_{k}", below, f"post_l_{k}", "0 0 0", "0 0 1")
        joints += _revolute(f"right_{k}", below, f"post_r_{k}", f"{LINK} 0 0", "0 0 1")
        joints += _revolute(f"top_{k}", f"post_l_{k}", f"rung_{k}", f"{height} 0 0", "0 0 1")
        joints += (
            f'  <joint name="post_r_{k}_top_mount" type="fixed"><parent link="post_r_{k}"/>'
            f'<child link="post_r_{k}_top"/><origin xyz="{height} 0 0"/></joint>\n'
            f'  <joint name="rung_{k}_right_mount" type="fixed"><parent link="rung_{k}"/>'
            f'<child link="rung_{k}_right"/><origin xyz="{LINK} 0 0"/></joint>\n'
        )
        play = 'type="planar_revolute" radial_clearance="5e-05"'
        clearances += (
            f'    <joint name="left_{k}" {play} driven="true" q="{angle}"/>\n'
            f'    <joint name="right_{k}" {play} q="{angle}"/>\n'
            f'    <joint name="top_{k}" {play} q="{-angle}"/>\n'
            f'    <loop_joint name="loop_{k}" {play} frame_a="post_r_{k}_top" '
            f'frame_b="rung_{k}_right" axis="0 0 1"/>\n'
        )
    return (
        f'<?xml version="1.0"?>\n<robot name="four_bar_ladder_{loops}">\n{links}{joints}'
        f"  <clearance_pin>\n{clearances}"
        f'    <force link="rung_{loops}" point="{LINK / 2} 0 0" value="-5 -20 0"/>\n'
        "  </clearance_pin>\n</robot>\n"
    )


FAMILIES = {
    # name: (generator of size, joints per size unit)
    "planar_chain": (planar_chain, 1),
    "revolute_chain": (revolute_chain, 1),
    "four_bar_ladder": (four_bar_ladder, 4),
}
SIZES = (1, 2, 3, 5, 10, 20, 30, 50, 70, 100)
QUICK_SIZES = (1, 2, 5, 10)


@dataclass(frozen=True)
class ScalingSettings:
    """Repetitions and limits.

    Attributes:
        loads: different loads per timed run; budget_s: stop a run after this once
        ``min_solves`` are done [s]; batch: cases of the solve_many run; exact_max: largest
        number of joints for the exact model; fit_from: smallest number of joints in the fit.
    """

    loads: int = 60
    budget_s: float = 2.0
    min_solves: int = 10
    batch: int = 16
    exact_max: int = 30
    fit_from: int = 10
    seed: int = 7


QUICK = ScalingSettings(loads=8, budget_s=0.3, min_solves=3, batch=16, exact_max=5, fit_from=2)


def _rss_bytes() -> int:
    """Current resident set size [bytes] (Linux /proc; 0 elsewhere)."""
    try:
        with open("/proc/self/statm") as handle:
            pages = int(handle.read().split()[1])
        import os

        return pages * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return 0


def _median_time(call, count: int, settings: ScalingSettings) -> tuple[float, float, int, int]:
    """(median wall seconds, median CPU seconds, solves, failures) of call(i) for i < count."""
    times, cpu, failures = [], [], 0
    gc.collect()
    started = time.perf_counter()
    for i in range(count):
        c0, t0 = time.process_time(), time.perf_counter()
        try:
            call(i)
        except clearance_pin.ClearancePinError:
            failures += 1
            continue
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
        if i + 1 >= settings.min_solves and time.perf_counter() - started > settings.budget_s:
            break
    if not times:
        return math.nan, math.nan, 0, failures
    return float(np.median(times)), float(np.median(cpu)), len(times), failures


def measure(family: str, size: int, settings: ScalingSettings) -> dict:
    """Every measurement of one generated mechanism."""
    from work_precision import perturbed_loads  # here: the generators import without it

    generator, per_unit = FAMILIES[family]
    text = generator(size)
    gc.collect()
    rss_before = _rss_bytes()
    t0 = time.perf_counter()
    mechanism = clearance_pin.loads(text, source=f"{family}_{size}")
    load_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    first = mechanism.solve()
    first_s = time.perf_counter() - t0
    rss_growth = _rss_bytes() - rss_before
    rng = np.random.default_rng(settings.seed + size)
    loads = perturbed_loads(mechanism, max(settings.loads, settings.batch), 0.3, rng)
    cold_s, cold_cpu, cold_n, cold_fail = _median_time(
        lambda i: mechanism.solve(loads[i], warm_start=False), settings.loads, settings
    )
    warm_s, warm_cpu, warm_n, warm_fail = _median_time(
        lambda i: mechanism.solve(loads[i]), settings.loads, settings
    )
    warm_paths: dict[str, int] = {}
    for i in range(min(warm_n, 20)):
        status = mechanism.solve(loads[i]).solver_status.split(":")[0]
        warm_paths[status] = warm_paths.get(status, 0) + 1
    gc.collect()
    c0, t0 = time.process_time(), time.perf_counter()
    batch = mechanism.solve_many(loads[: settings.batch], progress=False, errors="return")
    batch_s = (time.perf_counter() - t0) / settings.batch
    batch_cpu = (time.process_time() - c0) / settings.batch
    tracemalloc.start()
    mechanism.solve(loads[0], warm_start=False)
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.reset_peak()
    mechanism.solve_many(loads[: settings.batch], progress=False, errors="return")
    _, batch_peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    joints = per_unit * size
    point = {
        "size": size,
        "joints": joints,
        "contacts": len(first.contacts),
        "active_contacts": len(first.active_contacts),
        "load_s": load_s,
        "first_solve_s": first_s,
        "cold_s": cold_s,
        "cold_cpu_s": cold_cpu,
        "resolve_cpu_s": warm_cpu,
        "batch_per_case_cpu_s": batch_cpu,
        "cold_solves": cold_n,
        "cold_failures": cold_fail,
        "resolve_s": warm_s,
        "resolve_solves": warm_n,
        "resolve_failures": warm_fail,
        "resolve_paths": warm_paths,
        "batch_per_case_s": batch_s,
        "batch_ok": int(np.sum(batch.ok)),
        "tracemalloc_peak_bytes": int(peak),
        "batch_tracemalloc_peak_bytes": int(batch_peak),
        "rss_growth_bytes": int(rss_growth),
        "solver_status": first.solver_status,
        "cold_path": mechanism.solve(loads[0], warm_start=False).solver_status.split(":")[0],
        "polished": first.polished,
    }
    if joints <= settings.exact_max:
        try:
            t0 = time.perf_counter()
            exact = mechanism.solve(exact=True)
            point["exact_first_s"] = time.perf_counter() - t0
            point["exact_build_s"] = exact.build_time
            point["exact_solve_s"] = exact.solve_time
            t0 = time.perf_counter()
            again = mechanism.solve(loads[1], exact=True)
            point["exact_resolve_s"] = again.solve_time
        except clearance_pin.ClearancePinError as exc:
            point["exact_error"] = f"{type(exc).__name__}: {str(exc)[:160]}"
    return point


def exponent(points: list[dict], key: str, fit_from: int) -> float | None:
    """Least-squares slope of log(key) against log(joints) over joints >= fit_from."""
    pairs = [
        (p["joints"], p[key])
        for p in points
        if p["joints"] >= fit_from and key in p and p[key] and np.isfinite(p[key]) and p[key] > 0
    ]
    if len(pairs) < 2:
        return None
    x, y = np.log([a for a, _ in pairs]), np.log([b for _, b in pairs])
    return float(np.polyfit(x, y, 1)[0])


def plot(families: dict, directory: Path, settings: ScalingSettings) -> Path:
    """Time and memory against the number of joints, log-log, one line per family and metric."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    figure, (left, right) = plt.subplots(1, 2, figsize=(12, 4.5))
    styles = {"cold_s": "-", "resolve_s": "--", "first_solve_s": ":", "batch_per_case_s": "-."}
    colours = {name: plt.cm.tab10(i) for i, name in enumerate(families)}
    for name, family in families.items():
        points = family["points"]
        joints = [p["joints"] for p in points]
        for key, style in styles.items():
            values = [p.get(key, math.nan) for p in points]
            slope = family["exponents"].get(key)
            label = f"{name} {key}" + (f" (p={slope:.2f})" if slope is not None else "")
            left.plot(joints, values, style, marker="o", ms=3, color=colours[name], label=label)
        right.plot(
            joints,
            [p["tracemalloc_peak_bytes"] / 2**20 for p in points],
            "-",
            marker="o",
            ms=3,
            color=colours[name],
            label=f"{name} one cold solve",
        )
        right.plot(
            joints,
            [p["batch_tracemalloc_peak_bytes"] / 2**20 for p in points],
            "-.",
            marker="s",
            ms=3,
            color=colours[name],
            label=f"{name} solve_many of {settings.batch} loads",
        )
    for ax, label in ((left, "time [s]"), (right, "memory [MiB]")):
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.set_xlabel("joints with clearance")
        ax.set_ylabel(label)
        ax.legend(fontsize=6)
        ax.grid(True, which="both", lw=0.3)
    left.set_title("solve time (cold, re-solve, first solve, batch per case)", fontsize=9)
    right.set_title("tracemalloc peak (Python + numpy allocations)", fontsize=9)
    figure.tight_layout()
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / "scaling.png"
    figure.savefig(path, dpi=110)
    plt.close(figure)
    return path


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", type=Path, help="write the results to this JSON file")
    parser.add_argument("--plots", type=Path, default=ROOT / "out" / "scaling")
    parser.add_argument("--no-plots", action="store_true")
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--sizes", type=int, nargs="*", help="joints (ladder: rounded to loops)")
    parser.add_argument("--families", nargs="*", choices=sorted(FAMILIES), default=None)
    parser.add_argument("--exact-max", type=int, help="largest joint count for the exact model")
    parser.add_argument(
        "--fit-from",
        type=int,
        help="smallest joint count in the fitted exponents (default 10, --quick 2)",
    )
    parser.add_argument("--replot", type=Path, help="only draw the PNG from this JSON file")
    args = parser.parse_args(argv)
    settings = QUICK if args.quick else ScalingSettings()
    if args.replot:
        document = json.loads(args.replot.read_text())
        saved = ScalingSettings(**document["settings"])
        print(f"wrote {plot(document['families'], args.plots, saved)}")
        return 0
    if args.exact_max is not None:
        settings = ScalingSettings(**{**asdict(settings), "exact_max": args.exact_max})
    if args.fit_from is not None:
        settings = ScalingSettings(**{**asdict(settings), "fit_from": args.fit_from})
    from work_precision import _git_state

    sizes = args.sizes or (QUICK_SIZES if args.quick else SIZES)
    warnings.simplefilter("ignore", clearance_pin.ConditioningWarning)
    started = time.perf_counter()
    load_start = os.getloadavg()
    git_state = _git_state()  # at the start: what is imported is what is measured
    families = {}
    for name in args.families or FAMILIES:
        per_unit = FAMILIES[name][1]
        units = sorted({max(1, round(n / per_unit)) for n in sizes})
        points = []
        for unit in units:
            point = measure(name, unit, settings)
            points.append(point)
            print(
                f"{name:<16}{point['joints']:5d} joints  load {point['load_s'] * 1e3:8.2f} ms"
                f"  first {point['first_solve_s'] * 1e3:8.2f} ms  cold "
                f"{point['cold_s'] * 1e3:8.3f} ms  re-solve {point['resolve_s'] * 1e3:8.3f} ms"
                f"  batch {point['batch_per_case_s'] * 1e3:8.3f} ms/case  tracemalloc "
                f"{point['tracemalloc_peak_bytes'] / 2**20:6.2f} MiB, batch "
                f"{point['batch_tracemalloc_peak_bytes'] / 2**20:7.2f} MiB"
                + (
                    f"  exact {point['exact_solve_s'] * 1e3:8.2f} ms (build "
                    f"{point['exact_build_s']:.2f} s)"
                    if "exact_solve_s" in point
                    else ""
                )
                + f"  [{point['cold_path']}]",
                flush=True,
            )
        keys = (
            "cold_s",
            "cold_cpu_s",
            "resolve_s",
            "resolve_cpu_s",
            "first_solve_s",
            "batch_per_case_s",
            "batch_per_case_cpu_s",
            "load_s",
            "exact_solve_s",
            "exact_build_s",
            "tracemalloc_peak_bytes",
            "batch_tracemalloc_peak_bytes",
        )
        exponents = {key: exponent(points, key, settings.fit_from) for key in keys}
        exponents_all = {key: exponent(points, key, 1) for key in keys}
        families[name] = {
            "points": points,
            "exponents": exponents,
            "exponents_all_sizes": exponents_all,
        }
        print(
            f"{name}: time ~ joints^p over joints >= {settings.fit_from}: "
            + ", ".join(f"{k} p={v:.2f}" for k, v in exponents.items() if v is not None),
            flush=True,
        )
    document = {
        "families": families,
        "settings": asdict(settings),
        "wall_time_s": time.perf_counter() - started,
        "machine": {
            "cpus": os.cpu_count(),
            "load_average_start": load_start,
            "load_average_end": os.getloadavg(),
            "blas_threads": os.environ.get("OPENBLAS_NUM_THREADS"),
            "git": git_state,
        },
    }
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(document, indent=1, default=float))
        print(f"wrote {args.json}")
    if not args.no_plots:
        print(f"wrote {plot(families, args.plots, settings)}")
    print(f"total {time.perf_counter() - started:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
