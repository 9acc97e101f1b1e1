"""coal's distance calls: counted, timed, placements in either form, failures re-raised as ours."""

from __future__ import annotations

import coal
import numpy as np
import pinocchio as pin
import pytest

from clearance_pin.check.measure import Probe
from clearance_pin.errors import ClearancePinError


def test_placements_as_se3_or_pairs_agree_and_calls_are_counted():
    """A pin.SE3 and a (rotation, translation) pair give the same reading; each call is counted
    and its time added."""
    probe = Probe(1e-12)
    ball, dot = coal.Sphere(1e-4), coal.Sphere(0.0)
    frame = pin.SE3(pin.exp3(np.array([0.3, -0.2, 0.1])), np.array([0.2, 0.0, -0.1]))
    point = frame.act(np.array([3e-5, 0.0, 4e-5]))
    as_se3 = probe.distance(ball, frame, dot, pin.SE3(np.eye(3), point), "a")
    as_pair = probe.distance(
        ball, (frame.rotation, frame.translation), dot, (np.eye(3), point), "b"
    )
    assert as_se3 == as_pair == pytest.approx(-5e-5, abs=1e-16)
    assert probe.count == 2 and probe.coal_time > 0.0


def test_functor_path():
    """A coal.ComputeDistance functor (shape_2=None) reads the same as coal.distance."""
    probe = Probe(1e-12)
    ball, dot = coal.Sphere(1e-4), coal.Sphere(0.0)
    functor = coal.ComputeDistance(ball, dot)
    placement = (np.eye(3), np.array([0.0, 2e-4, 0.0]))
    identity = (np.eye(3), np.zeros(3))
    assert probe.distance(functor, identity, None, placement, "f") == pytest.approx(1e-4)


def test_coal_failures_name_the_reading():
    """coal's exceptions and its failure value (-DBL_MAX from a broken GJK) are re-raised as
    ClearancePinError naming the reading."""
    probe = Probe(1e-12)
    identity = (np.eye(3), np.zeros(3))

    def broken(*_):
        return -np.finfo(float).max

    def raising(*_):
        raise RuntimeError("not yet supported")

    with pytest.raises(ClearancePinError, match=r"I2:end\+.*-1.79"):
        probe.distance(broken, identity, None, identity, "I2:end+")
    with pytest.raises(ClearancePinError, match="I1:ball: not yet supported"):
        probe.distance(raising, identity, None, identity, "I1:ball")


def test_build_time_is_recorded():
    """Shapes built through the probe add their time to build_time."""
    probe = Probe(1e-12)
    shape = probe.build(coal.Sphere, 1.0)
    assert isinstance(shape, coal.Sphere) and probe.build_time > 0.0
