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


#: what pdoc cannot do, and why each is harmless (every other warning is a defect of the docs)
KNOWN = (
    # clearance_pin.CheckReport is imported on first use (it loads coal): pdoc cannot follow it
    # from the package's __all__, and documents it in clearance_pin.check.report
    ".*CheckReport.*",
    # a NamedTuple's generated constructor has globals of its own: its field annotations (named
    # in the module) do not resolve there; the class's own fields are documented
    r"Error parsing type annotation ForwardRef\('\w+'\) for clearance_pin\.\S+\.__init__\.",
)


def modules() -> list[str]:
    """Every module of the package once, the package first (its ``__all__`` names the front
    door; pdoc would list no submodule of a package with ``__all__``, so they are named here,
    but for those pdoc already adds with their package: a module a package's ``__all__``
    names)."""
    import pdoc.extract

    walked = [m.name for m in pkgutil.walk_packages(clearance_pin.__path__, "clearance_pin.")]
    named = ["clearance_pin", *sorted(m for m in walked if m not in SKIPPED)]
    added = {
        module
        for package in named
        if hasattr(sys.modules.get(package) or _imported(package), "__path__")
        for module in pdoc.extract.walk_specs([package])[1:]
    }
    return [m for m in named if m not in added]


def _imported(name: str) -> object:
    import importlib

    return importlib.import_module(name)


def build(folder: Path) -> tuple[list[Path], list[str]]:
    """Write the reference into ``folder`` (Google-style docstring sections rendered); returns
    the pages written and pdoc's warnings but the :data:`KNOWN` ones."""
    import pdoc
    import pdoc.render

    pdoc.render.configure(docformat="google")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for pattern in KNOWN:
            warnings.filterwarnings("ignore", message=pattern)
        names = modules()
        for name in names:  # a lazily imported name of an __all__ resolves once touched
            module = _imported(name)
            for attribute in getattr(module, "__all__", ()):
                getattr(module, attribute, None)
        pdoc.pdoc(*names, output_directory=folder)
    return sorted(folder.rglob("*.html")), sorted({str(w.message) for w in caught})


def main(arguments: list[str]) -> int:
    folder = Path(arguments[0]) if arguments else Path("out/api")
    pages, problems = build(folder)
    for problem in problems:
        print(f"warning: {problem}", file=sys.stderr)
    print(f"{len(pages)} pages of API reference in {folder}; open {folder / 'index.html'}")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
