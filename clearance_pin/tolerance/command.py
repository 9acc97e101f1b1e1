"""``clearance-pin tolerance MODEL``: tolerance propagation over a sweep of the driven joint [F].

    clearance-pin tolerance models/slider_crank.urdf --clockwise \\
        --output x4=slider.x --output theta3=rod.rz --samples 100000 --exact \\
        --budget x4 --plot bands.png --json bands.json
    clearance-pin tolerance tests/data/stewart_6ups.urdf --joint leg1 --start 210 --stop 230 \\
        --output platform.x --output platform.z

Prints, at every position of the sweep, the nominal outputs, their sensitivities to the
``<dimension>`` elements of the model, the worst-case and RSS half bands (P. Flores 2011), the
exact Monte Carlo checks (uniform: largest deviation; normal: ``3 s``) and, with ``--exact``, the
exact worst case; then the maxima of the bands over the continuous range of the sweep. A revolute
joint is swept by an angle ``phi`` (``--start``/``--stop``/``--offset`` in degrees, one turn by
default), a prismatic one by a travel ``s`` (in millimetres, and ``--start``/``--stop`` are
required: a slider has no cycle). Units: um and urad in the table, SI (m, rad) in the JSON.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from ..arguments import MOST_POSITIONS, MOST_SAMPLES, check_count, check_seed
from ..commands import (
    OK,
    OUT_OF_TOLERANCE,
    add_json_argument,
    add_model_arguments,
    model_options,
    say,
    write_json,
)
from ..errors import ArgumentError, ClearancePinError, NotFoundError
from ..json_documents import TOLERANCE_SCHEMA
from .sensitivity import Output, determined_outputs, parse_output, sensitivities
from .spec import Verdict, contributors, parse_spec, verdict
from .sweep import (
    Budget,
    Sweep,
    clearance_budget,
    cycle_maximum,
    driven_joint,
    joint_unit,
    plot_sweep,
    sweep,
)

if TYPE_CHECKING:
    from ..mechanism import Mechanism

__all__ = ["add_arguments", "default_outputs", "run"]

#: the largest bands over the sweep: (output, "worst" or "rss") -> (band, where [rad or m])
Maxima = dict[tuple[str, str], tuple[float, float]]

_TABLE_SCALE = {"m": (1e6, "um"), "rad": (1e6, "urad")}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the ``tolerance`` sub-command."""
    add_model_arguments(parser, " (with <dimension> elements)")
    parser.add_argument(
        "--output",
        action="append",
        metavar="[NAME=]FRAME.x|y|z|rx|ry|rz|JOINT",
        help="an output (repeatable); default: the moved coordinates of the leaf links",
    )
    parser.add_argument("--joint", help="driven joint to sweep (default: the only driven joint)")
    parser.add_argument(
        "--positions",
        type=int,
        default=25,
        help=f"positions (default 25, at most {MOST_POSITIONS})",
    )
    parser.add_argument(
        "--start",
        type=float,
        help="first phi [deg] of a revolute joint (default 0); first s [mm] of a prismatic "
        "joint (required)",
    )
    parser.add_argument(
        "--stop",
        type=float,
        help="last phi [deg] of a revolute joint (default 360); last s [mm] of a prismatic "
        "joint (required: no cycle)",
    )
    parser.add_argument(
        "--offset",
        type=float,
        default=0.0,
        help="driven joint value at phi = 0 [deg], or at s = 0 [mm] for a prismatic joint "
        "(default 0: s is the joint value); the range must stay within the URDF limits",
    )
    parser.add_argument(
        "--clockwise",
        action="store_true",
        help="q = offset - phi (the Flores convention theta2 = -phi; prismatic: q = offset - s)",
    )
    parser.add_argument(
        "--samples",
        type=int,
        default=10_000,
        help="Monte Carlo samples per position and law (default 10000, 0: none, at most "
        f"{MOST_SAMPLES})",
    )
    parser.add_argument("--seed", type=int, default=0, help="Monte Carlo seed >= 0 (default 0)")
    parser.add_argument("--exact", action="store_true", help="exact worst case per position")
    parser.add_argument(
        "--no-maxima", action="store_true", help="skip the maxima over the continuous cycle"
    )
    parser.add_argument(
        "--budget",
        metavar="NAME",
        help="add the clearance-induced deviation of this output (equilibrium "
        "engine, the model's loads) and the combined budget",
    )
    parser.add_argument(
        "--spec",
        action="append",
        default=[],
        metavar="NAME=LIMIT",
        help="a spec limit on |deviation| of an output, SI or with a unit (x4=50um, "
        "theta3=0.1deg); repeatable: each output's worst case, RSS and Monte Carlo judged "
        "against it (exit 1 when a worst case exceeds it)",
    )
    parser.add_argument("--plot", type=Path, metavar="FILE", help="write a PNG of the bands")
    add_json_argument(parser, "the results")


def default_outputs(mechanism: Mechanism) -> tuple[Output, ...]:
    """The coordinates of the leaf links that the dimensions move at the nominal configuration."""
    model = mechanism.model
    parents = {f.parentFrame for f in model.frames}
    leaves = [
        f.name
        for i, f in enumerate(model.frames)
        if f.type == pin.FrameType.BODY and i not in parents
    ]
    candidates = [
        parse_output(model, f"{name}.{c}")
        for name in leaves
        for c in ("x", "y", "z", "rx", "ry", "rz")
    ]
    candidates = list(determined_outputs(mechanism, candidates))  # not a freely spinning rod
    if not candidates:
        raise ClearancePinError(f"{mechanism.source}: no leaf link to report; give --output")
    linear = sensitivities(mechanism, candidates)
    scale = np.array([mechanism.length_scale() if o.unit == "rad" else 1.0 for o in candidates])
    moved = np.max(np.abs(linear.matrix), axis=1) * scale > 1e-9
    chosen = tuple(o for o, keep in zip(candidates, moved) if keep)
    if not chosen:
        raise ClearancePinError(
            f"{mechanism.source}: the dimensions move no leaf link; give --output"
        )
    return chosen


def run(args: argparse.Namespace) -> int:
    """Run the sub-command; returns the exit status (0)."""
    from ..loading import load

    check_count("--positions", args.positions, 1, MOST_POSITIONS)
    if args.samples != 0:  # 0: no Monte Carlo; one sample has no spread
        check_count("--samples", args.samples, 2, MOST_SAMPLES)
    check_seed("--seed", args.seed)
    mechanism = load(args.model, **model_options(args))
    if not mechanism.dimensions:
        raise ClearancePinError(
            f"{args.model}: no <dimension> element in the <clearance_pin> "
            "block; nothing to propagate"
        )
    outputs = (
        tuple(parse_output(mechanism.model, s) for s in args.output)
        if args.output
        else default_outputs(mechanism)
    )
    if args.budget and args.budget not in [output.name for output in outputs]:
        raise NotFoundError("output", args.budget, [output.name for output in outputs], "--budget")
    specs = dict(parse_spec(text, outputs) for text in args.spec)
    limits = [specs.get(output.name, math.inf) for output in outputs] if specs else None
    start, stop, offset = _range_si(mechanism, args)
    result = sweep(
        mechanism,
        outputs,
        args.joint,
        args.positions,
        start,
        stop,
        args.clockwise,
        offset,
        samples=args.samples,
        seed=args.seed,
        exact=args.exact,
        limits=limits,
    )
    maxima: Maxima = {}
    if not args.no_maxima and args.positions > 1:
        fine = sweep(
            mechanism,
            result.outputs,
            result.joint,
            361,
            result.phi[0],
            result.phi[-1],
            args.clockwise,
            result.offset,
        )
        for output in result.outputs:
            for band in ("worst", "rss"):
                maxima[(output.name, band)] = cycle_maximum(
                    mechanism, result, output.name, band, fine=fine
                )
    budget = clearance_budget(mechanism, result, args.budget) if args.budget else None
    verdicts = [
        verdict(result, i, specs[output.name], _largest(maxima, output.name))
        for i, output in enumerate(result.outputs)
        if output.name in specs
    ]
    say(args, _table(mechanism, result, maxima, budget))
    for line in _spec_lines(verdicts):
        say(args, line)
    if args.plot:
        plot_sweep(
            result, args.plot, budget, title=f"{mechanism.name}: tolerance bands", limits=specs
        )
        say(args, f"plot written to {args.plot}")
    if args.json is not None:
        write_json(args, _document(args.model, result, maxima, budget, verdicts))
    failed = [v for v in verdicts if not v.worst_case_passes]
    if failed:  # a non-zero exit says why on standard error, in one line
        names = ", ".join(v.output for v in failed)
        print(
            f"clearance-pin: {args.model}: out of spec (worst case beyond the limit): {names}",
            file=sys.stderr,
        )
        return OUT_OF_TOLERANCE
    return OK


def _largest(maxima: Maxima, name: str) -> tuple[float, float] | None:
    """(worst, RSS) maxima of output ``name`` over the continuous sweep, when computed."""
    if (name, "worst") not in maxima:
        return None
    return maxima[(name, "worst")][0], maxima[(name, "rss")][0]


def _spec_lines(verdicts: list[Verdict]) -> list[str]:
    """The spec section of the table: per output its limit, worst case and RSS pass or fail,
    and the Monte Carlo shares out of spec."""
    lines = []
    for v in verdicts:
        factor, unit = _TABLE_SCALE[v.unit]
        lines.append("")
        lines.append(
            f"spec {v.output}: |deviation| <= {factor * v.limit:.4g} {unit}: worst case "
            f"{'PASS' if v.worst_case_passes else 'FAIL'} (largest band "
            f"{factor * v.worst:.4g} {unit}), RSS {'PASS' if v.rss_passes else 'FAIL'} "
            f"({factor * v.rss:.4g} {unit})"
        )
        if v.uniform_share is not None and v.normal_share is not None:
            lines.append(
                f"  out of spec over the sweep (Monte Carlo): {100 * v.uniform_share:.3g} % "
                f"(uniform dimensions), {100 * v.normal_share:.3g} % (normal, 6 sigma = T)"
            )
    return lines


def _range_si(mechanism: Mechanism, args: argparse.Namespace) -> tuple[float, float, float]:
    """``--start``, ``--stop``, ``--offset`` in SI [rad or m], read in the swept joint's
    display unit: deg for a revolute joint (0 to 360 by default), mm for a prismatic one."""
    joint_id = driven_joint(mechanism, args.joint)
    if joint_unit(mechanism, joint_id) == "rad":
        start = 0.0 if args.start is None else args.start
        stop = 360.0 if args.stop is None else args.stop
        return math.radians(start), math.radians(stop), math.radians(args.offset)
    if args.start is None or args.stop is None:
        raise ArgumentError(
            "--start, --stop",
            f"the travel s [mm] of prismatic joint {mechanism.model.names[joint_id]!r} "
            "(a prismatic joint has no cycle: give both)",
            (args.start, args.stop),
        )
    return args.start / 1e3, args.stop / 1e3, args.offset / 1e3  # correctly rounded m


def _table(mechanism: Mechanism, result: Sweep, maxima: Maxima, budget: Budget | None) -> str:
    lines = [
        f"{mechanism.name}: {len(result.dimensions)} dimensions, sweep of "
        f"{result.joint} ({_law(result)}), {len(result.phi)} positions, {result.seconds:.2f} s"
    ]
    for d in result.dimensions:
        factor, unit = _TABLE_SCALE[d.unit]
        grade = f" ({d.grade})" if d.grade else ""
        nominal = f"{d.nominal * 1e3:.6g} mm" if d.kind == "length" else "0 rad"
        lines.append(
            f"  {d.name}: {d.kind} at {d.joint}, nominal {nominal}, +/- "
            f"{factor * d.half_tolerance:.4g} {unit}{grade}"
        )
    for i, output in enumerate(result.outputs):
        factor, unit = _TABLE_SCALE[output.unit]
        value_unit = "mm" if output.unit == "m" else "deg"
        value_factor = 1e3 if output.unit == "m" else 180.0 / math.pi
        lines.append("")
        lines.append(
            f"{output.name} ({output.kind} of {output.target}); bands are half widths [{unit}]"
        )
        head = f"{result.symbol + '[' + result.display_unit + ']':>9}"
        head += f" {output.name + '[' + value_unit + ']':>12}"
        head += "".join(f" {'S_' + d.name:>10}" for d in result.dimensions)
        head += f" {'worst':>9} {'rss':>9}"
        if result.uniform:
            head += f" {'MC|max|':>9} {'MC 3s':>9}"
        if result.exact:
            head += f" {'exact-':>9} {'exact+':>9}"
        if budget is not None and budget.output == output.name:
            head += f" {'clear.':>9} {'total':>9}"
        lines.append(head)
        for k, phi in enumerate(result.display()):
            row = f"{phi:9.2f}" if result.unit == "rad" else f"{phi:9.3f}"
            row += f" {value_factor * result.values[k, i]:12.6f}"
            row += "".join(f" {s:10.5f}" for s in result.matrix[k, i])
            row += f" {factor * result.worst[k, i]:9.3f} {factor * result.rss[k, i]:9.3f}"
            if result.uniform:
                row += (
                    f" {factor * result.uniform[k].max_abs[i]:9.3f}"
                    f" {factor * result.normal[k].three_sigma[i]:9.3f}"
                )
            if result.exact:
                row += (
                    f" {factor * result.exact[k].lower[i]:9.3f}"
                    f" {factor * result.exact[k].upper[i]:9.3f}"
                )
            if budget is not None and budget.output == output.name:
                row += f" {factor * budget.clearance[k]:9.3f} {factor * budget.total_worst[k]:9.3f}"
            lines.append(row)
        for band in ("worst", "rss"):
            if (output.name, band) in maxima:
                value, where = maxima[(output.name, band)]
                lines.append(
                    f"  max {band} band over {_span(result)}: {factor * value:.4f} {unit} at "
                    f"{result.symbol} = {result.display(where):.4f} {result.display_unit}"
                )
        ranked = contributors(result, i)
        if ranked:
            lines.append(f"  what moves {output.name} most (largest share of its worst band):")
            for c in ranked:
                lines.append(
                    f"    {c.dimension}: {factor * c.share:.4g} {unit} at {result.symbol} = "
                    f"{result.display(result.phi[c.position]):.4g} {result.display_unit} "
                    f"({100 * c.fraction:.0f} % of the band there)"
                )
    if result.uniform:
        lines.append("")
        lines.append(
            f"Monte Carlo: {result.uniform[0].samples} samples per position and law, loops "
            "closed exactly for each (uniform: inside the worst case; normal with sigma "
            "= T/6: three times the samples' standard deviation (3 s) against the RSS band)"
        )
    return "\n".join(lines)


def _law(result: Sweep) -> str:
    """The driven joint's value along the sweep, e.g. ``q = +0 - phi`` or
    ``q = +0 mm + s`` (a prismatic joint)."""
    sign = "-" if result.sign < 0 else "+"
    if result.unit == "rad":
        return f"q = {result.offset:+.4g} {sign} phi"
    return f"q = {1e3 * result.offset:+.6g} mm {sign} s"


def _span(result: Sweep) -> str:
    """Where the maxima are sought: ``the cycle`` (an angle) or ``s in [a, b] mm``."""
    if result.unit == "rad":
        return "the cycle"
    low, high = sorted((result.display(result.phi[0]), result.display(result.phi[-1])))
    return f"s in [{low:.6g}, {high:.6g}] mm"


def _document(
    model: Path,
    result: Sweep,
    maxima: Maxima,
    budget: Budget | None,
    verdicts: list[Verdict] | None = None,
) -> dict[str, Any]:
    """The ``tolerance`` document (:data:`~..json_documents.TOLERANCE_SCHEMA`), SI: every
    quantity suffixed with its unit (an output's ``_m`` or ``_rad``, a dimension's likewise; a
    sensitivity ``_m_per_m``, ``_rad_per_m``, ...); the sweep's motion parameter (phi [rad] or
    s [m]) with ``q_drive = offset + sign * parameter``."""
    motion = result.unit  # the driven joint's: rad or m
    outputs: dict[str, dict[str, Any]] = {}
    for i, output in enumerate(result.outputs):
        u = output.unit
        entry: dict[str, Any] = {
            "kind": output.kind,
            "target": output.target,
            f"values_{u}": result.values[:, i].tolist(),
            "sensitivities": {
                d.name: {
                    f"values_{u}_per_{d.unit}": result.matrix[:, i, j].tolist(),
                }
                for j, d in enumerate(result.dimensions)
            },
            f"worst_{u}": result.worst[:, i].tolist(),
            f"rss_{u}": result.rss[:, i].tolist(),
        }
        if result.uniform:
            entry[f"mc_uniform_max_abs_{u}"] = [r.max_abs[i] for r in result.uniform]
            entry[f"mc_normal_3sigma_{u}"] = [r.three_sigma[i] for r in result.normal]
        if result.exact:
            entry[f"exact_lower_{u}"] = [w.lower[i] for w in result.exact]
            entry[f"exact_upper_{u}"] = [w.upper[i] for w in result.exact]
        for band in ("worst", "rss"):
            if (output.name, band) in maxima:
                value, where = maxima[(output.name, band)]
                entry[f"{band}_max_{u}"] = value
                entry[f"{band}_max_parameter_{motion}"] = float(where)
        if budget is not None and budget.output == output.name:
            entry[f"clearance_deviation_{u}"] = budget.clearance.tolist()
            entry[f"total_worst_{u}"] = budget.total_worst.tolist()
            entry[f"total_rss_{u}"] = budget.total_rss.tolist()
        entry["contributors"] = [
            {
                "dimension": c.dimension,
                f"largest_share_{u}": c.share,
                f"at_parameter_{motion}": float(result.phi[c.position]),
                "share_of_band": c.fraction,
            }
            for c in contributors(result, i)
        ]
        for v in verdicts or ():
            if v.output == output.name:
                entry["spec"] = {
                    f"limit_{u}": v.limit,
                    "worst_case_passes": v.worst_case_passes,
                    "rss_passes": v.rss_passes,
                    "mc_uniform_share_beyond": v.uniform_share,
                    "mc_normal_share_beyond": v.normal_share,
                }
        outputs[output.name] = entry
    return {
        "schema": TOLERANCE_SCHEMA,
        "model": str(model),
        "joint": result.joint,
        "sign": result.sign,
        f"offset_{motion}": result.offset,
        f"parameter_{motion}": result.phi.tolist(),
        "dimensions": [
            {
                "name": d.name,
                "joint": d.joint,
                "kind": d.kind,
                f"nominal_{d.unit}": d.nominal,
                f"tolerance_{d.unit}": d.tolerance,
                f"half_tolerance_{d.unit}": d.half_tolerance,
                "grade": d.grade,
            }
            for d in result.dimensions
        ],
        "outputs": outputs,
        "mc_samples": result.uniform[0].samples if result.uniform else 0,
        "time_s": result.seconds,
    }


if __name__ == "__main__":  # pragma: no cover
    _parser = argparse.ArgumentParser(prog="clearance-pin tolerance")
    add_arguments(_parser)
    sys.exit(run(_parser.parse_args()))
