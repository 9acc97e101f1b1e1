r"""The two clearance frames of every joint at a solved pose (world placements, Pinocchio's ``oM``).

A joint's clearance frame exists twice: carried by the parent part (the bore, the socket, the guide)
and by the child part (the journal, the ball, the block). They coincide at the nominal
configuration; at the solved pose their relative placement is the joint's finite relative motion.

- tree joint k (child body k, parent body p, clearance rotation :math:`C_k`):

  .. math::  oM_{parent} = oM_p\; (oM_p^0)^{-1}\, oM_k^0\; C_k, \qquad oM_{child} = oM_k\; C_k

  (the child's nominal frame carried along with the parent; :math:`oM^0` nominal placements);
- loop joint between frames a and b: :math:`oM_{parent} = oM_a\; aM_c`,
  :math:`oM_{child} = oM_b\; bM_c` (``Configuration.aMc``, ``Configuration.bMc``: the zone sits
  where the child part is, :mod:`clearance_pin.kinematics.loop_frames`).

:math:`oM_p, oM_k` are ``Equilibrium.body_placements``, :math:`oM_a = oM_{j(a)}\; jM_a` with
:math:`jM_a` the frame's placement in its Pinocchio joint.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, cast

import pinocchio as pin

from ..equilibrium.poses import ClearanceFrames, clearance_frames

if TYPE_CHECKING:
    from ..equilibrium.result import Equilibrium
    from ..model.mechanism_parts import MechanismParts as Mechanism

__all__ = ["ClearanceFrames", "clearance_frames", "joint_links", "solved_mechanism"]


def solved_mechanism(equilibrium: Equilibrium) -> Mechanism:
    """The mechanism ``equilibrium`` was solved on (``Equilibrium.mechanism``, declared
    ``object``; a check needs it, :func:`~clearance_pin.check.check_equilibrium` refuses None)."""
    return cast("Mechanism", equilibrium.mechanism)


def joint_links(mechanism: Mechanism, name: str) -> tuple[int, int]:
    """Frame ids of the parent link and the child link (BODY frames) that a joint joins.

    Tree joint: the link the URDF joint hangs from and the link it carries; loop joint: the links
    holding ``frame_a`` and ``frame_b`` (the frames themselves when they are links).
    """
    model = mechanism.model
    joint = mechanism.joint(name)
    if hasattr(joint, "frame_a"):
        return _link_of(model, joint.frame_a), _link_of(model, joint.frame_b)
    joint_frame = model.getFrameId(joint.name, pin.FrameType.JOINT)
    parent = _link_of(model, model.frames[joint_frame].parentFrame)
    child = next(
        i
        for i, f in enumerate(model.frames)
        if f.type == pin.FrameType.BODY and f.parentFrame == joint_frame
    )
    return parent, child


def _link_of(model: pin.Model, frame_id: int) -> int:
    while model.frames[frame_id].type != pin.FrameType.BODY and frame_id != 0:
        frame_id = model.frames[frame_id].parentFrame
    return frame_id


__all__ = ["ClearanceFrames", "clearance_frames", "joint_links", "solved_mechanism"]
