"""The ``clearance-pin`` command.

    clearance-pin solve MODEL [--exact] [--check] [--output FRAME|LINK@[X Y Z] ...]
                        [--gravity on|off] [--json [FILE]] [--plot FILE]
    clearance-pin envelope MODEL [--output FRAME|LINK@[X Y Z] ...] [--json [FILE]] [--plot F]
    clearance-pin accuracy MODEL --output FRAME|LINK@[X Y Z] [--poses N] [--payload KG ...]
                           [--gravity on|off] [--json [FILE]] [--plot F]
    clearance-pin tolerance MODEL [--clearances FILE] ...   (``clearance-pin tolerance --help``)
    clearance-pin compile              (the compiled kernel of re-solves, once per machine)
    clearance-pin --version            (also: python -m clearance_pin ...)

MODEL is a URDF or MJCF file; every sub-command takes ``--clearances FILE`` (the clearances
beside an unmodified vendor file, XML or TOML) and ``--package-dir DIR`` (where meshes are).
The options that mean the same thing are spelt the same way (:mod:`clearance_pin.commands`):
``--json [FILE]``, ``--gravity on|off``, ``--output FRAME|LINK@[X Y Z]``.

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
    STDOUT,
    add_gravity_argument,
    add_json_argument,
    add_model_arguments,
    add_output_argument,
    gravity_option,
    json_on_stdout,
    model_options,
    say,
    write_json,
)
from .errors import ClearancePinError, SolverError, UnboundedLoadError
from .json_documents import error_document, solve_document

DESCRIPTION = """\
clearance-pin: where the parts of a mechanism or robot settle inside their joint play, drive
backlash and stiffness under load, and how far tolerances and play move its output. Every
sub-command reads a URDF or MJCF model with its clearances (a <clearance_pin> block, or
--clearances FILE beside an unmodified vendor file, XML or TOML: docs/model-format.md).

Shared options: --json [FILE] (the result as JSON into FILE, or on standard output without
FILE), --gravity on|off (the model's own weight; default: the model file's setting),
--output FRAME|LINK@[X Y Z] (a Pinocchio frame, or a point of a link [m] in its frame)."""

EPILOG = """\
exit status:
  0  done: a verified equilibrium (and, with --check, a check within its tolerances)
  1  out of tolerance: residuals or the coal check; tolerance: a --spec the worst case exceeds
  2  bad model, load or option (one line naming the file, element and problem)
  3  no equilibrium: the load drives a motion nothing blocks; envelope: an unbounded output
  4  the solver did not reach a verified answer (its status and residuals)
  5  compile: numba cannot compile or cache the kernel (NUMBA_CACHE_DIR)
Every non-zero status prints one line on standard error. Details: docs/cli.md."""


def _solve(args: argparse.Namespace) -> int:
    from .loading import load

    mechanism = load(args.model, **model_options(args))
    outputs = args.output or None
    equilibrium = mechanism.solve(exact=args.exact, gravity=gravity_option(args), outputs=outputs)
    # the check judges the real boundaries, on the exact pose; a linear answer's own departure
    # from them (its second-order error) is information (report.departure), not a failure
    report = equilibrium.check() if args.check else None
    if args.json is not None:
        write_json(args, solve_document(str(args.model), equilibrium, report))
    if not json_on_stdout(args):
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
        say(args, f"settled pose drawn in {args.plot}")
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

    parser = argparse.ArgumentParser(
        prog="clearance-pin",
        description=DESCRIPTION,
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"clearance-pin {__version__}")
    commands = parser.add_subparsers(dest="command", required=True, title="sub-commands",
                                     metavar="COMMAND")  # fmt: skip
    solve = commands.add_parser(
        "solve", help="where the parts settle in their joint play under the model's loads"
    )
    add_model_arguments(solve)
    solve.add_argument("--exact", action="store_true", help="also solve the exact model")
    add_json_argument(solve, "the equilibrium")
    solve.add_argument("--check", action="store_true", help="measure the pose with coal")
    add_gravity_argument(solve)
    solve.add_argument(
        "--plot",
        type=Path,
        metavar="FILE",
        help="draw the settled pose (nominal and settled skeleton, magnified; contacts and their "
        "forces; the plays to scale) into FILE (PNG, PDF, SVG; needs the plot extra)",
    )
    add_output_argument(
        solve,
        "an output whose world displacement is reported (repeatable; default: the loaded "
        "points and the leaf links)",
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
        tolerance = commands.add_parser(
            "tolerance", help="how far dimensional tolerances move the outputs (Flores)"
        )
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
    """Say the failure (one line on standard error; with ``--json`` on standard output, also
    the ``error`` document there) and return its exit status."""
    _say(args, message)
    if json_on_stdout(args):
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
        if isinstance(value, Path) and value != STDOUT:  # --json alone: standard output
            check_not_an_input(f"--{option}", value, inputs)
            check_output_file(f"--{option}", value, formats)


if __name__ == "__main__":
    raise SystemExit(main())
