"""The one plan of a small-displacement solve: which engines, in which order.

A pure function of the problem's structure, the caller's options and what is installed; never of
counters, clocks, threads or the cache's history beyond "this mechanism has a verified answer"
(the compiled kernel starts from one). The same call takes the same engines in every process.

Engines (:class:`~.method.Method`):

1. ``CLOSED_FORM`` when the backend is ``"auto"`` and the mechanism is a tree whose joints are
   independent blocks (:func:`.blocks.block_structure`);
2. otherwise ``COMPILED`` when numba's kernel is installed (:func:`.fast_path.kernel_installed`),
   the mechanism has a verified answer to start from, the reduced problem has at most
   :data:`~.cone_solver.WARM_MAX_SIZE` unknowns (a dense Newton step, O(size^3)) and no more
   contacts than unknowns. With more contacts than unknowns (a prismatic block's corner slabs:
   statically indeterminate contact sets, whose constraint gradients are dependent) the active-set
   walk rarely pays: on a SCARA with a Z carriage (20 unknowns, 25 contacts) the kernel took 5.2 ms
   per re-solve on average against Clarabel's 1.2 ms (45 of 300 loads it could not verify, 12 to
   68 ms each), on an R-P-R arm with a block (15, 22) 3.1 ms against 1.1 ms; on the paper's
   shafts, the four-bar and the slider-crank (contacts <= unknowns) it takes 0.16 to 0.19 of
   Clarabel's time;
   Neither when a joint has stiffness (the potential is quadratic: :mod:`.elastic_newton`);
3. then the cold backend: Clarabel when installed (``backend="auto"`` or ``"clarabel"``), else or
   on request IPOPT; Clarabel's unverified answer goes to IPOPT.

Each engine's answer is judged by the same residuals (:mod:`.residuals`); the next engine runs only
when it is not verified.
"""

from __future__ import annotations

from .cone_solver import WARM_MAX_SIZE
from .method import Method


def plan_linear(
    *,
    independent_blocks: bool,
    size: int,
    contacts: int,
    solved_before: bool,
    backend: str,
    kernel: bool,
    clarabel: bool,
    elastic: bool = False,
) -> tuple[Method, ...]:
    """The engines to try, in order (module docstring).

    Args:
        independent_blocks: the mechanism is a tree of independent blocks (closed forms apply).
        size: unknowns of the reduced problem.
        contacts: contact sets (balls, discs, slabs) of the reduced problem.
        solved_before: the mechanism has a verified answer of this structure (a start).
        backend: the caller's ``"auto"``, ``"clarabel"`` or ``"ipopt"``.
        kernel: the compiled kernel is installed in this process.
        clarabel: Clarabel is importable.
        elastic: a joint has stiffness (a quadratic potential: the cold backends only).
    """
    engines: list[Method] = []
    if elastic:
        pass
    elif backend == "auto" and independent_blocks:
        engines.append(Method.CLOSED_FORM)
    elif kernel and solved_before and size <= WARM_MAX_SIZE and contacts <= size:
        engines.append(Method.COMPILED)
    if backend == "clarabel" or (backend == "auto" and clarabel):
        engines.append(Method.CLARABEL)
    engines.append(Method.IPOPT)
    return tuple(engines)


__all__ = ["plan_linear"]
