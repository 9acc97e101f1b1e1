"""Pictures of an envelope (matplotlib, the ``plot`` extra, imported on first use).

One panel per kind: a planar envelope (span 2-D) as its boundary polygon of support points in the
plane of its span, a 1-D one as a segment, a spatial one as the triangulated surface of its
support points; the certified largest deviation is marked (its state's deviation) with the circle
(or sphere) of that radius for scale. Translations in um, rotations in urad, axes named by their
world direction.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ClearancePinError
from .result import Envelope

SCALES = {"translation": (1e6, "um"), "rotation": (1e6, "urad")}


def _pyplot() -> Any:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise ClearancePinError(
            "plotting needs matplotlib: pip install clearance_pin[plot]"
        ) from None
    return plt


def plot_envelope(envelope: Envelope, path: str | Path, level: int = 3) -> Path:
    """Draw ``envelope`` to ``path`` (PNG, PDF or SVG by its suffix); returns the path.

    Raises:
        ClearancePinError: matplotlib is missing (``pip install clearance_pin[plot]``).
    """
    plt = _pyplot()
    kinds = list(envelope.kinds)
    fig = plt.figure(figsize=(6.0 * len(kinds), 5.6))
    for index, kind in enumerate(kinds):
        part = envelope.kinds[kind]
        k = part.dimension
        projection = "3d" if k == 3 else None
        ax = fig.add_subplot(1, len(kinds), index + 1, projection=projection)
        factor, unit = SCALES[kind]
        extreme = part.maximum
        title = (
            f"{kind}: max {extreme.lower * factor:.4g} {unit}\n"
            f"(certified gap {extreme.gap:.1e}, {extreme.method})"
        )
        if k == 0:
            ax.text(0.5, 0.5, "no motion: the play does not move it", ha="center", va="center")
            ax.set_axis_off()
        elif k == 1:
            _segment(ax, envelope, kind, factor, unit)
        elif k == 2:
            _polygon(ax, envelope, kind, factor, unit, level)
        else:
            _surface(ax, envelope, kind, factor, unit, level)
        if part.free.shape[1]:
            free = ", ".join(_axis_name(f) for f in part.free.T)
            title += f"\nunbounded (free motion) along {free}"
        ax.set_title(title, fontsize=10)
    fig.suptitle(
        f"clearance envelope of {envelope.output.name!r} ({envelope.mechanism_name}): how far it "
        "can move inside the play, whatever the load; world axes, from its nominal place",
        fontsize=12,
    )
    fig.tight_layout()
    target = Path(path)
    fig.savefig(target, dpi=130)
    plt.close(fig)
    return target


def _segment(ax: Any, envelope: Envelope, kind: str, factor: float, unit: str) -> None:
    part = envelope.kinds[kind]
    axis = part.basis[:, 0]
    low, high = envelope.range(axis, kind)
    ax.plot([low * factor, high * factor], [0.0, 0.0], "-", color="tab:blue", linewidth=6,
            label="small-displacement model")  # fmt: skip
    ax.plot([0.0], [0.0], "k+", markersize=12)
    for value in (low, high):
        ax.annotate(f"{value * factor:+.4g}", (value * factor, 0.0), textcoords="offset points",
                    xytext=(0, 10), ha="center")  # fmt: skip
    exact = (envelope.exact or {}).get(kind)
    if exact is not None:
        ends = [exact.world, exact.frame]
        along = [np.eye(3), envelope.output.axes]
        for values, axes in zip(ends, along):
            for i in range(3):
                if abs(abs(float(axes[:, i] @ axis)) - 1.0) < 1e-9:
                    sign = float(np.sign(axes[:, i] @ axis))
                    lo, hi = sorted(sign * v for v in values[i])
                    ax.plot([lo * factor, hi * factor], [-0.12, -0.12], "-", color="black",
                            linewidth=2, label="exact model")  # fmt: skip
                    for value in (lo, hi):
                        ax.annotate(f"{value * factor:+.6g}", (value * factor, -0.12),
                                    textcoords="offset points", xytext=(0, -16), ha="center")  # fmt: skip
                    break
            else:
                continue
            break
        ax.legend(loc="upper right", fontsize=8)
    ax.set_yticks([])
    ax.set_ylim(-0.6, 0.6)
    ax.set_xlabel(f"along {_axis_name(axis)} [{unit}]")
    span = max(abs(low), abs(high)) * factor * 1.3 or 1.0
    ax.set_xlim(-span, span)


def _polygon(ax: Any, envelope: Envelope, kind: str, factor: float, unit: str, level: int) -> None:
    part = envelope.kinds[kind]
    boundary = envelope.boundary(kind, level)
    points = np.vstack([boundary.points, boundary.points[:1]]) * factor
    ax.fill(points[:, 0], points[:, 1], color="tab:blue", alpha=0.25, label="envelope")
    ax.plot(points[:, 0], points[:, 1], "-", color="tab:blue", linewidth=1.5)
    extreme = part.maximum
    reach = part.basis.T @ extreme.deviation * factor
    circle = np.linspace(0.0, 2.0 * np.pi, 361)
    radius = extreme.lower * factor
    ax.plot(radius * np.cos(circle), radius * np.sin(circle), ":", color="grey",
            label=f"radius {radius:.4g} {unit}")  # fmt: skip
    ax.plot([0.0, reach[0]], [0.0, reach[1]], "-", color="tab:red")
    ax.plot([reach[0]], [reach[1]], "o", color="tab:red", label="largest (verified state)")
    ax.plot([0.0], [0.0], "k+", markersize=12)
    ax.set_aspect("equal")
    ax.set_xlabel(f"along {_axis_name(part.basis[:, 0])} [{unit}]")
    ax.set_ylabel(f"along {_axis_name(part.basis[:, 1])} [{unit}]")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="lower right", fontsize=8)


def _surface(ax: Any, envelope: Envelope, kind: str, factor: float, unit: str, level: int) -> None:
    part = envelope.kinds[kind]
    boundary = envelope.boundary(kind, level)
    world = boundary.world * factor
    ax.plot_trisurf(world[:, 0], world[:, 1], world[:, 2], triangles=boundary.faces,
                    color="tab:blue", alpha=0.35, edgecolor="none")  # fmt: skip
    reach = part.maximum.deviation * factor
    ax.plot([0.0, reach[0]], [0.0, reach[1]], [0.0, reach[2]], "-", color="tab:red")
    ax.scatter([reach[0]], [reach[1]], [reach[2]], color="tab:red", s=30)
    span = float(np.max(np.abs(world))) * 1.05 or 1.0
    for setter in (ax.set_xlim, ax.set_ylim, ax.set_zlim):
        setter(-span, span)
    ax.set_box_aspect((1.0, 1.0, 1.0))
    ax.set_xlabel(f"world x [{unit}]")
    ax.set_ylabel(f"world y [{unit}]")
    ax.set_zlabel(f"world z [{unit}]")


def _axis_name(direction: Any) -> str:
    """A world direction as text: ``+x`` for a coordinate axis, else its components."""
    d = np.asarray(direction, dtype=float)
    i = int(np.argmax(np.abs(d)))
    if abs(abs(d[i]) - 1.0) < 1e-9:
        return f"world {'+' if d[i] > 0 else '-'}{'xyz'[i]}"
    return "world (" + ", ".join(f"{v:+.2f}" for v in d) + ")"
