r"""coal shapes of the cross-check: clearance regions as solid primitives, journals in faceted bores.

**Point checks.** The clearance condition of a contact point (:class:`~clearance_pin.model.clearance.
ContactPoint`) says that the point of the child, nominally at :math:`r` in the parent's clearance
frame, stays in a region: a solid ball of radius :math:`c` about :math:`r` (three components,
``norm``), a solid cylinder of radius :math:`c` whose axis is the unbounded direction (two
components), or a slab of half-width :math:`c` (one component, ``abs``). coal computes the signed
distance of a point (``coal.Sphere(0)``) to these solids in closed form or by GJK/EPA: inside, it is
minus the depth, so the play the point has left is

.. math::  g_{coal} = -\operatorname{sd}(x, \mathcal{R}) = c - \|d_{sel}\| \quad\text{(ball, cylinder)},
           \qquad c - |d_i| \quad\text{(slab)}

with :math:`d` the point's displacement. The region is unbounded along the free directions; the
solid is a window of half-length :data:`WINDOW` clearances cut from it and centred, along those
directions only, on the point (so its caps never decide the distance and its size does not depend on
how far the part slid).

**Journal in a bore.** A journal of radius :math:`R` and length :math:`L` (the model's axis ends at
:math:`\pm L/2`) in a bore of radius :math:`R + c`. The bore is a mesh of ``N`` flat facets
*tangent* to the circle of radius :math:`R + c` (vertices at :math:`(R + c)/\cos(\pi/N)`), so the
faceted bore contains the round one and sits inside the round bore of the vertex radius: coal's
distance :math:`D_N` to the facets overestimates the distance :math:`D` to the round bore by at most
the faceting bound

.. math::  0 \le D_N - D \le (R + c)\,\bigl(1/\cos(\pi/N) - 1\bigr),

reached by a part that reaches a vertex. Sizes in [m].
"""

from __future__ import annotations

import math
from types import ModuleType
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import ArgumentError, UnsupportedError
from ..model.clearance import ContactPoint

if TYPE_CHECKING:
    import coal

    from ..model.mechanism_parts import MechanismParts as Mechanism

WINDOW = 2.0
"""Half-extent of a region's solid along its unbounded directions, in clearances."""

BORE_LENGTH = 2.0
"""Length of a generated bore, in journal lengths (centred on the journal's axial position)."""


def _coal() -> ModuleType:
    import coal

    module: ModuleType = coal
    return module


def cyclic_rotation(axis: int) -> np.ndarray:
    """Rotation (3, 3) taking coal's shape axis z onto the coordinate axis ``axis`` (0, 1, 2)."""
    rotation = np.zeros((3, 3))
    rotation[axis, 2] = 1.0
    rotation[(axis + 1) % 3, 0] = 1.0
    rotation[(axis + 2) % 3, 1] = 1.0
    return rotation


class Region:
    """The clearance region of one contact point as a coal solid, in the parent clearance frame.

    Attributes:
        point: the :class:`~clearance_pin.model.clearance.ContactPoint`.
        kind: ``"sphere"``, ``"cylinder"`` or ``"box"``.
        shape: the coal shape (radius or half-width = the clearance ``bound`` [m]).
        rotation: orientation (3, 3) of the shape in the clearance frame.
        free: the unbounded coordinate axes of the region (the window slides along them).
    """

    kind: str
    shape: coal.ShapeBase
    rotation: np.ndarray

    def __init__(self, point: ContactPoint) -> None:
        coal = _coal()
        self.point = point
        bound = point.bound
        bounded = tuple(sorted(point.components))
        self.free = tuple(i for i in range(3) if i not in bounded)
        self.nominal = np.asarray(point.point, dtype=float)
        window = 2.0 * WINDOW * bound
        if len(bounded) == 3 and point.shape == "norm":
            self.kind, self.shape, self.rotation = "sphere", coal.Sphere(bound), np.eye(3)
        elif len(bounded) == 2 and point.shape == "norm":
            self.kind = "cylinder"
            self.shape = coal.Cylinder(bound, window)
            self.rotation = cyclic_rotation(self.free[0])
        elif len(bounded) == 1:
            sides = np.full(3, window)
            sides[bounded[0]] = 2.0 * bound
            self.kind, self.shape, self.rotation = "box", coal.Box(*sides), np.eye(3)
        else:
            raise UnsupportedError(
                f"contact point {point.name!r}: no solid for components {point.components} "
                f"with shape {point.shape!r}"
            )

    def centre(self, local: np.ndarray) -> np.ndarray:
        """Centre (3,) of the window in the clearance frame [m] for the point at ``local``: the
        nominal point, moved along the free axes only."""
        centre = self.nominal.copy()
        for axis in self.free:
            centre[axis] = local[axis]
        return centre

    def placement(
        self, oR_c: np.ndarray, o_c: np.ndarray, x: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """World placement (rotation (3, 3), translation (3,)) of the solid for the point at
        world position ``x`` [m], the parent's clearance frame being at (``oR_c``, ``o_c``)."""
        centre = self.centre(oR_c.T @ (x - o_c))
        return oR_c @ self.rotation, oR_c @ centre + o_c


def point_shape() -> coal.Sphere:
    """A point for coal: a sphere of radius 0."""
    return _coal().Sphere(0.0)


def faceting_bound(radius: float, facets: int) -> float:
    r"""Largest excess [m] of the distance to ``facets`` facets tangent to a circle of ``radius``
    [m] over the distance to the circle: :math:`R\,(1/\cos(\pi/N) - 1)`."""
    if facets < 3:
        raise ArgumentError("facets", "a faceted bore of at least 3 facets", facets)
    return radius * (1.0 / math.cos(math.pi / facets) - 1.0)


def tangent_polygon(radius: float, facets: int) -> np.ndarray:
    """Vertices (N, 2) of the regular N-gon whose edges are tangent to the circle of ``radius``
    [m]; vertex k at angle 2 pi k / N, edge k (between vertices k and k+1) touching the circle at
    angle 2 pi (k + 1/2) / N."""
    angles = 2.0 * math.pi * np.arange(facets) / facets
    vertex_radius = radius / math.cos(math.pi / facets)
    return vertex_radius * np.column_stack([np.cos(angles), np.sin(angles)])


def bore_mesh(radius: float, facets: int, length: float) -> coal.BVHModelOBBRSS:
    """The inner surface of a bore along x, centred at the origin, as a coal BVH of triangles.

    Args:
        radius: radius [m] of the round bore the facets are tangent to.
        facets: number N of facets around.
        length: bore length [m] (open ends).

    Returns:
        ``coal.BVHModelOBBRSS`` with 2N vertices and 2N triangles.
    """
    coal = _coal()
    polygon = tangent_polygon(radius, facets)
    half = 0.5 * length
    vertices = np.vstack(
        [
            np.column_stack([np.full(facets, -half), polygon]),
            np.column_stack([np.full(facets, half), polygon]),
        ]
    )
    k = np.arange(facets)
    following = (k + 1) % facets
    triangles = np.vstack(
        [
            np.column_stack([k, following, k + facets]),
            np.column_stack([k + facets, following, following + facets]),
        ]
    )
    mesh = coal.BVHModelOBBRSS()
    mesh.beginModel(len(triangles), len(vertices))
    mesh.addVertices(vertices)
    mesh.addTriangles(triangles.astype(np.int64))
    mesh.endModel()
    return mesh


def journal_shape(radius: float, length: float) -> coal.Cylinder:
    """The journal: a solid coal cylinder of ``radius`` and ``length`` [m], axis z (rotate it with
    :func:`cyclic_rotation` (0) onto a clearance frame's x axis)."""
    return _coal().Cylinder(radius, length)


def distance_request(gjk_tolerance: float) -> coal.DistanceRequest:
    """A coal distance request with GJK and EPA tolerances set to ``gjk_tolerance`` (relative)."""
    coal = _coal()
    request = coal.DistanceRequest()
    request.gjk_tolerance = gjk_tolerance
    request.epa_tolerance = gjk_tolerance
    request.enable_signed_distance = True
    return request


def shape_cache(mechanism: Mechanism) -> dict[Any, Any]:
    """The mechanism's store of built coal shapes (regions, bores), created on first use.

    It lives in the mechanism's solver store, which is dropped on pickling and rebuilt on demand.
    """
    shapes: dict[Any, Any] = mechanism.cache.check_shapes
    return shapes


__all__ = [
    "WINDOW",
    "Region",
    "point_shape",
    "faceting_bound",
    "tangent_polygon",
    "bore_mesh",
    "journal_shape",
    "cyclic_rotation",
    "distance_request",
    "shape_cache",
]
