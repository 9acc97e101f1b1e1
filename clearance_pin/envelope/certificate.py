r"""A quadratic certificate of the largest deviation, from the contact forces of one state.

The largest deviation $\max_{y \in Y} \lVert G y \rVert$ maximises a convex function over the
convex set of admissible states (:mod:`.state_space`). For any multipliers $\mu_j \ge 0$ and every
admissible $y$ (each term of the sum is $\ge 0$ there),

.. math::

    \lVert G y \rVert^2 \le \lVert G y \rVert^2 + \sum_j \mu_j \big(c_j^2 - \lVert A_j y + o_j
    \rVert^2\big) = s - y^T M y - 2 b^T y,

    M = \sum_j \mu_j A_j^T A_j - G^T G, \qquad b = \sum_j \mu_j A_j^T o_j, \qquad
    s = \sum_j \mu_j (c_j^2 - \lVert o_j \rVert^2),

so when $M \succeq 0$ the largest deviation is at most $U$ with $U^2 = s + b^T M^{+} b$ (the
Lagrangian relaxation, an S-lemma bound). The multipliers are those of the state $y^*$ that
reaches the largest deviation $\lVert \delta^* \rVert$ under the unit load along
$d = \delta^* / \lVert \delta^* \rVert$: its contact forces $\kappa_j = \lVert f_j \rVert$ [N] balance
that load, $G^T d = \sum_j \kappa_j A_j^T (A_j y^* + o_j) / c_j$, so
$\mu_j = \lVert \delta^* \rVert \kappa_j / c_j$ are the Lagrange multipliers of the non-convex
problem at $y^*$, and then $U = \lVert \delta^* \rVert$: the state is the global maximum whenever
$M \succeq 0$ (a disc, a ball, a cylinder of play; sums of them along a serial chain). Otherwise the
bound is larger and the direction grid of :mod:`.certify` decides.

Round-off is accounted for, not neglected: with $\lambda_{min}$ the smallest eigenvalue of $M$ on
the motions the contacts see and $\epsilon = \max(0, -\lambda_{min}) + 10^{-14} \lambda_{max}$,
$U^2 = s + b^T (M + \epsilon I)^{-1} b + \epsilon R^2$, where
$R^2 = \sum_j (1 + \lVert o_j \rVert / c_j)^2 / \lambda_{min}(\sum_j A_j^T A_j / c_j^2)$ bounds
$\lVert y \rVert^2$ over the admissible states. Every number is checked here with numpy: the
certificate does not trust the solver.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import numpy.typing as npt

from .state_space import StateSpace

Vector = npt.NDArray[np.float64]


def multiplier_bound(space: StateSpace, projected: Vector, state: Any, deviation: float) -> float:
    r"""The certificate's bound $U$ [m or rad] (module docstring); ``inf`` when it certifies
    nothing (no contact force, or the state's contacts are not the model's).

    Args:
        space: the admissible states.
        projected: $G$ (k, n): the output's deviation in span coordinates.
        state: the equilibrium under the unit load along the deviation's direction.
        deviation: $\lVert \delta^* \rVert$, the state's deviation [m or rad].
    """
    forces = {c.label: float(c.force_magnitude) for c in state.contacts}
    labels = {c.label for c in space.contacts}
    if any(force > 0.0 and label not in labels for label, force in forces.items()):
        return math.inf
    free = space.free
    n = space.size
    # work on the motions the contacts see (the free ones move neither side of the bound)
    seen = _complement(free, n)
    g = projected @ seen
    weights = np.array([deviation * forces.get(c.label, 0.0) / c.bound for c in space.contacts])
    if not np.any(weights > 0.0):
        return math.inf
    rows = [c.rows @ seen for c in space.contacts]
    m = -g.T @ g
    b = np.zeros(seen.shape[1])
    s = 0.0
    coverage = np.zeros((seen.shape[1], seen.shape[1]))
    sizes = 0.0
    for contact, a, mu in zip(space.contacts, rows, weights):
        coverage += a.T @ a / contact.bound**2
        sizes += (1.0 + float(np.linalg.norm(contact.offset)) / contact.bound) ** 2
        if mu > 0.0:
            m += mu * (a.T @ a)
            b += mu * (a.T @ contact.offset)
            s += mu * (contact.bound**2 - float(contact.offset @ contact.offset))
    m = 0.5 * (m + m.T)
    eigenvalues = np.linalg.eigvalsh(m)
    largest = max(float(np.max(np.abs(eigenvalues), initial=0.0)), float(np.sum(g * g)), 1e-300)
    epsilon = max(0.0, -float(eigenvalues[0])) + 1e-14 * largest
    smallest_seen = float(np.linalg.eigvalsh(0.5 * (coverage + coverage.T))[0])
    if smallest_seen <= 0.0:
        return math.inf
    radius2 = sizes / smallest_seen
    shifted = m + epsilon * np.eye(m.shape[0])
    bound2 = s + float(b @ np.linalg.solve(shifted, b)) + epsilon * radius2
    return math.sqrt(max(bound2, 0.0))


def _complement(basis: Vector, n: int) -> Vector:
    """Orthonormal basis (n, n - f) of the orthogonal complement of ``basis`` (n, f)."""
    if basis.shape[1] == 0:
        return np.eye(n)
    u, _, _ = np.linalg.svd(basis, full_matrices=True)
    return np.asarray(u[:, basis.shape[1] :], dtype=float)
