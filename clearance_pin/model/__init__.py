"""Model description: clearance kinds, joints, loads, toleranced dimensions, the model-file reader
(:func:`~.model_file.read_file`; :func:`clearance_pin.load` builds the mechanism)."""

from .clearance import KINDS, Clearance, ContactPoint
from .dimensions import Dimension
from .joints import LoopJoint, TreeJoint
from .loads import Gravity, PointForce, Torque
from .model_file import MechanismDescription, read_file, read_text

__all__ = [
    "KINDS",
    "Clearance",
    "ContactPoint",
    "LoopJoint",
    "TreeJoint",
    "Gravity",
    "PointForce",
    "Torque",
    "Dimension",
    "MechanismDescription",
    "read_file",
    "read_text",
]
