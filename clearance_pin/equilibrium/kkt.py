r"""KKT system of the reduced cone programme, vectorised over all contacts, and its Newton solve.

Problem (:mod:`.reduction`): :math:`\min f^T y` s.t. :math:`\phi_j(y) \le 0` with
:math:`\phi_j = \|P_j y\|^2 - 1` (ball, disc) or :math:`\phi_j = s_j p_j^T y - 1` (slab side
:math:`s_j = \pm 1`). All :math:`P_j` are stacked into one matrix P (rows of contact j in
``starts[j]:starts[j+1]``), so every evaluation is a few matrix products:

.. math::  \nabla\phi_j = \sum_{rows\ i\ of\ j} w_i P_i, \quad w_i = 2 (P y)_i \ (\text{norm}),
           \ s_j \ (\text{slab}); \qquad
           \nabla^2 L = P^T \mathrm{diag}(2\lambda_{j(i)} [\text{norm}]) P

Newton's method on :math:`F(y, \lambda_A) = (f + G_A^T\lambda_A,\ \phi_A(y)) = 0` for an active set A
converges quadratically; the result is accepted only when it is verified: multipliers >= 0, every
contact feasible, KKT residual at round-off.
"""

from __future__ import annotations

import numpy as np

POLISH_TOL = 1e-14
ACCEPT_KKT = 1e-10
ACTIVE_GAP = 1e-6


class StackedContacts:
    """All contact matrices of a reduced problem stacked for vectorised evaluation.

    Attributes:
        matrix: P, (total rows, r).
        starts: first row of each contact, (m,).
        is_norm: per contact, True for balls and discs, (m,).
        row_contact: per row, its contact index, (total rows,).
    """

    def __init__(self, matrices: tuple[np.ndarray, ...], shapes: list[str], size: int):
        self.size = size
        self.count = len(matrices)
        self.matrix = np.vstack(matrices) if matrices else np.zeros((0, size))
        lengths = np.array([m.shape[0] for m in matrices], dtype=int)
        self.starts = (
            np.concatenate([[0], np.cumsum(lengths)[:-1]]).astype(int)
            if matrices
            else np.zeros(0, dtype=int)
        )
        self.is_norm = np.array([s == "norm" for s in shapes], dtype=bool)
        self.row_contact = np.repeat(np.arange(self.count), lengths)
        self.row_is_norm = self.is_norm[self.row_contact] if self.count else np.zeros(0, bool)

    def values(self, y: np.ndarray, signs: np.ndarray) -> np.ndarray:
        """phi_j(y) for every contact (slabs on their side ``signs``; |.| if signs is None)."""
        image = self.matrix @ y
        squares = np.add.reduceat(image * image, self.starts) if self.count else np.zeros(0)
        slab = image[self.starts]
        slab = np.abs(slab) if signs is None else signs * slab
        return np.where(self.is_norm, squares, slab) - 1.0

    def gradients(self, y: np.ndarray, signs: np.ndarray) -> np.ndarray:
        """Gradients of phi_j as rows, (m, r)."""
        image = self.matrix @ y
        weights = np.where(self.row_is_norm, 2.0 * image, signs[self.row_contact])
        return np.add.reduceat(self.matrix * weights[:, None], self.starts, axis=0)

    def evaluate(self, y: np.ndarray, signs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(phi_j on the sides ``signs``, gradients (m, r)) from one product P y."""
        image = self.matrix @ y
        squares = np.add.reduceat(image * image, self.starts)
        values = np.where(self.is_norm, squares, signs * image[self.starts]) - 1.0
        weights = np.where(self.row_is_norm, 2.0 * image, signs[self.row_contact])
        return values, np.add.reduceat(self.matrix * weights[:, None], self.starts, axis=0)

    def hessian(self, multipliers: np.ndarray) -> np.ndarray:
        """Hessian of the Lagrangian, sum over norm contacts of 2 lambda_j P_j^T P_j, (r, r)."""
        weights = np.where(self.row_is_norm, 2.0 * multipliers[self.row_contact], 0.0)
        return (self.matrix.T * weights) @ self.matrix

    def sides(self, y: np.ndarray) -> np.ndarray:
        """Side (+1/-1) of every slab at y (1 for norm contacts)."""
        slab = (self.matrix @ y)[self.starts] if self.count else np.zeros(0)
        return np.where(self.is_norm | (slab >= 0.0), 1.0, -1.0)


def residuals(stack: StackedContacts, objective, y, multipliers, signs) -> dict[str, float]:
    """Measured KKT residuals (max norms): stationarity, feasibility, complementarity, dual."""
    phi = stack.values(y, None)
    gradients = stack.gradients(y, signs)
    return {
        "stationarity": float(np.max(np.abs(objective + gradients.T @ multipliers), initial=0.0)),
        "feasibility": float(np.max(phi, initial=0.0)),
        "complementarity": float(np.max(np.abs(multipliers * phi), initial=0.0)),
        "dual_infeasibility": float(max(0.0, -np.min(multipliers, initial=0.0))),
    }


def newton(stack: StackedContacts, objective, y, multipliers, signs, active, iterations: int = 12):
    """Newton on the KKT system of ``active``; returns (y, lambda_active) or None."""
    size, count = stack.size, active.size
    kkt = np.zeros((size + count, size + count))
    residual = np.empty(size + count)
    y = y.copy()
    lam = multipliers[active].copy()
    full = np.zeros(stack.count)
    for iteration in range(iterations + 1):
        values, gradients = stack.evaluate(y, signs)
        gradients = gradients[active]
        residual[:size] = objective + gradients.T @ lam
        residual[size:] = values[active]
        size_now = np.abs(residual).max()
        if size_now < POLISH_TOL:
            return y, lam
        if iteration == iterations or (iteration >= 6 and size_now > 1e-4):
            break  # quadratic convergence did not set in: a wrong active set, give up early
        full[active] = lam
        kkt[:size, :size] = stack.hessian(full)
        kkt[:size, size:] = gradients.T
        kkt[size:, :size] = gradients
        try:
            step = np.linalg.solve(kkt, -residual)
        except np.linalg.LinAlgError:
            step = np.linalg.lstsq(kkt, -residual, rcond=None)[0]
        if not np.isfinite(step).all():
            return None
        y += step[:size]
        lam += step[size:]
    return (y, lam) if np.abs(residual).max() < 1e-11 else None


def active_set_solve(
    stack: StackedContacts, objective, y, multipliers, signs=None, rounds: int = 4
):
    """Verified active-set Newton from a guess (y, multipliers); None if it cannot be verified.

    The active set starts as the contacts in touch or carrying a multiplier; contacts whose
    multiplier turns negative are released, violated ones are added, for a few rounds.

    Returns:
        (y, multipliers (all contacts), signs, residuals) or None.
    """
    signs = stack.sides(y) if signs is None else signs.copy()
    phi = stack.values(y, None)
    largest = max(1.0, float(np.max(multipliers, initial=0.0)))
    active = np.flatnonzero((phi > -ACTIVE_GAP) | (multipliers > 1e-9 * largest))
    for _ in range(rounds):
        if active.size == 0:
            return None
        solved = newton(stack, objective, y, multipliers, signs, active)
        if solved is None:
            return None
        y_new, lam_active = solved
        negative = active[lam_active < -1e-12]
        if negative.size:
            active = np.setdiff1d(active, negative)
            continue
        phi_new = stack.values(y_new, None)
        violated = np.flatnonzero(phi_new > 1e-13)
        if violated.size:
            signs = stack.sides(y_new)
            active = np.union1d(active, violated)
            continue
        lam_new = np.zeros(stack.count)
        lam_new[active] = np.maximum(lam_active, 0.0)
        measured = residuals(stack, objective, y_new, lam_new, signs)
        if max(measured.values()) <= ACCEPT_KKT:
            return y_new, lam_new, signs, measured
        return None
    return None
