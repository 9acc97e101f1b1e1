"""Model files generated from a few numbers: the shafts of Younes, Dal Santo & Potiron, section 6.

A shaft (one rigid part) is held on the ground by two joints in parallel. Joint I1 is the tree
joint (a URDF ``floating`` joint carrying the clearance kind); joint I2 is a loop joint between the
frames ``ground_I2`` and ``shaft_I2`` placed at its centre. The generated text is an ordinary model
file (docs/model-format.md), in SI units.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class JointSpec:
    """One joint of a shaft case, SI: kind, centre [m], diametral clearance J [m], length L [m]."""

    name: str
    kind: str
    center: tuple[float, float, float]
    diametral: float
    length: float = 0.0
    axis: tuple[float, float, float] = (1.0, 0.0, 0.0)


def _attributes(joint: JointSpec) -> str:
    text = f'type="{joint.kind}" diametral_clearance="{joint.diametral!r}"'
    if joint.length:
        text += f' length="{joint.length!r}"'
    text += ' axis="{} {} {}"'.format(*(repr(float(a)) for a in joint.axis))
    return text


def _xyz(vector: Iterable[float]) -> str:
    return " ".join(repr(float(v)) for v in vector)


def shaft_urdf(
    first: JointSpec,
    second: JointSpec,
    point: Sequence[float] | np.ndarray = (0.0, 0.0, 0.0),
    force: Sequence[float] | np.ndarray = (0.0, 0.0, 0.0),
    torque: Sequence[float] | np.ndarray = (0.0, 0.0, 0.0),
    name: str = "shaft",
) -> str:
    """URDF text of a shaft on two parallel joints with a force at ``point`` and a torque.

    Args:
        first: joint I1 (tree joint; its centre is the shaft frame's origin).
        second: joint I2 (loop joint).
        point: world point of the force [m]; force [N]; torque [N m] (world axes).
    """
    origin = np.asarray(first.center, dtype=float)
    relative = np.asarray(second.center, dtype=float) - origin
    local_point = np.asarray(point, dtype=float) - origin
    return f"""<?xml version="1.0"?>
<robot name="{name}">
  <link name="ground"/>
  <link name="shaft"/>
  <link name="ground_I2"/>
  <link name="shaft_I2"/>
  <joint name="{first.name}" type="floating">
    <parent link="ground"/><child link="shaft"/><origin xyz="{_xyz(origin)}"/>
  </joint>
  <joint name="ground_I2_mount" type="fixed">
    <parent link="ground"/><child link="ground_I2"/><origin xyz="{_xyz(second.center)}"/>
  </joint>
  <joint name="shaft_I2_mount" type="fixed">
    <parent link="shaft"/><child link="shaft_I2"/><origin xyz="{_xyz(relative)}"/>
  </joint>
  <clearance_pin>
    <joint name="{first.name}" {_attributes(first)}/>
    <loop_joint name="{second.name}" frame_a="ground_I2" frame_b="shaft_I2" {_attributes(second)}/>
    <force link="shaft" point="{_xyz(local_point)}" value="{_xyz(force)}"/>
    <torque link="shaft" value="{_xyz(torque)}"/>
  </clearance_pin>
</robot>
"""
