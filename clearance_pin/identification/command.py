"""``clearance-pin identify MODEL``: a robot's drive backlash and stiffness from measured
deflections, where to measure them, and the accuracy the identified robot predicts.

    clearance-pin identify ur5.urdf --clearances datasheet.toml --point 'tool0@[0.2 0 0.1]' \\
        --measurements deflections.csv --write identified.toml --json identify.json
    clearance-pin identify ur5.urdf --clearances datasheet.toml --point 'tool0@[0.2 0 0.1]' \\
        --design 40 --noise 10um --payload 5 --plan to_measure.csv
    clearance-pin identify ... --measurements deflections.csv --payload 5 --iso9283

``--measurements CSV``: the measurement file (docs/identification.md): each drive's backlash
and stiffness fitted, with standard errors, rank, conditioning, correlated pairs and the
residuals before (the clearance file's values) and after; ``--held-out SHARE`` keeps that share
of the poses out of the fit to judge its prediction; ``--write FILE`` writes the clearance file
with the identified values (TOML). ``--design N``: the N poses among ``--candidates`` random
ones that determine the parameters best, under the rated ``--payload`` (hung, and pulled along
+-x and +-y), the standard errors expected for ``--noise``, ``--plan FILE`` a measurement file to
fill in. ``--iso9283`` (with ``--payload KG``): the position error predicted at the ISO 9283
test cube's poses, split by play, backlash and compliance, with the identified values (or the
clearance file's without measurements). ``--gravity on``: the arm's own
weight among the loads (a real robot always carries it; default: as the model says).

Exit status: 0; 1 when a parameter asked for could not be identified (unobservable, not
separable, not physical: the table says which) or the linear model departs from the solver;
2 bad input (a measurement file's error names its line and column); 3, 4 as the other
sub-commands.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

from ..commands import (
    OK,
    OUT_OF_TOLERANCE,
    add_gravity_argument,
    add_json_argument,
    add_model_arguments,
    gravity_option,
    model_options,
    say,
    write_json,
)
from ..errors import ArgumentError
from ..json_documents import IDENTIFY_SCHEMA
from ..model.mechanism_parts import MechanismParts

LENGTH_UNITS = {"m": 1.0, "mm": 1e-3, "um": 1e-6}
MODEL_TOLERANCE = 1e-9  # [m] the linear model against the solver (it is the solver's, to round-off)

__all__ = ["IDENTIFY_SCHEMA", "add_arguments", "register", "run"]


def register(subparsers: Any) -> argparse.ArgumentParser:
    """Add the ``identify`` sub-command to ``subparsers`` (``add_subparsers()``'s result)."""
    parser: argparse.ArgumentParser = subparsers.add_parser(
        "identify", help="a robot's drive backlash and stiffness from measured deflections"
    )
    add_arguments(parser)
    parser.set_defaults(run=run)
    return parser


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the ``identify`` sub-command."""
    add_model_arguments(parser, " (its values: the priors, e.g. the datasheet's)")
    parser.add_argument(
        "--point",
        required=True,
        metavar="FRAME|FRAME@[X Y Z]",
        help="the measured point: a frame, or a point [m] in it (as --output elsewhere)",
    )
    parser.add_argument("--measurements", type=Path, metavar="CSV", help="the measurement file")
    parser.add_argument(
        "--parameters",
        default="backlash,drive_stiffness",
        help="what to fit: backlash, drive_stiffness or both (default)",
    )
    parser.add_argument("--joints", help="the drives to fit, comma-separated (default: all)")
    add_gravity_argument(parser)
    parser.add_argument(
        "--held-out", type=float, metavar="SHARE", help="share of the poses kept out of the fit"
    )
    parser.add_argument("--seed", type=int, default=0, help="random choices' seed (default 0)")
    parser.add_argument("--write", type=Path, metavar="FILE", help="the identified clearance file")
    add_json_argument(parser, "the report")
    parser.add_argument("--design", type=int, metavar="N", help="choose N poses to measure")
    parser.add_argument(
        "--noise", default="10um", help="measurement noise per coordinate (default 10um)"
    )
    parser.add_argument(
        "--candidates", type=int, default=500, help="random candidate poses (default 500)"
    )
    parser.add_argument(
        "--payload", type=float, metavar="KG", help="the rated payload [kg] (design, ISO 9283)"
    )
    parser.add_argument("--plan", type=Path, metavar="FILE", help="with --design: a CSV to fill in")
    parser.add_argument(
        "--iso9283",
        action="store_true",
        help="the position error predicted at the ISO 9283 test cube's poses under --payload",
    )


def parse_length(option: str, text: str) -> float:
    """``10um``, ``0.01mm``, ``1e-5`` [m] -> metres."""
    digits = text.rstrip("mu")
    unit = text[len(digits) :] or "m"
    try:
        value = float(digits) * LENGTH_UNITS[unit]
    except (KeyError, ValueError):
        raise ArgumentError(option, "a length, e.g. 10um, 0.01mm or 1e-5 [m]", text) from None
    if not (math.isfinite(value) and value > 0.0):
        raise ArgumentError(option, "a length > 0", text)
    return value


def run(args: argparse.Namespace) -> int:
    """Run the sub-command; returns the exit status."""
    from .. import load
    from .design import design_measurements
    from .identify import identify
    from .iso9283 import iso9283_prediction

    if args.measurements is None and args.design is None and args.payload is None:
        raise ArgumentError(
            "--measurements", "a measurement file, --design N or --payload KG", None
        )
    if args.plan is not None and args.design is None:
        raise ArgumentError("--plan", "with --design N", str(args.plan))
    if args.write is not None and args.measurements is None:
        raise ArgumentError("--write", "with --measurements CSV", str(args.write))
    kinds = tuple(k.strip() for k in args.parameters.split(",") if k.strip())
    joints = None if args.joints is None else [j.strip() for j in args.joints.split(",")]
    gravity = gravity_option(args)
    noise = parse_length("--noise", args.noise)
    mechanism = load(args.model, **model_options(args))
    document: dict[str, Any] = {
        "schema": IDENTIFY_SCHEMA,
        "model": str(args.model),
        "point": args.point,
        "identification": None,
        "design": None,
        "iso9283": None,
    }
    status = OK
    robot: MechanismParts = mechanism
    if args.measurements is not None:
        result = identify(
            mechanism, args.measurements, args.point, kinds, joints=joints, gravity=gravity,
            held_out=args.held_out, seed=args.seed,
        )  # fmt: skip
        say(args, result.table())
        document["identification"] = result.to_dict()
        if result.status != "ok" or not result.solver_check <= MODEL_TOLERANCE:
            status = OUT_OF_TOLERANCE
        if args.write is not None:
            result.write_clearances(args.write, args.clearances)
            say(args, f"clearance file with the identified values written to {args.write}")
        robot = result.identified_mechanism()
    if args.design is not None:
        design = design_measurements(
            mechanism, args.point, args.design, noise, candidates=args.candidates,
            payload=args.payload, parameters=kinds, joints=joints, gravity=gravity,
            seed=args.seed,
        )  # fmt: skip
        say(args, design.table())
        document["design"] = design.to_dict()
        if args.plan is not None:
            design.write_plan(args.plan)
            say(args, f"measurement plan written to {args.plan}")
    if args.iso9283:
        prediction = iso9283_prediction(robot, args.point, args.payload, gravity=gravity)
        which = "identified" if args.measurements is not None else "clearance file's"
        say(args, f"with the {which} values:")
        say(args, prediction.table())
        document["iso9283"] = prediction.to_dict()
    if args.json is not None:
        write_json(args, document)
    return status
