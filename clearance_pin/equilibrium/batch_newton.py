r"""The active-set Newton step of :mod:`.kkt` for many objectives at once (same problem geometry).

For N load cases of one mechanism at one configuration only the objective f changes. From one
solved case (its contact set A, multipliers and slab sides) every case runs the same Newton
iteration on stacked arrays,

.. math::  \begin{bmatrix} \sum_{j\in A} 2\lambda_j P_j^T P_j & G_A^T \\ G_A & 0 \end{bmatrix}
           \begin{bmatrix} \delta y \\ \delta\lambda \end{bmatrix} =
           -\begin{bmatrix} f + G_A^T \lambda \\ \phi_A(y) \end{bmatrix}

(one batched linear solve per iteration). Each case is then verified on its own, exactly as a
single solve is: multipliers >= 0, every contact feasible, KKT residual at round-off. Cases whose
contact set differs fail the verification and are solved one by one by the caller.
"""

from __future__ import annotations

import numpy as np

from .kkt import ACCEPT_KKT, StackedContacts


def batched_newton(
    stack: StackedContacts,
    objectives: np.ndarray,
    y0: np.ndarray,
    multipliers0: np.ndarray,
    signs: np.ndarray,
    iterations: int = 8,
):
    """Solve the KKT systems of the contact set of (y0, multipliers0) for every row of objectives.

    Args:
        objectives: f per case, (N, r).
        y0, multipliers0, signs: a verified solution of one case (its active set is used).

    Returns:
        (Y (N, r), multipliers (N, m), verified (N,) bool, residuals (N, 4): stationarity,
        feasibility, complementarity and dual infeasibility, as :func:`~.kkt.residuals`).
    """
    count_cases = objectives.shape[0]
    active = np.flatnonzero(multipliers0 > 0.0)
    size, count = stack.size, active.size
    matrix = stack.matrix
    y = np.repeat(y0[None, :], count_cases, axis=0)
    lam = np.repeat(multipliers0[None, active], count_cases, axis=0)
    kkt = np.zeros((count_cases, size + count, size + count))
    row_weights = np.where(stack.row_is_norm, 1.0, 0.0)
    for _ in range(iterations):
        values, gradients = _evaluate(stack, y, signs)
        gradients = gradients[:, active, :]
        residual = np.concatenate(
            [objectives + np.einsum("nar,na->nr", gradients, lam), values[:, active]], axis=1
        )
        full = np.zeros((count_cases, stack.count))
        full[:, active] = lam
        lam_rows = 2.0 * full[:, stack.row_contact] * row_weights
        kkt[:, :size, :size] = np.matmul(matrix.T[None] * lam_rows[:, None, :], matrix)
        kkt[:, :size, size:] = np.transpose(gradients, (0, 2, 1))
        kkt[:, size:, :size] = gradients
        try:
            step = np.linalg.solve(kkt, -residual[..., None])[..., 0]
        except np.linalg.LinAlgError:
            step = np.einsum("nij,nj->ni", np.linalg.pinv(kkt), -residual)
        step = np.where(np.isfinite(step), step, 0.0)
        y += step[:, :size]
        lam += step[:, size:]
    multipliers = np.zeros((count_cases, stack.count))
    multipliers[:, active] = lam
    verified, table = _verify(stack, objectives, y, multipliers, signs)
    return y, np.maximum(multipliers, 0.0), verified, table


def _evaluate(stack: StackedContacts, y: np.ndarray, signs: np.ndarray):
    image = y @ stack.matrix.T
    squares = np.add.reduceat(image * image, stack.starts, axis=1)
    values = np.where(stack.is_norm, squares, signs * image[:, stack.starts]) - 1.0
    weights = np.where(stack.row_is_norm, 2.0 * image, signs[stack.row_contact])
    gradients = np.add.reduceat(
        stack.matrix[None, :, :] * weights[:, :, None], stack.starts, axis=1
    )
    return values, gradients


def _verify(stack: StackedContacts, objectives, y, multipliers, signs):
    image = y @ stack.matrix.T
    squares = np.add.reduceat(image * image, stack.starts, axis=1)
    phi = np.where(stack.is_norm, squares, np.abs(image[:, stack.starts])) - 1.0
    _, gradients = _evaluate(stack, y, signs)
    stationarity = np.abs(objectives + np.einsum("nmr,nm->nr", gradients, multipliers)).max(axis=1)
    feasibility = np.maximum(phi, 0.0).max(axis=1)
    complementarity = np.abs(multipliers * phi).max(axis=1)
    dual = np.maximum(-multipliers, 0.0).max(axis=1)
    table = np.stack([stationarity, feasibility, complementarity, dual], axis=1)
    verified = (
        (table.max(axis=1) <= ACCEPT_KKT)
        & (multipliers.min(axis=1) >= -1e-12)
        & (phi.max(axis=1) <= 1e-13)
    )
    return verified, table
