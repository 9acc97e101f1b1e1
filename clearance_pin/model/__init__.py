"""Model description: clearance kinds, joints, loads, and the model-file reader."""

from .clearance import KINDS, Clearance, ContactPoint
from .joints import LoopJoint, TreeJoint
from .loads import Gravity, PointForce, Torque
from .model_file import load, loads

__all__ = [
    "KINDS",
    "Clearance",
    "ContactPoint",
    "LoopJoint",
    "TreeJoint",
    "Gravity",
    "PointForce",
    "Torque",
    "load",
    "loads",
]
