"""Worst-case and statistical (RSS) bands, tolerance allocation and confidence factors.

The arithmetic of P. Flores, "A methodology for quantifying the kinematic position errors due
to manufacturing and assembly tolerances", Strojniski vestnik - J. Mech. Eng. (2011) [F],
once the sensitivities are known. All quantities are SI ([m] for lengths, [rad] for angles);
sensitivities have the units output/dimension.

Conventions, used throughout:

- ``S`` [output/dimension]: first-order sensitivities ``dq = S dd``, shape ``(..., n_dim)``:
  the last axis runs over the toleranced dimensions, leading axes over outputs and positions.
- ``half_tol`` [m]: half tolerances ``T_j / 2`` (a bilateral tolerance ``d_j +/- T_j/2``),
  shape ``(n_dim,)``. Every band, input and result here is a *half width*.
- A dimension an output does not see (``S_ij = 0``) contributes nothing to that output's band,
  even with an infinite tolerance (``0 * inf`` is taken as 0).
- Statistical model of [F]: each dimension is normal with its process spread equal to its
  tolerance, ``6 sigma_j = T_j``, i.e. ``sigma_j = half_tol_j / 3``. The RSS band is then
  ``3 sigma`` of the (linearised) output.
"""

from __future__ import annotations

import math
from statistics import NormalDist
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..model.iso286 import ToleranceInputError

__all__ = [
    "confidence_for_admissible",
    "confidence_from_gamma",
    "equal_effect_allocation",
    "gamma_for_admissible",
    "gamma_from_confidence",
    "monte_carlo_inputs",
    "rss_band",
    "sampling_error_of_3sigma",
    "worst_case_band",
]

_STANDARD_NORMAL = NormalDist()


# --------------------------------------------------------------------------------------------
# Input checkers (return the cleaned value)
# --------------------------------------------------------------------------------------------


def _half_tolerances(half_tol: ArrayLike, *, allow_inf: bool) -> NDArray[np.float64]:
    """Half tolerances as a float vector (n_dim,), all >= 0 (and finite unless allowed)."""
    h = np.asarray(half_tol, dtype=float)
    if h.ndim != 1 or h.size == 0:
        raise ToleranceInputError(half_tol, f"half_tol must have shape (n_dim,), got {h.shape}")
    if np.isnan(h).any() or (h < 0).any():
        raise ToleranceInputError(half_tol, "half_tol must be >= 0 (and not NaN) [m]")
    if not allow_inf and np.isinf(h).any():
        raise ToleranceInputError(half_tol, "half_tol must be finite here [m]")
    return h


def _sensitivities(S: ArrayLike, n_dim: int | None = None) -> NDArray[np.float64]:
    """Sensitivities as a finite float array (..., n_dim)."""
    s = np.asarray(S, dtype=float)
    if s.ndim == 0 or s.shape[-1] == 0:
        raise ToleranceInputError(
            S, f"S must have shape (..., n_dim) with n_dim >= 1, got {s.shape}"
        )
    if n_dim is not None and s.shape[-1] != n_dim:
        raise ToleranceInputError(
            S,
            f"S must have shape (..., {n_dim}) to match half_tol of shape ({n_dim},), "
            f"got {s.shape}",
        )
    if not np.isfinite(s).all():
        raise ToleranceInputError(
            S,
            "S must be finite (an infinite sensitivity means a singular configuration, "
            "where the linear analysis does not apply)",
        )
    return s


def _scalar(x: Any, name: str, *, lower: float = 0.0, allow_inf: bool = False) -> float:
    """A real number >= lower (finite unless allowed)."""
    if isinstance(x, bool):
        raise ToleranceInputError(x, f"{name} must be a real number, not a bool")
    try:
        value = float(x)
    except (TypeError, ValueError):
        raise ToleranceInputError(x, f"{name} must be a real number") from None
    if math.isnan(value) or value < lower or (math.isinf(value) and not allow_inf):
        finite = "" if allow_inf else " and finite"
        raise ToleranceInputError(x, f"{name} must be >= {lower:g}{finite}")
    return value


def _count(n: Any, name: str, minimum: int) -> int:
    """An integer >= minimum (bool refused)."""
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < minimum:
        raise ToleranceInputError(n, f"{name} must be an integer >= {minimum}")
    return int(n)


def _terms(S: ArrayLike, half_tol: ArrayLike) -> NDArray[np.float64]:
    """``|S_ij| T_j/2`` with the convention 0 * inf = 0, shape (..., n_dim)."""
    h = _half_tolerances(half_tol, allow_inf=True)
    s = np.abs(_sensitivities(S, h.size))
    with np.errstate(invalid="ignore"):
        return np.where(s == 0.0, 0.0, s * h)


# --------------------------------------------------------------------------------------------
# Bands
# --------------------------------------------------------------------------------------------


def worst_case_band(S: ArrayLike, half_tol: ArrayLike) -> NDArray[np.float64]:
    r"""Worst-case half band of the outputs [F]:

    .. math:: |dq_i| \le \sum_j |S_{ij}| \, T_j / 2

    The absolute values matter: at bottom dead centre of a slider-crank ``dx4/dr2 = -1`` and a
    signed sum would cancel the two contributions.

    Args:
        S: Sensitivities [output/dimension], shape ``(..., n_dim)`` (e.g. ``(n_out, n_dim)`` or
            ``(n_dim,)``).
        half_tol: Half tolerances ``T_j/2`` [m], shape ``(n_dim,)``, >= 0.

    Returns:
        Half bands [output units], shape ``S.shape[:-1]`` (0-d for a single output).
    """
    return np.asarray(np.sum(_terms(S, half_tol), axis=-1))


def rss_band(S: ArrayLike, half_tol: ArrayLike) -> NDArray[np.float64]:
    r"""Statistical (root-sum-square) half band of the outputs [F]:

    .. math:: |dq_i| \le \sqrt{\sum_j (S_{ij} \, T_j / 2)^2}

    With ``6 sigma_j = T_j`` for every dimension this is ``3 sigma`` of the linearised output.

    Args:
        S: Sensitivities [output/dimension], shape ``(..., n_dim)``.
        half_tol: Half tolerances ``T_j/2`` [m], shape ``(n_dim,)``, >= 0.

    Returns:
        Half bands [output units], shape ``S.shape[:-1]`` (0-d for a single output).
    """
    terms = _terms(S, half_tol)
    # scaled by the largest term, so that squares neither underflow nor overflow (as hypot)
    scale = np.max(terms, axis=-1, keepdims=True)
    finite = np.isfinite(scale) & (scale > 0.0)
    ratio = np.divide(terms, scale, out=np.zeros_like(terms), where=finite)
    norm = np.where(finite, scale, 0.0) * np.sqrt(np.sum(ratio * ratio, axis=-1, keepdims=True))
    norm = np.where(np.isinf(scale), np.inf, norm)
    return np.asarray(norm[..., 0])


def equal_effect_allocation(
    S_row: ArrayLike, allowed_half: float, method: Literal["worst", "rss"] = "worst"
) -> NDArray[np.float64]:
    r"""Half tolerances that share an allowed output half band equally among dimensions [F].

    Every dimension with a non-zero sensitivity gets the same share of the band:

    .. math::

        \text{worst case: } \frac{T_j}{2} = \frac{T_{max}/2}{m |S_j|}, \qquad
        \text{statistical: } \frac{T_j}{2} = \frac{T_{max}/2}{\sqrt{m} |S_j|}

    (the formulas of [F] are linear, so they read the same in full or half widths; here all
    widths are halves). ``m`` counts the dimensions with ``S_j != 0``; a dimension with
    ``S_j = 0`` does not affect the output and gets an infinite allowance. Round trip:
    :func:`worst_case_band` (resp. :func:`rss_band`) of the result is ``allowed_half``.

    Args:
        S_row: Sensitivities of one output [output/dimension], shape ``(n_dim,)``.
        allowed_half: Allowed output half band ``T_max/2`` [output units], finite, >= 0.
        method: ``"worst"`` (worst-case stack-up) or ``"rss"`` (statistical).

    Returns:
        Half tolerances ``T_j/2`` [m], shape ``(n_dim,)``; ``inf`` where ``S_j = 0``.
    """
    s = _sensitivities(S_row)
    if s.ndim != 1:
        raise ToleranceInputError(S_row, f"S_row must have shape (n_dim,), got {s.shape}")
    allowed = _scalar(allowed_half, "allowed_half")
    if method not in ("worst", "rss"):
        raise ToleranceInputError(method, 'method must be "worst" or "rss"')
    seen = s != 0.0
    m = int(np.count_nonzero(seen))
    out = np.full(s.shape, np.inf)
    if m:
        share = allowed / m if method == "worst" else allowed / math.sqrt(m)
        out[seen] = share / np.abs(s[seen])
    return out


# --------------------------------------------------------------------------------------------
# Confidence
# --------------------------------------------------------------------------------------------


def gamma_from_confidence(p: float) -> float:
    r"""Two-sided standard-normal quantile ``gamma`` with ``P(|Z| <= gamma) = p`` [F].

    .. math:: \gamma = \Phi^{-1}\left(\frac{1 + p}{2}\right) = -\Phi^{-1}\left(\frac{1 - p}{2}\right)

    computed (not tabulated) with :class:`statistics.NormalDist`, through the lower tail for
    accuracy near ``p = 1``. [F] prints 2.96 / 2.58 / 2.17 / 1.96 for 99.7 / 99 / 97 / 95 %;
    the exact values are 2.9677 / 2.5758 / 2.1701 / 1.9600 (the paper's 2.96 is 2.97 rounded).

    Args:
        p: Confidence level [-], in [0, 1).

    Returns:
        ``gamma`` [-], >= 0.
    """
    level = _scalar(p, "p (confidence level)")
    if level >= 1.0:
        raise ToleranceInputError(p, "p (confidence level) must be in [0, 1)")
    return abs(_STANDARD_NORMAL.inv_cdf((1.0 - level) / 2.0))


def confidence_from_gamma(gamma: float) -> float:
    r"""Two-sided confidence ``p = P(|Z| <= gamma) = erf(gamma / sqrt(2))`` [F].

    Args:
        gamma: Quantile [-], >= 0 (``inf`` gives 1).

    Returns:
        ``p`` [-], in [0, 1].
    """
    g = _scalar(gamma, "gamma", allow_inf=True)
    return math.erf(g / math.sqrt(2.0))


def gamma_for_admissible(admissible_half: float, rss_half_band: float) -> float:
    r"""Confidence factor of an admissible output error, as in the example of [F].

    With every process spread equal to its tolerance (``6 sigma_j = T_j``) the RSS half band is
    ``3 sigma`` of the output, so an admissible half error ``T_max/2`` is ``gamma`` output
    standard deviations:

    .. math:: \gamma = \frac{T_{max}/2}{\sigma} = \frac{3 \, T_{max}/2}{\text{RSS band}}

    Example of [F]: ``3 * 55 um / 86.02 um = 1.92`` (IT10), a confidence under 95 %.

    Args:
        admissible_half: Admissible output half error ``T_max/2`` [output units], >= 0.
        rss_half_band: RSS half band of the output (:func:`rss_band`) [output units], >= 0.

    Returns:
        ``gamma`` [-] (``inf`` for a zero RSS band).
    """
    admissible = _scalar(admissible_half, "admissible_half")
    band = _scalar(rss_half_band, "rss_half_band")
    return math.inf if band == 0.0 else 3.0 * admissible / band


def confidence_for_admissible(admissible_half: float, rss_half_band: float) -> float:
    """Confidence ``p`` [-] that the output error stays within ``+/- admissible_half``.

    ``confidence_from_gamma(gamma_for_admissible(admissible_half, rss_half_band))``; same
    arguments and units as :func:`gamma_for_admissible`.
    """
    return confidence_from_gamma(gamma_for_admissible(admissible_half, rss_half_band))


# --------------------------------------------------------------------------------------------
# Monte Carlo helpers
# --------------------------------------------------------------------------------------------


def monte_carlo_inputs(
    rng: np.random.Generator,
    half_tol: ArrayLike,
    n: int,
    distribution: Literal["uniform", "normal"] = "uniform",
) -> NDArray[np.float64]:
    """Random dimension deviations ``dd`` for a Monte Carlo check of the linear bands.

    - ``"uniform"``: ``dd_j ~ U(-T_j/2, T_j/2)``; every sample lies inside the worst-case band.
    - ``"normal"``: ``dd_j ~ N(0, sigma_j^2)`` with ``6 sigma_j = T_j``, i.e.
      ``sigma_j = half_tol_j / 3``; the output's ``3 sigma`` then matches :func:`rss_band`.

    Args:
        rng: Random generator (seed it for reproducible runs).
        half_tol: Half tolerances ``T_j/2`` [m], shape ``(n_dim,)``, finite, >= 0.
        n: Number of samples, >= 1.
        distribution: ``"uniform"`` or ``"normal"``.

    Returns:
        Samples [m], shape ``(n, n_dim)``.
    """
    if not isinstance(rng, np.random.Generator):
        raise ToleranceInputError(rng, "rng must be a numpy.random.Generator")
    h = _half_tolerances(half_tol, allow_inf=False)
    count = _count(n, "n", 1)
    if distribution == "uniform":
        return rng.uniform(-1.0, 1.0, size=(count, h.size)) * h
    if distribution == "normal":
        return rng.standard_normal(size=(count, h.size)) * (h / 3.0)
    raise ToleranceInputError(distribution, 'distribution must be "uniform" or "normal"')


def sampling_error_of_3sigma(n: int) -> float:
    r"""Relative standard error of a ``3 sigma`` estimated from ``n`` normal samples.

    The sample standard deviation ``s`` of ``n`` normal samples has, to first order,
    ``std(s) = sigma / sqrt(2 (n - 1))``; scaling by 3 keeps the relative error:

    .. math:: \frac{\operatorname{std}(3 s)}{3 \sigma} \approx \frac{1}{\sqrt{2 (n - 1)}}

    Use it to compare :func:`rss_band` with a Monte Carlo ``3 s`` (e.g. within 4 of these).

    Args:
        n: Number of samples, >= 2.

    Returns:
        Relative standard error [-].
    """
    count = _count(n, "n", 2)
    return 1.0 / math.sqrt(2.0 * (count - 1))
