"""The examples of the docs run: the package docstring's doctest (its printed values are the
library's answer on the bundled model; their closed form is checked in the paper-case tests)."""

from __future__ import annotations

import doctest

from conftest import ROOT

import clearance_pin


def test_the_package_docstring_example_runs(monkeypatch):
    """``import clearance_pin``'s docstring example, from the repository's root."""
    monkeypatch.chdir(ROOT)
    failures, tried = doctest.testmod(clearance_pin, verbose=False, report=True)
    assert tried >= 4 and failures == 0


def readme_examples() -> list[str]:
    """The README's Python blocks marked to run as a test."""
    text = (ROOT / "README.md").read_text()
    marker = "<!-- runs as a test"
    blocks = []
    for part in text.split(marker)[1:]:
        start = part.index("```python\n") + len("```python\n")
        blocks.append(part[start : part.index("```\n", start)])
    return blocks


def test_the_readme_examples_run(monkeypatch, capsys):
    """Every README example marked to run runs as written, from the repository's root (the quick
    start's tool displacement and envelope, the library tour)."""
    monkeypatch.chdir(ROOT)
    blocks = readme_examples()
    assert len(blocks) >= 2
    for block in blocks:
        exec(compile(block, "README.md", "exec"), {"__name__": "readme"})
    assert "tool moves" in capsys.readouterr().out
