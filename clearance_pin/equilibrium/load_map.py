r"""The loads of one signature as one linear map to body wrenches, at one configuration.

Loads with given kinds, links and points (their *signature*) act through their vectors alone: a
force F [N] at a fixed point, a torque C [N m] and a gravity's acceleration a [m/s^2] each enter
the body wrenches linearly,

.. math::  W = A\,p, \qquad p = (v_1, \dots, v_k) \in \mathbb{R}^{3k},

:math:`v_i` the vector of the i-th load (F, C or a). Column j of A is the wrench of the unit
load :math:`e_j`, formed once per signature and configuration by the one reading of loads
(:func:`.load_table.load_table`: links to bodies, points to body frames, a gravity to a force at
every centre of mass) and the one wrench formula (:func:`.load_table.body_wrenches`). Every
engine then reads its wrenches as one product: the NumPy path (:meth:`.prepared.PreparedGeometry.
wrenches`), the closed forms (:func:`.block_verify.centred_problem`, the moments about each
body's origin) and the compiled kernel (:meth:`.fast_path.FastTerms.load_binding`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ..model.loads import Gravity, PointForce, Torque
from ..numerics import Array, Index
from .cache import LOAD_MAPS_KEPT, LeastRecentlyUsed
from .load_table import body_wrenches, check_links, load_table

if TYPE_CHECKING:
    from ..model.mechanism_parts import MechanismParts as Mechanism

# per load: (link, its point's bytes) for a PointForce, (link, None) a Torque, (None, None) a
# gravity: the loads a map is formed for, in order
LoadSignature = tuple[tuple[str | None, bytes | None], ...]


def signature_of(loads: Sequence[object]) -> tuple[LoadSignature, Array] | None:
    """(the signature of resolved ``loads``, their vectors p (3 k,) [N, N m, m/s^2]); None
    when one is not a PointForce, Torque or Gravity."""
    key: list[tuple[str | None, bytes | None]] = []
    vectors: list[Array] = []
    for load in loads:
        kind: type | None = type(load)
        if kind not in _KINDS:  # a subclass of a load, or not a load
            kind = next((known for known in _KINDS if isinstance(load, known)), None)
        if kind is PointForce:
            key.append((load.link, load.point.tobytes()))  # type: ignore[attr-defined]
            vectors.append(load.force)  # type: ignore[attr-defined]
        elif kind is Torque:
            key.append((load.link, None))  # type: ignore[attr-defined]
            vectors.append(load.torque)  # type: ignore[attr-defined]
        elif kind is Gravity:
            key.append((None, None))
            vectors.append(load.acceleration)  # type: ignore[attr-defined]
        else:
            return None
    return tuple(key), (np.concatenate(vectors) if vectors else np.zeros(0))


_KINDS = (PointForce, Torque, Gravity)


@dataclass(frozen=True)
class LoadMap:
    """W = A p for the loads of one signature at one configuration (module docstring).

    Attributes:
        world: A for the wrenches about the world origin, (6 bodies, 3 k) (body b's rows
            6 b .. 6 b + 5: force, moment; ground row 0).
        centred: A for the moments about each body's own origin (world axes), (6 bodies, 3 k).
        varying: the columns of the forces and torques (a slice when they come first, as
            resolved loads put gravity last); fixed: those of the gravities.
        bound: what an engine binds to this map, per gravity vector (the kernel's arguments,
            :meth:`.fast_path.FastTerms.load_binding`), the most recent kept.
    """

    world: Array
    centred: Array
    varying: slice | Index
    fixed: slice | Index
    bound: LeastRecentlyUsed[bytes, Any] = field(
        default_factory=lambda: LeastRecentlyUsed(LOAD_MAPS_KEPT)
    )


def build_load_map(
    mechanism: Mechanism, loads: Sequence[object], rotations: Array, translations: Array
) -> LoadMap:
    """The :class:`LoadMap` of resolved ``loads`` (PointForce, Torque, Gravity) at the body
    placements ``rotations`` (bodies, 3, 3) and ``translations`` (bodies, 3) [m]; a LoadError
    names a link the model does not have."""
    check_links(mechanism, loads)
    units: list[object] = []
    for load in loads:
        for axis in np.eye(3):
            if isinstance(load, PointForce):
                units.append(PointForce(load.link, axis, load.point))
            elif isinstance(load, Torque):
                units.append(Torque(load.link, axis))
            else:
                units.append(Gravity(axis))
    bodies = rotations.shape[0]
    centred = np.zeros((len(units), bodies, 6))
    world = np.zeros((len(units), bodies, 6))
    if units:
        table = load_table(mechanism, [[unit] for unit in units], False)
        centred, about = body_wrenches(table, rotations[None], translations[None], bodies, False)
        world[..., :3] = centred[..., :3]
        world[..., 3:] = about
    gravity = np.repeat(np.array([isinstance(load, Gravity) for load in loads], dtype=bool), 3)
    count = int((~gravity).sum())
    first = not gravity[:count].any()  # forces and torques first, then gravities
    return LoadMap(
        world=np.ascontiguousarray(world.reshape(len(units), 6 * bodies).T),
        centred=np.ascontiguousarray(centred.reshape(len(units), 6 * bodies).T),
        varying=slice(0, count) if first else np.flatnonzero(~gravity),
        fixed=slice(count, gravity.size) if first else np.flatnonzero(gravity),
    )


__all__ = ["LoadMap", "LoadSignature", "build_load_map", "signature_of"]
