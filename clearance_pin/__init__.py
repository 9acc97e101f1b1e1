"""clearance_pin: where mechanism parts settle inside their joint clearances, and how far
dimensional tolerances move a mechanism's output, on Pinocchio models.

Build once, solve many (run from the repository's root; tests/test_docs_examples.py runs this):

>>> import clearance_pin
>>> mechanism = clearance_pin.load("models/younes_sphere_cylinder.urdf")
>>> equilibrium = mechanism.solve()  # the small-displacement model [Y], loads from the file
>>> equilibrium.ok, [c.label for c in equilibrium.active_contacts]
(True, ['I1:ball', 'I2:end+'])
>>> u, v, w, alpha, beta, gamma = equilibrium.torsor("I2")  # [m, rad], I2's clearance frame
>>> round(float(v) * 1e6, 3), round(float(w) * 1e6, 3)  # [um]
(61.343, 61.343)
"""

from typing import TYPE_CHECKING

from .equilibrium.batch import EquilibriumBatch
from .equilibrium.method import Method
from .equilibrium.result import Contact, Equilibrium
from .errors import (
    ArgumentError,
    CaseIndexError,
    ClearancePinError,
    ClearancePinWarning,
    ConditioningWarning,
    HeldMotionWarning,
    LoadError,
    MeasurementError,
    ModelError,
    NearSingularError,
    NotFoundError,
    SingularPositionError,
    SolverError,
    StiffnessLeftOutWarning,
    SuspectValueWarning,
    UnboundedLoadError,
)
from .loading import from_model, load, loads
from .mechanism import Mechanism
from .model.loads import Gravity, PointForce, Torque

if TYPE_CHECKING:  # imported on first use (__getattr__)
    from .check.report import CheckReport

__version__ = "0.1.0"

__all__ = [
    "load",
    "loads",
    "from_model",
    "Mechanism",
    "Equilibrium",
    "EquilibriumBatch",
    "Contact",
    "Method",
    "CheckReport",
    "PointForce",
    "Torque",
    "Gravity",
    "ClearancePinError",
    "ArgumentError",
    "MeasurementError",
    "ModelError",
    "NotFoundError",
    "CaseIndexError",
    "LoadError",
    "UnboundedLoadError",
    "SingularPositionError",
    "NearSingularError",
    "SolverError",
    "ClearancePinWarning",
    "SuspectValueWarning",
    "StiffnessLeftOutWarning",
    "ConditioningWarning",
    "HeldMotionWarning",
]


def __getattr__(name: str) -> object:
    """``clearance_pin.CheckReport`` on first use: the check package loads coal, which a solve
    never needs."""
    if name == "CheckReport":
        from .check.report import CheckReport

        return CheckReport
    raise AttributeError(f"module 'clearance_pin' has no attribute {name!r}")
