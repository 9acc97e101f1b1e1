"""Tests of clearance_pin.model.iso286 (ISO 286-1 standard tolerance grades)."""

from __future__ import annotations

import itertools
import json
import math
import pickle

import pytest
from hypothesis import given
from hypothesis import strategies as st

from clearance_pin.model.iso286 import (
    GRADES,
    ISO286_RANGES_MM,
    ToleranceInputError,
    size_range_index,
    table_um,
    tolerance_m,
    tolerance_um,
)


@pytest.mark.parametrize(
    ("grade", "size_mm", "expected_um"),
    [
        ("IT10", 50.0, 100.0),  # Flores 2011 case: crank r2, +/- 50 um
        ("IT10", 120.0, 140.0),  # rod r3, +/- 70 um
        ("IT9", 50.0, 62.0),  # +/- 31 um
        ("IT9", 120.0, 87.0),  # +/- 43.5 um
    ],
)
def test_spot_checks_of_the_flores_case(grade: str, size_mm: float, expected_um: float) -> None:
    """The cells used by the Flores 2011 slider-crank case (../cases/flores2011.toml)."""
    assert tolerance_um(grade, size_mm) == expected_um


@pytest.mark.parametrize(
    ("grade", "size_mm", "expected_um"),
    [
        ("IT01", 2.0, 0.3),
        ("IT0", 450.0, 6.0),
        ("IT1", 150.0, 3.5),
        ("IT6", 5.0, 8.0),  # the one IT6 cell that is not IT11/10 (IT11 there is 75)
        ("IT7", 25.0, 21.0),
        ("IT12", 1.5, 100.0),  # printed 0.1 mm
        ("IT14", 10.0, 360.0),  # printed 0.36 mm
        ("IT18", 500.0, 9700.0),  # printed 9.7 mm
    ],
)
def test_further_cells(grade: str, size_mm: float, expected_um: float) -> None:
    """A few more cells, across grades printed in um and in mm."""
    assert tolerance_um(grade, size_mm) == expected_um


def test_table_shape_and_positive_cells() -> None:
    """20 grades x 13 ranges, every cell a positive finite number of micrometres."""
    table = table_um()
    assert tuple(table) == GRADES
    assert len(GRADES) == 20 and GRADES[0] == "IT01" and GRADES[1] == "IT0"
    assert GRADES[-1] == "IT18"
    for grade, row in table.items():
        assert len(row) == len(ISO286_RANGES_MM), grade
        assert all(math.isfinite(v) and v > 0 for v in row), grade


def test_monotonic_in_grade_and_size() -> None:
    """Strictly coarser with the grade number, never finer with the size."""
    table = table_um()
    for k in range(len(ISO286_RANGES_MM)):
        column = [table[g][k] for g in GRADES]
        assert all(a < b for a, b in itertools.pairwise(column)), k
    for grade, row in table.items():
        assert all(a <= b for a, b in itertools.pairwise(row)), grade


def test_decade_rule_from_it7() -> None:
    """From IT6 up the grades step by a factor 10 every fifth grade (R5 series).

    Holds exactly in every printed cell from IT7 on (IT7..IT13 -> IT12..IT18), a check on the
    transcription of the coarse, mm-printed grades. IT6 -> IT11 holds except at (3, 6] mm, where
    the standard prints IT6 = 8 um and IT11 = 75 um.
    """
    table = table_um()
    for n in range(7, 14):
        assert table[f"IT{n + 5}"] == [10 * v for v in table[f"IT{n}"]], n
    mismatches = [k for k, (a, b) in enumerate(zip(table["IT6"], table["IT11"])) if b != 10 * a]
    assert mismatches == [1]


def test_ranges_are_contiguous() -> None:
    """The 13 ranges tile (0, 500] mm without gaps."""
    assert ISO286_RANGES_MM[0][0] == 0 and ISO286_RANGES_MM[-1][1] == 500
    for (_, hi), (lo, _) in itertools.pairwise(ISO286_RANGES_MM):
        assert hi == lo


def test_upper_limit_belongs_to_its_range() -> None:
    """A size equal to a range's upper limit is in that range: 50 mm is in (30, 50]."""
    for k, (lo, hi) in enumerate(ISO286_RANGES_MM):
        assert size_range_index(hi) == k
        assert size_range_index(math.nextafter(lo, math.inf)) == k
    assert size_range_index(50.0) == 5
    assert tolerance_um("IT10", 50.0) == 100.0
    assert tolerance_um("IT10", 50.000001) == 120.0


@given(st.floats(min_value=0.0, max_value=500.0, exclude_min=True))
def test_range_index_brackets_the_size(size_mm: float) -> None:
    """For any size in (0, 500] mm: lo < size <= hi of the range found."""
    lo, hi = ISO286_RANGES_MM[size_range_index(size_mm)]
    assert lo < size_mm <= hi


def test_si_accessor() -> None:
    """tolerance_m is tolerance_um in SI: metres in, metres out."""
    assert tolerance_m("IT10", 0.050) == pytest.approx(100e-6, rel=1e-15)
    assert tolerance_m("IT10", 0.120) == pytest.approx(140e-6, rel=1e-15)
    for grade in GRADES:
        for _lo, hi in ISO286_RANGES_MM:
            assert tolerance_m(grade, hi / 1e3) == pytest.approx(
                tolerance_um(grade, hi) * 1e-6, rel=1e-15
            )


def test_si_accessor_keeps_limits_despite_binary_rounding() -> None:
    """A size in metres that is a range limit up to rounding stays in that range."""
    assert tolerance_m("IT7", 0.1 + 0.215) == tolerance_m("IT7", 0.315) == 52e-6
    assert tolerance_m("IT7", 0.5 + 1e-16) == 63e-6


def test_grade_names_are_case_insensitive() -> None:
    """'it7', ' IT7 ' and 'IT7' name the same grade."""
    assert tolerance_um("it7", 25.0) == tolerance_um(" IT7 ", 25.0) == tolerance_um("IT7", 25.0)


def test_table_is_a_json_ready_copy() -> None:
    """table_um() serialises to JSON and mutating it does not touch the module's table."""
    table = table_um()
    assert json.loads(json.dumps(table)) == table
    table["IT7"][0] = -1.0
    assert table_um()["IT7"][0] == 10.0


@pytest.mark.parametrize(
    ("grade", "size_mm"),
    [
        ("IT10", 0.0),
        ("IT10", -1.0),
        ("IT10", 500.0001),
        ("IT10", math.inf),
        ("IT10", math.nan),
        ("IT10", "fifty"),
        ("IT10", None),
        ("IT10", True),
        ("IT19", 50.0),
        ("IT-1", 50.0),
        ("H7", 50.0),
        (10, 50.0),
        ("IT14", 1.0),  # the standard: IT14..IT18 not for sizes <= 1 mm
        ("IT18", 0.5),
    ],
)
def test_bad_inputs_raise(grade: object, size_mm: object) -> None:
    """Out-of-domain sizes and unknown grades raise ToleranceInputError (a ValueError)."""
    with pytest.raises(ToleranceInputError) as info:
        tolerance_um(grade, size_mm)  # type: ignore[arg-type]
    assert isinstance(info.value, ValueError)
    assert info.value.problem
    assert info.value.value is size_mm or info.value.value is grade


def test_bad_sizes_in_metres_raise_with_metres() -> None:
    """The SI accessor reports the size as given, in metres."""
    with pytest.raises(ToleranceInputError, match=r"\(0, 0.5\] m") as info:
        tolerance_m("IT7", 0.6)
    assert info.value.value == 0.6
    with pytest.raises(ToleranceInputError):
        tolerance_m("IT7", math.nan)
    with pytest.raises(ToleranceInputError):
        size_range_index(math.nan)


def test_it14_is_allowed_just_above_one_millimetre() -> None:
    """The <= 1 mm exclusion of IT14..IT18 stops exactly at 1 mm."""
    assert tolerance_um("IT14", 1.0001) == 250.0
    assert tolerance_um("IT13", 0.5) == 140.0


def test_error_carries_its_data_and_pickles() -> None:
    """ToleranceInputError has value and problem, a readable message, and survives pickling."""
    error = ToleranceInputError(7.0, "something must be in (0, 1]")
    assert error.value == 7.0 and error.problem == "something must be in (0, 1]"
    assert str(error) == "something must be in (0, 1] (got 7.0)"
    clone = pickle.loads(pickle.dumps(error))
    assert (clone.value, clone.problem, str(clone)) == (error.value, error.problem, str(error))
