"""The API reference (issue 24: built in CI): docs/build_api.py renders every module of the
package with pdoc, and every name of the front door has a docstring that says what it is."""

from __future__ import annotations

import importlib.util
import inspect
from pathlib import Path

import pytest

import clearance_pin

ROOT = Path(__file__).resolve().parent.parent


def _builder():
    spec = importlib.util.spec_from_file_location("build_api", ROOT / "docs" / "build_api.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_api_reference_builds_a_page_per_module(tmp_path):
    pytest.importorskip("pdoc")
    builder = _builder()
    names = builder.modules()
    assert len(names) == len(set(names))  # each module once
    pages, problems = builder.build(tmp_path)
    assert problems == []  # pdoc's warnings are defects of the docs (docs/build_api.py KNOWN)
    written = {p.relative_to(tmp_path).with_suffix("").as_posix().replace("/", ".") for p in pages}
    assert set(names) <= written  # every module has its page
    front = (tmp_path / "clearance_pin.html").read_text()
    for name in ("Mechanism", "Equilibrium", "PointForce", "Method", "load"):
        assert f'id="{name}"' in front
    # Google-style sections rendered as sections, not run into one paragraph
    assert '<h6 id="arguments">Arguments:</h6>' in front and '<h6 id="returns">' in front


def test_every_public_name_has_a_docstring():
    missing = [
        name for name in clearance_pin.__all__ if not inspect.getdoc(getattr(clearance_pin, name))
    ]
    assert missing == []
