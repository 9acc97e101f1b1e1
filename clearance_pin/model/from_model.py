"""Describe a mechanism on a ``pin.Model`` already in memory, without a model file.

A planner holds a ``pin.Model`` (``pin.buildModelFromUrdf``, ``example_robot_data.load(...)``,
built in code); :func:`describe_model` gives it clearances from a dict or a clearance file
(:mod:`~clearance_pin.model.clearance_file`), loop joints between two of its frames, loads,
gravity and a nominal configuration. Everything is SI (m, rad, N) unless a clearance file states
its unit. A value given both in the clearance file and as an argument (loads, gravity, loop
joints, nominal values) is refused, not merged.

The model's joint types are read from its Pinocchio joints (revolute, continuous, prismatic,
floating), its fixed joints from its ``FIXED_JOINT`` frames (a URDF's fixed joints), so a
clearance file written for the URDF reads the same beside the model built from it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import Any, TypeAlias

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike

from ..errors import ArgumentError, ModelError, NotFoundError
from . import plausibility
from .block import empty_block, joint_table, read_block, read_loop_joints, set_nominal
from .clearance_file import ClearanceSource, clearance_block, loop_joint_elements
from .couplings import coupled
from .description import MechanismDescription, combined_source, describe
from .loads import Gravity, PointForce, Torque
from .mimic_model import configuration_of, without_mimic
from .xml_values import label_of

# q=... of from_model: a configuration (nq,), or joint name -> value [rad or m]
Nominal: TypeAlias = ArrayLike | Mapping[str, float] | None
# gravity=...: on (True: -9.81 m/s^2 along z, or an acceleration [m/s^2]) or off
GravityArgument: TypeAlias = bool | Gravity | ArrayLike | None


def describe_model(
    model: pin.Model,
    clearances: ClearanceSource = None,
    loop_joints: Mapping[str, Mapping[str, Any]] | None = None,
    loads: Sequence[PointForce | Torque] | None = None,
    gravity: GravityArgument = None,
    q: Nominal = None,
    source: str = "<api>",
    name: str = "",
) -> MechanismDescription:
    """The description of a mechanism on ``model`` (a copy: later edits of it do not reach the
    mechanism).

    Args:
        model: the kinematic tree at its nominal configuration.
        clearances: a clearance file (.xml or .toml path), or a dict (SI): joint name -> dict of
            ``<joint>`` attributes (``{"type": "revolute", "radial_clearance": 1e-5, ...}``),
            plus ``"defaults"``: joint type -> dict of ``<default>`` attributes. Joints it does
            not name (nor a default) are ideal. None (and no ``loop_joints``) is refused:
            ``{}`` is a model of ideal joints on purpose.
        loop_joints: loop joint name -> dict of ``<loop_joint>`` attributes (``type``,
            ``frame_a``, ``frame_b``: two frames of the model; clearances [m]; ``axis`` in
            ``frame_a``).
        loads: the default loads of ``solve`` (forces [N] and torques [N m], world axes).
        gravity: True (-9.81 m/s^2 along the world z), an acceleration (3,) [m/s^2] or a
            :class:`~clearance_pin.model.loads.Gravity`; False or None: off (None: as the
            clearance file says).
        q: the nominal configuration: an array (nq,), or joint name -> value [rad or m] over
            Pinocchio's neutral configuration.
        source: how messages name the mechanism.
        name: the mechanism's name (default: the model's).

    Raises:
        ModelError: a bad clearance, loop joint or file (naming it, the entry and the problem);
            no clearances and no loop joints given.
        ArgumentError: an argument of the wrong kind, or given twice (file and argument).
        NotFoundError: a load on a link, or a nominal value of a joint, the model has not.
    """
    if not isinstance(model, pin.Model):
        raise ArgumentError("model", "a pinocchio.Model", model)
    if clearances is None and loop_joints is None:
        raise ModelError(
            source,
            "clearances",
            "no clearances given: every joint would be ideal and every answer zero; give "
            "clearances={joint: {...}} or a clearance file (clearances={} for a model of ideal "
            "joints on purpose)",
        )
    given = model
    # a copy, its mimic joints (mimic=True) as ordinary joints tied by couplings
    model, couplings = without_mimic(pin.Model(model), source)
    plausibility.check_magnitudes(source, model)  # before any length of it is measured
    if couplings and q is not None and not isinstance(q, Mapping):
        q = _unmimicked_q(given, model, q)
    beside = clearance_block(clearances, dict_source=source)
    block = beside.element if beside is not None else empty_block()
    block_source = beside.source if beside is not None else source
    kind = beside.kind if beside is not None else "model"
    table = replace(joint_table(model, "model"), couplings=couplings)
    contents = read_block(block_source, block, model, table, kind)
    from_file = beside.source if beside is not None and beside.source != source else None
    description = describe(model, contents, combined_source(source, from_file), name or model.name)
    changes: dict[str, Any] = {}
    if loop_joints is not None:
        _not_twice(block, "loop_joint", "loop_joints", block_source)
        loops = empty_block()
        loops.extend(loop_joint_elements(loop_joints, source))
        changes["loop_joints"] = read_loop_joints(source, loops, model)
    if loads is not None:
        _not_twice(block, ("force", "torque"), "loads", block_source)
        changes["loads"] = _loads(model, loads)
    if gravity is not None:
        _not_twice(block, "gravity", "gravity", block_source)
        changes["gravity"] = _gravity(gravity)
    if q is not None:
        if contents.nominal_given:
            raise ArgumentError("q", f"nominal values in {block_source} or as q=..., not both", q)
        nominal, changes["nominal_given"] = _nominal(model, q)
        changes["q_nominal"] = coupled(model, contents.couplings, nominal)  # followers set
    if not changes:
        return description
    return MechanismDescription(**{**description.arguments(), **changes})


def _unmimicked_q(given: pin.Model, model: pin.Model, q: Nominal) -> Nominal:
    """``q`` of the model as given (mimic joints without a value of their own) as one of its
    tree (:func:`.mimic_model.without_mimic`); any other ``q`` as it is (checked later)."""
    try:
        array = np.asarray(q, dtype=float)
    except (TypeError, ValueError):
        return q
    if array.shape != (given.nq,) or given.nq == model.nq:
        return q
    return configuration_of(given, model, array)


def _not_twice(block: Any, tags: str | tuple[str, ...], argument: str, block_source: str) -> None:
    tags = (tags,) if isinstance(tags, str) else tags
    found = [label_of(e) or f"<{e.tag}>" for e in block if e.tag in tags]
    if found:
        raise ArgumentError(
            argument,
            f"{argument} in the clearance file or as the argument, not both (they are not merged)",
            found,
            f"{block_source} gives {', '.join(found)}",
        )


def _loads(model: pin.Model, loads: object) -> tuple[PointForce | Torque, ...]:
    if not isinstance(loads, Sequence) or isinstance(loads, str):
        raise ArgumentError("loads", "a list of PointForce and Torque", loads)
    links = [f.name for f in model.frames if f.type == pin.FrameType.BODY]
    for index, load in enumerate(loads):
        if not isinstance(load, (PointForce, Torque)):
            raise ArgumentError(f"loads[{index}]", "a PointForce or a Torque", load)
        if load.link not in links:
            raise NotFoundError("link", load.link, tuple(links), where=f"loads[{index}]")
    return tuple(loads)


def _gravity(gravity: object) -> Gravity | None:
    if gravity is True:
        return Gravity()
    if gravity is False:
        return None
    if isinstance(gravity, Gravity):
        return gravity
    try:
        return Gravity(gravity)  # type: ignore[arg-type]  # any 3 numbers, checked there
    except Exception:
        raise ArgumentError(
            "gravity", "True, False, None, a Gravity or an acceleration (3,) [m/s^2]", gravity
        ) from None


def _nominal(model: pin.Model, q: object) -> tuple[np.ndarray, dict[int, float] | None]:
    if isinstance(q, Mapping):
        values = pin.neutral(model)
        given: dict[int, float] = {}
        names = tuple(model.names[1:])
        for joint, value in q.items():
            if joint not in names:
                raise NotFoundError("joint", joint, names, where="q")
            if not isinstance(value, (int, float, np.floating, np.integer)) or isinstance(
                value, bool
            ):
                raise ArgumentError(f"q[{joint!r}]", "a number [rad or m]", value)
            joint_id = int(model.getJointId(joint))
            set_nominal("<api>", f"q[{joint!r}]", model, joint_id, values, float(value))
            given[joint_id] = float(value)
        return values, given
    try:
        array = np.array(q, dtype=float)
    except (TypeError, ValueError):
        raise ArgumentError("q", f"{model.nq} numbers or a dict joint -> value", q) from None
    if array.shape != (model.nq,) or not np.all(np.isfinite(array)):
        raise ArgumentError("q", f"{model.nq} finite numbers (nq,)", q, f"shape {array.shape}")
    return array, None


__all__ = ["GravityArgument", "Nominal", "describe_model"]
