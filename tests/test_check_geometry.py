"""coal shapes of the cross-check: point-in-primitive readings and faceted bores against analytic gaps."""

from __future__ import annotations

import math

import coal
import numpy as np
import pinocchio as pin
import pytest

from clearance_pin.check.accuracy import coal_accuracy
from clearance_pin.check.geometry import (
    Region,
    bore_mesh,
    cyclic_rotation,
    distance_request,
    faceting_bound,
    journal_shape,
    point_shape,
    tangent_polygon,
)
from clearance_pin.model.clearance import Clearance

C = 1e-4  # clearance [m]
R = 10 * C  # journal radius [m]
L = 0.04  # journal length [m]
POINTS = {
    "ball": Clearance("spherical", C).contacts[0],
    "end+": Clearance("cylindrical", C, length=L).contacts[1],
    "axial": Clearance("revolute", 2 * C, length=L, axial=C).contacts[2],
    "corner.z": Clearance("prismatic", C, length=L, width=0.01, height=0.01).contacts[1],
}


def _reading(region: Region, oM_c: pin.SE3, x: np.ndarray) -> float:
    """coal's signed distance of the point x (world) to the region placed on frame oM_c."""
    request, result = distance_request(1e-12), coal.DistanceResult()
    rotation, translation = region.placement(oM_c.rotation, oM_c.translation, x)
    return coal.distance(
        region.shape,
        coal.Transform3s(rotation, translation),
        point_shape(),
        coal.Transform3s(np.eye(3), x),
        request,
        result,
    )


def _analytic_gap(point, d: np.ndarray) -> float:
    selected = d[list(point.components)]
    reach = np.linalg.norm(selected) if point.shape == "norm" else abs(selected[0])
    return point.bound - float(reach)


def _random_readings(point, seed: int, slide: float, count: int = 300):
    """(analytic gap, coal's signed distance, |x|) for random placements of the point."""
    rng = np.random.default_rng(seed)
    region = Region(point)
    r = np.asarray(point.point)
    for _ in range(count):
        oM_c = pin.SE3(pin.exp3(rng.normal(size=3)), rng.uniform(-0.05, 0.05, 3))
        d = np.zeros(3)
        d[list(point.components)] = rng.uniform(-1.3, 1.3, len(point.components)) * point.bound
        for axis in region.free:
            d[axis] = rng.uniform(-slide, slide)
        x = oM_c.act(r + d)
        yield _analytic_gap(point, d), _reading(region, oM_c, x), float(np.linalg.norm(x))


@pytest.mark.parametrize("name", sorted(POINTS))
def test_point_in_primitive_reads_the_analytic_gap(name):
    """coal's point-vs-primitive signed distance is minus the analytic gap (inside: negative,
    outside: positive) to 1e-12 of the clearance, for random frames and points within 0.1 m of
    the origin and displacements of the bounded components up to 1.3 c."""
    point = POINTS[name]
    for gap, signed, _ in _random_readings(point, 7, slide=0.02):
        assert abs(-signed - gap) <= 1e-12 * point.bound, (name, gap, signed)
        if abs(gap) > 1e-9 * point.bound:
            assert np.sign(signed) == -np.sign(gap)


@pytest.mark.parametrize("name", sorted(POINTS))
def test_far_points_within_the_stated_coal_accuracy(name):
    """Points slid up to 1 m along their free axes (the window follows them): the reading stays
    within the stated coal accuracy, gjk_tolerance * c + 16 eps |x|."""
    point = POINTS[name]
    for gap, signed, position in _random_readings(point, 11, slide=1.0):
        assert abs(-signed - gap) <= coal_accuracy(1e-12, point.bound, position)


def test_region_kinds():
    """A ball condition is a sphere, a disc condition a cylinder along the free axis, a slab a box
    of half-width c across its bounded axis."""
    assert Region(POINTS["ball"]).kind == "sphere"
    cylinder = Region(POINTS["end+"])
    assert cylinder.kind == "cylinder" and cylinder.free == (0,)
    assert np.allclose(cylinder.rotation[:, 2], [1.0, 0.0, 0.0])
    box = Region(POINTS["axial"])
    assert box.kind == "box" and np.isclose(box.shape.halfSide[0], C)


def test_cyclic_rotation_is_a_rotation_onto_the_axis():
    """cyclic_rotation(a) is a proper rotation whose third column is the unit axis a."""
    for axis in range(3):
        rotation = cyclic_rotation(axis)
        assert np.allclose(rotation @ rotation.T, np.eye(3))
        assert np.isclose(np.linalg.det(rotation), 1.0)
        assert np.allclose(rotation[:, 2], np.eye(3)[axis])


@pytest.mark.parametrize("facets", [8, 64, 512])
def test_tangent_polygon_edges_touch_the_circle(facets):
    """The bore's facets are tangent to the circle: edge midpoints at radius R + c, vertices at
    (R + c)/cos(pi/N), i.e. the faceting bound outside it."""
    polygon = tangent_polygon(R + C, facets)
    midpoints = 0.5 * (polygon + np.roll(polygon, -1, axis=0))
    assert np.allclose(np.linalg.norm(midpoints, axis=1), R + C, rtol=1e-14, atol=0)
    vertex = np.linalg.norm(polygon, axis=1)
    assert np.allclose(vertex - (R + C), faceting_bound(R + C, facets), rtol=1e-9, atol=0)


def _journal_distance(bore, offset, rotation=None) -> float:
    rotation = np.eye(3) if rotation is None else rotation
    request, result = distance_request(1e-12), coal.DistanceResult()
    journal = journal_shape(R, L)
    return coal.distance(
        bore,
        coal.Transform3s(),
        journal,
        coal.Transform3s(rotation @ cyclic_rotation(0), np.asarray(offset, float)),
        request,
        result,
    )


@pytest.mark.parametrize("facets", [16, 64, 256])
def test_faceting_bound_against_a_centred_journal(facets):
    """A centred journal reads the clearance c (the facets are tangent: no excess); displaced by
    delta toward a vertex it reads c - delta cos(pi/N), toward a facet c - delta: the excess over
    the round bore, delta (1 - cos(pi/N)), lies within the faceting bound (R + c)(1/cos(pi/N) - 1).
    All to coal's stated accuracy for a cylinder (support inflated by 1e-10)."""
    bore = bore_mesh(R + C, facets, 2 * L)
    bound = faceting_bound(R + C, facets)
    accuracy = coal_accuracy(1e-12, max(L, R + C), L, inflated=True)
    assert abs(_journal_distance(bore, [0, 0, 0]) - C) <= accuracy
    delta = 0.8 * C
    vertex = np.array([0.0, 1.0, 0.0])  # vertex 0 lies on +y
    half_step = math.pi / facets
    facet = np.array([0.0, math.cos(half_step), math.sin(half_step)])
    toward_vertex = _journal_distance(bore, delta * vertex)
    toward_facet = _journal_distance(bore, delta * facet)
    assert abs(toward_vertex - (C - delta * math.cos(half_step))) <= accuracy
    assert abs(toward_facet - (C - delta)) <= accuracy
    assert 0.0 <= toward_vertex - (C - delta) <= bound


@pytest.mark.parametrize("facets", [16, 64, 256])
def test_faceting_bound_is_reached_at_a_vertex(facets):
    """The bound is tight: a point on a vertex ray at radius s reads (R + c) - s cos(pi/N), an
    excess s (1 - cos(pi/N)) over the round bore, which equals the bound at the vertex."""
    bore = bore_mesh(R + C, facets, 2 * L)
    request, result = distance_request(1e-12), coal.DistanceResult()
    vertex_radius = (R + C) / math.cos(math.pi / facets)
    for s in (0.5 * R, R, 0.999 * vertex_radius):
        reading = coal.distance(
            bore,
            coal.Transform3s(),
            point_shape(),
            coal.Transform3s(np.eye(3), np.array([0.0, s, 0.0])),
            request,
            result,
        )
        excess = reading - (R + C - s)
        assert abs(excess - s * (1.0 - math.cos(math.pi / facets))) <= 1e-12 * R
    assert math.isclose(
        vertex_radius * (1.0 - math.cos(math.pi / facets)), faceting_bound(R + C, facets)
    )


def _round_bore_gap(offset: np.ndarray, rotation: np.ndarray) -> float:
    """R + c minus the largest distance of the journal's end rims from the bore axis (dense)."""
    axis, e1, e2 = rotation[:, 0], rotation[:, 1], rotation[:, 2]
    phi = np.linspace(0.0, 2.0 * math.pi, 40001)
    reach = 0.0
    for end in (-0.5 * L, 0.5 * L):
        centre = offset + end * axis
        rim = centre[:, None] + R * (np.outer(e1, np.cos(phi)) + np.outer(e2, np.sin(phi)))
        reach = max(reach, float(np.max(np.hypot(rim[1], rim[2]))))
    return R + C - reach


@pytest.mark.parametrize("facets", [16, 64, 256])
def test_tilted_journal_within_the_faceting_bound(facets):
    """Random offsets (up to 0.9 c at the axis ends) and tilts: the faceted reading exceeds the
    round bore's gap by 0 to the faceting bound."""
    rng = np.random.default_rng(facets)
    bore = bore_mesh(R + C, facets, 2 * L)
    bound = faceting_bound(R + C, facets)
    for _ in range(20):
        tilt = rng.normal(size=2)
        tilt *= rng.uniform(0, 0.9) * C / (0.5 * L) / np.linalg.norm(tilt) / 2
        rotation = pin.exp3(np.array([rng.uniform(-3, 3), tilt[0], tilt[1]]))
        offset = np.r_[rng.uniform(-1e-3, 1e-3), rng.normal(size=2)]
        offset[1:] *= rng.uniform(0, 0.4) * C / np.linalg.norm(offset[1:])
        reading = _journal_distance(bore, offset, rotation)
        excess = reading - _round_bore_gap(offset, rotation)
        assert -1e-11 <= excess <= bound + 1e-11, (excess, bound)


def test_bore_mesh_size():
    """A bore of N facets has 2N vertices and 2N triangles."""
    bore = bore_mesh(R + C, 32, L)
    assert bore.num_vertices == 64 and bore.num_tris == 64


def test_faceting_bound_rejects_too_few_facets():
    """Fewer than 3 facets is not a bore."""
    with pytest.raises(ValueError, match="at least 3"):
        faceting_bound(1.0, 2)
