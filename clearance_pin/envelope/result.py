r"""The answer of :func:`clearance_pin.envelope.envelope`: a frozen :class:`Envelope`.

For each kind (``"translation"`` [m], ``"rotation"`` [rad]) of one output: the span $B$ the play
bounds, the free directions $F$ along which the output moves without bound (deviations are
reported with them removed), the certified largest deviation (:class:`~.certify.Extreme`), the
ranges along the world axes and the output frame's own, the support evaluations made, and a
drawable boundary. :meth:`Envelope.support` and :meth:`Envelope.range` solve any other direction
(one equilibrium each, remembered).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import numpy.typing as npt

from ..errors import ArgumentError
from .certify import Extreme
from .output import KINDS, Kind, Output
from .support import SupportFunction, SupportValues

Vector = npt.NDArray[np.float64]
FREE_RTOL = 1e-9  # a direction with this share along a free direction is unbounded


@dataclass(frozen=True)
class Boundary:
    """A drawable boundary: support points of the envelope.

    Attributes:
        kind: ``"translation"`` or ``"rotation"``.
        basis: the span $B$ (3, k) whose coordinates ``points`` are given in.
        points: support points (N, k) in span coordinates [m or rad]: k = 1 the two ends, k = 2
            the boundary polygon in order, k = 3 the vertices of a triangulated surface.
        faces: k = 3: vertex indices (M, 3) of the surface's triangles (their convex hull's
            with scipy installed, else the direction mesh's); else empty.
    """

    kind: str
    basis: Vector
    points: Vector
    faces: npt.NDArray[np.int64]

    @property
    def world(self) -> Vector:
        """The support points in world axes (N, 3)."""
        return np.asarray(self.points @ self.basis.T, dtype=float)


@dataclass(frozen=True)
class KindEnvelope:
    """The envelope of one kind.

    Attributes:
        kind: ``"translation"`` [m] or ``"rotation"`` [rad].
        basis: $B$ (3, k): orthonormal directions the play bounds (k = 2 for a planar
            mechanism's translation, 1 for its rotation).
        free: $F$ (3, f): directions along which a free motion moves the output (a shaft's spin).
        maximum: the certified largest deviation.
        world: ranges (3, 2) [min, max] along the world x, y, z axes (inf along a free one).
        frame: ranges (3, 2) along the output frame's own axes (nominal configuration).
        evaluations: every support evaluation of the certification (world axes).
    """

    kind: str
    basis: Vector
    free: Vector
    maximum: Extreme
    world: Vector
    frame: Vector
    evaluations: SupportValues = field(repr=False)

    @property
    def dimension(self) -> int:
        """k = dim B."""
        return int(self.basis.shape[1])


@dataclass(frozen=True)
class Envelope:
    """The clearance envelope of one output (see the module docstring).

    Attributes:
        mechanism_name: the mechanism's name.
        output: the :class:`~.output.Output`.
        q: the configuration it was computed at (nq,).
        tol: the relative gap asked for.
        kinds: kind -> :class:`KindEnvelope`.
        exact: kind -> the exact model's re-solved extremes (:class:`~.exact.ExactKind`), when
            asked for (``exact=True``).
        timings: seconds spent per kind (``"translation"``, ``"rotation"``, ``"exact"``).
    """

    mechanism_name: str
    output: Output
    q: Vector
    tol: float
    kinds: Mapping[str, KindEnvelope]
    exact: Mapping[str, Any] | None = None
    timings: Mapping[str, float] = field(default_factory=dict)
    _supports: Mapping[str, SupportFunction] = field(
        default_factory=dict, repr=False, compare=False
    )
    _memo: dict[tuple[str, bytes], float] = field(default_factory=dict, repr=False, compare=False)

    # -- the two maxima --------------------------------------------------------------------
    @property
    def max_translation(self) -> Extreme:
        """The certified largest displacement of the output point [m] (``.lower``, ``.upper``,
        ``.gap``, ``.state``, ``.contacts``, ``.deviation``)."""
        return self._kind("translation").maximum

    @property
    def max_rotation(self) -> Extreme:
        """The certified largest rotation of the output's part [rad]."""
        return self._kind("rotation").maximum

    # -- any direction ---------------------------------------------------------------------
    def support(self, direction: object, kind: str = "translation") -> float:
        r"""$h(d) = \max_{\delta \in D} d \cdot \delta$ [m or rad] for a direction in world axes
        (normalised here): the equilibrium under the unit load along it; ``inf`` when ``d`` has
        a component along a free direction. An envelope built with ``exact=True`` answers with
        the exact model: :math:`d \cdot \delta_{ex}(d)`, the exact extreme along d (a verified
        exact state, not certified: :mod:`.exact`)."""
        d = _direction(direction)
        envelope = self._kind(kind)
        free = envelope.free
        if free.shape[1] and float(np.linalg.norm(free.T @ d)) > FREE_RTOL:
            return math.inf
        key = (kind, np.round(d, 15).tobytes())
        if key not in self._memo:
            exact = (self.exact or {}).get(kind)
            if exact is not None and exact.support is not None:
                self._memo[key] = exact.extreme_along(d)
            else:
                self._memo[key] = float(self._supports[kind].evaluate(d[None, :]).values[0])
        return self._memo[key]

    def range(self, direction: object, kind: str = "translation") -> tuple[float, float]:
        """(min, max) of $d \\cdot \\delta$ over the envelope [m or rad]: $(-h(-d), h(d))$ (with
        ``exact=True``, the exact model's: asymmetric at second order)."""
        d = _direction(direction)
        return (-self.support(-d, kind), self.support(d, kind))

    def boundary(self, kind: str = "translation", level: int = 3) -> Boundary:
        """Support points to draw (one batch of equilibria, remembered): k = 2, a polygon of
        ``8 * 2**level`` directions; k = 3, the support points of an icosahedron split
        ``level`` times (642 directions for level 3) with its triangles."""
        from . import cells as grid

        key = (f"boundary:{kind}", bytes([level]))
        cached = self.__dict__.setdefault("_boundaries", {})
        if key in cached:
            return cached[key]  # type: ignore[no-any-return]
        envelope = self._kind(kind)
        basis = envelope.basis
        k = envelope.dimension
        faces = np.zeros((0, 3), dtype=np.int64)
        if k == 0:
            points = np.zeros((1, 0))
        else:
            if k == 1:
                unit = np.array([[1.0], [-1.0]])
            elif k == 2:
                unit, _ = grid.circle(8 * 2**level)
            else:
                unit, faces = grid.icosphere(level)
            found = self._supports[kind].evaluate(unit @ basis.T)
            points = found.points @ basis
            if k == 3:
                faces = _hull_faces(points, faces)
        result = Boundary(kind, basis, points, faces)
        cached[key] = result
        return result

    # -- reporting -------------------------------------------------------------------------
    def to_dict(self, length: float = 1.0, unit: str = "m") -> dict[str, Any]:
        """JSON-ready dict; lengths multiplied by ``length`` (1e6 for um), angles in rad."""
        kinds = {}
        for kind, envelope in self.kinds.items():
            scale = length if kind == "translation" else 1.0
            extreme = envelope.maximum
            kinds[kind] = {
                "unit": unit if kind == "translation" else "rad",
                "span": envelope.basis.T.tolist(),
                "unbounded": bool(envelope.free.shape[1]),
                "free_directions": envelope.free.T.tolist(),
                "maximum": {
                    "lower": extreme.lower * scale,
                    "upper": extreme.upper * scale,
                    "gap": extreme.gap,
                    "certified": extreme.certified,
                    "method": extreme.method,
                    "deviation": (extreme.deviation * scale).tolist(),
                    "load_direction": extreme.direction.tolist(),
                    "contacts": list(extreme.contacts),
                    "torsors": _torsors(extreme.state, length),
                    "directions": extreme.directions,
                },
                "world_axes": _ranges(envelope.world, scale),
                "frame_axes": _ranges(envelope.frame, scale),
            }
        document: dict[str, Any] = {
            "mechanism": self.mechanism_name,
            "output": self.output.name,
            "link": self.output.link,
            "position_m": self.output.position.tolist(),
            "q": self.q.tolist(),
            "tol": self.tol,
            "length_unit": unit,
            "kinds": kinds,
            "timings_s": dict(self.timings),
        }
        if self.exact is not None:
            document["exact"] = {kind: value.to_dict(length) for kind, value in self.exact.items()}
        return document

    def table(self, length: float = 1e6, unit: str = "um") -> str:
        """A readable report (lengths in ``unit``, rotations in urad)."""
        lines = [f"clearance envelope of {self.output.name!r} in {self.mechanism_name!r}"]
        for kind, envelope in self.kinds.items():
            scale, label = (length, unit) if kind == "translation" else (1e6, "urad")
            extreme = envelope.maximum
            free_count = envelope.free.shape[1]
            if free_count:
                lines.append(
                    f"{kind}: UNBOUNDED along {free_count} free direction(s) (a motion no play "
                    "or drive limits moves the output: drive or lock the joint that allows it)"
                )
            removed = " (free directions removed)" if free_count else ""
            if extreme.certified:
                largest = (
                    f"largest {extreme.upper * scale:.6f} {label}: a settled state reaches it, "
                    f"and none goes further (proven to {extreme.gap:.0e} of it)"
                )
            else:
                largest = (
                    f"largest between {extreme.lower * scale:.6f} and {extreme.upper * scale:.6f} "
                    f"{label}: not narrowed to the tolerance asked for (raise max_directions)"
                )
            lines.append(f"{kind}{removed}: {largest}; moves in {envelope.dimension}-D")
            lines.append(f"  reached with contacts: {', '.join(extreme.contacts) or '-'}")
            deviation = extreme.deviation
            size = float(deviation @ deviation)
            shares = [
                f"{joint} {np.linalg.norm(share) * scale:.4g} {label} "
                f"({100 * float(share @ deviation) / size:.0f} %)"
                for joint, share in self.contributors(kind).items()
            ]
            if shares and size > 0.0:
                lines.append(f"  what moves it there (share, % along it): {', '.join(shares)}")
            if envelope.free.shape[1]:
                free = "; ".join(np.array2string(f, precision=3) for f in envelope.free.T)
                lines.append(f"  free (unbounded) directions: {free}")
            for name, ranges in (("world", envelope.world), ("frame", envelope.frame)):
                text = ", ".join(
                    f"{axis} [{lo * scale:+.4f}, {hi * scale:+.4f}]"
                    for axis, (lo, hi) in zip("xyz", ranges)
                )
                lines.append(f"  {name} axes: {text} {label}")
        if self.exact is not None:
            for value in self.exact.values():
                lines.extend(value.lines(length, unit))
        return "\n".join(lines)

    def contributors(self, kind: str) -> dict[str, np.ndarray]:
        """What each joint's play moves the output by in the state that reaches the largest
        deviation of ``kind``: joint name -> share (3,) [m or rad], world axes, largest first
        (:meth:`~clearance_pin.equilibrium.result.Equilibrium.contributions`; the shares sum to
        that state's displacement of the output). Empty for a point that is no frame (a
        ``link@[x y z]``) and for a mechanism with loops (its passive joints follow the loops)."""
        state = self._kind(kind).maximum.state
        if state is None or "@" in self.output.name or state.mechanism.loop_joints:
            return {}
        index = 0 if kind == "translation" else 1
        shares = {
            joint: parts[index] for joint, parts in state.contributions(self.output.name).items()
        }
        return dict(sorted(shares.items(), key=lambda item: -float(np.linalg.norm(item[1]))))

    def _kind(self, kind: str) -> KindEnvelope:
        if kind not in KINDS:
            raise ArgumentError("kind", "'translation' or 'rotation'", kind)
        if kind not in self.kinds:
            raise ArgumentError(
                "kind", f"a kind this envelope was computed for: {', '.join(self.kinds)}", kind
            )
        return self.kinds[kind]


def _hull_faces(points: Vector, mesh: npt.NDArray[np.int64]) -> npt.NDArray[np.int64]:
    """Triangles of the convex hull of the support points (scipy's Qhull, the ``fast`` extra);
    the direction mesh's triangles without scipy or for a degenerate set. A polytope-like
    envelope sends many directions to one vertex, which folds the mesh's triangles; the hull
    does not."""
    try:
        from scipy.spatial import ConvexHull, QhullError
    except ImportError:
        return mesh
    try:
        return np.asarray(ConvexHull(points).simplices, dtype=np.int64)
    except (QhullError, ValueError):
        return mesh


def _direction(direction: object) -> Vector:
    try:
        d = np.asarray(direction, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ArgumentError("direction", "3 finite numbers (world axes)", direction) from None
    norm = float(np.linalg.norm(d)) if d.shape == (3,) else 0.0
    if d.shape != (3,) or not np.all(np.isfinite(d)) or norm == 0.0:
        raise ArgumentError("direction", "3 finite numbers, not all zero (world axes)", direction)
    return np.asarray(d / norm, dtype=float)


def _ranges(ranges: Vector, scale: float) -> dict[str, list[float | None]]:
    """Axis name -> [min, max] (None for an unbounded side: JSON has no infinity)."""
    return {
        axis: [None if not math.isfinite(v) else v * scale for v in row]
        for axis, row in zip("xyz", ranges)
    }


def _torsors(state: Any, length: float) -> dict[str, list[float]]:
    if state is None:
        return {}
    out = {}
    for name, torsor in state.torsors.items():
        values = np.array(torsor, dtype=float)
        values[:3] *= length
        out[name] = values.tolist()
    return out


def kind_of(kind: object) -> Kind:
    """``kind`` checked: ``"translation"`` or ``"rotation"``."""
    if kind == "translation":
        return "translation"
    if kind == "rotation":
        return "rotation"
    raise ArgumentError("kind", "'translation' or 'rotation'", kind)
