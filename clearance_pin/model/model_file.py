"""Read a mechanism from a URDF, with its ``<clearance_pin>`` block or a clearance file beside it
(format: docs/model-format.md).

The URDF holds the kinematic tree at its nominal configuration; the ``<clearance_pin>`` block
(ignored by other URDF tools, as ``<gazebo>`` blocks are) adds joint clearances, loop joints,
driven joints, nominal joint values and loads. The block is either inside the URDF or a clearance
file of its own beside an unmodified URDF (:mod:`~clearance_pin.model.clearance_file`, XML or TOML),
never both. It is read by :mod:`~clearance_pin.model.block`; an MJCF file (root ``<mujoco>``) is
read by :mod:`~clearance_pin.model.mjcf`. Every problem found is raised as a
:class:`~clearance_pin.errors.ModelError` naming the file, the element and the problem; nothing is
half-loaded.

Suspect values (a clearance in mm, a nominal value outside the URDF limits, a tolerance as wide as
its size) load, with a :class:`~clearance_pin.errors.SuspectValueWarning`
(:mod:`clearance_pin.model.plausibility`). Collision meshes are read only when a check first needs
them (:class:`CollisionGeometry`), so a solve works on a URDF whose meshes are elsewhere.
"""

from __future__ import annotations

import os
import re
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import TypeAlias

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike

from ..errors import ArgumentError, ModelError, SuspectValueWarning
from . import plausibility
from .block import BLOCK, ClearanceBlock, JointTable, empty_block, read_block
from .clearance_file import ClearanceSource, clearance_block, no_clearances
from .couplings import urdf_couplings
from .description import MechanismDescription, combined_source, describe
from .length_check import ModelScaleError, warn_model_scale
from .mjcf import read_mjcf
from .reference_sizes import Geometry, urdf_shapes
from .xml_text import decode_xml, parse, xml_text
from .xml_values import number, vector

# the deepest chain read: Pinocchio's URDF reader recurses once per joint level and crashed with
# SIGSEGV between 3757 and 3765 levels on an 8 MB stack (about 2.2 kB per level; 900 levels pass
# and 1000 crash on a 2 MB stack). 1000 keeps a margin of 3.7 on the usual 8 MB.
MAX_TREE_DEPTH = 1000
COUPLED_TYPES = ("revolute", "continuous", "prismatic")  # what a <mimic> couples
URDF_JOINT_TYPES = ("revolute", "continuous", "prismatic", "fixed", "floating", "planar")

# package_dirs of clearance_pin.load: one directory, or a list of them
PackageDirs: TypeAlias = str | os.PathLike[str] | Iterable[str | os.PathLike[str]] | None


def read_file(
    path: str | Path, package_dirs: PackageDirs = None, clearances: ClearanceSource = None
) -> MechanismDescription:
    """Read a model file: a URDF (with its block, or beside ``clearances``) or an MJCF file
    (beside ``clearances``); the arguments are those of :func:`clearance_pin.load`, which builds
    the mechanism from the description."""
    if not isinstance(path, (str, os.PathLike)):
        raise ArgumentError("path", "a file path (str or pathlib.Path)", path)
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise ModelError(str(path), "<file>", f"cannot be read: {exc.strerror or exc}") from None
    return _read(data, str(path), path.parent, package_dirs, clearances, path)


def read_text(
    text: str | bytes,
    source: str = "<string>",
    mesh_dir: Path | None = None,
    package_dirs: PackageDirs = None,
    clearances: ClearanceSource = None,
) -> MechanismDescription:
    """Read the text of a model file (see :func:`read_file`).

    Args:
        text: the file's text (str), or its bytes, decoded as its XML declaration says.
        source: the name used in messages.
        mesh_dir: directory of relative mesh paths (the file's directory).
        package_dirs: as in :func:`read_file`.
        clearances: a clearance file or a dict, as in :func:`read_file`.
    """
    return _read(text, source, mesh_dir, package_dirs, clearances, None)


def _read(
    text: object,
    source: str,
    mesh_dir: Path | None,
    package_dirs: PackageDirs,
    clearances: ClearanceSource,
    path: Path | None,
) -> MechanismDescription:
    text = xml_text(text, source)
    beside = clearance_block(clearances)
    root = parse(text, source)
    if root.tag == "mujoco":
        return read_mjcf(text, root, source, path, beside)
    directories = _package_dirs(package_dirs)
    if mesh_dir is not None:
        directories = (*directories, str(mesh_dir))
    reader = _Reader(text, root, source)
    model = reader.pin_model()
    plausibility.check_magnitudes(source, model)  # before any length of it is measured
    own = reader.block()
    if beside is not None and own is not None:
        raise ModelError(
            source,
            f"<{BLOCK}>",
            f"the URDF has a <{BLOCK}> block of its own and clearances are given beside it "
            f"({beside.source}); they are not merged: remove the block from the URDF, or leave "
            "out the clearance file",
        )
    if model.njoints <= 1:
        fixed = len(reader.urdf_joints)
        raise ModelError(
            source,
            "<robot>",
            f"no joints: the URDF has no movable joint ({len(reader.root.findall('link'))} "
            f"link(s), {fixed} fixed joint(s)): nothing can move in a play",
        )
    if beside is None and own is None:  # after the file's own checks: they come first
        raise no_clearances(source, "URDF")
    block = beside or ClearanceBlock(own if own is not None else empty_block(), source)
    types = {name: str(element.get("type")) for name, element in reader.urdf_joints.items()}
    couplings = urdf_couplings(source, _mimicking_joints(source, reader.urdf_joints))
    table = JointTable(types, "URDF", couplings=couplings)
    shapes = urdf_shapes(reader.root)
    try:
        contents = read_block(block.source, block.element, model, table, block.kind, shapes)
    except ModelScaleError as exc:  # the URDF's own lengths: the URDF is named
        raise ModelError(source, "<robot>", exc.problem) from None
    # read_file or read_text, load or loads, the caller
    with np.errstate(over="ignore", invalid="ignore"):  # a huge origin: judged elsewhere
        geometry = Geometry(model, contents.q_nominal, shapes)
    warn_model_scale(source, "<robot>", geometry, 4)
    collision = CollisionGeometry(text, source, directories) if reader.has_collision() else None
    return describe(
        model,
        contents,
        combined_source(source, beside.source if beside else None),
        reader.root.get("name", ""),
        collision,
    )


def _mimicking_joints(source: str, joints: dict[str, ET.Element]) -> list[ET.Element]:
    """The URDF joints whose ``<mimic>`` is read: a mimic on a fixed joint (TALOS's grippers
    as shipped) moves nothing and is left out, with a warning naming the URDF and the joints;
    one whose follower or leader is no revolute, continuous or prismatic joint is refused,
    naming the URDF (the clearance file was named)."""
    fixed = [
        name
        for name, element in joints.items()
        if element.get("type") == "fixed" and element.find("mimic") is not None
    ]
    if fixed:
        # _read, read_file or read_text, load or loads, the caller
        warnings.warn(
            SuspectValueWarning(
                f"{source}: <mimic> of fixed joint(s) {', '.join(map(repr, fixed))} ignored: a "
                "fixed joint has no motion to couple"
            ),
            stacklevel=5,
        )
    kept = [element for name, element in joints.items() if name not in fixed]
    for element in kept:
        mimic = element.find("mimic")
        leader = mimic.get("joint") if mimic is not None else None
        if not leader:
            continue  # no mimic, or one naming no joint: urdf_couplings says so
        label = f"<joint name='{element.get('name')}'> <mimic joint='{leader}'>"
        for role, joint in (("the follower", element), ("its leader", joints.get(leader))):
            if joint is None:
                raise ModelError(source, label, f"{leader!r} is no joint of the URDF")
            if joint.get("type") not in COUPLED_TYPES:
                raise ModelError(
                    source,
                    label,
                    f"{role} is a {joint.get('type')} joint: a mimic couples revolute, "
                    "continuous or prismatic joints",
                )
    return kept


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
    def __init__(self, text: str, root: ET.Element, source: str) -> None:
        self.text = text
        self.source = source
        self.root = root
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
        self._check_depth(parents)

    def _check_depth(self, parents: dict[str, str]) -> None:
        """Refuse a tree deeper than :data:`MAX_TREE_DEPTH` joints before Pinocchio reads it:
        its URDF reader recurses once per level and crashes the process (SIGSEGV) on a deep
        chain."""
        parent_link = {}
        for child, joint in parents.items():
            parent = self.urdf_joints[joint].find("parent")
            parent_link[child] = parent.get("link", "") if parent is not None else ""
        depth: dict[str, int] = {}
        for start in parent_link:
            path: list[str] = []
            link = start
            while link in parent_link and link not in depth and len(path) <= len(parent_link):
                path.append(link)
                link = parent_link[link]
            base = depth.get(link, 0)
            for offset, visited in enumerate(reversed(path), start=1):
                depth[visited] = base + offset
        deepest = max(depth.values(), default=0)
        if deepest > MAX_TREE_DEPTH:
            link = max(depth, key=depth.__getitem__)
            raise ModelError(
                self.source,
                f"<joint name='{parents[link]}'>",
                f"the tree is {deepest} joints deep (to link {link!r}); at most "
                f"{MAX_TREE_DEPTH} are read: Pinocchio's URDF reader crashes the process beyond "
                "about 3700 (8 MB stack)",
            )

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

    def block(self) -> ET.Element | None:
        """The URDF's own ``<clearance_pin>`` block, None without one."""
        blocks = self.root.findall(BLOCK)
        if len(blocks) > 1:
            raise ModelError(self.source, f"<{BLOCK}>", "only one block is allowed")
        return blocks[0] if blocks else None


def _number(
    source: str,
    element: ET.Element,
    attribute: str,
    nonnegative: bool = False,
    label: str | None = None,
) -> float:
    return number(source, label or f"<{element.tag}>", element, attribute, nonnegative)


def _vector(
    source: str,
    element: ET.Element | None,
    attribute: str,
    default: ArrayLike | None = None,
    allow_zero: bool = False,
    label: str | None = None,
) -> np.ndarray:
    text = element.get(attribute) if element is not None else None
    tag = f"<{element.tag}>" if element is not None else "<?>"
    return vector(source, label or tag, text, attribute, default, allow_zero)


__all__ = [
    "CollisionGeometry",
    "MechanismDescription",
    "PackageDirs",
    "decode_xml",
    "read_file",
    "read_text",
]
