"""The check report: verdicts, loud failures, the table and the JSON contract."""

from __future__ import annotations

import json

import pytest

from clearance_pin.check import CheckReport, JointCheck, PointCheck, Tolerance

TOL = Tolerance(faceting=0.0, solver=1e-15, coal=1e-15)  # total 2e-15 m


def _reading(distance, model_gap=0.0, contact=True, judged=True, point="end+"):
    return PointCheck("I2", point, "cylinder", 1e-4, model_gap, distance, contact, TOL, judged)


def _report(*readings, formulation="exact"):
    joint = JointCheck("I2", "cylindrical", tuple(readings))
    return CheckReport(formulation, {"I2": joint}, 1e-4, 1e-6, 0.0, len(readings), 1e-12)


@pytest.mark.parametrize(
    ("distance", "model_gap", "contact", "judged", "verdict"),
    [
        (1e-15, 0.0, True, True, "ok"),  # contact reads zero within tolerance
        (3e-15, 0.0, True, True, "off boundary"),  # contact reads a gap
        (-3e-15, 0.0, True, True, "penetration"),  # contact overlaps
        (5e-5 + 1e-15, 5e-5, False, True, "ok"),  # free point reads its gap
        (5e-5 + 1e-9, 5e-5, False, True, "gap mismatch"),
        (-1e-9, 5e-5, False, True, "penetration"),  # overlap wins over mismatch
        (3e-6, 0.0, True, False, "not judged"),  # unknown faceting: only penetration judged
        (-3e-6, 0.0, True, False, "penetration"),
    ],
)
def test_verdicts(distance, model_gap, contact, judged, verdict):
    """Contact must read zero, a free point its gap, nothing may overlap; beyond the tolerance
    each reading gets the verdict that says which rule it broke."""
    reading = _reading(distance, model_gap, contact, judged)
    assert reading.verdict == verdict
    assert reading.ok == (verdict in ("ok", "not judged"))


def test_failures_are_loud_and_worst_first():
    """A failing report names the joint, the point and the amount, worst first, in the table."""
    report = _report(
        _reading(3e-15, point="end-"), _reading(1.77e-6, point="end+"), _reading(0.0, point="x")
    )
    assert not report.ok
    assert [r.point for r in report.failures] == ["end+", "end-"]
    message = report.failures[0].message()
    assert "I2:end+" in message and "1.77 um" in message and "off the boundary" in message
    table = report.table()
    assert "FAIL I2:end+" in table and "FAILED" in table.splitlines()[0]
    assert report.off_boundary == (pytest.approx(1.77e-6), "I2:end+")


def test_linear_summary_says_how_far_off_the_pose_sits():
    """For a linear pose the summary states how far it sits off the real boundaries and whether
    that exceeds the tolerance."""
    report = _report(_reading(1.77e-6), formulation="linear")
    summary = report.summary()
    assert "sits up to 1.77 um off the real boundaries" in summary and "exceeds" in summary


@pytest.mark.parametrize(("length", "unit"), [(1.0, "m"), (1e3, "mm"), (1e6, "um")])
def test_json_keys_and_scaling(length, unit):
    """to_dict(length) scales lengths and suffixes keys with the unit; one entry per point."""
    report = _report(_reading(1e-15, point="end-"), _reading(2e-5, 2e-5, False, point="end+"))
    document = json.loads(json.dumps(report.to_dict(length=length)))
    joint = document["joints"]["I2"]
    assert document["ok"] is True and document["length_unit"] == unit
    assert joint["point"] == ["end-", "end+"]
    assert joint["contact"] == [True, False]
    assert joint[f"model_gap_{unit}"] == pytest.approx([0.0, 2e-5 * length])
    assert joint[f"coal_distance_{unit}"] == pytest.approx([1e-15 * length, 2e-5 * length])
    assert joint[f"tolerance_{unit}"] == pytest.approx([2e-15 * length] * 2)
    assert joint[f"tolerance_terms_{unit}"][0]["solver"] == pytest.approx(1e-15 * length)
    assert joint["surfaces"]["point"] == []


def test_json_unknown_length_needs_a_unit():
    """A length factor without a known unit must be named."""
    report = _report(_reading(0.0))
    with pytest.raises(ValueError, match="name the unit"):
        report.to_dict(length=25.4)
    assert "model_gap_in" in report.to_dict(length=1 / 0.0254, unit="in")["joints"]["I2"]


def test_one_sided_tolerance():
    """Faceting and rim terms of a generated bore only raise a reading: above what it should read
    the whole tolerance applies, below it only solver + coal."""
    one_sided = Tolerance(faceting=1e-8, solver=1e-15, coal=1e-15, one_sided=True)
    assert one_sided.below == 2e-15 and one_sided.total == pytest.approx(1e-8 + 2e-15)

    def reading(distance, gap=0.0, contact=True):
        return PointCheck("I2", "surface", "bore N=512", 1e-4, gap, distance, contact, one_sided)

    assert reading(5e-9).verdict == "ok"
    assert reading(-5e-9).verdict == "penetration"
    assert reading(1e-5 + 5e-9, 1e-5, False).verdict == "ok"
    assert reading(1e-5 - 5e-9, 1e-5, False).verdict == "gap mismatch"
    assert "^ one-sided" in _report(reading(5e-9)).table()


def test_the_table_keeps_its_columns_apart_on_long_joint_names():
    """A vendor's long joint name (40 characters) widens its column: every row keeps two spaces
    between its cells (the label ran into the method before), and the columns line up."""
    name = "left_arm_shoulder_pitch_joint_with_encoder"
    reading = PointCheck(name, "end+", "cylinder", 1e-4, 0.0, 1e-15, True, TOL, True)
    joint = JointCheck(name, "cylindrical", (reading,))
    report = CheckReport("exact", {name: joint}, 1e-4, 1e-6, 0.0, 1, 1e-12)
    header, row = report.table().splitlines()[1:3]
    assert row.startswith(f"{name}:end+  ")
    assert header.index("method") + len("method") == row.index("cylinder") + len("cylinder")
