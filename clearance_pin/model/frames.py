"""Pinocchio frames by name, when a URDF gives a joint and a link the same name.

Vendor URDFs often name a joint after the link it carries (``wrist_2`` joint, ``wrist_2`` link);
Pinocchio then holds two frames of that name, and ``Model.getFrameId(name)`` refuses to choose.
A name given by a user means the link (the part) when both exist.
"""

from __future__ import annotations

import pinocchio as pin


def frame_id(model: pin.Model, name: str) -> int | None:
    """The id of the frame called ``name``: the link (BODY frame) when several frames share the
    name, else the only one; None when there is none."""
    found = [i for i, frame in enumerate(model.frames) if frame.name == name]
    if len(found) > 1:
        links = [i for i in found if model.frames[i].type == pin.FrameType.BODY]
        return links[0] if links else found[0]
    return found[0] if found else None


__all__ = ["frame_id"]
