"""Model description: clearance kinds, joints, loads, toleranced dimensions, the model-file reader
(:func:`~.model_file.read_file`: a URDF with its block, or a URDF or MJCF file beside a clearance
file), the description of a ``pin.Model`` in memory (:func:`~.from_model.describe_model`);
:func:`clearance_pin.load` and :func:`clearance_pin.from_model` build the mechanism."""

from .clearance import KINDS, Clearance, ContactPoint
from .description import MechanismDescription
from .dimensions import Dimension
from .from_model import describe_model
from .joints import LoopJoint, TreeJoint
from .loads import Gravity, PointForce, Torque
from .model_file import read_file, read_text

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
    "describe_model",
]
