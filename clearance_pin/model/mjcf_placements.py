"""Where an MJCF file places its bodies, joints and sites, read as MuJoCo reads it (plain XML
and NumPy), and the same file rewritten so that Pinocchio's MJCF reader places them there too.

The rewrite (:func:`read_placements`), on a copy of the file's tree:

1. ``<include>`` files are spliced in (relative to the file's directory);
2. the ``pos`` and orientation (joints: ``pos``, ``axis``, ``ref`` and ``type``) that a
   ``<default>`` class gives an element are written on the element (MuJoCo: the element's own,
   else the nearest class's), and the classes' orientations removed;
3. every orientation (:mod:`~clearance_pin.model.mjcf_orientation`) becomes a unit ``quat``;
4. every ``<frame>`` is composed into its children and removed (MuJoCo 3 frames): a child's
   ``pos`` becomes ``p_frame + R_frame p``, its ``quat`` ``q_frame q``, a joint's ``axis``
   ``R_frame axis``, a geom's ``fromto`` both points mapped;
5. a root body without a joint, or with a free joint, loses its ``pos`` and ``quat``, kept as
   :attr:`FilePlacements.root` for the caller to compose in memory (Pinocchio 4.1 ignores the
   first's, issue #2782, and counts the second's twice at qpos0).

The world placements at MuJoCo's ``qpos0`` (every joint at its ``ref``, where the file draws the
bodies) follow from the rewritten tree: a body's is its parent's composed with its ``pos`` and
``quat``: ``p = p_parent + R_parent pos``, ``R = R_parent R(quat)``.
"""

from __future__ import annotations

import copy
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import ModelError
from .mjcf_orientation import (
    IDENTITY,
    ORIENTATIONS,
    Compiler,
    compiler_settings,
    numbers,
    orientation,
    quat_matrix,
    quat_multiply,
)

ORIENTED = ("body", "frame", "geom", "site", "inertial", "camera", "light")
DEFAULTED = ("joint", "site", "geom")  # elements whose defaults may place them
JOINT_DEFAULTS = ("type", "pos", "axis", "ref")
# MuJoCo's values of those when no class gives them (its <joint> reference)
BUILT_IN_JOINT = {"type": "hinge", "pos": "0 0 0", "axis": "0 0 1", "ref": "0"}
PROCEDURAL = ("replicate", "attach", "composite", "flexcomp")


@dataclass(frozen=True)
class Placement:
    """A frame in the world at ``qpos0``.

    Attributes:
        rotation: (3, 3) its axes in world axes.
        translation: (3,) its origin [m].
        given: how the file places it (its attributes, and the frames it sits in), for messages.
    """

    rotation: np.ndarray
    translation: np.ndarray
    given: str


@dataclass(frozen=True)
class JointPlacement:
    """A hinge or slide joint in the world at ``qpos0``.

    Attributes:
        kind: "hinge", "slide", "ball" or "free".
        anchor: (3,) a point of its axis [m].
        axis: (3,) its unit axis, world axes.
        body: the body it moves.
        given: how the file places it, for messages.
        ref: its value at qpos0 [rad or m] (MuJoCo's ``ref``, in the compiler's angle unit for
            a hinge).
    """

    kind: str
    anchor: np.ndarray
    axis: np.ndarray
    body: str
    given: str
    ref: float = 0.0


@dataclass
class FilePlacements:
    """What the file places, as MuJoCo reads it, and the tree rewritten for Pinocchio.

    Attributes:
        tree: the rewritten ``<mujoco>`` element.
        bodies: named bodies: their world placement at ``qpos0``.
        joints: named joints.
        sites: named sites: their world placement, and the body they belong to (None: the world).
        site_local: named sites: (rotation, translation) in their body's frame.
        root: the placement (rotation, translation [m]) of a root body fixed to the world or
            free, taken out of the rewritten tree; None when there is none to compose.
    """

    tree: ET.Element
    bodies: dict[str, Placement] = field(default_factory=dict)
    joints: dict[str, JointPlacement] = field(default_factory=dict)
    sites: dict[str, tuple[Placement, str | None]] = field(default_factory=dict)
    site_local: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)
    root: tuple[np.ndarray, np.ndarray] | None = None


def label(element: ET.Element) -> str:
    """How messages name an element: ``<body name='arm'>``, or ``<geom>`` without a name."""
    name = element.get("name")
    return f"<{element.tag} name='{name}'>" if name else f"<{element.tag}>"


def read_placements(root: ET.Element, source: str, directory: Path | None) -> FilePlacements:
    """The placements of the MJCF tree ``root`` and the tree rewritten for Pinocchio (module
    docstring).

    Args:
        root: the ``<mujoco>`` element (not modified).
        source: the file, named in messages.
        directory: the file's directory, where its ``<include>`` files are (None: text without
            a file; an include is then refused).
    """
    tree = copy.deepcopy(root)
    _splice_includes(tree, source, directory, depth=0)
    compiler = compiler_settings(tree, source)
    for tag in PROCEDURAL:
        found = tree.find(f".//worldbody//{tag}")
        if found is None:
            found = tree.find(f"worldbody/{tag}")
        if found is not None:
            raise ModelError(
                source,
                label(found),
                f"<{tag}> (procedural MJCF) is not read: Pinocchio's MJCF reader does not "
                "expand it. Write the elements it makes (MuJoCo's mj_saveLastXML saves them)",
            )
    defaults = _Defaults(tree, source)
    for world in tree.findall("worldbody"):
        _resolve(world, "main", defaults, compiler, source, "")
        _flatten(world, source)
    defaults.strip_orientations()
    placements = FilePlacements(tree)
    for world in tree.findall("worldbody"):
        _place_children(
            world, None, np.eye(3), np.zeros(3), placements, source, compiler.angle_unit
        )
    roots = [b for w in tree.findall("worldbody") for b in w.findall("body")]
    if roots and _composed_in_memory(roots[0]):
        rotation, translation = _local(roots[0], source)
        if translation.any() or not np.array_equal(rotation, np.eye(3)):
            placements.root = (rotation, translation)
            for attribute in ("pos", "quat"):
                roots[0].attrib.pop(attribute, None)
    for element in tree.iter():
        element.attrib.pop("_given", None)
    return placements


def _splice_includes(element: ET.Element, source: str, directory: Path | None, depth: int) -> None:
    if depth > 20:
        raise ModelError(source, "<include>", "includes nested more than 20 deep (a cycle?)")
    index = 0
    while index < len(element):
        child = element[index]
        if child.tag != "include":
            _splice_includes(child, source, directory, depth)
            index += 1
            continue
        name = child.get("file")
        if not name:
            raise ModelError(source, "<include>", "needs a file attribute")
        if directory is None:
            raise ModelError(
                source,
                f"<include file='{name}'>",
                "an include is read relative to the MJCF file: load the file by its path "
                "(clearance_pin.load), not its text",
            )
        try:
            included = ET.fromstring((directory / name).read_bytes())
        except OSError as exc:
            raise ModelError(
                source, f"<include file='{name}'>", f"cannot be read: {exc.strerror or exc}"
            ) from None
        except ET.ParseError as exc:
            raise ModelError(source, f"<include file='{name}'>", f"malformed XML: {exc}") from None
        if included.tag != "mujoco":
            raise ModelError(
                source, f"<include file='{name}'>", "an included file's root must be <mujoco>"
            )
        _splice_includes(included, source, directory, depth + 1)
        element.remove(child)
        for offset, grandchild in enumerate(list(included)):
            element.insert(index + offset, grandchild)
        index += len(included)


class _Defaults:
    """The ``<default>`` classes: an attribute of an element kind, looked up from a class up
    through its parents to "main" (MuJoCo's inheritance)."""

    def __init__(self, tree: ET.Element, source: str) -> None:
        self.parent: dict[str, str | None] = {}
        self.entries: dict[tuple[str, str], ET.Element] = {}
        for top in tree.findall("default"):
            self._read(top, None, source, top=True)

    def _read(self, element: ET.Element, parent: str | None, source: str, top: bool) -> None:
        name = element.get("class", "main" if top else None)
        if name is None:
            raise ModelError(source, "<default>", "a nested default class needs a class name")
        self.parent.setdefault(name, parent)
        for child in element:
            if child.tag == "default":
                self._read(child, name, source, top=False)
                continue
            given = [a for a in ORIENTATIONS if child.get(a) is not None]
            if len(given) > 1:
                raise ModelError(
                    source,
                    f"<default class='{name}'> <{child.tag}>",
                    f"several orientations ({', '.join(given)}): MuJoCo takes at most one",
                )
            self.entries[(name, child.tag)] = child

    def orientation(self, cls: str, tag: str) -> tuple[str, str, str] | None:
        """(class, attribute, value) of the nearest class of the chain that orients ``tag``
        elements (MuJoCo: the nearest specification wins, whatever its form); None: none."""
        seen = set()
        current: str | None = cls
        while current is not None and current not in seen:
            seen.add(current)
            entry = self.entries.get((current, tag))
            given = [a for a in ORIENTATIONS if entry is not None and entry.get(a) is not None]
            if entry is not None and given:
                return current, given[0], str(entry.get(given[0]))
            current = self.parent.get(current)
        return None

    def strip_orientations(self) -> None:
        """Remove the orientations from the classes, once written on the elements (Pinocchio's
        reader is not left to merge them its own way)."""
        for entry in self.entries.values():
            for attribute in ORIENTATIONS:
                entry.attrib.pop(attribute, None)

    def get(self, cls: str, tag: str, attribute: str) -> str | None:
        seen = set()
        current: str | None = cls
        while current is not None and current not in seen:
            seen.add(current)
            entry = self.entries.get((current, tag))
            if entry is not None and entry.get(attribute) is not None:
                return entry.get(attribute)
            current = self.parent.get(current)
        return None


def _resolve(
    element: ET.Element,
    childclass: str,
    defaults: _Defaults,
    compiler: Compiler,
    source: str,
    frames: str,
) -> None:
    """Write on each element the placement its class gives it and its orientation as a unit
    quat; note how the file placed it (private attribute ``_given``, removed at the end)."""
    for child in element:
        cls = child.get("class", childclass)
        if child.get("class") is not None and cls not in defaults.parent:
            raise ModelError(source, label(child), f"class='{cls}' is not a default class")
        if child.tag in DEFAULTED:
            wanted = JOINT_DEFAULTS if child.tag == "joint" else ("pos",)
            for attribute in wanted:
                if child.get(attribute) is None:
                    value = defaults.get(cls, child.tag, attribute)
                    if value is not None:
                        child.set(attribute, value)
        given = ""
        inherited = ""
        own = any(child.get(a) is not None for a in (*ORIENTATIONS, "fromto"))
        if child.tag in ORIENTED and not own:
            found = defaults.orientation(cls, child.tag)
            if found is not None:
                child.set(found[1], found[2])
                inherited = f" (orientation from default class '{found[0]}')"
        if child.tag in (*ORIENTED, "joint"):
            given = _given(child, compiler) + inherited
            if child.tag == "site" and child.get("fromto") is not None:
                given = f"fromto='{child.get('fromto')}'"
                _site_fromto(child, source)
            if child.tag != "joint":
                quat, oriented = orientation(source, label(child), child, compiler)
                if oriented is not None:
                    _set_quat(child, quat)
            child.set("_given", given + frames)
        if child.tag == "joint" and child.get("type", "hinge") in ("hinge", "slide"):
            # MuJoCo's own defaults, written out: Pinocchio's reader would take a joint's
            # missing attribute from its body's childclass even when the joint names another
            # class (MuJoCo: the joint's class chain, then these; a ball or free joint takes
            # no axis or ref)
            for attribute, value in BUILT_IN_JOINT.items():
                if child.get(attribute) is None:
                    child.set(attribute, value)
        inner = child.get("childclass", cls) if child.tag in ("body", "frame") else childclass
        # the frames an element sits in are named in its messages
        where = f", inside {label(child)} {given}{frames}" if child.tag == "frame" else ""
        _resolve(child, inner, defaults, compiler, source, where)


def _site_fromto(site: ET.Element, source: str) -> None:
    """A site given by ``fromto`` (it overrides pos and orientation): at the middle of the
    segment, its z axis from the second point to the first (MuJoCo's user_objects.cc: the
    zaxis rule applied to from - to), written as pos and zaxis."""
    ends = numbers(source, label(site), site, "fromto", 6).reshape(2, 3)
    if np.linalg.norm(ends[1] - ends[0]) < 1e-14:
        raise ModelError(source, label(site), "fromto has zero length: it has no direction")
    for attribute in ("fromto", *ORIENTATIONS):
        site.attrib.pop(attribute, None)
    site.set("pos", _text(ends.mean(axis=0)))
    site.set("zaxis", _text(ends[0] - ends[1]))


def _given(element: ET.Element, compiler: Compiler) -> str:
    """How the file places ``element``: its attributes, with the angle unit and Euler sequence
    they are read with."""
    shown = [f"{a}='{element.get(a)}'" for a in ("pos", *ORIENTATIONS, "axis") if element.get(a)]
    given = " ".join(shown) or "no pos or orientation"
    unit = "degrees" if compiler.degrees else "radians"
    if element.get("euler") is not None:
        given += f" (angles in {unit}, eulerseq '{compiler.eulerseq}')"
    elif element.get("axisangle") is not None:
        given += f" (angle in {unit})"
    return given


def _set_quat(element: ET.Element, quat: np.ndarray) -> None:
    for attribute in ORIENTATIONS:
        element.attrib.pop(attribute, None)
    element.set("quat", " ".join(f"{v:.17g}" for v in quat))


def _vector(
    element: ET.Element, attribute: str, default: tuple[float, ...], source: str
) -> np.ndarray:
    """The numbers of an attribute (as many as ``default``), or ``default`` without it."""
    if element.get(attribute) is None:
        return np.array(default, dtype=float)
    return numbers(source, label(element), element, attribute, len(default))


def _local(element: ET.Element, source: str) -> tuple[np.ndarray, np.ndarray]:
    """(rotation, translation) of an element in its parent, from its pos and unit quat."""
    quat = _vector(element, "quat", tuple(IDENTITY), source)
    return quat_matrix(quat), _vector(element, "pos", (0.0, 0.0, 0.0), source)


def _text(values: np.ndarray) -> str:
    return " ".join(f"{v:.17g}" for v in values)


def _flatten(element: ET.Element, source: str) -> None:
    """Compose every ``<frame>`` under ``element`` into its children, and remove it."""
    index = 0
    while index < len(element):
        child = element[index]
        _flatten(child, source)
        if child.tag != "frame":
            index += 1
            continue
        frame_quat = _vector(child, "quat", tuple(IDENTITY), source)
        rotation, translation = (
            quat_matrix(frame_quat),
            _vector(child, "pos", (0.0, 0.0, 0.0), source),
        )
        childclass = child.get("childclass")
        moved = list(child)
        for grandchild in moved:
            if childclass is not None:
                if grandchild.tag in ("body", "frame"):
                    grandchild.set("childclass", grandchild.get("childclass", childclass))
                else:
                    grandchild.set("class", grandchild.get("class", childclass))
            if grandchild.tag == "geom" and grandchild.get("fromto") is not None:
                ends = numbers(source, label(grandchild), grandchild, "fromto", 6).reshape(2, 3)
                grandchild.set("fromto", _text((ends @ rotation.T + translation).ravel()))
                continue
            if grandchild.tag == "joint":
                grandchild.set(
                    "axis", _text(rotation @ _vector(grandchild, "axis", (0.0, 0.0, 1.0), source))
                )
            pos = _vector(grandchild, "pos", (0.0, 0.0, 0.0), source)
            grandchild.set("pos", _text(translation + rotation @ pos))
            if grandchild.tag != "joint":
                quat = quat_multiply(
                    frame_quat, _vector(grandchild, "quat", tuple(IDENTITY), source)
                )
                _set_quat(grandchild, quat / np.linalg.norm(quat))
        element.remove(child)
        for offset, grandchild in enumerate(moved):
            element.insert(index + offset, grandchild)
        index += len(moved)


def _composed_in_memory(body: ET.Element) -> bool:
    """Whether Pinocchio's reader misplaces this root body: fixed to the world (its placement
    ignored, issue #2782) or free (its placement counted twice at qpos0)."""
    joints = body.findall("joint")
    return not joints or body.find("freejoint") is not None or joints[0].get("type") == "free"


def _place_children(
    element: ET.Element,
    body: str | None,
    rotation: np.ndarray,
    translation: np.ndarray,
    placements: FilePlacements,
    source: str,
    angle_unit: float,
) -> None:
    for child in element:
        if child.tag == "site":
            local_rotation, local_translation = _local(child, source)
            name = child.get("name")
            if name:
                placements.sites[name] = (
                    Placement(
                        rotation @ local_rotation,
                        translation + rotation @ local_translation,
                        child.get("_given", ""),
                    ),
                    body,
                )
                placements.site_local[name] = (local_rotation, local_translation)
        elif child.tag in ("joint", "freejoint"):
            kind = "free" if child.tag == "freejoint" else child.get("type", "hinge")
            axis = _vector(child, "axis", (0.0, 0.0, 1.0), source)
            norm = float(np.linalg.norm(axis))
            if kind in ("hinge", "slide") and norm < 1e-14:
                raise ModelError(source, label(child), "axis is zero: it has no direction")
            name = child.get("name")
            ref = float(_vector(child, "ref", (0.0,), source)[0])
            if name and body is not None:
                placements.joints[name] = JointPlacement(
                    kind,
                    translation + rotation @ _vector(child, "pos", (0.0, 0.0, 0.0), source),
                    rotation @ axis / (norm or 1.0),
                    body,
                    child.get("_given", ""),
                    ref * angle_unit if kind == "hinge" else ref,
                )
        elif child.tag == "body":
            local_rotation, local_translation = _local(child, source)
            world_rotation = rotation @ local_rotation
            world_translation = translation + rotation @ local_translation
            name = child.get("name")
            if name:
                placements.bodies[name] = Placement(
                    world_rotation, world_translation, child.get("_given", "")
                )
            _place_children(
                child, name, world_rotation, world_translation, placements, source, angle_unit
            )


__all__ = ["FilePlacements", "JointPlacement", "Placement", "label", "read_placements"]
