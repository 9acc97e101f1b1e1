"""The examples of the docs run, and their links lead somewhere.

- the package docstring's doctest (its printed values are the library's answer on the bundled
  model; their closed form is checked in the paper-case tests);
- every ```python block of README.md and docs/*.md, as written, from the repository's root: the
  blocks of one page run in order in one namespace, as a reader pastes them into one session. A
  block is left out only when an HTML comment just before it says so and why
  (``<!-- not run: REASON -->``). A block that needs example-robot-data (the UR5 as shipped) or
  the viewer's meshcat skips the rest of its page when that is not installed;
- every relative link of README.md, docs/*.md, benchmarks/README.md and models/README.md points at
  a file of the repository, and a link into a Markdown page's section at one of its headings.
"""

from __future__ import annotations

import doctest
import importlib.metadata
import re
from dataclasses import dataclass
from pathlib import Path

import pytest
from conftest import ROOT

import clearance_pin

PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
LINKED_PAGES = [*PAGES, ROOT / "benchmarks" / "README.md", ROOT / "models" / "README.md"]
FENCE = re.compile(r"^```(\w*)[^\n]*\n(.*?)^```[ \t]*$", re.MULTILINE | re.DOTALL)
NOT_RUN = re.compile(r"<!--\s*not run:\s*(?P<reason>\S.*?)\s*-->\s*$", re.DOTALL)
LINK = re.compile(r"!?\[[^\]]*\]\((?P<target>[^)\s]+)(?:\s+\"[^\"]*\")?\)")


@dataclass(frozen=True)
class Block:
    """One ```python block of a page: its code, its line, why it is not run (None: it runs)."""

    page: Path
    line: int
    code: str
    not_run: str | None


def python_blocks(page: Path) -> list[Block]:
    """The page's ```python blocks, in order."""
    text = page.read_text()
    blocks = []
    for fence in FENCE.finditer(text):
        if fence.group(1) != "python":
            continue
        before = text[: fence.start()].rstrip()
        marker = NOT_RUN.search(before[before.rfind("<!--") :]) if "<!--" in before else None
        if marker is not None and not before.endswith("-->"):
            marker = None
        line = text.count("\n", 0, fence.start()) + 2
        blocks.append(Block(page, line, fence.group(2), marker and marker.group("reason")))
    return blocks


def test_the_package_docstring_example_runs(monkeypatch):
    """``import clearance_pin``'s docstring example, from the repository's root."""
    monkeypatch.chdir(ROOT)
    failures, tried = doctest.testmod(clearance_pin, verbose=False, report=True)
    assert tried >= 4 and failures == 0


def needs(block: Block) -> str | None:
    """Why the block cannot run here (an optional package missing), or None."""
    if "example-robot-data" in block.code:
        try:
            importlib.metadata.distribution("example-robot-data")
        except importlib.metadata.PackageNotFoundError:
            return "example-robot-data is not installed (pip install example-robot-data)"
    if "show_equilibrium" in block.code or "show_trajectory" in block.code:
        try:
            importlib.metadata.distribution("meshcat")
        except importlib.metadata.PackageNotFoundError:
            return "meshcat is not installed (pip install clearance_pin[viz])"
    return None


@pytest.mark.parametrize(
    "page",
    [page for page in PAGES if python_blocks(page)],
    ids=lambda page: str(page.relative_to(ROOT)),
)
def test_every_python_example_runs(page, monkeypatch, capsys):
    """Every ```python block of the page runs as written, in order, from the repository's root
    (the README's tour prints the 6R arm's tool displacement and the UR5's accuracy map)."""
    monkeypatch.chdir(ROOT)
    namespace: dict = {"__name__": "docs_example"}
    for block in python_blocks(page):
        if block.not_run is not None:
            continue
        missing = needs(block)
        if missing is not None:
            pytest.skip(f"{page.name} line {block.line} and after: {missing}")
        name = f"{page.relative_to(ROOT)}, block at line {block.line}"
        exec(compile(block.code, name, "exec"), namespace)
    if page.name == "README.md":
        printed = capsys.readouterr().out
        assert "tool moves" in printed and "largest deviation" in printed


def test_examples_not_run_are_few_and_say_why():
    """Blocks left out are marked with their reason, and few (a user's own file path)."""
    blocks = [block for page in PAGES for block in python_blocks(page)]
    left_out = [block for block in blocks if block.not_run is not None]
    assert len(blocks) >= 8
    assert len(left_out) <= 3, [(b.page.name, b.line, b.not_run) for b in left_out]
    assert all(len(block.not_run) >= 10 for block in left_out)


def slug(heading: str) -> str:
    """GitHub's anchor of a Markdown heading: lower case, punctuation dropped, spaces to '-'."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def anchors(page: Path) -> set[str]:
    """The anchors of a Markdown page's headings (code blocks left out)."""
    text = FENCE.sub("", page.read_text())
    return {slug(m.group(1)) for m in re.finditer(r"^#{1,6}\s+(.+?)\s*#*$", text, re.MULTILINE)}


@pytest.mark.parametrize("page", LINKED_PAGES, ids=lambda page: str(page.relative_to(ROOT)))
def test_relative_links_point_at_files(page):
    """Every relative link (and image) of the page leads to a file of the repository; one into a
    section of a Markdown page, to one of its headings."""
    text = FENCE.sub("", page.read_text())
    broken = []
    for link in LINK.finditer(text):
        target = link.group("target")
        if re.match(r"^[a-z][a-z0-9+.-]*:", target):  # https:, mailto:
            continue
        path_part, _, fragment = target.partition("#")
        path = (page.parent / path_part).resolve() if path_part else page
        if not path.exists() or ROOT.resolve() not in (path, *path.parents):
            broken.append(target)
        elif fragment and path.suffix == ".md" and fragment not in anchors(path):
            broken.append(target)
    assert not broken, f"{page.relative_to(ROOT)}: links to nothing: {broken}"
