"""The identified values as a TOML clearance file (docs/model-format.md): the robot's own clearance
block (its clearance file, XML or TOML, or the block inside its URDF) with a ``backlash`` and a
``drive_stiffness`` in each identified drive's ``[joints.<name>]`` table.

Backlash is written in rad for a revolute drive and in the block's unit for a prismatic one;
drive stiffness always in SI (docs/model-format.md). Every number is written as the shortest
decimal of its float, so the file loads back to the same values.
"""

from __future__ import annotations

import math
import os
import re
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..errors import ArgumentError
from ..model.clearance_file import (
    BOOLEAN_KEYS,
    STRING_KEYS,
    TOML_TABLES,
    VECTOR_KEYS,
    clearance_block,
)

if TYPE_CHECKING:
    from ..model.mechanism_parts import MechanismParts as Mechanism

UNIT_FACTORS = {"m": 1.0, "mm": 1e-3, "um": 1e-6, "µm": 1e-6}  # [m per unit]
BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")

__all__ = ["block_tables", "toml_text", "write_clearances"]


def write_clearances(
    path: str | os.PathLike[str],
    mechanism: Mechanism,
    values: dict[str, tuple[float, float]],
    base: str | os.PathLike[str] | None = None,
) -> None:
    """Write ``base``'s block (None: the block inside the mechanism's model file) with each
    joint's ``values[name] = (backlash, drive stiffness)`` (SI; stiffness inf: left as is)."""
    element = _block(mechanism, base)
    unit, tables = block_tables(element)
    factor = UNIT_FACTORS.get(unit or "m", 1.0)
    joints = tables.setdefault("joints", {})
    for name, (backlash, stiffness) in values.items():
        entry = joints.setdefault(name, {})
        joint = mechanism.joints[name]
        prismatic = getattr(joint, "motion_component", None) == 0
        entry["driven"] = True
        entry["backlash"] = backlash / factor if prismatic else backlash
        if math.isfinite(stiffness):
            entry["drive_stiffness"] = stiffness
    header = (
        f"# {mechanism.name}: drives identified by clearance-pin identify (backlash and "
        "drive_stiffness of each [joints] table)\n"
    )
    Path(path).write_text(header + toml_text(unit, tables), encoding="utf-8")


def _block(mechanism: Mechanism, base: str | os.PathLike[str] | None) -> ET.Element:
    if base is not None:
        block = clearance_block(base, "base")
        assert block is not None
        return block.element
    try:
        root = ET.fromstring(Path(mechanism.source).read_bytes())
    except (OSError, ET.ParseError):
        root = None
    inner = None if root is None else root.find("clearance_pin")
    if inner is None:
        raise ArgumentError(
            "base",
            "the clearance file the robot was loaded with (its model file has no "
            "<clearance_pin> block)",
            base,
        )
    return inner


def block_tables(element: ET.Element) -> tuple[str | None, dict[str, Any]]:
    """(the block's unit, its TOML tables): table -> name -> attributes, or a list of
    attribute dicts for ``forces`` and ``torques``, a dict for ``gravity``; values typed."""
    by_tag = {tag: (table, key) for table, (tag, key) in TOML_TABLES.items()}
    tables: dict[str, Any] = {}
    for child in element:
        if not isinstance(child.tag, str) or child.tag not in by_tag:
            continue
        table, named_by = by_tag[child.tag]
        attributes = {k: _typed(k, v) for k, v in child.attrib.items() if k != named_by}
        if named_by is not None:
            name = child.get(named_by, "")
            tables.setdefault(table, {}).setdefault(name, {}).update(attributes)
        elif table == "gravity":
            tables["gravity"] = attributes
        else:
            tables.setdefault(table, []).append(attributes)
    return element.get("unit"), tables


def _typed(key: str, text: str) -> Any:
    if key in BOOLEAN_KEYS:
        return text.strip().lower() == "true"
    if key in STRING_KEYS:
        return text
    if key in VECTOR_KEYS:
        return [float(v) for v in text.replace(",", " ").split()]
    return float(text)


def toml_text(unit: str | None, tables: dict[str, Any]) -> str:
    """The TOML text of a block's tables (:func:`block_tables`)."""
    lines = [f"unit = {_value(unit)}", ""] if unit else []
    for table in TOML_TABLES:
        if table not in tables:
            continue
        content = tables[table]
        if isinstance(content, list):
            for attributes in content:
                lines.append(f"[[{table}]]")
                lines += [f"{_key(k)} = {_value(v)}" for k, v in attributes.items()]
                lines.append("")
        elif table == "gravity":
            lines.append("[gravity]")
            lines += [f"{_key(k)} = {_value(v)}" for k, v in content.items()]
            lines.append("")
        else:
            for name, attributes in content.items():
                lines.append(f"[{table}.{_key(name)}]")
                lines += [f"{_key(k)} = {_value(v)}" for k, v in attributes.items()]
                lines.append("")
    return "\n".join(lines)


def _key(name: str) -> str:
    if BARE_KEY.match(name):
        return name
    return '"' + name.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return '"' + value.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(value, list):
        return "[" + ", ".join(_value(v) for v in value) + "]"
    number = float(value)
    if not math.isfinite(number):
        raise ArgumentError("value", "a finite number", number)
    return repr(number)
