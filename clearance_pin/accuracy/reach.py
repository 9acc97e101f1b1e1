r"""The reach of an output: how far from its nominal place it can sit over the motions its load
leaves free (issue 33 item 2: indeterminacy is a band, never a silent zero).

A contact group that carries no load in a case (at most :data:`~clearance_pin.equilibrium.kkt.
UNLOADED` = 1e-9 of the case's largest contact multiplier, the single solve's rule for its
``free_motions``; a driven joint whose load torque is zero relative to the loads' torque scale
leaves its backlash slab free) does not fix where the part sits: the optimum is not unique and
the solver returns the centre of that play. The output can then be anywhere in

.. math::  \delta p = \delta p_0 + \sum_i D_i\, e_i, \qquad e_i \in [-c_i, c_i],

with :math:`\delta p_0` the settled displacement [m], :math:`e_i` the image of free contact row i
(a slab: the axial play :math:`\pm c_a`, the backlash :math:`\pm b/2` on its lever; a journal
end: its two radial components) and :math:`D_i` (3,) [m per m] the output's translation per unit
of it (the row's unknowns mapped to the joint's torsor, then by the joint's lever, as the map's
shares are). The reach is :math:`\max \lVert \delta p \rVert` over that box: a convex function
takes its maximum at a vertex, so the :math:`2^k` vertices are enumerated, the k free rows with
the largest :math:`c_i \lVert D_i \rVert` first; beyond :data:`VERTICES_LIMIT` rows the others
add :math:`\sum c_i \lVert D_i \rVert` (the triangle inequality: a sound upper bound). A free
journal end is a disc :math:`\lVert e \rVert \le c`: its enclosing square is used, an upper bound
(exact for slabs, at most :math:`\sqrt 2` too large on that end's share).
"""

from __future__ import annotations

import numpy as np

VERTICES_LIMIT = 10  # free rows enumerated exactly (2^10 vertices); the rest bounded


def row_directions(
    torsor_units: dict[str, np.ndarray], levers: dict[str, tuple[np.ndarray, np.ndarray]]
) -> np.ndarray:
    r"""The output's translation per unit image of each contact row, (Q, R, 3) [m per m]:
    :math:`D_r = \sum_j R_j t_{jr} + (R_j \omega_{jr}) \times (p - c_j)`, with ``torsor_units``
    joint -> (R, 6) its torsor per unit of each row and ``levers`` joint -> (axes (Q, 3, 3),
    arms (Q, 3)) (:func:`~clearance_pin.kinematics.joint_shares.joint_levers`)."""
    out: np.ndarray | None = None
    for name, (axes, arms) in levers.items():
        units = torsor_units[name]  # (R, 6)
        turned = units[:, 3:] @ axes.transpose(0, 2, 1)  # (Q, R, 3): R_q t_r as rows
        moved = units[:, :3] @ axes.transpose(0, 2, 1) + np.cross(turned, arms[:, None])
        out = moved if out is None else out + moved
    assert out is not None  # at least one joint moves the output
    return out


def reach(
    settled: np.ndarray,
    directions: np.ndarray,
    pose: np.ndarray,
    bounds: np.ndarray,
    free: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    r"""(the largest distance [m] of the output from its nominal place, the largest distance
    [m] the free motions alone move it from its settled place :math:`\max \lVert \sum_i D_i e_i
    \rVert`), each (N,): ``settled`` (N, 3) [m], ``directions`` (Q, R, 3)
    (:func:`row_directions`), ``pose`` (N,) each case's pose, ``bounds`` (R,) [m] the
    half-range of each row, ``free`` (N, R) the rows free in each case (module docstring)."""
    out: np.ndarray = np.sqrt((settled * settled).sum(axis=1))
    spread = np.zeros(len(settled))
    packed = np.ascontiguousarray(np.packbits(free, axis=1))  # each case's pattern as bytes
    keys = packed.view(np.dtype((np.void, packed.shape[1]))).ravel()
    _, first, which = np.unique(keys, return_index=True, return_inverse=True)
    order = np.argsort(which.reshape(-1), kind="stable")
    starts = np.searchsorted(which.reshape(-1)[order], np.arange(first.size + 1))
    for p, case in enumerate(first.tolist()):
        rows = np.flatnonzero(free[case])
        cases = order[starts[p] : starts[p + 1]]
        if not rows.size:
            continue
        columns = directions[pose[cases][:, None], rows[None, :]] * bounds[rows][None, :, None]
        bound = np.zeros(cases.size)
        if rows.size > VERTICES_LIMIT:  # the largest enumerated, the others bounded
            sizes = np.sqrt((columns * columns).sum(axis=2))
            ranked = np.argsort(-sizes, axis=1)
            columns = np.take_along_axis(columns, ranked[:, :, None], axis=1)
            bound = np.take_along_axis(sizes, ranked, axis=1)[:, VERTICES_LIMIT:].sum(axis=1)
            columns = columns[:, :VERTICES_LIMIT]
        k = columns.shape[1]
        signs = 1.0 - 2.0 * ((np.arange(2**k)[:, None] >> np.arange(k)) & 1)
        moved = signs @ columns  # (M, 2^k, 3): the free motions' vertices
        spread[cases] = np.sqrt((moved * moved).sum(axis=2).max(axis=1)) + bound
        vertices = settled[cases][:, None] + moved
        out[cases] = np.sqrt((vertices * vertices).sum(axis=2).max(axis=1)) + bound
    spread[~np.isfinite(out)] = np.nan
    return out, spread


__all__ = ["VERTICES_LIMIT", "reach", "row_directions"]
