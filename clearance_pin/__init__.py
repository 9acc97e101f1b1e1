"""clearance_pin: where mechanism parts settle inside their joint clearances, and how far
dimensional tolerances move a mechanism's output, on Pinocchio models.

Build once, solve many::

    import clearance_pin
    mechanism = clearance_pin.load("models/shaft_sphere_cylinder.urdf")
    equilibrium = mechanism.solve()              # small-displacement model [Y]
    equilibrium.torsor("I2")                     # (u, v, w, alpha, beta, gamma) [m, rad]
"""

from .equilibrium.result import Contact, Equilibrium
from .errors import (
    ArgumentError,
    ClearancePinError,
    ClearancePinWarning,
    ConditioningWarning,
    LoadError,
    ModelError,
    SolverError,
    SuspectValueWarning,
    UnboundedLoadError,
)
from .mechanism import Mechanism
from .model.loads import Gravity, PointForce, Torque
from .model.model_file import load, loads

__version__ = "0.1.0"

__all__ = [
    "load",
    "loads",
    "Mechanism",
    "Equilibrium",
    "Contact",
    "PointForce",
    "Torque",
    "Gravity",
    "ClearancePinError",
    "ArgumentError",
    "ModelError",
    "LoadError",
    "UnboundedLoadError",
    "SolverError",
    "ClearancePinWarning",
    "SuspectValueWarning",
    "ConditioningWarning",
]
