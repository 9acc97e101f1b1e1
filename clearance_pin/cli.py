"""The ``clearance-pin`` command.

    clearance-pin solve MODEL [--clearances FILE] [--exact] [--json] [--check] [--output FRAME]
                        [--plot FILE] [--gravity on|off] [--package-dir DIR]
    clearance-pin envelope MODEL [--clearances FILE] [--output FRAME] [--plot F] [--json F]
    clearance-pin accuracy MODEL --output FRAME [--poses N] [--payload KG ...] [--plot F] [--json F]
    clearance-pin tolerance MODEL [--clearances FILE] ...   (``clearance-pin tolerance --help``)
    clearance-pin compile              (the compiled kernel of re-solves, once per machine)
    clearance-pin --version            (also: python -m clearance_pin ...)

MODEL is a URDF or MJCF file; every sub-command takes ``--clearances FILE`` (the clearances
beside an unmodified vendor file, XML or TOML) and ``--package-dir DIR`` (where meshes are).

The paper's validation cases are a script of the source tree, not a sub-command:
``python validation/younes2013.py [--json FILE] [--check]``.

Exit status:

- 0: a verified equilibrium (and, with ``--check``, a check within its tolerances); the
  tolerance propagation done;
- 1: the answer's residuals or the coal check out of tolerance (the result is printed, then one
  line on standard error saying which);
- 2: a bad model, load or option: one line naming the file, the element and the problem; bad
  command-line arguments also exit with 2 (argparse's usage message), as does a file that cannot
  be read or written (checked before any work where it can be: ``--plot`` of a known type,
  ``--json`` in an existing folder, neither of them an input file), and a count out of its
  bounds (``accuracy --poses``, ``tolerance --positions``, ``--samples``);
- 3: no equilibrium: the load drives a motion that nothing blocks (the line names the motion);
  ``envelope``: an output moves without bound along such a motion (the line names it);
- 4: the solver did not reach a verified answer (the line gives its status and residuals);
- 5: ``compile``: numba is installed but cannot compile or cache the kernel (a read-only
  install: the line names numba's reason and the fix, ``NUMBA_CACHE_DIR``); ``compile`` exits
  with 0 when numba is not installed (the solves go the NumPy way).
"""

from __future__ import annotations

import argparse
import json
import sys
import warnings
from pathlib import Path
from types import ModuleType
from typing import TextIO

from .commands import (
    BAD_INPUT,
    NO_EQUILIBRIUM,
    OK,
    OUT_OF_TOLERANCE,
    SOLVER_FAILED,
    add_model_arguments,
    model_options,
)
from .errors import ClearancePinError, SolverError, UnboundedLoadError
from .json_documents import error_document, solve_document


def _solve(args: argparse.Namespace) -> int:
    from .loading import load

    mechanism = load(args.model, **model_options(args))
    gravity = {"on": True, "off": False, None: None}[args.gravity]
    outputs = args.output or None
    equilibrium = mechanism.solve(exact=args.exact, gravity=gravity, outputs=outputs)
    # the check judges the real boundaries, on the exact pose; a linear answer's own departure
    # from them (its second-order error) is information (report.departure), not a failure
    report = equilibrium.check() if args.check else None
    if args.json:
        document = solve_document(str(args.model), equilibrium, report)
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
    if args.plot is not None:
        from .plot import plot_equilibrium

        plot_equilibrium(equilibrium, args.plot)
        if not args.json:
            print(f"settled pose drawn in {args.plot}")
    problems = [] if equilibrium.ok else ["residuals out of tolerance"]
    if report is not None and not report.ok:
        problems.append(f"coal check out of tolerance ({len(report.failures)} readings)")
    if problems:
        _say(args, "; ".join(problems))
        return OUT_OF_TOLERANCE
    return OK


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the command."""
    from . import __version__

    parser = argparse.ArgumentParser(prog="clearance-pin", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=f"clearance-pin {__version__}")
    commands = parser.add_subparsers(dest="command", required=True)
    solve = commands.add_parser("solve", help="equilibrium of a model in its joint clearances")
    add_model_arguments(solve)
    solve.add_argument("--exact", action="store_true", help="also solve the exact model")
    solve.add_argument("--json", action="store_true", help="print JSON instead of a table")
    solve.add_argument("--check", action="store_true", help="measure the pose with coal")
    solve.add_argument("--gravity", choices=["on", "off"], help="override the model's gravity")
    solve.add_argument(
        "--plot",
        type=Path,
        metavar="FILE",
        help="draw the settled pose (nominal and settled skeleton, magnified; contacts and their "
        "forces; the plays to scale) into FILE (PNG, PDF, SVG; needs the plot extra)",
    )
    solve.add_argument(
        "--output",
        action="append",
        metavar="FRAME",
        help="a Pinocchio frame whose world displacement is reported (repeatable; default: the "
        "loaded points and the leaf links)",
    )
    solve.set_defaults(run=_solve)
    tolerance_command: ModuleType | None
    from . import compile_command
    from .accuracy import command as accuracy_command
    from .envelope import command as envelope_command

    envelope_command.register(commands)
    accuracy_command.register(commands)
    try:
        from .tolerance import command as tolerance_command
    except ImportError:
        tolerance_command = None
    if tolerance_command is not None:
        tolerance = commands.add_parser("tolerance", help="tolerance propagation (Flores)")
        tolerance_command.add_arguments(tolerance)
        tolerance.set_defaults(run=tolerance_command.run)
    from .identification import command as identification_command

    identification_command.register(commands)
    compile_command.register(commands)
    return parser


def _one_line_warnings(
    message: Warning | str,
    category: type[Warning],
    filename: str,
    lineno: int,
    file: TextIO | None = None,
    line: str | None = None,
) -> None:
    """Warnings as one line on standard error, without Python's source echo."""
    text = " ".join(str(message).splitlines())
    print(f"clearance-pin: warning ({category.__name__}): {text}", file=sys.stderr)


def _say(args: argparse.Namespace, text: object) -> None:
    """One line on standard error, ``clearance-pin: MODEL: text`` (the model named once); a
    character that standard error cannot encode (a lone surrogate of an undecodable file name)
    is written as a backslash escape."""
    line = " ".join(str(text).splitlines())
    model = getattr(args, "model", None)
    if model is not None and not line.startswith(str(model)):
        line = f"{model}: {line}"
    encoding = getattr(sys.stderr, "encoding", None) or "utf-8"
    line = line.encode(encoding, "backslashreplace").decode(encoding)
    print(f"clearance-pin: {line}", file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``clearance-pin``; returns the exit status (module docstring)."""
    args = build_parser().parse_args(argv)
    warnings.showwarning = _one_line_warnings
    try:
        _check_output_files(args)
        status: int = args.run(args)
        return status
    except UnboundedLoadError as exc:
        return _failed(args, exc, str(exc), NO_EQUILIBRIUM)
    except SolverError as exc:
        message = f"the solver did not reach a verified answer: {exc}"
        return _failed(args, exc, message, SOLVER_FAILED)
    except ClearancePinError as exc:
        return _failed(args, exc, str(exc), BAD_INPUT)
    except OSError as exc:  # a file written at the end (a full disk, a folder removed meanwhile)
        where = f"{exc.filename}: " if exc.filename else ""
        message = f"{where}cannot be read or written: {exc.strerror or exc}"
        return _failed(args, exc, message, BAD_INPUT)


def _failed(args: argparse.Namespace, error: Exception, message: str, status: int) -> int:
    """Say the failure (one line on standard error; with ``solve --json``, also the ``error``
    document on standard output) and return its exit status."""
    _say(args, message)
    if getattr(args, "json", None) is True:  # solve's --json prints its document on stdout
        model = getattr(args, "model", None)
        document = error_document(
            str(args.command), None if model is None else str(model), type(error).__name__,
            " ".join(message.splitlines()), status,
        )  # fmt: skip
        print(json.dumps(document, indent=2))
    return status


def _check_output_files(args: argparse.Namespace) -> None:
    """``--plot`` and ``--json`` FILE of any sub-command, before any work (a mistyped extension
    or folder found after a minute's sweep loses the minute), and none of them an input file
    (the model, the clearance file, accuracy's ``--configurations``)."""
    from .arguments import PLOT_FORMATS, check_not_an_input, check_output_file

    inputs = {
        "the model file": getattr(args, "model", None),
        "the clearance file": getattr(args, "clearances", None),
        "the --configurations file": getattr(args, "configurations", None),
    }
    for option, formats in (("plot", PLOT_FORMATS), ("json", ())):
        value = getattr(args, option, None)
        if isinstance(value, Path):  # solve's --json is a flag: the JSON goes to stdout
            check_not_an_input(f"--{option}", value, inputs)
            check_output_file(f"--{option}", value, formats)


if __name__ == "__main__":
    raise SystemExit(main())
