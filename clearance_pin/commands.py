"""What every sub-command of ``clearance-pin`` shares: the model arguments and the exit statuses.

Every sub-command reads its mechanism the same way: a URDF or MJCF file, its clearances in a
``<clearance_pin>`` block or beside it (``--clearances FILE``, XML or TOML), collision meshes
looked for under ``--package-dir`` (docs/model-format.md).
"""

from __future__ import annotations

import argparse
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


__all__ = [
    "BAD_INPUT",
    "KERNEL_UNAVAILABLE",
    "NO_EQUILIBRIUM",
    "OK",
    "OUT_OF_TOLERANCE",
    "SOLVER_FAILED",
    "add_model_arguments",
    "model_options",
]
