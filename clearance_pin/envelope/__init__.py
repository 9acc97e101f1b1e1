r"""The clearance envelope: how far an output can move inside the joint play, whatever the load.

In the small-displacement model the deviations of an output over every admissible clearance
state (driven joints held, passive joints following their loops) form a convex set $D$; its
support function in a direction is the equilibrium under a unit load along that direction at
the output (:mod:`.support`). :func:`envelope` computes, for a Pinocchio frame or a point of a
link:

- the span of $D$ and the directions a free motion moves without bound (:mod:`.state_space`);
- the largest translation and rotation, certified between a verified state and a proven upper
  bound, to a relative gap of ``tol`` (:mod:`.certify`, :mod:`.cells`, :mod:`.certificate`);
- the ranges along the world axes and the output frame's own, any support or range on demand,
  and a drawable boundary (:mod:`.result`);
- with ``exact=True``, the extreme states re-solved with finite displacements and the
  asymmetric ranges they give (:mod:`.exact`).

Loads (:mod:`.loads`) and tolerances (:mod:`.tolerances`) build on it. Equations and closed-form
checks: docs/method.md, "The clearance envelope".
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np
import numpy.typing as npt

from ..errors import ArgumentError
from .certify import Extreme, maximum
from .output import KINDS, Kind, Output, resolve_output
from .result import FREE_RTOL, Boundary, Envelope, KindEnvelope, kind_of
from .state_space import StateSpace, build_state_space
from .support import SupportFunction, SupportValues

__all__ = [
    "envelope",
    "Envelope",
    "KindEnvelope",
    "Extreme",
    "Boundary",
    "Output",
    "SupportFunction",
    "SupportValues",
    "StateSpace",
]

Vector = npt.NDArray[np.float64]


def envelope(
    mechanism: Any,
    output: object,
    q: object = None,
    exact: bool = False,
    kinds: tuple[str, ...] = KINDS,
    tol: float = 1e-6,
    max_directions: int = 20000,
    certificate: bool = True,
) -> Envelope:
    """The clearance envelope of ``output`` (module docstring).

    Args:
        mechanism: the :class:`~clearance_pin.mechanism.Mechanism`.
        output: a Pinocchio frame name, ``"link@[x y z]"`` or ``(link, (x, y, z))`` ([m], link
            frame).
        q: configuration (nq,) (None: the nominal one); driven joints are held there.
        exact: also re-solve the extreme states with the exact finite-displacement model.
        kinds: which envelopes: ``"translation"`` [m] and/or ``"rotation"`` [rad].
        tol: relative gap (upper - lower) / upper of the certified maxima, in (0, 0.1].
        max_directions: support evaluations allowed per kind before giving up certification
            (the gap reached is then reported, ``certified=False``).
        certificate: use the quadratic certificate of the best state's contact forces
            (False: the direction grid alone bounds the maximum, for checks of the grid).

    Returns:
        :class:`Envelope`.

    Raises:
        ArgumentError: a bad argument (named with what it must be).
        NotFoundError: an unknown frame or link.
    """
    chosen = _kinds(kinds)
    if not isinstance(exact, bool):
        raise ArgumentError("exact", "True or False", exact)
    if not isinstance(tol, (int, float)) or not 0.0 < tol <= 0.1:
        raise ArgumentError("tol", "a relative gap in (0, 0.1]", tol)
    if (
        isinstance(max_directions, bool)
        or not isinstance(max_directions, int)
        or max_directions < 8
    ):
        raise ArgumentError("max_directions", "an int >= 8", max_directions)
    q_solve = None if q is None else _configuration(mechanism, q)
    configuration = mechanism.configure(q_solve)
    where = resolve_output(mechanism, output, configuration)
    space = build_state_space(mechanism, configuration, where)
    envelopes: dict[str, KindEnvelope] = {}
    supports: dict[str, SupportFunction] = {}
    timings: dict[str, float] = {}
    for kind in chosen:
        start = time.perf_counter()
        support = SupportFunction(mechanism, where, kind, q_solve)
        basis = space.bounded_span(kind)
        free = space.free_directions(kind)
        support.span = basis
        world, frame, seed = _axis_ranges(support, basis, free, where.axes)
        extreme, evaluations = maximum(
            support.evaluate,
            basis,
            space,
            kind,
            tol=float(tol),
            max_directions=max_directions,
            seed=seed,
            certificate=bool(certificate),
        )
        envelopes[kind] = KindEnvelope(kind, basis, free, extreme, world, frame, evaluations)
        supports[kind] = support
        timings[kind] = time.perf_counter() - start
    exact_result: dict[str, Any] | None = None
    if exact:
        from .exact import exact_extremes

        start = time.perf_counter()
        exact_result = {
            kind: exact_extremes(mechanism, where, kind, q_solve, envelopes[kind])
            for kind in chosen
        }
        timings["exact"] = time.perf_counter() - start
    return Envelope(
        mechanism_name=str(mechanism.name),
        output=where,
        q=np.array(configuration.q, dtype=float),
        tol=float(tol),
        kinds=envelopes,
        exact=exact_result,
        timings=timings,
        _supports=supports,
    )


def _kinds(kinds: object) -> tuple[Kind, ...]:
    if isinstance(kinds, str):
        kinds = (kinds,)
    if not isinstance(kinds, (tuple, list)) or not kinds:
        raise ArgumentError("kinds", "'translation' and/or 'rotation'", kinds)
    chosen = tuple(dict.fromkeys(kind_of(k) for k in kinds))
    return chosen


def _configuration(mechanism: Any, q: object) -> Vector:
    try:
        array = np.asarray(q, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ArgumentError("q", f"{mechanism.model.nq} finite numbers", q) from None
    if array.shape != (mechanism.model.nq,) or not np.all(np.isfinite(array)):
        raise ArgumentError("q", f"{mechanism.model.nq} finite numbers", q)
    return array


def _axis_ranges(
    support: SupportFunction, basis: Vector, free: Vector, axes: Vector
) -> tuple[Vector, Vector, SupportValues | None]:
    """Ranges [min, max] along the world axes and the frame's (3, 2) each: one batch of the
    +/- directions with no free component; +/- inf along a free one; 0 off the span. Also
    returns the evaluations made (None when none was needed)."""
    candidates = np.vstack([np.eye(3), axes.T])  # 6 axes
    ranges = np.zeros((6, 2))
    solve = []
    for i, axis in enumerate(candidates):
        if free.shape[1] and float(np.linalg.norm(free.T @ axis)) > FREE_RTOL:
            ranges[i] = (-np.inf, np.inf)
        elif basis.shape[1] == 0 or float(np.linalg.norm(basis.T @ axis)) == 0.0:
            ranges[i] = (0.0, 0.0)
        else:
            solve.append(i)
    found = None
    if solve:
        directions = np.vstack([candidates[solve], -candidates[solve]])
        found = support.evaluate(directions)
        count = len(solve)
        for j, i in enumerate(solve):
            ranges[i] = (-found.values[count + j], found.values[j])
    return ranges[:3], ranges[3:], found
