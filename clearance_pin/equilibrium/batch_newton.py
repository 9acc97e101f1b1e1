r"""The active-set Newton step of :mod:`.kkt` for many objectives at once (same problem geometry).

For N load cases of one mechanism at one configuration only the objective f changes. From one
solved case (its contact set A, multipliers and slab sides) every case runs the same Newton
iteration on stacked arrays, with the same evaluation and proximal term as :func:`.kkt.newton`,

.. math::  \begin{bmatrix} \sum_{j\in A} 2\lambda_j P_j^T P_j & G_A^T \\ G_A & -\epsilon I \end{bmatrix}
           \begin{bmatrix} \delta y \\ \delta\lambda \end{bmatrix} =
           -\begin{bmatrix} f + G_A^T \lambda \\ \phi_A(y) \end{bmatrix}

(one batched linear solve per iteration). Each case is then verified on its own, exactly as a
single solve is: multipliers >= 0, every contact feasible, KKT residual at round-off, and unique
contact forces (independent active gradients; otherwise the single solve picks the minimum-norm
forces). Cases that fail are solved by the caller in another group or one by one.
"""

from __future__ import annotations

import numpy as np

from ..numerics import Array, Mask
from .kkt import ACCEPT_KKT, POLISH_TOL, PROXIMAL, StackedContacts, kkt_passed, kkt_table


def batched_newton(
    stack: StackedContacts,
    objectives: Array,
    y0: Array,
    multipliers0: Array,
    signs: Array,
    iterations: int = 8,
    accept: float = ACCEPT_KKT,
) -> tuple[Array, Array, Mask, Array]:
    """Solve the KKT systems of the contact set of (y0, multipliers0) for every row of objectives.

    Args:
        objectives: f per case, (N, r).
        y0, multipliers0, signs: a verified solution of one case (its active set is used).
        accept: KKT residual accepted (as the single solve's, grown by ill conditioning).

    Returns:
        (Y (N, r), multipliers (N, m), verified (N,) bool, residuals (N, 4): stationarity,
        feasibility, complementarity and dual infeasibility, as :func:`~.kkt.residuals`).
    """
    cases = objectives.shape[0]
    active = np.flatnonzero(multipliers0 > 0.0)
    size, count = stack.size, active.size
    rows, starts, norm_rows, local, _, _, offsets = stack.subset(active)
    slab_signs = (1.0 - norm_rows) * signs[active][local]
    twice_norm = 2.0 * norm_rows
    unknowns = np.empty((cases, size + count))
    unknowns[:, :size] = y0
    unknowns[:, size:] = multipliers0[active]
    y, lam = unknowns[:, :size], unknowns[:, size:]
    kkt = np.zeros((cases, size + count, size + count))
    kkt[:, size:, size:] = -PROXIMAL * np.eye(count)
    for _ in range(iterations + 1):
        image = y @ rows.T + offsets
        weight = twice_norm * image + slab_signs
        gradients = np.add.reduceat(rows[None] * weight[:, :, None], starts, axis=1)
        values = np.add.reduceat(image * (weight - norm_rows * image), starts, axis=1) - 1.0
        residual = np.concatenate(
            (objectives + np.einsum("na,nar->nr", lam, gradients), values), axis=1
        )
        if np.abs(residual).max() < POLISH_TOL:
            break
        kkt[:, :size, :size] = np.matmul(rows.T[None] * (twice_norm * lam[:, local])[:, None], rows)
        kkt[:, :size, size:] = np.transpose(gradients, (0, 2, 1))
        kkt[:, size:, :size] = gradients
        try:
            step = np.linalg.solve(kkt, residual[..., None])[..., 0]
        except np.linalg.LinAlgError:
            step = np.einsum("nij,nj->ni", np.linalg.pinv(kkt), residual)
        unknowns -= np.where(np.isfinite(step), step, 0.0)
    multipliers = np.zeros((cases, stack.count))
    multipliers[:, active] = _minimum_norm_forces(gradients, objectives, lam)
    verified, table = _verify(stack, objectives, y, multipliers, signs, accept)
    return y.copy(), np.maximum(multipliers, 0.0), verified, table


def _minimum_norm_forces(gradients: Array, objectives: Array, lam: Array) -> Array:
    """Per case, as :func:`.kkt._minimum_norm_forces`: Newton's multipliers when the active
    gradients are independent, else the minimum-norm ones when they are non-negative."""
    count, size = gradients.shape[1:]
    if count == 0:  # no active contact: no force to choose
        return lam
    singular = np.linalg.svd(gradients, compute_uv=False)
    unique = singular[:, -1] > 1e-10 * singular[:, 0] if count <= size else np.zeros(len(lam), bool)
    if unique.all():
        return lam
    rcond = np.finfo(float).eps * max(count, size)  # as numpy.linalg.lstsq's default
    transposed = np.transpose(gradients, (0, 2, 1))
    least = np.einsum("nar,nr->na", np.linalg.pinv(transposed, rcond=rcond), -objectives)
    use_least = ~unique & np.all(least >= -1e-14, axis=1)
    return np.where(use_least[:, None], np.maximum(least, 0.0), lam)


def stacked_evaluation(stack: StackedContacts, y: Array, signs: Array) -> tuple[Array, Array]:
    """For every case, phi of every contact (slabs on either side, |.|) and the gradients of
    every contact on the sides ``signs``: ((N, m), (N, m, r)), as :meth:`.kkt.StackedContacts.evaluate`."""
    image = y @ stack.matrix.T + stack.offset
    squares = np.add.reduceat(image * image, stack.starts, axis=1)
    phi = np.where(stack.is_norm, squares, np.abs(image[:, stack.starts])) - 1.0
    weights = np.where(stack.row_is_norm, 2.0 * image, signs[stack.row_contact])
    gradients = np.add.reduceat(stack.matrix[None] * weights[:, :, None], stack.starts, axis=1)
    return phi, gradients


def _verify(
    stack: StackedContacts,
    objectives: Array,
    y: Array,
    multipliers: Array,
    signs: Array,
    accept: float,
) -> tuple[Mask, Array]:
    phi, gradients = stacked_evaluation(stack, y, signs)
    stationarity = objectives + np.einsum("nmr,nm->nr", gradients, multipliers)
    table = kkt_table(stationarity, phi, multipliers)
    return kkt_passed(table, phi, multipliers, accept), table
