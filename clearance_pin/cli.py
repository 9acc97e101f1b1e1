"""The ``clearance-pin`` command.

    clearance-pin solve MODEL [--exact] [--json] [--check] [--gravity on|off] [--package-dir DIR]
    clearance-pin validate [--json FILE] [--check]
    clearance-pin tolerance MODEL ...      (see ``clearance-pin tolerance --help``)

Errors of the model or the load are printed as one line naming the file, the element and the
problem, with exit status 2; an equilibrium that does not exist (unbounded load) exits with 3.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from .errors import ClearancePinError, ModelError, UnboundedLoadError


def _solve(args: argparse.Namespace) -> int:
    from .model.model_file import load

    mechanism = load(args.model, package_dirs=args.package_dir)
    gravity = {"on": True, "off": False, None: None}[args.gravity]
    equilibrium = mechanism.solve(exact=args.exact, gravity=gravity)
    report = equilibrium.check() if args.check else None
    if args.json:
        document = {"model": str(args.model), "equilibrium": equilibrium.to_dict()}
        if equilibrium.linear is not None:
            document["linear"] = equilibrium.linear.to_dict()
        if report is not None:
            document["check"] = report.to_json()
        print(json.dumps(document, indent=2))
    else:
        print(f"{mechanism!r} from {args.model}")
        if equilibrium.linear is not None:
            print(equilibrium.linear.table())
            print()
        print(equilibrium.table())
        if report is not None:
            print()
            print(report.table())
            if not report.ok and equilibrium.formulation == "linear":
                print(
                    "(the small-displacement model's own second-order error shows here; "
                    "solve with --exact for a pose that sits on the real boundaries)"
                )
    return 0 if equilibrium.ok and (report is None or report.ok) else 1


def _validate(args: argparse.Namespace) -> int:
    script = Path(__file__).resolve().parent.parent / "validation" / "younes2013.py"
    if not script.exists():
        print(
            "clearance-pin validate: the validation scripts ship with the source tree "
            "(validation/younes2013.py), not with the installed package",
            file=sys.stderr,
        )
        return 2
    import runpy

    namespace = runpy.run_path(str(script))
    argv = (["--json", str(args.json)] if args.json else []) + (["--check"] if args.check else [])
    return namespace["main"](argv)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the command."""
    parser = argparse.ArgumentParser(prog="clearance-pin", description=__doc__.splitlines()[0])
    commands = parser.add_subparsers(dest="command", required=True)
    solve = commands.add_parser("solve", help="equilibrium of a model in its joint clearances")
    solve.add_argument("model", type=Path, help="model file (URDF with a <clearance_pin> block)")
    solve.add_argument("--exact", action="store_true", help="also solve the exact model")
    solve.add_argument("--json", action="store_true", help="print JSON instead of a table")
    solve.add_argument("--check", action="store_true", help="measure the pose with coal")
    solve.add_argument("--gravity", choices=["on", "off"], help="override the model's gravity")
    solve.add_argument(
        "--package-dir",
        action="append",
        type=Path,
        metavar="DIR",
        help="where collision meshes are looked for (package://PKG/FILE is DIR/PKG/FILE; "
        "repeatable; ROS_PACKAGE_PATH is searched too); only --check reads meshes",
    )
    solve.set_defaults(run=_solve)
    validate = commands.add_parser("validate", help="the paper's cases, published vs computed")
    validate.add_argument("--json", type=Path, help="write the results to this file")
    validate.add_argument("--check", action="store_true", help="add the coal check")
    validate.set_defaults(run=_validate)
    try:
        from .tolerance import command as tolerance_command
    except ImportError:
        tolerance_command = None
    if tolerance_command is not None:
        tolerance = commands.add_parser("tolerance", help="tolerance propagation (Flores)")
        tolerance_command.add_arguments(tolerance)
        tolerance.set_defaults(run=tolerance_command.run)
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``clearance-pin``."""
    args = build_parser().parse_args(argv)
    try:
        return args.run(args)
    except UnboundedLoadError as exc:
        print(f"clearance-pin: {exc}", file=sys.stderr)
        return 3
    except (ModelError, ClearancePinError) as exc:
        print(f"clearance-pin: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    raise SystemExit(main())
