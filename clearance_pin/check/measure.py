"""coal's distance calls of one check: one request, timed and counted, errors re-raised as ours."""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from types import ModuleType
from typing import TYPE_CHECKING, Any, TypeAlias, TypeVar

import numpy as np
import pinocchio as pin

from ..errors import ClearancePinError
from .geometry import distance_request

if TYPE_CHECKING:
    import coal

#: a world placement: a pin.SE3, or (rotation (3, 3), translation (3,))
WorldPlacement: TypeAlias = "pin.SE3 | tuple[np.ndarray, np.ndarray]"
_Built = TypeVar("_Built")

FAILED = 1e30
"""A reading this large [m] is coal's failure value (it returns -DBL_MAX when GJK breaks down)."""


class Probe:
    """Asks coal for signed distances between shapes placed in the world.

    Attributes:
        gjk_tolerance: GJK/EPA tolerance of every request (relative).
        coal_time: wall time spent inside coal's distance calls [s].
        build_time: wall time spent building shapes through :meth:`build` [s].
        count: number of distance calls.
    """

    def __init__(self, gjk_tolerance: float) -> None:
        import coal

        self._coal: ModuleType = coal
        self.gjk_tolerance = gjk_tolerance
        self.request = distance_request(gjk_tolerance)
        self.result = coal.DistanceResult()
        self.coal_time = 0.0
        self.build_time = 0.0
        self.count = 0

    def build(self, function: Callable[..., _Built], *args: Any) -> _Built:
        """``function(*args)``, its time added to :attr:`build_time`."""
        started = time.perf_counter()
        built = function(*args)
        self.build_time += time.perf_counter() - started
        return built

    def distance(
        self,
        shape_1: coal.CollisionGeometry | coal.ComputeDistance,
        oM_1: WorldPlacement,
        shape_2: coal.CollisionGeometry | None,
        oM_2: WorldPlacement,
        label: str,
    ) -> float:
        """coal's signed distance [m] between two shapes at world placements (negative: overlap).

        Args:
            shape_1, shape_2: coal geometries; or ``shape_1`` a ``coal.ComputeDistance`` functor
                built on the pair and ``shape_2`` None.
            oM_1, oM_2: their world placements: pin.SE3, or (rotation (3, 3), translation (3,)).
            label: the reading's name, for the error message.
        """
        coal = self._coal
        transform_1, transform_2 = _transform(coal, oM_1), _transform(coal, oM_2)
        self.result.clear()
        started = time.perf_counter()
        try:
            if shape_2 is None:
                value = shape_1(transform_1, transform_2, self.request, self.result)
            else:
                value = coal.distance(
                    shape_1, transform_1, shape_2, transform_2, self.request, self.result
                )
        except (RuntimeError, ValueError) as exc:
            raise ClearancePinError(f"coal could not measure {label}: {exc}") from None
        self.coal_time += time.perf_counter() - started
        self.count += 1
        if not math.isfinite(value) or abs(value) > FAILED:
            raise ClearancePinError(f"coal could not measure {label}: it returned {value!r}")
        return float(value)


def _transform(coal: ModuleType, placement: WorldPlacement) -> coal.Transform3s:
    if isinstance(placement, pin.SE3):
        return coal.Transform3s(placement)
    return coal.Transform3s(*placement)


__all__ = ["Probe"]
