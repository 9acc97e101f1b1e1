"""A clearance file: the ``<clearance_pin>`` block on its own, beside an unmodified URDF or MJCF.

Two spellings of the same content (docs/model-format.md):

- XML, the block as the root element::

      <clearance_pin unit="mm">
        <default joint_type="revolute" type="revolute" radial_clearance="0.01"
                 axial_clearance="0.005" length="30" driven="true"/>
        <joint name="elbow_joint" radial_clearance="0.02" q="1.2"/>
        <force link="tool0" point="0 0 50" value="20 -30 -50"/>
      </clearance_pin>

- TOML, one table per element (``[defaults.<joint type>]``, ``[joints.<name>]``,
  ``[loop_joints.<name>]``, ``[dimensions.<name>]``, ``[gravity]``; ``[[forces]]`` and
  ``[[torques]]`` arrays), the block's ``unit`` a top-level key, vectors as arrays::

      unit = "mm"
      [defaults.revolute]
      type = "revolute"
      radial_clearance = 0.01
      [joints.elbow_joint]
      q = 1.2
      [[forces]]
      link = "tool0"
      point = [0, 0, 50]
      value = [20, -30, -50]

A Python dict (``clearance_pin.from_model(model, clearances={...})``) is a third spelling, in SI:
joint name -> dict of the ``<joint>`` attributes, plus ``"defaults"``: joint type -> dict of the
``<default>`` attributes. Loop joints come as their own dict (name -> attributes).

Each spelling becomes the same XML block (:class:`~clearance_pin.model.block.ClearanceBlock`),
read by :mod:`~clearance_pin.model.block` whatever it came from, its elements named in messages as
the file names them (``[joints.elbow_joint]``, ``clearances['elbow_joint']``). Numbers keep their
decimal text, so a length in mm converts to the float its value in metres would give.
"""

from __future__ import annotations

import numbers
import os
import tomllib
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, TypeAlias

import numpy as np

from ..errors import ArgumentError, ModelError
from .block import BLOCK, ClearanceBlock
from .xml_text import decode_xml, parse
from .xml_values import labelled

# clearances=... of clearance_pin.load and from_model: a clearance file, or a dict (SI)
ClearanceSource: TypeAlias = str | os.PathLike[str] | Mapping[str, Any] | None

STRING_KEYS = {"type", "frame_a", "frame_b", "link", "joint", "grade", "stiffness_frame"}
BOOLEAN_KEYS = {"driven", "enabled"}
VECTOR_KEYS = {"axis", "point", "value", "direction", "rotation_axis", "stiffness"}
NUMBER_KEYS = {
    "radial_stiffness",
    "axial_stiffness",
    "tilt_stiffness",
    "drive_stiffness",
    "radial_clearance",
    "diametral_clearance",
    "length",
    "axial_clearance",
    "play_z",
    "width",
    "height",
    "q",
    "tolerance",
    "half_tolerance",
}
# TOML table -> (element, the attribute its keys name, or None for an array of tables)
TOML_TABLES: dict[str, tuple[str, str | None]] = {
    "defaults": ("default", "joint_type"),
    "joints": ("joint", "name"),
    "loop_joints": ("loop_joint", "name"),
    "dimensions": ("dimension", "name"),
    "locks": ("lock", "joint"),
    "forces": ("force", None),
    "torques": ("torque", None),
    "gravity": ("gravity", None),
}
DICT_SOURCE = "<api>"  # the source of a dict in messages, as of anything built in Python


class _TomlFloat(str):
    """A TOML float kept as its text (tomllib's parse_float), told apart from a TOML string."""


def clearance_block(
    clearances: ClearanceSource, argument: str = "clearances", dict_source: str = DICT_SOURCE
) -> ClearanceBlock | None:
    """The block of ``clearances``: a clearance file (XML or TOML) or a dict, None for None.
    A dict's entries are named ``clearances['elbow']`` in messages, from ``dict_source``.

    Raises:
        ModelError: the file is unreadable or invalid, naming it, the element and the problem.
        ArgumentError: ``clearances`` is neither a path nor a dict.
    """
    if clearances is None:
        return None
    if isinstance(clearances, Mapping):
        return ClearanceBlock(from_dict(clearances, dict_source), dict_source, "dict")
    if not isinstance(clearances, (str, os.PathLike)):
        raise ArgumentError(
            argument, "a clearance file (.xml or .toml path) or a dict of clearances", clearances
        )
    return read_clearance_file(clearances)


def no_clearances(source: str, model_kind: str) -> ModelError:
    """The error of a model file read with no clearance information at all: no
    ``<clearance_pin>`` block in it and no clearance file beside it. Its every answer would be
    zero (ideal joints) -- a silent non-answer, so it is refused with how to add one.

    Args:
        source: the model file, named in the message.
        model_kind: ``"URDF"`` or ``"MJCF"`` (an MJCF file takes only a clearance file).
    """
    where = f"add a <{BLOCK}> block to the URDF, or " if model_kind == "URDF" else ""
    return ModelError(
        source,
        f"<{BLOCK}>",
        f"no clearances: the {model_kind} file has no <{BLOCK}> block and no clearance file is "
        f"given; {where}give a clearance file beside it (clearances='play.toml' in "
        "clearance_pin.load, --clearances FILE in the command line; docs/model-format.md)",
    )


def read_clearance_file(path: str | os.PathLike[str]) -> ClearanceBlock:
    """Read a clearance file: TOML when its name ends in ``.toml`` or its text does not start
    with ``<``, else XML."""
    path = Path(path)
    source = str(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise ModelError(source, "<file>", f"cannot be read: {exc.strerror or exc}") from None
    stripped = data.lstrip(b"\xef\xbb\xbf \t\r\n")
    if path.suffix.lower() == ".toml" or (
        path.suffix.lower() != ".xml" and not stripped.startswith(b"<")
    ):
        try:
            text = data.decode("utf-8-sig")
        except UnicodeDecodeError as exc:
            raise ModelError(source, "<toml>", f"a TOML file is UTF-8: {exc}") from None
        return ClearanceBlock(from_toml(text, source), source, "file")
    return ClearanceBlock(from_xml(decode_xml(data, source), source), source, "file")


def from_xml(text: str, source: str) -> ET.Element:
    """The block of an XML clearance file's text (its root element)."""
    root = parse(text, source)
    if root.tag == "robot":
        raise ModelError(
            source,
            "<robot>",
            f"this is a URDF, not a clearance file; a clearance file's root element is <{BLOCK}> "
            "(give the URDF as the model, or load it alone when the block is inside it)",
        )
    if root.tag != BLOCK:
        raise ModelError(
            source, f"<{root.tag}>", f"the root element of a clearance file must be <{BLOCK}>"
        )
    return root


def from_toml(text: str, source: str) -> ET.Element:
    """The block of a TOML clearance file's text."""
    try:
        document = tomllib.loads(text, parse_float=_TomlFloat)
    except tomllib.TOMLDecodeError as exc:
        raise ModelError(source, "<toml>", f"malformed TOML: {exc}") from None
    block = labelled(BLOCK, {}, "unit")  # the block's one attribute: the top-level unit key
    for key, value in document.items():
        if key == "unit":
            if not isinstance(value, str) or isinstance(value, _TomlFloat):
                raise ModelError(source, "unit", f'unit = {value!r} must be a string ("mm")')
            block.set("unit", value)
            continue
        if key not in TOML_TABLES:
            raise ModelError(
                source,
                f"[{key}]",
                f"unknown table; expected unit or one of {sorted(TOML_TABLES)}",
            )
        tag, named_by = TOML_TABLES[key]
        if named_by is not None:
            entries = _table(source, f"[{key}]", value)
            for name, attributes in entries.items():
                label = f"[{key}.{_toml_key(name)}]"
                block.append(_element(source, tag, label, attributes, named_by, name))
        elif key == "gravity":
            block.append(_element(source, tag, "[gravity]", _table(source, "[gravity]", value)))
        else:
            if not isinstance(value, list):
                raise ModelError(
                    source, f"[[{key}]]", f"{key} must be an array of tables ([[{key}]])"
                )
            for index, attributes in enumerate(value):
                label = f"[[{key}]] number {index + 1}"
                block.append(_element(source, tag, label, _table(source, label, attributes)))
    return block


def from_dict(clearances: Mapping[str, Any], source: str = DICT_SOURCE) -> ET.Element:
    """The block of a Python dict of clearances (SI): joint name -> attributes, plus
    ``"defaults"``: joint type -> attributes."""
    block = ET.Element(BLOCK)
    for name, attributes in clearances.items():
        if not isinstance(name, str):
            raise ModelError(source, f"clearances[{name!r}]", "a joint name must be a str")
        if name == "defaults":
            for joint_type, values in _table(source, "clearances['defaults']", attributes).items():
                label = f"clearances['defaults'][{joint_type!r}]"
                block.append(_element(source, "default", label, values, "joint_type", joint_type))
            continue
        if name == "unit":
            raise ModelError(
                source,
                "clearances['unit']",
                "a dict of clearances is in SI units (m, rad): give its lengths in metres "
                "(a clearance file can state its unit)",
            )
        label = f"clearances[{name!r}]"
        block.append(_element(source, "joint", label, attributes, "name", name))
    return block


def loop_joint_elements(
    loop_joints: Mapping[str, Any], source: str = DICT_SOURCE
) -> list[ET.Element]:
    """``<loop_joint>`` elements of a dict: loop joint name -> attributes (SI)."""
    if not isinstance(loop_joints, Mapping):
        raise ArgumentError(
            "loop_joints", "a dict: loop joint name -> dict of <loop_joint> attributes", loop_joints
        )
    elements = []
    for name, attributes in loop_joints.items():
        label = f"loop_joints[{name!r}]"
        if not isinstance(name, str):
            raise ModelError(source, label, "a loop joint name must be a str")
        elements.append(_element(source, "loop_joint", label, attributes, "name", name))
    return elements


def _toml_key(name: str) -> str:
    bare = name and all(c.isalnum() or c in "-_" for c in name) and name.isascii()
    return name if bare else f'"{name}"'


def _table(source: str, label: str, value: object) -> Mapping[str, Any]:
    if not isinstance(value, Mapping):
        raise ModelError(source, label, f"must be a table of keys and values, found {value!r}")
    return value


def _element(
    source: str,
    tag: str,
    label: str,
    attributes: object,
    named_by: str | None = None,
    name: str | None = None,
) -> ET.Element:
    """``<tag>`` with the attributes of a TOML table or a dict, each checked for its kind."""
    values = _table(source, label, attributes)
    text: dict[str, str] = {}
    if named_by is not None and name is not None:
        if named_by in values:
            raise ModelError(
                source, label, f"{named_by} is given by the key; remove {named_by} = ..."
            )
        text[named_by] = name
    for key, value in values.items():
        text[str(key)] = _text(source, label, str(key), value)
    return labelled(tag, text, label)


def _text(source: str, label: str, key: str, value: object) -> str:
    """An attribute's text: a number as its decimal text, a vector as 3 numbers, a boolean as
    true or false, a string as it is."""
    if key in BOOLEAN_KEYS:
        if isinstance(value, (bool, np.bool_)):
            return "true" if value else "false"
        raise ModelError(source, label, f"{key} = {value!r} must be true or false")
    if key in STRING_KEYS:
        if isinstance(value, str) and not isinstance(value, _TomlFloat):
            return value
        raise ModelError(source, label, f"{key} = {value!r} must be a string")
    if key in VECTOR_KEYS:
        if isinstance(value, np.ndarray):
            value = value.reshape(-1).tolist()
        if isinstance(value, Sequence) and not isinstance(value, str):
            return " ".join(_number_text(source, label, key, v) for v in value)
        expected = "36 numbers (6x6, row by row)" if key == "stiffness" else "3 numbers ([x, y, z])"
        raise ModelError(source, label, f"{key} = {value!r} must be {expected}")
    if key in NUMBER_KEYS:
        return _number_text(source, label, key, value)
    return str(value)  # an unknown attribute: the block's reader refuses it, naming the allowed


def _number_text(source: str, label: str, key: str, value: object) -> str:
    if isinstance(value, _TomlFloat):
        return str(value)
    if isinstance(value, numbers.Integral) and not isinstance(value, (bool, np.bool_)):
        return str(int(value))
    if isinstance(value, numbers.Real) and not isinstance(value, (bool, np.bool_)):
        return repr(float(value))  # the shortest text of the float: read back exactly
    raise ModelError(source, label, f"{key} = {value!r} must be a number")


__all__ = [
    "ClearanceSource",
    "clearance_block",
    "from_dict",
    "from_toml",
    "from_xml",
    "loop_joint_elements",
    "read_clearance_file",
]
