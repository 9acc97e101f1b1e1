"""What every sub-command of ``clearance-pin`` shares: one grammar, written once.

Every sub-command reads its mechanism the same way: a URDF or MJCF file, its clearances in a
``<clearance_pin>`` block or beside it (``--clearances FILE``, XML or TOML), collision meshes
looked for under ``--package-dir`` (docs/model-format.md). The options that mean the same thing
are spelt the same way everywhere:

- ``--json [FILE]``: the result as JSON into FILE, or on standard output without FILE (the
  document alone: no table);
- ``--gravity on|off``: the robot's or mechanism's own weight (default: the model file's);
- ``--output FRAME|LINK@[X Y Z]``: a Pinocchio frame, or a point of a link [m] in its frame.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

OK, OUT_OF_TOLERANCE, BAD_INPUT, NO_EQUILIBRIUM, SOLVER_FAILED, KERNEL_UNAVAILABLE = range(6)
"""The exit statuses (:mod:`clearance_pin.cli`'s docstring); KERNEL_UNAVAILABLE: ``compile``
found numba unable to compile or cache the kernel (:mod:`clearance_pin.compile_command`)."""


def add_model_arguments(parser: argparse.ArgumentParser, what: str = "") -> None:
    """The positional MODEL and ``--clearances``, ``--package-dir``; ``what``: what the
    sub-command needs of the model beyond its clearances (appended to MODEL's help)."""
    parser.add_argument(
        "model",
        type=Path,
        help="URDF or MJCF model file, its clearances in a <clearance_pin> block or in "
        f"--clearances FILE{what}",
    )
    parser.add_argument(
        "--clearances",
        type=Path,
        metavar="FILE",
        help="the clearances of an unmodified URDF or MJCF file: a <clearance_pin> XML file or "
        "its TOML form (docs/model-format.md)",
    )
    parser.add_argument(
        "--package-dir",
        action="append",
        type=Path,
        metavar="DIR",
        help="where meshes are looked for (package://PKG/FILE is DIR/PKG/FILE; repeatable; "
        "ROS_PACKAGE_PATH is searched too)",
    )


def model_options(args: argparse.Namespace) -> dict[str, Any]:
    """Keyword arguments of :func:`clearance_pin.load` from the command line."""
    return {"package_dirs": args.package_dir, "clearances": args.clearances}


#: ``--json`` without FILE (or ``--json -``): the document on standard output
STDOUT = Path("-")


def add_json_argument(parser: argparse.ArgumentParser, what: str) -> None:
    """``--json [FILE]``: ``what`` as JSON into FILE, or on standard output without FILE."""
    parser.add_argument(
        "--json",
        nargs="?",
        const=STDOUT,
        type=Path,
        metavar="FILE",
        help=f"{what} as JSON (SI) into FILE, or on standard output without FILE (then no table)",
    )


def json_on_stdout(args: argparse.Namespace) -> bool:
    """Whether the JSON document goes to standard output (``--json`` without FILE)."""
    return getattr(args, "json", None) == STDOUT


def say(args: argparse.Namespace, text: str) -> None:
    """Print what a person reads on standard output; nothing when standard output carries the
    JSON document (``--json`` without FILE: the document says it all; warnings and a non-zero
    exit's line still go to standard error)."""
    if not json_on_stdout(args):
        print(text)


def write_json(args: argparse.Namespace, document: dict[str, Any]) -> None:
    """The ``--json`` document: printed on standard output, or written to FILE (and said)."""
    text = json.dumps(document, indent=1)
    if json_on_stdout(args):
        print(text)
    elif args.json is not None:
        args.json.write_text(text)
        say(args, f"JSON written to {args.json}")


def add_gravity_argument(parser: argparse.ArgumentParser) -> None:
    """``--gravity on|off``: the mechanism's own weight (default: the model file's setting)."""
    parser.add_argument(
        "--gravity",
        choices=["on", "off"],
        help="the mechanism's own weight from the URDF inertials (default: the model file's "
        "setting, off unless the file switches it on)",
    )


def gravity_option(args: argparse.Namespace) -> bool | None:
    """``--gravity`` as the library's ``gravity=``: True, False, or None (the model's)."""
    value: bool | None = {"on": True, "off": False, None: None}[args.gravity]
    return value


def add_output_argument(
    parser: argparse.ArgumentParser, help_text: str, required: bool = False
) -> None:
    """``--output FRAME|LINK@[X Y Z]`` (repeatable unless ``required``: then one)."""
    parser.add_argument(
        "--output",
        action="store" if required else "append",
        required=required,
        metavar="FRAME|LINK@[X Y Z]",
        help=f"{help_text}: a Pinocchio frame, or a point of a link [m] in its frame",
    )


__all__ = [
    "BAD_INPUT",
    "KERNEL_UNAVAILABLE",
    "NO_EQUILIBRIUM",
    "OK",
    "OUT_OF_TOLERANCE",
    "SOLVER_FAILED",
    "STDOUT",
    "add_gravity_argument",
    "add_json_argument",
    "add_model_arguments",
    "add_output_argument",
    "gravity_option",
    "json_on_stdout",
    "model_options",
    "say",
    "write_json",
]
