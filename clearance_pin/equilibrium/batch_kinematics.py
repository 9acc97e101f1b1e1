r"""Forward kinematics of many configurations at once (numpy, the joint types of URDF trees).

Pinocchio's recursion :math:`{}^oM_i = {}^oM_{\lambda(i)}\ {}^{\lambda(i)}M_i\ M_J(q)` (placement of
the joint in its parent, then the joint's own motion), vectorised over N configurations: per
joint a few (N, 3, 3) products instead of N calls. Joint motions, :math:`(R_J, p_J)`:

- revolute about a unit axis a (RX, RY, RZ, unaligned): :math:`R_J = I + \sin q\, [a]_\times +
  (1 - \cos q)\, [a]_\times^2` (Rodrigues), :math:`p_J = 0`; unbounded revolute (RUB*):
  :math:`(\cos q, \sin q)` read from its two coordinates;
- prismatic along a: :math:`R_J = I`, :math:`p_J = q\, a`;
- free flyer :math:`(p, x, y, z, w)` and spherical :math:`(x, y, z, w)`: the unit quaternion's
  rotation matrix.

Any other joint type (planar, translation, composite, mimic) falls back to Pinocchio, one
configuration after the other.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from .blocks import Array

if TYPE_CHECKING:
    from ..mechanism import Mechanism

REVOLUTE = ("JointModelRX", "JointModelRY", "JointModelRZ", "JointModelRevoluteUnaligned")
UNBOUNDED = (
    "JointModelRUBX",
    "JointModelRUBY",
    "JointModelRUBZ",
    "JointModelRevoluteUnboundedUnaligned",
)
PRISMATIC = ("JointModelPX", "JointModelPY", "JointModelPZ", "JointModelPrismaticUnaligned")
QUATERNION = ("JointModelFreeFlyer", "JointModelSpherical")

Plan = list[tuple[str, int, Array]]  # per joint 1..: (type, first coordinate, axis)


def _plan(model: pin.Model) -> Plan | None:
    """Per joint its type, first coordinate and axis; None when a type is not vectorised."""
    plan: Plan = []
    for i in range(1, model.njoints):
        joint = model.joints[i]
        name = joint.shortname()
        axis = np.zeros(3)
        if name in REVOLUTE + UNBOUNDED + PRISMATIC:
            data = joint.createData()
            joint.calc(data, pin.neutral(model))
            motion = np.asarray(data.S).reshape(6, -1)[:, 0]
            axis = motion[3:] if name not in PRISMATIC else motion[:3]
        elif name not in QUATERNION:
            return None
        plan.append((name, int(joint.idx_q), axis))
    return plan


def _rotations(angle_cos: Array, angle_sin: Array, axis: Array) -> Array:
    """Rodrigues' rotations (N, 3, 3) about a unit axis by angles given by (cos, sin) (N,)."""
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    rotations: Array = (
        np.eye(3)[None]
        + angle_sin[:, None, None] * k[None]
        + (1.0 - angle_cos)[:, None, None] * (k @ k)[None]
    )
    return rotations


def _quaternion(q: Array) -> Array:
    """Rotation matrices (N, 3, 3) of unit quaternions (N, 4) stored (x, y, z, w)."""
    x, y, z, w = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], axis=1),
            np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], axis=1),
            np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], axis=1),
        ],
        axis=1,
    )


def body_placements(mechanism: Mechanism, configurations: Sequence[Array]) -> tuple[Array, Array]:
    """World rotation (N, bodies, 3, 3) and translation (N, bodies, 3) of every Pinocchio joint
    frame at each configuration (row 0: the ground)."""
    model = mechanism.model
    plan = _plan(model)
    if plan is None:
        return _pinocchio_placements(mechanism, configurations)
    q = np.asarray(configurations, dtype=float).reshape(len(configurations), model.nq)
    count, bodies = q.shape[0], model.njoints
    rotations = np.empty((count, bodies, 3, 3))
    translations = np.empty((count, bodies, 3))
    rotations[:, 0] = np.eye(3)
    translations[:, 0] = 0.0
    for i, (name, first, axis) in enumerate(plan, start=1):
        parent = model.parents[i]
        placed = model.jointPlacements[i]
        above = rotations[:, parent]
        # products with a constant matrix as one (3 N, 3) product (numpy's broadcast is slow)
        rotation = (above.reshape(-1, 3) @ placed.rotation).reshape(count, 3, 3)
        origin = translations[:, parent] + (above.reshape(-1, 3) @ placed.translation).reshape(
            count, 3
        )
        if name in REVOLUTE:
            rotations[:, i] = rotation @ _rotations(np.cos(q[:, first]), np.sin(q[:, first]), axis)
            translations[:, i] = origin
        elif name in UNBOUNDED:
            rotations[:, i] = rotation @ _rotations(q[:, first], q[:, first + 1], axis)
            translations[:, i] = origin
        elif name in PRISMATIC:
            rotations[:, i] = rotation
            along = (rotation.reshape(-1, 3) @ axis).reshape(count, 3)
            translations[:, i] = origin + along * q[:, first, None]
        else:
            offset = 3 if name == "JointModelFreeFlyer" else 0
            turn = _quaternion(q[:, first + offset : first + offset + 4])
            rotations[:, i] = rotation @ turn
            moved = q[:, first : first + 3] if offset else np.zeros((count, 3))
            translations[:, i] = origin + (rotation @ moved[:, :, None])[:, :, 0]
    return rotations, translations


def _pinocchio_placements(
    mechanism: Mechanism, configurations: Sequence[Array]
) -> tuple[Array, Array]:
    """:func:`body_placements` by Pinocchio's forward kinematics, one configuration at a time."""
    model = mechanism.model
    data = mechanism.cache.data  # this thread's
    count, bodies = len(configurations), model.njoints
    rotations = np.empty((count, bodies, 3, 3))
    translations = np.empty((count, bodies, 3))
    rotations[:, 0] = np.eye(3)
    translations[:, 0] = 0.0
    for k, q in enumerate(configurations):
        pin.forwardKinematics(model, data, q)
        for i in range(1, bodies):
            placement = data.oMi[i]
            rotations[k, i] = placement.rotation
            translations[k, i] = placement.translation
    return rotations, translations


__all__ = ["body_placements"]
