"""``clearance-pin envelope MODEL``: how far an output moves inside the joint play, any load.

    clearance-pin envelope models/arm_6r.urdf --output tool --plot tool.png --json tool.json
    clearance-pin envelope models/four_bar.urdf --output rocker --exact
    clearance-pin envelope models/slider_crank.urdf --output "rod@[0.06 0 0]" --kind translation

Prints, per output, the certified largest translation [um] and rotation [urad] (the verified
state's deviation, the proven upper bound, their relative gap, the contacts the state touches),
the ranges along the world axes and the output frame's own and, with ``--exact``, the extremes
re-solved with finite displacements. ``--json`` writes the same in SI (m, rad); ``--plot`` draws
the envelopes (matplotlib). Exit status: 0 certified to ``--tol``, 1 a gap left above it
(printed, then one line on standard error); 3 an output that moves without bound along a motion
no play or drive limits (printed as UNBOUNDED with those directions, the rest of its envelope
with them removed, then one line on standard error); errors as the other sub-commands (2 bad
input, 3 a load along a free motion, 4 a solver failure).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from ..commands import (
    NO_EQUILIBRIUM,
    add_json_argument,
    add_model_arguments,
    add_output_argument,
    model_options,
    say,
    write_json,
)
from ..json_documents import envelope_document
from . import envelope
from .result import Envelope

__all__ = ["register", "add_arguments", "run"]


def register(subparsers: Any) -> argparse.ArgumentParser:
    """Add the ``envelope`` sub-command to ``subparsers`` (``add_subparsers()``'s result)."""
    parser: argparse.ArgumentParser = subparsers.add_parser(
        "envelope", help="clearance envelope of an output (any load), certified"
    )
    add_arguments(parser)
    parser.set_defaults(run=run)
    return parser


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the ``envelope`` sub-command."""
    add_model_arguments(parser)
    add_output_argument(parser, "an output (repeatable; default: the leaf links)")
    parser.add_argument(
        "--kind",
        choices=["translation", "rotation", "both"],
        default="both",
        help="which envelope (default both)",
    )
    parser.add_argument("--exact", action="store_true", help="re-solve the extremes exactly")
    parser.add_argument(
        "--tol", type=float, default=1e-6, help="relative gap of the maxima (default 1e-6)"
    )
    parser.add_argument("--plot", type=Path, metavar="FILE", help="draw the envelopes (PNG, ...)")
    add_json_argument(parser, "the envelopes")


def run(args: argparse.Namespace) -> int:
    """Run the sub-command; returns the exit status (0 certified, 1 a gap above ``--tol``)."""
    from .. import load
    from ..equilibrium.outputs import leaf_links

    mechanism = load(args.model, **model_options(args))
    outputs = args.output or list(leaf_links(mechanism.model))
    kinds = ("translation", "rotation") if args.kind == "both" else (args.kind,)
    results: list[Envelope] = []
    for index, output in enumerate(outputs):
        result = envelope(mechanism, output, exact=args.exact, kinds=kinds, tol=args.tol)
        results.append(result)
        say(args, result.table())
        timings = ", ".join(f"{k} {v:.3f} s" for k, v in result.timings.items())
        say(args, f"  time: {timings}")
        if args.plot:
            from .plot import plot_envelope

            target = args.plot
            if len(outputs) > 1:
                target = args.plot.with_name(f"{args.plot.stem}_{index}{args.plot.suffix}")
            plot_envelope(result, target)
            say(args, f"plot written to {target}")
    if args.json is not None:
        write_json(args, envelope_document(str(args.model), results))
    unbounded = [
        f"{r.output.name} {kind} ({part.free.shape[1]} free direction(s))"
        for r in results
        for kind, part in r.kinds.items()
        if part.free.shape[1]
    ]
    if unbounded:
        print(
            f"clearance-pin: {args.model}: unbounded: " + "; ".join(unbounded) + ": a motion "
            "that no play or drive limits moves the output (drive or lock that joint)",
            file=sys.stderr,
        )
        return NO_EQUILIBRIUM
    open_gaps = [
        f"{r.output.name} {kind} gap {part.maximum.gap:.2e}"
        for r in results
        for kind, part in r.kinds.items()
        if not part.maximum.certified
    ]
    if open_gaps:
        print(
            f"clearance-pin: {args.model}: not certified to tol {args.tol:g}: "
            + "; ".join(open_gaps),
            file=sys.stderr,
        )
        return 1
    return 0
