"""The compiled kernel's one-time costs (issue 12), each measured in a new process.

- ``fresh_s``: loading the kernel with an empty numba cache (what a fresh install pays once:
  numba's import and the compilation of every entry point, ``fast_path.load_kernel``);
- ``warm_s``: the same with that cache filled (every later process that loads it);
- ``import_s``, ``first_solve_s``: ``import clearance_pin``, then loading models/four_bar.urdf and
  its first solve (the NumPy path: a first solve never loads the kernel), and whether numba was
  imported by then (``numba_loaded``: it must not be).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

LOAD = "from clearance_pin.equilibrium.fast_path import load_kernel; print(load_kernel())"
FIRST_SOLVE = """
import json, sys, time
started = time.perf_counter()
import clearance_pin
imported = time.perf_counter()
mechanism = clearance_pin.load({model!r})
loaded = time.perf_counter()
mechanism.solve()
solved = time.perf_counter()
print(json.dumps({{"import_s": imported - started, "model_load_s": loaded - imported,
                  "first_solve_s": solved - loaded, "numba_loaded": "numba" in sys.modules}}))
"""


def _run(code: str, environment: dict) -> str:
    done = subprocess.run(
        [sys.executable, "-c", code], env=environment, capture_output=True, text=True, check=True
    )
    return done.stdout.strip().splitlines()[-1]


def kernel_costs() -> dict:
    """The figures of the module docstring [s]."""
    environment = {k: v for k, v in os.environ.items() if k != "CLEARANCE_PIN_COMPILED"}
    with tempfile.TemporaryDirectory() as cache:
        environment["NUMBA_CACHE_DIR"] = cache
        fresh = float(_run(LOAD, environment))
        warm = float(_run(LOAD, environment))
        first = json.loads(
            _run(FIRST_SOLVE.format(model=str(ROOT / "models/four_bar.urdf")), environment)
        )
    return {"fresh_s": fresh, "warm_s": warm, **first}


if __name__ == "__main__":
    print(json.dumps(kernel_costs(), indent=1))
