"""IPOPT through CasADi, one solve at a time in a process.

IPOPT (with MUMPS, its linear solver) and a CasADi ``nlpsol`` function keep state that two threads
must not share: two threads solving at once crash the process (a segmentation fault in libipopt,
reproduced with ``solve_many(..., backend="ipopt", executor=ThreadPoolExecutor(4))``). Every IPOPT
solver is built and called under one process-wide lock, its statistics read before the lock is
released. IPOPT is the fallback path, so holding the lock costs threads little; processes do not
share it.
"""

from __future__ import annotations

import threading
from typing import Any

#: held while an IPOPT solver is built or runs (re-entrant: a build may happen inside a solve)
IPOPT_LOCK = threading.RLock()


def build(*arguments: Any) -> Any:
    """``casadi.nlpsol(*arguments)`` under :data:`IPOPT_LOCK`."""
    import casadi as ca

    with IPOPT_LOCK:
        return ca.nlpsol(*arguments)


def run(solver: Any, **arguments: Any) -> tuple[dict[str, Any], dict[str, Any]]:
    """``(solver(**arguments), solver.stats())`` under :data:`IPOPT_LOCK`: the answer and the
    statistics of this call, not of another thread's."""
    with IPOPT_LOCK:
        result = solver(**arguments)
        return result, dict(solver.stats())
