r"""The small-displacement equilibrium as a reduced, scaled cone programme.

Problem (docs/method.md section 2, [Y]): minimise the potential :math:`g^T x` over the small
displacements x that close every loop (:math:`E x = 0`: rigid components of loop joints and contact
points with zero clearance) and keep every contact point in its clearance set
(:math:`\|S_j x\| \le c_j` or :math:`|s_j^T x| \le c_j`).

Reduction, in the scaled unknowns :math:`z = Z^{-1} x` (Z: clearance-sized scales):

1. :math:`N_E` spans the null space of :math:`E Z` (closure eliminated exactly; redundant
   closure equations of planar mechanisms cost nothing);
2. :math:`K` spans the motions that no contact sees (:math:`S_j Z N_E k = 0` for all j): free
   motions such as the spin of a shaft. A load with a component along K has no equilibrium
   (the potential is unbounded below); a load orthogonal to K leaves K indeterminate, and we
   return the minimum-norm optimum by restricting to the complement of K. The rows
   :math:`S_j Z N_E` are ranked block by block (columns joined by the rows that read them: a
   tree's groups of contacts on one joint's unknowns), so a long chain costs a few small SVDs
   per joint instead of one dense SVD over all unknowns; a block of full rank keeps its
   coordinates, and a tree without free motions keeps :math:`Q = I` (:func:`_split_blocks`);
3. :math:`x = Z Q y` with :math:`Q = N_E K^\perp` orthonormal, and each contact becomes
   :math:`\|P_j y + o_j\| \le 1` with :math:`P_j = S_j Z Q / c_j` and :math:`o_j` the nominal
   eccentricity of a misaligned loop joint over its play (zero for an aligned one,
   :mod:`clearance_pin.kinematics.loop_frames`).

With joint stiffness (:mod:`.small_displacement`: elastic unknowns with stiffnesses
:math:`k_i`) the potential gains :math:`\tfrac12 x^T \mathrm{diag}(k) x`: an elastic unknown is
seen by its energy as a contact sees a play unknown (step 2 counts it as blocked), and the
objective becomes :math:`f^T y + \tfrac12 y^T H y` with
:math:`H = Q^T Z \mathrm{diag}(k) Z Q / \sigma` (:attr:`ReducedProblem.hessian`).
"""

from __future__ import annotations

import statistics
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..errors import UnboundedLoadError
from ..kinematics.loop_frames import nominal_offsets
from ..model.clearance import COMPONENT_MEANING, COMPONENT_NAMES, ContactPoint
from ..model.couplings import Coupling, coupled_joint
from ..model.joints import LoopJoint, TreeJoint
from ..numerics import Array, Index, Mask, norm, row_spaces
from .kkt import StackedContacts
from .lazy import LazySequence
from .small_displacement import SmallDisplacementMaps

# what a built solver depends on: (reduced unknowns r, per contact (shape, rows)[, True when the
# objective is quadratic])
Signature = tuple[int, tuple[tuple[str, int], ...]] | tuple[int, tuple[tuple[str, int], ...], bool]
# joint name -> TreeJoint or LoopJoint (tree joints first, in tree order)
Joints = Mapping[str, TreeJoint | LoopJoint]

UNBOUNDED_FRACTION = 1e-9
ROUND_OFF_WORK = 1e-12  # working part of a load below this share of the load is round-off
RANK_ATOL = 1e-9  # on rows normalised to their natural size (closure rows, contact rows / play)


@dataclass(frozen=True)
class ContactConstraint:
    """One contact point of one joint, as rows on the unknowns x.

    Attributes:
        joint: joint name.
        contact: the contact point (its name, shape and bound).
        rows: map x -> bounded displacement components [m], shape (k, n).
        offset: the bounded components at x = 0 [m], shape (k,): zero but for a loop joint with
            a nominal eccentricity; the condition is :math:`\\|o + S x\\| \\le c`.
    """

    joint: str
    contact: ContactPoint
    rows: np.ndarray
    offset: np.ndarray

    @property
    def label(self) -> str:
        """``joint:contact`` identifier used in results and reports."""
        return f"{self.joint}:{self.contact.name}"


@dataclass(frozen=True)
class ReducedProblem:
    """Scaled, reduced cone programme :math:`\\min f^T y` s.t. :math:`\\|P_j y + o_j\\| \\le 1`.

    Attributes:
        gradient: g, the potential's gradient in x [J per unit], (n,).
        scale: Z as a vector, (n,).
        basis: Q, (n, r); x = scale * (Q @ y).
        contacts: contact points with positive clearance.
        equalities: E, (m, n).
        free_motions: x-space basis of the motions no contact sees, (n, f).
        free_descriptions: one sentence per column of ``free_motions``.
        objective: f = Q^T Z g / sigma, (r,).
        objective_scale: sigma [J], so that the potential is sigma * f^T y.
        contact_matrices: P_j, one (k_j, r) array per contact.
        stack: the P_j stacked for vectorised KKT evaluation.
        conditioning: see :func:`closure_conditioning`.
        load_size: size of the whole load on the clearance scale [J] (see
            :func:`with_scaled_load`), the reference of relative residuals.
        unblocked_share: the share of the load along the motions nothing blocks, at most
            :data:`UNBOUNDED_FRACTION` (a larger one raises UnboundedLoadError): neglected, and
            reported with the answer (``residuals["unblocked_load"]``).
    """

    gradient: np.ndarray
    scale: np.ndarray
    basis: np.ndarray
    contacts: tuple[ContactConstraint, ...]
    equalities: np.ndarray
    free_motions: np.ndarray
    free_descriptions: LazySequence[str]
    objective: np.ndarray
    objective_scale: float
    contact_matrices: tuple[np.ndarray, ...]
    stack: StackedContacts
    conditioning: float = 1.0
    load_size: float = 0.0
    unblocked_share: float = 0.0
    translational: np.ndarray | None = None  # per unknown: a translation [m] (else a rotation)
    hessian: np.ndarray | None = None  # H (r, r) of the elastic energy over sigma; None: rigid

    @property
    def size(self) -> int:
        """Number of reduced unknowns r."""
        return int(self.basis.shape[1])

    def x_from_y(self, y: np.ndarray) -> np.ndarray:
        """Unknowns x (joint torsor coordinates, SI) from reduced ones y."""
        x: Array = self.scale * (self.basis @ y)  # (NumPy's stubs: Any)
        return x

    def signature(self) -> Signature:
        """What a built solver depends on: sizes and shapes, not numbers (and whether the
        objective is quadratic)."""
        shapes = tuple((c.contact.shape, c.rows.shape[0]) for c in self.contacts)
        if self.hessian is not None:
            return (self.size, shapes, True)
        return (self.size, shapes)


@dataclass(frozen=True)
class ReducedGeometry:
    """The load-independent part of the reduction at one configuration (cached per configuration).

    Attributes: see :class:`ReducedProblem`; ``free_scaled`` is K in the scaled unknowns z.
    """

    scale: np.ndarray
    basis: np.ndarray
    contacts: tuple[ContactConstraint, ...]
    equalities: np.ndarray
    free_motions: np.ndarray
    free_scaled: np.ndarray
    free_descriptions: LazySequence[str]
    contact_matrices: tuple[np.ndarray, ...]
    stack: StackedContacts
    conditioning: float = 1.0
    translational: np.ndarray | None = None  # per unknown: a translation [m] (else a rotation)
    stiffness: np.ndarray | None = None  # per unknown x_i, k_i [N/m or N m/rad]; None: rigid


def _split_rows(
    rows: np.ndarray, dimension: int, rtol: float = 1e-10
) -> tuple[np.ndarray, np.ndarray, float]:
    """One SVD of ``rows`` (k, d): orthonormal bases of their null space (d, d - rank) and of its
    complement (d, rank), and their conditioning: the smallest singular value above ``rtol`` of
    the largest, over the largest.

    Applied to the closure equations E Z and to the contact rows on the closed motions, the
    conditioning is 1 for a well-posed mechanism and small near a toggle position, where the
    joints are about to allow a motion that no contact sees (values below ``rtol`` count as such
    a motion and are eliminated).

    The rank counts singular values above ``rtol`` of the largest and above :data:`RANK_ATOL`
    (the rows are normalised to their natural size, so round-off rows have rank 0).
    """
    if rows.size == 0:
        return np.eye(dimension), np.zeros((dimension, 0)), 1.0
    spaces = row_spaces(rows, rtol, RANK_ATOL)
    singular = spaces.singular
    if singular.size == 0 or singular[0] == 0.0:
        return spaces.null, spaces.row, 1.0
    kept = singular[singular > rtol * singular[0]]
    return spaces.null, spaces.row, float(kept[-1] / singular[0])


def _split_blocks(
    rows: np.ndarray, rtol: float = 1e-10
) -> tuple[np.ndarray, np.ndarray, float, Index | None] | None:
    r""":func:`_split_rows` of ``rows`` (k, d) block by block, or None when they form one block
    over all d columns.

    Columns joined by a row with nonzero entries in both form a block (a tree's contact rows
    read only their own joint's unknowns: one block per group of contacts sharing unknowns, a
    few columns each). The singular values of ``rows`` are those of its blocks, so the rank rule
    of :func:`_split_rows` (above ``rtol`` of the largest of all and above :data:`RANK_ATOL`)
    and the conditioning are decided on the blocks' SVDs (one batched SVD per block shape), at a
    cost linear in the number of blocks instead of one dense (k, d) SVD. A block of full rank
    keeps its coordinate vectors (as the whole basis is kept when every motion is seen); a
    column no row reads is a free motion of its own; a rank-deficient block contributes its
    SVD's row and null vectors.

    Returns:
        (free (d, f), seen (d, d - f), conditioning, seen_columns): seen_columns, when every
        seen direction is a coordinate vector, is the index array of those columns (seen is
        then the identity's columns ``seen_columns``), else None.
    """
    k, d = rows.shape
    touched, where = np.nonzero(rows)  # row-major: each row's columns in order
    labels = _column_blocks(touched, where, d)
    read = labels >= 0
    count = int(labels.max(initial=-1)) + 1
    if count == 1 and bool(read.all()):
        return None
    row_label = np.full(k, -1)
    row_label[touched] = labels[where]
    column_sets = _members(labels, count)
    row_sets = _members(row_label, count)
    shapes: dict[tuple[int, int], list[int]] = {}
    for b in range(count):
        shapes.setdefault((row_sets[b].size, column_sets[b].size), []).append(b)
    parts = []  # per block shape: (blocks, their columns (B, w), singular values, V^T)
    for (height, width), members in shapes.items():
        columns = np.array([column_sets[b] for b in members])  # (B, w)
        stacked = rows[np.array([row_sets[b] for b in members])[:, :, None], columns[:, None, :]]
        _, values, vt = np.linalg.svd(stacked, full_matrices=height < width)
        parts.append((members, columns, values, vt))
    largest = max((float(values[:, 0].max()) for _, _, values, _ in parts), default=0.0)
    if largest == 0.0:
        return np.eye(d), np.zeros((d, 0)), 1.0, np.zeros(0, dtype=np.intp)
    smallest = largest
    free_parts: dict[int, np.ndarray] = {}  # rank-deficient block -> its null vectors (d, .)
    seen_parts: dict[int, np.ndarray] = {}  # and its seen directions (d, rank)
    for members, columns, values, vt in parts:
        counted = values > rtol * largest
        smallest = min(smallest, float(np.where(counted, values, np.inf).min()))
        ranks = np.sum(counted & (values > RANK_ATOL), axis=1)
        for i in np.flatnonzero(ranks < columns.shape[1]).tolist():  # rank-deficient blocks
            rank = int(ranks[i])
            free_parts[members[i]] = _embedded(vt[i, rank:].T, columns[i], d)
            seen_parts[members[i]] = _embedded(vt[i, :rank].T, columns[i], d)
    unread = np.flatnonzero(~read)
    free = np.hstack(
        [*(free_parts[b] for b in sorted(free_parts)), _embedded(np.eye(unread.size), unread, d)]
    )
    seen_columns: np.ndarray | None
    if not free_parts:  # every block of full rank: the seen directions are coordinates
        seen_columns = np.flatnonzero(read)
        seen = np.eye(d)[:, seen_columns]
    else:
        seen_columns = None
        seen = np.hstack(
            [
                seen_parts[b] if b in seen_parts else _embedded(np.eye(cols.size), cols, d)
                for b, cols in enumerate(column_sets)
            ]
        )
    return free, seen, smallest / largest, seen_columns


def _embedded(vectors: np.ndarray, columns: np.ndarray, d: int) -> np.ndarray:
    """Vectors (len(columns), p) on the coordinates ``columns`` as vectors (d, p)."""
    out = np.zeros((d, vectors.shape[1]))
    out[columns] = vectors
    return out


def _members(labels: np.ndarray, count: int) -> list[np.ndarray]:
    """Per label 0 .. count - 1, the indices carrying it, in order (-1: none)."""
    kept = np.flatnonzero(labels >= 0)
    ordered = kept[np.argsort(labels[kept], kind="stable")]
    return np.split(ordered, np.cumsum(np.bincount(labels[kept], minlength=count))[:-1])


def _column_blocks(touched: np.ndarray, where: np.ndarray, d: int) -> np.ndarray:
    """Per column, the label 0, 1, ... of its block (columns joined by rows with nonzero entries
    in both, numbered in the order of their first column), -1 for a column no row reads; from
    the nonzero entries (``touched`` rows, ``where`` columns, row-major).

    Each column's label starts as its own index and becomes the smallest over the rows that
    read it (then over its label's label), until every row's columns share one: the smallest
    column of the block, in a few array passes over the nonzero entries."""
    labels = np.arange(d)
    if where.size:
        starts = np.flatnonzero(np.r_[True, touched[1:] != touched[:-1]])
        lengths = np.diff(np.r_[starts, where.size])
        while True:
            smallest = np.repeat(np.minimum.reduceat(labels[where], starts), lengths)
            updated = labels.copy()
            np.minimum.at(updated, where, smallest)
            while True:  # follow the labels to their roots
                jumped = updated[updated]
                if np.array_equal(jumped, updated):
                    break
                updated = jumped
            if np.array_equal(updated, labels):
                break
            labels = updated
    read = np.zeros(d, dtype=bool)
    read[where] = True
    roots = read & (labels == np.arange(d))  # the first column of each block
    out = np.full(d, -1)
    out[read] = (np.cumsum(roots) - 1)[labels[read]]
    return out


def reduce_geometry(
    maps: SmallDisplacementMaps,
    joints: Joints,
    length_scale: float,
    couplings: tuple[Coupling, ...] = (),
) -> ReducedGeometry:
    r"""Steps 1-3 of the reduction, which do not depend on the load.

    Args:
        maps: linear maps at the nominal configuration.
        joints: joint name -> TreeJoint or LoopJoint (tree joints first, in tree order).
        length_scale: characteristic length of the mechanism L_ref [m], for rotation scales.
        couplings: the couplings of passive leaders (:func:`~..model.couplings.passive`):
            each a closure equation :math:`\delta q_f - m\, \delta q_l = 0` on the two joints'
            motions, after the loops' (the exact model writes them in the same order).
    """
    n = maps.size
    contacts, equality_rows, equality_joints = _constraints(maps, joints)
    for coupling in couplings:
        follower, leader = (
            coupled_joint(joints, coupling.follower),
            coupled_joint(joints, coupling.leader),
        )
        equality_rows.append(
            maps.play_torsor[follower.name][follower.motion_component]
            - coupling.multiplier * maps.play_torsor[leader.name][leader.motion_component]
        )
        equality_joints.append(follower.name)
    scale = _variable_scales(maps, joints, contacts, length_scale)
    equalities = np.array(equality_rows, dtype=float).reshape(len(equality_rows), n)
    normalised = _normalised_equalities(maps, equalities, equality_joints, scale)
    closure_basis, _, conditioning = _split_rows(normalised, n)
    no_closure = normalised.size == 0  # a tree: the closure basis is the identity
    seen_columns = None  # the basis is these columns of the identity (a tree's usual case)
    elastic = np.flatnonzero(maps.stiffness)
    if contacts or elastic.size:
        # an elastic unknown is seen by its own energy (a unit row), as a contact sees its play
        rows = [c.rows / c.contact.bound * scale for c in contacts]
        if elastic.size:
            unit = np.zeros((elastic.size, n))
            unit[np.arange(elastic.size), elastic] = 1.0
            rows.append(unit)
        contact_rows = np.vstack(rows)
        seen_rows = contact_rows if no_closure else contact_rows @ closure_basis
        split = _split_blocks(seen_rows)
        if split is None:  # one block over all unknowns (loops): one SVD
            free_w, seen_w, seen_conditioning = _split_rows(seen_rows, closure_basis.shape[1])
        else:
            free_w, seen_w, seen_conditioning, seen_columns = split
        conditioning = min(conditioning, seen_conditioning)
        if not free_w.shape[1]:
            # every motion is seen: keep the closure basis as it is (the SVD's rotation of it
            # would mix every unknown into every contact row and make the cone data dense)
            seen_w = np.eye(closure_basis.shape[1])
            seen_columns = np.arange(closure_basis.shape[1])
    else:
        free_w = np.eye(closure_basis.shape[1])
        seen_w = np.zeros((closure_basis.shape[1], 0))
    if no_closure:  # I W = W: no (n, n) products
        free_z, basis = free_w, seen_w
    else:
        free_z = closure_basis @ free_w
        basis = closure_basis @ seen_w
        seen_columns = None
    if elastic.size and seen_columns is None:
        basis = _play_columns_first(basis, elastic)
    # a coordinate selection: gathered, not multiplied (+ 0.0: a -0.0 reads +0.0, as it did in
    # the product with the identity)
    if seen_columns is not None and seen_columns.size == n:  # Q = I: no (k, n) x (n, n)
        matrices = tuple((c.rows * scale + 0.0) / c.contact.bound for c in contacts)
    elif seen_columns is not None:
        matrices = tuple(
            (c.rows[:, seen_columns] * scale[seen_columns] + 0.0) / c.contact.bound
            for c in contacts
        )
    else:
        matrices = tuple((c.rows * scale) @ basis / c.contact.bound for c in contacts)
    free_x = scale[:, None] * free_z
    descriptions = LazySequence(
        lambda: (
            "; ".join(describe_motion(maps, joints, free_x[:, i], length_scale))
            for i in range(free_x.shape[1])
        )
    )
    stack = StackedContacts(
        matrices,
        [c.contact.shape for c in contacts],
        basis.shape[1],
        [c.offset / c.contact.bound for c in contacts],
    )
    return ReducedGeometry(
        scale,
        basis,
        tuple(contacts),
        equalities,
        free_x,
        free_z,
        descriptions,
        matrices,
        stack,
        conditioning,
        translational_unknowns(maps),
        maps.stiffness if elastic.size else None,
    )


def _play_columns_first(basis: np.ndarray, elastic: np.ndarray) -> np.ndarray:
    """The same span as ``basis`` (n, r), its first columns the motions without elastic
    deflection, their entries on the ``elastic`` unknowns exactly zero (they are round-off of the
    SVD's), the others spanning what deflects. The elastic energy then has exact zeros on the
    play columns: a stiff joint's deflection (1e-11 of the play at k = 1e15 N/m) is not lost in
    the round-off of the play's basis vectors."""
    spaces = row_spaces(basis[elastic], 1e-12, 1e-13)
    play, deflecting = basis @ spaces.null, basis @ spaces.row
    play[elastic] = 0.0
    return np.hstack([play, deflecting])


def with_scaled_load(
    geometry: ReducedGeometry,
    scaled_gradient: np.ndarray,
    reduced_gradient: np.ndarray,
    along_free: np.ndarray,
    maps: SmallDisplacementMaps,
    joints: Joints,
    length_scale: float,
    load_size: float = 0.0,
) -> ReducedProblem:
    """The reduced problem for one load: objective f and the check for unbounded loads.

    Args:
        scaled_gradient: Z g, (n,); reduced_gradient: Q^T Z g, (r,); along_free: K^T Z g, (f,).
        load_size: size of the whole load on the clearance scale [J] (forces x play, moments x
            play / length), the reference for the unbounded test; 0 uses the working part only.

    Raises:
        UnboundedLoadError: the load works along a motion that nothing blocks (more than 1e-9 of
            the load).
    """
    scale = geometry.scale
    # compare with the whole load (load_size), not only its working part: a load through a
    # pivot leaves a round-off moment that is all "working part" but nothing of the load
    gradient_size = norm(scaled_gradient)
    reference = max(gradient_size, load_size)
    free_size = norm(along_free)
    if reference > 0.0 and free_size > UNBOUNDED_FRACTION * reference:
        motion = scale * (geometry.free_scaled @ along_free)
        raise UnboundedLoadError(
            describe_motion(maps, joints, motion, length_scale),
            min(1.0, free_size / gradient_size),
        )
    sigma = norm(reduced_gradient)
    if sigma <= ROUND_OFF_WORK * reference:
        reduced_gradient, sigma = np.zeros_like(reduced_gradient), 0.0  # round-off: no working load
    objective = reduced_gradient / sigma if sigma > 0.0 else reduced_gradient
    share = free_size / reference if reference > 0.0 else 0.0
    return loaded_problem(geometry, scaled_gradient / scale, objective, sigma, load_size, share)


def loaded_problem(
    geometry: ReducedGeometry,
    gradient: np.ndarray,
    objective: np.ndarray,
    sigma: float,
    load_size: float,
    unblocked_share: float = 0.0,
) -> ReducedProblem:
    r"""The reduced problem of ``geometry`` for one load already reduced: x-space gradient g,
    objective f, objective scale sigma [J], load size [J] and the neglected share of the load
    along unblocked motions (see :func:`with_scaled_load`); with stiffness, the elastic energy's
    :math:`H = Q^T Z \mathrm{diag}(k) Z Q / \sigma` (the rigid problem when sigma is 0: no
    working load, nothing deflects)."""
    hessian = None
    if geometry.stiffness is not None and sigma > 0.0:
        weighted = geometry.basis * (geometry.scale**2 * geometry.stiffness)[:, None]
        hessian = geometry.basis.T @ weighted / sigma
    return ReducedProblem(
        gradient,
        geometry.scale,
        geometry.basis,
        geometry.contacts,
        geometry.equalities,
        geometry.free_motions,
        geometry.free_descriptions,
        objective,
        float(sigma),
        geometry.contact_matrices,
        geometry.stack,
        geometry.conditioning,
        float(load_size),
        float(unblocked_share),
        geometry.translational,
        hessian,
    )


def _constraints(
    maps: SmallDisplacementMaps, joints: Joints
) -> tuple[list[ContactConstraint], list[np.ndarray], list[str]]:
    contacts: list[ContactConstraint] = []
    equality_rows: list[np.ndarray] = []
    equality_joints: list[str] = []
    for name, joint in joints.items():
        torsor = maps.play_torsor[name]
        is_loop = not hasattr(joint, "joint_id")
        if is_loop:
            for component in joint.clearance.rigid_components:
                equality_rows.append(torsor[component])
                equality_joints.append(name)
        offsets = (
            nominal_offsets(joint, maps.eccentricity[name]) if isinstance(joint, LoopJoint) else {}
        )
        for contact in joint.clearance.contacts:
            rows = contact.linear_rows() @ torsor
            if contact.bound > 0.0:
                offset = offsets.get(contact.name, np.zeros(len(contact.components)))
                contacts.append(ContactConstraint(name, contact, rows, offset))
            elif is_loop:
                equality_rows.extend(rows)
                equality_joints.extend([name] * rows.shape[0])
    return contacts, equality_rows, equality_joints


def _normalised_equalities(
    maps: SmallDisplacementMaps, equalities: Array, names: list[str], scale: Array
) -> Array:
    """Closure rows E Z, each divided by the size of its joint's whole scaled torsor map.

    A row that is round-off of that size (the out-of-plane closure of a planar loop whose tree
    joints already keep it planar) then reads ~1e-16 and is dropped by the absolute rank test.
    """
    if not names:
        return equalities * scale
    sizes = {
        name: float(np.abs(maps.joint_torsor[name] * scale).max(initial=0.0)) for name in set(names)
    }
    divisors = np.array([sizes[name] or 1.0 for name in names])
    normalised: Array = equalities * scale / divisors[:, None]  # (NumPy's stubs: Any)
    return normalised


def _variable_scales(
    maps: SmallDisplacementMaps,
    joints: Joints,
    contacts: list[ContactConstraint],
    length_scale: float,
) -> Array:
    """Clearance-sized scale of every unknown: its joint's play [m], or play / L_ref [rad]."""
    bounds = [c.contact.bound for c in contacts]
    reference = float(statistics.median(bounds)) if bounds else 1.0
    plays = np.array([joints[name].clearance.max_play or reference for name in maps.variable_joint])
    return np.where(translational_unknowns(maps), plays, reference / length_scale)


def translational_unknowns(maps: SmallDisplacementMaps) -> Mask:
    """Per unknown, True when it is a translation [m] (its basis direction moves more than it
    turns), False for a rotation [rad]."""
    basis = np.array(maps.variable_basis).reshape(-1, 6)
    translational: Mask = np.abs(basis[:, :3]).sum(axis=1) >= np.abs(basis[:, 3:]).sum(axis=1)
    return translational


def describe_motion(
    maps: SmallDisplacementMaps, joints: Joints, motion: np.ndarray, length_scale: float
) -> list[str]:
    """Name the joint components that a motion x moves, largest first: those above 20 % of the
    largest, then how many smaller ones it moves too (above 1e-9 of the largest).

    Rotations are weighted by the length scale so that translations and rotations compare.
    """
    entries = []
    for name in joints:
        torsor = maps.joint_torsor[name] @ motion
        weighted = np.concatenate([torsor[:3], torsor[3:] * length_scale])
        for component, value in enumerate(weighted):
            entries.append((abs(value), name, component))
    largest = max((e[0] for e in entries), default=0.0)
    if largest == 0.0:
        return ["no joint moves"]
    picked = sorted((e for e in entries if e[0] > 0.2 * largest), reverse=True)
    smaller = sum(1e-9 * largest < e[0] <= 0.2 * largest for e in entries)
    named = [
        f"joint {name!r} {COMPONENT_NAMES[c]} ({COMPONENT_MEANING[c]})" for _, name, c in picked
    ]
    if smaller:
        named.append(
            f"and {smaller} smaller component{'s' if smaller > 1 else ''} (under 20 % of the largest)"
        )
    return named
