"""ISO 286-1 standard tolerance grades IT01 ... IT18 for nominal sizes up to 500 mm.

A standard tolerance grade turns a nominal size into a tolerance width ``T`` (the full width of
the tolerance zone, upper limit minus lower limit). A bilateral tolerance on a dimension ``d``
then reads ``d +/- T/2``, which is what :mod:`clearance_pin.tolerance.statistics` propagates.

The values are the standard's *table*, not its formula: the formula for the standard tolerance
factor ``i = 0.45 D^(1/3) + 0.001 D`` [um] with rounding misses about a fifth of the printed
cells, and the printed values are the authoritative ones.

Size ranges are "above ``lo`` up to and including ``hi``" [mm]: 50 mm belongs to (30, 50].

Footnote of the standard honoured here: grades IT14 to IT18 shall not be used for nominal sizes
less than or equal to 1 mm; :func:`tolerance_um` raises :class:`ToleranceInputError` there.

Units: the table and :func:`tolerance_um` are in micrometres and millimetres, as the standard;
:func:`tolerance_m` is the SI edge used by the rest of the library.
"""

from __future__ import annotations

import math
from bisect import bisect_left
from typing import Any

from ..errors import ClearancePinError

__all__ = [
    "GRADES",
    "ISO286_RANGES_MM",
    "ToleranceInputError",
    "size_range_index",
    "table_um",
    "tolerance_m",
    "tolerance_um",
]


# --------------------------------------------------------------------------------------------
# Errors
# --------------------------------------------------------------------------------------------


class ToleranceInputError(ClearancePinError, ValueError):
    """An input of the tolerance arithmetic is outside its domain.

    A :class:`~clearance_pin.ClearancePinError`, and a ``ValueError`` as before.

    Attributes:
        value: The offending input, as given.
        problem: What was expected, in words (which argument, which domain).
    """

    def __init__(self, value: Any, problem: str) -> None:
        super().__init__(value, problem)  # keeps the exception picklable
        self.value = value
        self.problem = problem

    def __str__(self) -> str:
        return f"{self.problem} (got {self.value!r})"


# --------------------------------------------------------------------------------------------
# The table
# --------------------------------------------------------------------------------------------

#: Nominal size ranges [mm], each "above lo, up to and including hi".
ISO286_RANGES_MM: tuple[tuple[float, float], ...] = (
    (0.0, 3.0), (3.0, 6.0), (6.0, 10.0), (10.0, 18.0), (18.0, 30.0), (30.0, 50.0),
    (50.0, 80.0), (80.0, 120.0), (120.0, 180.0), (180.0, 250.0), (250.0, 315.0),
    (315.0, 400.0), (400.0, 500.0),
)  # fmt: skip

#: Grade names, finest first.
GRADES: tuple[str, ...] = ("IT01", "IT0", *tuple(f"IT{k}" for k in range(1, 19)))

# Standard tolerance values [um], one column per range of ISO286_RANGES_MM.
#
# Source: ISO 286-1:2010, Table 1 (IT1 to IT18; IT12 and up are printed there in mm and are
# converted to um here), and the standard's separate table for IT01 and IT0 (sizes up to
# 500 mm only; Annex A, Table 5 in the 1988 edition). Transcribed from and cross-checked
# cell by cell against independent reproductions:
#   [A] GB/T 1800.3-1998 (Chinese national standard, identical values to ISO 286-1:1988),
#       table "standard tolerance values", IT1..IT18, all 13 ranges:
#       https://m.cadhome.net/news/jxbz/8485.html
#   [B] DIN ISO 286 Part 1 extract, "ISO-Fundamental Tolerance series", IT01..IT18, all 13
#       ranges (Otto Ganter GmbH technical sheet):
#       https://sparkifix.com.br/ganter/kate/iso286s1.htm
#   [C] engineersvault, "Index of ISO hole and shaft", IT1..IT14 up to 315 mm:
#       https://engineersvault.blogspot.com/2007/02/index-of-iso-hole-and-shaft.html
#   [D] mechguru, "DIN ISO 286 standard tolerance zone size table", IT5..IT11 (in mm):
#       http://mechguru.com/machine-design/din-iso-286-standard-tolerance-zone-size-table-different-grades-nominal-size
#   [E] "DIN ISO 286 ISO-Grundtoleranzen, Auszug Teil 1, Zahlenwerte", IT01..IT12, all 13
#       ranges: https://de.scribd.com/document/690338557/286-1-01
# Every IT1..IT18 cell is in [A] and [B] (IT1..IT11 also in [D] and/or [C], IT1..IT12 in [E]);
# IT01 and IT0 are in [B] and [E], and agree with the IT01/IT0 rows of several open-source
# tolerance tables based on GB/T 1800.1. None of these sources disagreed on any cell.
_TABLE_UM: dict[str, tuple[float, ...]] = {
    # columns: (0,3] (3,6] (6,10] (10,18] (18,30] (30,50] (50,80] (80,120] (120,180]
    #          (180,250] (250,315] (315,400] (400,500] mm
    "IT01": (0.3, 0.4, 0.4, 0.5, 0.6, 0.6, 0.8, 1.0, 1.2, 2.0, 2.5, 3.0, 4.0),
    "IT0": (0.5, 0.6, 0.6, 0.8, 1.0, 1.0, 1.2, 1.5, 2.0, 3.0, 4.0, 5.0, 6.0),
    "IT1": (0.8, 1.0, 1.0, 1.2, 1.5, 1.5, 2.0, 2.5, 3.5, 4.5, 6.0, 7.0, 8.0),
    "IT2": (1.2, 1.5, 1.5, 2.0, 2.5, 2.5, 3.0, 4.0, 5.0, 7.0, 8.0, 9.0, 10.0),
    "IT3": (2.0, 2.5, 2.5, 3.0, 4.0, 4.0, 5.0, 6.0, 8.0, 10.0, 12.0, 13.0, 15.0),
    "IT4": (3.0, 4.0, 4.0, 5.0, 6.0, 7.0, 8.0, 10.0, 12.0, 14.0, 16.0, 18.0, 20.0),
    "IT5": (4.0, 5.0, 6.0, 8.0, 9.0, 11.0, 13.0, 15.0, 18.0, 20.0, 23.0, 25.0, 27.0),
    "IT6": (6.0, 8.0, 9.0, 11.0, 13.0, 16.0, 19.0, 22.0, 25.0, 29.0, 32.0, 36.0, 40.0),
    "IT7": (10.0, 12.0, 15.0, 18.0, 21.0, 25.0, 30.0, 35.0, 40.0, 46.0, 52.0, 57.0, 63.0),
    "IT8": (14.0, 18.0, 22.0, 27.0, 33.0, 39.0, 46.0, 54.0, 63.0, 72.0, 81.0, 89.0, 97.0),
    "IT9": (25.0, 30.0, 36.0, 43.0, 52.0, 62.0, 74.0, 87.0, 100.0, 115.0, 130.0, 140.0, 155.0),
    "IT10": (40.0, 48.0, 58.0, 70.0, 84.0, 100.0, 120.0, 140.0, 160.0, 185.0, 210.0, 230.0,
             250.0),
    "IT11": (60.0, 75.0, 90.0, 110.0, 130.0, 160.0, 190.0, 220.0, 250.0, 290.0, 320.0, 360.0,
             400.0),
    # printed in mm from here on
    "IT12": (100.0, 120.0, 150.0, 180.0, 210.0, 250.0, 300.0, 350.0, 400.0, 460.0, 520.0, 570.0,
             630.0),
    "IT13": (140.0, 180.0, 220.0, 270.0, 330.0, 390.0, 460.0, 540.0, 630.0, 720.0, 810.0, 890.0,
             970.0),
    "IT14": (250.0, 300.0, 360.0, 430.0, 520.0, 620.0, 740.0, 870.0, 1000.0, 1150.0, 1300.0,
             1400.0, 1550.0),
    "IT15": (400.0, 480.0, 580.0, 700.0, 840.0, 1000.0, 1200.0, 1400.0, 1600.0, 1850.0, 2100.0,
             2300.0, 2500.0),
    "IT16": (600.0, 750.0, 900.0, 1100.0, 1300.0, 1600.0, 1900.0, 2200.0, 2500.0, 2900.0,
             3200.0, 3600.0, 4000.0),
    "IT17": (1000.0, 1200.0, 1500.0, 1800.0, 2100.0, 2500.0, 3000.0, 3500.0, 4000.0, 4600.0,
             5200.0, 5700.0, 6300.0),
    "IT18": (1400.0, 1800.0, 2200.0, 2700.0, 3300.0, 3900.0, 4600.0, 5400.0, 6300.0, 7200.0,
             8100.0, 8900.0, 9700.0),
}  # fmt: skip

_UPPER_MM: tuple[float, ...] = tuple(hi for _, hi in ISO286_RANGES_MM)
_COARSE_GRADES: frozenset[str] = frozenset(f"IT{k}" for k in range(14, 19))
_COARSE_MIN_SIZE_MM = 1.0  # IT14..IT18 not for sizes <= 1 mm (footnote of Table 1)
_SNAP_RTOL = 1e-9  # metre -> millimetre conversion: snap to a range limit within 0.5 nm


# --------------------------------------------------------------------------------------------
# Look-ups
# --------------------------------------------------------------------------------------------


def _as_size(size: Any, name: str) -> float:
    """Return ``size`` as a float, or raise if it is not a real number."""
    if isinstance(size, bool):
        raise ToleranceInputError(size, f"{name} must be a real number, not a bool")
    try:
        value = float(size)
    except (TypeError, ValueError):
        raise ToleranceInputError(size, f"{name} must be a real number") from None
    if math.isnan(value):
        raise ToleranceInputError(size, f"{name} must not be NaN")
    return value


def _as_grade(grade: Any) -> str:
    """Return the canonical grade name ("IT7"), accepting any case and surrounding blanks."""
    if not isinstance(grade, str):
        raise ToleranceInputError(grade, f"grade must be a string, one of {', '.join(GRADES)}")
    name = grade.strip().upper()
    if name not in _TABLE_UM:
        raise ToleranceInputError(
            grade, f"unknown ISO 286 grade; expected one of {', '.join(GRADES)}"
        )
    return name


def _range_index(size_mm: float) -> int:
    """Index of the range "above lo, up to and including hi" holding ``size_mm`` (in range)."""
    return bisect_left(_UPPER_MM, size_mm)


def size_range_index(size_mm: float) -> int:
    """Index in :data:`ISO286_RANGES_MM` of the range holding a nominal size.

    Args:
        size_mm: Nominal size [mm], in (0, 500].

    Returns:
        ``k`` such that ``lo_k < size_mm <= hi_k``.

    Raises:
        ToleranceInputError: ``size_mm`` is not a number, NaN, <= 0 or > 500 mm.
    """
    size = _as_size(size_mm, "size_mm")
    if not 0.0 < size <= _UPPER_MM[-1]:
        raise ToleranceInputError(size_mm, "nominal size must be in (0, 500] mm for ISO 286 grades")
    return _range_index(size)


def _lookup(grade: Any, size_mm: float, given: Any, unit_note: str) -> float:
    """Table value [um]; errors report ``given`` (the caller's input) and ``unit_note``."""
    name = _as_grade(grade)
    if not 0.0 < size_mm <= _UPPER_MM[-1]:
        raise ToleranceInputError(given, f"nominal size must be in {unit_note} for ISO 286 grades")
    if name in _COARSE_GRADES and size_mm <= _COARSE_MIN_SIZE_MM:
        raise ToleranceInputError(
            given, f"ISO 286-1: {name} shall not be used for nominal sizes <= 1 mm"
        )
    return _TABLE_UM[name][_range_index(size_mm)]


def tolerance_um(grade: str, size_mm: float) -> float:
    """Standard tolerance (full width of the zone) of a grade at a nominal size.

    Args:
        grade: "IT01", "IT0", "IT1", ..., "IT18" (case-insensitive).
        size_mm: Nominal size [mm], in (0, 500].

    Returns:
        The tolerance ``T`` [um], as the standard's table prints it.

    Raises:
        ToleranceInputError: unknown grade; size not a number, NaN or out of (0, 500] mm;
            IT14..IT18 asked for a size <= 1 mm (the standard excludes it).
    """
    return _lookup(grade, _as_size(size_mm, "size_mm"), size_mm, "(0, 500] mm")


def _m_to_mm(size_m: Any) -> float:
    """Convert [m] to [mm]; a result within 1e-9 (relative) of a range limit is that limit.

    This keeps SI inputs such as 0.315 m in the range (250, 315] despite binary rounding.
    """
    size_mm = _as_size(size_m, "size_m") * 1e3
    for limit in _UPPER_MM:
        if abs(size_mm - limit) <= _SNAP_RTOL * limit:
            return limit
    return size_mm


def tolerance_m(grade: str, size_m: float) -> float:
    """SI edge of :func:`tolerance_um`: standard tolerance ``T`` [m] at a nominal size [m].

    Args:
        grade: "IT01", "IT0", "IT1", ..., "IT18" (case-insensitive).
        size_m: Nominal size [m], in (0, 0.5].

    Returns:
        The tolerance ``T`` [m] (full width; the bilateral half tolerance is ``T/2``).

    Raises:
        ToleranceInputError: as :func:`tolerance_um`.
    """
    return _lookup(grade, _m_to_mm(size_m), size_m, "(0, 0.5] m") / 1e6


def table_um() -> dict[str, list[float]]:
    """The whole table, ``{grade: [T per range of ISO286_RANGES_MM]}`` [um], a fresh copy.

    Suitable for JSON output.
    """
    return {grade: list(_TABLE_UM[grade]) for grade in GRADES}
