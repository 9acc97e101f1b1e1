"""Read a mechanism from a URDF with a ``<clearance_pin>`` block (format: docs/model-format.md).

The URDF holds the kinematic tree at its nominal configuration; the ``<clearance_pin>`` element
(ignored by other URDF tools, as ``<gazebo>`` blocks are) adds joint clearances, loop joints,
driven joints, nominal joint values and loads. Every problem found is raised as a
:class:`~clearance_pin.errors.ModelError` naming the file, the element and the problem; nothing is
half-loaded.

Suspect values (a clearance in mm, a nominal value outside the URDF limits, a tolerance as wide as
its size) load, with a :class:`~clearance_pin.errors.SuspectValueWarning`
(:mod:`clearance_pin.model.plausibility`). Collision meshes are read only when a check first needs
them (:class:`CollisionGeometry`), so a solve works on a URDF whose meshes are elsewhere.
"""

from __future__ import annotations

import codecs
import math
import os
import re
import xml.etree.ElementTree as ET
import xml.parsers.expat
from collections.abc import Container, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeAlias

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike

from ..errors import ArgumentError, LoadError, ModelError
from .clearance import KINDS, Clearance, ideal
from .dimensions import Dimension, parse_dimensions
from .frames import frame_id
from .joints import MOTION_COMPONENT_BY_PIN_JOINT, LoopJoint, TreeJoint, rotation_x_to
from .loads import Gravity, PointForce, Torque
from .xml_values import number, vector

BLOCK = "clearance_pin"
CLEARANCE_ATTRIBUTES = {
    "radial_clearance": "radial",
    "length": "length",
    "axial_clearance": "axial",
    "play_z": "play_z",
    "width": "width",
    "height": "height",
}
JOINT_ATTRIBUTES = {
    "name",
    "type",
    "diametral_clearance",
    "driven",
    "q",
    "axis",
    *CLEARANCE_ATTRIBUTES,
}
LOOP_ATTRIBUTES = {
    "name",
    "type",
    "frame_a",
    "frame_b",
    "diametral_clearance",
    "axis",
    *CLEARANCE_ATTRIBUTES,
}
URDF_JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")
IDEAL_KIND_OF_URDF: dict[str | None, str] = {
    "revolute": "revolute",
    "continuous": "revolute",
    "prismatic": "prismatic",
    "floating": "free",
}


# package_dirs of clearance_pin.load: one directory, or a list of them
PackageDirs: TypeAlias = str | os.PathLike[str] | Iterable[str | os.PathLike[str]] | None


@dataclass(frozen=True)
class MechanismDescription:
    """What a model file describes: the arguments of a
    :class:`~clearance_pin.mechanism.Mechanism` (:func:`clearance_pin.load` builds it)."""

    model: pin.Model
    tree_joints: tuple[TreeJoint, ...]
    loop_joints: tuple[LoopJoint, ...]
    q_nominal: np.ndarray
    loads: tuple[PointForce | Torque, ...]
    gravity: Gravity | None
    source: str
    name: str
    collision_model: CollisionGeometry | None
    dimensions: tuple[Dimension, ...]
    nominal_given: dict[int, float]

    def arguments(self) -> dict[str, Any]:
        """Keyword arguments of the Mechanism constructor."""
        return {f: getattr(self, f) for f in self.__dataclass_fields__}


def read_file(path: str | Path, package_dirs: PackageDirs = None) -> MechanismDescription:
    """Read a model file (URDF + ``<clearance_pin>``); the arguments are those of
    :func:`clearance_pin.load`, which builds the mechanism from the description."""
    if not isinstance(path, (str, os.PathLike)):
        raise ArgumentError("path", "a file path (str or pathlib.Path)", path)
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise ModelError(str(path), "<file>", f"cannot be read: {exc.strerror or exc}") from None
    return _read(data, str(path), path.parent, package_dirs)


def read_text(
    text: str | bytes,
    source: str = "<string>",
    mesh_dir: Path | None = None,
    package_dirs: PackageDirs = None,
) -> MechanismDescription:
    """Read the text of a model file (see :func:`read_file`).

    Args:
        text: the file's text (str), or its bytes, decoded as its XML declaration says.
        source: the name used in messages.
        mesh_dir: directory of relative mesh paths (the file's directory).
        package_dirs: as in :func:`read_file`.
    """
    return _read(text, source, mesh_dir, package_dirs)


def _read(
    text: object, source: str, mesh_dir: Path | None, package_dirs: PackageDirs
) -> MechanismDescription:
    if isinstance(text, (bytes, bytearray)):
        text = decode_xml(bytes(text), source)
    elif not isinstance(text, str):
        raise ArgumentError("text", "the model file's text (str or bytes)", text)
    else:
        text = _without_declaration(text)
    directories = _package_dirs(package_dirs)
    if mesh_dir is not None:
        directories = (*directories, str(mesh_dir))
    reader = _Reader(text, source)
    model = reader.pin_model()
    block = reader.block()
    collision = CollisionGeometry(text, source, directories) if reader.has_collision() else None
    tree_joints, q = reader.tree_joints(model, block)
    loop_joints = reader.loop_joints(model, block)
    forces, gravity = reader.loads(model, block)
    return MechanismDescription(
        model=model,
        tree_joints=tuple(tree_joints),
        loop_joints=tuple(loop_joints),
        q_nominal=q,
        loads=tuple(forces),
        gravity=gravity,
        source=source,
        name=reader.root.get("name", ""),
        collision_model=collision,
        dimensions=parse_dimensions(source, block, model),
        nominal_given=dict(reader.nominal_given),
    )


_DECLARATION = re.compile(r"^\ufeff?\s*<\?xml\b[^>]*\?>")
_BOMS = (
    (codecs.BOM_UTF32_LE, "utf-32"),
    (codecs.BOM_UTF32_BE, "utf-32"),
    (codecs.BOM_UTF8, "utf-8-sig"),
    (codecs.BOM_UTF16_LE, "utf-16"),
    (codecs.BOM_UTF16_BE, "utf-16"),
)


def decode_xml(data: bytes, source: str = "<string>") -> str:
    """The text of an XML document: decoded as its byte-order mark or its declaration says
    (UTF-8 without either), with the declaration removed (Pinocchio's parser reads UTF-8 text)."""
    declared: list[str | None] = []
    parser = xml.parsers.expat.ParserCreate()
    parser.XmlDeclHandler = lambda version, encoding, standalone: declared.append(encoding)
    try:
        parser.Parse(data, True)
    except xml.parsers.expat.ExpatError as exc:
        raise ModelError(source, "<xml>", f"malformed XML: {exc}") from None
    encoding = next((name for bom, name in _BOMS if data.startswith(bom)), None)
    encoding = encoding or (declared[0] if declared and declared[0] else "utf-8")
    try:
        text = data.decode(encoding)
    except (UnicodeDecodeError, LookupError) as exc:
        raise ModelError(source, "<xml>", f"cannot be decoded as {encoding}: {exc}") from None
    return _without_declaration(text)


def _without_declaration(text: str) -> str:
    return _DECLARATION.sub("", text, count=1)


def _package_dirs(package_dirs: PackageDirs) -> tuple[str, ...]:
    """``package_dirs`` as a tuple of existing directories (one str or Path is one directory)."""
    if package_dirs is None:
        return ()
    if isinstance(package_dirs, (str, os.PathLike)):
        package_dirs = [package_dirs]
    try:
        entries = list(package_dirs)
    except TypeError:
        raise ArgumentError(
            "package_dirs", "a list of directories (str or pathlib.Path)", package_dirs
        ) from None
    directories = []
    for index, entry in enumerate(entries):
        if not isinstance(entry, (str, os.PathLike)) or not Path(entry).is_dir():
            raise ArgumentError(f"package_dirs[{index}]", "an existing directory", entry)
        directories.append(str(entry))
    return tuple(directories)


MESH_NOT_FOUND = re.compile(r"Mesh (\S+) could not be found")


@dataclass(frozen=True)
class CollisionGeometry:
    """The URDF's collision geometry, built (meshes read) when first asked for.

    Attributes:
        text: the URDF text.
        source: the file, for messages.
        package_dirs: directories searched for meshes, before those of ROS_PACKAGE_PATH.
    """

    text: str
    source: str
    package_dirs: tuple[str, ...]

    def __call__(self, model: pin.Model) -> pin.GeometryModel:
        """The ``pin.GeometryModel`` of the ``<collision>`` elements of ``model``'s URDF."""
        try:
            return pin.buildGeomFromUrdfString(
                model, self.text, pin.GeometryType.COLLISION, package_dirs=list(self.package_dirs)
            )
        except (RuntimeError, ValueError) as exc:
            raise self._error(str(exc)) from None

    def _error(self, message: str) -> ModelError:
        missing = MESH_NOT_FOUND.search(message)
        if missing is None:
            return ModelError(self.source, "<collision>", f"cannot be loaded: {message}")
        filename = missing.group(1).rstrip(".")
        element = f"<collision> <mesh filename='{filename}'>"
        root = ET.fromstring(self.text)
        for link in root.findall("link"):
            names = [m.get("filename") for m in link.findall("collision/geometry/mesh")]
            if filename in names:
                element = f"<link name='{link.get('name')}'> {element}"
                break
        searched = [*self.package_dirs, *_ros_package_path()]
        return ModelError(
            self.source,
            element,
            f"mesh file not found (searched: {', '.join(searched) or 'nothing'}). A "
            "package://<pkg>/<file> mesh is looked for as <dir>/<pkg>/<file>, a relative one as "
            "<dir>/<file>, for every <dir> of package_dirs=[...] in clearance_pin.load "
            "(--package-dir in the command line), the URDF's own directory and the "
            "ROS_PACKAGE_PATH environment variable. Only the coal check reads meshes; solving "
            "does not.",
        )


def _ros_package_path() -> list[str]:
    return [d for d in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep) if d]


class _Reader:
    def __init__(self, text: str, source: str) -> None:
        self.text = text
        self.source = source
        try:
            self.root = ET.fromstring(text)
        except ET.ParseError as exc:
            raise ModelError(source, "<xml>", f"malformed XML: {exc}") from None
        if self.root.tag != "robot":
            raise ModelError(source, f"<{self.root.tag}>", "the root element must be <robot>")
        self.urdf_joints: dict[str, ET.Element] = {}
        parents: dict[str, str] = {}
        for element in self.root.findall("joint"):
            name = element.get("name")
            if not name:
                raise ModelError(source, "<joint>", "a URDF joint needs a name")
            if name in self.urdf_joints:
                raise ModelError(source, f"<joint name='{name}'>", "duplicate joint name")
            self.urdf_joints[name] = element
            child = element.find("child")
            child_link = child.get("link") if child is not None else None
            if child_link in parents:
                raise ModelError(
                    source,
                    f"<joint name='{name}'>",
                    f"link {child_link!r} is already the child of joint {parents[child_link]!r}: a "
                    "URDF is a tree, and Pinocchio would silently corrupt the model. Declare the "
                    "second joint as a <loop_joint> in the <clearance_pin> block.",
                )
            if child_link:
                parents[child_link] = name
        self._check_urdf_structure()

    def _check_urdf_structure(self) -> None:
        """The URDF checks Pinocchio makes without naming the element (it prints to stderr)."""
        links: set[str] = set()
        for element in self.root.findall("link"):
            name = element.get("name")
            if not name:
                raise ModelError(self.source, "<link>", "a URDF link needs a name")
            if name in links:
                raise ModelError(self.source, f"<link name='{name}'>", "duplicate link name")
            links.add(name)
            self._check_inertial(name, element.find("inertial"))
        for name, element in self.urdf_joints.items():
            label = f"<joint name='{name}'>"
            kind = element.get("type")
            if kind not in URDF_JOINT_TYPES:
                raise ModelError(
                    self.source,
                    label,
                    f"type={kind!r} is not a URDF joint type; expected one of {URDF_JOINT_TYPES}",
                )
            for tag in ("parent", "child"):
                child = element.find(tag)
                link = child.get("link") if child is not None else None
                if not link:
                    raise ModelError(self.source, label, f"needs <{tag} link='...'/>")
                if link not in links:
                    raise ModelError(
                        self.source, label, f"<{tag} link='{link}'> is not a link of the URDF"
                    )
            mimic = element.find("mimic")
            if mimic is not None:
                raise ModelError(
                    self.source,
                    label,
                    f"a mimic joint (it follows joint {mimic.get('joint')!r}): clearance_pin "
                    "does not model mimic couplings, and Pinocchio would make it an independent "
                    "joint. Remove the <mimic> element (an independent joint: drive it or give it "
                    "a clearance) or make the joint fixed.",
                )
            origin = element.find("origin")
            for attribute in ("xyz", "rpy"):
                if origin is not None and origin.get(attribute) is not None:
                    _vector(self.source, origin, attribute, allow_zero=True, label=label)
            axis = element.find("axis")
            if axis is not None and kind in ("revolute", "continuous", "prismatic"):
                try:
                    _vector(self.source, axis, "xyz", label=label)
                except ModelError as exc:
                    raise ModelError(self.source, label, f"<axis> {exc.problem}") from None

    def _check_inertial(self, link: str, inertial: ET.Element | None) -> None:
        """Numbers of a link's <inertial>, which urdfdom drops with only a message on stderr."""
        if inertial is None:
            return
        label = f"<link name='{link}'> <inertial>"
        mass = inertial.find("mass")
        if mass is not None:
            value = _number(self.source, mass, "value", nonnegative=True, label=label)
            if value < 0.0:
                raise ModelError(self.source, label, "mass must be >= 0 [kg]")
        inertia = inertial.find("inertia")
        if inertia is not None:
            for key in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"):
                if inertia.get(key) is not None:
                    _number(self.source, inertia, key, label=label)
        origin = inertial.find("origin")
        for attribute in ("xyz", "rpy"):
            if origin is not None and origin.get(attribute) is not None:
                _vector(self.source, origin, attribute, allow_zero=True, label=label)

    def pin_model(self) -> pin.Model:
        try:
            return pin.buildModelFromXML(self.text)
        except (RuntimeError, ValueError) as exc:
            raise ModelError(
                self.source, "<robot>", f"Pinocchio cannot build the URDF: {exc}"
            ) from None

    def has_collision(self) -> bool:
        return self.root.find("link/collision") is not None

    def block(self) -> ET.Element:
        blocks = self.root.findall(BLOCK)
        if len(blocks) > 1:
            raise ModelError(self.source, f"<{BLOCK}>", "only one block is allowed")
        block = blocks[0] if blocks else ET.Element(BLOCK)
        allowed = {"joint", "loop_joint", "force", "torque", "gravity", "dimension"}
        for child in block:
            if child.tag not in allowed:
                raise ModelError(
                    self.source,
                    f"<{child.tag}>",
                    f"unknown element in <{BLOCK}>; expected one of {sorted(allowed)}",
                )
        return block

    # -- joints ---------------------------------------------------------------------------
    def _named(
        self,
        element: ET.Element,
        allowed: set[str],
        taken: Container[str],
        duplicate: str,
        missing: str,
    ) -> tuple[str, str]:
        """(label, name) of a joint element with known attributes and a new, non-empty name."""
        label = _label(element)
        _check_attributes(self.source, element, allowed)
        name = element.get("name")
        if not name:
            raise ModelError(self.source, label, missing)
        if name in taken:
            raise ModelError(self.source, label, duplicate)
        return label, name

    def tree_joints(
        self, model: pin.Model, block: ET.Element
    ) -> tuple[tuple[TreeJoint, ...], np.ndarray]:
        declared: dict[str, ET.Element] = {}
        for entry in block.findall("joint"):
            label, name = self._named(
                entry,
                JOINT_ATTRIBUTES,
                declared,
                "declared twice",
                "needs a name (a URDF joint's name)",
            )
            if name not in self.urdf_joints:
                raise ModelError(
                    self.source,
                    label,
                    f"no URDF joint is called {name!r}; the URDF "
                    f"joints are: {', '.join(self.urdf_joints) or 'none'}",
                )
            if self.urdf_joints[name].get("type") == "fixed":
                raise ModelError(
                    self.source,
                    label,
                    "the URDF joint is fixed: Pinocchio merges its "
                    "two links into one body, so it cannot carry play. Give it type "
                    "'floating' (any play) or 'revolute' in the URDF.",
                )
            declared[name] = entry
        q = pin.neutral(model)
        joints = []
        self.nominal_given: dict[int, float] = {}  # joint id -> the file's q [rad or m]
        for joint_id in range(1, model.njoints):
            name = model.names[joint_id]
            urdf_type = self.urdf_joints[name].get("type") if name in self.urdf_joints else None
            pin_joint = model.joints[joint_id]
            shortname = pin_joint.shortname()
            element = declared.get(name)
            label = _label(element) if element is not None else f"<joint name='{name}'>"
            if shortname not in MOTION_COMPONENT_BY_PIN_JOINT:
                raise ModelError(
                    self.source,
                    label,
                    f"joint type {urdf_type!r} ({shortname}) is "
                    "not supported; use revolute, continuous, prismatic or floating",
                )
            motion = MOTION_COMPONENT_BY_PIN_JOINT[shortname]
            if motion is None:
                axis = _vector(self.source, element, "axis", default=(1.0, 0.0, 0.0))
            else:
                if element is not None and element.get("axis") is not None:
                    raise ModelError(
                        self.source,
                        label,
                        "the axis of a revolute or prismatic joint "
                        "is the URDF joint's <axis>; remove the attribute",
                    )
                axis = _pin_axis(pin_joint)
            clearance = self._clearance(element, label, IDEAL_KIND_OF_URDF.get(urdf_type, "free"))
            if motion is not None and motion not in clearance.free_components:
                raise ModelError(
                    self.source,
                    label,
                    f"a {clearance.kind} clearance does not allow "
                    f"the motion of the URDF {urdf_type} joint",
                )
            driven = _boolean(self.source, element, "driven", False)
            if driven and motion is None:
                raise ModelError(
                    self.source, label, "a floating joint has no single motion to drive"
                )
            if element is not None and element.get("q") is not None:
                value = _number(self.source, element, "q")
                self.nominal_given[joint_id] = value
                _set_nominal(self.source, label, model, joint_id, q, value)
            joints.append(TreeJoint(name, joint_id, clearance, rotation_x_to(axis), motion, driven))
        return tuple(joints), q

    def loop_joints(self, model: pin.Model, block: ET.Element) -> tuple[LoopJoint, ...]:
        joints = []
        names = set(model.names)
        for element in block.findall("loop_joint"):
            label, name = self._named(
                element,
                LOOP_ATTRIBUTES,
                names,
                "a joint of that name exists already",
                "needs a name",
            )
            names.add(name)
            frames = []
            for key in ("frame_a", "frame_b"):
                frame = element.get(key)
                if not frame:
                    raise ModelError(self.source, label, f"needs {key} (a link or frame name)")
                if not model.existFrame(frame):
                    known = ", ".join(sorted({f.name for f in model.frames}))
                    raise ModelError(
                        self.source,
                        label,
                        f"unknown frame {frame!r} ({key}); the frames are: {known}",
                    )
                frames.append(frame_id(model, frame))
            if model.frames[frames[0]].parentJoint == model.frames[frames[1]].parentJoint:
                raise ModelError(
                    self.source,
                    label,
                    "frame_a and frame_b are on the same body: a "
                    "loop joint must join two different bodies",
                )
            kind = element.get("type")
            if kind is None:
                raise ModelError(self.source, label, f"needs a type, one of {KINDS}")
            clearance = self._clearance(element, label, kind)
            axis = _vector(self.source, element, "axis", default=(1.0, 0.0, 0.0))
            joints.append(LoopJoint(name, frames[0], frames[1], clearance, rotation_x_to(axis)))
        return tuple(joints)

    def _clearance(self, element: ET.Element | None, label: str, default_kind: str) -> Clearance:
        if element is None or element.get("type") is None:
            if element is not None and any(
                element.get(a) for a in (*CLEARANCE_ATTRIBUTES, "diametral_clearance")
            ):
                raise ModelError(self.source, label, f"clearances need a type, one of {KINDS}")
            return ideal(default_kind)
        kind = element.get("type")
        if kind not in KINDS:
            raise ModelError(self.source, label, f"unknown type {kind!r}; expected one of {KINDS}")
        values: dict[str, float] = {}
        for attribute, field_name in CLEARANCE_ATTRIBUTES.items():
            if element.get(attribute) is not None:
                values[field_name] = _number(self.source, element, attribute, nonnegative=True)
        if element.get("diametral_clearance") is not None:
            if "radial" in values:
                raise ModelError(
                    self.source, label, "give radial_clearance or diametral_clearance, not both"
                )
            values["radial"] = 0.5 * _number(
                self.source, element, "diametral_clearance", nonnegative=True
            )
        if kind in ("cylindrical", "revolute", "prismatic") and values.get("length", 0.0) <= 0.0:
            raise ModelError(
                self.source,
                label,
                f"a {kind} joint needs length > 0 [m] (the journal or block length)",
            )
        if kind not in ("free", "rigid") and "radial" not in values:
            raise ModelError(
                self.source,
                label,
                "needs radial_clearance or diametral_clearance [m] (0 for an ideal joint)",
            )
        try:
            return Clearance(kind, **values)
        except ValueError as exc:
            raise ModelError(self.source, label, str(exc)) from None

    # -- loads ----------------------------------------------------------------------------
    def loads(
        self, model: pin.Model, block: ET.Element
    ) -> tuple[tuple[PointForce | Torque, ...], Gravity | None]:
        links = {f.name for f in model.frames if f.type == pin.FrameType.BODY}
        loads: list[PointForce | Torque] = []
        for element in block:
            label = _label(element)
            if element.tag not in ("force", "torque"):
                continue
            _check_attributes(self.source, element, {"link", "point", "value"})
            link = element.get("link")
            if link is None or link not in links:
                raise ModelError(
                    self.source,
                    label,
                    f"unknown link {link!r}; the links are: {', '.join(sorted(links))}",
                )
            value = _vector(self.source, element, "value", allow_zero=True)
            try:
                if element.tag == "force":
                    point = _vector(
                        self.source, element, "point", default=(0.0, 0.0, 0.0), allow_zero=True
                    )
                    loads.append(PointForce(link, value, point))
                else:
                    loads.append(Torque(link, value))
            except LoadError as exc:
                raise ModelError(self.source, label, str(exc)) from None
        gravity = None
        for element in block.findall("gravity"):
            _check_attributes(self.source, element, {"value", "enabled"})
            if _boolean(self.source, element, "enabled", True):
                gravity = Gravity(
                    _vector(self.source, element, "value", default=(0, 0, -9.81), allow_zero=True)
                )
        return tuple(loads), gravity


def _label(element: ET.Element | None) -> str:
    if element is None:
        return "<?>"
    name = element.get("name") or element.get("link")
    key = "name" if element.get("name") else "link"
    return f"<{element.tag} {key}='{name}'>" if name else f"<{element.tag}>"


def _check_attributes(source: str, element: ET.Element, allowed: set[str]) -> None:
    unknown = sorted(set(element.attrib) - allowed)
    if unknown:
        raise ModelError(
            source, _label(element), f"unknown attribute(s) {unknown}; allowed: {sorted(allowed)}"
        )


def _number(
    source: str,
    element: ET.Element,
    attribute: str,
    nonnegative: bool = False,
    label: str | None = None,
) -> float:
    return number(source, label or _label(element), element, attribute, nonnegative)


def _vector(
    source: str,
    element: ET.Element | None,
    attribute: str,
    default: ArrayLike | None = None,
    allow_zero: bool = False,
    label: str | None = None,
) -> np.ndarray:
    text = element.get(attribute) if element is not None else None
    return vector(source, label or _label(element), text, attribute, default, allow_zero)


def _boolean(source: str, element: ET.Element | None, attribute: str, default: bool) -> bool:
    text = element.get(attribute) if element is not None else None
    if text is None:
        return default
    if text.lower() in ("true", "1", "yes"):
        return True
    if text.lower() in ("false", "0", "no"):
        return False
    raise ModelError(source, _label(element), f"{attribute}={text!r} must be true or false")


def _pin_axis(pin_joint: pin.JointModel) -> np.ndarray:
    """Unit axis of a 1-DOF Pinocchio joint, in its joint frame, from its motion subspace
    (works for every revolute and prismatic variant, unaligned and unbounded ones included)."""
    data = pin_joint.createData()
    neutral = np.zeros(pin_joint.nq)
    if pin_joint.nq == 2:  # unbounded revolute: (cos, sin)
        neutral[0] = 1.0
    pin_joint.calc(data, neutral)
    subspace = np.asarray(data.S).reshape(6, -1)[:, 0]
    axis = subspace[3:] if np.linalg.norm(subspace[3:]) > 0.5 else subspace[:3]
    unit: np.ndarray = axis / np.linalg.norm(axis)
    return unit


def _set_nominal(
    source: str, label: str, model: pin.Model, joint_id: int, q: np.ndarray, value: float
) -> None:
    joint = model.joints[joint_id]
    if joint.nq == 1:
        q[joint.idx_q] = value
    elif joint.nq == 2 and joint.nv == 1:
        q[joint.idx_q : joint.idx_q + 2] = (math.cos(value), math.sin(value))
    else:
        raise ModelError(source, label, "a nominal value q applies to 1-DOF joints only")
