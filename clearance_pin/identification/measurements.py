"""The measurement file of ``clearance-pin identify``: where one point of a robot was measured, at
several poses, each pose under two or more loads (docs/identification.md).

A CSV file with a header line, one row per measurement (blank lines and lines starting with
``#`` are skipped; the values are SI):

- ``pose``: an identifier shared by the rows of one pose (any text);
- one column per joint of the model, named as in the model: its value [rad, or m for a
  prismatic joint]; joints without a column stay at their nominal value. The rows of one pose
  must give the same values;
- the load at the measured point: ``mass`` [kg] hung there (its weight, 9.80665 m/s^2 along
  world -z) and/or ``fx, fy, fz`` [N] (world axes); both present: their sum;
- ``x, y, z``: the measured position [m], in any fixed frame whose axes are the model's world
  axes (its origin anywhere: only differences within a pose are used);
- optional ``rx, ry, rz``: the measured orientation as a rotation vector [rad], same axes.

Every problem is a :class:`~clearance_pin.errors.MeasurementError` naming the file, the line and
the column.
"""

from __future__ import annotations

import csv
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..errors import MeasurementError

if TYPE_CHECKING:
    from ..model.mechanism_parts import MechanismParts as Mechanism

STANDARD_GRAVITY = 9.80665  # [m/s^2], a hung mass's weight (as the accuracy map's payloads)
POSITION = ("x", "y", "z")
ROTATION = ("rx", "ry", "rz")
FORCE = ("fx", "fy", "fz")
SAME_POSE_TOLERANCE = 1e-9  # [rad or m]: the rows of one pose give the same joint values to this

__all__ = ["Measurements", "read_measurements", "STANDARD_GRAVITY"]


@dataclass(frozen=True)
class Measurements:
    """Measurements of one point of a robot, grouped by pose (M rows, P poses).

    Attributes:
        poses: each pose's identifier, in the order of first appearance (P,).
        pose_of_row: the pose index of each row (M,).
        configurations: the joint configuration q of each row (M, nq) [rad, m].
        forces: the force at the measured point of each row (M, 3) [N], world axes.
        positions: the measured positions (M, 3) [m].
        rotations: the measured rotation vectors (M, 3) [rad], or None.
        lines: each row's line in the file (M,) (its index + 2 for arrays), for messages.
        source: the file, or ``"<api>"``.
    """

    poses: tuple[str, ...]
    pose_of_row: np.ndarray
    configurations: np.ndarray
    forces: np.ndarray
    positions: np.ndarray
    rotations: np.ndarray | None
    lines: np.ndarray
    source: str = "<api>"

    def __len__(self) -> int:
        return len(self.pose_of_row)

    def subset(self, poses: np.ndarray) -> Measurements:
        """The rows of the poses whose indices are in ``poses`` (indices renumbered)."""
        keep = np.isin(self.pose_of_row, poses)
        kept = sorted(set(int(p) for p in self.pose_of_row[keep]), key=list(poses).index)
        renumber = {old: new for new, old in enumerate(kept)}
        return Measurements(
            tuple(self.poses[p] for p in kept),
            np.array([renumber[int(p)] for p in self.pose_of_row[keep]], dtype=int),
            self.configurations[keep],
            self.forces[keep],
            self.positions[keep],
            None if self.rotations is None else self.rotations[keep],
            self.lines[keep],
            self.source,
        )

    @classmethod
    def from_arrays(
        cls,
        pose_of_row: np.ndarray,
        configurations: np.ndarray,
        forces: np.ndarray,
        positions: np.ndarray,
        rotations: np.ndarray | None = None,
        source: str = "<api>",
    ) -> Measurements:
        """Measurements from arrays (M rows): pose index (M,) (or any hashable ids), q (M, nq),
        forces (M, 3) [N], positions (M, 3) [m], rotation vectors (M, 3) [rad] or None; checked
        as a file's rows (each row named ``line index + 2``, as if under a header)."""
        ids = [str(p) for p in np.asarray(pose_of_row).tolist()]
        order = list(dict.fromkeys(ids))
        index = {name: k for k, name in enumerate(order)}
        rows = len(ids)
        arrays = {
            "configurations": np.asarray(configurations, dtype=float),
            "forces": np.asarray(forces, dtype=float),
            "positions": np.asarray(positions, dtype=float),
        }
        if rotations is not None:
            arrays["rotations"] = np.asarray(rotations, dtype=float)
        for name, values in arrays.items():
            if values.ndim != 2 or values.shape[0] != rows:
                raise MeasurementError(
                    source, None, name, f"{rows} rows expected, found shape {values.shape}"
                )
            bad = np.argwhere(~np.isfinite(values))
            if len(bad):
                raise MeasurementError(source, int(bad[0][0]) + 2, name, "not a finite number")
        measurements = cls(
            tuple(order),
            np.array([index[i] for i in ids], dtype=int),
            arrays["configurations"],
            arrays["forces"],
            arrays["positions"],
            arrays.get("rotations"),
            np.arange(rows) + 2,
            source,
        )
        _check_poses(measurements)
        return measurements


def read_measurements(path: str | os.PathLike[str], mechanism: Mechanism) -> Measurements:
    """Read a measurement file (module docstring) for ``mechanism``.

    Raises:
        MeasurementError: the file cannot be read, a column is unknown or missing, a value is
            not a finite number, a pose has one row or rows of different joint values; the
            message names the line and the column.
    """
    source = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8-sig")
    except (OSError, UnicodeDecodeError) as error:
        raise MeasurementError(source, None, None, f"cannot be read: {error}") from None
    numbered = [
        (number, line)
        for number, line in enumerate(text.splitlines(), start=1)
        if line.strip() and not line.lstrip().startswith("#")
    ]
    if not numbered:
        raise MeasurementError(source, None, None, "no header line and no rows")
    header_line, header_text = numbered[0]
    header = [name.strip() for name in next(csv.reader([header_text]))]
    joints = _joint_columns(mechanism)
    _check_header(source, header_line, header, joints)
    column = {name: k for k, name in enumerate(header)}
    model = mechanism.model
    rows = numbered[1:]
    if not rows:
        raise MeasurementError(source, None, None, "a header and no measurement rows")
    ids: list[str] = []
    q = np.tile(mechanism.q_nominal, (len(rows), 1))
    forces = np.zeros((len(rows), 3))
    positions = np.zeros((len(rows), 3))
    rotated = all(name in column for name in ROTATION)
    rotations = np.zeros((len(rows), 3)) if rotated else None
    lines = np.array([number for number, _ in rows], dtype=int)
    for i, (number, line) in enumerate(rows):
        cells = [cell.strip() for cell in next(csv.reader([line]))]
        if len(cells) != len(header):
            raise MeasurementError(
                source, number, None, f"{len(cells)} values for the {len(header)} columns"
            )

        def value(name: str, number: int = number, cells: list[str] = cells) -> float:
            text = cells[column[name]]
            try:
                parsed = float(text)
            except ValueError:
                parsed = math.nan
            if not math.isfinite(parsed):
                raise MeasurementError(source, number, name, f"{text!r} is not a finite number")
            return parsed

        pose = cells[column["pose"]]
        if not pose:
            raise MeasurementError(source, number, "pose", "empty: every row names its pose")
        ids.append(pose)
        for name, joint_id in joints.items():
            if name in column:
                q[i, model.joints[joint_id].idx_q] = value(name)
        if "mass" in column:
            mass = value("mass")
            if mass < 0.0:
                raise MeasurementError(source, number, "mass", f"{mass} kg: a mass is >= 0")
            forces[i, 2] -= STANDARD_GRAVITY * mass
        if "fx" in column:
            forces[i] += [value(name) for name in FORCE]
        positions[i] = [value(name) for name in POSITION]
        if rotations is not None:
            rotations[i] = [value(name) for name in ROTATION]
    order = list(dict.fromkeys(ids))
    index = {name: k for k, name in enumerate(order)}
    measurements = Measurements(
        tuple(order),
        np.array([index[name] for name in ids], dtype=int),
        q,
        forces,
        positions,
        rotations,
        lines,
        source,
    )
    _check_poses(measurements, {model.joints[j].idx_q: name for name, j in joints.items()})
    return measurements


def _joint_columns(mechanism: Mechanism) -> dict[str, int]:
    """Joint name -> Pinocchio joint id of every 1-coordinate joint (a column may give it)."""
    model = mechanism.model
    return {model.names[j]: j for j in range(1, model.njoints) if model.joints[j].nq == 1}


def _check_header(source: str, line: int, header: list[str], joints: dict[str, int]) -> None:
    known = {"pose", "mass", *FORCE, *POSITION, *ROTATION, *joints}
    seen: set[str] = set()
    for name in header:
        if name in seen:
            raise MeasurementError(source, line, name, "a column named twice")
        seen.add(name)
        if name not in known:
            raise MeasurementError(
                source,
                line,
                name,
                "unknown column; the columns are pose, mass and/or fx, fy, fz, x, y, z, "
                f"optionally rx, ry, rz, and the joints: {', '.join(joints)}",
            )
    for needed in ("pose", *POSITION):
        if needed not in seen:
            raise MeasurementError(source, line, needed, "missing (the header must name it)")
    for group in (FORCE, ROTATION):
        given = [name for name in group if name in seen]
        if given and len(given) != 3:
            missing = [name for name in group if name not in seen]
            raise MeasurementError(
                source, line, missing[0], f"missing: {', '.join(group)} come together"
            )
    if "mass" not in seen and "fx" not in seen:
        raise MeasurementError(
            source, line, "mass", "missing: the load is a column mass [kg] or fx, fy, fz [N]"
        )


def _check_poses(measurements: Measurements, columns: dict[int, str] | None = None) -> None:
    """Every pose has two rows or more, and its rows give the same joint values (``columns``:
    coordinate index -> its column's name, for the message)."""
    source = measurements.source
    for k, pose in enumerate(measurements.poses):
        rows = np.flatnonzero(measurements.pose_of_row == k)
        if len(rows) < 2:
            raise MeasurementError(
                source,
                int(measurements.lines[rows[0]]),
                "pose",
                f"pose {pose!r} has one row: each pose needs two loads or more (only the "
                "differences within a pose are used)",
            )
        q = measurements.configurations[rows]
        differs = np.argwhere(np.abs(q - q[0]) > SAME_POSE_TOLERANCE)
        if len(differs):
            row, coordinate = differs[0]
            column = (columns or {}).get(int(coordinate), f"configurations[{coordinate}]")
            raise MeasurementError(
                source,
                int(measurements.lines[rows[row]]),
                column,
                f"pose {pose!r}: {q[row, coordinate]!r} differs from the pose's first row "
                f"({q[0, coordinate]!r}, line {int(measurements.lines[rows[0]])}): the rows of "
                "one pose are taken at the same joint values",
            )
