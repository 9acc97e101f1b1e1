"""Pinocchio frames by name, when a URDF gives a joint and a link the same name, and points of
links by name (``link@[x y z]``).

Vendor URDFs often name a joint after the link it carries (``wrist_2`` joint, ``wrist_2`` link);
Pinocchio then holds two frames of that name, and ``Model.getFrameId(name)`` refuses to choose.
A name given by a user means the link (the part) when both exist. A point of a link is named
``link@[x y z]`` ([m], the link's frame; commas or spaces between the numbers), everywhere an
output is named: solves, envelopes, accuracy maps, the command line.
"""

from __future__ import annotations

import re

import numpy as np
import pinocchio as pin

_POINT = re.compile(r"^\s*([^@\s]+)\s*@\s*\[([^\]]*)\]\s*$")


def frame_id(model: pin.Model, name: str) -> int | None:
    """The id of the frame called ``name``: the link (BODY frame) when several frames share the
    name, else the only one; None when there is none."""
    found = [i for i, frame in enumerate(model.frames) if frame.name == name]
    if len(found) > 1:
        links = [i for i in found if model.frames[i].type == pin.FrameType.BODY]
        return links[0] if links else found[0]
    return found[0] if found else None


def parse_point(text: str) -> tuple[str, np.ndarray] | None:
    """``"link@[x y z]"`` as (link, its numbers (k,) [m]); None for a text of another form (a
    frame's name). The numbers are not checked here: a caller wants 3 finite ones, and says so
    naming its argument (an empty array when one is not a number)."""
    match = _POINT.match(text)
    if match is None:
        return None
    try:
        numbers = [float(v) for v in match.group(2).replace(",", " ").split()]
    except ValueError:
        numbers = []
    return match.group(1), np.array(numbers, dtype=float)


def point_name(link: str, point: np.ndarray) -> str:
    """``link@[x y z]``, the numbers to 6 significant digits [m] (a load's point is named so)."""
    x, y, z = (float(c) for c in point)
    return f"{link}@[{x:.6g} {y:.6g} {z:.6g}]"


__all__ = ["frame_id", "parse_point", "point_name"]
