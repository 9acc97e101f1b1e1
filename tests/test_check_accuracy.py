"""The tolerance terms of a reading: each rule on its own, and coal's measured accuracy."""

from __future__ import annotations

import math
from types import SimpleNamespace

import coal
import numpy as np
import pinocchio as pin
import pytest

from clearance_pin.check.accuracy import (
    ROUNDING,
    SUPPORT_INFLATION,
    Tolerance,
    coal_accuracy,
    rim_excess,
    solver_accuracy,
)
from clearance_pin.check.geometry import cyclic_rotation, distance_request


def test_total_is_the_sum_of_the_terms():
    """The tolerance is faceting + rim + solver + coal, and terms() lists them."""
    tolerance = Tolerance(faceting=1.0, solver=0.25, coal=0.125, rim=0.5)
    assert tolerance.total == 1.875
    assert tolerance.terms() == {"faceting": 1.0, "rim": 0.5, "solver": 0.25, "coal": 0.125}


@pytest.mark.parametrize("bad", [-1e-12, math.nan, math.inf])
def test_terms_must_be_finite_and_nonnegative(bad):
    """A negative or non-finite term is refused, naming it."""
    with pytest.raises(ValueError, match="solver"):
        Tolerance(faceting=0.0, solver=bad, coal=0.0)


def test_solver_rule():
    """solver = c max(stationarity, feasibility, max_violation_rel) + closure + |gap| (contacts)."""
    equilibrium = SimpleNamespace(
        residuals={
            "stationarity": 1e-12,
            "feasibility": 3e-12,
            "max_violation_rel": -0.0,
            "closure": 2e-18,
        }
    )
    c = 1e-4
    assert math.isclose(solver_accuracy(equilibrium, c), 3e-16 + 2e-18)
    assert math.isclose(solver_accuracy(equilibrium, c, gap=-5e-17, contact=True), 3.52e-16)
    assert math.isclose(solver_accuracy(equilibrium, c, gap=5e-5, contact=False), 3.02e-16)


def test_coal_rule():
    """coal = (gjk + inflation if GJK runs on a box/cylinder) size + 16 eps |x|."""
    assert coal_accuracy(1e-12, 1e-4, 0.5) == 1e-12 * 1e-4 + ROUNDING * 0.5
    assert coal_accuracy(1e-12, 1e-4, 0.5, inflated=True) == pytest.approx(
        (1e-12 + SUPPORT_INFLATION) * 1e-4 + ROUNDING * 0.5, rel=1e-15
    )


@pytest.mark.parametrize("theta", [1e-7, 1e-4, 1e-2, 0.5])
def test_rim_excess_is_r_one_minus_cos(theta):
    """A journal tilted by theta about any axis across it: R (1 - cos theta) = 2 R sin^2(theta/2),
    with its digits kept for tiny tilts."""
    radius = 1e-3
    for axis in ([0.0, 1.0, 0.0], [0.0, 0.6, 0.8]):
        rotation = pin.exp3(theta * np.array(axis))
        expected = 2.0 * radius * math.sin(0.5 * theta) ** 2
        assert math.isclose(rim_excess(radius, rotation), expected, rel_tol=1e-12)
    spin = pin.exp3(np.array([0.7, 0.0, 0.0]))
    assert rim_excess(radius, spin) == 0.0


@pytest.mark.parametrize("radius", [1e-3, 1e-1])
def test_support_inflation_bounds_coal_on_a_cylinder(radius):
    """Measured: coal reads a cylinder's distance to a flat face short by about 1e-10 of the
    shapes' size (its support inflation), within the stated coal accuracy."""
    gap = 1e-4
    request, result = distance_request(1e-12), coal.DistanceResult()
    cylinder = coal.Cylinder(radius, 0.04)
    box = coal.Box(0.2, 0.2, 0.2)
    reading = coal.distance(
        box,
        coal.Transform3s(np.eye(3), np.array([0.0, radius + gap + 0.1, 0.0])),
        cylinder,
        coal.Transform3s(cyclic_rotation(0), np.zeros(3)),
        request,
        result,
    )
    size = max(0.2, radius)
    assert abs(reading - gap) <= coal_accuracy(1e-12, size, 0.3, inflated=True)
    assert abs(reading - gap) > 1e-12 * size  # the inflation is real, not below the GJK tolerance
