"""Identify a robot's drives: each one's backlash b_j and stiffness k_j from measured deflections of
one point (issue 35; docs/identification.md). :func:`identify` is ``Mechanism.identify``.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import ArgumentError
from .differences import (
    KINDS,
    DifferenceModel,
    MeasuredPoint,
    difference_model,
    measured_point,
    parameter_unit,
    with_drives,
)
from .fit import CORRELATED, LeastSquares, centred, least_squares, rms
from .measurements import Measurements, read_measurements

if TYPE_CHECKING:
    from ..model.mechanism_parts import MechanismParts as Mechanism

__all__ = ["IdentifiedParameter", "Identification", "identify"]


@dataclass(frozen=True)
class IdentifiedParameter:
    """One drive's backlash or stiffness, as the fit found it.

    Attributes:
        joint: the driven joint.
        kind: ``"backlash"`` [rad, or m for a prismatic drive] or ``"drive_stiffness"``
            [N m/rad, or N/m].
        value: the estimate (the prior when not fitted); a stiffness fitted as a compliance
            c <= 0 is ``inf`` (rigid) or negative, status ``"not physical"``.
        standard_error: its standard error (NaN when not fitted); for a stiffness
            se(k) = se(c) / c^2 (first order).
        prior: the clearance file's value (``inf``: a rigid drive).
        status: ``"identified"``, ``"not physical"`` (a negative backlash or compliance: the
            file's value is kept when writing), ``"unobservable"``, ``"not separable"`` or
            ``"not fitted"`` (not asked for).
        reason: why it was not identified ("" when it was).
        compliance: the fitted unknown of a stiffness, c = 1/k [rad/(N m)] (None for backlash).
        compliance_error: its standard error.
    """

    joint: str
    kind: str
    value: float
    standard_error: float
    prior: float
    status: str
    reason: str = ""
    compliance: float | None = None
    compliance_error: float | None = None
    prismatic: bool = False

    @property
    def unit(self) -> str:
        return parameter_unit(self.kind, self.prismatic)

    @property
    def label(self) -> str:
        return f"{self.joint} {self.kind}"


@dataclass(frozen=True)
class Identification:
    """What :func:`identify` found, with its statistics and residuals.

    Attributes:
        point: the measured point.
        parameters: every drive's backlash and stiffness (:class:`IdentifiedParameter`).
        status: ``"ok"`` (every parameter asked for identified), ``"partial"`` (some were
            not: their status says why) or ``"failed"`` (none could be).
        rank: numerical rank of the scaled design matrix of the observable parameters.
        condition: its condition number (of what was fitted).
        correlated: pairs of fitted parameters with |correlation| > 0.9: (label, label, corr).
        sigma: the residuals' standard deviation after the fit [m] (an estimate of the
            measurement noise, per coordinate).
        rms: ``{"fitted": {...}, "held_out": {...}}``, each ``{"before_m", "after_m"}`` (and
            ``"before_rad"``, ``"after_rad"`` with rotations): root mean square of the
            within-pose residuals (each coordinate less its pose's mean) with the clearance
            file's values (before) and the identified ones (after); ``held_out`` empty without
            held-out poses.
        poses, rows: poses and measurements fitted; held_out_poses: those kept out.
        solver_check: the largest difference [m] between the fitted linear model and the
            solver's answer of the identified mechanism on the fitted rows (within-pose
            deviations): the linear model is the solver's, to round-off.
        residuals: the fitted rows' within-pose residuals after the fit (M, d) [m, rad].
        gravity: the arm's own weight was among the loads.
        time: wall time [s].
        notes: anything the report should say.
    """

    point: MeasuredPoint
    parameters: tuple[IdentifiedParameter, ...]
    status: str
    rank: int
    condition: float
    correlated: tuple[tuple[str, str, float], ...]
    sigma: float
    rms: dict[str, dict[str, float]]
    poses: int
    rows: int
    held_out_poses: int
    solver_check: float
    residuals: np.ndarray
    gravity: bool
    time: float
    notes: tuple[str, ...] = ()
    mechanism: Any = field(default=None, repr=False, compare=False)

    def parameter(self, joint: str, kind: str) -> IdentifiedParameter:
        """The parameter ``kind`` (``"backlash"``, ``"drive_stiffness"``) of ``joint``."""
        for parameter in self.parameters:
            if parameter.joint == joint and parameter.kind == kind:
                return parameter
        raise ArgumentError("joint, kind", "a fitted drive and a kind", (joint, kind))

    def drive_values(self) -> dict[str, tuple[float, float]]:
        """Joint -> (backlash, drive stiffness) to write: the identified values where they are
        physical, the clearance file's elsewhere (SI; stiffness inf: rigid)."""
        values: dict[str, list[float]] = {}
        for parameter in self.parameters:
            entry = values.setdefault(parameter.joint, [np.nan, np.nan])
            kept = parameter.status == "identified"
            entry[KINDS.index(parameter.kind)] = parameter.value if kept else parameter.prior
        return {joint: (b, k) for joint, (b, k) in values.items()}

    def identified_mechanism(self) -> Mechanism:
        """The robot with :meth:`drive_values` (its values not checked again)."""
        return with_drives(self.mechanism, self.drive_values())

    def write_clearances(
        self, path: str | os.PathLike[str], base: str | os.PathLike[str] | None = None
    ) -> None:
        """Write a TOML clearance file: ``base`` (the clearance file the robot was loaded with;
        None: the block inside its model file) with each drive's :meth:`drive_values`
        (docs/model-format.md). Loaded beside the model it gives these values back."""
        from .clearance_output import write_clearances

        write_clearances(path, self.mechanism, self.drive_values(), base)

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready summary (SI; infinite stiffness as null)."""

        def number(value: float | None) -> float | None:
            return None if value is None or not np.isfinite(value) else float(value)

        return {
            "point": {
                "frame": self.point.frame,
                "offset_m": [float(v) for v in self.point.offset],
                "link": self.point.link,
            },
            "status": self.status,
            "gravity": self.gravity,
            "poses": self.poses,
            "rows": self.rows,
            "held_out_poses": self.held_out_poses,
            "parameters": [
                {
                    "joint": p.joint,
                    "kind": p.kind,
                    "unit": p.unit,
                    "value": number(p.value),
                    "standard_error": number(p.standard_error),
                    "prior": number(p.prior),
                    "status": p.status,
                    "reason": p.reason,
                }
                for p in self.parameters
            ],
            "rank": self.rank,
            "condition": number(self.condition),
            "correlated": [
                {"first": a, "second": b, "correlation": c} for a, b, c in self.correlated
            ],
            "sigma_m": number(self.sigma),
            "rms": {
                part: {key: number(value) for key, value in values.items()}
                for part, values in self.rms.items()
            },
            "solver_check_m": number(self.solver_check),
            "time_s": self.time,
            "notes": list(self.notes),
        }

    def table(self) -> str:
        """The engineer's summary."""
        lines = [
            f"identified at {self.point.label} from {self.poses} poses, {self.rows} "
            f"measurements (arm's weight {'on' if self.gravity else 'off'}): {self.status}",
            f"{'joint':<22} {'parameter':<26} {'value':>12} {'std. error':>11} {'file':>12}  status",
        ]
        for p in self.parameters:
            value, error, prior = p.value, p.standard_error, p.prior
            lines.append(
                f"{p.joint:<22} {p.kind + ' [' + p.unit + ']':<26} "
                f"{value:12.5g} {error:11.3g} {prior:12.5g}  {p.status}"
                + (f": {p.reason}" if p.reason else "")
            )
        lines.append(
            f"rank {self.rank}, condition {self.condition:.3g}, residual sigma "
            f"{self.sigma * 1e6:.3g} um, model vs solver {self.solver_check:.2g} m"
        )
        for a, b, c in self.correlated:
            lines.append(f"correlated: {a} and {b} ({c:+.3f})")
        for part, values in self.rms.items():
            if values:
                lines.append(
                    f"residual RMS, {part.replace('_', '-')} poses: before {values['before_m'] * 1e6:.3g} "
                    f"um, after {values['after_m'] * 1e6:.3g} um"
                )
        lines += list(self.notes)
        return "\n".join(lines)


def identify(
    mechanism: Mechanism,
    measurements: Measurements | str | os.PathLike[str],
    point: Any,
    parameters: Any = KINDS,
    joints: Any = None,
    gravity: bool | None = None,
    held_out: Measurements | float | None = None,
    rotation_weight: float | None = None,
    seed: int = 0,
) -> Identification:
    """Fit each driven joint's backlash b_j and drive stiffness k_j to measured deflections.

    Args:
        mechanism: the robot, its clearance file's values the priors (and what the fit does not
            change: its bearings' play and compliance, kept fixed).
        measurements: a measurement file (:mod:`.measurements`) or :class:`Measurements`.
        point: the measured point: a frame, ``"FRAME@[x y z]"`` or ``(frame, [x, y, z])`` [m].
        parameters: which of ``"backlash"``, ``"drive_stiffness"`` to fit (the other at the
            file's values).
        joints: the drives to fit (default: every driven joint that moves the point).
        gravity: the arm's own weight among the loads: None as the model says (a real robot
            always carries it: switch it on unless the model does).
        held_out: poses kept out of the fit to judge its prediction: a share in (0, 1) of the
            poses (chosen with ``seed``) or other :class:`Measurements`.
        rotation_weight: with measured rotations, the length [m/rad] a rotation's residual
            counts as (default: the robot's length scale).

    Returns:
        :class:`Identification`.
    """
    started = time.perf_counter()
    kinds = (parameters,) if isinstance(parameters, str) else tuple(parameters)
    for kind in kinds:
        if kind not in KINDS:
            raise ArgumentError("parameters", f"a subset of {KINDS}", parameters)
    if not kinds:
        raise ArgumentError("parameters", f"at least one of {KINDS}", parameters)
    if not isinstance(measurements, Measurements):
        measurements = read_measurements(measurements, mechanism)
    if measurements.configurations.shape[1] != mechanism.model.nq:
        raise ArgumentError(
            "measurements", f"configurations of {mechanism.model.nq} coordinates",
            measurements.configurations.shape,
        )  # fmt: skip
    where = measured_point(mechanism, point)
    fitted, kept = _split(measurements, held_out, seed)
    rotations = fitted.rotations is not None
    d = 6 if rotations else 3
    weight = mechanism.length_scale() if rotation_weight is None else float(rotation_weight)
    if not (np.isfinite(weight) and weight > 0.0):
        raise ArgumentError("rotation_weight", "a length > 0 [m/rad]", rotation_weight)
    weights = np.array([1.0] * 3 + [weight] * (d - 3))
    model = difference_model(
        mechanism, where, fitted.configurations, fitted.forces, joints, gravity, rotations
    )
    measured = _measured(fitted)
    free = np.array([p.kind in kinds for p in model.parameters])
    fit = least_squares(model, measured, fitted.pose_of_row, free, weights)
    prior = model.prior()
    before = rms(model, measured, fitted.pose_of_row, prior)
    after = rms(model, measured, fitted.pose_of_row, fit.theta)
    report = {"fitted": _rms_entry(before, after), "held_out": {}}
    if kept is not None:
        other = difference_model(
            mechanism, where, kept.configurations, kept.forces, joints, gravity, rotations
        )
        held = _measured(kept)
        report["held_out"] = _rms_entry(
            rms(other, held, kept.pose_of_row, prior), rms(other, held, kept.pose_of_row, fit.theta)
        )
    identified = _parameters(model, fit, free)
    status = _status(identified, kinds)
    notes = [
        f"{p.label}: {p.value:.4g} {p.unit} is not physical; the clearance file's value is kept"
        for p in identified
        if p.status == "not physical"
    ]
    result = Identification(
        where,
        identified,
        status,
        fit.rank,
        fit.condition,
        _correlated(model, fit),
        fit.sigma,
        report,
        len(fitted.poses),
        len(fitted),
        0 if kept is None else len(kept.poses),
        np.nan,
        centred(measured - model.predict(fit.theta), fitted.pose_of_row),
        model.gravity,
        0.0,
        tuple(notes),
        mechanism,
    )
    check = _solver_check(result, model, fitted, gravity, fit.theta)
    return _replaced(result, solver_check=check, time=time.perf_counter() - started)


def _replaced(result: Identification, **changes: Any) -> Identification:
    from dataclasses import replace

    return replace(result, **changes)


def _measured(measurements: Measurements) -> np.ndarray:
    """The measured coordinates (M, d): positions, then (with rotations) rotation vectors taken
    relative to the pose's first row, so that only their small differences enter (rad)."""
    if measurements.rotations is None:
        return measurements.positions
    import pinocchio as pin

    turned = np.zeros_like(measurements.rotations)
    first: dict[int, np.ndarray] = {}
    for i, (pose, vector) in enumerate(zip(measurements.pose_of_row, measurements.rotations)):
        rotation = pin.exp3(vector)
        reference = first.setdefault(int(pose), rotation)
        turned[i] = pin.log3(rotation @ reference.T)  # world axes
    return np.hstack([measurements.positions, turned])


def _split(
    measurements: Measurements, held_out: Measurements | float | None, seed: int
) -> tuple[Measurements, Measurements | None]:
    if held_out is None:
        return measurements, None
    if isinstance(held_out, Measurements):
        return measurements, held_out
    share = float(held_out)
    count = round(share * len(measurements.poses))
    if not (0.0 < share < 1.0) or count < 1 or count >= len(measurements.poses):
        raise ArgumentError(
            "held_out", "a share in (0, 1) leaving at least one pose on each side", held_out
        )
    rng = np.random.default_rng(seed)
    chosen = np.sort(rng.choice(len(measurements.poses), count, replace=False))
    rest = np.setdiff1d(np.arange(len(measurements.poses)), chosen)
    return measurements.subset(rest), measurements.subset(chosen)


def _rms_entry(
    before: tuple[float, float | None], after: tuple[float, float | None]
) -> dict[str, float]:
    entry = {"before_m": before[0], "after_m": after[0]}
    if before[1] is not None and after[1] is not None:
        entry.update({"before_rad": before[1], "after_rad": after[1]})
    return entry


def _parameters(
    model: DifferenceModel, fit: LeastSquares, free: np.ndarray
) -> tuple[IdentifiedParameter, ...]:
    errors = fit.standard_errors()
    out = []
    for i, parameter in enumerate(model.parameters):
        estimate, error = float(fit.theta[i]), float(errors[i])
        fitted = i in set(fit.fitted.tolist())
        reason = fit.left_out.get(i, "" if free[i] or fitted else "not asked for")
        status = "identified" if fitted else "not fitted"
        if not fitted and reason.startswith("unobservable"):
            status = "unobservable"
        elif not fitted and reason.startswith("it does not move"):
            status = "unobservable"
        elif not fitted and reason.startswith("not separable"):
            status = "not separable"
        if parameter.kind == "backlash":
            if fitted and estimate < 0.0:
                status = "not physical"
            value = estimate if fitted else parameter.prior
            out.append(IdentifiedParameter(parameter.joint, "backlash", value, error,
                                           parameter.prior, status, reason,
                                           prismatic=parameter.prismatic))  # fmt: skip
            continue
        if fitted:
            stiffness = 1.0 / estimate if estimate != 0.0 else np.inf
            status = "identified" if estimate > 0.0 else "not physical"
            out.append(IdentifiedParameter(
                parameter.joint, "drive_stiffness", stiffness, error / estimate**2,
                parameter.prior, status, reason, estimate, error, parameter.prismatic,
            ))  # fmt: skip
        else:
            out.append(IdentifiedParameter(parameter.joint, "drive_stiffness", parameter.prior,
                                           np.nan, parameter.prior, status, reason,
                                           prismatic=parameter.prismatic))  # fmt: skip
    return tuple(out)


def _status(parameters: tuple[IdentifiedParameter, ...], kinds: tuple[str, ...]) -> str:
    asked = [p for p in parameters if p.kind in kinds]
    done = [p for p in asked if p.status == "identified"]
    if not done:
        return "failed"
    return "ok" if len(done) == len(asked) else "partial"


def _correlated(model: DifferenceModel, fit: LeastSquares) -> tuple[tuple[str, str, float], ...]:
    correlation = fit.correlations()
    labels = [f"{model.parameters[i].joint} {model.parameters[i].kind}" for i in fit.fitted]
    pairs = []
    for a in range(len(labels)):
        for b in range(a + 1, len(labels)):
            if abs(correlation[a, b]) > CORRELATED:
                pairs.append((labels[a], labels[b], float(correlation[a, b])))
    return tuple(pairs)


def _solver_check(
    result: Identification,
    model: DifferenceModel,
    fitted: Measurements,
    gravity: bool | None,
    theta: np.ndarray,
) -> float:
    """The largest difference [m] between the linear model's within-pose deviations at
    ``theta`` and the solver's, the robot solved with the values written to the file."""
    from ..model.loads import PointForce

    values = {joint: (b, k) for joint, (b, k) in result.drive_values().items()}
    used = theta.copy()
    for i, parameter in enumerate(model.parameters):  # what the file gets, in theta's terms
        b, k = values[parameter.joint]
        used[i] = b if parameter.kind == "backlash" else 1.0 / k
    robot = with_drives(result.mechanism, values)
    point = result.point
    cases = [
        [PointForce(point.link, f, point.link_point)] if np.any(f) else [] for f in fitted.forces
    ]
    batch = robot.solve_many(cases, configurations=list(fitted.configurations), gravity=gravity)
    translation, rotation = batch.frame_displacements(point.frame)
    import pinocchio as pin

    data = robot.model.createData()
    solved = np.zeros_like(translation)
    for i, q in enumerate(fitted.configurations):
        pin.forwardKinematics(robot.model, data, q)
        axes = pin.updateFramePlacement(robot.model, data, point.frame_id).rotation
        solved[i] = translation[i] + np.cross(rotation[i], axes @ point.offset)
    predicted = model.predict(used)[:, :3]
    difference = centred(solved - predicted, fitted.pose_of_row)
    return float(np.max(np.abs(difference), initial=0.0))
