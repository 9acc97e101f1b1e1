r"""The envelope under bounded loads: the deviation range over a set of loads, and how much of
the envelope one load uses.

**A set of loads.** A mechanism under a load $W$ settles in the state $y^*(W)$ of least potential
(docs/method.md section 2) and its output deviates by $\delta(W) = G\,y^*(W)$, inside the envelope
$D$ whatever $W$. :func:`deviation_range` solves a set of loads, a list of load cases or a
:class:`LoadSpread` (a nominal force or torque whose magnitude and direction vary, on top of
fixed loads and gravity), and reports the range of the deviation along the world axes and its
largest norm. The set is sampled (the spread's cap of directions by rings, its magnitudes at
even steps, both ends included): the range is that of the cases solved, not a bound; the
envelope's own maximum is the bound of any load. In the small-displacement model one force alone
settles the parts where its direction says, whatever its size ($y^*(sW) = y^*(W)$ for $s > 0$);
sizes matter against fixed loads.

**How much of the envelope a load uses.** For a deviation $\delta \ne 0$ along $u = \delta /
\lVert\delta\rVert$ (in the span $B$):

- ``share``: $\lVert\delta\rVert / \max_D \lVert\cdot\rVert$, against the certified maximum (its
  upper bound);
- ``support_fraction``: $u \cdot \delta / h_D(u)$, against the supporting plane of $D$ normal to
  $u$ (one equilibrium);
- ``gauge``: $\gamma = \lVert\delta\rVert / \rho(u)$, with $\rho(u) = \max\{t : t u \in D\}$ the
  radial function, the share of the play left along the deviation's own direction that it uses
  ($\gamma = 1$ on the boundary). $\rho(u) = \min_{d \cdot u = 1} h_D(d)
  = \min_s \varphi(s)$, $\varphi(s) = h_D(u + V s)$ convex ($V$: an orthonormal basis of $B$
  orthogonal to $u$) with subgradient $V^T \delta(u + V s)$; Kelley's cutting planes bracket the
  minimum: every $\varphi(s_i)$ is above it, the minimum of the piecewise-linear model
  $\max_i \varphi(s_i) + g_i \cdot (s - s_i)$ below it, until their relative gap is at most
  ``tol``. The gauge is given as that bracket.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from ..errors import ArgumentError
from ..model.loads import Gravity, PointForce, Torque
from .output import Kind, Output, resolve_output
from .result import Envelope, kind_of

Vector = npt.NDArray[np.float64]
KELLEY_STEPS = 60


@dataclass(frozen=True)
class LoadSpread:
    """A nominal load whose size and direction vary.

    Attributes:
        load: the nominal :class:`~clearance_pin.PointForce` or :class:`~clearance_pin.Torque`.
        magnitude: (low, high) factors on its size, 0 <= low <= high.
        spread: largest angle [rad] of its direction from the nominal one, in [0, pi].
    """

    load: PointForce | Torque
    magnitude: tuple[float, float] = (1.0, 1.0)
    spread: float = 0.0

    def __post_init__(self) -> None:
        if not isinstance(self.load, (PointForce, Torque)):
            raise ArgumentError("LoadSpread(load)", "a PointForce or a Torque", self.load)
        low, high = _pair(self.magnitude)
        if not 0.0 <= low <= high:
            raise ArgumentError(
                "LoadSpread(magnitude)", "(low, high), 0 <= low <= high", self.magnitude
            )
        if not (isinstance(self.spread, (int, float)) and 0.0 <= self.spread <= math.pi):
            raise ArgumentError("LoadSpread(spread)", "an angle in [0, pi] [rad]", self.spread)
        if float(np.linalg.norm(_vector(self.load))) == 0.0:
            raise ArgumentError("LoadSpread(load)", "a load of nonzero size", self.load)

    def cases(self, rings: int = 4, magnitudes: int = 3) -> list[PointForce | Torque]:
        """The sampled loads: directions on ``rings`` circles of the cap (6 i directions on
        ring i, at angle spread * i / rings) and the nominal one, times ``magnitudes`` sizes
        evenly from low to high (one when they are equal)."""
        nominal = _vector(self.load)
        size = float(np.linalg.norm(nominal))
        axis = nominal / size
        across = _orthonormal(axis)
        directions = [axis]
        if self.spread > 0.0:
            for ring in range(1, rings + 1):
                angle = self.spread * ring / rings
                for j in range(6 * ring):
                    turn = 2.0 * math.pi * j / (6 * ring)
                    side = math.cos(turn) * across[:, 0] + math.sin(turn) * across[:, 1]
                    directions.append(math.cos(angle) * axis + math.sin(angle) * side)
        low, high = _pair(self.magnitude)
        sizes = [low] if low == high else list(np.linspace(low, high, max(magnitudes, 2)))
        out: list[PointForce | Torque] = []
        for factor in sizes:
            for d in directions:
                value = d * size * factor
                if isinstance(self.load, PointForce):
                    out.append(PointForce(self.load.link, force=value, point=self.load.point))
                else:
                    out.append(Torque(self.load.link, torque=value))
        return out


@dataclass(frozen=True)
class LoadRange:
    """The deviation of one output over a set of loads (module docstring).

    Attributes:
        kind: ``"translation"`` [m] or ``"rotation"`` [rad].
        output: the output's name.
        cases: the load cases solved (each a tuple of loads).
        deviations: the deviation of each case, world axes (N, 3).
        world: (3, 2) [min, max] of the deviation along the world axes over the cases.
        largest: the largest norm of a deviation over the cases.
        largest_case: the index of that case.
        states: the equilibria, in case order.
    """

    kind: str
    output: str
    cases: tuple[tuple[Any, ...], ...]
    deviations: Vector
    world: Vector
    largest: float
    largest_case: int
    states: tuple[Any, ...] = field(repr=False)

    def along(self, direction: object) -> tuple[float, float]:
        """(min, max) of the deviation along a world direction (normalised) over the cases."""
        d = np.asarray(direction, dtype=float).reshape(-1)
        if d.shape != (3,) or not np.all(np.isfinite(d)) or not np.any(d):
            raise ArgumentError("direction", "3 finite numbers, not all zero", direction)
        values = self.deviations @ (d / np.linalg.norm(d))
        return float(values.min()), float(values.max())


@dataclass(frozen=True)
class Usage:
    """How much of the envelope one deviation uses (module docstring).

    Attributes:
        kind: ``"translation"`` [m] or ``"rotation"`` [rad].
        deviation: the deviation, world axes (3,), free directions removed.
        magnitude: its norm [m or rad].
        share: magnitude / the envelope's certified maximum (its upper bound).
        support_fraction: $u \\cdot \\delta / h(u)$.
        gauge: (lower, upper) bracket of $\\gamma = \\lVert\\delta\\rVert / \\rho(u)$.
        radial: (lower, upper) bracket of $\\rho(u)$ [m or rad], the envelope's extent along u.
    """

    kind: str
    deviation: Vector
    magnitude: float
    share: float
    support_fraction: float
    gauge: tuple[float, float]
    radial: tuple[float, float]


def deviation_range(
    mechanism: Any,
    output: object,
    loads: LoadSpread | Sequence[Sequence[Any]],
    kind: str = "translation",
    fixed: Sequence[Any] = (),
    gravity: object = None,
    q: object = None,
    rings: int = 4,
    magnitudes: int = 3,
) -> LoadRange:
    """The deviation of ``output`` over a set of loads (module docstring).

    Args:
        mechanism: the mechanism.
        output: as in :func:`~clearance_pin.envelope.envelope`.
        loads: a :class:`LoadSpread` (sampled by ``rings`` and ``magnitudes``) or a list of load
            cases (each a list of loads).
        kind: ``"translation"`` [m] or ``"rotation"`` [rad].
        fixed: loads added to every case of a spread (not to explicit cases).
        gravity: as in :meth:`Mechanism.solve` (True, False, None: the model's).
        q: configuration (None: nominal).
    """
    chosen = kind_of(kind)
    if isinstance(loads, LoadSpread):
        cases: list[list[Any]] = [[load, *fixed] for load in loads.cases(rings, magnitudes)]
    elif isinstance(loads, Sequence) and loads and not isinstance(loads, str):
        cases = [_case(case, index) for index, case in enumerate(loads)]
    else:
        raise ArgumentError("loads", "a LoadSpread or a non-empty list of load cases", loads)
    configuration = mechanism.configure(None if q is None else np.asarray(q, dtype=float))
    where = resolve_output(mechanism, output, configuration)
    options: dict[str, Any] = {"gravity": gravity}
    if q is not None:
        options["configurations"] = [np.asarray(q, dtype=float)] * len(cases)
    states = list(mechanism.solve_many(cases, **options))
    deviations = np.array([where.deviation(s, chosen) for s in states])
    norms = np.linalg.norm(deviations, axis=1)
    world = np.column_stack([deviations.min(axis=0), deviations.max(axis=0)])
    return LoadRange(
        kind=chosen,
        output=where.name,
        cases=tuple(tuple(c) for c in cases),
        deviations=deviations,
        world=world,
        largest=float(norms.max()),
        largest_case=int(np.argmax(norms)),
        states=tuple(states),
    )


def usage(
    envelope: Envelope, deviation: object, kind: str = "translation", tol: float = 1e-6
) -> Usage:
    """How much of ``envelope`` a deviation uses (module docstring).

    Args:
        envelope: the :class:`~.result.Envelope` of the output.
        deviation: a deviation (3,) [m or rad], world axes, or an equilibrium of the same
            mechanism (its deviation at the envelope's output is read).
        kind: ``"translation"`` or ``"rotation"``.
        tol: relative gap of the radial function's bracket.
    """
    chosen = kind_of(kind)
    part = envelope.kinds.get(chosen)
    if part is None:
        raise ArgumentError("kind", f"one of {', '.join(envelope.kinds)}", kind)
    if hasattr(deviation, "frame_displacement"):
        delta = envelope.output.deviation(deviation, chosen)
    else:
        delta = np.asarray(deviation, dtype=float).reshape(-1)
        if delta.shape != (3,) or not np.all(np.isfinite(delta)):
            raise ArgumentError("deviation", "3 finite numbers or an Equilibrium", deviation)
    basis = part.basis
    inside = basis @ (basis.T @ delta)
    magnitude = float(np.linalg.norm(inside))
    maximum = part.maximum.upper
    if magnitude == 0.0:
        return Usage(chosen, inside, 0.0, 0.0, 0.0, (0.0, 0.0), (0.0, 0.0))
    u = inside / magnitude
    support = envelope._supports[chosen]
    radial = _radial(support, basis, u, tol)
    h_u = envelope.support(u, chosen)
    return Usage(
        kind=chosen,
        deviation=inside,
        magnitude=magnitude,
        share=magnitude / maximum if maximum > 0.0 else math.inf,
        support_fraction=magnitude / h_u if h_u > 0.0 else math.inf,
        gauge=(magnitude / radial[1], magnitude / radial[0] if radial[0] > 0 else math.inf),
        radial=radial,
    )


def _radial(support: Any, basis: Vector, u: Vector, tol: float) -> tuple[float, float]:
    """Bracket of $\\rho(u) = \\min_s h(u + V s)$ by Kelley's cutting planes (module
    docstring)."""
    k = basis.shape[1]
    coordinates = basis.T @ u
    if k == 1:
        value = float(support.evaluate(u[None, :]).values[0])
        return value, value
    across = _complement(coordinates)  # (k, k - 1) in span coordinates
    points: list[Vector] = []
    values: list[float] = []
    slopes: list[Vector] = []
    s = np.zeros(k - 1)
    box = 1.0
    lower, upper = 0.0, math.inf
    for _ in range(KELLEY_STEPS):
        d = coordinates + across @ s
        found = support.evaluate((basis @ d)[None, :])
        delta = basis.T @ found.points[0]
        points.append(s.copy())
        values.append(float(d @ delta))
        slopes.append(across.T @ delta)
        upper = min(upper, values[-1])
        s, model = _kelley_step(np.array(points), np.array(values), np.array(slopes), box)
        if np.max(np.abs(s)) >= box * (1.0 - 1e-12):
            box *= 4.0  # the model's minimum is on the box: it was too small
            continue
        lower = max(lower, model)
        if upper - lower <= tol * upper:
            break
    return max(lower, 0.0), upper


def _kelley_step(
    points: Vector, values: Vector, slopes: Vector, box: float
) -> tuple[Vector, float]:
    """Minimum (s, t) of the cutting-plane model $t \\ge v_i + g_i \\cdot (s - s_i)$ over the box
    $|s_j| \\le$ ``box``, by enumerating its vertices (dimension 1 or 2)."""
    m = points.shape[1]
    rows = [np.concatenate([g, [-1.0]]) for g in slopes]  # g.s - t <= g.s_i - v_i
    rhs = [float(g @ p - v) for g, p, v in zip(slopes, points, values)]
    for j in range(m):
        for sign in (1.0, -1.0):
            row = np.zeros(m + 1)
            row[j] = sign
            rows.append(row)
            rhs.append(box)
    a, b = np.array(rows), np.array(rhs)
    best_t, best_s = math.inf, np.zeros(m)
    combos = np.array(list(itertools.combinations(range(a.shape[0]), m + 1)))
    systems = a[combos]
    regular = np.abs(np.linalg.det(systems)) > 1e-14
    solutions = np.linalg.solve(
        np.where(regular[:, None, None], systems, np.eye(m + 1)[None]), b[combos][..., None]
    )[..., 0]
    slack = 1e-12 * max(1.0, float(np.max(np.abs(b))))
    feasible = regular & np.all(solutions @ a.T <= b[None, :] + slack, axis=1)
    if np.any(feasible):
        candidates = solutions[feasible]
        index = int(np.argmin(candidates[:, -1]))
        best_t, best_s = float(candidates[index, -1]), candidates[index, :-1]
    return best_s, best_t


def _complement(u: Vector) -> Vector:
    """Orthonormal basis (k, k - 1) of the directions orthogonal to the unit vector u (k,)."""
    q, _ = np.linalg.qr(np.column_stack([u, np.eye(u.size)]))
    return np.asarray(q[:, 1 : u.size], dtype=float)


def _orthonormal(axis: Vector) -> Vector:
    """Two unit vectors (3, 2) orthogonal to ``axis`` and to each other."""
    helper = np.eye(3)[int(np.argmin(np.abs(axis)))]
    first = np.cross(axis, helper)
    first /= np.linalg.norm(first)
    return np.column_stack([first, np.cross(axis, first)])


def _vector(load: PointForce | Torque) -> Vector:
    return np.asarray(load.force if isinstance(load, PointForce) else load.torque, dtype=float)


def _pair(value: object) -> tuple[float, float]:
    try:
        low, high = (float(v) for v in value)  # type: ignore[attr-defined]
    except (TypeError, ValueError):
        raise ArgumentError("LoadSpread(magnitude)", "(low, high)", value) from None
    return low, high


def _case(case: object, index: int) -> list[Any]:
    if isinstance(case, (PointForce, Torque, Gravity)) or not isinstance(case, Sequence):
        raise ArgumentError(f"loads[{index}]", "a load case: a list of loads", case)
    return list(case)


__all__ = ["LoadSpread", "LoadRange", "Usage", "deviation_range", "usage", "Output", "Kind"]
