r"""Quasi-static equilibrium of parts in their joint clearances (docs/method.md section 2).

Shared math: the equilibrium minimises the potential of the loads
:math:`\mathcal{V} = -\sum (F\cdot U_P + C\cdot\Theta)` over the kinematically admissible
displacements, those that close every loop and keep every contact point inside its clearance set
(Younes, Dal Santo & Potiron). The small-displacement model is a convex cone programme
(:mod:`.reduction`, :mod:`.cone_solver`); the exact model places the parts by finite rigid motions
(:mod:`.exact`). Active constraints are the contacts; their multipliers are the contact forces.
"""

from .method import Method
from .result import Contact, Equilibrium

__all__ = ["Contact", "Equilibrium", "Method"]
