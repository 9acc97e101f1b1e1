r"""Closed forms of the small-displacement cone programme of a mechanism without loops.

Without loop joints every contact reads its own joint's torsor (docs/method.md 2.1-2.2), so the
programme of section 3 splits into independent problems. Per joint the contacts fall into
*groups* that share unknowns: the two ends of a journal (v, w, beta, gamma), its axial play (u),
a ball (u, v, w), a planar pin (v, w). With :math:`g_k` the x-space gradient of the potential on
the group's unknowns [J per unit] (minus the load's wrench on the child side at the joint centre,
in the clearance frame), and :math:`M` the group's contact rows (square and invertible, rows
:math:`e = M t` [m]), the energy of the group is :math:`g_k^T t = a^T e` with
:math:`a = M^{-T} g_k` [N]: a sum over the contacts of the group of :math:`a_j \cdot e_j`, each
bounded by itself. So each contact goes to its own boundary:

.. math::  e_j = -c_j\, a_j / \lVert a_j \rVert \ (\text{ball, disc}), \qquad
           e_j = -c_j\, \mathrm{sign}(a_j) \ (\text{slab}), \qquad t = M^{-1} e .

- spherical ball (u, v, w), :math:`\lVert (u, v, w) \rVert \le c`: :math:`a = g`, :math:`t = -c g/|g|`;
- planar pin (v, w) disc: :math:`(v, w) = -c\, g_{vw} / |g_{vw}|`;
- journal (revolute, cylindrical) of length L, ends at :math:`x = \mp L/2`:
  :math:`e_\mp = (v \mp \gamma L/2,\ w \pm \beta L/2)` (:meth:`ContactPoint.linear_rows`), so
  :math:`v = (e_{+y} + e_{-y})/2`, :math:`\gamma = (e_{+y} - e_{-y})/L`,
  :math:`w = (e_{+z} + e_{-z})/2`, :math:`\beta = (e_{-z} - e_{+z})/L` and

  .. math::  a_\pm = \big(g_v/2 \pm g_\gamma/L,\ \ g_w/2 \mp g_\beta/L\big),
             \qquad e_\pm = -c\, a_\pm / |a_\pm| ;

  the axial play :math:`u = -c_a\, \mathrm{sign}(g_u)`;
- a prismatic block with a width or a height has more corner slabs than unknowns: not separable,
  it keeps the general path (so does any group whose rows are not square and well conditioned).

The contact force of the parent on the child is :math:`f_j = a_j` [N] (statics: :math:`g = \sum_j
S_j^T f_j`), and the multipliers of the reduced programme (:mod:`.kkt`, :math:`\sigma` its objective
scale [J]) are :math:`\lambda_j = c_j \lVert a_j \rVert / (2 \sigma)` (ball, disc) and
:math:`c_j |a_j| / \sigma` (slab).

**Which cases the closed form decides.** The general path returns the minimum-norm point along the
directions the loaded contacts do not see (:meth:`.prepared.PreparedGeometry.flat_directions`;
a contact is loaded above UNLOADED = :math:`10^{-9}` of the largest multiplier). A group whose
contacts all carry at most half of that (nothing loads the joint, a journal's axial play under a
radial load, a load component at round-off) is such a direction in every metric: its unknowns
are 0, its forces 0 (what it drops must pass the stationarity test), and it is reported among
the free motions. A group whose contacts all carry more than twice that has a unique optimum
when its curvature is seen. Both verdicts of the general path's test (singular values of the
loaded gradients and of the Hessian above :math:`10^{-9}` of the largest) are guaranteed with a
factor 10 of margin by bounds: a loaded group's smallest singular value is at least
:math:`2 \min_j \lambda_j\, \sigma_{min}(P_g)^2` (ball, disc; :math:`P_g` the group's scaled
rows) or :math:`\sigma_{min}(P_g)` (slabs), an unloaded group's largest at most
:math:`\sum_j 2 \lambda_j \lVert P_j^T P_j \rVert_F`, and the largest of all lies between the
largest loaded gradient (:math:`\ge 2\sigma_{min}(P_j)` or :math:`\lVert p_j \rVert`) and the
largest group's Frobenius norm (the blocks are diagonal over the groups); the few cases these
bounds leave open are decided on the groups' singular values themselves (eigenvalues of
:math:`B_g^T B_g`, a few small matrices per case). Anything else (an
unloaded end of a loaded journal, a contact between the two shares) is left to the general path,
whose minimum-norm point there depends on the scaling.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from ..numerics import Array, Index, Mask
from .kkt import UNLOADED
from .reduction import ReducedGeometry

LOADED_SHARE = 2.0 * UNLOADED  # of the largest multiplier: loaded, with a margin of 2
NEGLIGIBLE_SHARE = 0.5 * UNLOADED  # of the largest multiplier: unloaded, with a margin of 2
FLAT_MARGIN = 1e-8  # seen: 10x above the general path's 1e-9 rank test of the flat directions
UNSEEN_MARGIN = 1e-10  # unseen: 10x below it
BASIS_ROUND_OFF = 1e-12  # the reduced basis and the free motions must lie on coordinates
GROUP_CONDITION = 1e10  # largest condition number of a group's rows (its closed form's inverse)


@dataclass(frozen=True)
class BlockStructure:
    """The groups of a tree geometry and the constant maps of their closed forms.

    Rows are the stacked contact rows of the geometry (:class:`~.kkt.StackedContacts` order).

    Attributes:
        size_x: number of unknowns n.
        gradient_to_rows: (n, R): :math:`a = g\\, A` (the blocks :math:`M^{-1}`).
        rows_to_x: (R, n): :math:`x = e\\, X` (the blocks :math:`M^{-T}`).
        row_bound: clearance of each row's contact [m], (R,).
        row_contact: contact of each row, (R,).
        row_sums: (R, m), 1.0 where row i belongs to contact j: sums over each contact's rows as
            one matrix product.
        starts: first row of each contact, (m,).
        is_norm: per contact, a ball or disc, (m,).
        bounds: clearance per contact [m], (m,).
        members: (m, G) 1.0 where contact j belongs to group g.
        group_order: the contacts sorted by group, (m,); group_starts: where each group starts
            in that order, (G,).
        group_size: contacts per group, (G,).
        group_is_norm: per group, balls or discs (else slabs), (G,).
        group_floor: per group, :math:`\\sigma_{min}(P_g)^2` (balls, discs) or
            :math:`\\sigma_{min}(P_g)` (slabs), (G,).
        gradient_size: per contact, an upper bound of its gradient's norm on the boundary,
            :math:`2 \\lVert P_j \\rVert_2` or :math:`\\lVert p_j \\rVert`, (m,).
        gradient_floor: per contact, a lower bound of it, :math:`2 \\sigma_{min}(P_j)` or
            :math:`\\lVert p_j \\rVert`, (m,).
        contact_group: the group of each contact, (m,).
        curvature_size: per contact, :math:`\\lVert P_j^T P_j \\rVert_F` (0 for a slab), (m,).
        group_columns: per group, its unknowns (columns of x).
        group_rows: per group, its rows; group_matrices: per group, its scaled rows
            :math:`P_g` (z = x / Z on its unknowns), for the exact rank test of borderline cases.
        basis: Q (n, r) of the geometry (y = Q^T x / Z); identity without free motions
            (``plain``).
        scale: Z (n,).
        norm_rows: per row, its contact is a ball or disc, (R,).
        multiplier_factor: per contact, c/2 (ball, disc) or c (slab) [m]: lambda = factor |a| /
            sigma, (m,).
    """

    size_x: int
    gradient_to_rows: Array
    rows_to_x: Array
    row_bound: Array
    row_contact: Index
    row_sums: Array
    starts: Index
    is_norm: Mask
    bounds: Array
    members: Array
    group_order: Index
    group_starts: Index
    group_size: Array
    group_is_norm: Mask
    group_floor: Array
    gradient_size: Array
    gradient_floor: Array
    contact_group: Index
    curvature_size: Array
    group_columns: tuple[Index, ...]
    group_rows: tuple[Index, ...]
    group_matrices: tuple[Array, ...]
    basis: Array
    scale: Array
    plain: bool
    norm_rows: Mask
    multiplier_factor: Array


@dataclass(frozen=True)
class ClosedForms:
    """The closed-form answers of N cases.

    Attributes:
        x: unknowns (N, n) [m, rad].
        multipliers: lambda_j (N, m), the reduced programme's (squared-norm form).
        signs: slab sides (N, m) (+1 for balls and discs, and for a slab at 0).
        decided: (N,) the closed form is the general path's answer (module docstring).
        unloaded: (N, G) groups left at zero, unloaded (the general path's flat directions).
    """

    x: Array
    multipliers: Array
    signs: Array
    decided: Mask
    unloaded: Mask

    FIELDS: ClassVar[tuple[str, ...]] = ("x", "multipliers", "signs", "decided", "unloaded")


_MISSING = object()


def block_structure(geometry: ReducedGeometry, loops: bool) -> BlockStructure | None:
    """The block structure of a tree geometry (memoised on it), or None when the closed forms do
    not apply: loop joints, a group whose rows are not square and well conditioned (a prismatic
    block with width or height), mixed ball/slab groups, or a reduction that does not lie on
    coordinates (free motions that are not whole unknowns)."""
    if loops:
        return None
    cached = geometry.__dict__.get("_blocks", _MISSING)
    if cached is _MISSING:
        cached = _build(geometry)
        # frozen dataclass: a derived, private cache (as small_displacement.tree_joint_basis)
        object.__setattr__(geometry, "_blocks", cached)
    return cached if isinstance(cached, BlockStructure) else None


def _build(geometry: ReducedGeometry) -> BlockStructure | None:
    contacts = geometry.contacts
    stack = geometry.stack
    scale = geometry.scale
    n = scale.size
    if not contacts or np.any(stack.offset != 0.0):
        return None
    rows = np.vstack([c.rows for c in contacts])
    row_bound = np.concatenate([np.full(c.rows.shape[0], c.contact.bound) for c in contacts])
    groups = _groups([np.flatnonzero(np.any(c.rows != 0.0, axis=0)) for c in contacts])
    seen = np.any(rows != 0.0, axis=0)
    if np.any(geometry.equalities[:, seen] != 0.0):
        # closure equations (a passive coupling's) tie unknowns that contacts read: no blocks;
        # one between joints without play (a gripper's coupled fingers) ties free motions only
        return None
    basis, free = geometry.basis, geometry.free_scaled
    if (
        basis.shape[1] != int(seen.sum())
        or np.abs(basis[~seen]).max(initial=0.0) > BASIS_ROUND_OFF
        or np.abs(free[seen]).max(initial=0.0) > BASIS_ROUND_OFF
    ):
        return None
    row_ranges = [np.arange(s, s + c.rows.shape[0]) for s, c in zip(stack.starts, contacts)]
    bounds = np.array([c.contact.bound for c in contacts])
    to_rows, to_x = np.zeros((n, rows.shape[0])), np.zeros((rows.shape[0], n))
    members = np.zeros((len(contacts), len(groups)))
    floors, norms = [], []
    gradient_size, curvature_size = np.zeros(len(contacts)), np.zeros(len(contacts))
    gradient_floor, contact_group = np.zeros(len(contacts)), np.zeros(len(contacts), np.intp)
    columns_of: list[Index] = []
    rows_of: list[Index] = []
    matrices: list[Array] = []
    for g, group in enumerate(groups):
        shapes = {contacts[j].contact.shape for j in group}
        group_rows = np.concatenate([row_ranges[j] for j in group])
        columns = np.flatnonzero(np.any(rows[group_rows] != 0.0, axis=0))
        block = rows[np.ix_(group_rows, columns)]
        if len(shapes) != 1 or block.shape[0] != block.shape[1]:
            return None
        if np.linalg.cond(block) > GROUP_CONDITION:
            return None
        inverse = np.linalg.inv(block)
        to_rows[np.ix_(columns, group_rows)] = inverse
        to_x[np.ix_(group_rows, columns)] = inverse.T
        scaled = block * scale[columns] / row_bound[group_rows][:, None]  # P_g (z-space)
        smallest = float(np.linalg.svd(scaled, compute_uv=False)[-1])
        is_norm = shapes == {"norm"}
        floors.append(smallest * smallest if is_norm else smallest)
        norms.append(is_norm)
        first = 0
        for j in group:
            members[j, g] = 1.0
            local = scaled[first : first + row_ranges[j].size]  # j's rows in the group
            first += row_ranges[j].size
            singular = np.linalg.svd(local, compute_uv=False)
            gradient_size[j] = 2.0 * singular[0] if is_norm else singular[0]
            gradient_floor[j] = 2.0 * singular[-1] if is_norm else singular[-1]
            contact_group[j] = g
            curvature_size[j] = float(np.linalg.norm(local.T @ local)) if is_norm else 0.0
        columns_of.append(columns.astype(np.intp))
        rows_of.append(group_rows.astype(np.intp))
        matrices.append(scaled)
    return BlockStructure(
        size_x=n,
        gradient_to_rows=to_rows,
        rows_to_x=to_x,
        row_bound=row_bound,
        row_contact=stack.row_contact.astype(np.intp),
        row_sums=(stack.row_contact[:, None] == np.arange(len(contacts))[None]).astype(float),
        starts=stack.starts.astype(np.intp),
        is_norm=stack.is_norm.copy(),
        bounds=bounds,
        members=members,
        group_order=np.concatenate([np.array(group, dtype=np.intp) for group in groups]),
        group_starts=np.cumsum([0] + [len(group) for group in groups[:-1]]).astype(np.intp),
        group_size=members.sum(axis=0),
        group_is_norm=np.array(norms, dtype=bool),
        group_floor=np.array(floors),
        gradient_size=gradient_size,
        gradient_floor=gradient_floor,
        contact_group=contact_group,
        curvature_size=curvature_size,
        group_columns=tuple(columns_of),
        group_rows=tuple(rows_of),
        group_matrices=tuple(matrices),
        basis=basis,
        scale=scale,
        plain=not free.shape[1] and np.array_equal(basis, np.eye(n)),
        norm_rows=stack.is_norm[stack.row_contact],
        multiplier_factor=np.where(stack.is_norm, 0.5, 1.0) * bounds,
    )


def _groups(columns: list[Index]) -> list[list[int]]:
    """Contacts joined into groups when they share an unknown (connected components)."""
    owner: dict[int, int] = {}
    parent = list(range(len(columns)))

    def root(j: int) -> int:
        while parent[j] != j:
            parent[j] = parent[parent[j]]
            j = parent[j]
        return j

    for j, cols in enumerate(columns):
        for column in cols.tolist():
            if column in owner:
                parent[root(j)] = root(owner[column])
            else:
                owner[column] = j
    found: dict[int, list[int]] = {}
    for j in range(len(columns)):
        found.setdefault(root(j), []).append(j)
    return list(found.values())


def closed_forms(structure: BlockStructure, gradients: Array, sigmas: Array) -> ClosedForms:
    """The closed forms of N cases (module docstring) from their x-space gradients g (N, n)
    [J per unit] and objective scales sigma (N,) [J]; ``decided`` marks the cases whose answer
    is the general path's (the others go to it)."""
    s = structure
    a = gradients @ s.gradient_to_rows  # (N, R) [N]: the energy is a . e
    sizes = np.sqrt((a * a) @ s.row_sums)  # (N, m): |a_j|
    sigma = np.where(sigmas > 0.0, sigmas, 1.0)[:, None]
    multipliers = sizes * (s.multiplier_factor / sigma)  # c/2 or c, over sigma
    largest = multipliers.max(axis=1, initial=0.0)[:, None]
    loaded = multipliers > LOADED_SHARE * largest
    negligible = multipliers <= NEGLIGIBLE_SHARE * largest
    all_loaded = loaded @ s.members == s.group_size  # (N, G)
    unloaded = negligible @ s.members == s.group_size
    decided = np.all(all_loaded | unloaded, axis=1) & (largest[:, 0] > 0.0)
    # e = -c a / |a| (N, R) [m]: for a slab (one row) that is -c sign(a); 0 where a = 0
    # np.take: a C-ordered gather (a [:, index] one is not, and slows the products after it)
    images = a * np.take(-s.bounds / np.where(sizes > 0.0, sizes, 1.0), s.row_contact, axis=1)
    clear = _unique(s, multipliers, loaded, all_loaded, unloaded)
    borderline = np.flatnonzero(decided & ~clear)
    clear[borderline] = _unique_exactly(
        s, images[borderline], multipliers[borderline], all_loaded[borderline]
    )
    decided &= clear
    if unloaded.any():  # the unloaded groups at the minimum-norm point: zero, no force
        kept = ~unloaded[:, s.contact_group]  # (N, m)
        multipliers = np.where(kept, multipliers, 0.0)
        images = np.where(kept[:, s.row_contact], images, 0.0)
    slab_side = np.take(images, s.starts, axis=1)
    signs = np.where(s.is_norm | (slab_side >= 0.0), 1.0, -1.0)
    return ClosedForms(images @ s.rows_to_x, multipliers, signs, decided, unloaded)


def _unique(
    s: BlockStructure, multipliers: Array, loaded: Mask, all_loaded: Mask, unloaded: Mask
) -> Mask:
    """Cases where the general path's flat test (singular values of the loaded gradients and
    the Hessian above 1e-9 of the largest) surely keeps every loaded group and surely drops
    every unloaded one: against the largest singular value's upper bound (the largest group's
    Frobenius norm: B = [G; H] is block diagonal over the groups, so its largest singular value
    is the largest of the groups') and lower bound (the largest loaded gradient), with a factor 10
    of margin either way."""
    curvature = multipliers @ (2.0 * s.curvature_size[:, None] * s.members)  # (N, G) >= |H_g|_F
    gradients = (loaded * s.gradient_size**2) @ s.members  # (N, G) >= |G_g|_F^2
    upper = np.sqrt((gradients + curvature * curvature).max(axis=1, initial=0.0))[:, None]
    lower = (loaded * s.gradient_floor).max(axis=1, initial=0.0)[:, None]
    ordered = np.take(multipliers, s.group_order, axis=1)
    smallest = np.minimum.reduceat(ordered, s.group_starts, axis=1)
    floor = np.where(s.group_is_norm, 2.0 * smallest * s.group_floor, s.group_floor)
    seen = floor > FLAT_MARGIN * upper
    unseen = curvature <= UNSEEN_MARGIN * lower  # slabs: no curvature, always unseen
    clear: Mask = np.all((seen | ~all_loaded) & (unseen | ~unloaded), axis=1)
    return clear


def _unique_exactly(s: BlockStructure, images: Array, multipliers: Array, loaded: Mask) -> Mask:
    """The general path's flat test for the K cases the bounds leave undecided, on each group's
    block :math:`B_g = [G_g; H_g]` (loaded gradients, Hessian): its singular values from the
    eigenvalues of :math:`B_g^T B_g`, a loaded group's smallest above FLAT_MARGIN of the largest
    of all groups, an unloaded group's largest below UNSEEN_MARGIN of it; images e (K, R) [m]."""
    count = images.shape[0]
    if not count:
        return np.zeros(0, dtype=bool)
    low = np.zeros((count, len(s.group_rows)))
    high = np.zeros((count, len(s.group_rows)))
    threshold = UNLOADED * multipliers.max(axis=1)[:, None, None]
    for groups, rows, contact, matrix, bound, is_norm, starts in _shape_classes(s):
        lam = multipliers[:, contact]  # (K, G', k): the groups of one shape at once
        counted = lam > threshold
        if is_norm:
            weights = np.where(counted, 2.0 * images[:, rows] / bound, 0.0)
        else:
            weights = np.where(counted, np.sign(images[:, rows]), 0.0)
        gradients = np.add.reduceat(weights[..., None] * matrix[None], starts, axis=2)
        gram = np.einsum("kgci,kgcj->kgij", gradients, gradients)
        if is_norm:
            hessian = np.einsum("gri,kgr,grj->kgij", matrix, 2.0 * lam, matrix)
            gram = gram + hessian @ hessian
        values = np.sqrt(np.maximum(np.linalg.eigvalsh(gram), 0.0))
        low[:, groups], high[:, groups] = values[..., 0], values[..., -1]
    largest = high.max(axis=1)[:, None]
    seen = low > FLAT_MARGIN * largest
    unseen = high <= UNSEEN_MARGIN * largest
    clear: Mask = np.all(np.where(loaded, seen, unseen), axis=1)
    return clear


def _shape_classes(s: BlockStructure) -> list[tuple[Any, ...]]:
    """The groups of one shape (rows x columns, ball/disc or slab, contacts' row pattern) stacked
    together, so that :func:`_unique_exactly` runs a few batched products, not one per group:
    (group indices, rows (G', k), their contacts, matrices (G', k, c), row bounds, is_norm,
    contact starts); memoised on the structure."""
    cached = s.__dict__.get("_shape_classes")
    if cached is not None:
        return cached  # type: ignore[no-any-return]
    found: dict[tuple[Any, ...], list[int]] = {}
    for g, (rows, matrix) in enumerate(zip(s.group_rows, s.group_matrices)):
        contact = s.row_contact[rows]
        starts = np.flatnonzero(np.r_[True, contact[1:] != contact[:-1]])
        found.setdefault(
            (matrix.shape, bool(s.group_is_norm[g]), tuple(starts.tolist())), []
        ).append(g)
    classes = []
    for (_, is_norm, starts), groups in found.items():
        rows = np.stack([s.group_rows[g] for g in groups])
        classes.append(
            (
                np.array(groups, dtype=np.intp),
                rows,
                s.row_contact[rows],
                np.stack([s.group_matrices[g] for g in groups]),
                s.row_bound[rows],
                is_norm,
                np.array(starts, dtype=np.intp),
            )
        )
    object.__setattr__(s, "_shape_classes", classes)  # frozen dataclass: a derived cache
    return classes


def reduced_unknowns(structure: BlockStructure, x: Array) -> Array:
    """y = Q^T (x / Z), (N, r): the reduced unknowns of :mod:`.reduction` (x lies on the
    geometry's seen coordinates, the range of Q; Q is the identity without free motions)."""
    scaled = x / structure.scale
    return scaled if structure.plain else scaled @ structure.basis


__all__ = [
    "FLAT_MARGIN",
    "LOADED_SHARE",
    "NEGLIGIBLE_SHARE",
    "UNSEEN_MARGIN",
    "BlockStructure",
    "ClosedForms",
    "block_structure",
    "closed_forms",
    "reduced_unknowns",
]
