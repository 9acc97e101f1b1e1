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

import threading
from collections import OrderedDict
from typing import Any

import pinocchio as pin

GEOMETRIES_KEPT = 64  # prepared configurations per mechanism (a trajectory re-visits few)


class SolveCache:
    """The solve state of one mechanism.

    Attributes:
        lock: held while a member is built or trimmed (threads of ``solve_many`` share a cache).
        geometries: configuration key -> prepared geometry, least recently used first.
        tree_geometry: the reduced geometry of a mechanism without loops (the same at every
            configuration), or None before the first solve.
        geometry_terms: id of a reduced geometry -> (the geometry, its load-independent terms).
        warm: structure signature -> the last verified cone solution (warm starts).
        warm_bets: structure signature -> whether warm starts pay (:class:`.cone_solver.WarmBet`).
        projection_hints: structure signature -> active sets that needed the projected Newton.
        exact_problems: key -> built :class:`.exact.ExactProblem`.
        backends: (backend name, signature, tol) -> built optimiser.
        check_shapes: coal shapes of the geometric check, built once.
        output_points: (loaded points, outputs asked for) -> the output points of a solve.
    """

    def __init__(self, model: pin.Model):
        self._model = model
        self._threads = threading.local()
        self.lock = threading.RLock()
        self.geometries: OrderedDict[Any, Any] = OrderedDict()
        self.tree_geometry: Any = None
        self.geometry_terms: dict[int, tuple[Any, Any]] = {}
        self.warm: dict[tuple, Any] = {}
        self.warm_bets: dict[tuple, Any] = {}
        self.projection_hints: dict[tuple, set[bytes]] = {}
        self.exact_problems: dict[tuple, Any] = {}
        self.backends: dict[tuple, Any] = {}
        self.check_shapes: dict[Any, Any] = {}
        self.output_points: dict[tuple, tuple] = {}

    @property
    def data(self) -> pin.Data:
        """This thread's ``pin.Data`` of the mechanism's model (created on first use)."""
        data = getattr(self._threads, "data", None)
        if data is None:
            data = self._threads.data = self._model.createData()
        return data

    def geometry(self, key):
        """The prepared geometry kept for ``key`` (marked as recently used), or None."""
        with self.lock:
            prepared = self.geometries.get(key)
            if prepared is not None:
                self.geometries.move_to_end(key)
            return prepared

    def keep_geometry(self, key, prepared) -> None:
        """Keep ``prepared`` for ``key``, dropping the least recently used beyond the limit (and
        the terms of the geometries no longer kept)."""
        with self.lock:
            self.geometries[key] = prepared
            self.geometries.move_to_end(key)
            while len(self.geometries) > GEOMETRIES_KEPT:
                self.geometries.popitem(last=False)
            live = {id(p.geometry) for p in self.geometries.values()}
            if self.tree_geometry is not None:
                live.add(id(self.tree_geometry))
            for stale in [k for k in self.geometry_terms if k not in live]:
                del self.geometry_terms[stale]

    def __getstate__(self) -> dict[str, pin.Model]:
        return {"model": self._model}  # built state is rebuilt on demand where it is unpickled

    def __setstate__(self, state: dict[str, pin.Model]) -> None:
        SolveCache.__init__(self, state["model"])


__all__ = ["GEOMETRIES_KEPT", "SolveCache"]
