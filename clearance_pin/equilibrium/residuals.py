"""The residuals an answer carries, measured by the library itself, and the test they must pass.

A solver's status is no proof. Every answer is checked on the quantities of its own formulation:

- KKT (dimensionless, on the clearance-scaled problem): ``stationarity``, ``feasibility``,
  ``complementarity``, ``dual_infeasibility`` (a contact pulling);
- ``statics``: what the loads and the reported contact forces leave unbalanced in every joint
  direction, forces [N] and moments over the length scale [N m / L] alike whatever the joint's
  play, relative to the load (:meth:`.prepared.PreparedGeometry.statics_residual`; the compiled
  kernel and the exact model measure the same);
- ``max_violation_m`` [m] and ``max_violation_rel`` (penetration, absolute and over the play) and
  ``clearance_m`` [m] (the largest play, the scale of the closure test);
- small-displacement model: ``closure_conditioning`` (how close the loops are to a toggle
  position) and ``largest_rotation_rad`` [rad];
- exact model: ``closure`` (the largest loop equation [m or rad], redundant ones included) and
  ``held_by_gauge`` (what holding the motions the linear model leaves free takes at the solved
  pose, as a share of the load weighed like ``statics``: those motions are held where the linear
  answer puts them, as whatever drives them would, docs/method.md section 4; a reported
  quantity, not an imbalance: the reactions carry it as their ``held`` part);
- ``exact="auto"``: ``second_order_m`` [m], the estimated exact - linear difference at the
  outputs;
- ``unblocked_load``: the share of the load along motions nothing blocks that the answer neglects
  (at most 1e-9 of the load; a larger share has no equilibrium: UnboundedLoadError). It is not
  always round-off: a load component of 1e-9 of the load is neglected too, and shows here. The
  closed forms report here too the share left on a joint whose contacts would carry less than
  1e-9 of the largest force (the joint left at the centre of its play).

A quantity a formulation does not measure is None (not 0): :meth:`Residuals.ok` says which ones
each test needs.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass, fields
from typing import Any

from ..errors import NotFoundError

STATICS_TOLERANCE = 1e-8
FEASIBILITY_TOLERANCE = 1e-9
DUAL_TOLERANCE = 1e-8


@dataclass(frozen=True)
class Tolerances:
    """What a verified answer must meet.

    Attributes:
        feasibility: largest penetration over the play (dimensionless).
        statics: largest relative statics residual (dimensionless).
        dual: largest pulling multiplier (dimensionless).
        closure: largest loop equation over the largest play (exact model; dimensionless).
    """

    feasibility: float = FEASIBILITY_TOLERANCE
    statics: float = STATICS_TOLERANCE
    dual: float = DUAL_TOLERANCE
    closure: float = FEASIBILITY_TOLERANCE


def verified(
    statics: Any, violation_rel: Any, dual: Any = 0.0, tolerances: Tolerances = Tolerances()
) -> Any:
    """The one verifier's test of the measured residuals, for one answer (floats) or a batch
    (arrays, element-wise): statics residual (relative to the load), penetration over the play
    and pulling multiplier each within :class:`Tolerances`. Every engine's answer passes it
    (:meth:`Residuals.ok` adds the exact model's closure check)."""
    return (
        (statics <= tolerances.statics)
        & (violation_rel <= tolerances.feasibility)
        & (dual <= tolerances.dual)
    )


@dataclass(frozen=True)
class Residuals(Mapping[str, float]):
    """Measured residuals of one answer (see the module docstring); read like a mapping of the
    quantities measured (``residuals["statics"]``, ``dict(residuals)``)."""

    stationarity: float = 0.0
    dual_infeasibility: float = 0.0
    statics: float = 0.0
    max_violation_m: float = 0.0
    max_violation_rel: float = 0.0
    clearance_m: float = 0.0
    feasibility: float | None = None
    complementarity: float | None = None
    closure_conditioning: float | None = None
    largest_rotation_rad: float | None = None
    closure: float | None = None
    held_by_gauge: float | None = None
    second_order_m: float | None = None
    unblocked_load: float | None = None

    @classmethod
    def of(cls, values: Mapping[str, float]) -> Residuals:
        """From a mapping of measured quantities (names of the fields)."""
        return cls(**{name: float(value) for name, value in values.items()})

    def ok(self, tolerances: Tolerances = Tolerances()) -> bool:
        """Every contact inside its play, the contact forces balancing the load, no contact
        pulling, and (exact model) the loops closed to ``tolerances.closure`` of the play."""
        closed = self.closure is None or self.closure <= tolerances.closure * max(
            self.clearance_m, 1e-12
        )
        measured = verified(
            self.statics, self.max_violation_rel, self.dual_infeasibility, tolerances
        )
        return bool(measured) and closed

    def to_dict(self) -> dict[str, float]:
        """The quantities measured, JSON-ready."""
        return self._measured()

    def _measured(self) -> dict[str, float]:
        return {f.name: v for f in fields(self) if (v := getattr(self, f.name)) is not None}

    def __getitem__(self, name: str) -> float:
        value = getattr(self, name, None) if name in _FIELDS else None  # (not every field's dict)
        if value is None:
            raise NotFoundError("residual", name, tuple(self._measured()))
        return float(value)

    def __contains__(self, name: object) -> bool:
        return name in _FIELDS and getattr(self, name) is not None

    def __iter__(self) -> Iterator[str]:
        return iter(self._measured())

    def __len__(self) -> int:
        return len(self._measured())


_FIELDS = frozenset(field.name for field in fields(Residuals))

__all__ = [
    "DUAL_TOLERANCE",
    "verified",
    "FEASIBILITY_TOLERANCE",
    "STATICS_TOLERANCE",
    "Residuals",
    "Tolerances",
]
