r"""Both clearance frames of every joint at a solved pose (parent side and child side).

For a tree joint the parent side is the child's nominal joint frame carried by the parent part,
:math:`oM_p\, (oM_{p0}^{-1} oM_{k0})\, C_k`, and the child side is :math:`oM_k C_k`; for a loop joint
they are :math:`oM_a\, {}^aM_c` and :math:`oM_b\, {}^bM_c` (``Configuration.aMc``,
``Configuration.bMc``: the zone sits where the child part is). The child frame in the parent frame
is the joint's finite relative motion, on which the contact conditions are written.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin

from ..errors import ArgumentError


@dataclass(frozen=True)
class ClearanceFrames:
    """Both clearance frames of one joint at the solved pose.

    Attributes:
        parent: world placement (pin.SE3) of the parent part's clearance frame.
        child: world placement (pin.SE3) of the child part's clearance frame.
        parent_body: Pinocchio joint index of the parent part.
        child_body: Pinocchio joint index of the child part.
    """

    parent: pin.SE3
    child: pin.SE3
    parent_body: int
    child_body: int

    @property
    def relative(self) -> pin.SE3:
        """The child's clearance frame in the parent's (the joint's finite relative motion)."""
        return self.parent.actInv(self.child)


def clearance_frames(equilibrium: Any) -> dict[str, ClearanceFrames]:
    """:class:`ClearanceFrames` of every joint (tree and loop) of ``equilibrium``'s mechanism."""
    mechanism = equilibrium.mechanism
    model = mechanism.model
    nominal = equilibrium.configuration
    placed = equilibrium.body_placements
    if len(placed) != model.njoints:
        raise ArgumentError(
            "body_placements", f"{model.njoints} placements (one per Pinocchio joint)", placed
        )
    frames = {}
    for joint in mechanism.tree_joints:
        k = joint.joint_id
        p = model.parents[k]
        clearance = pin.SE3(joint.rotation, np.zeros(3))
        carried = placed[p] * nominal.oMi[p].actInv(nominal.oMi[k]) * clearance
        frames[joint.name] = ClearanceFrames(carried, placed[k] * clearance, p, k)
    for loop in mechanism.loop_joints:
        frame_a, frame_b = model.frames[loop.frame_a], model.frames[loop.frame_b]
        side_a = placed[frame_a.parentJoint] * frame_a.placement * nominal.aMc[loop.name]
        side_b = placed[frame_b.parentJoint] * frame_b.placement * nominal.bMc[loop.name]
        frames[loop.name] = ClearanceFrames(
            side_a, side_b, frame_a.parentJoint, frame_b.parentJoint
        )
    return frames
