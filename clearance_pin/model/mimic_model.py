"""A ``pin.Model`` built with mimic joints (``buildModelFromUrdf(..., mimic=True)``) read as a
tree of ordinary joints and its couplings (:mod:`.couplings`).

Pinocchio's ``JointModelMimic`` has no configuration of its own: its motion is ``scaling`` times its
leader's, plus ``offset``. clearance_pin needs every joint's own motion (its play sits there), so
each mimic joint becomes the joint it mimics along (a revolute or prismatic joint about or along
the axis its motion takes, found from the model's own kinematics: the relative motion of its
frame per unit of its leader's, over ``scaling``) at the same placement, with the same body and
frames, and a :class:`~.couplings.Coupling` ``follower = scaling x leader + offset``: the model a
URDF gives with ``mimic=False``, plus its ``<mimic>`` elements.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin

from ..errors import ModelError
from .couplings import Coupling

PROBE = 1e-6  # [rad or m] the leader's step that reveals a mimic joint's axis


def without_mimic(
    model: pin.Model, source: str = "<model>"
) -> tuple[pin.Model, tuple[Coupling, ...]]:
    """(the model with its mimic joints as ordinary joints, their couplings); ``model`` itself
    and () when it has none."""
    mimicking = [
        j for j in range(1, model.njoints) if model.joints[j].shortname() == "JointModelMimic"
    ]
    if not mimicking:
        return model, ()
    leaders = dict(zip(model.mimicking_joints, model.mimicked_joints))
    tree = pin.Model()
    tree.name = model.name
    tree.gravity = model.gravity
    couplings = []
    for j in range(1, model.njoints):
        joint = model.joints[j]
        if j in mimicking:
            leader = int(leaders[j])
            mimic = joint.extract()
            kind = _own_joint(model, j, leader, float(mimic.scaling), source)
            low, high = _follower_range(model, leader, float(mimic.scaling), float(mimic.offset))
            limits = (np.full(1, np.inf), np.full(1, np.inf), np.array([low]), np.array([high]))
            couplings.append(
                Coupling(model.names[j], model.names[leader], float(mimic.scaling),
                         float(mimic.offset))
            )  # fmt: skip
        else:
            kind = joint
            q, v = (
                slice(joint.idx_q, joint.idx_q + joint.nq),
                slice(joint.idx_v, joint.idx_v + joint.nv),
            )
            limits = (
                model.effortLimit[v], model.velocityLimit[v],
                model.lowerPositionLimit[q], model.upperPositionLimit[q],
            )  # fmt: skip
        index = tree.addJoint(
            int(model.parents[j]), kind, model.jointPlacements[j], model.names[j], *limits
        )
        tree.appendBodyToJoint(index, model.inertias[j], pin.SE3.Identity())
    for frame in list(model.frames)[1:]:  # the same order: the same frame indices
        tree.addFrame(pin.Frame(frame))
    return tree, tuple(couplings)


def _own_joint(model: pin.Model, joint: int, leader: int, scaling: float, source: str) -> Any:
    """The revolute or prismatic joint whose motion the mimic joint ``joint`` makes: its axis
    from the relative motion of its frame when its leader moves by :data:`PROBE`."""
    data = model.createData()
    q = pin.neutral(model)
    pin.forwardKinematics(model, data, q)
    before = pin.SE3(data.liMi[joint])
    q[model.joints[leader].idx_q] += PROBE
    pin.forwardKinematics(model, data, q)
    motion = pin.log6(before.inverse() * pin.SE3(data.liMi[joint])).vector / (PROBE * scaling)
    linear, angular = np.linalg.norm(motion[:3]), np.linalg.norm(motion[3:])
    if abs(max(linear, angular) - 1.0) > 1e-6 or min(linear, angular) > 1e-6:
        raise ModelError(
            source,
            f"mimic joint {model.names[joint]!r}",
            "its motion is no revolute or prismatic joint's (clearance_pin reads mimic joints of "
            "those kinds)",
        )
    if angular > linear:
        return pin.JointModelRevoluteUnaligned(motion[3:] / angular)
    return pin.JointModelPrismaticUnaligned(motion[:3] / linear)


def _follower_range(
    model: pin.Model, leader: int, scaling: float, offset: float
) -> tuple[float, float]:
    """The follower's range: its leader's, mapped through the coupling."""
    index = model.joints[leader].idx_q
    ends = [scaling * model.lowerPositionLimit[index] + offset,
            scaling * model.upperPositionLimit[index] + offset]  # fmt: skip
    return float(min(ends)), float(max(ends))


def configuration_of(model: pin.Model, tree: pin.Model, q: np.ndarray) -> np.ndarray:
    """A configuration of the mimic ``model`` (nq,) as one of ``tree`` (its mimic joints as
    ordinary joints, :func:`without_mimic`): each joint's values by name, a follower's left at
    its neutral value (the couplings set it)."""
    out: np.ndarray = np.array(pin.neutral(tree), dtype=float)
    for j in range(1, model.njoints):
        joint = model.joints[j]
        if joint.nq and joint.shortname() != "JointModelMimic":
            target = tree.joints[tree.getJointId(model.names[j])]
            out[target.idx_q : target.idx_q + target.nq] = q[joint.idx_q : joint.idx_q + joint.nq]
    return out


__all__ = ["configuration_of", "without_mimic"]
