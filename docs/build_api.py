"""Build the API reference of clearance_pin with pdoc (a test extra): every module of the
package, from its docstrings, into a folder of HTML pages (default ``out/api``; open its
``index.html``). ``make docs`` runs it; tests/test_api_reference.py builds it in CI.

Usage: ``python docs/build_api.py [FOLDER]``.
"""

from __future__ import annotations

import pkgutil
import sys
import warnings
from pathlib import Path

import clearance_pin

SKIPPED = ("clearance_pin.__main__",)  # runs the command line when imported


def modules() -> list[str]:
    """Every module of the package, the package first (its ``__all__`` names the front door;
    pdoc would list no submodule of a package with ``__all__``, so they are named here)."""
    walked = pkgutil.walk_packages(clearance_pin.__path__, "clearance_pin.")
    return ["clearance_pin", *sorted(m.name for m in walked if m.name not in SKIPPED)]


def build(folder: Path) -> list[Path]:
    """Write the reference into ``folder``; returns the pages written."""
    import pdoc

    with warnings.catch_warnings():
        # clearance_pin.CheckReport is imported on first use (it loads coal): pdoc cannot follow
        # it from the package's __all__, and documents it in clearance_pin.check.report
        warnings.filterwarnings("ignore", message=".*CheckReport.*")
        pdoc.pdoc(*modules(), output_directory=folder)
    return sorted(folder.rglob("*.html"))


def main(arguments: list[str]) -> int:
    folder = Path(arguments[0]) if arguments else Path("out/api")
    pages = build(folder)
    print(f"{len(pages)} pages of API reference in {folder}; open {folder / 'index.html'}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
