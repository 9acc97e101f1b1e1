r"""Coupled joints: a follower driven through its leader (a URDF ``<mimic>``).

A follower's value is :math:`q_f = m\, q_l + o` (multiplier m, offset o, URDF defaults 1 and 0), as
a gear pair, a rack and pinion or a tendon sets it. clearance_pin holds a follower through its
leader's drive: the leader must be driven, and the follower is then held at :math:`m q_l + o` as a
driven joint (its own bearing play, if any, still acts; a ``backlash`` on the follower is the
coupling's deadband). The torque the coupling holds on the follower is its reported drive torque;
the leader's motor carries :math:`m` times it besides its own (virtual work of the coupling:
:math:`\tau_l\, \delta q_l + \tau_f\, m\, \delta q_l`).

A passive leader (not driven) leaves both joints free but tied: the coupling is the condition
:math:`\delta q_f = m\, \delta q_l` on their motions (a closure equation of the
small-displacement model, :mod:`clearance_pin.equilibrium.reduction`), its reaction a torque
:math:`\mu` on the follower and :math:`-m\mu` on the leader (a gear mesh's).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin

from ..errors import ModelError
from .joints import LoopJoint, TreeJoint


@dataclass(frozen=True)
class Coupling:
    """One follower joint set by its leader: ``q[follower] = multiplier * q[leader] + offset``
    [rad or m]."""

    follower: str
    leader: str
    multiplier: float = 1.0
    offset: float = 0.0
    from_drawn: bool = False  # MJCF: q_f - q0_f = offset + multiplier (q_l - q0_l), q0 = qpos0

    def absolute(self, model: pin.Model, drawn: np.ndarray) -> Coupling:
        """The coupling on Pinocchio's q itself: an MJCF one (``from_drawn``) holds about the
        drawn configuration ``drawn`` (MuJoCo's qpos0, each joint at its ref)."""
        if not self.from_drawn:
            return self
        leader = drawn[model.joints[model.getJointId(self.leader)].idx_q]
        follower = drawn[model.joints[model.getJointId(self.follower)].idx_q]
        offset = self.offset + follower - self.multiplier * leader
        return Coupling(self.follower, self.leader, self.multiplier, float(offset))


def passive(couplings: Iterable[Coupling], joints: Mapping[str, Any]) -> tuple[Coupling, ...]:
    """The couplings whose leader is not driven (joint name -> TreeJoint ``joints``)."""
    return tuple(c for c in couplings if not joints[c.leader].driven)


def coupled_joint(joints: Mapping[str, TreeJoint | LoopJoint], name: str) -> TreeJoint:
    """The joint ``name`` of a coupling, in ``joints`` (joint name -> joint): a tree joint, as
    couplings join the model's joints."""
    joint = joints[name]
    assert isinstance(joint, TreeJoint)  # couplings are read from the model's (tree) joints
    return joint


def urdf_couplings(source: str, joints: Iterable[ET.Element]) -> tuple[Coupling, ...]:
    """The ``<mimic joint= multiplier= offset=>`` elements of a URDF's joints."""
    couplings = []
    for element in joints:
        mimic = element.find("mimic")
        if mimic is None:
            continue
        label = f"<joint name='{element.get('name')}'> <mimic>"
        leader = mimic.get("joint")
        if not leader:
            raise ModelError(source, label, "names no joint to follow (joint='...')")
        values = []
        for attribute, default in (("multiplier", 1.0), ("offset", 0.0)):
            text = mimic.get(attribute)
            try:
                value = default if text is None else float(text)
            except ValueError:
                raise ModelError(source, label, f"{attribute}={text!r} is not a number") from None
            if not np.isfinite(value):
                raise ModelError(source, label, f"{attribute}={text!r} is not finite")
            values.append(value)
        couplings.append(Coupling(str(element.get("name")), leader, values[0], values[1]))
    return tuple(couplings)


def coupled(model: pin.Model, couplings: tuple[Coupling, ...], q: np.ndarray) -> np.ndarray:
    """``q`` with every follower set from its leader (a copy; ``q`` itself when none)."""
    if not couplings:
        return q
    q = np.array(q, dtype=float)
    for coupling in couplings:
        leader = model.joints[model.getJointId(coupling.leader)].idx_q
        follower = model.joints[model.getJointId(coupling.follower)].idx_q
        q[follower] = coupling.multiplier * q[leader] + coupling.offset
    return q


__all__ = ["Coupling", "coupled", "coupled_joint", "passive", "urdf_couplings"]
