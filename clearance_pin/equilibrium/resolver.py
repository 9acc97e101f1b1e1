"""Re-solves of one set of loads with new values: a planner's loop, built once.

``mechanism.resolver(loads)`` checks the arguments once, resolves the loads (gravity included),
the output points and the prepared geometry; ``resolver.solve(values)`` takes the new force and
torque vectors of those loads, in their order, as one array (k, 3) or (3 k,) [N, N m] (the way a
prebuilt optimiser takes a new cost vector) and returns the verified
:class:`~.result.Equilibrium`, the same answer as ``mechanism.solve`` of those loads, at the
same cost (measured: the argument checks and look-ups it saves are a few microseconds); a
convenience for a planner's loop, not a faster path.
"""

from __future__ import annotations

import numpy as np

from ..arguments import check_solve
from ..errors import ArgumentError, ClearancePinError, SolverError
from ..model.loads import PointForce, Torque, with_vector
from .outputs import resolve_outputs
from .prepared import prepared_geometry
from .result import Equilibrium
from .solve import solve_linear


class Resolver:
    """One mechanism, one set of loads whose force and torque vectors change (small-displacement
    model; the exact model: ``Mechanism.solve(exact=...)``).

    Attributes:
        loads: the resolved loads (gravity last when on); ``solve`` replaces the vectors of the
            PointForce and Torque ones, in this order.
        size: how many numbers ``solve`` takes (3 per PointForce or Torque).
    """

    def __init__(
        self,
        mechanism,
        loads=None,
        q=None,
        gravity=None,
        tol: float = 1e-12,
        backend: str = "auto",
        warm_start: bool = True,
        outputs=None,
    ):
        self._q = check_solve(mechanism, loads, False, q, gravity, tol, backend, 1e-9, warm_start)
        self.mechanism = mechanism
        self.loads = mechanism.resolve_loads(loads, False if gravity is False else gravity)
        self._varying = [
            i for i, load in enumerate(self.loads) if isinstance(load, (PointForce, Torque))
        ]
        if not self._varying:
            raise ArgumentError(
                "loads", "at least one PointForce or Torque (solve() changes their vectors)", loads
            )
        self.size = 3 * len(self._varying)
        self._points = resolve_outputs(mechanism, self.loads, outputs)
        self._prepared = prepared_geometry(mechanism, self._q)  # kept: valid while we hold it
        self._options = (tol, backend, warm_start)

    def solve(self, values) -> Equilibrium:
        """The equilibrium with the force and torque vectors ``values`` ((k, 3) or (3 k,) [N,
        N m], in the order of :attr:`loads`); raises like :meth:`Mechanism.solve`."""
        try:
            vector = None if np.iscomplexobj(values) else np.asarray(values, dtype=float).ravel()
        except (TypeError, ValueError):
            vector = None
        if vector is None or vector.shape != (self.size,) or not np.isfinite(vector).all():
            raise ArgumentError(
                "values", f"{self.size} finite numbers (the loads' vectors [N, N m])", values
            )
        loads = list(self.loads)
        for k, index in enumerate(self._varying):
            loads[index] = with_vector(loads[index], vector[3 * k : 3 * k + 3])
        mechanism, (tol, backend, warm_start) = self.mechanism, self._options
        try:
            return solve_linear(
                mechanism,
                tuple(loads),
                self._q,
                tol,
                backend,
                warm_start,
                self._points,
                self._prepared,
            )
        except (np.linalg.LinAlgError, OverflowError, FloatingPointError, ValueError) as exc:
            if isinstance(exc, ClearancePinError):
                raise
            raise SolverError(
                f"numerical failure in {mechanism.name!r} ({type(exc).__name__}: {exc})",
                "numerical error",
            ) from None


__all__ = ["Resolver"]
