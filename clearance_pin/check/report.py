"""The answer of a cross-check: per joint and per contact point, the model's gap, coal's reading,
the tolerance term by term, and a verdict; a report that says loudly what failed and by how much.

Verdicts (coal's reading :math:`D`, what it should read :math:`e` = 0 for a predicted contact and
the model's gap :math:`g` for a free point, tolerance :math:`\\tau` above and :math:`\\tau_-` below,
equal unless one-sided, :mod:`.accuracy`):

- ``penetration``: :math:`D < -\\tau_-` (parts overlap), whatever the model predicts;
- ``off boundary``: a predicted contact with :math:`D - e` outside :math:`[-\\tau_-, \\tau]`;
- ``gap mismatch``: a predicted free point with :math:`D - e` outside :math:`[-\\tau_-, \\tau]`;
- ``not judged``: the tolerance is unknown (a URDF mesh whose faceting was not given): only
  penetration is judged;
- ``ok`` otherwise.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from ..equilibrium.report import columns
from ..errors import ArgumentError
from .accuracy import Tolerance

UNITS = {1.0: "m", 1e3: "mm", 1e6: "um", 1e9: "nm"}


@dataclass(frozen=True)
class PointCheck:
    """One coal reading: a contact point (point check) or a pair of surfaces (surface check).

    Attributes:
        joint: joint name.
        point: contact point name (``ball``, ``end-``, ...), or ``surface`` / ``parts``.
        method: what coal measured (``sphere``, ``cylinder``, ``box``: point in a solid primitive;
            ``bore N=...``: journal cylinder in a generated faceted bore; ``parts``: the URDF's
            collision geometry).
        clearance: the clearance of the reading [m].
        model_gap: the model's gap (``Contact.gap``; for a surface check the smallest of the
            joint's radial points) [m].
        distance: coal's reading of the same gap [m] (negative: penetration).
        contact: the model predicts a contact.
        tolerance: the tolerance, term by term.
        judged: False when the tolerance is unknown (only penetration is judged).
    """

    joint: str
    point: str
    method: str
    clearance: float
    model_gap: float
    distance: float
    contact: bool
    tolerance: Tolerance
    judged: bool = True

    @property
    def label(self) -> str:
        """``joint:point``."""
        return f"{self.joint}:{self.point}"

    @property
    def expected(self) -> float:
        """What coal should read [m]: 0 for a predicted contact, else the model's gap."""
        return 0.0 if self.contact else self.model_gap

    @property
    def deviation(self) -> float:
        """coal's reading minus what it should read [m]."""
        return self.distance - self.expected

    @property
    def verdict(self) -> str:
        """``ok``, ``penetration``, ``off boundary``, ``gap mismatch`` or ``not judged``."""
        above, below = self.tolerance.total, self.tolerance.below
        if self.distance < -below:
            return "penetration"
        if not self.judged:
            return "not judged"
        if -below <= self.deviation <= above:
            return "ok"
        return "off boundary" if self.contact else "gap mismatch"

    @property
    def ok(self) -> bool:
        """The reading passes (``ok`` or ``not judged``)."""
        return self.verdict in ("ok", "not judged")

    def message(self, length: float = 1e6, unit: str = "um") -> str:
        """One line saying what failed, where, and by how much (empty when it passed)."""
        if self.ok:
            return ""
        if self.verdict == "penetration":
            excess, bound = -self.distance, self.tolerance.below
            what = f"parts overlap by {excess * length:.6g} {unit}"
            if self.method.startswith(("bore", "parts")):
                what += " (coal's deepest facet penetration; the solids may overlap more)"
        else:
            excess = abs(self.deviation)
            bound = self.tolerance.total if self.deviation > 0 else self.tolerance.below
            if self.contact:
                what = (
                    f"predicted contact, coal reads {self.distance * length:.6g} {unit}: off the "
                    f"boundary by {excess * length:.6g} {unit}"
                )
            else:
                what = (
                    f"model gap {self.model_gap * length:.6g} {unit}, coal reads "
                    f"{self.distance * length:.6g} {unit}: off by {excess * length:.6g} {unit}"
                )
        ratio = excess / bound if bound > 0 else float("inf")
        return (
            f"FAIL {self.label} ({self.method}): {what} > tolerance {bound * length:.3g} {unit} "
            f"({ratio:.3g} x)"
        )


@dataclass(frozen=True)
class JointCheck:
    """The readings of one joint.

    Attributes:
        name: joint name.
        kind: its clearance kind.
        points: one reading per contact point, in the order of ``Equilibrium.contacts``.
        surfaces: surface readings (generated bore, URDF collision parts), may be empty.
    """

    name: str
    kind: str
    points: tuple[PointCheck, ...]
    surfaces: tuple[PointCheck, ...] = ()

    @property
    def readings(self) -> tuple[PointCheck, ...]:
        """Points, then surfaces."""
        return self.points + self.surfaces

    @property
    def ok(self) -> bool:
        """Every reading passes."""
        return all(r.ok for r in self.readings)


@dataclass(frozen=True)
class CheckReport:
    """coal's measure of a solved pose (see :func:`clearance_pin.check.check_equilibrium`).

    Attributes:
        formulation: the checked equilibrium's formulation (``linear`` or ``exact``).
        joints: joint name -> :class:`JointCheck`, joints with contact points only.
        check_time: wall time of the whole check [s] (poses, shapes, coal calls).
        coal_time: wall time inside coal's distance calls [s].
        build_time: wall time spent building coal shapes in this call [s] (0 when cached).
        readings: number of coal distance calls.
        gjk_tolerance: GJK/EPA tolerance used (relative).
        notes: what was not checked and why (joints without play, unknown faceting, ...).
        departure: for a linear answer checked on its exact pose, the measure of the linear pose
            itself: how far the small-displacement model's own pose sits off the real
            boundaries (its second-order error; information, not part of the verdict).
        exact_solve_time: wall time [s] of the exact solve that gave the checked pose (0 when
            the pose was measured as solved).
        information: this report is a linear pose's departure (information, not a verdict: its
            summary says how far off, not FAILED).
    """

    formulation: str
    joints: dict[str, JointCheck]
    check_time: float
    coal_time: float
    build_time: float
    readings: int
    gjk_tolerance: float
    notes: tuple[str, ...] = field(default=())
    departure: CheckReport | None = None
    exact_solve_time: float = 0.0
    information: bool = False

    @property
    def ok(self) -> bool:
        """Every reading of every joint passes."""
        return all(j.ok for j in self.joints.values())

    @property
    def failures(self) -> tuple[PointCheck, ...]:
        """The readings that fail, worst first (deviation over tolerance)."""
        failed = [r for j in self.joints.values() for r in j.readings if not r.ok]
        return tuple(sorted(failed, key=_excess, reverse=True))

    @property
    def off_boundary(self) -> tuple[float, str]:
        """Largest |deviation| [m] of a point reading from what coal should read, and where: for a
        linear solution, how far its pose sits off the real clearance boundaries. (Surface
        readings are left out: their deviations include the faceting and the journal's rim.)"""
        readings = [r for j in self.joints.values() for r in j.points]
        if not readings:
            return 0.0, ""
        worst = max(readings, key=lambda r: abs(r.deviation))
        return abs(worst.deviation), worst.label

    def summary(self, length: float = 1e6, unit: str = "um") -> str:
        """One line: verdict, size, times, and for a linear pose how far off it sits."""
        count = sum(len(j.readings) for j in self.joints.values())
        off, where = self.off_boundary
        if self.information:
            return (
                f"departure of the small-displacement pose from the real boundaries (information, "
                f"not a verdict): up to {off * length:.4g} {unit}{f' at {where}' if where else ''}"
                f", {count} readings in {len(self.joints)} joints"
            )
        checked = self.formulation
        if self.departure is not None:
            checked = "the exact pose of the small-displacement answer"
        line = (
            f"coal check ({checked}): {'ok' if self.ok else 'FAILED'}, {count} readings "
            f"in {len(self.joints)} joints, {self.check_time * 1e6:.0f} us "
            f"(coal {self.coal_time * 1e6:.0f} us, shapes built {self.build_time * 1e6:.0f} us)"
        )
        if where:
            line += f"; largest deviation {off * length:.4g} {unit} at {where}"
        if self.formulation == "linear" and where:
            exceeded = any(not r.ok for j in self.joints.values() for r in j.points)
            line += (
                f"; the small-displacement pose sits up to {off * length:.4g} {unit} off the real "
                f"boundaries ({'exceeds' if exceeded else 'within'} the tolerance; no allowance "
                "is made for the model's error)"
            )
        if self.departure is not None:
            apart, at = self.departure.off_boundary
            line += (
                f"; the small-displacement pose itself sits up to {apart * length:.4g} {unit} off "
                f"the real boundaries{f' at {at}' if at else ''} (the linear model's second-order "
                "error, information: pose='as_solved' judges it)"
            )
        return line

    def table(self, length: float = 1e6, unit: str = "um") -> str:
        """A readable table: one row per reading, the tolerance term by term, failures listed."""
        header = ["reading", "method", "pred.", "model gap", "coal", "deviation", "tolerance",
                  f"= facets + rim + solver + coal [{unit}]", "verdict"]  # fmt: skip
        rows = []
        for joint in self.joints.values():
            for r in joint.readings:
                t = r.tolerance
                rows.append(
                    [
                        r.label,
                        r.method,
                        "contact" if r.contact else "free",
                        f"{r.model_gap * length + 0.0:.6g}",
                        f"{r.distance * length + 0.0:.6g}",
                        f"{r.deviation * length + 0.0:.4g}",
                        f"{t.total * length:.3g}{'^' if t.one_sided else ' '}",
                        f"= {t.faceting * length:.2g} + {t.rim * length:.2g} + "
                        f"{t.solver * length:.2g} + {t.coal * length:.2g}",
                        r.verdict,
                    ]
                )
        # every column as wide as its widest cell: long joint names never run into the next
        lines = [self.summary(length, unit), *columns(header, rows)]
        lines.extend(r.message(length, unit) for r in self.failures)
        if any(r.tolerance.one_sided for j in self.joints.values() for r in j.readings):
            lines.append(
                "^ one-sided: the faceting and rim terms only raise a reading; below what it "
                "should read, a reading may lie by solver + coal only"
            )
        lines.extend(self.notes)
        return "\n".join(lines)

    def to_dict(self, length: float = 1.0, unit: str | None = None) -> dict[str, Any]:
        """JSON-ready dict; lengths times ``length``, keys suffixed ``_<unit>`` (``unit`` defaults
        from ``length``: 1 -> m, 1e3 -> mm, 1e6 -> um, 1e9 -> nm). One list entry per contact
        point: ``{"ok", "formulation", "joints": {name: {"point", "model_gap_<u>",
        "coal_distance_<u>", "tolerance_<u>" (above), "tolerance_below_<u>", "contact", "verdict",
        "tolerance_terms_<u>",
        "surfaces": {same keys}}}, "off_boundary_<u>", "failures", "check_time_s", ...}``."""
        if unit is None:
            if length not in UNITS:
                raise ArgumentError(
                    "length",
                    f"one of {sorted(UNITS)}, or unit=... naming the unit",
                    length,
                    "name the unit of this length (unit=...)",
                )
            unit = UNITS[length]
        off, where = self.off_boundary
        return {
            "ok": self.ok,
            "formulation": self.formulation,
            "length_unit": unit,
            "joints": {
                name: {
                    "kind": joint.kind,
                    **_columns(joint.points, length, unit),
                    "surfaces": _columns(joint.surfaces, length, unit),
                }
                for name, joint in self.joints.items()
            },
            f"off_boundary_{unit}": off * length,
            "off_boundary_at": where,
            "failures": [r.message(length, unit) for r in self.failures],
            "check_time_s": self.check_time,
            "coal_time_s": self.coal_time,
            "build_time_s": self.build_time,
            "readings": self.readings,
            "gjk_tolerance": self.gjk_tolerance,
            "notes": list(self.notes),
            "exact_solve_time_s": self.exact_solve_time,
            "information": self.information,
        }


def _columns(readings: Sequence[PointCheck], length: float, unit: str) -> dict[str, list[Any]]:
    return {
        "point": [r.point for r in readings],
        "method": [r.method for r in readings],
        f"model_gap_{unit}": [r.model_gap * length for r in readings],
        f"coal_distance_{unit}": [r.distance * length for r in readings],
        f"tolerance_{unit}": [r.tolerance.total * length for r in readings],
        f"tolerance_below_{unit}": [r.tolerance.below * length for r in readings],
        "contact": [r.contact for r in readings],
        "verdict": [r.verdict for r in readings],
        f"tolerance_terms_{unit}": [
            {k: v * length for k, v in r.tolerance.terms().items()} for r in readings
        ],
    }


def _excess(reading: PointCheck) -> float:
    tau = reading.tolerance.total if reading.deviation > 0 else reading.tolerance.below
    return abs(reading.deviation) / tau if tau > 0 else float("inf")


__all__ = ["PointCheck", "JointCheck", "CheckReport", "UNITS"]
