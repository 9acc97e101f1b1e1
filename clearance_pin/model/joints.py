"""Joints of a mechanism: tree joints (Pinocchio joints) and loop joints (cut joints).

The kinematic tree is the ``pin.Model`` built from the URDF. A *tree joint* is one of its joints,
with a clearance kind (ideal when the file gives none). A *loop joint* closes a kinematic loop: it
joins two frames, ``frame_a`` on one body and ``frame_b`` on another, that coincide at the nominal
configuration (the convention of Pinocchio's closed-loop tooling: the loop is cut into a tree and
the cut is named by its two frames).

Frames (one convention everywhere, Pinocchio's): ``oM_x`` is the placement of frame x in the world;
``jointM_clearance`` is the clearance frame in the Pinocchio joint frame; its x axis is the joint axis.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .clearance import ALPHA, Clearance, U


@dataclass(frozen=True)
class TreeJoint:
    """A joint of the Pinocchio tree with its clearance.

    Attributes:
        name: joint name (as in the URDF).
        joint_id: index in ``pin.Model.joints``.
        clearance: the clearance kind and dimensions.
        rotation: rotation of the clearance frame in the Pinocchio joint frame, shape (3, 3).
        motion_component: torsor component that the URDF joint moves (``ALPHA`` for revolute and
            continuous joints, ``U`` for prismatic ones, None for floating joints).
        driven: the joint's own motion is locked (an actuated joint held by its drive).
        locked: a ``<lock>`` holds it at its nominal value (a rigid joint the study leaves out):
            a configuration giving it another value is refused.
    """

    name: str
    joint_id: int
    clearance: Clearance
    rotation: np.ndarray
    motion_component: int | None
    driven: bool
    locked: bool = False

    @property
    def locked_components(self) -> tuple[int, ...]:
        """Free components that the drive locks (none with backlash: its contact bounds the
        motion instead)."""
        if self.driven and self.motion_component is not None and not self.clearance.backlash:
            return (self.motion_component,)
        return ()


@dataclass(frozen=True)
class LoopJoint:
    """A cut joint closing a kinematic loop between two frames.

    Attributes:
        name: joint name, unique among all joints.
        frame_a: Pinocchio frame id on the parent side (the clearance frame hangs on it).
        frame_b: Pinocchio frame id on the child side.
        clearance: the clearance kind and dimensions.
        rotation: rotation of the clearance frame in ``frame_a``, shape (3, 3).
    """

    name: str
    frame_a: int
    frame_b: int
    clearance: Clearance
    rotation: np.ndarray


def rotation_x_to(axis: np.ndarray) -> np.ndarray:
    """Smallest rotation taking the unit x axis onto ``axis`` (a rotation about x + pi for -x).

    Args:
        axis: direction, shape (3,), any nonzero length.

    Returns:
        rotation matrix (3, 3) whose first column is ``axis / |axis|``.
    """
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    if a[0] < 0.0:
        # near -x the formula below loses accuracy as 1 / (1 + c): turn half a revolution about
        # z first, then take the small rotation from x to the turned axis
        half_turn = np.diag([-1.0, -1.0, 1.0])
        turned: np.ndarray = half_turn @ _small_rotation_x_to(half_turn @ a)
        return turned
    return _small_rotation_x_to(a)


def _small_rotation_x_to(a: np.ndarray) -> np.ndarray:
    """Rodrigues rotation taking x onto the unit vector ``a`` with a[0] >= 0 (well conditioned)."""
    c = float(a[0])
    k = np.array([0.0, -a[2], a[1]])  # x cross a
    kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    rotation: np.ndarray = np.eye(3) + kx + kx @ kx / (1.0 + c)
    return rotation


MOTION_COMPONENT_BY_PIN_JOINT = {
    "JointModelRX": ALPHA,
    "JointModelRY": ALPHA,
    "JointModelRZ": ALPHA,
    "JointModelRevoluteUnaligned": ALPHA,
    "JointModelRUBX": ALPHA,
    "JointModelRUBY": ALPHA,
    "JointModelRUBZ": ALPHA,
    "JointModelRevoluteUnboundedUnaligned": ALPHA,
    "JointModelPX": U,
    "JointModelPY": U,
    "JointModelPZ": U,
    "JointModelPrismaticUnaligned": U,
    "JointModelFreeFlyer": None,
}
