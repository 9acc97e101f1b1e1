r"""The envelope's extreme states re-solved with finite displacements (``exact=True``).

The exact model (docs/method.md section 4) keeps the linear model's contact conditions on the
true contact points and composes the joints' finite motions. Under a unit force along $d$ at the
output its equilibrium maximises the exact work $d \cdot \delta$ near the linear state (a unit
torque: $\sin\theta\, n \cdot d$, monotone in the rotation), so it is the exact extreme in that
direction. The exact admissible set is not convex in general and its two extremes along an axis
are no longer opposite: the exact range along $d$ is

.. math::  [\, d \cdot \delta_{ex}(-d),\ d \cdot \delta_{ex}(d) \,],

asymmetric at second order (the four-bar's rocker: the rigid four-bar with coupler
$L_3 \mp 4r$). The largest exact deviation is followed from the linear maximiser by the same
ascent as the linear one, $d \leftarrow \delta_{ex}(d) / \lVert \delta_{ex}(d) \rVert$; it is a
verified exact state, a lower bound, not a certified maximum.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from ..errors import ClearancePinError
from .output import Kind, Output
from .support import SupportFunction

Vector = npt.NDArray[np.float64]
ASCENT_STEPS = 4


@dataclass(frozen=True)
class ExactKind:
    """The exact model's extremes of one kind.

    Attributes:
        kind: ``"translation"`` [m] or ``"rotation"`` [rad].
        largest: the largest exact deviation found (a verified exact state: a lower bound).
        linear_largest: the small-displacement model's certified largest (its lower bound).
        deviation: that exact state's deviation, world axes (3,) [m or rad].
        direction: its unit load's direction (3,).
        state: the exact equilibrium (``state.linear``: the linear one it started from).
        world: exact ranges (3, 2) along the world axes (inf along a free direction, 0 off the
            span).
        frame: exact ranges (3, 2) along the output frame's axes.
        linear_world, linear_frame: the linear ranges, for comparison.
    """

    kind: str
    largest: float
    linear_largest: float
    deviation: Vector
    direction: Vector
    state: Any = field(repr=False)
    world: Vector
    frame: Vector
    linear_world: Vector
    linear_frame: Vector
    support: SupportFunction | None = field(default=None, repr=False, compare=False)

    def extreme_along(self, d: Vector) -> float:
        """:math:`d \\cdot \\delta_{ex}(d)` [m or rad]: the exact equilibrium under the unit load
        along the unit direction ``d`` (module docstring: a verified exact state, the exact
        extreme along d; not certified)."""
        if self.support is None:
            raise ClearancePinError("this exact envelope was built without its support function")
        return float(d @ self.support.evaluate(d[None, :]).points[0])

    def to_dict(self, length: float = 1.0) -> dict[str, Any]:
        """JSON-ready dict (translations times ``length``)."""
        scale = length if self.kind == "translation" else 1.0

        def ranges(values: Vector) -> dict[str, list[float | None]]:
            return {
                axis: [None if not math.isfinite(v) else v * scale for v in row]
                for axis, row in zip("xyz", values)
            }

        return {
            "largest": self.largest * scale,
            "linear_largest": self.linear_largest * scale,
            "difference": (self.largest - self.linear_largest) * scale,
            "deviation": (self.deviation * scale).tolist(),
            "load_direction": self.direction.tolist(),
            "world_axes": ranges(self.world),
            "frame_axes": ranges(self.frame),
            "note": "exact: verified exact states; extremes not certified (the exact set is "
            "not convex)",
        }

    def lines(self, length: float, unit: str) -> list[str]:
        """Report lines (translations times ``length`` in ``unit``, rotations in urad)."""
        scale, label = (length, unit) if self.kind == "translation" else (1e6, "urad")
        out = [
            f"exact {self.kind}: largest {self.largest * scale:.6f} {label} (linear "
            f"{self.linear_largest * scale:.6f}, difference "
            f"{(self.largest - self.linear_largest) * scale:+.3e})"
        ]
        for name, ranges in (("world", self.world), ("frame", self.frame)):
            text = ", ".join(
                f"{axis} [{lo * scale:+.6f}, {hi * scale:+.6f}]"
                for axis, (lo, hi) in zip("xyz", ranges)
            )
            out.append(f"  exact {name} axes: {text} {label}")
        return out


def exact_extremes(
    mechanism: Any, output: Output, kind: Kind, q: Vector | None, linear: Any
) -> ExactKind:
    """Re-solve the extreme states of ``linear`` (a :class:`~.result.KindEnvelope`) with the
    exact model (module docstring)."""
    support = SupportFunction(mechanism, output, kind, q, exact=True)
    axes = np.vstack([np.eye(3), output.axes.T])
    linear_ranges = np.vstack([linear.world, linear.frame])
    ranges = linear_ranges.copy()
    wanted = [
        i for i in range(6) if np.all(np.isfinite(linear_ranges[i])) and np.any(linear_ranges[i])
    ]
    if wanted:
        found = support.evaluate(np.vstack([axes[wanted], -axes[wanted]]))
        count = len(wanted)
        for j, i in enumerate(wanted):
            along = axes[i]
            ranges[i] = (float(along @ found.points[count + j]), float(along @ found.points[j]))
    extreme = linear.maximum
    basis = linear.basis
    best: tuple[float, Vector, Vector, Any] = (0.0, np.zeros(3), extreme.direction, extreme.state)
    if extreme.state is not None and float(np.linalg.norm(extreme.direction)) > 0.0:
        # the linear envelope is symmetric, the exact one is not: follow both extremes
        for start in (extreme.direction, -extreme.direction):
            candidate = _ascent(support, basis, start)
            if candidate[0] > best[0]:
                best = candidate
    largest, deviation, reached, state = best
    return ExactKind(
        kind=kind,
        largest=largest,
        linear_largest=float(extreme.lower),
        deviation=deviation,
        direction=reached,
        state=state,
        world=ranges[:3],
        frame=ranges[3:],
        linear_world=linear.world,
        linear_frame=linear.frame,
        support=support,
    )


def _ascent(
    support: SupportFunction, basis: Vector, direction: Vector
) -> tuple[float, Vector, Vector, Any]:
    """$d \\leftarrow \\delta_{ex}(d) / \\lVert \\delta_{ex}(d) \\rVert$ from ``direction``; returns
    (largest deviation, deviation (3,), its load direction, its state)."""
    best: tuple[float, Vector, Vector, Any] = (0.0, np.zeros(3), direction, None)
    for _ in range(ASCENT_STEPS):
        found = support.evaluate(direction[None, :])
        moved = basis @ (basis.T @ found.points[0])
        norm = float(np.linalg.norm(moved))
        if norm <= best[0]:
            break
        best = (norm, moved, direction, found.states[0])
        turned = moved / norm
        if float(turned @ direction) > 1.0 - 1e-14:
            break
        direction = turned
    return best
