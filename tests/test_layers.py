"""The import graph runs one way (issue 22): ``Mechanism`` is the front door only.

Nothing under ``equilibrium/``, ``kinematics/`` or ``check/`` imports ``mechanism.py`` (not even
for its types: they read a mechanism through ``model.mechanism_parts.MechanismParts``), and the
model layer imports nothing above it. Read from the source's import statements (every one,
those under ``TYPE_CHECKING`` and inside functions included), so a cycle hidden by a late
import fails here too.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "clearance_pin"
CORE = ("equilibrium", "kinematics", "check")
ABOVE_MODEL = ("equilibrium", "kinematics", "check", "mechanism", "loading", "envelope",
               "tolerance", "accuracy", "plot", "cli", "commands")  # fmt: skip


def _imported(path: Path) -> set[str]:
    """Every module ``path`` imports, as a dotted name inside the package ('' for outside)."""
    package = path.relative_to(PACKAGE.parent).with_suffix("").parts[:-1]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - node.level + 1]
                target = ".".join((*base, node.module)) if node.module else ".".join(base)
                names = [f"{target}.{alias.name}" for alias in node.names]
                found.update([target, *names])
            elif node.module and node.module.startswith("clearance_pin"):
                found.add(node.module)
                found.update(f"{node.module}.{alias.name}" for alias in node.names)
        elif isinstance(node, ast.Import):
            found.update(a.name for a in node.names if a.name.startswith("clearance_pin"))
    return found


@pytest.mark.parametrize("layer", CORE)
def test_the_core_does_not_import_the_front_door(layer):
    for path in sorted((PACKAGE / layer).rglob("*.py")):
        imported = _imported(path)
        bad = sorted(name for name in imported if name.startswith("clearance_pin.mechanism"))
        assert not bad, f"{path.relative_to(PACKAGE)} imports {bad}"


def test_the_model_layer_imports_nothing_above_it():
    for path in sorted((PACKAGE / "model").rglob("*.py")):
        above = sorted(
            name
            for name in _imported(path)
            if name.split(".")[1:2] and name.split(".")[1] in ABOVE_MODEL
        )
        assert not above, f"{path.relative_to(PACKAGE)} imports {above}"
