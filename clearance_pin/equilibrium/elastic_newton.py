r"""The verified Newton polish of the reduced problem with joint stiffness (a quadratic potential).

Problem (:mod:`.reduction`): :math:`\min f^T y + \tfrac12 y^T H y` s.t. :math:`\phi_j(y) \le 0`
(:mod:`.kkt`'s contacts), H the elastic energy (positive semi-definite, positive on the elastic
unknowns). For an active set A, Newton's method on

.. math::  F(y, \lambda_A) = \big(f + H y + G_A^T \lambda_A,\ \phi_A(y)\big) = 0, \qquad
           \partial F = \begin{pmatrix} H + \sum_A \lambda_j \nabla^2\phi_j & G_A^T \\
           G_A & 0 \end{pmatrix}

converges quadratically from the backend's answer. Both run on the problem rescaled by
:func:`curvature_scaled`: a stiff joint (k up to 1e15 N/m against a play of 1e-5 m) makes H's
eigenvalues span many decades, which neither an interior point nor Newton's step survives.
The active set is corrected (a pulling contact released, a penetrated one added) a few times;
the answer is accepted only when verified: multipliers >= 0, every contact feasible, KKT
residual at round-off (:func:`elastic_residuals`).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .kkt import ACTIVE_GAP, NEARLY_TOUCHING, StackedContacts, residuals
from .reduction import ReducedProblem

Vector = np.ndarray
Polished = tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, float]]  # y, multipliers, sides

NEWTON_STEPS = 30
SET_CHANGES = 8
STALLED = 1e-12  # a residual this small that halves no more is round-off
ROUND_OFF = 1e-15  # per unknown, of H's largest eigenvalue: below it an eigenvalue is zero


def curvature_scaled(problem: ReducedProblem) -> tuple[ReducedProblem, np.ndarray | None]:
    r"""(the problem in w, T) with :math:`y = T w`, :math:`T = V \mathrm{diag}(1 /
    \sqrt{\max(\lambda_i, 1)})` from :math:`H = V \mathrm{diag}(\lambda) V^T`: every direction
    H curves by more than the unit of the load's objective gets unit curvature
    (:math:`f \to T^T f`, :math:`H \to T^T H T`, :math:`P_j \to P_j T`); the contacts and their
    multipliers are the same functions of w as of y. T is None when no curvature exceeds 1."""
    assert problem.hessian is not None  # a problem with stiffness
    hessian = 0.5 * (problem.hessian + problem.hessian.T)
    curved = np.flatnonzero(np.any(hessian != 0.0, axis=1))  # play columns are exact zeros
    values, vectors = np.linalg.eigh(hessian[np.ix_(curved, curved)])
    if values.size == 0 or values[-1] <= 1.0:
        return problem, None
    # eigenvalues within round-off of the largest are zero: H's round-off would otherwise curve
    # them negatively, and no convex solver takes that
    values = np.where(values > ROUND_OFF * values.size * values[-1], values, 0.0)
    transform = np.eye(problem.size)
    transform[np.ix_(curved, curved)] = vectors / np.sqrt(np.maximum(values, 1.0))
    curvature = np.zeros(problem.size)
    curvature[curved] = values / np.maximum(values, 1.0)
    matrices = tuple(matrix @ transform for matrix in problem.contact_matrices)
    stack = problem.stack
    scaled_stack = StackedContacts(
        matrices,
        ["norm" if is_norm else "abs" for is_norm in stack.is_norm],
        problem.size,
        [stack.offset[start : start + m.shape[0]] for start, m in zip(stack.starts, matrices)],
    )
    scaled = replace(
        problem,
        objective=transform.T @ problem.objective,
        hessian=np.diag(curvature),
        contact_matrices=matrices,
        stack=scaled_stack,
    )
    return scaled, transform


def elastic_residuals(
    stack: StackedContacts, objective: Vector, hessian: Vector, y: Vector, multipliers: Vector,
    signs: Vector,
) -> dict[str, float]:  # fmt: skip
    """Measured KKT residuals (max norms) of the quadratic problem: those of :func:`.kkt.residuals`
    with the potential's gradient :math:`f + H y` in place of f."""
    gradient = objective + hessian @ y
    if not stack.count:
        zero = {"feasibility": 0.0, "complementarity": 0.0, "dual_infeasibility": 0.0}
        return {"stationarity": float(np.abs(gradient).max(initial=0.0)), **zero}
    return residuals(stack, gradient, y, multipliers, signs)


def polish_elastic(
    stack: StackedContacts, objective: Vector, hessian: Vector, y0: Vector, multipliers0: Vector,
    accept: float,
) -> Polished | None:  # fmt: skip
    """(y, multipliers, slab sides, residuals) verified to ``accept``, or None.

    Starts from the backend's (y0, multipliers0) with the contacts that carry a force or touch
    (within :data:`ACTIVE_GAP`), then with every nearly touching one."""
    y0 = np.asarray(y0, dtype=float)
    multipliers0 = np.maximum(np.asarray(multipliers0, dtype=float), 0.0)
    signs = stack.sides(y0) if stack.count else np.zeros(0)
    values = stack.values(y0, signs) if stack.count else np.zeros(0)
    largest = float(multipliers0.max(initial=0.0))
    carrying = multipliers0 > 1e-9 * largest if largest > 0.0 else np.zeros(stack.count, bool)
    for gap in (ACTIVE_GAP, NEARLY_TOUCHING):
        active = carrying | (values > -gap)
        answer = _with_set_changes(stack, objective, hessian, y0, multipliers0, signs, active,
                                   accept)  # fmt: skip
        if answer is not None:
            return answer
    return None


def _with_set_changes(
    stack: StackedContacts, objective: Vector, hessian: Vector, y: Vector, multipliers: Vector,
    signs: Vector, active: Vector, accept: float,
) -> Polished | None:  # fmt: skip
    for _ in range(SET_CHANGES):
        solved = _newton(stack, objective, hessian, y, multipliers, signs, active)
        if solved is None:
            return None
        y, multipliers = solved
        if stack.count:
            signs = np.where(active, signs, stack.sides(y))
        measured = elastic_residuals(stack, objective, hessian, y, multipliers, signs)
        pulling = active & (multipliers < -accept)
        values = stack.values(y, None) if stack.count else np.zeros(0)
        penetrated = ~active & (values > accept)
        if not pulling.any() and not penetrated.any():
            if max(measured.values(), default=0.0) <= accept:
                return y, np.maximum(multipliers, 0.0), signs, measured
            return None
        active = (active & ~pulling) | penetrated
        multipliers = np.where(active, multipliers, 0.0)
    return None


def _newton(
    stack: StackedContacts, objective: Vector, hessian: Vector, y: Vector, multipliers: Vector,
    signs: Vector, active: Vector,
) -> tuple[Vector, Vector] | None:  # fmt: skip
    """Newton's method on F(y, lambda_A) = 0 (module docstring); (y, multipliers) or None."""
    y = y.copy()
    indices = np.flatnonzero(active)
    lam = np.where(active, np.maximum(multipliers, 0.0), 0.0)
    size, count = y.size, indices.size
    best, kept = np.inf, (y.copy(), lam.copy())
    for _ in range(NEWTON_STEPS):
        gradient = objective + hessian @ y
        if stack.count:
            values, gradients = stack.evaluate(y, signs)
            gradients_a = gradients[indices]
            residual = np.concatenate((gradient + lam[indices] @ gradients_a, values[indices]))
            curvature = hessian + stack.hessian(lam)
        else:
            gradients_a = np.zeros((0, size))
            residual = gradient
            curvature = hessian
        size_now = float(np.abs(residual).max(initial=0.0))
        if not np.isfinite(size_now):
            break
        if size_now >= 0.5 * best and best <= STALLED:  # round-off: no further progress
            break
        if size_now < best:
            best, kept = size_now, (y.copy(), lam.copy())
        if size_now <= 1e-16:
            break
        kkt = np.zeros((size + count, size + count))
        kkt[:size, :size] = curvature
        kkt[:size, size:] = gradients_a.T
        kkt[size:, :size] = gradients_a
        try:
            step = np.linalg.solve(kkt, -residual)
        except np.linalg.LinAlgError:  # dependent contact gradients (an indeterminate split)
            step = np.linalg.lstsq(kkt, -residual, rcond=None)[0]
        y = y + step[:size]
        lam[indices] = lam[indices] + step[size:]
    if not np.isfinite(best):
        return None
    return kept  # the iterate of least residual (round-off stalls the last steps)


__all__ = ["curvature_scaled", "elastic_residuals", "polish_elastic"]
