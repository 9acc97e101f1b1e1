"""The common style of the pictures: matplotlib imported on first use, colours, round scales.

Every picture of :mod:`clearance_pin.plot` (and the tolerance and envelope plots, which follow the
same rules) states its units on the axes (mm for positions, um for deviations, N for forces), its
scales (a displacement magnification, a force per mm) in its title or legend, and keeps its legend
outside the drawing. matplotlib is the ``plot`` extra: it is imported only when a picture is drawn,
and its absence is a :class:`~clearance_pin.errors.ClearancePinError` that says what to install.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from ..errors import ArgumentError, ClearancePinError

NOMINAL = "0.6"  # nominal pose: grey, dashed
SETTLED = "tab:blue"  # settled pose (magnified)
GROUND = "0.25"  # the fixed part
PLAY = "tab:orange"  # joint play, to scale with the magnification
CONTACT = "tab:red"  # contact points and their forces
LOAD = "tab:green"  # applied loads
OUTPUT = "black"  # output points
DPI = 130


def new_figure(width: float, height: float) -> Any:
    """A ``matplotlib.figure.Figure`` of ``width`` x ``height`` inches, not registered with pyplot
    (no global state: nothing to close, safe in threads; a notebook displays it as any figure).

    Raises:
        ClearancePinError: matplotlib is missing (``pip install clearance_pin[plot]``).
    """
    try:
        from matplotlib.figure import Figure
    except ImportError:
        raise ClearancePinError(
            "plotting needs matplotlib: pip install clearance_pin[plot]"
        ) from None
    return Figure(figsize=(width, height), layout="constrained")


def save(figure: Any, path: str | Path | None) -> None:
    """Write ``figure`` to ``path`` (PNG, PDF or SVG by its suffix) when a path is given."""
    if path is None:
        return
    target = Path(path)
    if target.parent != Path() and not target.parent.is_dir():
        raise ArgumentError("path", "a file in an existing directory", str(path))
    figure.savefig(target, dpi=DPI, bbox_inches="tight")


def nice_floor(value: float) -> float:
    """The largest number of the 1-2-5 series (1, 2, 5, 10, 20, ...) not above ``value`` > 0."""
    return _nice(value, up=False)


def nice_ceil(value: float) -> float:
    """The smallest number of the 1-2-5 series not below ``value`` > 0."""
    return _nice(value, up=True)


def nice_round(value: float) -> float:
    """The number of the 1-2-5 series nearest to ``value`` > 0 on a logarithmic scale."""
    low, high = nice_floor(value), nice_ceil(value)
    return low if value * value < low * high else high


def _nice(value: float, up: bool) -> float:
    if not value > 0.0 or not math.isfinite(value):
        return 1.0
    decade = 10.0 ** math.floor(math.log10(value))
    steps = (1.0, 2.0, 5.0, 10.0)
    mantissa = value / decade
    if up:
        chosen = next(s for s in steps if s >= mantissa * (1.0 - 1e-12))
    else:
        chosen = max(s for s in steps if s <= mantissa * (1.0 + 1e-12))
    return chosen * decade


def number(value: float) -> str:
    """A scale factor or a scale as text: ``50``, ``2000``, ``0.5``, ``2e+05``."""
    if value >= 1e5 or value < 1e-3:
        return f"{value:.0e}"
    return f"{value:g}"
