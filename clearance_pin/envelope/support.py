r"""The support function of the clearance envelope, by duality with an equilibrium.

In the small-displacement model the admissible states $y$ form a convex set $Y$ (docs/method.md
sections 2-3) and the output's deviation is linear in them, $\delta = G y$, so the deviations form
a convex set $D = G\,Y$, the *envelope*. Its support function in a unit direction $d$ (world axes)
is

.. math::  h_D(d) = \max_{y \in Y} d \cdot G y = -\min_{y \in Y} g^T y ,

the minimum of the potential $g^T y$ of a unit force along $d$ at the output point (kind
``"translation"``, [m]) or of a unit torque along $d$ on its part (``"rotation"``, [rad]):
the equilibrium under that load (:meth:`Mechanism.solve`) is the state that reaches the support,
and $h_D(d) = d \cdot \delta$ its deviation along $d$. Driven joints are held by their drives;
passive joints follow their loops. The support point $\delta(d)$ is a subgradient of $h_D$ at $d$.

The exact model is evaluated the same way (``exact=True``): the equilibrium under the unit load
maximises the load's exact work, $d \cdot \delta$ for a force, $\sin\theta\, n \cdot d$ for a
torque (docs/method.md section 4), near the linear state.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from ..equilibrium.batch import BATCH_MINIMUM
from ..errors import SolverError
from ..model.loads import PointForce, Torque
from .output import Kind, Output

Vector = npt.NDArray[np.float64]


@dataclass(frozen=True)
class SupportValues:
    """Support evaluations in many directions.

    Attributes:
        directions: unit directions (N, 3), world axes.
        values: $h(d) = d \\cdot \\delta(d)$ [m or rad], (N,).
        points: the deviations $\\delta(d)$ of the states that reach them [m or rad], (N, 3).
        states: the verified equilibria (:class:`~clearance_pin.equilibrium.result.Equilibrium`).
    """

    directions: Vector
    values: Vector
    points: Vector
    states: tuple[Any, ...]


class SupportFunction:
    """$h(d)$ of one output and kind, by equilibria under unit loads (module docstring).

    Args:
        mechanism: the :class:`~clearance_pin.mechanism.Mechanism`.
        output: the :class:`~.output.Output`.
        kind: ``"translation"`` (unit force at the output point) or ``"rotation"`` (unit torque).
        q: configuration (None: the nominal one); driven joints are held there.
        exact: solve the exact finite-displacement model instead.
    """

    def __init__(
        self, mechanism: Any, output: Output, kind: Kind, q: Vector | None, exact: bool = False
    ) -> None:
        self.mechanism = mechanism
        self.output = output
        self.kind = kind
        self.q = q
        self.exact = exact
        self.evaluations = 0
        self.span: Vector | None = None  # the envelope's span (3, k): where a turn may go
        self._batch_rate = 0.0  # seconds per case of the last batch (0: not tried yet)
        self._run_rate = math.inf  # seconds per case in short runs (inf: not measured yet)

    def load(self, direction: Vector) -> PointForce | Torque:
        """The unit load along ``direction`` (1 N at the output point, or 1 N m on its link)."""
        if self.kind == "translation":
            return PointForce(self.output.link, force=direction, point=self.output.point)
        return Torque(self.output.link, torque=direction)

    def evaluate(self, directions: Vector) -> SupportValues:
        """Support values and states in ``directions`` (N, 3) (normalised here), solved as one
        batch of load cases (:meth:`Mechanism.solve_many`, warm-started along a path through
        the directions, so neighbouring directions share their contact set)."""
        directions = np.atleast_2d(np.asarray(directions, dtype=float))
        directions = directions / np.linalg.norm(directions, axis=1)[:, None]
        if directions.shape[0] == 0:
            return SupportValues(directions, np.zeros(0), np.zeros((0, 3)), ())
        order = _path(directions)
        cases = [[self.load(directions[i])] for i in order]
        solved = self._solve(cases)
        states: list[Any] = [None] * len(order)
        for position, index in enumerate(order):
            state = solved[position]
            if isinstance(state, Exception):
                state, directions[index] = self._retry(directions[index], state)
            if not state.ok:
                raise SolverError(
                    f"envelope of {self.output.name!r}: the equilibrium under a unit "
                    f"{'force' if self.kind == 'translation' else 'torque'} along "
                    f"{np.round(directions[index], 6).tolist()} did not verify",
                    state.solver_status,
                    dict(state.residuals.to_dict()),
                )
            states[index] = state
        points = np.array([self.output.deviation(s, self.kind) for s in states])
        self.evaluations += len(states)
        values = np.einsum("ij,ij->i", directions, points)
        return SupportValues(directions, values, points, tuple(states))

    def _retry(self, direction: Vector, error: Exception) -> tuple[Any, Vector]:
        """A direction whose equilibrium did not verify in the batch (a degenerate optimum, a
        face of the envelope normal to it), solved again alone: from the nominal position, then
        at directions turned by 1e-9, 1e-7 and 1e-5 rad (the support there is a valid support
        value of the turned direction, which is returned with the state); the first error is
        raised when every attempt fails."""
        if not isinstance(error, SolverError):
            raise error
        options: dict[str, Any] = {"gravity": False, "exact": self.exact, "q": self.q}
        across = _across(direction, self.span)
        angles = (0.0, 1e-9, 1e-7, 1e-5) if across is not None else (0.0,)
        for angle in angles:
            turned = (
                direction
                if across is None
                else (math.cos(angle) * direction + math.sin(angle) * across)
            )
            try:
                state = self.mechanism.solve(loads=[self.load(turned)], warm_start=False, **options)
            except SolverError:
                continue
            return state, turned
        raise error

    def _solve(self, cases: list[list[PointForce | Torque]]) -> list[Any]:
        """The equilibria of ``cases`` by :meth:`Mechanism.solve_many`: as one batch (stacked
        Newton over the cases that share a contact set), or in runs shorter than the batch
        minimum (each case warm-started from the previous one) once a batch has cost more per
        case than such runs (a running comparison of the two, per support function)."""
        options: dict[str, Any] = {"gravity": False, "exact": self.exact, "errors": "return"}
        batched = len(cases) >= BATCH_MINIMUM and not self.exact and self.q is None
        if batched and self._batch_rate <= 1.5 * self._run_rate:
            start = time.perf_counter()
            items = list(self.mechanism.solve_many(cases, **options))
            self._batch_rate = (time.perf_counter() - start) / len(cases)
            return items
        items = []
        start = time.perf_counter()
        run = BATCH_MINIMUM - 1
        for first in range(0, len(cases), run):
            chunk = cases[first : first + run]
            if self.q is not None:
                options["configurations"] = [self.q] * len(chunk)
            items.extend(self.mechanism.solve_many(chunk, **options))
        rate = (time.perf_counter() - start) / len(cases)
        self._run_rate = (
            rate if not math.isfinite(self._run_rate) else 0.5 * (self._run_rate + rate)
        )
        if batched:  # let the batch try again after a while
            self._batch_rate *= 0.8
        return items


def _path(directions: Vector) -> list[int]:
    """An order of the directions in which each is near the previous one (greedy nearest
    neighbour from the first; by longitude and latitude bands beyond 600 directions)."""
    count = directions.shape[0]
    if count <= 2:
        return list(range(count))
    if count > 600:
        latitude = np.arcsin(np.clip(directions[:, 2], -1.0, 1.0))
        longitude = np.arctan2(directions[:, 1], directions[:, 0])
        band = np.floor((latitude + np.pi / 2) / (np.pi / 24)).astype(int)
        serpentine = np.where(band % 2 == 0, longitude, -longitude)
        return [int(i) for i in np.lexsort((serpentine, band))]
    remaining = np.ones(count, dtype=bool)
    order = [0]
    remaining[0] = False
    for _ in range(count - 1):
        last = directions[order[-1]]
        cosines = np.where(remaining, directions @ last, -np.inf)
        nxt = int(np.argmax(cosines))
        order.append(nxt)
        remaining[nxt] = False
    return order


def _across(direction: Vector, span: Vector | None) -> Vector | None:
    """A unit vector orthogonal to ``direction`` inside ``span`` (3, k) (anywhere when None);
    None when the span has no such direction (k = 1)."""
    if span is None:
        helper = np.eye(3)[int(np.argmin(np.abs(direction)))]
        across = np.cross(direction, helper)
    else:
        inside = span - np.outer(direction, direction @ span)
        u, s, _ = np.linalg.svd(inside, full_matrices=False)
        if s.size == 0 or s[0] < 1e-6:
            return None
        across = u[:, 0]
    return np.asarray(across / np.linalg.norm(across), dtype=float)
