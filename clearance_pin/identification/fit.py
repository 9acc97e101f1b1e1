r"""The fit: linear least squares of the drives' backlash and compliance on the within-pose
deviations of the measured point (docs/identification.md, section 3).

Each pose's unknown offset :math:`o_p` (the device's placement, the robot's geometric error
there) is eliminated by centring: every quantity less its mean over the pose's rows,
:math:`\bar y_{pl} = y_{pl} - \frac{1}{L_p} \sum_{l'} y_{pl'}` (the least-squares estimate of
:math:`o_p`; the same information as the differences :math:`d_{pl} - d_{p1}`, without singling
out a first load). Then

.. math::  \bar y - \bar f - \bar A_{fixed}\, \theta_{fixed} = \bar A\, \theta + \varepsilon,
           \qquad \hat\theta = (\bar A^T \bar A)^{-1} \bar A^T (\ldots),

solved by the SVD of :math:`\bar A` with its columns scaled to unit norm (the condition number
is that matrix's), and

.. math::  \hat\sigma^2 = \frac{\lVert r \rVert^2}{(M - P)\,d - n}, \qquad
           \mathrm{cov}(\hat\theta) = \hat\sigma^2 (\bar A^T \bar A)^{-1}

(M rows, P poses, d coordinates per row, n parameters; the centring uses P d degrees of
freedom). A parameter that no pose's loads can tell apart is left out before the fit, with its
reason (:func:`observability`); a combination the data cannot separate (rank deficiency) leaves
out, one at a time, the parameter that weighs most in the null space.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .differences import ZERO_TORQUE, DifferenceModel

RANK_RTOL = 1e-9  # singular values below this share of the largest (columns scaled): rank lost
CORRELATED = 0.9  # |correlation| above this: a correlated pair
NO_LEVER = 1e-12  # a drive whose lever at a pose is below this share of the largest: none there

__all__ = ["CORRELATED", "LeastSquares", "centred", "least_squares", "observability", "rms"]


def centred(values: np.ndarray, pose_of_row: np.ndarray) -> np.ndarray:
    """``values`` (M, ...) less the mean of their pose's rows."""
    poses = int(pose_of_row.max()) + 1
    counts = np.bincount(pose_of_row, minlength=poses).astype(float)
    flat = values.reshape(len(values), -1)
    sums = np.zeros((poses, flat.shape[1]))
    np.add.at(sums, pose_of_row, flat)
    out: np.ndarray = (flat - (sums / counts[:, None])[pose_of_row]).reshape(values.shape)
    return out


def observability(model: DifferenceModel, pose_of_row: np.ndarray) -> dict[int, str]:
    """Parameter index -> why the data cannot determine it, for every such parameter: a drive
    that never moves the point, a backlash whose side never changes within a pose (the drive's
    torque keeps its sign under every load of every pose), a compliance whose torque never
    changes within a pose."""
    reasons: dict[int, str] = {}
    lever = np.linalg.norm(model.levers, axis=1)  # (M, J)
    largest = float(lever.max(initial=0.0))
    torque_scale = np.max(np.abs(model.torques), initial=0.0)
    poses = int(pose_of_row.max()) + 1
    for j in range(len(model.joints)):
        moves = lever[:, j] > NO_LEVER * largest
        if not moves.any():
            why = "it does not move the measured point"
            reasons[2 * j] = reasons[2 * j + 1] = why
            continue
        side_changes = torque_changes = False
        for p in range(poses):
            rows = (pose_of_row == p) & moves
            if rows.sum() < 2:
                continue
            signs = model.signs[rows, j]
            side_changes |= bool(signs.max() > signs.min())
            torques = model.torques[rows, j]
            torque_changes |= bool(torques.max() - torques.min() > ZERO_TORQUE * torque_scale)
        if not side_changes:
            reasons[2 * j] = (
                "unobservable: its torque never changes sign within a pose (no load of any "
                "pose takes up its backlash on the other side)"
            )
        if not torque_changes:
            reasons[2 * j + 1] = "unobservable: its torque does not change within any pose"
    return reasons


@dataclass(frozen=True)
class LeastSquares:
    """A linear least-squares fit of some of the parameters (module docstring).

    Attributes:
        theta: every parameter (b_j, c_j), the fitted ones at their estimates, the others at
            their priors (2 J,).
        fitted: indices of the fitted parameters (n,).
        covariance: their covariance (n, n) [SI units of theta squared].
        sigma: the residuals' standard deviation (weighted coordinates) [m].
        rank: the numerical rank of the scaled design matrix (before anything was left out for
            a rank deficiency).
        condition: its condition number (largest / smallest singular value) of what was fitted.
        dof: the residuals' degrees of freedom, (M - P) d - n.
        left_out: parameter index -> why it was not fitted.
    """

    theta: np.ndarray
    fitted: np.ndarray
    covariance: np.ndarray
    sigma: float
    rank: int
    condition: float
    dof: int
    left_out: dict[int, str]

    def standard_errors(self) -> np.ndarray:
        """Every parameter's standard error (2 J,) (NaN where not fitted)."""
        errors = np.full(len(self.theta), np.nan)
        errors[self.fitted] = np.sqrt(np.clip(np.diag(self.covariance), 0.0, None))
        return errors

    def correlations(self) -> np.ndarray:
        """The fitted parameters' correlation matrix (n, n)."""
        scale = np.sqrt(np.diag(self.covariance))
        with np.errstate(invalid="ignore", divide="ignore"):
            correlation: np.ndarray = self.covariance / np.outer(scale, scale)
        return correlation


def design_rows(model: DifferenceModel, pose_of_row: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """The centred, weighted model columns (M d, 2 J)."""
    columns = centred(model.columns, pose_of_row) * weights[None, :, None]
    rows: np.ndarray = columns.reshape(-1, columns.shape[2])
    return rows


def least_squares(
    model: DifferenceModel,
    measured: np.ndarray,
    pose_of_row: np.ndarray,
    free: np.ndarray,
    weights: np.ndarray,
) -> LeastSquares:
    """Fit the parameters ``free`` (a mask over the 2 J parameters) to ``measured`` (M, d), the
    others at their priors; ``weights`` (d,) scale each coordinate's rows (1 for positions, a
    length [m/rad] for rotations)."""
    prior = model.prior()
    reasons = {i: why for i, why in observability(model, pose_of_row).items() if free[i]}
    chosen = [i for i in range(len(prior)) if free[i] and i not in reasons]
    rows = design_rows(model, pose_of_row, weights)
    held = [i for i in range(len(prior)) if i not in chosen]
    target = centred(measured - model.fixed, pose_of_row) * weights[None, :]
    target = target.reshape(-1) - rows[:, held] @ prior[held]
    effective = (len(measured) - (int(pose_of_row.max()) + 1)) * measured.shape[1]
    rank = -1
    while True:
        a = rows[:, chosen]
        norms = np.linalg.norm(a, axis=0)
        if not chosen:
            u, s, vt = np.zeros((len(a), 0)), np.zeros(0), np.zeros((0, 0))
            break
        u, s, vt = np.linalg.svd(a / norms, full_matrices=False)
        independent = int(np.sum(s > RANK_RTOL * s[0]))
        rank = independent if rank < 0 else rank
        if independent == len(chosen):
            break
        null = vt[independent:]
        weight = np.sum(null**2, axis=0)
        worst = int(np.argmax(weight))
        partners = [chosen[k] for k in np.flatnonzero(weight > 0.01 * weight[worst]) if k != worst]
        reasons[chosen[worst]] = (
            "not separable (the data determine only a combination with "
            + (", ".join(_label(model, k) for k in partners) or "others")
            + ")"
        )
        chosen = [c for k, c in enumerate(chosen) if k != worst]
    theta = prior.copy()
    n = len(chosen)
    covariance = np.zeros((n, n))
    sigma, condition = np.nan, np.nan
    dof = effective - n
    if n:
        scaled = vt.T @ ((u.T @ target) / s)
        theta[chosen] = scaled / norms
        residual = target - rows[:, chosen] @ theta[chosen]
        sigma = float(np.sqrt(residual @ residual / dof)) if dof > 0 else np.nan
        inverse = (vt.T / s**2) @ vt / np.outer(norms, norms)
        covariance = sigma**2 * inverse
        condition = float(s[0] / s[-1])
    return LeastSquares(
        theta, np.array(chosen, dtype=int), covariance, sigma, max(rank, 0), condition, dof,
        reasons,
    )  # fmt: skip


def _label(model: DifferenceModel, index: int) -> str:
    parameter = model.parameters[index]
    return f"{parameter.joint} {parameter.kind}"


def rms(
    model: DifferenceModel, measured: np.ndarray, pose_of_row: np.ndarray, theta: np.ndarray
) -> tuple[float, float | None]:
    """(position [m], rotation [rad] or None): the root mean square of the centred residuals,
    each measured coordinate less the model's at ``theta``, both less their pose's mean."""
    residual = centred(measured - model.predict(theta), pose_of_row)
    position = float(np.sqrt(np.mean(residual[:, :3] ** 2)))
    rotation = float(np.sqrt(np.mean(residual[:, 3:] ** 2))) if residual.shape[1] > 3 else None
    return position, rotation
