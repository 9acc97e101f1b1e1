r"""Dimensional tolerances and the clearance envelope together, along a motion of a driven joint.

**Worst case.** At each position of a sweep (:func:`clearance_pin.tolerance.sweep`), an output
coordinate $o = e \cdot p_f$ (a frame's world position, or a small rotation about a world axis)
deviates by $S\,\delta d$ from the dimensions (Flores: $|\delta d_j| \le T_j / 2$) and by
$e \cdot \delta$ from the play ($\delta \in D$, the clearance envelope at that configuration). In
the linear model the two sets add as a Minkowski sum, so their support functions add:

.. math::  o - o_0 \in \big[ -W - h_D(-e),\ W + h_D(e) \big], \qquad W = \sum_j |S_j| T_j / 2 .

With ``exact=True`` the tolerance side is the exact worst case over the box (the exact closure,
from the best vertex) and the clearance side the exact model's extremes along $e$; their sum is
reported as the combined exact range (each side exact, the interaction of the two second-order
effects neglected).

**Contact modes.** :func:`contact_modes` samples, at each position, manufactured mechanisms
(dimension deviations uniform in their boxes, :func:`~clearance_pin.tolerance.dimensions.with_deviations`)
and unit load directions at the output (uniform on the envelope's span at that position), solves
each equilibrium and records its contact mode (the set of contacts that touch) and the output's
deviation. It reports the probability of each mode per position and the deviation's spread, and
draws where the mode switches: the positioning discontinuities of Altuzarra et al. (MMT 46, 2011),
where a small change of load or geometry jumps the parts to other contacts.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from ..errors import ArgumentError, ClearancePinError
from .output import Kind, resolve_output
from .result import kind_of
from .state_space import build_state_space
from .support import SupportFunction

Vector = npt.NDArray[np.float64]


@dataclass(frozen=True)
class MotionEnvelope:
    """Tolerance bands and clearance ranges of output coordinates along a motion.

    Attributes:
        joint: the driven joint swept.
        phi: the motion parameter at each position [rad, or m for a prismatic joint], (n,).
        unit: ``"rad"`` or ``"m"``.
        outputs: the output names (the tolerance specs' names).
        kinds: per output, ``"translation"`` (a position, [m]) or ``"rotation"`` ([rad]).
        tolerance: linear worst-case half band $W$ per position and output, (n, m).
        clearance: the clearance envelope's range $[-h(-e), h(e)]$ along each output's axis,
            (n, m, 2).
        combined: $[-W - h(-e), W + h(e)]$, (n, m, 2).
        tolerance_exact: exact worst case [lower, upper] over the tolerance box, (n, m, 2), or
            None.
        clearance_exact: the exact model's range along the axis, (n, m, 2), or None.
        configurations: the closed configurations, (n, nq).
    """

    joint: str
    phi: Vector
    unit: str
    outputs: tuple[str, ...]
    kinds: tuple[str, ...]
    tolerance: Vector
    clearance: Vector
    combined: Vector
    tolerance_exact: Vector | None
    clearance_exact: Vector | None
    configurations: Vector = field(repr=False)

    @property
    def combined_exact(self) -> Vector | None:
        """Exact tolerance extremes plus the exact clearance range, (n, m, 2), or None."""
        if self.tolerance_exact is None or self.clearance_exact is None:
            return None
        return np.asarray(self.tolerance_exact + self.clearance_exact, dtype=float)

    def display(self) -> Vector:
        """The positions in deg (revolute joint) or mm (prismatic joint)."""
        return np.degrees(self.phi) if self.unit == "rad" else 1e3 * self.phi

    def largest(self, output: str) -> tuple[float, float]:
        """(phi, half range) where the combined linear range of ``output`` is widest."""
        if output not in self.outputs:
            raise ArgumentError("output", f"one of {', '.join(self.outputs)}", output)
        i = self.outputs.index(output)
        width = np.max(np.abs(self.combined[:, i, :]), axis=1)
        k = int(np.argmax(width))
        return float(self.phi[k]), float(width[k])

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict, SI (m, rad)."""
        out: dict[str, Any] = {
            "joint": self.joint,
            "unit": self.unit,
            "phi": self.phi.tolist(),
            "outputs": {},
        }
        for i, name in enumerate(self.outputs):
            entry = {
                "kind": self.kinds[i],
                "tolerance_worst": self.tolerance[:, i].tolist(),
                "clearance": self.clearance[:, i].tolist(),
                "combined": self.combined[:, i].tolist(),
            }
            if self.tolerance_exact is not None and self.clearance_exact is not None:
                entry["tolerance_exact"] = self.tolerance_exact[:, i].tolist()
                entry["clearance_exact"] = self.clearance_exact[:, i].tolist()
            out["outputs"][name] = entry
        return out


def motion_envelope(
    mechanism: Any,
    outputs: Sequence[str],
    joint: str | None = None,
    positions: int = 25,
    start: float | None = None,
    stop: float | None = None,
    clockwise: bool = False,
    offset: float = 0.0,
    exact: bool = False,
) -> MotionEnvelope:
    """Tolerance worst case and clearance envelope of frame coordinates along a motion (module
    docstring).

    Args:
        mechanism: a mechanism with ``<dimension>`` elements.
        outputs: tolerance output specs of frames, ``[NAME=]FRAME.x|y|z|rx|ry|rz``.
        joint, positions, start, stop, clockwise, offset: the sweep, as in
            :func:`clearance_pin.tolerance.sweep` ([rad] or [m]).
        exact: also the exact worst case over the tolerance box and the exact clearance range.

    Raises:
        ArgumentError: an output that is a joint coordinate (the envelope reads frames).
    """
    from ..tolerance import sweep

    result = sweep(
        mechanism,
        list(outputs),
        joint=joint,
        positions=positions,
        start=start,
        stop=stop,
        clockwise=clockwise,
        offset=offset,
        exact=exact,
    )
    kinds: list[Kind] = []
    for output in result.outputs:
        if output.kind == "joint":
            raise ArgumentError(
                "outputs", "frame coordinates FRAME.x|y|z|rx|ry|rz", output.name,
                "a joint coordinate has no clearance envelope here",
            )  # fmt: skip
        kinds.append("translation" if output.kind == "position" else "rotation")
    n, m = len(result.phi), len(result.outputs)
    clearance = np.zeros((n, m, 2))
    clearance_exact = np.zeros((n, m, 2)) if exact else None
    for k, q in enumerate(result.configurations):
        configuration = mechanism.configure(q)
        for i, output in enumerate(result.outputs):
            axis = np.eye(3)[output.component]
            where = resolve_output(mechanism, output.target, configuration)
            for formulation in (False, True) if exact else (False,):
                support = SupportFunction(mechanism, where, kinds[i], np.asarray(q), formulation)
                found = support.evaluate(np.array([axis, -axis]))
                pair = (float(axis @ found.points[1]), float(axis @ found.points[0]))
                if formulation and clearance_exact is not None:
                    clearance_exact[k, i] = pair
                else:
                    clearance[k, i] = pair
    worst = np.asarray(result.worst, dtype=float)
    combined = np.stack([clearance[..., 0] - worst, clearance[..., 1] + worst], axis=-1)
    tolerance_exact = None
    if exact:
        tolerance_exact = np.array([[w.lower, w.upper] for w in result.exact]).transpose(0, 2, 1)
    return MotionEnvelope(
        joint=str(result.joint),
        phi=np.asarray(result.phi, dtype=float),
        unit=str(result.unit),
        outputs=tuple(o.name for o in result.outputs),
        kinds=tuple(kinds),
        tolerance=worst,
        clearance=clearance,
        combined=combined,
        tolerance_exact=tolerance_exact,
        clearance_exact=clearance_exact,
        configurations=np.asarray(result.configurations, dtype=float),
    )


@dataclass(frozen=True)
class ContactModes:
    """Contact modes of sampled mechanisms and loads along a motion (module docstring).

    Attributes:
        output: the output's name.
        kind: ``"translation"`` or ``"rotation"``.
        phi: positions [rad or m], (n,).
        unit: ``"rad"`` or ``"m"``.
        modes: every contact mode met: the contacts that touch, ``joint:point``, a slab's with
            the side it touches (``joint:point[+]`` or ``[-]``).
        mode: the mode index of each sample, (n, s).
        directions: the unit load direction of each sample, world axes (n, s, 3).
        deviations: the output's deviation of each sample [m or rad], (n, s, 3).
        dimensions: the dimension deviations of each sample's mechanism [m or rad], (n, s, d).
    """

    output: str
    kind: str
    phi: Vector
    unit: str
    modes: tuple[tuple[str, ...], ...]
    mode: npt.NDArray[np.int64]
    directions: Vector
    deviations: Vector
    dimensions: Vector

    def probabilities(self) -> Vector:
        """Share of the samples in each mode per position, (n, number of modes)."""
        counts = np.zeros((self.mode.shape[0], len(self.modes)))
        for k in range(self.mode.shape[0]):
            counts[k] = np.bincount(self.mode[k], minlength=len(self.modes))
        return np.asarray(counts / self.mode.shape[1], dtype=float)

    def spread(self) -> Vector:
        """Largest and mean norm of the deviation per position, (n, 2) [m or rad]."""
        norms = np.linalg.norm(self.deviations, axis=2)
        return np.column_stack([norms.max(axis=1), norms.mean(axis=1)])


def contact_modes(
    mechanism: Any,
    output: object,
    kind: str = "translation",
    configurations: Sequence[Any] | None = None,
    phi: Sequence[float] | None = None,
    unit: str = "rad",
    mechanisms: int = 8,
    directions: int = 16,
    seed: int = 0,
    tolerances: bool = True,
) -> ContactModes:
    """Monte Carlo of contact modes over tolerances x load directions (module docstring).

    ``mechanisms`` manufactured mechanisms (dimension deviations uniform in their boxes; the
    nominal one when ``tolerances`` is False) are each loaded, at every position, by
    ``directions`` unit loads at the output spread evenly over the envelope's span (a circle or
    a sphere turned at random per mechanism): ``mechanisms * directions`` samples a position.

    Args:
        mechanism: the mechanism (with ``<dimension>`` elements when ``tolerances``).
        output: as in :func:`~clearance_pin.envelope.envelope`.
        kind: the unit load: a force at the output (``"translation"``) or a torque.
        configurations: closed configurations (n, nq) of a motion (default: the nominal one);
            :attr:`MotionEnvelope.configurations` or a tolerance sweep's are such.
        phi: the motion parameter of each configuration (for the maps; default 0..n-1).
        unit: ``"rad"`` or ``"m"``, the unit of ``phi``.
        mechanisms: manufactured mechanisms sampled.
        directions: load directions per mechanism and position.
        seed: random seed (the results depend on it and on nothing else).
        tolerances: sample the dimensions (False: the nominal mechanism only).
    """
    from ..tolerance.dimensions import with_deviations

    chosen = kind_of(kind)
    for name, value in (("mechanisms", mechanisms), ("directions", directions)):
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            raise ArgumentError(name, "an int >= 1", value)
    if configurations is None:
        configurations = [mechanism.configure().q]
    qs = [np.asarray(q, dtype=float) for q in configurations]
    positions = np.asarray(phi, dtype=float) if phi is not None else np.arange(len(qs), dtype=float)
    if positions.shape != (len(qs),):
        raise ArgumentError("phi", f"{len(qs)} positions, one per configuration", phi)
    dimensions = tuple(getattr(mechanism, "dimensions", ()))
    if tolerances and not dimensions:
        raise ClearancePinError(
            f"{mechanism.name}: no <dimension> element: nothing to sample (tolerances=False "
            "samples the load directions only)"
        )
    half = np.array([d.half_tolerance for d in dimensions]) if tolerances else np.zeros(0)
    rng = np.random.default_rng(seed)
    count = mechanisms if tolerances else 1
    sampled = [rng.uniform(-half, half) for _ in range(count)]
    built = [with_deviations(mechanism, dd) if half.size else mechanism for dd in sampled]
    turns = [rng.uniform(0.0, 1.0, size=3) for _ in range(count)]
    sides = _slab_sides(mechanism)
    labels: dict[tuple[str, ...], int] = {}
    total = count * directions
    mode = np.zeros((len(qs), total), dtype=np.int64)
    loads = np.zeros((len(qs), total, 3))
    deviations = np.zeros((len(qs), total, 3))
    dims = np.zeros((len(qs), total, half.size))
    for k, q in enumerate(qs):
        configuration = mechanism.configure(q)
        where = resolve_output(mechanism, output, configuration)
        basis = build_state_space(mechanism, configuration, where).bounded_span(chosen)
        if basis.shape[1] == 0:
            raise ArgumentError(
                "output", "an output the play moves", where.name, f"its {chosen} is held"
            )
        for j, manufactured in enumerate(built):
            spread = _spread(basis, directions, turns[j])
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # near dead centres the engine warns
                found = SupportFunction(manufactured, where, chosen, q).evaluate(spread)
            rows = slice(j * directions, (j + 1) * directions)
            for offset, state in enumerate(found.states):
                key = _mode(state, sides)
                mode[k, j * directions + offset] = labels.setdefault(key, len(labels))
            loads[k, rows] = found.directions
            deviations[k, rows] = found.points
            dims[k, rows] = sampled[j]
    return ContactModes(
        output=str(output),
        kind=chosen,
        phi=positions,
        unit=unit,
        modes=tuple(labels),
        mode=mode,
        directions=loads,
        deviations=deviations,
        dimensions=dims,
    )


def _spread(basis: Vector, count: int, turn: Vector) -> Vector:
    """``count`` unit directions (count, 3) evenly over the span (3, k): a circle started at a
    random angle, a Fibonacci sphere turned at random, or the two ends of a segment."""
    k = basis.shape[1]
    if k == 1:
        return np.array([basis[:, 0] * (1.0 if j % 2 == 0 else -1.0) for j in range(count)])
    if k == 2:
        angles = 2.0 * math.pi * (np.arange(count) + turn[0]) / count
        return np.column_stack([np.cos(angles), np.sin(angles)]) @ basis.T
    golden = math.pi * (3.0 - math.sqrt(5.0))
    z = 1.0 - 2.0 * (np.arange(count) + 0.5) / count
    ring = np.sqrt(1.0 - z**2)
    angles = golden * np.arange(count) + 2.0 * math.pi * turn[0]
    points = np.column_stack([ring * np.cos(angles), ring * np.sin(angles), z])
    axis = turn[1:] - 0.5
    rotation = _rotation(np.array([axis[0], axis[1], 0.5]), 2.0 * math.pi * turn[2])
    return np.asarray(points @ rotation.T @ basis.T, dtype=float)


def _rotation(axis: Vector, angle: float) -> Vector:
    """Rodrigues' rotation about ``axis`` by ``angle`` [rad], (3, 3)."""
    a = axis / np.linalg.norm(axis)
    k = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    return np.asarray(np.eye(3) + math.sin(angle) * k + (1.0 - math.cos(angle)) * k @ k)


def _slab_sides(mechanism: Any) -> dict[str, int]:
    """``joint:point`` -> the component a slab contact bounds (its side is read from the force)."""
    return {
        f"{joint.name}:{contact.name}": int(contact.components[0])
        for joint in mechanism.joints.values()
        for contact in joint.clearance.contacts
        if contact.shape == "abs"
    }


def _mode(state: Any, sides: dict[str, int]) -> tuple[str, ...]:
    """The contacts that touch, a slab's with its side (the force pushes the child back from
    the side it touches: a negative component is the + side)."""
    out = []
    for contact in state.active_contacts:
        component = sides.get(contact.label)
        if component is None:
            out.append(contact.label)
        else:
            pushed = contact.force if contact.moment is None else contact.moment  # a stop's
            push = float(pushed[component])
            out.append(contact.label + ("[+]" if push < 0 else "[-]" if push > 0 else "[0]"))
    return tuple(sorted(out))


def plot_motion_envelope(result: MotionEnvelope, path: str | Path) -> Path:
    """Draw the tolerance band, the clearance range and their sum against the driven joint,
    one panel per output (um or urad); returns the path."""
    from .plot import _pyplot

    plt = _pyplot()
    m = len(result.outputs)
    fig, axes = plt.subplots(m, 1, figsize=(11.0, 3.0 * m), sharex=True, squeeze=False)
    x = result.display()
    for i, name in enumerate(result.outputs):
        ax = axes[i, 0]
        scale, unit = (1e6, "um") if result.kinds[i] == "translation" else (1e6, "urad")
        w = result.tolerance[:, i] * scale
        c = result.clearance[:, i] * scale
        total = result.combined[:, i] * scale
        ax.fill_between(x, c[:, 0], c[:, 1], color="tab:orange", alpha=0.45, label="clearance")
        ax.fill_between(x, total[:, 1] - w, total[:, 1], color="tab:blue", alpha=0.3,
                        label="tolerances (worst case)")  # fmt: skip
        ax.fill_between(x, total[:, 0], total[:, 0] + w, color="tab:blue", alpha=0.3)
        ax.plot(x, total[:, 0], "-", color="tab:blue", linewidth=1.2)
        ax.plot(x, total[:, 1], "-", color="tab:blue", linewidth=1.2, label="combined (linear)")
        exact = result.combined_exact
        if exact is not None:
            ax.plot(x, exact[:, i, 0] * scale, "k--", linewidth=1.0, label="combined (exact)")
            ax.plot(x, exact[:, i, 1] * scale, "k--", linewidth=1.0)
        ax.axhline(0.0, color="grey", linewidth=0.6)
        ax.set_ylabel(f"{name} deviation [{unit}]")
        ax.grid(True, alpha=0.3)
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    axes[-1, 0].set_xlabel(
        f"{result.joint} {'angle [deg]' if result.unit == 'rad' else 'travel [mm]'}"
    )
    fig.suptitle("dimensional tolerances + clearance envelope along the motion", fontsize=11)
    fig.tight_layout()
    target = Path(path)
    fig.savefig(target, dpi=130)
    plt.close(fig)
    return target


def plot_contact_modes(result: ContactModes, path: str | Path, top: int = 8) -> Path:
    """Map of the contact modes: position against the load direction's angle in the span's
    first two coordinates (the in-plane angle of a planar mechanism), one colour per mode (the
    ``top`` most frequent; the rest grey), with each mode's probability per position beside."""
    from .plot import _pyplot

    plt = _pyplot()
    fig, (left, right) = plt.subplots(1, 2, figsize=(13.0, 5.0))
    x = np.degrees(result.phi) if result.unit == "rad" else 1e3 * result.phi
    xs = np.repeat(x[:, None], result.mode.shape[1], axis=1)
    angle = np.degrees(np.arctan2(result.directions[..., 1], result.directions[..., 0]))
    frequency = np.bincount(result.mode.ravel(), minlength=len(result.modes))
    order = list(np.argsort(-frequency)[:top])
    colours = plt.get_cmap("tab10")
    shown = [set(result.modes[i]) for i in order]
    common = set.intersection(*shown) if shown else set()
    for rank, index in enumerate(order):
        chosen = result.mode == index
        own = tuple(c for c in result.modes[index] if c not in common)
        left.scatter(xs[chosen], angle[chosen], s=14, color=colours(rank % 10),
                     label=_mode_label(own) if own else "the common contacts only")  # fmt: skip
    rest = ~np.isin(result.mode, order)
    if np.any(rest):
        left.scatter(xs[rest], angle[rest], s=10, color="lightgrey", label="other modes")
    left.set_xlabel("driven joint [deg]" if result.unit == "rad" else "travel [mm]")
    left.set_ylabel("load direction angle in the x-y plane [deg]")
    title = f"contact mode of {result.output!r} under a unit {result.kind} load"
    if common:
        title += "\nevery mode touches: " + _mode_label(tuple(sorted(common)), 90)
    left.set_title(title, fontsize=9)
    left.legend(fontsize=8, loc="upper left", bbox_to_anchor=(0.0, -0.12), ncol=2,
                title="the mode's other contacts (slab side [+] / [-])", title_fontsize=8)  # fmt: skip
    probabilities = result.probabilities()
    for rank, index in enumerate(order):
        right.plot(x, probabilities[:, index], "-o", markersize=3 + 2 * (len(order) - rank),
                   color=colours(rank % 10), alpha=0.8)  # fmt: skip
    right.set_xlabel(left.get_xlabel())
    right.set_ylabel("probability of the mode")
    right.set_ylim(0.0, 1.0)
    right.grid(True, alpha=0.3)
    right.set_title(f"{result.mode.shape[1]} samples per position", fontsize=10)
    fig.tight_layout()
    target = Path(path)
    fig.savefig(target, dpi=130)
    plt.close(fig)
    return target


def _mode_label(mode: tuple[str, ...], width: int = 60) -> str:
    text = ", ".join(mode) or "no contact"
    return text if len(text) <= width else text[: width - 3] + "..."


__all__ = [
    "MotionEnvelope",
    "motion_envelope",
    "ContactModes",
    "contact_modes",
    "plot_motion_envelope",
    "plot_contact_modes",
]
