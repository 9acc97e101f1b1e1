r"""What each joint's torsor moves a frame: the additive split of a frame's small displacement.

With :math:`T_j = (v_j, \omega_j)` joint :math:`j`'s torsor in its clearance frame (axes
:math:`R_j`, origin the joint centre :math:`c_j`) and :math:`p` the frame's nominal origin, every
joint between the ground and the frame moves it by

.. math::  \delta p_j = R_j v_j + (R_j \omega_j) \times (p - c_j), \qquad
           \delta\theta_j = R_j \omega_j

(world axes), and the frame's displacement is their sum (first order in the rotations; exactly
the small-displacement model's). Placements from Pinocchio's forward kinematics of each pose.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

if TYPE_CHECKING:
    from ..model.joints import TreeJoint


def joint_levers(
    model: pin.Model,
    tree_joints: tuple[TreeJoint, ...],
    frame: int,
    poses: np.ndarray,
    point: np.ndarray | None = None,
) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Per tree joint between the ground and frame ``frame``: its clearance frame's axes R_j
    (Q, 3, 3) and the arm p - c_j from its centre to the frame's origin, or to ``point`` (3,)
    [m] in the frame, (Q, 3) [m], world axes, at each pose of ``poses`` (Q, nq); joints off that
    path move the frame by nothing and are left out."""
    data = model.createData()
    body = model.frames[frame].parentJoint
    chain = set()
    while body:
        chain.add(body)
        body = model.parents[body]
    joints = [joint for joint in tree_joints if joint.joint_id in chain]
    axes = {joint.name: np.zeros((len(poses), 3, 3)) for joint in joints}
    arms = {joint.name: np.zeros((len(poses), 3)) for joint in joints}
    for i, q in enumerate(poses):
        pin.forwardKinematics(model, data, q)
        placed = pin.updateFramePlacement(model, data, frame)
        at = placed.translation if point is None else placed.act(point)
        for joint in joints:
            axes[joint.name][i] = data.oMi[joint.joint_id].rotation @ joint.rotation
            arms[joint.name][i] = at - data.oMi[joint.joint_id].translation
    return {joint.name: (axes[joint.name], arms[joint.name]) for joint in joints}


def moved_by(
    axes: np.ndarray, arms: np.ndarray, torsors: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(translation (Q, 3) [m], rotation (Q, 3) [rad]) of the frame that torsors (Q, 6) [m, rad]
    of one joint give it, with that joint's :func:`joint_levers`."""
    turned = np.einsum("qab,qb->qa", axes, torsors[:, 3:])
    moved = np.einsum("qab,qb->qa", axes, torsors[:, :3]) + np.cross(turned, arms)
    return moved, turned


__all__ = ["joint_levers", "moved_by"]
