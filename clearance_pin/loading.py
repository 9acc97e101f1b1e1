"""Build a mechanism: from a model file (:func:`load`), its text (:func:`loads`), or a
``pin.Model`` in memory (:func:`from_model`).

The model layer reads the file (a URDF with its ``<clearance_pin>`` block, or a URDF or MJCF
file beside a clearance file: :mod:`clearance_pin.model.model_file`, format in
docs/model-format.md) into a description; the mechanism is built from it here, so the model
layer depends on nothing above it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import pinocchio as pin

from .mechanism import Mechanism
from .model.clearance_file import ClearanceSource
from .model.from_model import GravityArgument, Nominal, describe_model
from .model.loads import PointForce, Torque
from .model.model_file import PackageDirs, read_file, read_text


def load(
    path: str | Path, package_dirs: PackageDirs = None, clearances: ClearanceSource = None
) -> Mechanism:
    """Read a mechanism from a model file.

    Args:
        path: a URDF (``.urdf``, with its ``<clearance_pin>`` block or beside ``clearances``),
            or an MJCF file (root ``<mujoco>``, beside ``clearances``), in the encoding its XML
            declaration names (UTF-8 without one).
        package_dirs: directories in which collision meshes are looked for: a ``package://pkg/f``
            mesh is ``<dir>/pkg/f``, a relative one ``<dir>/f``; then the file's own directory
            and the entries of the environment variable ROS_PACKAGE_PATH. Meshes are read only
            when a check needs them (``Equilibrium.check``), never to solve.
        clearances: a clearance file beside the model (``play.xml``, the block as its own XML
            file, or ``play.toml``; lengths in the unit it states, metres by default), or a dict
            as in :func:`from_model`. A URDF with a block of its own and ``clearances`` is
            refused (ModelError), not merged; a file with neither is refused too (every answer
            would be zero): ``clearances={}`` reads its joints as ideal on purpose.

    Returns:
        :class:`~clearance_pin.mechanism.Mechanism`, loops closed.

    Raises:
        ModelError: a file is unreadable or invalid (naming the file, the element and the
            problem), has no clearance information, or the loops cannot be closed.
    """
    return Mechanism(**read_file(path, package_dirs, clearances).arguments())


def loads(
    text: str | bytes,
    source: str = "<string>",
    mesh_dir: Path | None = None,
    package_dirs: PackageDirs = None,
    clearances: ClearanceSource = None,
) -> Mechanism:
    """Read a mechanism from the text of a model file (see :func:`load`).

    Args:
        text: the file's text (str), or its bytes, decoded as its XML declaration says.
        source: the name used in messages.
        mesh_dir: directory of relative mesh paths (the file's directory).
        package_dirs: as in :func:`load`.
        clearances: as in :func:`load`.
    """
    return Mechanism(**read_text(text, source, mesh_dir, package_dirs, clearances).arguments())


def from_model(
    model: pin.Model,
    clearances: ClearanceSource = None,
    loop_joints: Mapping[str, Mapping[str, Any]] | None = None,
    loads: Sequence[PointForce | Torque] | None = None,
    gravity: GravityArgument = None,
    q: Nominal = None,
    source: str = "<api>",
    name: str = "",
) -> Mechanism:
    """A mechanism on a ``pin.Model`` already in memory (``pin.buildModelFromUrdf(...)``,
    ``example_robot_data.load("ur5").model``), without a model file.

    Args:
        model: the kinematic tree at its nominal configuration (copied).
        clearances: a dict (SI): joint name -> dict of ``<joint>`` attributes, e.g.
            ``{"elbow_joint": {"type": "revolute", "radial_clearance": 1e-5,
            "axial_clearance": 5e-6, "length": 0.03, "driven": True}}``, plus ``"defaults"``:
            joint type -> dict of ``<default>`` attributes (``{"revolute": {...}}``); or a
            clearance file, as in :func:`load`. Neither clearances nor ``loop_joints`` is
            refused (ModelError); ``{}`` is a model of ideal joints on purpose.
        loop_joints: loop joint name -> dict of ``<loop_joint>`` attributes: ``type``,
            ``frame_a`` and ``frame_b`` (two frames of the model), clearances [m], ``axis``.
        loads: default loads of ``solve``: forces [N] and torques [N m], world axes.
        gravity: True (-9.81 m/s^2 along z), an acceleration [m/s^2] or a Gravity; None: off,
            or as the clearance file says.
        q: nominal configuration: an array (nq,) or joint name -> value [rad or m].
        source: how messages name the mechanism.
        name: its name (default: the model's).

    Raises:
        ModelError: a bad clearance or loop joint (naming the entry and the problem).
        ArgumentError: an argument of the wrong kind, or given both in the clearance file and
            as an argument (not merged).
        NotFoundError: a load's link or a nominal value's joint that the model has not.
    """
    description = describe_model(model, clearances, loop_joints, loads, gravity, q, source, name)
    return Mechanism(**description.arguments())


__all__ = ["from_model", "load", "loads"]
