r"""The tolerance of a cross-check reading, term by term (all terms [m], each >= 0).

.. math::  \tau = \tau_{facets} + \tau_{rim} + \tau_{solver} + \tau_{coal}

- :math:`\tau_{facets}`: the faceting bound of a meshed surface
  (:func:`~clearance_pin.check.geometry.faceting_bound`); 0 for the solid primitives of the point
  checks, which are exact.
- :math:`\tau_{rim}`: surface checks of a journal only: the journal's rim reaches past its axis end
  by at most :math:`R (1 - \cos\theta)` (:math:`\theta` the journal's tilt in the bore, :math:`R` its
  radius), so the real parts' gap lies in :math:`[g, g + R(1 - \cos\theta)]` around the model's gap
  :math:`g` of the axis ends. Exact geometry of the parts, not an allowance for a model error.
- :math:`\tau_{solver}` (rule): :math:`c\,\max(\text{stationarity}, \text{feasibility},
  \text{max\_violation\_rel}) + \text{closure} + |g|_{\text{predicted contact}}`: the optimiser's
  dimensionless residuals are on clearance-scaled unknowns, so times the clearance :math:`c` they are
  lengths; the exact model's loop closure residual is a length; and a point the solver declared in
  contact was left :math:`|g|` from its boundary (its own reported gap).
- :math:`\tau_{coal}` (rule): :math:`(\epsilon_{GJK} + \epsilon_{support})\, s + 16\,\epsilon_{mach}
  \|x\|`: coal's GJK/EPA relative tolerance times the size :math:`s` of the shapes (the clearance
  for a point check), plus the rounding of world coordinates of magnitude :math:`\|x\|` (the poses
  are composed in the world). :math:`\epsilon_{support} =` :data:`SUPPORT_INFLATION` counts only when
  GJK runs on boxes or cylinders (surface checks): coal inflates their support points by that
  relative amount to keep its simplices non-degenerate (measured: a journal cylinder of radius R
  in a bore reads :math:`10^{-10} R` short). The point checks use coal's closed-form
  sphere-sphere, sphere-cylinder and sphere-box distances, exact to rounding.

The faceting and rim terms of a generated bore are *one-sided* (``Tolerance.one_sided``): the
tangent facets and the journal's rim can only make the reading larger than the model's gap, so a
reading is accepted in :math:`[g - \tau_{solver} - \tau_{coal},\ g + \tau]`. Elsewhere the
tolerance is symmetric.

There is **no** term for the small-displacement model's own error: a linear pose measured as solved
(``pose="as_solved"``, or a report's ``departure``) that sits off the real boundary by more than
:math:`\tau` fails, and the report says by how much.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..errors import ArgumentError

if TYPE_CHECKING:
    from ..equilibrium.result import Equilibrium

ROUNDING = 16.0 * np.finfo(float).eps
"""Relative rounding of world coordinates allowed for (16 machine epsilons)."""

SUPPORT_INFLATION = 1e-10
"""Relative inflation of the support points of coal's boxes and cylinders in GJK."""


@dataclass(frozen=True)
class Tolerance:
    """The tolerance of one reading, term by term [m]."""

    faceting: float
    solver: float
    coal: float
    rim: float = 0.0
    one_sided: bool = False

    def __post_init__(self) -> None:
        for name in ("faceting", "solver", "coal", "rim"):
            value = getattr(self, name)
            if not np.isfinite(value) or value < 0.0:
                raise ArgumentError(f"Tolerance({name})", "a finite length >= 0 [m]", value)

    @property
    def total(self) -> float:
        """The sum of the terms [m]: how far above what it should read a reading may lie."""
        return self.faceting + self.rim + self.solver + self.coal

    @property
    def below(self) -> float:
        """How far below what it should read a reading may lie [m]: the total, or only the
        solver and coal terms when the faceting and rim terms are one-sided."""
        return self.solver + self.coal if self.one_sided else self.total

    def terms(self) -> dict[str, float]:
        """``{"faceting": ..., "rim": ..., "solver": ..., "coal": ...}`` [m]."""
        return {
            "faceting": self.faceting,
            "rim": self.rim,
            "solver": self.solver,
            "coal": self.coal,
        }


def solver_accuracy(
    equilibrium: Equilibrium, clearance: float, gap: float = 0.0, contact: bool = False
) -> float:
    """:math:`\\tau_{solver}` [m] for a reading on a clearance ``clearance`` [m] whose model gap is
    ``gap`` [m] (counted when the model predicts a ``contact``); see the module docstring."""
    residuals = equilibrium.residuals
    relative = max(
        residuals.get("stationarity", 0.0),
        residuals.get("feasibility", 0.0),
        residuals.get("max_violation_rel", 0.0),
        0.0,
    )
    term = clearance * relative + max(residuals.get("closure", 0.0), 0.0)
    if contact:
        term += abs(gap)
    return float(term)


def coal_accuracy(
    gjk_tolerance: float, size: float, position: float, inflated: bool = False
) -> float:
    """:math:`\\tau_{coal}` [m] for shapes of size ``size`` [m] at distance ``position`` [m] from
    the world origin; ``inflated``: GJK runs on a box or cylinder (adds :data:`SUPPORT_INFLATION`)."""
    relative = gjk_tolerance + (SUPPORT_INFLATION if inflated else 0.0)
    return float(relative * size + ROUNDING * position)


def rim_excess(radius: float, relative_rotation: np.ndarray) -> float:
    r""":math:`R (1 - \cos\theta)` [m], :math:`\theta` the angle between the journal's axis and the
    bore's (the x axes of the two clearance frames; ``relative_rotation`` (3, 3) is the journal's
    frame in the bore's), computed as :math:`\sin^2\theta / (1 + \cos\theta)` to keep its digits."""
    axis = np.asarray(relative_rotation)[:, 0]
    sine_squared = float(axis[1] ** 2 + axis[2] ** 2)
    cosine = float(axis[0])
    if cosine <= 0.0:
        return radius * (1.0 - cosine)
    return radius * sine_squared / (1.0 + cosine)


__all__ = [
    "Tolerance",
    "solver_accuracy",
    "coal_accuracy",
    "rim_excess",
    "ROUNDING",
    "SUPPORT_INFLATION",
]
