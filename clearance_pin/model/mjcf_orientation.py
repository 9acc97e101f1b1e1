"""MJCF frame orientations read as MuJoCo reads them (plain XML and NumPy, no Pinocchio).

MuJoCo's rules (XML reference, "Frame orientations" and ``<compiler>``): an element's
orientation is given by at most one of ``quat`` (w x y z, normalised), ``axisangle`` (x y z a,
the axis normalised, a in the compiler's angle unit), ``euler`` (three angles about the axes
of ``<compiler eulerseq>``, "xyz" by default: a lower-case letter turns about the moving
(intrinsic) axis, an upper-case one about the fixed (extrinsic) axis of the parent), ``xyaxes``
(the x axis, then the y axis made orthogonal to it, z = x cross y) and ``zaxis`` (the minimal
rotation taking (0, 0, 1) onto the vector). Angles are in degrees unless ``<compiler
angle="radian">``. Every quaternion here is (w, x, y, z), the rotation it stands for acting on
vectors of the element's frame to give them in its parent's frame.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np

from ..errors import ModelError

ORIENTATIONS = ("quat", "axisangle", "euler", "xyaxes", "zaxis")
TINY = 1e-14  # below this norm, an axis or a quaternion is refused (MuJoCo: mjEPS)
IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])


@dataclass(frozen=True)
class Compiler:
    """The ``<compiler>`` settings that orientations depend on.

    Attributes:
        degrees: angles in degrees (MuJoCo's default), else radians.
        eulerseq: three letters of x, y, z, X, Y, Z (lower case intrinsic, upper case extrinsic).
    """

    degrees: bool = True
    eulerseq: str = "xyz"

    @property
    def angle_unit(self) -> float:
        """One angle unit of the file [rad]."""
        return np.pi / 180.0 if self.degrees else 1.0


def compiler_settings(root: ET.Element, source: str) -> Compiler:
    """The angle unit and Euler sequence of every ``<compiler>`` of ``root`` (the last wins)."""
    degrees, eulerseq = True, "xyz"
    for compiler in root.iter("compiler"):
        angle = compiler.get("angle")
        if angle is not None:
            if angle not in ("degree", "radian"):
                raise ModelError(
                    source, f"<compiler angle='{angle}'>", "angle must be 'degree' or 'radian'"
                )
            degrees = angle == "degree"
        sequence = compiler.get("eulerseq")
        if sequence is not None:
            if len(sequence) != 3 or any(c not in "xyzXYZ" for c in sequence):
                raise ModelError(
                    source,
                    f"<compiler eulerseq='{sequence}'>",
                    "eulerseq must be exactly 3 letters of x, y, z (moving axes) and X, Y, Z "
                    "(fixed axes)",
                )
            eulerseq = sequence
        if compiler.get("coordinate", "local") != "local":
            raise ModelError(
                source,
                f"<compiler coordinate='{compiler.get('coordinate')}'>",
                "global coordinates are not read (MuJoCo 3 removed them): write the file in "
                "local coordinates",
            )
    return Compiler(degrees, eulerseq)


def numbers(source: str, label: str, element: ET.Element, attribute: str, count: int) -> np.ndarray:
    """The ``count`` real numbers of ``element``'s ``attribute``."""
    text = element.get(attribute, "")
    try:
        values = np.array([float(v) for v in text.split()], dtype=float)
    except ValueError:
        values = np.array([])
    if values.shape != (count,) or not np.all(np.isfinite(values)):
        raise ModelError(source, label, f"{attribute}='{text}' must be {count} finite real numbers")
    return values


def quat_multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The Hamilton product a b of two (w, x, y, z) quaternions: the rotation b, then a."""
    aw, av = a[0], a[1:]
    bw, bv = b[0], b[1:]
    return np.concatenate(([aw * bw - av @ bv], aw * bv + bw * av + np.cross(av, bv)))


def quat_matrix(q: np.ndarray) -> np.ndarray:
    """The rotation matrix of the unit quaternion q = (w, x, y, z)."""
    w, x, y, z = q
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def matrix_quat(r: np.ndarray) -> np.ndarray:
    """The unit quaternion (w >= 0 when the trace allows) of the rotation matrix r (Shepperd's
    method: the largest of 1 + trace, 1 + 2 r_ii - trace under the square root)."""
    trace = float(np.trace(r))
    candidates = [1 + trace, 1 + 2 * r[0, 0] - trace, 1 + 2 * r[1, 1] - trace]
    candidates.append(1 + 2 * r[2, 2] - trace)
    k = int(np.argmax(candidates))
    s = 2.0 * np.sqrt(candidates[k])  # = 4 |q_k|
    if k == 0:
        q = [s / 4, (r[2, 1] - r[1, 2]) / s, (r[0, 2] - r[2, 0]) / s, (r[1, 0] - r[0, 1]) / s]
    elif k == 1:
        q = [(r[2, 1] - r[1, 2]) / s, s / 4, (r[0, 1] + r[1, 0]) / s, (r[0, 2] + r[2, 0]) / s]
    elif k == 2:
        q = [(r[0, 2] - r[2, 0]) / s, (r[0, 1] + r[1, 0]) / s, s / 4, (r[1, 2] + r[2, 1]) / s]
    else:
        q = [(r[1, 0] - r[0, 1]) / s, (r[0, 2] + r[2, 0]) / s, (r[1, 2] + r[2, 1]) / s, s / 4]
    quat = np.array(q, dtype=float)
    return np.asarray(quat / np.linalg.norm(quat), dtype=float)


def axis_angle_quat(axis: np.ndarray, angle: float) -> np.ndarray:
    """q = (cos(a/2), sin(a/2) u) for the unit vector u of ``axis`` and the angle a [rad]."""
    return np.concatenate(([np.cos(angle / 2)], np.sin(angle / 2) * axis / np.linalg.norm(axis)))


def _unit(source: str, label: str, vector: np.ndarray, what: str) -> np.ndarray:
    norm = float(np.linalg.norm(vector))
    if norm < TINY:
        raise ModelError(source, label, f"{what} is zero: it has no direction")
    return vector / norm


def orientation(
    source: str, label: str, element: ET.Element, compiler: Compiler
) -> tuple[np.ndarray, str | None]:
    """The unit quaternion of ``element``'s orientation and the attribute that gave it (None:
    no orientation attribute, the identity)."""
    given = [a for a in ORIENTATIONS if element.get(a) is not None]
    if len(given) > 1:
        raise ModelError(
            source,
            label,
            f"several orientations ({', '.join(given)}): MuJoCo takes at most one; keep one",
        )
    if not given:
        return IDENTITY.copy(), None
    attribute = given[0]
    if attribute == "quat":
        q = numbers(source, label, element, "quat", 4)
        return _unit(source, label, q, "quat"), attribute
    if attribute == "axisangle":
        values = numbers(source, label, element, "axisangle", 4)
        axis = _unit(source, label, values[:3], "the axis of axisangle")
        return axis_angle_quat(axis, values[3] * compiler.angle_unit), attribute
    if attribute == "euler":
        angles = numbers(source, label, element, "euler", 3) * compiler.angle_unit
        q = IDENTITY.copy()
        for letter, angle in zip(compiler.eulerseq, angles):
            turn = axis_angle_quat(np.eye(3)["xyz".index(letter.lower())], float(angle))
            # moving axes (lower case): post-multiply; fixed axes (upper case): pre-multiply
            q = quat_multiply(q, turn) if letter.islower() else quat_multiply(turn, q)
        return q / np.linalg.norm(q), attribute
    if attribute == "xyaxes":
        values = numbers(source, label, element, "xyaxes", 6)
        x = _unit(source, label, values[:3], "the x axis of xyaxes")
        y = _unit(source, label, values[3:] - (values[3:] @ x) * x, "the y axis of xyaxes")
        return matrix_quat(np.column_stack((x, y, np.cross(x, y)))), attribute
    z = _unit(source, label, numbers(source, label, element, "zaxis", 3), "zaxis")
    normal = np.cross([0.0, 0.0, 1.0], z)
    sine = float(np.linalg.norm(normal))
    # z = -(0, 0, 1): MuJoCo turns by pi about x
    axis = normal / sine if sine > 1e-10 else np.array([1.0, 0.0, 0.0])
    return axis_angle_quat(axis, float(np.arctan2(sine, z[2]))), attribute


__all__ = [
    "IDENTITY",
    "ORIENTATIONS",
    "Compiler",
    "axis_angle_quat",
    "compiler_settings",
    "matrix_quat",
    "numbers",
    "orientation",
    "quat_matrix",
    "quat_multiply",
]
