r"""The largest deviation of an envelope, certified between a lower and an upper bound.

$\max_{\delta \in D} \lVert \delta \rVert = \max_{\lVert d \rVert = 1} h_D(d)$ maximises a convex
function over a convex set: a non-convex problem with, in general, several local maxima. It is
bracketed, in the span $B$ of the envelope (k = dim B):

- **lower bound** $L$: the largest $\lVert \delta \rVert$ of a verified state (an equilibrium of
  :mod:`.support`, admissible to the solver's verified feasibility), first over the direction
  grid, then improved by the ascent $d \leftarrow \delta(d) / \lVert \delta(d) \rVert$, which never
  decreases it ($\lVert \delta(d') \rVert \ge h(d') \ge d' \cdot \delta(d) = \lVert \delta(d)
  \rVert$) and stops where the load is along the deviation it causes;
- **upper bound** $U$: the smaller of the direction grid's outer bound (:mod:`.cells`: the
  largest norm of the polytope of support planes over each cell, support values taken
  $10^{-10}$ of the largest above the solver's, for its verified optimality) and the quadratic
  certificate of the best state's contact forces (:mod:`.certificate`);
- the cells whose bound exceeds $L (1 + \mathrm{tol})$ are split (arcs in two, triangles in four)
  and their new directions solved as one batch, until the relative gap
  $(U - L) / U \le \mathrm{tol}$ ($10^{-6}$ by default) or ``max_directions`` are spent (the gap
  is then reported as it is, and ``certified`` is False).

k = 1: the envelope is the segment $[-h(-b), h(b)]\,b$, solved exactly by its two ends.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from . import cells as grid
from .certificate import multiplier_bound
from .output import Kind
from .state_space import StateSpace
from .support import SupportValues

Vector = npt.NDArray[np.float64]
SUPPORT_MARGIN = 1e-10  # share of the largest support value added to each, for the upper bound
ASCENT_STEPS = 12


@dataclass(frozen=True)
class Extreme:
    """The largest deviation of one kind, certified.

    Attributes:
        kind: ``"translation"`` [m] or ``"rotation"`` [rad].
        lower: the deviation of a verified state that reaches it (a lower bound).
        upper: a proven upper bound of the largest deviation.
        deviation: that state's deviation, world axes (3,), free directions removed.
        direction: the unit load's direction that reached it (world axes, (3,)).
        state: the equilibrium under that unit load (its torsors, contacts, residuals).
        method: what gave the upper bound: ``"segment"`` (k = 1: exact), ``"multipliers"``
            (the quadratic certificate), ``"direction grid"``, or ``"none"`` (k = 0).
        directions: support evaluations spent.
        certified: the relative gap is within the tolerance asked for.
    """

    kind: str
    lower: float
    upper: float
    deviation: Vector
    direction: Vector
    state: Any = field(repr=False)
    method: str
    directions: int
    certified: bool

    @property
    def gap(self) -> float:
        """Relative gap $(U - L) / U$ (0 when both are 0)."""
        return 0.0 if self.upper <= 0.0 else max(self.upper - self.lower, 0.0) / self.upper

    @property
    def contacts(self) -> tuple[str, ...]:
        """Labels (``joint:point``) of the contacts the extreme state touches."""
        if self.state is None:
            return ()
        return tuple(c.label for c in self.state.active_contacts)


@dataclass
class _Evaluations:
    """Every support evaluation of one maximisation, in span coordinates: the grid's first (in
    the order of its directions), then the ascent's."""

    basis: Vector
    coordinates: list[Vector] = field(default_factory=list)
    values: list[float] = field(default_factory=list)
    points: list[Vector] = field(default_factory=list)
    states: list[Any] = field(default_factory=list)
    extra: list[tuple[Vector, float, Vector, Any]] = field(default_factory=list)

    def add(self, found: SupportValues, extra: bool = False) -> None:
        rows = zip(found.directions @ self.basis, found.values, found.points @ self.basis)
        for (coordinate, value, point), state in zip(rows, found.states):
            if extra:
                self.extra.append((coordinate, float(value), point, state))
            else:
                self.coordinates.append(coordinate)
                self.values.append(float(value))
                self.points.append(point)
                self.states.append(state)

    def every(self) -> list[tuple[Vector, float, Vector, Any]]:
        grid = list(zip(self.coordinates, self.values, self.points, self.states))
        return grid + self.extra

    def best(self) -> tuple[Vector, float, Vector, Any]:
        rows = self.every()
        return rows[int(np.argmax([np.linalg.norm(r[2]) for r in rows]))]


def maximum(
    evaluate: Callable[[Vector], SupportValues],
    basis: Vector,
    space: StateSpace,
    kind: Kind,
    tol: float = 1e-6,
    max_directions: int = 20000,
    initial: int | None = None,
    seed: SupportValues | None = None,
    certificate: bool = True,
) -> tuple[Extreme, SupportValues]:
    """Certify the largest deviation (module docstring).

    Args:
        evaluate: support values and states in world directions (N, 3).
        basis: the span $B$ (3, k), orthonormal columns.
        space: the admissible states (for the quadratic certificate).
        kind: ``"translation"`` or ``"rotation"``.
        tol: relative gap to reach.
        max_directions: support evaluations allowed.
        initial: directions of the first grid (k = 2: arcs, default 16; k = 3: icosahedron
            level, default 1).
        seed: evaluations already made (the axis ranges): the ascent starts from the best of
            them, and when its state's certificate closes the gap no grid is solved.
        certificate: use the quadratic certificate (False: the direction grid alone decides,
            for checks of the grid).

    Returns:
        The :class:`Extreme` and every support evaluation made (world axes).
    """
    k = basis.shape[1]
    record = _Evaluations(basis)
    if k == 0:
        return Extreme(kind, 0.0, 0.0, np.zeros(3), np.zeros(3), None, "none", 0, True), _all(
            record
        )
    if k == 1:
        record.add(evaluate(np.array([basis[:, 0], -basis[:, 0]])))
        best = record.best()
        upper = max([*record.values, float(np.linalg.norm(best[2]))])
        return _extreme(kind, record, best, upper, "segment", True), _all(record)
    projected = space.projected_map(kind, basis)
    if seed is not None and len(seed.states):
        record.add(seed, extra=True)
        best = _ascend(evaluate, record, record.best())
        lower = float(np.linalg.norm(best[2]))
        bound = multiplier_bound(space, projected, best[3], lower) if certificate else math.inf
        if math.isfinite(bound) and bound - lower <= tol * bound:
            upper = max(bound, lower)
            return _extreme(kind, record, best, upper, "multipliers", True), _all(record)
    if k == 2:
        unit, cells = grid.circle(initial or 16)
    else:
        unit, cells = grid.icosphere(1 if initial is None else initial)
    points = list(unit)
    midpoints: dict[tuple[int, int], int] = {}
    _solve_grid(evaluate, record, points, 0)
    use_certificate = certificate
    certificate_bound = math.inf
    ascended: Any = None
    while True:
        best = record.best()
        if best[3] is not ascended:  # the ascent and the certificate from a new best state
            best = _ascend(evaluate, record, best)
            ascended = best[3]
            lower = float(np.linalg.norm(best[2]))
            if use_certificate:
                certificate_bound = multiplier_bound(space, projected, best[3], lower)
        lower = float(np.linalg.norm(best[2]))
        values = np.array(record.values)
        margin = SUPPORT_MARGIN * float(np.max(np.abs(values), initial=0.0))
        bounds = grid.cell_bounds(np.array(points), values + margin, cells)
        upper_grid = float(np.max(bounds, initial=0.0))
        upper = max(min(upper_grid, certificate_bound), lower)
        method = "multipliers" if certificate_bound <= upper_grid else "direction grid"
        target = lower * (1.0 + tol)
        if upper - lower <= tol * upper:
            return _extreme(kind, record, best, upper, method, True), _all(record)
        refine = bounds > target
        spent = len(record.values) + len(record.extra)
        if spent + _new_count(k, int(refine.sum())) > max_directions:
            return _extreme(kind, record, best, upper, method, False), _all(record)
        before = len(points)
        if k == 2:
            children = grid.split_arcs(cells[refine], points)
        else:
            children = grid.split(cells[refine], points, midpoints)
        cells = np.concatenate([cells[~refine], children])
        _solve_grid(evaluate, record, points, before)


def _solve_grid(
    evaluate: Callable[[Vector], SupportValues],
    record: _Evaluations,
    points: list[Vector],
    start: int,
) -> None:
    """Solve the grid directions from ``start`` on; a direction the support function had to
    turn (a degenerate optimum) replaces the grid's, so every cell's planes stay valid."""
    found = evaluate(np.array(points[start:]) @ record.basis.T)
    solved = found.directions @ record.basis
    for offset, direction in enumerate(solved):
        points[start + offset] = direction / np.linalg.norm(direction)
    record.add(found)


def _new_count(k: int, refined: int) -> int:
    """Directions a refinement adds at most: one per arc, three per triangle."""
    return refined if k == 2 else 3 * refined


def _ascend(
    evaluate: Callable[[Vector], SupportValues],
    record: _Evaluations,
    best: tuple[Vector, float, Vector, Any],
) -> tuple[Vector, float, Vector, Any]:
    """$d \\leftarrow \\delta(d) / \\lVert \\delta(d) \\rVert$ from the best state (evaluations kept
    in ``record``); returns the best evaluation after it."""
    for _ in range(ASCENT_STEPS):
        norm = float(np.linalg.norm(best[2]))
        if norm == 0.0:
            break
        direction = best[2] / norm
        if float(direction @ best[0]) > 1.0 - 1e-15:
            break  # the load is along its own deviation: a fixed point
        found = evaluate((record.basis @ direction)[None, :])
        record.add(found, extra=True)
        new = record.extra[-1]
        gain = float(np.linalg.norm(new[2])) - norm
        if gain >= -1e-13 * norm:  # keep the state whose load is along its deviation
            best = new
        if gain <= 1e-13 * norm:
            break
    return best


def _extreme(
    kind: str,
    record: _Evaluations,
    best: tuple[Vector, float, Vector, Any],
    upper: float,
    method: str,
    certified: bool,
) -> Extreme:
    basis = record.basis
    return Extreme(
        kind=kind,
        lower=float(np.linalg.norm(best[2])),
        upper=float(upper),
        deviation=basis @ best[2],
        direction=basis @ best[0],
        state=best[3],
        method=method,
        directions=len(record.values) + len(record.extra),
        certified=certified,
    )


def _all(record: _Evaluations) -> SupportValues:
    rows = record.every()
    basis = record.basis
    if not rows:
        return SupportValues(np.zeros((0, 3)), np.zeros(0), np.zeros((0, 3)), ())
    return SupportValues(
        np.array([r[0] for r in rows]) @ basis.T,
        np.array([r[1] for r in rows]),
        np.array([r[2] for r in rows]) @ basis.T,
        tuple(r[3] for r in rows),
    )
