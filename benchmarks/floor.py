r"""The floor: clearance_pin's algorithm with no Python in the loop, on a known active set.

A verified re-solve of clearance_pin is, at its core, Newton's method on the KKT system of the
active contacts of the reduced cone programme (:mod:`clearance_pin.equilibrium.kkt`):

.. math::  F(y, \lambda_A) = \bigl(f + G_A(y)^T \lambda_A,\ \phi_A(y)\bigr) = 0, \qquad
           \phi_j = \|P_j y + o_j\|^2 - 1 \ (\text{ball, disc}), \quad
           \phi_j = s_j (p_j^T y + o_j) - 1 \ (\text{slab side } s_j),

followed by its verification: multipliers >= 0, every contact feasible, KKT residual at
round-off. This module measures that core alone, written once here with NumPy (numba is not
installed, and no dependency is added), on the reduced problem the library itself builds
(``clearance_pin.equilibrium.prepared.prepared_geometry(mechanism).problem(loads)``), from the
solution of the case's own load with its active set taken as known:

- ``single_s``: one load, one Newton solve and its verification, LAPACK's ``dgesv`` called
  directly (SciPy) as the library does: the cost of the algorithm when every step is a Python
  call (NumPy's per-call overhead, a few microseconds per operation, is most of it);
- ``vectorised_per_load_s``: the same Newton iterations and verification on many loads at once
  (stacked NumPy arrays, ``numpy.linalg.solve`` on a stack of KKT matrices), divided by the
  number of loads: Python runs once per iteration, not per load, so this is the arithmetic floor
  a compiled kernel approaches;
- ``lapack_call_s``: one ``dgesv`` of the KKT matrix's size from Python, the smallest step.

Only the loads whose solution keeps the known active set take part (the others would need the
active-set logic around Newton); how many did is reported. Their answers are compared with the
benchmark's references like every other path.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from scipy.linalg.lapack import dgesv

from clearance_pin.equilibrium import fast_path

ACCEPT = 1e-12  # the library's ACCEPT_KKT: verified KKT residual
CONVERGED = 1e-15  # Newton stops when the largest residual component is below this
FEASIBLE = 1e-13  # contact values phi above this are violations
ITERATIONS = 12


@dataclass(frozen=True)
class ActiveSet:
    """The rows of the active contacts of a stacked problem, ready for Newton.

    Attributes:
        active: contact indices (a,).
        rows: P_A (k, r); offsets: o_A (k,).
        starts: first row of each active contact in ``rows`` (a,).
        norm: per row 1.0 for a ball or disc row, 0.0 for a slab row (k,).
        slab_signs: per row s_j for a slab row, 0 otherwise (k,).
        local: per row its contact's index in ``active`` (k,).
        outer: per contact 2 P_j^T P_j flattened for a ball or disc, 0 for a slab (a, r * r):
            the Hessian of the Lagrangian is ``lambda_A @ outer``.
        blocks: per contact the slice of its rows in ``rows``.
    """

    active: np.ndarray
    rows: np.ndarray
    offsets: np.ndarray
    starts: np.ndarray
    norm: np.ndarray
    slab_signs: np.ndarray
    local: np.ndarray
    outer: np.ndarray
    blocks: tuple

    @classmethod
    def of(cls, stack, active: np.ndarray, signs: np.ndarray) -> ActiveSet:
        rows = np.concatenate([np.flatnonzero(stack.row_contact == j) for j in active])
        local = np.searchsorted(active, stack.row_contact[rows])
        starts = np.flatnonzero(np.r_[True, local[1:] != local[:-1]])
        norm = stack.row_is_norm[rows].astype(float)
        matrix = stack.matrix[rows]
        ends = [*starts[1:], len(rows)]
        blocks = tuple(slice(a, b) for a, b in zip(starts, ends))
        outer = np.array([2.0 * norm[b.start] * (matrix[b].T @ matrix[b]).ravel() for b in blocks])
        return cls(
            active,
            matrix,
            stack.offset[rows],
            starts,
            norm,
            (1.0 - norm) * signs[stack.row_contact[rows]],
            local,
            outer,
            blocks,
        )


def contact_values(stack, y: np.ndarray) -> np.ndarray:
    """phi of every contact, slabs on either side (|.|), for y (r,) or (N, r)."""
    image = y @ stack.matrix.T + stack.offset
    squares = np.add.reduceat(image * image, stack.starts, axis=-1)
    slab = np.abs(image[..., stack.starts])
    return np.where(stack.is_norm, squares, slab) - 1.0


def newton_single(stack, known: ActiveSet, objective, y, lam):
    """Newton on the KKT system of ``known`` from (y, lam), then the verification.

    Returns (y, lam_A, iterations, verified)."""
    rows, offsets, starts = known.rows, known.offsets, known.starts
    twice, shift, signs, outer = 2.0 * known.norm, known.norm, known.slab_signs, known.outer
    size, count = rows.shape[1], known.active.size
    kkt = np.zeros((size + count, size + count))
    hessian = kkt[:size, :size]
    residual = np.empty(size + count)
    y, lam = y.copy(), lam.copy()
    iterations = 0
    for iterations in range(ITERATIONS + 1):
        image = rows @ y + offsets
        weight = twice * image + signs
        gradients = np.add.reduceat(rows * weight[:, None], starts)
        residual[:size] = objective + lam @ gradients
        residual[size:] = np.add.reduceat(image * (weight - shift * image), starts) - 1.0
        if np.abs(residual).max() <= CONVERGED or iterations == ITERATIONS:
            break
        hessian[:] = (lam @ outer).reshape(size, size)
        kkt[:size, size:] = gradients.T
        kkt[size:, :size] = gradients
        _, _, step, info = dgesv(kkt, residual)
        if info != 0:
            return y, lam, iterations, False
        y -= step[:size]
        lam -= step[size:]
    verified = (
        lam.min() >= -ACCEPT
        and contact_values(stack, y).max() <= FEASIBLE
        and np.abs(residual).max() <= ACCEPT
    )
    return y, lam, iterations, bool(verified)


def newton_batch(stack, known: ActiveSet, objectives, y0, lam0):
    """:func:`newton_single` on N loads at once: objectives (N, r), each from (y0, lam0); a load
    leaves the iterations once converged (as a compiled loop per load would).

    Returns (y (N, r), lam_A (N, a), iteration count summed over the loads, verified (N,))."""
    rows, offsets, starts, blocks = known.rows, known.offsets, known.starts, known.blocks
    twice, shift, signs, outer = 2.0 * known.norm, known.norm, known.slab_signs, known.outer
    count_loads, size = objectives.shape
    count = known.active.size
    y_all = np.repeat(y0[None], count_loads, axis=0)
    lam_all = np.repeat(lam0[None], count_loads, axis=0)
    residual_all = np.full(count_loads, np.inf)
    todo = np.arange(count_loads)
    y, lam, f = y_all, lam_all, objectives
    steps = 0
    for iteration in range(ITERATIONS + 1):
        image = y @ rows.T + offsets  # (n, k)
        weight = twice * image + signs
        gradients = np.empty((len(todo), count, size))
        for a, block in enumerate(blocks):  # a loop over the active contacts, not the loads
            gradients[:, a] = weight[:, block] @ rows[block]
        residual = np.empty((len(todo), size + count))
        residual[:, :size] = f + np.einsum("na,nar->nr", lam, gradients)
        residual[:, size:] = np.add.reduceat(image * (weight - shift * image), starts, axis=1) - 1
        largest = np.abs(residual).max(axis=1)
        done = largest <= CONVERGED
        if iteration == ITERATIONS:
            done[:] = True
        if done.any():
            y_all[todo[done]], lam_all[todo[done]] = y[done], lam[done]
            residual_all[todo[done]] = largest[done]
            keep = ~done
            todo, y, lam, f = todo[keep], y[keep], lam[keep], f[keep]
            gradients, residual = gradients[keep], residual[keep]
        if not todo.size:
            break
        steps += todo.size
        kkt = np.zeros((todo.size, size + count, size + count))
        kkt[:, :size, :size] = (lam @ outer).reshape(-1, size, size)
        kkt[:, :size, size:] = gradients.transpose(0, 2, 1)
        kkt[:, size:, :size] = gradients
        step = np.linalg.solve(kkt, residual[:, :, None])[:, :, 0]
        y = y - step[:, :size]
        lam = lam - step[:, size:]
    verified = (
        (lam_all.min(axis=1) >= -ACCEPT)
        & (contact_values(stack, y_all).max(axis=1) <= FEASIBLE)
        & (residual_all <= ACCEPT)
    )
    return y_all, lam_all, steps, verified


def nominal_solution(problem, clarabel_peer):
    """(y, active set, lam_A) of ``problem`` verified at round-off: Clarabel (``clarabel_peer``,
    a :class:`peers.ReducedClarabel`), then Newton on the contacts it leaves touching, releasing
    a contact whose multiplier comes out negative. None when that does not verify."""
    stack = problem.stack
    y, _, _ = clarabel_peer.solve(problem)
    phi = contact_values(stack, y)
    signs = np.where(
        stack.is_norm | ((stack.matrix[stack.starts] @ y + stack.offset[stack.starts]) >= 0),
        1.0,
        -1.0,
    )
    active = np.flatnonzero(phi > -1e-6)
    for _ in range(stack.count):
        if not active.size:
            return None
        known = ActiveSet.of(stack, active, signs)
        image = known.rows @ y + known.offsets
        weight = 2.0 * known.norm * image + known.slab_signs
        gradients = np.add.reduceat(known.rows * weight[:, None], known.starts)
        lam = np.linalg.lstsq(gradients.T, -problem.objective, rcond=None)[0]
        y_new, lam_new, _, verified = newton_single(stack, known, problem.objective, y, lam)
        if verified:
            return y_new, known, lam_new
        if lam_new.min() < -ACCEPT:
            active = np.delete(active, int(np.argmin(lam_new)))
            continue
        return None
    return None


def compiled_floor(prepared, stack, known: ActiveSet, loads, y0, lam0) -> dict:
    """``compiled_s``: the library's compiled kernel alone on one load (``kernel.solve_cases``
    with one case: the objective, the active-set Newton step from the known set's solution, its
    verification, the flat-direction test and the answer's arrays), median over ``loads``;
    empty when the kernel is not loaded."""
    if fast_path.compiled_kernel() is None:
        return {}
    fast = fast_path.FastTerms(prepared)
    multipliers = np.zeros(stack.count)
    multipliers[known.active] = lam0
    signs = stack.sides(y0)
    times, solved = [], 0
    for resolved in loads:
        params, matrix, constant = fast.load_map(resolved)
        cases = params.reshape(1, -1)
        t0 = time.perf_counter()
        rows, _ = fast.solve(cases, matrix, constant, y0, multipliers, signs)
        times.append(time.perf_counter() - t0)
        solved += rows[0, 0] == fast.kernel.SOLVED
    return {"compiled_s": float(np.median(times)), "compiled_verified": int(solved)}


def median_time(function, repeats: int) -> float:
    """Median wall time of ``function()`` over ``repeats`` calls [s]."""
    times = []
    for _ in range(repeats):
        started = time.perf_counter()
        function()
        times.append(time.perf_counter() - started)
    return float(np.median(times))


def floor_case(
    prepared,
    problems,
    nominal_problem,
    vector_of,
    references,
    clarabel_peer,
    error_of,
    rows: int = 10_000,
    repeats: int = 5,
    loads=None,
) -> dict:
    """The floor of one case.

    The known active set and the start of Newton are those of one verified solution (Clarabel
    then Newton, untimed): the case's own load's, or one of the perturbed loads' of each of the
    most common active sets, whichever lets Newton verify the most perturbed loads (an untimed
    pass). Those loads are then solved again, timed, verified and compared with their
    references; the others (a different active set, or too far for Newton) are counted.

    Args:
        prepared: ``prepared_geometry(mechanism)``.
        problems: the reduced problems of the case's perturbed loads.
        nominal_problem: the reduced problem of the case's own load.
        vector_of: x (n,) -> the compared torsor vector (paper units).
        references: per perturbed load, the reference vector.
        clarabel_peer: a :class:`peers.ReducedClarabel` (finds the solutions, untimed).
        error_of: (vector, reference) -> (total, translation, rotation).
        rows: loads of the vectorised run (the group's loads repeated to this many).
        repeats: timed repeats of the vectorised run (median).
        loads: per perturbed load, its resolved loads (for the compiled kernel's floor).
    """
    started = time.perf_counter()
    stack = nominal_problem.stack

    def key(solution):
        return (
            None
            if solution is None
            else (solution[1].active.tobytes(), solution[1].slab_signs.tobytes())
        )

    own = [
        nominal_solution(problem, clarabel_peer) if problem.stack is stack else None
        for problem in problems
    ]
    groups: dict = {}
    for index, solution in enumerate(own):
        if solution is not None:
            groups.setdefault(key(solution), []).append(index)
    if not groups:
        return {"measured": False, "note": "no perturbed load's solution verified"}
    # candidate seeds: the case's own load, and one load of each of the largest groups; the
    # known set is the seed's from which Newton verifies the most loads (an untimed pass)
    candidates = []
    nominal = nominal_solution(nominal_problem, clarabel_peer)
    if nominal is not None:
        candidates.append(("the case's own load", nominal, None))
    for members in sorted(groups.values(), key=len, reverse=True)[:4]:
        candidates.append(("a perturbed load", own[members[0]], members[0]))
    best = None
    for name, (y0, known, lam0), excluded in candidates:
        members = [
            i
            for i, problem in enumerate(problems)
            if i != excluded
            and problem.stack is stack
            and newton_single(stack, known, problem.objective, y0, lam0)[3]
        ]
        if best is None or len(members) > len(best[2]):
            best = (name, (y0, known, lam0), members)
    seed, (y0, known, lam0), members = best
    out = {
        "active_contacts": int(known.active.size),
        "kkt_size": int(stack.size + known.active.size),
        "loads": len(problems),
        "loads_on_known_set": len(members),
        "active_sets_seen": len(groups),
        "seed": seed,
    }
    single_times, iterations, kept, errors, translation, rotation = [], [], [], [], [], []
    for index in members:
        t0 = time.perf_counter()
        y, _, count, verified = newton_single(stack, known, problems[index].objective, y0, lam0)
        seconds = time.perf_counter() - t0
        if not verified:
            continue
        single_times.append(seconds)
        iterations.append(count)
        kept.append(index)
        total, t, r = error_of(vector_of(prepared.x_from_y @ y), references[index])
        errors.append(total)
        translation.append(t)
        rotation.append(r)
    out["measured"] = bool(kept)
    if not kept:
        out["note"] = "Newton from the seed verified no perturbed load"
        return out
    if loads is not None:
        out.update(compiled_floor(prepared, stack, known, [loads[i] for i in kept], y0, lam0))
    objectives = np.array([problems[i].objective for i in kept])
    tiled = np.resize(objectives, (max(rows, len(kept)), objectives.shape[1]))
    y, _, batch_iterations, verified = newton_batch(stack, known, tiled, y0, lam0)
    for k in range(len(kept)):
        total, t, r = error_of(vector_of(prepared.x_from_y @ y[k]), references[kept[k]])
        errors.append(total)
        translation.append(t)
        rotation.append(r)
    vectorised = median_time(lambda: newton_batch(stack, known, tiled, y0, lam0), repeats)
    kkt = np.eye(out["kkt_size"]) + 0.1
    right = np.ones(out["kkt_size"])
    lapack = median_time(lambda: dgesv(kkt, right), 2000)
    out.update(
        {
            "single_s": float(np.median(single_times)),
            "single_p10_s": float(np.percentile(single_times, 10)),
            "single_iterations_median": float(np.median(iterations)),
            "vectorised_rows": len(tiled),
            "vectorised_per_load_s": vectorised / len(tiled),
            "vectorised_iterations_mean": batch_iterations / len(tiled),
            "vectorised_verified": int(np.sum(verified)),
            "lapack_call_s": lapack,
            "error_mm": float(max(errors)),
            "error_translation_mm": float(max(translation)),
            "error_rotation_rad": float(max(rotation)),
            "wall_s": time.perf_counter() - started,
        }
    )
    return out
