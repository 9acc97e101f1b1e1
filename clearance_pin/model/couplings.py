r"""Coupled joints: a follower driven through its leader (a URDF ``<mimic>``).

A follower's value is :math:`q_f = m\, q_l + o` (multiplier m, offset o, URDF defaults 1 and 0), as
a gear pair, a rack and pinion or a tendon sets it. The coupling ties the *actual* joint values.
A driven leader's follower is held through the leader's drive: whatever moves the leader inside
its drive (its backlash, its drive's deflection) moves the follower m times as much, and the
follower's own ``backlash`` and drive stiffness sit in series in the coupling (its deadband and
its compliance). In the small-displacement model the follower's motion about (along) its axis is

.. math::  \delta q_f = m\, \delta q_l + \beta_f + e_f ,

:math:`\delta q_l` the leader's whole motion (its own :math:`\beta_l + e_l`, plus m times its own
leader's for a chain), :math:`\beta_f` the follower's deadband (:math:`|\beta_f| \le b_f / 2`),
:math:`e_f` its deflection: a term of the follower's joint torsor, so every engine reads it where
it reads the tree's kinematics (:func:`coupled_motions`). Statics (virtual work): the follower's
deadband, or the coupling when it has none, holds :math:`\mu_f`, minus the generalised force of
the loads on :math:`q_f` plus what the follower's own followers take; the leader's drive holds
its own joint's torque plus :math:`m \mu_f`. The motor of a chain's root carries
:math:`\sum_j (\prod m)\, \tau_j` over every joint it moves (:func:`chain_multipliers`).

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
from .stiffness import elastic


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


def driven(couplings: Iterable[Coupling], joints: Mapping[str, Any]) -> tuple[Coupling, ...]:
    """The couplings whose leader is driven, leaders before their followers (a chain's links in
    order; :func:`coupling_cycle` has refused cycles)."""
    return tuple(c for c in in_order(couplings) if joints[c.leader].driven)


def leader_springs(couplings: Iterable[Coupling], joints: Mapping[str, Any]) -> bool:
    """Whether a driven leader's drive has a spring (its deflection carries its followers'
    torques besides its own joint's, so a spring's deflection is not its joint's reaction
    over its stiffness, :mod:`clearance_pin.equilibrium.elastic_tree`)."""
    return any(_drive_spring(joints[c.leader]) for c in driven(couplings, joints))


def leader_stops(couplings: Iterable[Coupling], joints: Mapping[str, Any]) -> bool:
    """Whether a driven leader has backlash (its stop holds its motor's torque, its joint's own
    and what it passes to its followers: a reaction split must know the coupling)."""
    return any(joints[c.leader].clearance.backlash for c in driven(couplings, joints))


def _drive_spring(joint: Any) -> bool:
    directions, _ = elastic(joint.clearance)
    return bool(joint.motion_component is not None and np.any(directions[joint.motion_component]))


def in_order(couplings: Iterable[Coupling]) -> tuple[Coupling, ...]:
    """The couplings with every leader's own coupling before its followers' (a chain's links in
    order; a cycle, refused by name when the model is read (:func:`coupling_cycle`), is a
    ModelError here too)."""
    left = list(couplings)
    followers = {c.follower for c in left}
    ordered: list[Coupling] = []
    placed: set[str] = set()
    while left:
        ready = [c for c in left if c.leader not in followers or c.leader in placed]
        if not ready:
            cycle = " -> ".join(c.follower for c in left)
            raise ModelError("<couplings>", "<mimic>", f"the couplings of {cycle} form a cycle")
        ordered.extend(ready)
        placed.update(c.follower for c in ready)
        left = [c for c in left if c not in ready]
    return tuple(ordered)


def coupling_cycle(couplings: Iterable[Coupling]) -> tuple[str, ...]:
    """The joints of a cycle of couplings (a joint following itself, or j2 following j3 following
    j2), in order; empty when there is none."""
    leader_of = {c.follower: c.leader for c in couplings}
    for start in leader_of:
        path = [start]
        while path[-1] in leader_of:
            following = leader_of[path[-1]]
            if following in path:
                return tuple(path[path.index(following) :])
            path.append(following)
    return ()


def coupled_motions(
    torsors: Mapping[str, np.ndarray], couplings: tuple[Coupling, ...], joints: Mapping[str, Any]
) -> dict[str, np.ndarray]:
    r"""Per follower of a driven leader (``couplings`` from :func:`driven`), its joint torsor map
    (6, n) with the coupled motion added: row ``motion_component`` gains m times the leader's
    whole motion row, :math:`\delta q_f = m\, \delta q_l + \beta_f + e_f` (module docstring),
    chains in order. ``torsors``: per tree joint, its own motion map x -> torsor (6, n)."""
    total = dict(torsors)
    for coupling in couplings:
        follower, leader = joints[coupling.follower], joints[coupling.leader]
        turned = total[follower.name].copy()
        turned[follower.motion_component] += (
            coupling.multiplier * total[leader.name][leader.motion_component]
        )
        total[follower.name] = turned
    return {c.follower: total[c.follower] for c in couplings}


def chain_multipliers(
    couplings: Iterable[Coupling], joints: Mapping[str, Any]
) -> dict[str, tuple[str, float]]:
    r"""Per follower of a driven leader: (the motor at its chain's root, the product of the
    multipliers from it) [1]: its joint's torque reaches that motor times the product (virtual
    work of :math:`q_f = m_1 m_2 \cdots\, q_{root} + \ldots`)."""
    held = driven(couplings, joints)
    root: dict[str, tuple[str, float]] = {}
    for c in held:  # leaders before followers
        motor, factor = root.get(c.leader, (c.leader, 1.0))
        root[c.follower] = (motor, factor * c.multiplier)
    return root


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
    for coupling in in_order(couplings):  # a chain's leaders first
        leader = model.joints[model.getJointId(coupling.leader)].idx_q
        follower = model.joints[model.getJointId(coupling.follower)].idx_q
        q[follower] = coupling.multiplier * q[leader] + coupling.offset
    return q


__all__ = [
    "Coupling",
    "chain_multipliers",
    "coupled",
    "coupled_joint",
    "coupled_motions",
    "coupling_cycle",
    "driven",
    "in_order",
    "leader_springs",
    "leader_stops",
    "passive",
    "urdf_couplings",
]
