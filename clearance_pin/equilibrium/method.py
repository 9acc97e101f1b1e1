"""Which engine answered a solve (:attr:`~.result.Equilibrium.method`).

The small-displacement model has one optimum (docs/method.md section 3); the engines differ in how
they find its contact set, never in what they verify (:mod:`.residuals`, one verifier for all).
:mod:`.plan` chooses them from the problem's structure and the caller's options.
"""

from __future__ import annotations

from enum import StrEnum

NO_LOAD_STATUS = "no load works on any admissible motion"
"""The solver status of a :attr:`Method.NO_LOAD` answer."""


class Method(StrEnum):
    """The engine that found the contact set of an answer (its value is the name reports print).

    - ``CLOSED_FORM``: a tree whose joints are independent blocks, each solved in closed form
      (:mod:`.blocks`);
    - ``COMPILED``: the compiled active-set Newton (:mod:`.kernel`), from a recent answer or from
      the centred position;
    - ``NEWTON``: the NumPy active-set Newton from the previous answer (:mod:`.kkt`);
    - ``CLARABEL``, ``IPOPT``: the conic interior point, or IPOPT through CasADi, from the nominal
      position, then the active-set Newton polish;
    - ``NO_LOAD``: no load works on any admissible motion (status ``"indeterminate"``): nothing
      to solve, the nominal position is the answer;
    - ``EXACT_NEWTON``: the exact model's Newton from the linear answer's contact set
      (:mod:`.exact`);
    - ``EXACT_IPOPT``: the exact model's IPOPT solve, then its Newton polish.
    """

    CLOSED_FORM = "closed form"
    COMPILED = "compiled Newton"
    NEWTON = "Newton"
    CLARABEL = "clarabel"
    IPOPT = "ipopt"
    NO_LOAD = "no load"
    EXACT_NEWTON = "exact Newton"
    EXACT_IPOPT = "exact ipopt"


def backend_method(name: str) -> Method:
    """The :class:`Method` of a cold backend by its name (``"clarabel"``, ``"ipopt"``)."""
    return Method.CLARABEL if name == "clarabel" else Method.IPOPT


__all__ = ["NO_LOAD_STATUS", "Method", "backend_method"]
