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
from ..model.frames import frame_id
from ..model.loads import PointForce, Torque


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
    x, y, z = (float(c) for c in load.point)
    return f"{load.link}@[{x:.6g} {y:.6g} {z:.6g}]"


def resolve_outputs(
    mechanism: Any, loads: Any = (), outputs: Any = None
) -> tuple[OutputPoint, ...]:
    """The output points of a solve: the loaded points, then ``outputs`` (Pinocchio frame names;
    default: the leaf links). Raises ArgumentError naming an unknown frame and the valid ones.

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
        if not model.existFrame(name):
            raise ArgumentError(
                f"outputs[{index}]", f"a frame of {mechanism.name!r}: {', '.join(valid)}", name
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
