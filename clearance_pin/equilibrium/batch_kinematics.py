r"""Forward kinematics of many configurations at once (numpy, the joint types of URDF trees).

Pinocchio's recursion :math:`{}^oM_i = {}^oM_{\lambda(i)}\ {}^{\lambda(i)}M_i\ M_J(q)` (placement of
the joint in its parent, then the joint's own motion), vectorised over N configurations: per
joint a few (N, 3, 3) products instead of N calls. Joint motions, :math:`(R_J, p_J)`:

- revolute about the joint frame's x, y or z axis (RX, RY, RZ; unbounded RUB*, whose two
  coordinates are :math:`(\cos q, \sin q)`): :math:`R_J` the plane rotation, :math:`p_J = 0`, and
  :math:`{}^{\lambda(i)}M_i` formed first (its rotation column by column,
  :func:`_turned`), then composed with the parent's, in the order of operations of Pinocchio's
  own recursion (on the 6R arm and the UR5 the placements come out bitwise as Pinocchio's on
  Linux x86-64; not guaranteed elsewhere, they agree to round-off);
- revolute about an unaligned unit axis a: :math:`R_J = I + \sin q\, [a]_\times +
  (1 - \cos q)\, [a]_\times^2` (Rodrigues), :math:`p_J = 0`;
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

from ..numerics import Array

if TYPE_CHECKING:
    from ..model.mechanism_parts import MechanismParts as Mechanism

REVOLUTE = ("JointModelRX", "JointModelRY", "JointModelRZ", "JointModelRevoluteUnaligned")
UNBOUNDED = (
    "JointModelRUBX",
    "JointModelRUBY",
    "JointModelRUBZ",
    "JointModelRevoluteUnboundedUnaligned",
)
PRISMATIC = ("JointModelPX", "JointModelPY", "JointModelPZ", "JointModelPrismaticUnaligned")
QUATERNION = ("JointModelFreeFlyer", "JointModelSpherical")
ALIGNED = {  # revolute joints about their frame's own axis: that axis (x, y, z)
    "JointModelRX": 0,
    "JointModelRY": 1,
    "JointModelRZ": 2,
    "JointModelRUBX": 0,
    "JointModelRUBY": 1,
    "JointModelRUBZ": 2,
}

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


def _turned(placement: Array, angle_cos: Array, angle_sin: Array, name: str) -> Array:
    r""":math:`R_{placement} R_J` (N, 3, 3) for a rotation about the joint frame's own x, y or z
    axis (k) by angles given by (cos, sin) (N,): column k is the placement's, the two others
    :math:`c\, m_a + s\, m_b` and :math:`c\, m_b - s\, m_a` ((a, b, k) a cyclic order)."""
    k = ALIGNED[name]
    a, b = (k + 1) % 3, (k + 2) % 3
    c, s = angle_cos[:, None], angle_sin[:, None]
    local = np.empty((angle_cos.size, 3, 3))
    local[:, :, k] = placement[:, k]
    local[:, :, a] = c * placement[:, a] + s * placement[:, b]
    local[:, :, b] = c * placement[:, b] - s * placement[:, a]
    return local


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
        # Pinocchio's order: lambda(i)M_i = placement M_J(q) first, then oM_i = oM_parent lambda(i)M_i
        if name in ALIGNED:  # R_placement R_J column by column, as Pinocchio forms it
            if name in REVOLUTE:
                local = _turned(placed.rotation, np.cos(q[:, first]), np.sin(q[:, first]), name)
            else:
                local = _turned(placed.rotation, q[:, first], q[:, first + 1], name)
            rotations[:, i] = np.einsum("nij,njk->nik", above, local)
            translations[:, i] = translations[:, parent] + np.einsum(
                "nij,j->ni", above, placed.translation
            )
            continue
        if name in PRISMATIC:  # t_placement + (R_placement a) q, the rotation the placement's
            moved = placed.translation + (placed.rotation @ axis) * q[:, first, None]
            rotations[:, i] = np.einsum("nij,jk->nik", above, placed.rotation)
            translations[:, i] = translations[:, parent] + np.einsum("nij,nj->ni", above, moved)
            continue
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
