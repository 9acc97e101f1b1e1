"""``clearance-pin compile``: the compiled kernel ready before the first solve.

The kernel (:mod:`clearance_pin.equilibrium.kernel`, numba) is compiled the first time a machine
uses it, about 20 s on a 2-core machine, and read from numba's on-disk cache afterwards, about
a second. Run at set-up (``make`` does), this sub-command pays that once, so that no
solve later waits for it; run again, it only loads the cache. It prints one line: the seconds
taken and where numba's cache is.

Numba writes every cache file atomically (``numba.core.caching.IndexDataCacheFile``: each file
is written to ``NAME.tmp.UUID`` and renamed onto its name with ``os.replace``, ``_open_for_write``;
the index, written before the compiled code, names a file that a load finding missing treats as
a cache miss): a compilation interrupted or run by two processes at once leaves whole files, at
worst an entry compiled again, never a partial file that a later load reads. The index also holds
``kernel.py``'s modification time and size and numba's version: a changed kernel or numba is
compiled again, never loaded stale.

Exit status (:mod:`clearance_pin.commands`): 0 the kernel ready, also when numba is not
installed (a dependency, but a platform may lack its wheels: the solves go the NumPy way, with
the same answers) or ``CLEARANCE_PIN_COMPILED=0`` switches it off; 5 numba is installed but
cannot compile or cache the kernel (most often a read-only install: one line naming the problem, and the fix,
``NUMBA_CACHE_DIR`` set to a writable folder).
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import re
import sys
import warnings
from typing import Any

from .commands import KERNEL_UNAVAILABLE, OK
from .errors import KernelUnavailableWarning


def register(subparsers: Any) -> argparse.ArgumentParser:
    """Add the ``compile`` sub-command to ``subparsers`` (``add_subparsers()``'s result)."""
    parser: argparse.ArgumentParser = subparsers.add_parser(
        "compile",
        help="compile the numba kernel of re-solves now (or load it from numba's cache), so that "
        "no solve waits for it",
    )
    parser.set_defaults(run=run)
    return parser


def run(args: argparse.Namespace) -> int:
    """Load the kernel (:func:`~clearance_pin.equilibrium.fast_path.load_kernel`) and print one
    line; the exit status (module docstring)."""
    from .equilibrium import fast_path

    if os.environ.get("CLEARANCE_PIN_COMPILED") == "0":
        print(
            "the compiled kernel is switched off (CLEARANCE_PIN_COMPILED=0): the solves go the "
            "NumPy way, nothing compiled"
        )
        return OK
    if importlib.util.find_spec("numba") is None:
        print(
            "numba is not installed (a dependency: pip install numba): the solves go the NumPy way, "
            "with the same answers; nothing to compile"
        )
        return OK
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", KernelUnavailableWarning)
        try:
            seconds = fast_path.load_kernel()
        except ImportError as exc:  # numba present but broken: the solves do not use it either
            print(
                f"numba cannot be imported ({' '.join(str(exc).split())}): the solves go the "
                "NumPy way, with the same answers; nothing compiled"
            )
            return OK
    where = fast_path.kernel_cache_dir()
    if where is None:
        print(f"clearance-pin: compile: {_unavailable(caught)}", file=sys.stderr)
        return KERNEL_UNAVAILABLE
    how = "compiled and saved to" if fast_path.kernel_compiled_now() else "loaded from"
    print(f"compiled kernel ready in {seconds:.1f} s ({how} numba's cache in {where})")
    return OK


def _unavailable(caught: list[warnings.WarningMessage]) -> str:
    """The line of a kernel that did not load: numba's reason, from load_kernel's
    :class:`~clearance_pin.errors.KernelUnavailableWarning`, and the fix."""
    reason = "numba could not load it in this process"
    for warning in caught:
        if warning.category is KernelUnavailableWarning:
            text = " ".join(str(warning.message).split())
            found = re.search(r"unavailable \((.*)\); the solves", text)
            reason = found.group(1) if found else text
            break
    return (
        f"the compiled kernel cannot be compiled or cached ({reason}); set NUMBA_CACHE_DIR to a "
        "writable folder and run 'clearance-pin compile' again (meanwhile the solves go the "
        "NumPy way, with the same answers)"
    )
