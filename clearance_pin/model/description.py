"""What a model describes: the arguments of a :class:`~clearance_pin.mechanism.Mechanism`.

Every reader makes one (a URDF with its block, a URDF or MJCF file beside a clearance file, a
``pin.Model`` with a dict); :mod:`clearance_pin.loading` builds the mechanism from it, so the
model layer depends on nothing above it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, TypeAlias

import numpy as np
import pinocchio as pin

from .block import BlockContents
from .couplings import Coupling
from .dimensions import Dimension
from .joints import LoopJoint, TreeJoint
from .loads import Gravity, PointForce, Torque

# a collision geometry, or what builds it from the model when a check first needs it
CollisionSource: TypeAlias = pin.GeometryModel | Callable[[pin.Model], pin.GeometryModel] | None


@dataclass(frozen=True)
class MechanismDescription:
    """What a model file describes: the arguments of a
    :class:`~clearance_pin.mechanism.Mechanism` (:func:`clearance_pin.load` builds it)."""

    model: pin.Model
    tree_joints: tuple[TreeJoint, ...]
    loop_joints: tuple[LoopJoint, ...]
    q_nominal: np.ndarray
    loads: tuple[PointForce | Torque, ...]
    gravity: Gravity | None
    source: str
    name: str
    collision_model: CollisionSource
    dimensions: tuple[Dimension, ...]
    nominal_given: dict[int, float] | None
    couplings: tuple[Coupling, ...] = ()

    def arguments(self) -> dict[str, Any]:
        """Keyword arguments of the Mechanism constructor."""
        return {f: getattr(self, f) for f in self.__dataclass_fields__}


def describe(
    model: pin.Model,
    contents: BlockContents,
    source: str,
    name: str,
    collision_model: CollisionSource = None,
) -> MechanismDescription:
    """The description of ``model`` with what its block says (:func:`~.block.read_block`)."""
    return MechanismDescription(
        model=model,
        tree_joints=contents.tree_joints,
        loop_joints=contents.loop_joints,
        q_nominal=contents.q_nominal,
        loads=contents.loads,
        gravity=contents.gravity,
        source=source,
        name=name,
        collision_model=collision_model,
        dimensions=contents.dimensions,
        nominal_given=contents.nominal_given,
        couplings=contents.couplings,
    )


def combined_source(model_source: str, block_source: str | None) -> str:
    """How a mechanism names where it came from: the model file, with its clearance file when
    the clearances are beside it (``ur5.urdf + play.toml``)."""
    if block_source is None or block_source == "<api>":  # a dict: no file to name
        return model_source
    return f"{model_source} + {block_source}"


def model_source(source: str) -> str:
    """The model file of a mechanism's ``source`` (:func:`combined_source`'s first part: without
    its clearance file)."""
    return source.split(" + ", 1)[0]


__all__ = [
    "CollisionSource",
    "MechanismDescription",
    "combined_source",
    "describe",
    "model_source",
]
