r"""The least-norm split of contact forces where the contacts in touch are statically indeterminate.

With the contacts in touch fixed, each force is a magnitude :math:`\mu_j \ge 0` [N] along a known
direction (a ball or disc pushes back along its image, a slab side across its face). A unit force at
contact j has the generalised force :math:`G_{:, j}` on the unknowns; the contact forces balance
the load through their resultant :math:`G \mu`. Where the columns of G are independent that
resultant fixes :math:`\mu`: the forces are unique. Where they are dependent (a prismatic block's
corners at one x, redundant supports of one part) many splits give the same resultant, and an
optimiser returns whichever its path reached (an active-set walk adds corners one by one, an
interior point spreads the load). The reported split is then the one of least norm,

.. math::  \mu^* = \arg\min_{\mu \ge 0} \lVert \mu \rVert_2 \quad \text{s.t.} \quad
           G \mu = G \mu_0 ,

(:math:`\mu_0`: the engine's forces): the pseudo-inverse solution :math:`G^+ G \mu_0` when it is
non-negative, else the least-norm non-negative one (a small quadratic programme: non-negative
least squares with the equality weighted, then the least-norm solution on its support). The
torsors, the energy and the statics do not change; the answer no longer depends on the engine
(docs/method.md section 3.3).
"""

from __future__ import annotations

import numpy as np

DEPENDENT = 1e-10  # a singular value below this of the largest: the gradients are dependent
EQUALITY_WEIGHT = 1e6  # of the equality rows in the non-negative least squares


def least_norm_split(columns: np.ndarray, forces: np.ndarray) -> np.ndarray:
    r"""The least-norm non-negative split :math:`\mu^*` (a,) [N] of the contact forces ``forces``
    (a,) [N, >= 0] with the same resultant ``columns`` @ forces (module docstring); ``forces``
    itself when the columns (r, a) are independent (the split is unique) or when the
    least-norm programme does not reach the same resultant to 1e-9 of it (then nothing is
    changed)."""
    count = forces.size
    if count < 2 or not np.any(forces > 0.0):
        return forces
    if count <= columns.shape[0] and _surely_independent(columns):
        return forces
    _, singular, vt = np.linalg.svd(columns, full_matrices=False)
    rank = int(np.count_nonzero(singular > DEPENDENT * singular[0]))
    if rank == count:
        return forces
    rows = vt[:rank]  # G mu = G mu0  <=>  rows mu = rows mu0 (to the rank's tolerance)
    target = rows @ forces
    split = rows.T @ target  # the pseudo-inverse solution
    size = float(np.abs(forces).max())
    if split.min() < -1e-12 * size:
        split = _non_negative(rows, target)
        if split is None:
            return forces
    split = np.maximum(split, 0.0)
    resultant = columns @ forces
    if np.abs(columns @ split - resultant).max() > 1e-9 * max(
        float(np.abs(columns).max()) * size, float(np.abs(resultant).max())
    ):
        return forces
    found: np.ndarray = split
    return found


def _non_negative(rows: np.ndarray, target: np.ndarray) -> np.ndarray | None:
    r"""The least-norm :math:`\mu \ge 0` with ``rows`` :math:`\mu` = ``target`` (rows
    orthonormal): non-negative least squares on :math:`[w R; I] \mu \approx [w t; 0]` (the
    equality weighted :data:`EQUALITY_WEIGHT`), then the least-norm solution of the equality on
    the support found, kept when it is non-negative and no larger; otherwise the weighted answer,
    or None when it misses the equality by more than 1e-9 of the target."""
    count = rows.shape[1]
    weight = EQUALITY_WEIGHT
    matrix = np.vstack([weight * rows, np.eye(count)])
    from scipy.optimize import nnls  # imported on first use: SciPy's import costs 0.2 s

    rough, _ = nnls(matrix, np.concatenate([weight * target, np.zeros(count)]), maxiter=50 * count)
    scale = float(np.abs(rough).max(initial=0.0))
    support = rough > 1e-9 * scale
    if support.any():
        exact = np.zeros(count)
        exact[support] = np.linalg.lstsq(rows[:, support], target, rcond=None)[0]
        if (
            exact.min() >= -1e-12 * scale
            and np.abs(rows @ exact - target).max() <= 1e-12 * scale
            and np.linalg.norm(exact) <= np.linalg.norm(rough) * (1.0 + 1e-9)
        ):
            return exact
    if np.abs(rows @ rough - target).max() <= 1e-9 * float(np.abs(target).max(initial=0.0)):
        least: np.ndarray = rough
        return least
    return None


def _surely_independent(columns: np.ndarray) -> bool:
    r"""True when every singular value of ``columns`` (r, a), a <= r, surely exceeds 1e-6 of the
    largest, decided without an SVD (a Cholesky factor of :math:`G^T G - t I`,
    :math:`t = 10^{-12} \lVert G \rVert_F^2`); False: maybe not, ask the SVD."""
    gram = columns.T @ columns
    shift = 1e-12 * float(np.trace(gram))
    try:
        np.linalg.cholesky(gram - shift * np.eye(gram.shape[0]))
    except np.linalg.LinAlgError:
        return False
    return True


__all__ = ["least_norm_split"]
