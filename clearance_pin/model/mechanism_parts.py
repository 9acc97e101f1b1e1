"""What the layers below the front door read of a mechanism: a structural type (a Protocol), so
that nothing under ``equilibrium/``, ``kinematics/``, ``check/`` or ``identification/`` imports
``mechanism.py``, not even for its types (issue 22). :class:`~clearance_pin.mechanism.Mechanism` is one.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, Protocol

import numpy as np
import pinocchio as pin

from .joints import LoopJoint, TreeJoint
from .loads import Gravity, Load


class MechanismParts(Protocol):
    """A mechanism as the core reads it: its model, joints, loads and the cache its solves keep
    (see :class:`~clearance_pin.mechanism.Mechanism` for each member)."""

    @property
    def model(self) -> pin.Model: ...

    @property
    def tree_joints(self) -> tuple[TreeJoint, ...]: ...

    @property
    def loop_joints(self) -> tuple[LoopJoint, ...]: ...

    @property
    def joints(self) -> Mapping[str, TreeJoint | LoopJoint]: ...

    @property
    def q_nominal(self) -> np.ndarray: ...

    @property
    def loads(self) -> tuple[Load, ...]: ...

    @property
    def gravity(self) -> Gravity | None: ...

    @property
    def source(self) -> str: ...

    @property
    def name(self) -> str: ...

    @property
    def link_frames(self) -> Mapping[str, int]: ...

    @property
    def couplings(self) -> tuple[Any, ...]: ...

    @property
    def cache(self) -> Any: ...  # the SolveCache (clearance_pin.equilibrium.cache) it keeps

    @property
    def collision_model(self) -> Any: ...

    def length_scale(self) -> float: ...

    def joint(self, name: str) -> Any: ...

    def configure(self, q: Any = None) -> Any: ...

    def resolve_loads(self, loads: Sequence[Any] | None = None, gravity: Any = None) -> Any: ...

    def rebuilt(self, model: pin.Model, tree_joints: Any, loop_joints: Any) -> MechanismParts: ...

    def link_point(self, frame: str) -> Any: ...

    def solve_many(self, loads: Any = None, *args: Any, **options: Any) -> Any: ...

    def accuracy(self, output: str, configurations: Any, *args: Any, **options: Any) -> Any: ...


class ConfigurationParts(Protocol):
    """A closed configuration as the core reads it (see
    :class:`~clearance_pin.mechanism.Configuration`)."""

    @property
    def q(self) -> np.ndarray: ...

    @property
    def oMi(self) -> tuple[Any, ...]: ...

    @property
    def oMf(self) -> tuple[Any, ...]: ...

    @property
    def aMc(self) -> dict[str, Any]: ...

    @property
    def bMc(self) -> dict[str, Any]: ...

    def eccentricity(self, loop: Any) -> Any: ...


__all__ = ["ConfigurationParts", "MechanismParts"]
