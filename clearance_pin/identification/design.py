r"""Where to measure: the poses that determine the drives' backlash and stiffness best
(docs/identification.md, section 4).

The fit's covariance is :math:`\sigma^2 (\bar A^T \bar A)^{-1}`, and :math:`\bar A^T \bar A` is
a sum over the poses of :math:`I_p = \bar A_p^T \bar A_p` (each pose's centred rows under its
loads). It does not depend on the parameters' values, only on the poses and loads (they set the
torques and the backlash sides), so the design is exact for the linear model: choose N of the
candidate poses to maximise :math:`\log\det \sum_p I_p` (D-optimal: the smallest volume of the
parameters' confidence ellipsoid; the choice does not depend on the parameters' units). Greedy
selection (each step the candidate that raises the log-determinant most, from
:math:`\varepsilon I`), then exchange passes (Fedorov): each chosen pose is swapped for the
candidate that raises it most, until no swap does.

Default candidates: poses uniform within the driven joints' limits (seeded), each under the
rated payload's weight :math:`F = m g` applied five ways at the point: hung (world -z) and
pulled along world +x, -x, +y, -y (a cable over a pulley): opposite pulls take up every drive's
backlash on both sides, and a horizontal force is the only one that loads a vertical axis.
"""

from __future__ import annotations

import csv
import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import ArgumentError
from .differences import KINDS, DifferenceModel, difference_model, measured_point
from .fit import RANK_RTOL, centred, observability
from .measurements import STANDARD_GRAVITY

if TYPE_CHECKING:
    from ..model.mechanism_parts import MechanismParts as Mechanism

__all__ = ["Design", "candidate_poses", "design_measurements", "payload_forces"]


def payload_forces(payload: float) -> np.ndarray:
    """The default loads (5, 3) [N] of a rated payload [kg]: its weight hung, then pulled along
    world +x, -x, +y, -y."""
    if not (np.isfinite(payload) and payload > 0.0):
        raise ArgumentError("payload", "a rated payload > 0 [kg]", payload)
    f = STANDARD_GRAVITY * float(payload)
    return np.array([[0, 0, -f], [f, 0, 0], [-f, 0, 0], [0, f, 0], [0, -f, 0]], dtype=float)


def candidate_poses(mechanism: Mechanism, count: int, seed: int = 0) -> np.ndarray:
    """``count`` poses (count, nq): each driven one-coordinate joint uniform within its limits
    (+/- pi for a revolute joint without finite limits), the others nominal."""
    model = mechanism.model
    poses = np.tile(mechanism.q_nominal, (count, 1))
    rng = np.random.default_rng(seed)
    for joint in mechanism.tree_joints:
        if not joint.driven or model.joints[joint.joint_id].nq != 1:
            continue
        index = model.joints[joint.joint_id].idx_q
        low, high = model.lowerPositionLimit[index], model.upperPositionLimit[index]
        if not (np.isfinite(low) and np.isfinite(high) and high > low):
            low, high = -np.pi, np.pi
        poses[:, index] = rng.uniform(low, high, count)
    return poses


@dataclass(frozen=True)
class Design:
    """The chosen poses and what they promise.

    Attributes:
        configurations: the chosen poses (N, nq) [rad, m].
        chosen: their indices among the candidates (N,).
        forces: the loads applied at every pose (L, 3) [N], world axes, at the point.
        labels: each parameter's ``"joint kind"`` (2 J).
        priors: each parameter's clearance-file value (b [rad]; k [N m/rad], inf: rigid).
        standard_errors: the expected standard error of each parameter for :attr:`noise`
            (b [rad]; for a stiffness, of its compliance c = 1/k [rad/(N m)]); NaN where it
            cannot be determined.
        relative_errors: the expected standard error relative to the prior (for a stiffness
            se(k)/k = se(c) k); NaN where the prior is 0 or infinite.
        left_out: label -> why no candidate can determine it.
        noise: the measurement noise assumed [m] (each coordinate, independent).
        log_det: log det of the information matrix (columns scaled to unit norm over the
            candidates).
        point: the point's label; joint_columns: every joint's column of a plan and its
            coordinate.
        time: wall time [s].
    """

    configurations: np.ndarray
    chosen: np.ndarray
    forces: np.ndarray
    labels: tuple[str, ...]
    priors: np.ndarray
    standard_errors: np.ndarray
    relative_errors: np.ndarray
    left_out: dict[str, str]
    noise: float
    log_det: float
    point: str
    joint_columns: dict[str, int]
    time: float

    @property
    def status(self) -> str:
        """``"ok"``: every parameter asked for can be determined by the chosen poses;
        ``"partial"``: some cannot (:attr:`left_out`, or a NaN standard error); ``"failed"``:
        none."""
        asked = [i for i, label in enumerate(self.labels) if label not in self.left_out]
        determined = [i for i in asked if np.isfinite(self.standard_errors[i])]
        if not determined:
            return "failed"
        return "ok" if not self.left_out and len(determined) == len(asked) else "partial"

    def to_dict(self) -> dict[str, Any]:
        def number(value: float) -> float | None:
            return float(value) if np.isfinite(value) else None

        return {
            "status": self.status,
            "poses": len(self.configurations),
            "noise_m": self.noise,
            "forces_N": self.forces.tolist(),
            "configurations": self.configurations.tolist(),
            "candidates_chosen": [int(i) for i in self.chosen],
            "log_det": number(self.log_det),
            "parameters": [
                {
                    "parameter": label,
                    "prior": number(prior),
                    "expected_standard_error": number(error),
                    "expected_relative_error": number(relative),
                    "left_out": self.left_out.get(label, ""),
                }
                for label, prior, error, relative in zip(
                    self.labels, self.priors, self.standard_errors, self.relative_errors
                )
            ],
        }

    def table(self) -> str:
        lines = [
            f"design: {len(self.configurations)} poses x {len(self.forces)} loads at "
            f"{self.point}, noise {self.noise * 1e6:g} um per coordinate: {self.status}",
            f"{'parameter':<40} {'expected std. error':>20} {'relative':>10}",
        ]
        for label, error, relative in zip(self.labels, self.standard_errors, self.relative_errors):
            why = self.left_out.get(label)
            unit = "rad" if label.endswith("backlash") else "rad/N m (c = 1/k)"
            text = f"{error:.3g} {unit}" if why is None else why
            lines.append(f"{label:<40} {text:>20} {relative:10.2%}")
        return "\n".join(lines)

    def write_plan(self, path: str | os.PathLike[str]) -> None:
        """A measurement file to fill in (docs/identification.md): one row per pose and load,
        the joints and the load given, ``x, y, z`` left empty."""
        with Path(path).open("w", newline="", encoding="utf-8") as file:
            writer = csv.writer(file)
            writer.writerow(["pose", *self.joint_columns, "fx", "fy", "fz", "x", "y", "z"])
            for p, q in enumerate(self.configurations):
                joints = [repr(float(q[i])) for i in self.joint_columns.values()]
                for force in self.forces:
                    writer.writerow(
                        [f"P{p + 1}", *joints, *(repr(float(f)) for f in force), "", "", ""]
                    )


def design_measurements(
    mechanism: Mechanism,
    point: Any,
    count: int,
    noise: float,
    candidates: int | np.ndarray = 500,
    forces: Any = None,
    payload: float | None = None,
    parameters: Any = KINDS,
    joints: Any = None,
    gravity: bool | None = None,
    seed: int = 0,
) -> Design:
    """Choose ``count`` poses among ``candidates`` (a number of random poses, or poses (C, nq))
    that determine the drives' parameters best (module docstring).

    Args:
        point: the measured point (as :func:`~.identify.identify`).
        noise: the measurement noise [m] (each coordinate).
        forces: the loads at every pose (L, 3) [N] (L >= 2); default: :func:`payload_forces`
            of ``payload`` [kg].
        parameters, joints, gravity: as :func:`~.identify.identify`.
    """
    started = time.perf_counter()
    if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or count < 1:
        raise ArgumentError("count", "a number of poses >= 1", count)
    if not (np.isfinite(noise) and noise > 0.0):
        raise ArgumentError("noise", "a measurement noise > 0 [m]", noise)
    kinds = (parameters,) if isinstance(parameters, str) else tuple(parameters)
    if not kinds or any(kind not in KINDS for kind in kinds):
        raise ArgumentError("parameters", f"a subset of {KINDS}", parameters)
    if forces is None:
        if payload is None:
            raise ArgumentError("payload", "the rated payload [kg] (or forces=...)", payload)
        loads = payload_forces(payload)
    else:
        loads = np.asarray(forces, dtype=float)
        if loads.ndim != 2 or loads.shape[1] != 3 or len(loads) < 2:
            raise ArgumentError("forces", "two forces or more, shaped (L, 3) [N]", np.shape(forces))
    if isinstance(candidates, (int, np.integer)) and not isinstance(candidates, bool):
        poses = candidate_poses(mechanism, int(candidates), seed)
    else:
        poses = np.asarray(candidates, dtype=float)
        if poses.ndim != 2 or poses.shape[1] != mechanism.model.nq:
            raise ArgumentError(
                "candidates", f"poses shaped (C, {mechanism.model.nq})", poses.shape
            )
    if count > len(poses):
        raise ArgumentError("count", f"at most the {len(poses)} candidates", count)
    where = measured_point(mechanism, point)
    per = len(loads)
    model = difference_model(
        mechanism, where, np.repeat(poses, per, axis=0), np.tile(loads, (len(poses), 1)),
        joints, gravity,
    )  # fmt: skip
    pose_of_row = np.repeat(np.arange(len(poses)), per)
    labels = tuple(f"{p.joint} {p.kind}" for p in model.parameters)
    reasons = observability(model, pose_of_row)
    free = [i for i, p in enumerate(model.parameters) if p.kind in kinds and i not in reasons]
    left_out = {labels[i]: why for i, why in reasons.items() if model.parameters[i].kind in kinds}
    chosen, log_det, information, norms = _d_optimal(model, pose_of_row, free, count, len(poses))
    errors = np.full(len(labels), np.nan)
    if free:
        values, vectors = np.linalg.eigh(information)  # of the unit-norm columns
        kept = values > RANK_RTOL * values[-1]
        scaled = (vectors[:, kept] / values[kept]) @ vectors[:, kept].T
        undetermined = np.sum(vectors[:, ~kept] ** 2, axis=1) > 1e-6  # too few poses for them
        errors[free] = noise * np.sqrt(np.clip(np.diag(scaled), 0.0, None)) / norms
        errors[np.array(free)[undetermined]] = np.nan
    priors = np.array([p.prior for p in model.parameters])
    relative = np.full(len(labels), np.nan)
    for i, parameter in enumerate(model.parameters):
        prior = parameter.prior
        if np.isfinite(prior) and prior > 0.0:
            relative[i] = errors[i] / prior if parameter.kind == "backlash" else errors[i] * prior
    asked = [i for i, parameter in enumerate(model.parameters) if parameter.kind in kinds]
    labels = tuple(labels[i] for i in asked)
    priors, errors, relative = priors[asked], errors[asked], relative[asked]
    columns = {
        mechanism.model.names[j.joint_id]: mechanism.model.joints[j.joint_id].idx_q
        for j in mechanism.tree_joints
        if mechanism.model.joints[j.joint_id].nq == 1
    }
    return Design(
        poses[chosen], chosen, loads, labels, priors, errors, relative, left_out, float(noise),
        log_det, where.label, columns, time.perf_counter() - started,
    )  # fmt: skip


def _d_optimal(
    model: DifferenceModel, pose_of_row: np.ndarray, free: list[int], count: int, poses: int
) -> tuple[np.ndarray, float, np.ndarray, np.ndarray]:
    """(chosen candidates, log det, the information matrix of unit-norm columns, the norms)."""
    if not free:
        return np.arange(count), -np.inf, np.zeros((0, 0)), np.zeros(0)
    rows = centred(model.columns[:, :, free], pose_of_row)  # (C L, d, n)
    n = len(free)
    blocks = rows.reshape(poses, -1, n)  # (C, L d, n)
    norms = np.sqrt(np.einsum("crn,crn->n", blocks, blocks))
    norms[norms == 0.0] = 1.0
    blocks = blocks / norms
    info = np.einsum("crn,crm->cnm", blocks, blocks)  # each candidate's I_p
    ridge = 1e-9 * np.trace(info.sum(axis=0)) / (poses * n) * np.eye(n)
    chosen: list[int] = []
    total = ridge.copy()
    for _ in range(count):
        _, logdets = np.linalg.slogdet(total[None] + info)
        logdets[chosen] = -np.inf
        best = int(np.argmax(logdets))
        chosen.append(best)
        total += info[best]
    for _ in range(10):  # exchange passes
        improved = False
        for k in range(count):
            without = total - info[chosen[k]]
            _, logdets = np.linalg.slogdet(without[None] + info)
            current = logdets[chosen[k]]
            logdets[chosen] = -np.inf
            best = int(np.argmax(logdets))
            if logdets[best] > current + 1e-9 * max(1.0, abs(current)):
                total = without + info[best]
                chosen[k] = best
                improved = True
        if not improved:
            break
    information = info[chosen].sum(axis=0)
    sign, log_det = np.linalg.slogdet(information)
    return np.array(chosen), float(log_det) if sign > 0 else -np.inf, information, norms
