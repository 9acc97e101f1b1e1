r"""Output points of a solve: where a user reads how far the mechanism moved.

An output is a point with an orientation carried by one part (Pinocchio body ``b``): a Pinocchio
frame's origin and axes, or the application point of a :class:`~clearance_pin.PointForce` (axes
of its link). Its world displacement, with :math:`oM_{o0} = oM_{b0}\, bM_o` its nominal placement:

- small-displacement model, from the body twist :math:`\xi_b = (v_b, \omega_b)` at the world
  origin: translation :math:`v_b + \omega_b \times p_{o0}` [m], rotation :math:`\omega_b` [rad];
- exact model, from the body's finite placement :math:`oM_b`: translation
  :math:`p_o - p_{o0}` [m], rotation :math:`\log_3(R_o R_{o0}^T)` [rad] (world axes).

The default outputs are the loaded points (and the links carrying a pure torque) plus the leaf
links: the links that carry no child joint (fixed joints included), the end of every chain.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin

from ..errors import ArgumentError
from ..model.frames import frame_id, parse_point, point_name
from ..model.loads import PointForce, Torque
from ..numerics import LARGEST_MAGNITUDE


@dataclass(frozen=True)
class OutputPoint:
    """A point of one part whose world displacement is reported.

    Attributes:
        name: a Pinocchio frame name, or ``link@[x y z]`` for a load's point (in the link frame).
        body: Pinocchio joint index of the part carrying it.
        placement: its placement in that body's joint frame (pin.SE3).
    """

    name: str
    body: int
    placement: pin.SE3


def leaf_links(model: pin.Model) -> tuple[str, ...]:
    """Links (BODY frames) that no joint frame (moving or fixed) hangs from, off the ground."""
    parents = {
        f.parentFrame
        for f in model.frames
        if f.type in (pin.FrameType.JOINT, pin.FrameType.FIXED_JOINT)
    }
    return tuple(
        f.name
        for i, f in enumerate(model.frames)
        if f.type == pin.FrameType.BODY and i not in parents and f.parentJoint != 0
    )


def load_point_name(load: PointForce) -> str:
    """``link@[x y z]``: the name of a point force's application point (link frame, [m])."""
    return point_name(load.link, load.point)


def resolve_outputs(
    mechanism: Any, loads: Any = (), outputs: Any = None
) -> tuple[OutputPoint, ...]:
    """The output points of a solve: the loaded points, then ``outputs`` (Pinocchio frame names
    or points of links, ``link@[x y z]`` [m]; default: the leaf links). Raises ArgumentError
    naming an unknown frame and the valid ones.

    Kept per mechanism for the same loaded points and outputs (a planner re-solving with new load
    values asks for the same points every time)."""
    try:
        loaded: list[tuple[str, bytes | None]] = []
        for load in loads:
            if isinstance(load, PointForce):
                loaded.append((load.link, load.point.tobytes()))
            elif isinstance(load, Torque):
                loaded.append((load.link, None))
        key = (
            tuple(loaded),
            outputs if outputs is None or isinstance(outputs, str) else tuple(outputs),
        )
        hash(key)
    except TypeError:  # outputs of the wrong kind: refused, with its message, by _resolve
        return _resolve(mechanism, loads, outputs)
    kept = mechanism.cache.output_points
    points = kept.get(key)
    if points is None:
        points = _resolve(mechanism, loads, outputs)
        if len(kept) < 256:
            kept[key] = points
    resolved: tuple[OutputPoint, ...] = points
    return resolved


def _resolve(mechanism: Any, loads: Any, outputs: Any) -> tuple[OutputPoint, ...]:
    model = mechanism.model
    points: dict[str, OutputPoint] = {}
    for load in loads:
        if isinstance(load, (PointForce, Torque)) and load.link in mechanism.link_frames:
            frame = model.frames[mechanism.link_frames[load.link]]
            if frame.parentJoint == 0:
                continue  # the ground does not move
            if isinstance(load, PointForce):
                local = frame.placement * pin.SE3(np.eye(3), np.asarray(load.point, dtype=float))
                name = load_point_name(load)
            else:
                local, name = frame.placement, load.link
            points.setdefault(name, OutputPoint(name, frame.parentJoint, local))
    if outputs is None:
        names = leaf_links(model)
    elif isinstance(outputs, str) or not all(isinstance(n, str) for n in outputs):
        raise ArgumentError("outputs", "a list of Pinocchio frame names", outputs)
    else:
        names = tuple(outputs)
    valid = list(dict.fromkeys(f.name for f in model.frames))  # a link and a joint share names
    for index, name in enumerate(names):
        point = _link_point(mechanism, f"outputs[{index}]", name)
        if point is not None:  # link@[x y z]: a point of a link
            points.setdefault(point.name, point)
            continue
        if not model.existFrame(name):
            raise ArgumentError(
                f"outputs[{index}]",
                f"a frame of {mechanism.name!r} ({', '.join(valid)}) or a point of a link, "
                "link@[x y z] [m]",
                name,
            )
        frame = model.frames[frame_id(model, name)]
        same = [  # a frame at a loaded point is reported once: under the frame's name if asked
            key
            for key, p in points.items()
            if p.body == frame.parentJoint and p.placement.isApprox(frame.placement, 1e-12)
        ]
        output = OutputPoint(name, frame.parentJoint, frame.placement)
        if outputs is not None and same and "@" in same[0]:  # link@[x y z]: a PointForce's
            points = {(name if key == same[0] else key): p for key, p in points.items()}
            points[name] = output
        elif not same or outputs is not None:
            points.setdefault(name, output)
    return tuple(points.values())


def _link_point(mechanism: Any, argument: str, text: str) -> OutputPoint | None:
    """The output point ``link@[x y z]`` names ([m], the link's frame); None for a frame name.
    Raises ArgumentError for an unknown link, numbers that are not 3 finite ones, or a link of
    the ground (it does not move)."""
    parsed = parse_point(text)
    if parsed is None:
        return None
    link, local = parsed
    if link not in mechanism.link_frames:
        raise ArgumentError(
            argument, f"a link of {mechanism.name!r}: {', '.join(mechanism.link_frames)}", text
        )
    if local.shape != (3,) or not np.all(np.isfinite(local)):
        raise ArgumentError(argument, "link@[x y z]: 3 finite numbers [m], link frame", text)
    if float(np.abs(local).max()) > LARGEST_MAGNITUDE:  # its square would overflow
        raise ArgumentError(argument, f"a point within {LARGEST_MAGNITUDE:.0e} m", text)
    frame = mechanism.model.frames[mechanism.link_frames[link]]
    if frame.parentJoint == 0:
        raise ArgumentError(argument, "a point of a moving part", text, "it is on the ground")
    placement = frame.placement * pin.SE3(np.eye(3), local)
    return OutputPoint(point_name(link, local), frame.parentJoint, placement)


def output_displacements(
    equilibrium: Any, points: Any = None
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Name -> (translation (3,) [m], rotation (3,) [rad]), world axes, of every output point of
    ``equilibrium`` (see the module docstring for both formulations)."""
    points = equilibrium.output_points if points is None else points
    nominal = equilibrium.configuration.oMi
    displacements = {}
    for point in points:
        start = nominal[point.body] * point.placement
        if equilibrium.body_twists is not None:
            twist = equilibrium.body_twists[point.body]
            moved = twist[:3] + np.cross(twist[3:], start.translation)
            displacements[point.name] = (moved, twist[3:].copy())
        else:
            placed = equilibrium.body_placements[point.body] * point.placement
            displacements[point.name] = (
                placed.translation - start.translation,
                np.asarray(pin.log3(placed.rotation @ start.rotation.T)),
            )
    return displacements
