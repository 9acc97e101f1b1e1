r"""Direction grids and the outer bound of the envelope over each cell of directions.

The directions of a k-dimensional envelope span (k = 2: a circle, k = 3: a sphere) are tiled by
*cells*: arcs between two directions, spherical triangles between three (an icosahedron split in
four, cells split in four again where they are refined, so the cells' cones always tile the
space). For a cell with unit vertex directions $w_1..w_k$ (the columns of $W$) and support values
$h_i = h_D(w_i)$, every deviation $\delta \in D$ whose direction lies in the cell's cone
$\{W\alpha,\ \alpha \ge 0\}$ satisfies $w_i \cdot \delta \le h_i$, hence lies in the polytope

.. math::  Q = \{ W \alpha : \alpha \ge 0,\ W^T W \alpha \le h \},

and the largest deviation in that cone is at most $U = \max_{Q} \lVert W\alpha \rVert$, the largest
norm over the vertices of $Q$ (a convex function's maximum over a polytope), found by enumerating
every choice of k active constraints among the 2k. $\max U$ over the cells bounds the largest
deviation from above; it tends to the maximum as the cells around the maximiser shrink (by
$O(\theta^2)$ for a cell of angular size $\theta$, and exactly once a corner's normal cone holds
a cell).
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import numpy.typing as npt

Vector = npt.NDArray[np.float64]
Cells = npt.NDArray[np.int64]
FEASIBLE_RTOL = 1e-12  # a vertex may miss a constraint by this share of the scale
TINY_CELL = 1e-6  # [rad] below this width a cell is bounded by max h / sqrt(cos theta)


def circle(count: int) -> tuple[Vector, Cells]:
    """``count`` equally spaced unit directions of the plane (count, 2) and the arcs between
    consecutive ones (count, 2)."""
    angles = 2.0 * np.pi * np.arange(count) / count
    directions = np.column_stack([np.cos(angles), np.sin(angles)])
    cells = np.column_stack([np.arange(count), (np.arange(count) + 1) % count])
    return directions, cells.astype(np.int64)


def icosphere(level: int) -> tuple[Vector, Cells]:
    """Unit directions (N, 3) and triangles (M, 3) of an icosahedron split ``level`` times in
    four (level 0: 12 directions, 20 triangles; level 1: 42, 80; level 2: 162, 320)."""
    t = (1.0 + 5.0**0.5) / 2.0
    vertices = [
        (-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t),
        (0, -1, -t), (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1),
    ]  # fmt: skip
    faces = [
        (0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
        (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
        (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1),
    ]  # fmt: skip
    points = [np.array(v, dtype=float) / np.linalg.norm(v) for v in vertices]
    triangles = np.array(faces, dtype=np.int64)
    for _ in range(level):
        midpoints: dict[tuple[int, int], int] = {}
        triangles = split(triangles, points, midpoints)
    return np.array(points), triangles


def split(triangles: Cells, points: list[Vector], midpoints: dict[tuple[int, int], int]) -> Cells:
    """Each triangle in four by its edges' normalised midpoints (appended to ``points``, shared
    through ``midpoints``); returns the new triangles (4 M, 3)."""

    def middle(a: int, b: int) -> int:
        key = (min(a, b), max(a, b))
        if key not in midpoints:
            m = points[a] + points[b]
            points.append(m / np.linalg.norm(m))
            midpoints[key] = len(points) - 1
        return midpoints[key]

    out = []
    for a, b, c in triangles:
        ab, bc, ca = middle(int(a), int(b)), middle(int(b), int(c)), middle(int(c), int(a))
        out += [(a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca)]
    return np.array(out, dtype=np.int64).reshape(-1, 3)


def split_arcs(arcs: Cells, points: list[Vector]) -> Cells:
    """Each arc in two by its normalised midpoint (appended to ``points``); (2 M, 2)."""
    out = []
    for a, b in arcs:
        m = points[int(a)] + points[int(b)]
        points.append(m / np.linalg.norm(m))
        out += [(a, len(points) - 1), (len(points) - 1, b)]
    return np.array(out, dtype=np.int64).reshape(-1, 2)


def cell_bounds(directions: Vector, values: Vector, cells: Cells) -> Vector:
    r"""Upper bound $U$ of the deviation's norm over each cell's cone (module docstring).

    The vertices of $Q$ are found in deviation space: $Q$ is $\{\delta : n_i \cdot \delta \ge 0,\
    w_i \cdot \delta \le h_i\}$ with $n_i$ the inner normal of the cone's face opposite $w_i$;
    each choice of k of these 2k constraints held with equality gives a candidate, kept when it
    meets the others (to :data:`FEASIBLE_RTOL` of the largest support value).

    Args:
        directions: unit directions (N, k) in span coordinates, k = 2 or 3.
        values: support values $h$ (N,) at them, >= 0.
        cells: vertex indices (M, k); each cell spans less than a half space.

    Returns:
        (M,) bounds [m or rad].
    """
    k = cells.shape[1]
    w = directions[cells]  # (M, k, k): row i = vertex direction i
    h = values[cells]  # (M, k)
    normals = _face_normals(w)
    scale = max(float(np.max(np.abs(values), initial=0.0)), 1e-300)
    rows_all = np.concatenate([normals, w], axis=1)  # (M, 2k, k): faces then planes
    rhs_all = np.concatenate([np.zeros_like(h), h], axis=1)
    best = np.zeros(cells.shape[0])
    identity = np.eye(k)
    for active in itertools.combinations(range(2 * k), k):
        rows = rows_all[:, list(active)]
        rhs = rhs_all[:, list(active)]
        regular = np.abs(np.linalg.det(rows)) > 1e-15
        safe = np.where(regular[:, None, None], rows, identity[None])
        delta = np.linalg.solve(safe, rhs[..., None])[..., 0]
        slack = FEASIBLE_RTOL * scale
        inside = np.einsum("mij,mj->mi", normals, delta) >= -slack
        below = np.einsum("mij,mj->mi", w, delta) <= h + slack
        feasible = regular & np.all(inside, axis=1) & np.all(below, axis=1)
        norms = np.linalg.norm(delta, axis=1)
        best = np.where(feasible, np.maximum(best, norms), best)
    # a cell too small for the vertex systems to be told from singular ones: the cruder bound
    # max h / sqrt(cos theta) (theta its widest angle: |W alpha|^2 >= cos theta on the simplex)
    cosine = np.min(np.einsum("mik,mjk->mij", w, w), axis=(1, 2))
    crude = np.max(h, axis=1) / np.sqrt(np.clip(cosine, 1e-300, 1.0))
    return np.where(cosine > math.cos(TINY_CELL), crude, best)


def _face_normals(w: Vector) -> Vector:
    """Unit inner normals (M, k, k) of the cone faces: row i is normal to the face spanned by
    the other vertices, on the side of vertex i."""
    k = w.shape[1]
    if k == 2:
        normals = np.stack([w[:, 1] @ np.array([[0.0, 1.0], [-1.0, 0.0]])] * 2, axis=1)
        normals[:, 1] = w[:, 0] @ np.array([[0.0, 1.0], [-1.0, 0.0]])
    else:
        normals = np.stack(
            [np.cross(w[:, 1], w[:, 2]), np.cross(w[:, 2], w[:, 0]), np.cross(w[:, 0], w[:, 1])],
            axis=1,
        )
    side = np.sign(np.einsum("mij,mij->mi", normals, w))
    normals = normals * np.where(side == 0.0, 1.0, side)[..., None]
    return np.asarray(normals / np.linalg.norm(normals, axis=2, keepdims=True), dtype=float)
