"""Sizes of a mechanism that its clearance block cannot change: the references against which
:mod:`~clearance_pin.model.length_check` judges the block's lengths.

All come from the model itself: the joint placements and frames of the Pinocchio tree (a URDF's
or an MJCF's), the primitive collision and visual shapes of a URDF's links and the geoms of an
MJCF's bodies (meshes are not read).

- a body's *size*: the largest distance between two of its points (its joint centre, the joint
  centres it carries, every frame on it, the centres of its shapes), or the largest diameter of
  its shapes;
- a joint's *part*: the larger size of the two bodies it joins;
- the mechanism's *extent*: the farthest joint or frame from the root at the nominal
  configuration, or the largest body size, whichever is larger.
"""

from __future__ import annotations

import itertools
import math
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

ROUND_OFF = 1e-9  # of the extent: a distance below it is round-off, not a size


def body_points(model: pin.Model) -> list[list[np.ndarray]]:
    """Points [m] of every body (index: its Pinocchio joint) in its joint frame: its joint
    centre, the joints it carries and every frame on it (links, fixed joints, sites, loop-joint
    frames)."""
    points: list[list[np.ndarray]] = [[]] + [[np.zeros(3)] for _ in range(1, model.njoints)]
    for child in range(1, model.njoints):
        points[model.parents[child]].append(np.array(model.jointPlacements[child].translation))
    for frame in model.frames:
        points[frame.parentJoint].append(np.array(frame.placement.translation))
    return points


def body_size(points: Sequence[np.ndarray], diameters: Sequence[float] = ()) -> float:
    """The size [m] of a body: the largest distance between two of its ``points`` [m] (shape
    centres included), or the largest of its shapes' ``diameters`` [m]."""
    size = max(
        (float(np.linalg.norm(a - b)) for a, b in itertools.combinations(points, 2)),
        default=0.0,
    )
    return max([size, *diameters])


@dataclass(frozen=True)
class Shape:
    """A primitive collision or visual shape of a link (a URDF ``<box>``, ``<cylinder>`` or
    ``<sphere>``): a size of its body that no joint centre shows (a pendulum's bob).

    Attributes:
        link: the link it belongs to.
        centre: its origin in the link frame [m] (3,).
        diameter: its largest dimension [m] (the diagonal of a box or a cylinder, a sphere's
            diameter).
    """

    link: str
    centre: tuple[float, float, float]
    diameter: float


def urdf_shapes(root: ET.Element) -> tuple[Shape, ...]:
    """The primitive shapes of a URDF's ``<collision>`` and ``<visual>`` elements (meshes are
    not read: their size needs the file and its scale). Malformed numbers are skipped: the
    geometry is URDF business, only a reference here."""
    shapes = []
    for link in root.findall("link"):
        for element in (*link.findall("collision"), *link.findall("visual")):
            try:
                diameter = _diameter(element.find("geometry"))
                origin = element.find("origin")
                xyz = origin.get("xyz", "0 0 0") if origin is not None else "0 0 0"
                centre = tuple(float(v) for v in xyz.split())
            except (TypeError, ValueError):
                continue
            if len(centre) == 3 and math.isfinite(diameter) and diameter > 0.0:
                x, y, z = centre
                shapes.append(Shape(str(link.get("name")), (x, y, z), diameter))
    return tuple(shapes)


def mjcf_shapes(tree: ET.Element) -> tuple[Shape, ...]:
    """The geoms of an MJCF tree's named bodies, as shapes of the link of the body's name (the
    name Pinocchio gives its frame). A geom whose size comes from a default class or a mesh is
    skipped, as are malformed numbers: the geometry is only a reference here."""
    shapes = []
    for body in tree.iter("body"):
        name = body.get("name")
        if not name:
            continue
        for geom in body.findall("geom"):
            try:
                shape = _mjcf_shape(name, geom)
            except (TypeError, ValueError):
                continue
            if shape is not None:
                shapes.append(shape)
    return tuple(shapes)


def _mjcf_shape(link: str, geom: ET.Element) -> Shape | None:
    """One MJCF geom (``size`` as MuJoCo reads it: radii and half-lengths) as a shape."""
    kind = geom.get("type", "sphere")
    size = [float(v) for v in geom.get("size", "").split()]
    if not size or kind not in ("sphere", "capsule", "cylinder", "box", "ellipsoid"):
        return None
    fromto = geom.get("fromto")
    if fromto is not None and kind in ("capsule", "cylinder", "box", "ellipsoid"):
        ends = np.array([float(v) for v in fromto.split()]).reshape(2, 3)
        centre = 0.5 * (ends[0] + ends[1])
        half = 0.5 * float(np.linalg.norm(ends[1] - ends[0]))
    else:
        centre = np.array([float(v) for v in geom.get("pos", "0 0 0").split()])
        half = size[1] if len(size) > 1 and kind in ("capsule", "cylinder") else 0.0
    if kind == "sphere":
        diameter = 2.0 * size[0]
    elif kind == "capsule":
        diameter = 2.0 * (half + size[0])
    elif kind == "cylinder":
        diameter = math.hypot(2.0 * half, 2.0 * size[0])
    else:  # box, ellipsoid: half sizes or radii
        diameter = 2.0 * float(np.linalg.norm(size[:3])) if kind == "box" else 2.0 * max(size)
    if centre.shape != (3,) or not (math.isfinite(diameter) and diameter > 0.0):
        return None
    x, y, z = (float(v) for v in centre)
    return Shape(link, (x, y, z), diameter)


def _diameter(geometry: ET.Element | None) -> float:
    """The largest dimension [m] of a URDF primitive (0 for a mesh or nothing)."""
    if geometry is None:
        return 0.0
    box = geometry.find("box")
    if box is not None:
        return float(np.linalg.norm([float(v) for v in box.get("size", "").split()]))
    cylinder = geometry.find("cylinder")
    if cylinder is not None:
        radius, length = float(cylinder.get("radius", "")), float(cylinder.get("length", ""))
        return math.hypot(2.0 * radius, length)
    sphere = geometry.find("sphere")
    if sphere is not None:
        return 2.0 * float(sphere.get("radius", ""))
    return 0.0


def world_placements(model: pin.Model, q: np.ndarray) -> list[pin.SE3]:
    """The world placement of every joint frame at ``q`` (nq,): the forward kinematics joint by
    joint, without a ``pin.Data`` (whose construction costs seconds for a long chain)."""
    placements = [pin.SE3.Identity()]
    for joint_id in range(1, model.njoints):
        joint = model.joints[joint_id]
        data = joint.createData()
        joint.calc(data, q)
        parent = placements[model.parents[joint_id]]
        placements.append(parent * model.jointPlacements[joint_id] * data.M)
    return placements


class Geometry:
    """The reference sizes of a model (see the module docstring), computed once.

    Args:
        model: the kinematic tree.
        q: the nominal configuration (nq,).
        shapes: primitive shapes of its links (a URDF's), widening their bodies' sizes.
    """

    def __init__(self, model: pin.Model, q: np.ndarray, shapes: tuple[Shape, ...] = ()):
        self.model = model
        points = body_points(model)
        diameters: list[list[float]] = [[] for _ in range(model.njoints)]
        for shape in shapes:
            if not model.existFrame(shape.link, pin.FrameType.BODY):
                continue
            frame = model.frames[model.getFrameId(shape.link, pin.FrameType.BODY)]
            points[frame.parentJoint].append(frame.placement.act(np.array(shape.centre)))
            diameters[frame.parentJoint].append(shape.diameter)
        self.sizes = [body_size(p, d) for p, d in zip(points, diameters, strict=True)]
        placements = world_placements(model, q)
        reach = [float(np.linalg.norm(m.translation)) for m in placements]
        for frame in model.frames:
            reach.append(
                float(np.linalg.norm((placements[frame.parentJoint] * frame.placement).translation))
            )
        self.extent = max([*reach, *self.sizes])

    def part(self, bodies: tuple[int, ...]) -> tuple[float, str]:
        """(size [m], what it is) of the part a value belongs to; the extent when unknown."""
        size = max((self.sizes[b] for b in bodies), default=0.0)
        if size > ROUND_OFF * self.extent:
            return size, "the part it joins"
        return self.extent, "the mechanism's extent"


__all__ = [
    "ROUND_OFF",
    "Geometry",
    "Shape",
    "body_points",
    "body_size",
    "mjcf_shapes",
    "urdf_shapes",
    "world_placements",
]
