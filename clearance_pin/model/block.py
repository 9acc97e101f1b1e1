"""The ``<clearance_pin>`` block, wherever it comes from, read against a Pinocchio model.

The block holds joint clearances (per joint and by default per joint type), loop joints, driven
joints, nominal joint values, loads, gravity and toleranced dimensions (format:
docs/model-format.md). It is an XML element: the one inside a URDF, the root of a clearance file
(:mod:`~clearance_pin.model.clearance_file`, which also turns a TOML file or a Python dict into
one). What it is read against is a ``pin.Model`` and a :class:`JointTable`, the type of every named
joint in URDF words (from the URDF text, or from the Pinocchio joints of an MJCF or in-memory
model), so the same block reads the same way beside a URDF, an MJCF file or a ``pin.Model``.

Units: every value is SI unless the block says otherwise with ``unit="mm"`` (``m``, ``mm`` or
``um``; default ``m``): then every length of the block (clearances, journal and block lengths,
force points, nominal values of prismatic joints, toleranced lengths) is in that unit and
converted to metres here; angles stay in radians, forces in N, torques in N m, gravity in m/s^2.
Every length is then judged against the model's own geometry, so a forgotten or wrong unit is
refused or warned (:mod:`~clearance_pin.model.length_check`).

Every problem is a :class:`~clearance_pin.errors.ModelError` naming the file, the element and the
problem.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Container, Mapping
from dataclasses import dataclass, replace

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike

from ..errors import LoadError, ModelError
from .clearance import BACKLASH_KINDS, KINDS, Clearance, U, ideal
from .couplings import Coupling, coupled, coupling_cycle, in_order
from .dimensions import Dimension, parse_dimensions
from .joints import MOTION_COMPONENT_BY_PIN_JOINT, LoopJoint, TreeJoint, rotation_x_to
from .length_check import Kind, Length, check_lengths
from .loads import Gravity, PointForce, Torque
from .reference_sizes import Geometry, Shape
from .stiffness import STIFFNESS_ATTRIBUTES, STIFFNESS_FRAMES, as_entries, stiffness_matrix
from .xml_values import UNITS, label_of, labelled, number, vector

BLOCK = "clearance_pin"
ELEMENTS = ("joint", "default", "loop_joint", "lock", "force", "torque", "gravity", "dimension")
LOCK_ATTRIBUTES = {"joint", "q"}
CLEARANCE_ATTRIBUTES = {
    "radial_clearance": "radial",
    "length": "length",
    "axial_clearance": "axial",
    "play_z": "play_z",
    "width": "width",
    "height": "height",
}
LENGTH_ATTRIBUTES = {*CLEARANCE_ATTRIBUTES, "diametral_clearance"}  # in the block's unit
JOINT_ATTRIBUTES = {
    "name", "type", "driven", "backlash", "q", "axis", *LENGTH_ATTRIBUTES, *STIFFNESS_ATTRIBUTES,
    "stiffness_frame",
}  # fmt: skip
DEFAULT_ATTRIBUTES = (JOINT_ATTRIBUTES - {"name", "q"}) | {"joint_type"}
LOOP_ATTRIBUTES = {
    "name", "type", "frame_a", "frame_b", "axis", *LENGTH_ATTRIBUTES,
    *(a for a in STIFFNESS_ATTRIBUTES if a != "drive_stiffness"), "stiffness_frame",
}  # fmt: skip
# URDF joint types a <default> may name; "revolute" also covers continuous joints
DEFAULT_TYPES = ("revolute", "continuous", "prismatic", "floating")
MJCF_WORDS = {"hinge": "revolute", "slide": "prismatic", "free": "floating"}
IDEAL_KIND_OF_URDF: dict[str | None, str] = {
    "revolute": "revolute",
    "continuous": "revolute",
    "prismatic": "prismatic",
    "floating": "free",
}
URDF_TYPE_OF_PIN_JOINT = {
    **dict.fromkeys(("JointModelRX", "JointModelRY", "JointModelRZ"), "revolute"),
    "JointModelRevoluteUnaligned": "revolute",
    **dict.fromkeys(("JointModelRUBX", "JointModelRUBY", "JointModelRUBZ"), "continuous"),
    "JointModelRevoluteUnboundedUnaligned": "continuous",
    **dict.fromkeys(("JointModelPX", "JointModelPY", "JointModelPZ"), "prismatic"),
    "JointModelPrismaticUnaligned": "prismatic",
    "JointModelFreeFlyer": "floating",
    "JointModelPlanar": "planar",
}


@dataclass(frozen=True)
class JointTable:
    """The named joints a block can refer to, with their type in URDF words.

    Attributes:
        types: joint name -> ``"revolute"``, ``"continuous"``, ``"prismatic"``, ``"floating"``,
            ``"fixed"``, ``"planar"``, or the Pinocchio joint's name when URDF has no word for it
            (``"JointModelSpherical"`` of an MJCF ball joint). Every movable joint of the model is
            in it; the fixed joints when their names are known (a URDF's ``fixed`` joints).
        origin: what the joints come from, in messages: ``"URDF"``, ``"MJCF"``, ``"model"``.
        supported: how to write a supported joint there (the end of the message refusing one).
        couplings: followers set by their leaders (a URDF's ``<mimic>``, :mod:`.couplings`).
    """

    types: Mapping[str, str]
    origin: str
    supported: str = "use revolute, continuous, prismatic or floating"
    couplings: tuple[Coupling, ...] = ()


def joint_table(model: pin.Model, origin: str, supported: str | None = None) -> JointTable:
    """The :class:`JointTable` of a ``pin.Model``: its joints' types from their Pinocchio kind,
    and its fixed joints from its ``FIXED_JOINT`` frames (a URDF's fixed joints)."""
    types: dict[str, str] = {}
    for frame in model.frames[1:]:
        if frame.type == pin.FrameType.FIXED_JOINT:
            types[frame.name] = "fixed"
    for joint_id in range(1, model.njoints):
        shortname = model.joints[joint_id].shortname()
        types[model.names[joint_id]] = URDF_TYPE_OF_PIN_JOINT.get(shortname, shortname)
    if supported is None:
        return JointTable(types, origin)
    return JointTable(types, origin, supported)


@dataclass(frozen=True)
class ClearanceBlock:
    """A ``<clearance_pin>`` block and where it comes from.

    Attributes:
        element: the block.
        source: the file (or ``"<clearances>"`` for a Python dict), named in messages.
        kind: ``"file"`` (a clearance file), ``"dict"`` (a Python dict) or ``"model"`` (a block
            inside a URDF, or none): how sure a length out of proportion is a unit mistake
            (:mod:`~clearance_pin.model.length_check`).
    """

    element: ET.Element
    source: str
    kind: str = "model"


@dataclass(frozen=True)
class BlockContents:
    """What a block says of a model (SI).

    Attributes:
        tree_joints: every joint of the model with its clearance (ideal when none is given).
        q_nominal: the nominal configuration (nq,): where the model file draws the parts
            (an MJCF file's ``qpos0``, each joint at its ``ref``; Pinocchio's neutral one for a
            URDF) with the block's nominal values.
        nominal_given: joint id -> nominal value [rad or m] as the block gives it.
        loop_joints: the cut joints.
        loads: forces and torques.
        gravity: gravity when the block switches it on, else None.
        dimensions: toleranced dimensions.
        couplings: followers held through their leaders' drives (:mod:`.couplings`).
    """

    tree_joints: tuple[TreeJoint, ...]
    q_nominal: np.ndarray
    nominal_given: dict[int, float]
    loop_joints: tuple[LoopJoint, ...]
    loads: tuple[PointForce | Torque, ...]
    gravity: Gravity | None
    dimensions: tuple[Dimension, ...]
    couplings: tuple[Coupling, ...] = ()


def empty_block() -> ET.Element:
    """A block that says nothing: every joint ideal, no loop, no load."""
    return ET.Element(BLOCK)


def read_block(
    source: str,
    block: ET.Element,
    model: pin.Model,
    joints: JointTable,
    kind: str = "model",
    shapes: tuple[Shape, ...] = (),
) -> BlockContents:
    """Read a ``<clearance_pin>`` block against ``model``; every length it gives is judged
    against the model's own geometry (:mod:`~clearance_pin.model.length_check`).

    Args:
        source: the block's file, named in messages.
        block: the ``<clearance_pin>`` element.
        model: the kinematic tree.
        joints: its named joints and their types.
        kind: where the block comes from (:attr:`ClearanceBlock.kind`).
        shapes: primitive shapes of the model's links (a URDF's), part of its geometry.

    Raises:
        ModelError: any invalid element, naming ``source``, the element and the problem; a
            length out of proportion with the geometry (a unit mistake), as length_check says.
    """
    reader = _BlockReader(source, block, model, joints)
    tree_joints, q = reader.tree_joints()
    loop_joints = reader.loop_joints()
    forces, gravity = reader.loads()
    dimensions = parse_dimensions(source, block, model, reader.exponent)
    lengths = reader.lengths + _tolerance_lengths(block, dimensions)
    if lengths:
        unit = block.get("unit")
        check_lengths(source, lengths, Geometry(model, q, shapes), unit, kind, stacklevel=4)
    return BlockContents(
        tree_joints=tree_joints,
        q_nominal=q,
        nominal_given=dict(reader.nominal_given),
        loop_joints=loop_joints,
        loads=forces,
        gravity=gravity,
        dimensions=dimensions,
        couplings=reader.couplings,
    )


def _tolerance_lengths(block: ET.Element, dimensions: tuple[Dimension, ...]) -> list[Length]:
    """The tolerances [m] of the length dimensions given in the block's unit."""
    elements = {element.get("name"): element for element in block.findall("dimension")}
    lengths = []
    for dimension in dimensions:
        element = elements.get(dimension.name)
        if dimension.kind != "length" or dimension.grade is not None or element is None:
            continue
        attribute = "tolerance" if element.get("tolerance") is not None else "half_tolerance"
        lengths.append(
            Length(
                label_of(element) or f"<dimension name='{dimension.name}'>",
                attribute,
                dimension.tolerance,
                "tolerance",
                reference=abs(dimension.nominal),
                written=dimension.half_tolerance if attribute == "half_tolerance" else math.nan,
            )
        )
    return lengths


def read_loop_joints(source: str, block: ET.Element, model: pin.Model) -> tuple[LoopJoint, ...]:
    """Read only the ``<loop_joint>`` elements of a block (loop joints given apart from the
    clearances: ``from_model(..., loop_joints=...)``, a dict in SI), their lengths judged
    against the model's geometry as a dict's (:mod:`~clearance_pin.model.length_check`)."""
    reader = _BlockReader(source, block, model, JointTable({}, "model"))
    loop_joints = reader.loop_joints()
    if reader.lengths:
        geometry = Geometry(model, drawn_configuration(model))
        check_lengths(source, reader.lengths, geometry, block.get("unit"), "dict", stacklevel=4)
    return loop_joints


class _BlockReader:
    def __init__(self, source: str, block: ET.Element, model: pin.Model, joints: JointTable):
        self.source = source
        self.block = block
        self.model = model
        self.joints = joints
        self.nominal_given: dict[int, float] = {}  # joint id -> the file's q [rad or m]
        self.locked: set[str] = set()  # joints a <lock> holds (no default applies to them)
        self.couplings: tuple[Coupling, ...] = ()  # on Pinocchio's q (tree_joints sets them)
        self.lengths: list[Length] = []  # every length read [m], judged against the geometry
        label = label_of(block) or f"<{BLOCK}>"
        _check_attributes(source, block, {"unit"}, label)
        unit = block.get("unit", "m")
        if unit not in UNITS:
            raise ModelError(
                source, label, f"unit={unit!r} is not a length unit; expected one of m, mm, um"
            )
        self.exponent = UNITS[unit]
        self.unit = unit  # named in messages about lengths
        for child in block:
            if child.tag not in ELEMENTS:
                raise ModelError(
                    source,
                    label_of(child) or f"<{child.tag}>",
                    f"unknown element in <{BLOCK}>; expected one of {sorted(ELEMENTS)}",
                )

    def _number(
        self, element: ET.Element, attribute: str, nonnegative: bool = False, length: bool = False
    ) -> float:
        exponent = self.exponent if length else 0
        return number(self.source, _label(element), element, attribute, nonnegative, "", exponent)

    def _vector(
        self,
        element: ET.Element | None,
        attribute: str,
        default: ArrayLike | None = None,
        allow_zero: bool = False,
        length: bool = False,
    ) -> np.ndarray:
        text = element.get(attribute) if element is not None else None
        label = _label(element)
        exponent = self.exponent if length else 0
        return vector(self.source, label, text, attribute, default, allow_zero, exponent)

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
        _check_attributes(self.source, element, allowed, label)
        name = element.get("name")
        if not name:
            raise ModelError(self.source, label, missing)
        if name in taken:
            raise ModelError(self.source, label, duplicate)
        return label, name

    def _declared(self) -> dict[str, ET.Element]:
        """The block's ``<joint>`` entries by name, each naming a movable joint of the model."""
        origin = self.joints.origin
        declared: dict[str, ET.Element] = {}
        for entry in self.block.findall("joint"):
            label, name = self._named(
                entry,
                JOINT_ATTRIBUTES,
                declared,
                "declared twice",
                f"needs a name (a {origin} joint's name)",
            )
            if name not in self.joints.types:
                raise ModelError(
                    self.source,
                    label,
                    f"no {origin} joint is called {name!r}; the {origin} "
                    f"joints are: {', '.join(self.joints.types) or 'none'}",
                )
            if self.joints.types[name] == "fixed":
                raise ModelError(
                    self.source,
                    label,
                    f"the {origin} joint is fixed: Pinocchio merges its "
                    "two links into one body, so it cannot carry play. Give it type "
                    f"'floating' (any play) or 'revolute' in the {origin}.",
                )
            declared[name] = entry
        for lock in self.block.findall("lock"):
            label = _label(lock)
            _check_attributes(self.source, lock, LOCK_ATTRIBUTES, label)
            target = lock.get("joint") or ""
            if not target or self.joints.types.get(target) in (None, "fixed"):
                raise ModelError(
                    self.source,
                    label,
                    f"joint= must name a movable {origin} joint; they are: "
                    + ", ".join(n for n, t in self.joints.types.items() if t != "fixed"),
                )
            if target in declared:
                raise ModelError(
                    self.source,
                    label,
                    f"{target!r} is both locked and given a <joint> entry: a locked joint is "
                    "rigid, held where it is; remove one of them",
                )
            # an ideal joint of its type, held by a drive at q (default: its nominal value)
            attributes = {"name": target, "driven": "true"}
            if lock.get("q") is not None:
                attributes["q"] = str(lock.get("q"))
            declared[target] = labelled("joint", attributes, f"<lock joint='{target}'>")
            self.locked.add(target)
        return declared

    def _defaults(self) -> dict[str, ET.Element]:
        """The block's ``<default>`` entries by URDF joint type, each a type the model has."""
        defaults: dict[str, ET.Element] = {}
        movable = {n: t for n, t in self.joints.types.items() if t != "fixed"}
        present = set(movable.values())
        if "continuous" in present:
            present.add("revolute")
        for entry in self.block.findall("default"):
            label = _label(entry)
            _check_attributes(self.source, entry, DEFAULT_ATTRIBUTES, label)
            joint_type = entry.get("joint_type")
            if joint_type is None:
                raise ModelError(
                    self.source, label, f"needs joint_type, one of {', '.join(DEFAULT_TYPES)}"
                )
            if joint_type not in DEFAULT_TYPES:
                hint = MJCF_WORDS.get(joint_type)
                also = f" (an MJCF {joint_type} joint is {hint!r} here)" if hint else ""
                raise ModelError(
                    self.source,
                    label,
                    f"joint_type={joint_type!r} is not a joint type a default applies to; "
                    f"expected one of {', '.join(DEFAULT_TYPES)}{also}",
                )
            if joint_type in defaults:
                raise ModelError(self.source, label, "declared twice")
            if joint_type not in present:
                kinds = ", ".join(f"{n} ({t})" for n, t in movable.items()) or "none"
                raise ModelError(
                    self.source,
                    label,
                    f"a default for {joint_type} joints, but the {self.joints.origin} has "
                    f"none; its movable joints are: {kinds}",
                )
            defaults[joint_type] = entry
        return defaults

    def tree_joints(self) -> tuple[tuple[TreeJoint, ...], np.ndarray]:
        model = self.model
        declared = self._declared()
        defaults = self._defaults()
        q = drawn_configuration(model)
        joints = []

        def element_of(name: str) -> ET.Element | None:
            joint_type = self.joints.types.get(name)
            default = None if name in self.locked else defaults.get(joint_type or "")
            if default is None and joint_type == "continuous" and name not in self.locked:
                default = defaults.get("revolute")
            return _with_default(name, declared.get(name), default)

        # a follower is held through its leader's drive; a passive leader's follower is passive
        # too, the coupling a condition between the two joints' motions (:mod:`.couplings`)
        followers: set[str] = set()  # a chain's: a follower's follower is held too
        try:
            ordered = in_order(self.joints.couplings)
        except ModelError:
            ordered = ()  # a cycle: refused by name below (_coupled)
        for c in ordered:
            if c.leader in followers or _boolean(
                self.source, element_of(c.leader), "driven", False
            ):
                followers.add(c.follower)
        for joint_id in range(1, model.njoints):
            name = model.names[joint_id]
            joint_type = self.joints.types.get(name)
            pin_joint = model.joints[joint_id]
            shortname = pin_joint.shortname()
            element = element_of(name)
            label = _label(element) if element is not None else f"<joint name='{name}'>"
            if shortname == "JointModelMimic":
                raise ModelError(
                    self.source,
                    label,
                    "a Pinocchio mimic joint (a model built with mimic=True) has no motion of its "
                    "own to hold play: load the URDF file with clearance_pin.load, which reads "
                    "its <mimic> as a coupling, or build the model with mimic=False (the default)",
                )
            if shortname not in MOTION_COMPONENT_BY_PIN_JOINT:
                raise ModelError(
                    self.source,
                    label,
                    f"joint type {joint_type!r} ({shortname}) is not supported; "
                    f"{self.joints.supported}",
                )
            motion = MOTION_COMPONENT_BY_PIN_JOINT[shortname]
            if motion is None:
                axis = self._vector(element, "axis", default=(1.0, 0.0, 0.0))
            else:
                if element is not None and element.get("axis") is not None:
                    raise ModelError(
                        self.source,
                        label,
                        f"the axis of a revolute or prismatic joint is the {self.joints.origin} "
                        "joint's <axis>; remove the attribute",
                    )
                axis = _pin_axis(pin_joint)
            kind = IDEAL_KIND_OF_URDF.get(joint_type, "free")
            bodies = (int(model.parents[joint_id]), joint_id)
            clearance = self._clearance(element, label, kind, bodies)
            if motion is not None and motion not in clearance.free_components:
                raise ModelError(
                    self.source,
                    label,
                    f"a {clearance.kind} clearance does not allow "
                    f"the motion of the {self.joints.origin} {joint_type} joint",
                )
            # a follower is held through its leader's drive (:mod:`.couplings`)
            driven = _boolean(self.source, element, "driven", False) or name in followers
            if driven and motion is None:
                raise ModelError(
                    self.source, label, "a floating joint has no single motion to drive"
                )
            drive_terms = [a for a in ("backlash", "drive_stiffness") if element is not None
                           and element.get(a) is not None]  # fmt: skip
            passive_leader = next((c.leader for c in self.joints.couplings if c.follower == name
                                   and name not in followers), None)  # fmt: skip
            if drive_terms and passive_leader is not None and not driven:
                raise ModelError(
                    self.source,
                    label,
                    f"{' and '.join(drive_terms)} belong to a drive, and this joint follows "
                    f"{passive_leader!r} through its <mimic>, which is not driven: drive the "
                    f'leader (driven="true" on {passive_leader!r}) to hold both, and the '
                    "follower's own backlash becomes the coupling's deadband",
                )
            if element is not None and element.get("backlash") is not None:
                clearance = self._with_backlash(element, label, clearance, driven, motion)
            clearance = self._with_stiffness(element, label, clearance, motion if driven else None)
            if element is not None and element.get("q") is not None:
                value = self._number(element, "q", length=motion == U)  # m or rad
                if motion == U:
                    span = _largest_limit(model, joint_id)
                    self.lengths.append(
                        Length(label, "q", abs(value), "position", (joint_id,), reference=span)
                    )
                self.nominal_given[joint_id] = value
                set_nominal(self.source, label, model, joint_id, q, value)
            locked = name in self.locked
            axes = rotation_x_to(axis)
            joints.append(TreeJoint(name, joint_id, clearance, axes, motion, driven, locked))
        self.couplings = tuple(
            c.absolute(model, drawn_configuration(model)) for c in self.joints.couplings
        )
        return tuple(joints), self._coupled(tuple(joints), q)

    def _coupled(self, joints: tuple[TreeJoint, ...], q: np.ndarray) -> np.ndarray:
        """``q`` with each follower at its leader's value times the multiplier plus the offset;
        a leader that is not driven, or a follower given another value, is refused."""
        couplings = self.couplings
        cycle = coupling_cycle(couplings)
        if cycle:
            chain = " -> ".join((*cycle, cycle[0]))
            raise ModelError(
                self.source,
                f"<joint name='{cycle[0]}'> <mimic>",
                f"the couplings form a cycle ({chain}: each follows the next): no joint of it "
                "is set by a joint outside it; remove one <mimic> of the cycle",
            )
        by_name = {joint.name: joint for joint in joints}
        for coupling in couplings:
            label = f"<joint name='{coupling.follower}'> <mimic joint='{coupling.leader}'>"
            for role in (coupling.leader, coupling.follower):
                if role not in by_name or by_name[role].motion_component is None:
                    raise ModelError(
                        self.source, label, f"{role!r} is no revolute or prismatic joint"
                    )
            follower = by_name[coupling.follower]
            if not by_name[coupling.leader].driven and follower.driven:
                raise ModelError(
                    self.source,
                    f"<joint name='{coupling.follower}'>",
                    f"its leader {coupling.leader!r} is not driven, so it is not either: the "
                    "coupling holds it to its passive leader; drive the leader instead "
                    '(driven="true") or remove driven',
                )
        for coupling in couplings:
            leader_locked = coupling.leader in self.locked
            if coupling.follower in self.locked and not leader_locked:
                raise ModelError(
                    self.source,
                    f"<lock joint='{coupling.follower}'>",
                    f"it follows {coupling.leader!r} through its <mimic>, which is not locked: "
                    "the coupling moves it with its leader, so a lock cannot hold it; lock the "
                    f"leader {coupling.leader!r} too (both then rigid), or remove this lock",
                )
        placed = coupled(self.model, couplings, q)
        for coupling in couplings:
            follower = self.model.getJointId(coupling.follower)
            given = self.nominal_given.get(follower)
            value = placed[self.model.joints[follower].idx_q]
            if given is not None and not math.isclose(given, value, rel_tol=1e-9, abs_tol=1e-12):
                raise ModelError(
                    self.source,
                    f"<joint name='{coupling.follower}'>",
                    f"q={given:g} differs from its <mimic> of {coupling.leader!r}: "
                    f"{coupling.multiplier:g} x q + {coupling.offset:g} = {value:g}; "
                    "give the leader's q only",
                )
        return placed

    def _with_backlash(
        self,
        element: ET.Element,
        label: str,
        clearance: Clearance,
        driven: bool,
        motion: int | None,
    ) -> Clearance:
        """``clearance`` with the drive's lost motion ``backlash`` (rad for a revolute joint, a
        length in the block's unit for a prismatic one)."""
        if not driven:
            raise ModelError(
                self.source,
                label,
                "backlash is the lost motion of a drive, and this joint is not driven: add "
                'driven="true" (or remove backlash)',
            )
        if motion is None or clearance.kind not in BACKLASH_KINDS:
            raise ModelError(
                self.source,
                label,
                f"backlash needs a joint that turns or slides, not a {clearance.kind} one",
            )
        value = self._number(element, "backlash", True, length=motion == U)  # rad or m
        return replace(clearance, backlash=value)

    def _with_stiffness(
        self,
        element: ET.Element | None,
        label: str,
        clearance: Clearance,
        drive_component: int | None,
        loop: bool = False,
    ) -> Clearance:
        """``clearance`` with the joint's stiffness attributes (SI, whatever the block's unit:
        :mod:`.stiffness`) and the frame K is fixed in (``stiffness_frame``: ``housing`` or
        ``part``; a loop joint's is its housing's); ``drive_component``: what a driven joint's
        drive moves (None: not driven)."""
        frame = None if element is None else element.get("stiffness_frame")
        if frame is not None:
            if frame not in STIFFNESS_FRAMES:
                raise ModelError(
                    self.source,
                    label,
                    f"stiffness_frame={frame!r}: expected one of {', '.join(STIFFNESS_FRAMES)} "
                    "(the part K is fixed in: the housing, the parent's side, or the moving "
                    "part, the child's side)",
                )
            if loop and frame == "part":
                raise ModelError(
                    self.source,
                    label,
                    'stiffness_frame="part" on a loop joint: its clearance frame keeps the '
                    "housing's axes (frame_a's) about the spin, so its K is the housing's; "
                    'remove the attribute (or write "housing")',
                )
            clearance = replace(clearance, stiffness_frame=frame)
        if element is None or not any(element.get(a) is not None for a in STIFFNESS_ATTRIBUTES):
            return clearance
        values = {
            attribute: self._number(element, attribute)
            for attribute in STIFFNESS_ATTRIBUTES[:-1]
            if element.get(attribute) is not None
        }
        full = None
        text = element.get("stiffness")
        if text is not None:
            try:
                full = np.array([float(word) for word in text.split()], dtype=float)
            except ValueError:
                raise ModelError(
                    self.source, label, f"stiffness={text!r} is not 36 numbers (6x6, row by row)"
                ) from None
        try:
            matrix = stiffness_matrix(clearance.kind, values, full, drive_component)
        except ValueError as exc:
            raise ModelError(self.source, label, str(exc)) from None
        return replace(clearance, stiffness=as_entries(matrix))

    def loop_joints(self) -> tuple[LoopJoint, ...]:
        model = self.model
        joints = []
        names = set(model.names)
        for element in self.block.findall("loop_joint"):
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
                frames.append(model.getFrameId(frame))
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
            bodies = tuple(int(model.frames[f].parentJoint) for f in frames)
            clearance = self._with_stiffness(
                element, label, self._clearance(element, label, kind, bodies), None, loop=True
            )
            axis = self._vector(element, "axis", default=(1.0, 0.0, 0.0))
            joints.append(LoopJoint(name, frames[0], frames[1], clearance, rotation_x_to(axis)))
        return tuple(joints)

    def _clearance(
        self,
        element: ET.Element | None,
        label: str,
        default_kind: str,
        bodies: tuple[int, ...] = (),
    ) -> Clearance:
        if element is None or element.get("type") is None:
            if element is not None and any(element.get(a) for a in LENGTH_ATTRIBUTES):
                raise ModelError(self.source, label, f"clearances need a type, one of {KINDS}")
            return ideal(default_kind)
        kind = element.get("type")
        if kind not in KINDS:
            raise ModelError(self.source, label, f"unknown type {kind!r}; expected one of {KINDS}")
        values: dict[str, float] = {}
        for attribute, field_name in CLEARANCE_ATTRIBUTES.items():
            if element.get(attribute) is not None:
                values[field_name] = self._number(element, attribute, True, length=True)
        if element.get("diametral_clearance") is not None:
            if "radial" in values:
                raise ModelError(
                    self.source, label, "give radial_clearance or diametral_clearance, not both"
                )
            diametral = self._number(element, "diametral_clearance", True, length=True)
            values["radial"] = 0.5 * diametral
        if kind in ("cylindrical", "revolute", "prismatic") and values.get("length", 0.0) <= 0.0:
            raise ModelError(
                self.source,
                label,
                f"a {kind} joint needs length > 0 [{self.unit}] (the journal or block length)",
            )
        if kind not in ("free", "rigid") and "radial" not in values:
            raise ModelError(
                self.source,
                label,
                f"needs radial_clearance or diametral_clearance [{self.unit}] (0 for an ideal "
                "joint)",
            )
        try:
            clearance = Clearance(kind, **values)  # type: ignore[arg-type]  # lengths only
        except ValueError as exc:
            raise ModelError(self.source, label, str(exc)) from None
        self._record_clearance(element, label, values, bodies)
        return clearance

    def _record_clearance(
        self, element: ET.Element, label: str, values: dict[str, float], bodies: tuple[int, ...]
    ) -> None:
        """Keep the lengths of a clearance for the check against the geometry."""
        own_length = values.get("length", 0.0)
        for attribute, field_name in CLEARANCE_ATTRIBUTES.items():
            if field_name not in values or element.get(attribute) is None:
                continue
            kind: Kind = "size" if field_name in ("length", "width", "height") else "play"
            value = values[field_name]
            self.lengths.append(Length(label, attribute, value, kind, bodies, own_length))
        if element.get("diametral_clearance") is not None:
            radial = values["radial"]
            self.lengths.append(
                Length(
                    label,
                    "diametral_clearance",
                    radial,
                    "play",
                    bodies,
                    own_length,
                    written=2.0 * radial,
                )
            )

    # -- loads ----------------------------------------------------------------------------
    def loads(self) -> tuple[tuple[PointForce | Torque, ...], Gravity | None]:
        model = self.model
        links = {f.name for f in model.frames if f.type == pin.FrameType.BODY}
        loads: list[PointForce | Torque] = []
        for element in self.block:
            label = _label(element)
            if element.tag not in ("force", "torque"):
                continue
            _check_attributes(self.source, element, {"link", "point", "value"}, label)
            link = element.get("link")
            if link is None or link not in links:
                raise ModelError(
                    self.source,
                    label,
                    f"unknown link {link!r}; the links are: {', '.join(sorted(links))}",
                )
            value = self._vector(element, "value", allow_zero=True)
            try:
                if element.tag == "force":
                    point = self._vector(
                        element, "point", default=(0.0, 0.0, 0.0), allow_zero=True, length=True
                    )
                    if element.get("point") is not None:
                        body = int(model.frames[model.getFrameId(link)].parentJoint)
                        distance = math.hypot(
                            *point
                        )  # of a point near double's largest: no overflow
                        self.lengths.append(Length(label, "point", distance, "point", (body,)))
                    loads.append(PointForce(link, value, point))
                else:
                    loads.append(Torque(link, value))
            except LoadError as exc:
                raise ModelError(self.source, label, str(exc)) from None
        gravity = None
        for element in self.block.findall("gravity"):
            _check_attributes(self.source, element, {"value", "enabled"}, _label(element))
            if _boolean(self.source, element, "enabled", True):
                gravity = Gravity(
                    self._vector(element, "value", default=(0, 0, -9.81), allow_zero=True)
                )
        return tuple(loads), gravity


def _with_default(
    name: str, entry: ET.Element | None, default: ET.Element | None
) -> ET.Element | None:
    """The joint's entry completed by the default of its type: the entry's attributes win; a
    radial or diametral clearance replaces both of the default's; an entry naming another
    clearance ``type`` than the default's inherits none of its clearance values (only
    ``driven``)."""
    if default is None:
        return entry
    inherited = {k: v for k, v in default.attrib.items() if k != "joint_type"}
    default_label = _label(default)
    if entry is None:
        return labelled("joint", {"name": name, **inherited}, f"{default_label} for joint {name!r}")
    if entry.get("type") is not None and entry.get("type") != default.get("type"):
        inherited = {
            k: v for k, v in inherited.items() if k in ("driven", "backlash", "drive_stiffness")
        }
    if entry.get("radial_clearance") is not None or entry.get("diametral_clearance") is not None:
        inherited.pop("radial_clearance", None)
        inherited.pop("diametral_clearance", None)
    return labelled("joint", {**inherited, **entry.attrib}, f"{_label(entry)} with {default_label}")


def _label(element: ET.Element | None) -> str:
    if element is None:
        return "<?>"
    custom = label_of(element)
    if custom:
        return custom
    for key in ("name", "link", "joint_type"):
        value = element.get(key)
        if value:
            return f"<{element.tag} {key}='{value}'>"
    return f"<{element.tag}>"


def _check_attributes(source: str, element: ET.Element, allowed: set[str], label: str) -> None:
    unknown = sorted(set(element.attrib) - allowed)
    if unknown:
        raise ModelError(
            source, label, f"unknown attribute(s) {unknown}; allowed: {sorted(allowed)}"
        )


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


def _largest_limit(model: pin.Model, joint_id: int) -> float:
    """The largest of ``|lower|``, ``|upper|`` [m] of a 1-DOF joint's URDF limits (0 without a
    range: equal or infinite limits)."""
    joint = model.joints[joint_id]
    lower = float(model.lowerPositionLimit[joint.idx_q])
    upper = float(model.upperPositionLimit[joint.idx_q])
    if not (math.isfinite(lower) and math.isfinite(upper)) or upper <= lower:
        return 0.0
    return max(abs(lower), abs(upper))


def set_nominal(
    source: str, label: str, model: pin.Model, joint_id: int, q: np.ndarray, value: float
) -> None:
    """Set a 1-DOF joint's value [rad or m] in ``q`` (an unbounded revolute's cos and sin)."""
    joint = model.joints[joint_id]
    if joint.nq == 1:
        q[joint.idx_q] = value
    elif joint.nq == 2 and joint.nv == 1:
        q[joint.idx_q : joint.idx_q + 2] = (math.cos(value), math.sin(value))
    else:
        raise ModelError(source, label, "a nominal value q applies to 1-DOF joints only")


__all__ = [
    "BLOCK",
    "BlockContents",
    "ClearanceBlock",
    "JointTable",
    "empty_block",
    "joint_table",
    "read_block",
    "read_loop_joints",
    "set_nominal",
]


def drawn_configuration(model: pin.Model) -> np.ndarray:
    """The configuration (nq,) at which the model file draws its parts: MuJoCo's ``qpos0``
    (every joint at its ``ref``) that Pinocchio's MJCF reader records, else the neutral one
    (a URDF draws its parts at q = 0)."""
    if "qpos0" in model.referenceConfigurations:
        return np.array(model.referenceConfigurations["qpos0"], dtype=float)
    return np.asarray(pin.neutral(model), dtype=float)
