"""What a mechanism keeps between solves: one owner, named members, one lock, one pickling rule.

Build once, solve many. Everything a solve builds that the next one can use is kept here, per
mechanism: the prepared geometry of every configuration (least recently used dropped first), the
one reduced geometry of a mechanism without loops, the load-independent terms of each geometry,
the last verified answer of each structure (warm starts) and the bet on them, the structures whose
KKT systems needed the projected Newton step, the built exact problems, the optimiser backends and
the check's shapes. The per-thread ``pin.Data`` lives here too: threads of ``solve_many`` place
the mechanism in their own data.

Nothing here is part of a mechanism's value: pickling keeps none of it (it is rebuilt on demand in
the receiving process), and a mechanism with other dimensions starts with an empty cache.
"""

from __future__ import annotations

import contextlib
import threading
from collections import OrderedDict
from typing import TYPE_CHECKING, Any, Generic, TypeVar

import pinocchio as pin

from ..errors import ArgumentError

if TYPE_CHECKING:  # prepared.py imports this module
    from .prepared import GeometryTerms, PreparedGeometry
    from .reduction import ReducedGeometry

GEOMETRIES_KEPT = 64  # prepared configurations per mechanism (a trajectory re-visits few)
LOAD_MAPS_KEPT = 64  # load maps per prepared configuration and per kernel (sets of loaded points)
RESOLVERS_KEPT = 16  # sets of loaded points Mechanism.solve keeps a resolver for
BACKENDS_KEPT = 16  # built optimisers per mechanism (one per structure, backend and tol)
EXACT_PROBLEMS_KEPT = 16  # built exact problems per mechanism (one per structure and tol)

Key = TypeVar("Key")
Value = TypeVar("Value")


class LeastRecentlyUsed(OrderedDict[Key, Value], Generic[Key, Value]):
    """A dict that keeps at most ``limit`` entries: reading one (``get``, ``[key]``) marks it as
    recently used, and storing beyond the limit drops the least recently used first.

    A key that varies without end (a gravity vector that follows a tilting base, a ``tol``
    swept by a study) would otherwise keep one entry each for the life of the mechanism."""

    def __init__(self, limit: int):
        super().__init__()
        if limit < 1:
            raise ArgumentError("limit", "at least 1 entry kept", limit)
        self.limit = limit

    def __getitem__(self, key: Key) -> Value:
        value = super().__getitem__(key)
        try:
            self.move_to_end(key)
        except KeyError:  # dropped by another thread meanwhile
            pass
        return value

    def get(self, key: Key, default: Any = None) -> Any:
        """The value of ``key`` (marked as recently used), or ``default``."""
        try:
            return self[key]
        except KeyError:
            return default

    def __setitem__(self, key: Key, value: Value) -> None:
        super().__setitem__(key, value)
        with contextlib.suppress(KeyError):
            self.move_to_end(key)
            while len(self) > self.limit:
                self.popitem(last=False)

    def __reduce__(
        self,
    ) -> tuple[Any, ...]:  # pickled with its limit (OrderedDict's own would drop it)
        return (type(self), (self.limit,), None, None, iter(self.items()))


class SolveCache:
    """The solve state of one mechanism.

    Attributes:
        lock: held while a member is built or trimmed (threads of ``solve_many`` share a cache).
        geometries: configuration key -> prepared geometry, least recently used first.
        tree_geometry: the reduced geometry of a mechanism without loops (the same at every
            configuration), or None before the first solve.
        geometry_terms: id of a reduced geometry -> (the geometry, its load-independent terms).
        warm: structure signature -> the last verified cone solution (warm starts).
        projection_hints: structure signature -> active sets that needed the projected Newton.
        exact_problems: key -> built :class:`.exact.ExactProblem` (at most
            :data:`EXACT_PROBLEMS_KEPT`, least recently used dropped first).
        backends: (backend name, signature, tol) -> built optimiser (at most
            :data:`BACKENDS_KEPT`, least recently used dropped first).
        check_shapes: coal shapes of the geometric check, built once.
        output_points: (loaded points, outputs asked for) -> the output points of a solve.
        resolvers: loaded points (:func:`.load_map.signature_of`) -> the resolver
            :meth:`Mechanism.solve` re-solves them by (:func:`.resolver.solve_by_resolver`).
    """

    def __init__(self, model: pin.Model):
        self._model = model
        self._threads = threading.local()
        self.lock = threading.RLock()
        self.geometries: LeastRecentlyUsed[bytes | None, PreparedGeometry] = LeastRecentlyUsed(
            GEOMETRIES_KEPT
        )
        self.tree_geometry: ReducedGeometry | None = None
        self.play_twin: Any = None  # a tree with stiffness: the same tree with rigid joints
        # the closure's idle passive motions, with the (model, tree, loop joints) they count
        self.idle_motions: tuple[tuple[object, ...], int] | None = None
        self.geometry_terms: dict[int, tuple[ReducedGeometry, GeometryTerms]] = {}
        self.warm: dict[tuple[Any, ...], Any] = {}
        self.projection_hints: dict[tuple[Any, ...], set[bytes]] = {}
        self.exact_problems: LeastRecentlyUsed[tuple[Any, ...], Any] = LeastRecentlyUsed(
            EXACT_PROBLEMS_KEPT
        )
        self.backends: LeastRecentlyUsed[tuple[Any, ...], Any] = LeastRecentlyUsed(BACKENDS_KEPT)
        self.check_shapes: dict[Any, Any] = {}
        self.output_points: dict[tuple[Any, ...], tuple[Any, ...]] = {}
        self.resolvers: LeastRecentlyUsed[tuple[Any, ...], Any] = LeastRecentlyUsed(RESOLVERS_KEPT)

    @property
    def data(self) -> pin.Data:
        """This thread's ``pin.Data`` of the mechanism's model (created on first use)."""
        data = getattr(self._threads, "data", None)
        if data is None:
            data = self._threads.data = self._model.createData()
        return data

    def geometry(self, key: bytes | None) -> PreparedGeometry | None:
        """The prepared geometry kept for ``key`` (marked as recently used), or None."""
        with self.lock:
            prepared: PreparedGeometry | None = self.geometries.get(key)
            return prepared

    def keep_geometry(self, key: bytes | None, prepared: PreparedGeometry) -> None:
        """Keep ``prepared`` for ``key``, dropping the least recently used beyond the limit (and
        the terms of the geometries no longer kept)."""
        with self.lock:
            self.geometries[key] = prepared
            live = {id(p.geometry) for p in self.geometries.values()}
            if self.tree_geometry is not None:
                live.add(id(self.tree_geometry))
            for stale in [k for k in self.geometry_terms if k not in live]:
                del self.geometry_terms[stale]

    def __getstate__(self) -> dict[str, pin.Model]:
        return {"model": self._model}  # built state is rebuilt on demand where it is unpickled

    def __setstate__(self, state: dict[str, pin.Model]) -> None:
        SolveCache.__init__(self, state["model"])


__all__ = [
    "LOAD_MAPS_KEPT",
    "RESOLVERS_KEPT",
    "BACKENDS_KEPT",
    "EXACT_PROBLEMS_KEPT",
    "GEOMETRIES_KEPT",
    "LeastRecentlyUsed",
    "SolveCache",
]
