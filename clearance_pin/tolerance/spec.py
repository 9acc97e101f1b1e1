r"""A tolerance sweep against the engineer's spec: which dimension dominates, and pass or fail.

Contributors [F]: dimension j's share of output i's worst-case band at position k is
:math:`|S_{kij}|\, T_j / 2` (the band is their sum); each dimension is ranked by its largest share
over the sweep.

Spec: a limit L on :math:`|\delta y|` per output [m or rad]. The worst case passes when its band
stays within L at every position (a guarantee for every part inside its tolerances), the RSS band
likewise (the statistical reading, normal dimensions with :math:`6\sigma = T`); the Monte Carlo
runs count the manufactured mechanisms out of spec (loops closed exactly for each).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..errors import ArgumentError, NotFoundError

if TYPE_CHECKING:
    from .monte_carlo import MonteCarloResult
    from .sensitivity import Output
    from .sweep import Sweep

# a limit's unit on the command line -> (SI unit, factor to it)
SPEC_UNITS = {
    "m": ("m", 1.0),
    "mm": ("m", 1e-3),
    "um": ("m", 1e-6),
    "rad": ("rad", 1.0),
    "mrad": ("rad", 1e-3),
    "urad": ("rad", 1e-6),
    "deg": ("rad", math.pi / 180.0),
}


@dataclass(frozen=True)
class Contributor:
    """One dimension's largest share of an output's worst-case band over the sweep.

    Attributes:
        dimension: its name.
        share: :math:`\\max_k |S_{kij}| T_j / 2` [m or rad, the output's unit].
        position: the index k where it is largest.
        fraction: that share over the worst band at k (0 to 1).
    """

    dimension: str
    share: float
    position: int
    fraction: float


@dataclass(frozen=True)
class Verdict:
    """An output against its spec limit.

    Attributes:
        output: the output's name.
        unit: its unit, ``"m"`` or ``"rad"``.
        limit: L [m or rad].
        worst: the largest worst-case band over the sweep's positions [m or rad].
        rss: the largest RSS band [m or rad].
        uniform_share, normal_share: share of the Monte Carlo samples out of spec over every
            position, uniform and normal dimensions (None without Monte Carlo).
    """

    output: str
    unit: str
    limit: float
    worst: float
    rss: float
    uniform_share: float | None
    normal_share: float | None

    @property
    def worst_case_passes(self) -> bool:
        """Every part inside its tolerances is inside the spec (to first order)."""
        return self.worst <= self.limit

    @property
    def rss_passes(self) -> bool:
        """The RSS band is inside the spec."""
        return self.rss <= self.limit


def contributors(result: Sweep, index: int) -> list[Contributor]:
    """The dimensions of ``result`` ranked by their largest share of output ``index``'s
    worst-case band (module docstring); dimensions that never move it are left out."""
    half = np.array([d.half_tolerance for d in result.dimensions])
    shares = np.abs(result.matrix[:, index, :]) * half  # (positions, dimensions)
    band = shares.sum(axis=1)
    ranked = []
    for j, dimension in enumerate(result.dimensions):
        k = int(np.argmax(shares[:, j]))
        if shares[k, j] > 0.0:
            fraction = float(shares[k, j] / band[k]) if band[k] > 0.0 else 0.0
            ranked.append(Contributor(dimension.name, float(shares[k, j]), k, fraction))
    return sorted(ranked, key=lambda c: -c.share)


def parse_spec(text: str, outputs: tuple[Output, ...]) -> tuple[str, float]:
    """``NAME=LIMIT`` of ``--spec``: the output's name and its limit in SI [m or rad]; LIMIT is a
    number > 0 in SI or with a unit (``50um``, ``0.05mm``, ``0.1deg``, ``2mrad``)."""
    name, sep, value = text.partition("=")
    if not sep or not name or not value:
        raise ArgumentError("--spec", "NAME=LIMIT (e.g. x4=50um)", text)
    by_name = {output.name: output for output in outputs}
    if name not in by_name:
        raise NotFoundError("output", name, list(by_name), "--spec")
    digits = value.rstrip("abcdefghijklmnopqrstuvwxyz")
    unit = value[len(digits) :] or by_name[name].unit
    if unit not in SPEC_UNITS:
        raise ArgumentError("--spec", f"a unit of {', '.join(SPEC_UNITS)}", text)
    kind, factor = SPEC_UNITS[unit]
    if kind != by_name[name].unit:
        raise ArgumentError(
            "--spec", f"a limit in {by_name[name].unit} units for output {name!r}", text
        )
    try:
        limit = float(digits) * factor
    except ValueError:
        raise ArgumentError("--spec", "NAME=LIMIT with a number (e.g. x4=50um)", text) from None
    if not (math.isfinite(limit) and limit > 0.0):
        raise ArgumentError("--spec", "a finite limit > 0", text)
    return name, limit


def verdict(
    result: Sweep, index: int, limit: float, largest: tuple[float, float] | None = None
) -> Verdict:
    """Output ``index`` of ``result`` against ``limit`` [m or rad] (module docstring): its bands
    at the sweep's positions, or ``largest`` (worst, RSS) when the maxima over the continuous
    sweep are known (:func:`.sweep.cycle_maximum`); the Monte Carlo shares need the sweep run
    with that limit (``sweep(..., limits=...)``)."""

    def share(runs: Sequence[MonteCarloResult]) -> float | None:
        counts = [run.beyond for run in runs]
        if not counts or any(count is None for count in counts):
            return None
        beyond = sum(int(count[index]) for count in counts if count is not None)
        return beyond / sum(run.samples for run in runs)

    output = result.outputs[index]
    worst, rss = float(result.worst[:, index].max()), float(result.rss[:, index].max())
    if largest is not None:
        worst, rss = max(worst, largest[0]), max(rss, largest[1])
    return Verdict(
        output.name,
        output.unit,
        float(limit),
        worst,
        rss,
        share(result.uniform),
        share(result.normal),
    )


__all__ = ["SPEC_UNITS", "Contributor", "Verdict", "contributors", "parse_spec", "verdict"]
