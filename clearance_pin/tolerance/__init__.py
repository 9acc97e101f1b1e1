r"""Kinematic position errors from dimensional tolerances (P. Flores 2011, [F]).

The shared math of the family. A mechanism with coordinates ``q`` and functional dimensions
``d`` obeys its constraints ``Phi(q, d) = 0`` (driving coordinates fixed). To first order

.. math::

    \Phi_q \, dq = -\Phi_d \, dd \quad\Rightarrow\quad dq = S \, dd, \qquad
    S = -\Phi_q^{-1} \Phi_d

with ``S`` [output/dimension] the sensitivities. A bilateral tolerance ``T_j`` puts
``dd_j`` in ``[-T_j/2, +T_j/2]``; every band in this package is a half width [m or rad]:

.. math::

    \text{worst case: } |dq_i| \le \sum_j |S_{ij}| \frac{T_j}{2}, \qquad
    \text{statistical (RSS): } |dq_i| \le \sqrt{\sum_j \left(S_{ij} \frac{T_j}{2}\right)^2}

With each process spread equal to its tolerance (``6 sigma_j = T_j``) the RSS band is the
output's ``3 sigma``; an admissible half error ``T_max/2`` is then ``gamma = 3 (T_max/2) /
RSS`` standard deviations, held with the two-sided confidence ``p = P(|Z| <= gamma)``.
Equal-effect allocation inverts the bands: ``T_j = T_max / (m |S_j|)`` (worst case) or
``T_max / (sqrt(m) |S_j|)`` (statistical). ISO 286-1 grades turn a grade and a nominal
size into ``T``.

Modules:

- :mod:`~clearance_pin.model.iso286`: the ISO 286-1 table IT01..IT18 up to 500 mm (read with the
  model's ``<dimension grade="IT10">``).
- :mod:`~clearance_pin.tolerance.statistics`: bands, allocation, confidence, Monte Carlo
  inputs.

Everything is SI inside; the ISO table keeps the standard's [um] and [mm] at its edge
(:func:`tolerance_m` is the SI accessor).

Source: P. Flores, "A methodology for quantifying the kinematic position errors due to
manufacturing and assembly tolerances", Strojniski vestnik - J. Mech. Eng. (2011).
"""

from ..model.dimensions import Dimension, parse_dimensions
from ..model.iso286 import (
    GRADES,
    ISO286_RANGES_MM,
    ToleranceInputError,
    size_range_index,
    table_um,
    tolerance_m,
    tolerance_um,
)
from .monte_carlo import MonteCarloResult, WorstCase, exact_worst_case, monte_carlo
from .sensitivity import Sensitivities, sensitivities
from .statistics import (
    confidence_for_admissible,
    confidence_from_gamma,
    equal_effect_allocation,
    gamma_for_admissible,
    gamma_from_confidence,
    monte_carlo_inputs,
    rss_band,
    sampling_error_of_3sigma,
    worst_case_band,
)
from .sweep import Budget, Sweep, clearance_budget, cycle_maximum, plot_sweep, sweep

__all__ = [
    "Dimension",
    "parse_dimensions",
    "Sensitivities",
    "sensitivities",
    "MonteCarloResult",
    "monte_carlo",
    "WorstCase",
    "exact_worst_case",
    "Sweep",
    "sweep",
    "cycle_maximum",
    "Budget",
    "clearance_budget",
    "plot_sweep",
    "GRADES",
    "ISO286_RANGES_MM",
    "ToleranceInputError",
    "confidence_for_admissible",
    "confidence_from_gamma",
    "equal_effect_allocation",
    "gamma_for_admissible",
    "gamma_from_confidence",
    "monte_carlo_inputs",
    "rss_band",
    "sampling_error_of_3sigma",
    "size_range_index",
    "table_um",
    "tolerance_m",
    "tolerance_um",
    "worst_case_band",
]
