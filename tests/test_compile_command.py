"""``clearance-pin compile`` (clearance_pin/compile_command.py): the compiled kernel made ready at
set-up, one line, and the documented exit statuses: 0 ready (or numba not installed: the NumPy
way), 5 numba unable to compile or cache the kernel (one line naming the problem and the fix).

The first test loads the kernel in this process, as the suite's compiled tests do (from numba's
cache after ``make``; a minute's compilation on an empty cache); the unwritable caches run in a
subprocess, where numba's state is fresh, and fail before any compilation."""

from __future__ import annotations

import os
import re
import stat
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from conftest import one_line, run_command

from clearance_pin.commands import KERNEL_UNAVAILABLE, OK
from clearance_pin.equilibrium import fast_path

ROOT = Path(__file__).resolve().parents[1]


def test_compile_prints_the_seconds_and_numbas_cache(capsys, monkeypatch):
    """One line: the load's seconds (those load_kernel() recorded, printed to 0.1 s) and the
    folder of numba's cache, which holds the kernel's index (numba names it
    kernel.solve_cases-LINE.pyXY.nbi)."""
    monkeypatch.setenv("CLEARANCE_PIN_COMPILED", "1")
    status, out, err = run_command(capsys, "compile")
    assert status == OK and err == ""
    lines = out.strip().splitlines()
    assert len(lines) == 1, out
    found = re.fullmatch(
        r"compiled kernel ready in (\S+) s \((.+) numba's cache in (.+)\)", lines[0]
    )
    assert found is not None, lines[0]
    seconds, where = float(found.group(1)), Path(found.group(3))
    assert abs(seconds - fast_path.kernel_load_time()) <= 0.05 + 1e-9
    assert found.group(2) in ("loaded from", "compiled and saved to")
    assert where.is_dir() and list(where.glob("kernel.solve_cases-*.nbi")), where


def test_without_numba_the_solves_go_the_numpy_way(capsys, monkeypatch):
    """numba is the optional extra ``fast``: without it (hidden from the import system here) the
    command says the solves go the NumPy way and exits 0, numba not imported."""
    monkeypatch.setenv("CLEARANCE_PIN_COMPILED", "1")
    monkeypatch.setitem(sys.modules, "numba", None)
    status, out, err = run_command(capsys, "compile")
    assert status == OK and err == ""
    assert len(out.strip().splitlines()) == 1 and "NumPy way" in out, out


# numba caches where it can write, in order: NUMBA_CACHE_DIR, the __pycache__ beside kernel.py,
# the user's cache folder; the kernel is uncachable only when none is writable. "mode 0o500" and
# "under a file": numba told to use NUMBA_CACHE_DIR alone (NUMBA_CACHE_LOCATOR_CLASSES), a folder
# of mode 0o500 (root writes through any mode: skipped) or a path under a regular file (no one can
# make that folder); "probe": numba's writability probe of every folder
# (_CacheLocator.ensure_cache_path, which makes the folder and a file in it) fails as an
# unwritable folder's does, with numba's own order of folders.
UNWRITABLE_PROBE = """
import numba.core.caching as caching

def unwritable(self):
    raise PermissionError(13, "Permission denied", self.get_cache_path())

caching._CacheLocator.ensure_cache_path = unwritable
"""


@pytest.mark.parametrize("how", ["mode 0o500", "under a file", "probe"])
def test_an_unwritable_cache_exits_5_with_one_line(tmp_path, how):
    cache = tmp_path / "cache"
    cache.mkdir()
    environment = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "PYTHONPATH": str(ROOT)}
    environment.pop("CLEARANCE_PIN_COMPILED", None)
    setup = UNWRITABLE_PROBE
    if how != "probe":
        import numba.core.config

        if not hasattr(numba.core.config, "CACHE_LOCATOR_CLASSES"):
            pytest.skip("this numba has no NUMBA_CACHE_LOCATOR_CLASSES")
        environment["NUMBA_CACHE_LOCATOR_CLASSES"] = "UserProvidedCacheLocator"
        setup = ""
    if how == "mode 0o500":
        if os.geteuid() == 0:
            pytest.skip("root writes into a folder of mode 0o500")
        cache.chmod(stat.S_IRUSR | stat.S_IXUSR)
    elif how == "under a file":
        (cache / "file").write_text("")
        environment["NUMBA_CACHE_DIR"] = str(cache / "file" / "numba")
    script = setup + textwrap.dedent(
        """
        from clearance_pin.cli import main

        raise SystemExit(main(["compile"]))
        """
    )
    try:
        done = subprocess.run(
            [sys.executable, "-c", script],
            check=False,
            capture_output=True,
            text=True,
            env=environment,
            timeout=600,
        )
    finally:
        cache.chmod(stat.S_IRWXU)
    assert done.returncode == KERNEL_UNAVAILABLE, done.stderr
    assert done.stdout == ""
    line = one_line(done.stderr)
    assert "Traceback" not in done.stderr
    assert "cannot be compiled or cached" in line and "set NUMBA_CACHE_DIR to a writable" in line
    assert [path.name for path in cache.iterdir()] in ([], ["file"])  # nothing written
