"""``clearance-pin accuracy MODEL``: where a robot's tool settles in its joint play, over poses and
payloads, and which joint moves it.

    clearance-pin accuracy models/arm_6r.urdf --output tool --payload 0 --payload 5 --plot a.png
    clearance-pin accuracy robot.urdf --clearances play.toml --output tool0 --poses 1000 --json a.json

Poses: ``--poses N`` random commands of the driven joints, uniform within ``--range`` of the
nominal pose (radians for revolute drives, metres for prismatic ones) and inside the joints'
limits (``--seed``), or ``--configurations FILE``: one q per line (whitespace- or
comma-separated, Pinocchio's order). Payloads: ``--payload KG`` (repeatable; a mass hung at the
output's origin, or at ``--payload-point X,Y,Z`` in the output frame [m], default 0 kg); the
robot's own weight with ``--gravity``. Prints the largest deviation and where, the largest reach
(the deviation plus every motion the load leaves free: a driven joint without load torque inside
its backlash, an unloaded axial play) and the free motions, per payload the largest and median,
and the joints ranked by their share; ``--json`` writes the summary in SI (add ``--poses-json``
for every pose's numbers), ``--csv`` one row per pose and payload, ``--plot`` the picture,
``--plot-workspace`` the deviation coloured on the tool's positions (two projections).
Exit status: 0, or as the other sub-commands (2 bad input, 3 a load along a free motion, 4 a
solver failure).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

from ..arguments import MOST_POSES, check_count, check_seed
from ..commands import (
    add_gravity_argument,
    add_json_argument,
    add_model_arguments,
    add_output_argument,
    gravity_option,
    model_options,
    say,
    write_json,
)
from ..errors import ArgumentError
from ..json_documents import ACCURACY_SCHEMA

UM = 1e6  # [um per m]

__all__ = ["add_arguments", "register", "run"]


def register(subparsers: Any) -> argparse.ArgumentParser:
    """Add the ``accuracy`` sub-command to ``subparsers`` (``add_subparsers()``'s result)."""
    parser: argparse.ArgumentParser = subparsers.add_parser(
        "accuracy", help="where a robot's tool settles in its play, over poses and payloads"
    )
    add_arguments(parser)
    parser.set_defaults(run=run)
    return parser


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of the ``accuracy`` sub-command."""
    add_model_arguments(parser, " (driven joints: the robot's drives)")
    add_output_argument(parser, "the tool", required=True)
    parser.add_argument(
        "--poses", type=int, default=200, help=f"random poses (default 200, at most {MOST_POSES})"
    )
    parser.add_argument(
        "--range",
        type=float,
        default=0.5,
        help="half-width of the random commands around the nominal pose [rad or m] (default 0.5)",
    )
    parser.add_argument("--seed", type=int, default=0, help="random poses' seed (default 0)")
    parser.add_argument(
        "--configurations", type=Path, metavar="FILE", help="poses q, one per line, instead"
    )
    parser.add_argument(
        "--payload",
        type=float,
        action="append",
        metavar="KG",
        help="a mass hung at the output [kg] (repeatable; default 0)",
    )
    parser.add_argument(
        "--payload-point",
        metavar="X,Y,Z",
        help="where the payload mass hangs, in the output frame [m] (default: its origin)",
    )
    add_gravity_argument(parser)
    parser.add_argument("--plot", type=Path, metavar="FILE", help="draw the map (PNG, ...)")
    parser.add_argument(
        "--plot-workspace",
        type=Path,
        metavar="FILE",
        help="the deviation and reach coloured on the tool's positions (PNG, ...)",
    )
    parser.add_argument(
        "--csv", type=Path, metavar="FILE", help="one row per pose and payload (SI)"
    )
    add_json_argument(parser, "the map's summary")
    parser.add_argument(
        "--poses-json", action="store_true", help="with --json: every pose's numbers too"
    )


def run(args: argparse.Namespace) -> int:
    """Run the sub-command; returns the exit status."""
    from .. import load

    check_count("--poses", args.poses, 1, MOST_POSES)  # before any work
    check_seed("--seed", args.seed)
    mechanism = load(args.model, **model_options(args))
    poses = (
        _read_configurations(args.configurations, mechanism.model.nq)
        if args.configurations
        else random_poses(mechanism, args.poses, args.range, args.seed)
    )
    amap = mechanism.accuracy(
        args.output,
        poses,
        payloads=args.payload or [0.0],
        gravity=gravity_option(args),
        payload_point=payload_point(args.payload_point),
    )
    say(args, loads_line(mechanism, args))
    say(args, table(amap))
    if args.plot:
        from .plot import plot_accuracy

        plot_accuracy(amap, mechanism, args.plot)
        say(args, f"plot written to {args.plot}")
    if args.plot_workspace:
        from .plot import plot_workspace

        plot_workspace(amap, mechanism, args.plot_workspace)
        say(args, f"workspace plot written to {args.plot_workspace}")
    if args.csv:
        amap.to_csv(args.csv, _q_names(mechanism))
        say(args, f"CSV written to {args.csv}")
    if args.json is not None:
        document = {
            "schema": ACCURACY_SCHEMA,
            "model": str(args.model),
            **amap.to_dict(poses=args.poses_json),
        }
        write_json(args, document)
    return 0


def loads_line(mechanism: Any, args: argparse.Namespace) -> str:
    """What loads the map: the payloads at the output, not the file's loads, and the robot's
    own weight on or off and why (an unloaded robot at 0 kg does not move: say so)."""
    chosen = gravity_option(args)
    weight = chosen if chosen is not None else mechanism.gravity is not None
    why = "--gravity" if chosen is not None else "the model file's setting; --gravity on|off"
    payloads = ", ".join(f"{m:g}" for m in (args.payload or [0.0]))
    return (
        f"loads: payloads {payloads} kg at the output (the model file's own loads are not "
        f"applied); the robot's own weight {'on' if weight else 'off'} ({why})"
        + ("" if weight or any(args.payload or []) else ": nothing loads it, it stays at 0 um")
    )


def payload_point(text: str | None) -> list[float] | None:
    """``--payload-point X,Y,Z`` [m] as three numbers (None: not given)."""
    if text is None:
        return None
    parts = text.replace(" ", "").split(",")
    try:
        values = [float(part) for part in parts]
    except ValueError:
        values = []
    if len(values) != 3 or not all(np.isfinite(values)):
        raise ArgumentError("--payload-point", "three numbers X,Y,Z [m] in the output frame", text)
    return values


def _q_names(mechanism: Any) -> list[str]:
    """A name per coordinate of q: the joint's, with its index when it has several."""
    model = mechanism.model
    names: list[str] = []
    for joint in range(1, model.njoints):
        size = model.joints[joint].nq
        name = model.names[joint]
        names += [name] if size == 1 else [f"{name}[{k}]" for k in range(size)]
    return names


def random_poses(mechanism: Any, count: int, half_range: float, seed: int) -> np.ndarray:
    """``count`` poses: each driven joint's command uniform within ``half_range`` [rad or m] of
    its nominal value and inside its limits; the other coordinates nominal (a locked joint's
    too: a pose may not move it off its lock)."""
    if count < 1:
        raise ArgumentError("--poses", "at least 1", count)
    if not half_range >= 0.0:
        raise ArgumentError("--range", "a half-width >= 0 [rad or m]", half_range)
    model = mechanism.model
    poses = np.tile(mechanism.q_nominal, (count, 1))
    rng = np.random.default_rng(seed)
    for joint in mechanism.tree_joints:
        if not joint.driven or joint.locked or model.joints[joint.joint_id].nq != 1:
            continue
        index = model.joints[joint.joint_id].idx_q
        low = max(model.lowerPositionLimit[index], poses[0, index] - half_range)
        high = min(model.upperPositionLimit[index], poses[0, index] + half_range)
        poses[:, index] = rng.uniform(low, high, count) if high > low else poses[0, index]
    return poses


def _read_configurations(path: Path, nq: int) -> np.ndarray:
    try:
        text = path.read_text()
    except OSError as error:
        raise ArgumentError("--configurations", "a readable file", f"{path} ({error})") from None
    rows = [line.replace(",", " ").split() for line in text.splitlines()]
    rows = [row for row in rows if row and not row[0].startswith("#")]
    try:
        poses = np.array([[float(value) for value in row] for row in rows])
    except ValueError:
        raise ArgumentError("--configurations", f"{nq} numbers per line", path) from None
    if poses.ndim != 2 or poses.shape[1] != nq:
        raise ArgumentError(
            "--configurations", f"{nq} numbers per line (q, Pinocchio's order)", path
        )
    return poses


def table(amap: Any) -> str:
    """The engineer's summary: the largest deviation and where, per payload, the joints ranked."""
    largest, pose, payload = amap.largest()
    norms = np.linalg.norm(amap.translation, axis=2) * UM
    lines = [
        f"{amap.output}: {amap.configurations.shape[0]} poses x {len(amap.payloads)} payloads, "
        f"all verified: {'yes' if amap.ok.all() else 'NO'}",
        f"largest deviation {largest * UM:.2f} um (pose {pose}, payload {amap.payloads[payload]})",
        f"{'payload':>12}  {'largest [um]':>12}  {'median [um]':>12}  {'largest turn [urad]':>19}"
        f"  {'largest reach [um]':>18}",
    ]
    for k, label in enumerate(amap.payloads):
        turn = np.nanmax(np.linalg.norm(amap.rotation[:, k], axis=1)) * UM
        column = amap.reach[:, k] if amap.reach is not None else np.full(1, np.nan)
        reach = f"{np.nanmax(column) * UM:18.2f}" if np.isfinite(column).any() else f"{'-':>18}"
        lines.append(
            f"{label:>12}  {np.nanmax(norms[:, k]):12.2f}  {np.nanmedian(norms[:, k]):12.2f}  "
            f"{turn:19.2f}  {reach}"
        )
    reach, at, case = amap.largest_reach()
    if np.isfinite(reach):
        free = ", ".join(amap.responsible(at, case)) or "none"
        lines.insert(
            2,
            f"largest reach {reach * UM:.2f} um (pose {at}, payload {amap.payloads[case]}): "
            f"the deviation plus the motions its load leaves free ({free})",
        )
        if amap.free_spread is not None:
            spread = np.nanmax(amap.free_spread) * UM
            lines.insert(3, f"the free motions alone move it up to {spread:.2f} um")
        lines.append("free motions (no load holds them; the output may sit anywhere in them):")
        total = amap.ok.size
        for name, mask in amap.free_motions.items():
            lines.append(f"  {name:<36} in {int(mask.sum())} of {total} cases")
    else:
        lines.insert(2, "reach: not computed (loop joints, couplings or joints not independent)")
    lines.append("what moves the output most (largest share over the map):")
    ranking = amap.ranking()
    width = max((len(source) for source, _, _ in ranking), default=0)  # the column fits them
    for source, joint, value in ranking:
        lines.append(f"  {joint:<24} {source:<{width}} {value * UM:10.2f} um")
    return "\n".join(lines)
