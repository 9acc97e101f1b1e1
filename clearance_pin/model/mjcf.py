"""Read a mechanism from an MJCF file (root ``<mujoco>``) beside a clearance file.

The kinematic tree is built by Pinocchio's MJCF reader (``pin.buildModelFromMJCF``, Pinocchio
3.x and later) from the file as clearance_pin rewrites it (:mod:`~.mjcf_placements`: every
orientation a unit quat, frames composed, includes spliced in); a root body fixed to the world
is placed in memory, and every named body, hinge or slide joint and site is checked against
clearance_pin's own reading of the file (MuJoCo's rules, :mod:`~.mjcf_orientation`).

The clearances, loop joints and loads come from a clearance file, as beside a URDF
(:mod:`~clearance_pin.model.clearance_file`). In a clearance file an MJCF ``hinge`` joint is a
``revolute`` joint, a ``slide`` joint ``prismatic`` and a ``free`` joint ``floating``; loads name
MJCF bodies; loop joints name any frames of the model (bodies or sites).

Not read, and refused with a :class:`~clearance_pin.errors.ModelError` rather than dropped:

- ``<equality>`` constraints other than a ``<joint>`` coupling (closed loops welded or connected
  by MuJoCo): cut the loop in the clearance file instead, as a ``<loop_joint>`` between two frames
  (sites), which also gives the cut joint its play. An ``<equality><joint joint1 joint2
  polycoef>`` is read as a coupling (:mod:`~.couplings`): joint1 = polycoef[0] + polycoef[1] x
  joint2, its higher coefficients zero;
- a ``<clearance_pin>`` element inside the MJCF file (MuJoCo refuses unknown elements): write it
  as a clearance file;
- a body with several joints (Pinocchio makes them one composite joint) and ``ball`` joints (a
  ball joint with play is a ``free`` joint with a ``spherical`` clearance);
- a second body under ``<worldbody>`` (Pinocchio reads the first one and its subtree only) and
  a body without a name (Pinocchio drops it with its subtree);
- procedural elements (``<replicate>``, ``<attach>``, ``<composite>``, ``<flexcomp>``), and
  placements Pinocchio's reader does not read as MuJoCo does (the check above).
"""

from __future__ import annotations

import os
import tempfile
import xml.etree.ElementTree as ET
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pinocchio as pin

from ..errors import ModelError
from . import plausibility
from .block import (
    BLOCK,
    ClearanceBlock,
    drawn_configuration,
    joint_table,
    read_block,
)
from .clearance_file import no_clearances
from .couplings import Coupling
from .description import MechanismDescription, combined_source, describe
from .length_check import ModelScaleError, warn_model_scale
from .mjcf_orientation import matrix_quat
from .mjcf_placements import FilePlacements, read_placements
from .reference_sizes import Geometry, mjcf_shapes

SUPPORTED = (
    "use hinge, slide or free joints, one joint per body (a ball joint with play: a free joint "
    "with a spherical clearance)"
)


# the deepest nesting of bodies read: the peak memory of a load grows faster than the square of
# the depth of a chain, in Pinocchio's MJCF reader (measured, whole load: 0.16 GB at 100 bodies,
# 0.62 GB at 200, 1.8 GB at 300, 13.8 GB at 600; Pinocchio's reader alone 0.95 GB at 300)
MAX_BODY_DEPTH = 200


def read_mjcf(
    text: str,
    root: ET.Element,
    source: str,
    path: Path | None,
    beside: ClearanceBlock | None,
) -> MechanismDescription:
    """The description of an MJCF model with the clearances ``beside`` it.

    Pinocchio reads the file rewritten as :func:`~.mjcf_placements.read_placements` says
    (orientations as unit quats, frames composed, includes spliced in); a root body fixed to the
    world or free is then placed in memory, and every named body, hinge or slide joint and site is
    checked against the file's own reading (:func:`check_placements`).

    Args:
        text: the MJCF text (decoded); what is read is its tree ``root``.
        root: its ``<mujoco>`` element.
        source: the file, named in messages.
        path: the file, when it is one: its ``<include>`` files and meshes are found relative to
            it.
        beside: the clearance block (None is refused: no clearance information).
    """
    _refuse_unread(root, source)
    _check_depth(root, source)
    placements = read_placements(root, source, path.parent if path is not None else None)
    _check_depth(placements.tree, source)  # with its <include> files spliced in
    rewritten = _pinocchio_text(placements.tree, path)
    model = _build(rewritten, source)
    plausibility.check_magnitudes(source, model)  # before any length of it is measured
    _check_tree(placements.tree, model, source)
    if placements.root is not None:
        _compose_root(model, placements.tree, pin.SE3(*placements.root))
    _add_missing_sites(model, placements)
    check_placements(model, placements, source)
    if model.njoints <= 1:
        raise ModelError(
            source, "<worldbody>", "no joints: the MJCF file has no hinge, slide or free joint"
        )
    if beside is None:  # after the file's own checks: they come first
        raise no_clearances(source, "MJCF")
    block = beside
    table = replace(
        joint_table(model, "MJCF", SUPPORTED), couplings=mjcf_couplings(root, source, model)
    )
    shapes = mjcf_shapes(placements.tree)
    try:
        contents = read_block(block.source, block.element, model, table, block.kind, shapes)
    except ModelScaleError as exc:  # the MJCF file's own lengths: the file is named
        raise ModelError(source, "<mujoco>", exc.problem) from None
    # read_mjcf, _read, read_file or read_text, load or loads, the caller
    with np.errstate(over="ignore", invalid="ignore"):  # a huge origin: judged elsewhere
        sizes = Geometry(model, contents.q_nominal, shapes)
    warn_model_scale(source, "<mujoco>", sizes, 5)
    geometry = MjcfGeometry(rewritten, source)
    return describe(
        model,
        contents,
        combined_source(source, beside.source if beside else None),
        root.get("model", ""),
        geometry,
    )


def mjcf_couplings(
    root: ET.Element, source: str, model: pin.Model | None = None
) -> tuple[Coupling, ...]:
    """The ``<equality><joint joint1="F" joint2="L" polycoef="c0 c1 0 0 0"/>`` couplings:
    F - F0 = c0 + c1 (L - L0) about MuJoCo's reference configuration qpos0 (each joint at its
    ``ref``; checked against MuJoCo's own constraint residual, tests/test_couplings.py); default
    polycoef 0 1 0 0 0; an inactive one (``active="false"``) is left out."""
    couplings = []
    for equality in root.iter("equality"):
        for constraint in equality.findall("joint"):
            if constraint.get("active", "true") == "false":
                continue
            element = f"<equality> <joint joint1='{constraint.get('joint1')}'>"
            follower, leader = constraint.get("joint1"), constraint.get("joint2")
            if not follower:
                raise ModelError(source, element, "names no joint1")
            text = constraint.get("polycoef", "0 1 0 0 0")
            try:
                coefficients = [float(v) for v in text.split()]
            except ValueError:
                raise ModelError(source, element, f"polycoef={text!r} is not numbers") from None
            coefficients += [0.0] * (5 - len(coefficients))
            if len(coefficients) != 5 or not np.all(np.isfinite(coefficients)):
                raise ModelError(source, element, f"polycoef={text!r}: 5 finite numbers")
            if any(coefficients[2:]):
                raise ModelError(
                    source,
                    element,
                    f"polycoef={text!r}: a coupling beyond linear (its coefficients after the "
                    "second are not zero) is not modelled",
                )
            if not leader:
                # MuJoCo holds joint1 at qpos0 + polycoef[0] (its ref, in radians for a hinge)
                ref = _qpos0(model, follower)
                at = f"{ref + coefficients[0]:.12g}" if ref is not None else "ref + polycoef[0]"
                raise ModelError(
                    source,
                    element,
                    "fixes joint1 at its ref + polycoef[0] (MuJoCo's qpos0 + a0) without a "
                    f'joint2: write <lock joint="{follower}" q="{at}"/> in the clearance file '
                    "and remove the constraint",
                )
            couplings.append(
                Coupling(follower, leader, coefficients[1], coefficients[0], from_drawn=True)
            )
    return tuple(couplings)


def _qpos0(model: pin.Model | None, joint: str) -> float | None:
    """A one-coordinate joint's value in MuJoCo's reference configuration qpos0 (its ``ref``
    [rad or m]), None when the model or the joint is not known."""
    if model is None or not model.existJointName(joint):
        return None
    index = model.joints[model.getJointId(joint)]
    if index.nq != 1 or "qpos0" not in model.referenceConfigurations:
        return None
    return float(model.referenceConfigurations["qpos0"][index.idx_q])


def _check_depth(root: ET.Element, source: str) -> None:
    """Refuse bodies nested deeper than :data:`MAX_BODY_DEPTH` before Pinocchio reads them."""
    deepest, stack = 0, [(root, 0)]
    while stack:
        element, depth = stack.pop()
        if element.tag == "body":
            depth += 1
            if depth > MAX_BODY_DEPTH:
                deepest = depth
                break
        stack.extend((child, depth) for child in element)
    if deepest:
        raise ModelError(
            source,
            f"<body name='{element.get('name', '')}'>",
            f"bodies are nested more than {MAX_BODY_DEPTH} deep; at most {MAX_BODY_DEPTH} are "
            "read: Pinocchio's MJCF reader's memory grows faster than the square of the depth "
            "(a load took 1.8 GB at 300, 13.8 GB at 600)",
        )


def _refuse_unread(root: ET.Element, source: str) -> None:
    for equality in root.iter("equality"):
        for constraint in equality:
            if constraint.tag == "joint":
                continue  # a coupling (mjcf_couplings)
            name = constraint.get("name")
            element = f"<equality> <{constraint.tag}" + (f" name='{name}'>" if name else ">")
            raise ModelError(
                source,
                element,
                "MJCF equality constraints (closed loops) are not read: cut the loop in the "
                "clearance file as a <loop_joint> between two frames (bodies or sites) of the "
                "two parts, and remove the constraint",
            )
    if root.find(f".//{BLOCK}") is not None:
        raise ModelError(
            source,
            f"<{BLOCK}>",
            "an MJCF file cannot hold the block (MuJoCo refuses unknown elements): write it as "
            "a clearance file beside the MJCF file (clearances=...)",
        )


ROUND_OFF = 1e-9  # of the model's size (at least 1 m) [m], and of a rotation [rad]


def _pinocchio_text(tree: ET.Element, path: Path | None) -> str:
    """The rewritten tree as text, its meshes found where the original file's are (MuJoCo: an
    absolute meshdir, else the file's directory joined with meshdir or assetdir)."""
    if path is not None:
        compilers = tree.findall("compiler")
        if not compilers:
            compilers = [ET.Element("compiler")]
            tree.insert(0, compilers[0])
        meshdir = next((c.get("meshdir") for c in compilers if c.get("meshdir")), None)
        assetdir = next((c.get("assetdir") for c in compilers if c.get("assetdir")), None)
        directory = (path.parent / (meshdir or assetdir or "")).resolve()
        for compiler in compilers:
            compiler.attrib.pop("meshdir", None)
        compilers[0].set("meshdir", str(directory) + os.sep)
    return ET.tostring(tree, encoding="unicode")


def _check_tree(tree: ET.Element, model: pin.Model, source: str) -> None:
    """Refuse bodies Pinocchio's MJCF reader did not read (Pinocchio 3.x-4.1 reads the first
    body under ``<worldbody>`` with its subtree only)."""
    worldbodies = tree.findall("worldbody")
    bodies = [b for w in worldbodies for b in w.iter("body")]
    frames = {f.name for f in model.frames if f.type == pin.FrameType.BODY}
    missing = [b.get("name") or "(unnamed)" for b in bodies if b.get("name") not in frames]
    if None in (b.get("name") for b in bodies):
        raise ModelError(
            source,
            "<body>",
            "a body without a name: Pinocchio's MJCF reader drops it with its subtree. Name "
            "every body",
        )
    if missing or len(bodies) != len(frames):
        roots = [b.get("name") or "(unnamed)" for w in worldbodies for b in w.findall("body")]
        raise ModelError(
            source,
            f"<body name='{missing[0]}'>" if missing else "<worldbody>",
            f"Pinocchio's MJCF reader did not read {len(bodies) - len(frames)} of the "
            f"{len(bodies)} bodies ({', '.join(missing)}): it reads the first body under "
            f"<worldbody> and its subtree only (root bodies here: {', '.join(roots)}). Put "
            "every body in one tree, under a single root body",
        )


def _compose_root(model: pin.Model, tree: ET.Element, placement: pin.SE3) -> None:
    """Place the root body fixed to the world (built at the origin) and all it carries:
    ``M_frame <- M_root M_frame`` for the frames of the world joint hanging from the root body,
    ``M_joint <- M_root M_joint`` for the joints whose parent is the world."""
    root = next(b for w in tree.findall("worldbody") for b in w.findall("body"))
    root_id = model.getFrameId(root.get("name", ""), pin.FrameType.BODY)
    for index in range(1, len(model.frames)):
        frame = model.frames[index]
        ancestor = index
        while ancestor not in (0, root_id):
            ancestor = model.frames[ancestor].parentFrame
        if frame.parentJoint == 0 and ancestor == root_id:
            frame.placement = placement * frame.placement
            model.frames[index] = frame
    for joint in range(1, model.njoints):
        if model.parents[joint] == 0:
            model.jointPlacements[joint] = placement * model.jointPlacements[joint]


def _add_missing_sites(model: pin.Model, placements: FilePlacements) -> None:
    """The named sites Pinocchio's reader left out (those of a body fixed to the world, of the
    world), as operational frames on their body's frame."""
    for name, (_, body) in placements.sites.items():
        if _site_frame(model, name) is not None:
            continue
        rotation, translation = placements.site_local[name]
        parent = 0 if body is None else model.getFrameId(body, pin.FrameType.BODY)
        local = pin.SE3(rotation, translation)
        if parent != 0:
            local = model.frames[parent].placement * local
        joint = model.frames[parent].parentJoint
        model.addFrame(pin.Frame(name, joint, parent, local, pin.FrameType.OP_FRAME))


def _site_frame(model: pin.Model, name: str) -> int | None:
    """The operational frame Pinocchio made of the site ``name`` (a body may share its name)."""
    found = [i for i, f in enumerate(model.frames) if f.name == name]
    sites = [i for i in found if model.frames[i].type == pin.FrameType.OP_FRAME]
    return sites[0] if sites else None


def _shown(rotation: np.ndarray, translation: np.ndarray) -> str:
    return (
        f"{np.round(translation, 9).tolist()} m, quat {np.round(matrix_quat(rotation), 9).tolist()}"
    )


def check_placements(model: pin.Model, placements: FilePlacements, source: str) -> None:
    """Refuse a body, joint or site that ``model`` places elsewhere than the file does.

    At MuJoCo's ``qpos0`` (each hinge or slide joint at its ``ref``, itself checked): a body's
    or site's origin within ``ROUND_OFF`` of the model's size (at least 1 m) and its axes within
    ``ROUND_OFF``; a hinge's world axis ``w`` and the velocity ``v`` of the world origin on it
    (``v = a x w`` for a point ``a`` of the axis), a slide's axis ``v``, from the joint's column
    of Pinocchio's world Jacobian.
    """
    data = model.createData()
    q = drawn_configuration(model)
    pin.forwardKinematics(model, data, q)
    pin.updateFramePlacements(model, data)
    pin.computeJointJacobians(model, data, q)
    points = [p.translation for p in placements.bodies.values()]
    size = max([1.0, *(float(np.linalg.norm(p)) for p in points)])

    def refuse(element: str, placed: str, given: str, expected: str) -> None:
        raise ModelError(
            source,
            element,
            f"Pinocchio's MJCF reader places it at {placed}, the file ({given}) at {expected}, "
            "as MuJoCo reads it: refused rather than solved on a misplaced model",
        )

    for name, joint in placements.joints.items():
        if joint.kind in ("hinge", "slide") and model.existJointName(name):
            index = model.getJointId(name)
            value = float(q[model.joints[index].idx_q])
            if model.joints[index].nq == 1 and abs(value - joint.ref) > ROUND_OFF:
                unit = "rad" if joint.kind == "hinge" else "m"
                raise ModelError(
                    source,
                    f"<joint name='{name}'>",
                    f"Pinocchio's MJCF reader reads its ref (the value at which the file draws "
                    f"the bodies) as {value:.12g} {unit}, the file gives {joint.ref:.12g} {unit}: "
                    "refused, as the joint values of the clearance file would not mean MuJoCo's",
                )
    framed = [
        (n, p, f"<body name='{n}'>", pin.FrameType.BODY) for n, p in placements.bodies.items()
    ]
    framed += [(n, p, f"<site name='{n}'>", None) for n, (p, _) in placements.sites.items()]
    for name, expected, element, kind in framed:
        index = model.getFrameId(name, kind) if kind is not None else _site_frame(model, name)
        if index is None or index >= len(model.frames):
            continue  # a body Pinocchio did not read is refused by _check_tree
        placed = data.oMf[index]
        if (
            np.linalg.norm(placed.translation - expected.translation) > ROUND_OFF * size
            or np.abs(placed.rotation - expected.rotation).max() > ROUND_OFF
        ):
            refuse(
                element,
                _shown(placed.rotation, placed.translation),
                expected.given,
                _shown(expected.rotation, expected.translation),
            )
    for name, joint in placements.joints.items():
        if joint.kind not in ("hinge", "slide") or not model.existJointName(name):
            continue
        index = model.getJointId(name)
        if model.joints[index].nv != 1:
            continue  # several joints in one body: refused by the joint table
        jacobian = pin.getJointJacobian(model, data, index, pin.ReferenceFrame.WORLD)
        column = np.reshape(jacobian, (6, model.nv))[:, model.joints[index].idx_v]  # nv = 1: (6,)
        velocity, turn = column[:3], column[3:]
        if joint.kind == "hinge":
            wrong = (
                np.abs(turn - joint.axis).max() > ROUND_OFF
                or np.linalg.norm(velocity - np.cross(joint.anchor, joint.axis)) > ROUND_OFF * size
            )
            through = np.round(data.oMi[index].translation, 9).tolist()
            placed = f"axis {np.round(turn, 9).tolist()} through {through} m"
        else:
            wrong = (
                np.abs(velocity - joint.axis).max() > ROUND_OFF or np.abs(turn).max() > ROUND_OFF
            )
            placed = f"axis {np.round(velocity, 9).tolist()}"
        if wrong:
            expected_text = f"axis {np.round(joint.axis, 9).tolist()}"
            if joint.kind == "hinge":
                expected_text += f" through {np.round(joint.anchor, 9).tolist()} m"
            refuse(f"<joint name='{name}'>", placed, joint.given, expected_text)


def _build(text: str, source: str) -> pin.Model:
    try:
        with tempfile.TemporaryDirectory() as directory:
            file = Path(directory) / "model.xml"
            file.write_text(text, encoding="utf-8")
            return pin.buildModelFromMJCF(str(file))
    except (RuntimeError, ValueError, IndexError) as exc:
        raise ModelError(source, "<mujoco>", f"Pinocchio cannot build the MJCF: {exc}") from None


@dataclass(frozen=True)
class MjcfGeometry:
    """The MJCF model's collision geometry, built when a check first needs it.

    Attributes:
        text: the MJCF text as Pinocchio reads it (rewritten by
            :func:`~.mjcf_placements.read_placements`, meshdir absolute when there is a file).
        source: the file, for messages.
    """

    text: str
    source: str

    def __call__(self, model: pin.Model) -> pin.GeometryModel:
        """The ``pin.GeometryModel`` of the MJCF collision geometry of ``model``."""
        try:
            with tempfile.TemporaryDirectory() as directory:
                file = Path(directory) / "model.xml"
                file.write_text(self.text, encoding="utf-8")
                return pin.buildGeomFromMJCF(model, str(file), pin.GeometryType.COLLISION)
        except (RuntimeError, ValueError, IndexError) as exc:
            raise ModelError(self.source, "<geom>", f"cannot be loaded: {exc}") from None


__all__ = ["MjcfGeometry", "check_placements", "read_mjcf"]
