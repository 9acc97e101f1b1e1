r"""Toleranced dimensions of a mechanism: the ``<dimension>`` elements of a model file.

A *dimension* is a functional size of a part whose manufactured value scatters within a
tolerance, as the link lengths of P. Flores, "A methodology for quantifying the kinematic
position errors due to manufacturing and assembly tolerances", Strojniski vestnik - J. Mech.
Eng. (2011) [F]. In a URDF the sizes of the parts are the joint origins, so a dimension names a
URDF joint and a direction.

Format (inside the ``<clearance_pin>`` block)::

    <dimension name="r2" joint="pin_A" direction="1 0 0" tolerance="1e-4"/>
    <dimension name="r2" joint="pin_A" direction="1 0 0" half_tolerance="5e-5"/>
    <dimension name="r2" joint="pin_A" direction="1 0 0" grade="IT10"/>
    <dimension name="e" joint="guide_mount" direction="0 1 0" tolerance="2e-4"/>
    <dimension name="a3" joint="pin_B" rotation_axis="0 0 1" tolerance="1e-3"/>

- ``name``: unique among the dimensions (used in tables, JSON and plots).
- ``joint``: a URDF joint, movable or fixed. Its ``<origin>`` (in the parent link frame) is
  the toleranced part geometry; a deviation moves the joint origin and, with it, the whole
  subtree below the joint (child link, its frames, the joints below).
- a *length* dimension, ``direction="x y z"`` (any non-zero length, normalised; expressed in the
  parent link frame, the frame of the URDF ``<origin xyz>``): the length is the component of
  the origin along ``u = direction / |direction|``, nominal ``d = u . xyz`` [m] (it may be 0,
  e.g. an offset); a deviation ``dd`` [m] translates the origin by ``u dd``.
- an *angle* dimension, ``rotation_axis="x y z"`` (parent link frame): a deviation ``dd``
  [rad] rotates the joint's ``<origin>`` frame about that axis through the origin point, i.e.
  an error of the origin's ``rpy``. Its nominal value is 0.
- exactly one of
    - ``tolerance``: the full bilateral width ``T`` [m or rad] >= 0: ``d +/- T/2``;
    - ``half_tolerance``: ``T/2`` [m or rad] >= 0;
    - ``grade``: an ISO 286-1 grade ``IT01 ... IT18`` (lengths only); the nominal size is
      ``|d|``, which must be in (0, 500] mm (see :mod:`~clearance_pin.model.iso286`).

Every problem raises :class:`~clearance_pin.errors.ModelError` naming the file, the element
(``<dimension name='r2'>``) and the problem; nothing is half-loaded.

Frames. Pinocchio stores a joint origin as ``jointPlacement = parentJoint_M_parentLink *
origin`` (a fixed joint as a frame placement, also in its parent joint), so every dimension is
kept in its *anchor*: the Pinocchio parent joint ``J`` in whose frame the deviation acts, the
unit vector ``axis_in_parent_joint`` and the origin point ``point_in_parent_joint`` [m], both in
that frame. A deviation is the rigid motion ``D(dd)`` of the subtree, in ``J``:

.. math::

    D_{length}(dd) = (I, \; u\, dd), \qquad
    D_{angle}(dd) = (E, \; c - E c), \; E = \exp(dd\, [a]_\times)

left-multiplied onto every joint placement and frame placement of the subtree that hangs on
``J`` directly (the deeper ones follow through the forward kinematics).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from typing import Literal

import numpy as np
import pinocchio as pin

from ..errors import ArgumentError, ModelError
from .iso286 import ToleranceInputError, tolerance_m
from .xml_values import label_of, number, vector

__all__ = ["Dimension", "parse_dimensions"]

ATTRIBUTES = {"name", "joint", "direction", "rotation_axis", "tolerance", "half_tolerance", "grade"}


@dataclass(frozen=True)
class Dimension:
    """One toleranced dimension (see the module docstring for the model-file format).

    Attributes:
        name: unique name, e.g. ``"r2"``.
        joint: the URDF joint whose origin carries the dimension.
        frame_id: the Pinocchio frame of that joint (type JOINT or FIXED_JOINT): the root of
            the subtree that a deviation moves.
        parent_joint_id: the Pinocchio joint ``J`` in whose frame the deviation acts.
        kind: ``"length"`` [m] or ``"angle"`` [rad].
        axis: unit direction (length) or rotation axis (angle) in the parent link frame.
        axis_in_parent_joint: the same unit vector in the frame of ``J``.
        point_in_parent_joint: the joint origin in the frame of ``J`` [m].
        nominal: ``u . xyz`` [m] for a length, 0 [rad] for an angle.
        tolerance: full bilateral width ``T`` [m or rad] (``d +/- T/2``).
        grade: the ISO 286 grade when the tolerance came from one, else None.
    """

    name: str
    joint: str
    frame_id: int
    parent_joint_id: int
    kind: Literal["length", "angle"]
    axis: tuple[float, float, float]
    axis_in_parent_joint: tuple[float, float, float]
    point_in_parent_joint: tuple[float, float, float]
    nominal: float
    tolerance: float
    grade: str | None = None

    def __post_init__(self) -> None:
        if self.kind not in ("length", "angle"):
            raise ArgumentError(f"Dimension {self.name!r}: kind", "'length' or 'angle'", self.kind)
        if not (math.isfinite(self.tolerance) and self.tolerance >= 0.0):
            raise ArgumentError(
                f"Dimension {self.name!r}: tolerance",
                "a finite number >= 0 [m or rad]",
                self.tolerance,
            )
        if abs(np.linalg.norm(self.axis_in_parent_joint) - 1.0) > 1e-9:
            raise ArgumentError(
                f"Dimension {self.name!r}: axis_in_parent_joint",
                "a unit vector",
                self.axis_in_parent_joint,
                f"norm {np.linalg.norm(self.axis_in_parent_joint):.6g}",
            )

    @property
    def half_tolerance(self) -> float:
        """``T/2`` [m or rad]."""
        return 0.5 * self.tolerance

    @property
    def unit(self) -> str:
        """``"m"`` or ``"rad"``."""
        return "m" if self.kind == "length" else "rad"

    def displacement(self, deviation: float) -> pin.SE3:
        """The rigid motion ``D(dd)`` of the subtree in the parent joint frame (exact)."""
        axis = np.asarray(self.axis_in_parent_joint)
        if self.kind == "length":
            return pin.SE3(np.eye(3), axis * deviation)
        rotation = pin.exp3(axis * deviation)
        point = np.asarray(self.point_in_parent_joint)
        return pin.SE3(rotation, point - rotation @ point)


def parse_dimensions(
    source: str, block: ET.Element, model: pin.Model, exponent: int = 0
) -> tuple[Dimension, ...]:
    """Read the ``<dimension>`` elements of a ``<clearance_pin>`` block.

    Args:
        source: file name for error messages.
        block: the ``<clearance_pin>`` element.
        model: the Pinocchio model built from the same URDF.
        exponent: power of ten of the block's length unit (-3 for ``unit="mm"``): the
            tolerances of lengths are converted to metres; those of angles stay in radians.

    Returns:
        The dimensions, in file order.

    Raises:
        ModelError: any invalid element (named in the error).
    """
    dimensions: list[Dimension] = []
    names: set[str] = set()
    for element in block.findall("dimension"):
        dimension = _parse_one(source, element, model, exponent)
        if dimension.name in names:
            raise ModelError(source, _label(element), "duplicate dimension name")
        names.add(dimension.name)
        dimensions.append(dimension)
    return tuple(dimensions)


def _label(element: ET.Element) -> str:
    custom = label_of(element)
    if custom:
        return custom
    name = element.get("name")
    return f"<dimension name='{name}'>" if name else "<dimension>"


def _parse_one(source: str, element: ET.Element, model: pin.Model, exponent: int) -> Dimension:
    label = _label(element)
    unknown = sorted(set(element.attrib) - ATTRIBUTES)
    if unknown:
        raise ModelError(
            source, label, f"unknown attribute(s) {unknown}; allowed: {sorted(ATTRIBUTES)}"
        )
    name = element.get("name")
    if not name or not name.strip():
        raise ModelError(source, label, "needs a name")
    joint = element.get("joint")
    if not joint:
        raise ModelError(source, label, "needs joint (the URDF joint whose origin is toleranced)")
    frame_id = _joint_frame(source, label, model, joint)

    has_direction = element.get("direction") is not None
    has_axis = element.get("rotation_axis") is not None
    if has_direction == has_axis:
        raise ModelError(
            source,
            label,
            "give exactly one of direction (a length [m]) or rotation_axis (an angle [rad])",
        )
    kind: Literal["length", "angle"] = "length" if has_direction else "angle"
    attribute = "direction" if has_direction else "rotation_axis"
    axis = vector(source, label, element.get(attribute), attribute)
    axis = axis / float(np.linalg.norm(axis))

    parent_joint, placement, link = _anchor(model, frame_id)
    axis_pj = link.rotation @ axis
    origin_xyz = link.actInv(placement).translation  # the URDF <origin xyz>
    nominal = float(axis @ origin_xyz) if kind == "length" else 0.0
    if abs(nominal) < 1e-12:  # round-off of the placement products: a zero offset
        nominal = 0.0

    given = [k for k in ("tolerance", "half_tolerance", "grade") if element.get(k) is not None]
    if len(given) != 1:
        raise ModelError(
            source,
            label,
            "give exactly one of tolerance (full width T), "
            f"half_tolerance (T/2) or grade (ISO 286); found {given or 'none'}",
        )
    grade = None
    if given[0] == "grade":
        if kind == "angle":
            raise ModelError(
                source,
                label,
                "ISO 286 grades apply to lengths, not to angles; give tolerance [rad]",
            )
        grade = element.get("grade", "").strip().upper()  # given: not empty
        try:
            tolerance = tolerance_m(grade, abs(nominal))
        except ToleranceInputError as exc:
            raise ModelError(
                source,
                label,
                f"grade={element.get('grade')!r} at the nominal size "
                f"{abs(nominal) * 1e3:.6g} mm (the joint origin along direction): "
                f"{exc.problem}",
            ) from None
    else:
        scale = exponent if kind == "length" else 0
        unit = {0: "m", -3: "mm", -6: "um"}.get(scale, "m") if kind == "length" else "rad"
        value = number(source, label, element, given[0], True, unit, scale)
        tolerance = value if given[0] == "tolerance" else 2.0 * value
    return Dimension(
        name,
        joint,
        frame_id,
        parent_joint,
        kind,
        _tuple(axis),
        _tuple(axis_pj),
        _tuple(placement.translation),
        nominal,
        tolerance,
        grade,
    )


def _tuple(v: np.ndarray) -> tuple[float, float, float]:
    return (float(v[0]), float(v[1]), float(v[2]))


def _joint_frame(source: str, label: str, model: pin.Model, joint: str) -> int:
    for kind in (pin.FrameType.JOINT, pin.FrameType.FIXED_JOINT):
        if model.existFrame(joint, kind):
            frame_id = int(model.getFrameId(joint, kind))
            if frame_id > 0:
                return frame_id
    known = [
        f.name
        for f in model.frames[1:]
        if f.type in (pin.FrameType.JOINT, pin.FrameType.FIXED_JOINT)
    ]
    raise ModelError(
        source,
        label,
        f"no URDF joint is called {joint!r}; the joints are: {', '.join(known) or 'none'}",
    )


def _anchor(model: pin.Model, frame_id: int) -> tuple[int, pin.SE3, pin.SE3]:
    """Parent joint ``J``, the joint origin in ``J`` and the parent link frame in ``J``."""
    frame = model.frames[frame_id]
    if frame.type == pin.FrameType.JOINT:
        joint_id = frame.parentJoint
        parent_joint = int(model.parents[joint_id])
        placement = model.jointPlacements[joint_id]
    else:
        parent_joint = int(frame.parentJoint)
        placement = frame.placement
    link = model.frames[frame.parentFrame]
    link_placement = link.placement if link.parentJoint == parent_joint else pin.SE3.Identity()
    return parent_joint, placement.copy(), link_placement.copy()
