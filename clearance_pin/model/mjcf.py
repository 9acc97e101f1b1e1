"""Read a mechanism from an MJCF file (root ``<mujoco>``) beside a clearance file.

The kinematic tree is built by Pinocchio's MJCF reader (``pin.buildModelFromMJCF``, Pinocchio
3.x and later); the clearances, loop joints and loads come from a clearance file, as beside a URDF
(:mod:`~clearance_pin.model.clearance_file`). In a clearance file an MJCF ``hinge`` joint is a
``revolute`` joint, a ``slide`` joint ``prismatic`` and a ``free`` joint ``floating``; loads name
MJCF bodies; loop joints name any frames of the model (bodies or sites).

Not read, and refused with a :class:`~clearance_pin.errors.ModelError` rather than dropped:

- ``<equality>`` constraints (closed loops welded or connected by MuJoCo): cut the loop in the
  clearance file instead, as a ``<loop_joint>`` between two frames (sites), which also gives the
  cut joint its play;
- a ``<clearance_pin>`` element inside the MJCF file (MuJoCo refuses unknown elements): write it
  as a clearance file;
- a body with several joints (Pinocchio makes them one composite joint) and ``ball`` joints (a
  ball joint with play is a ``free`` joint with a ``spherical`` clearance).
"""

from __future__ import annotations

import tempfile
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from ..errors import ModelError
from .block import BLOCK, ClearanceBlock, empty_block, joint_table, read_block
from .description import MechanismDescription, combined_source, describe

SUPPORTED = (
    "use hinge, slide or free joints, one joint per body (a ball joint with play: a free joint "
    "with a spherical clearance)"
)


def read_mjcf(
    text: str,
    root: ET.Element,
    source: str,
    path: Path | None,
    beside: ClearanceBlock | None,
) -> MechanismDescription:
    """The description of an MJCF model with the clearances ``beside`` it.

    Args:
        text: the MJCF text (decoded).
        root: its ``<mujoco>`` element.
        source: the file, named in messages.
        path: the file, when it is one: Pinocchio reads it there, so its ``<include>`` files and
            meshes are found relative to it (the text alone is read from a temporary file).
        beside: the clearance block (None: every joint ideal).
    """
    _refuse_unread(root, source)
    model = _build(text, source, path)
    _check_tree(root, model, source)
    block = beside or ClearanceBlock(empty_block(), source)
    contents = read_block(block.source, block.element, model, joint_table(model, "MJCF", SUPPORTED))
    geometry = MjcfGeometry(text, source, str(path) if path is not None else None)
    return describe(
        model,
        contents,
        combined_source(source, beside.source if beside else None),
        root.get("model", ""),
        geometry,
    )


def _refuse_unread(root: ET.Element, source: str) -> None:
    for equality in root.iter("equality"):
        for constraint in equality:
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


ORIENTATIONS = ("quat", "euler", "axisangle", "xyaxes", "zaxis")
ROUND_OFF = 1e-12  # of the model's size: the body positions compared


def _check_tree(root: ET.Element, model: pin.Model, source: str) -> None:
    """Refuse what Pinocchio's MJCF reader is known to drop or misplace, silently:

    - bodies it did not read (Pinocchio 3.x-4.1 reads the first body under ``<worldbody>`` with
      its subtree only);
    - the placement of a body fixed to the world (a root body without a joint: its ``pos`` and
      orientation are ignored, Pinocchio issue #2782);
    - and, where the file places its bodies by ``pos`` alone (no orientation, no include), every
      body's position recomputed here from the file against Pinocchio's.
    """
    worldbodies = root.findall("worldbody")
    bodies = [b for w in worldbodies for b in w.iter("body")]
    frames = {f.name for f in model.frames if f.type == pin.FrameType.BODY}
    missing = [b.get("name") or "(unnamed)" for b in bodies if b.get("name") not in frames]
    if missing or len(bodies) != len(frames):
        roots = [b.get("name") or "(unnamed)" for w in worldbodies for b in w.findall("body")]
        raise ModelError(
            source,
            f"<body name='{missing[0]}'>" if missing else "<worldbody>",
            f"Pinocchio's MJCF reader did not read {len(bodies) - len(frames)} of the "
            f"{len(bodies)} bodies ({', '.join(missing)}): it reads the first body under "
            f"<worldbody> and its subtree only (root bodies here: {', '.join(roots)}). Put "
            "every body in one tree, under a single root body at the world origin",
        )
    for world in worldbodies:
        for body in world.findall("body"):
            jointed = body.find("joint") is not None or body.find("freejoint") is not None
            placed = any(body.get(a) is not None for a in ORIENTATIONS) or _pos(body).any()
            if not jointed and placed:
                raise ModelError(
                    source,
                    f"<body name='{body.get('name')}'>",
                    "a body fixed to the world with a pos or an orientation: Pinocchio's MJCF "
                    "reader ignores its placement (Pinocchio issue #2782), which would move "
                    "the whole mechanism. Place it at the world origin and move its children "
                    "instead",
                )
    if root.find(".//include") is None and not any(
        b.get(a) is not None for b in bodies for a in ORIENTATIONS
    ):
        _check_positions(worldbodies, model, source)


def _pos(element: ET.Element) -> np.ndarray:
    try:
        return np.array([float(v) for v in element.get("pos", "0 0 0").split()], dtype=float)
    except ValueError:
        return np.zeros(3)


def _check_positions(worldbodies: list[ET.Element], model: pin.Model, source: str) -> None:
    """Every body's world position: the sum of the ``pos`` of its chain (bodies without
    orientation), against Pinocchio's at the neutral configuration."""
    data = model.createData()
    pin.framesForwardKinematics(model, data, pin.neutral(model))
    expected: dict[str, np.ndarray] = {}

    def walk(body: ET.Element, origin: np.ndarray) -> None:
        position = origin + _pos(body)
        name = body.get("name")
        if name:
            expected[name] = position
        for child in body.findall("body"):
            walk(child, position)

    for world in worldbodies:
        for body in world.findall("body"):
            walk(body, np.zeros(3))
    size = max((float(np.linalg.norm(p)) for p in expected.values()), default=0.0) or 1.0
    for name, position in expected.items():
        placed = data.oMf[model.getFrameId(name, pin.FrameType.BODY)].translation
        if np.linalg.norm(placed - position) > ROUND_OFF * size:
            raise ModelError(
                source,
                f"<body name='{name}'>",
                f"Pinocchio's MJCF reader placed the body at {np.round(placed, 12).tolist()} m, "
                f"the file at {np.round(position, 12).tolist()} m (the sum of the pos of its "
                "chain): a placement this reader does not read as MuJoCo does",
            )


def _build(text: str, source: str, path: Path | None) -> pin.Model:
    try:
        if path is not None:
            return pin.buildModelFromMJCF(str(path))
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
        text: the MJCF text.
        source: the file, for messages.
        path: the file Pinocchio reads (None: the text is written to a temporary file).
    """

    text: str
    source: str
    path: str | None

    def __call__(self, model: pin.Model) -> pin.GeometryModel:
        """The ``pin.GeometryModel`` of the MJCF collision geometry of ``model``."""
        try:
            if self.path is not None:
                return pin.buildGeomFromMJCF(model, self.path, pin.GeometryType.COLLISION)
            with tempfile.TemporaryDirectory() as directory:
                file = Path(directory) / "model.xml"
                file.write_text(self.text, encoding="utf-8")
                return pin.buildGeomFromMJCF(model, str(file), pin.GeometryType.COLLISION)
        except (RuntimeError, ValueError, IndexError) as exc:
            raise ModelError(self.source, "<geom>", f"cannot be loaded: {exc}") from None


__all__ = ["MjcfGeometry", "read_mjcf"]
