r"""KKT system of the reduced cone programme, vectorised over all contacts, and its Newton solve.

Problem (:mod:`.reduction`): :math:`\min f^T y` s.t. :math:`\phi_j(y) \le 0` with
:math:`\phi_j = \|P_j y + o_j\|^2 - 1` (ball, disc) or :math:`\phi_j = s_j (p_j^T y + o_j) - 1`
(slab side :math:`s_j = \pm 1`; :math:`o_j` a misaligned housing's eccentricity, usually 0).
All :math:`P_j` are stacked into one matrix P (rows of contact j in ``starts[j]:starts[j+1]``), so
every evaluation is a few matrix products:

.. math::  \nabla\phi_j = \sum_{rows\ i\ of\ j} w_i P_i, \quad w_i = 2 (P y + o)_i \ (\text{norm}),
           \ s_j \ (\text{slab}); \qquad
           \nabla^2 L = P^T \mathrm{diag}(2\lambda_{j(i)} [\text{norm}]) P

Newton's method on :math:`F(y, \lambda_A) = (f + G_A^T\lambda_A,\ \phi_A(y)) = 0` for an active set A
converges quadratically; the result is accepted only when it is verified: multipliers >= 0, every
contact feasible, KKT residual at round-off.
"""

from __future__ import annotations

import functools
from collections.abc import Callable

import numpy as np

from ..numerics import Array, Index, Mask, null_space, row_spaces

POLISH_TOL = 1e-14
ACCEPT_KKT = 1e-12  # polished answers reach ~1e-15; a load component of 1e-10 must not pass
UNLOADED = 1e-9  # a contact carrying less than this share of the largest force is unloaded
PROXIMAL = 1e-12
SUBSETS_KEPT = 64  # active sets whose rows are kept per geometry
SUBSET_SIZE_KEPT = 200_000  # numbers in one kept set of rows (larger problems re-slice)
ACTIVE_GAP = 1e-6
NEARLY_TOUCHING = 1e-3  # a second try of an active set: every contact this close joins it

# the rows of a set of contacts (StackedContacts.subset): P_A, the first row of each contact in
# P_A, per row 1.0 (ball, disc) or 0.0 (slab), per row its index in the set, P_A R, R or None, o_A
Subset = tuple[Array, Index, Array, Index, Array, Array | None, Array]
# what Newton on a set returns: (y, multipliers of the set, their gradients G_A)
NewtonAnswer = tuple[Array, Array, Array]


class StackedContacts:
    """All contact matrices of a reduced problem stacked for vectorised evaluation.

    Attributes:
        matrix: P, (total rows, r).
        offset: o, the images at y = 0, (total rows,); the images are P y + o.
        starts: first row of each contact, (m,).
        is_norm: per contact, True for balls and discs, (m,).
        row_contact: per row, its contact index, (total rows,).
    """

    def __init__(
        self,
        matrices: tuple[np.ndarray, ...],
        shapes: list[str],
        size: int,
        offsets: list[np.ndarray] | None = None,
    ) -> None:
        self.size = size
        self.count = len(matrices)
        self.matrix = np.vstack(matrices) if matrices else np.zeros((0, size))
        # o: the images at y = 0 (a misaligned housing), so that every image is P y + o
        self.offset = np.concatenate(offsets) if offsets else np.zeros(self.matrix.shape[0])
        lengths = np.array([m.shape[0] for m in matrices], dtype=int)
        self.starts = (
            np.concatenate([[0], np.cumsum(lengths)[:-1]]).astype(int)
            if matrices
            else np.zeros(0, dtype=int)
        )
        self.is_norm = np.array([s == "norm" for s in shapes], dtype=bool)
        self.row_contact = np.repeat(np.arange(self.count), lengths)
        self.row_is_norm = self.is_norm[self.row_contact] if self.count else np.zeros(0, bool)
        # memoised rows of active sets and splits, SUBSETS_KEPT of both together
        self._subsets: dict[tuple[bytes, bool], Subset] = {}
        self._splits: dict[bytes, tuple[Array, Array]] = {}
        # active sets that needed the projected Newton; shared by the geometries of one structure
        # (set by the caller), since which motions a set of contacts sees is structural
        self.projection_hints: set[bytes] = set()

    def subset(self, active: Index, projected: bool = False) -> Subset:
        r"""Rows of the contacts ``active`` (memoised when small): (P_A, first row of each contact
        in P_A, per row 1.0 for a ball or disc row and 0.0 for a slab row, per row its index in
        ``active``, P_A R, R, o_A). With ``projected``, R is the orthonormal basis (r, s) of the
        motions the contacts of A see (one SVD), None when they see every motion; without, R is
        None and P_A R is P_A. The Hessian :math:`2 \sum_A \lambda_j P_j^T P_j` is formed from
        these rows, weighted, in O(rows r^2) time and O(r^2) memory."""
        key = (active.tobytes(), projected)
        cached = self._subsets.get(key)
        if cached is None:
            rows = (
                np.concatenate([np.flatnonzero(self.row_contact == j) for j in active]).astype(int)
                if active.size
                else np.zeros(0, dtype=int)
            )
            local = np.searchsorted(active, self.row_contact[rows])
            starts = np.flatnonzero(np.r_[True, local[1:] != local[:-1]]) if rows.size else rows
            matrix = self.matrix[rows]
            seen, flat = self.split(active) if projected else (None, np.zeros((self.size, 0)))
            if not flat.shape[1]:
                seen = None
            cached = (
                matrix,
                starts,
                self.row_is_norm[rows].astype(float),
                local,
                matrix if seen is None else matrix @ seen,
                seen,
                self.offset[rows],
            )
            kept = len(self._subsets) + len(self._splits)
            if kept < SUBSETS_KEPT and matrix.size <= SUBSET_SIZE_KEPT:
                self._subsets[key] = cached
        return cached

    def split(self, contacts: Index) -> tuple[Array, Array]:
        r"""Orthonormal bases (r, s) and (r, r - s) of the motions the ``contacts`` see and of
        those they do not (:math:`P_j d = 0` for every j): along the latter neither the
        contacts' gradients nor the Hessian change, so the optimum is flat there (memoised)."""
        key = contacts.tobytes()
        cached = self._splits.get(key)
        if cached is None:
            cached = self._split(contacts)
            if len(self._subsets) + len(self._splits) < SUBSETS_KEPT:
                self._splits[key] = cached
        return cached

    def _split(self, contacts: Index) -> tuple[Array, Array]:
        rows = self.matrix[np.isin(self.row_contact, contacts)]
        if not rows.size:
            return np.zeros((self.size, 0)), np.eye(self.size)
        spaces = row_spaces(rows / max(1.0, float(np.abs(rows).max())), rtol=1e-9)
        return spaces.row, spaces.null

    def values(self, y: np.ndarray, signs: np.ndarray | None) -> np.ndarray:
        """phi_j(y) for every contact (slabs on their side ``signs``; |.| if signs is None)."""
        image = self.matrix @ y + self.offset
        squares = np.add.reduceat(image * image, self.starts) if self.count else np.zeros(0)
        slab = image[self.starts]
        slab = np.abs(slab) if signs is None else signs * slab
        return np.where(self.is_norm, squares, slab) - 1.0

    def evaluate(self, y: np.ndarray, signs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(phi_j on the sides ``signs``, gradients (m, r)) from one product P y."""
        image = self.matrix @ y + self.offset
        squares = np.add.reduceat(image * image, self.starts)
        values = np.where(self.is_norm, squares, signs * image[self.starts]) - 1.0
        weights = np.where(self.row_is_norm, 2.0 * image, signs[self.row_contact])
        return values, np.add.reduceat(self.matrix * weights[:, None], self.starts, axis=0)

    def hessian(self, multipliers: np.ndarray) -> np.ndarray:
        """Hessian of the Lagrangian, sum over norm contacts of 2 lambda_j P_j^T P_j, (r, r)."""
        weights = np.where(self.row_is_norm, 2.0 * multipliers[self.row_contact], 0.0)
        return (self.matrix.T * weights) @ self.matrix

    def sides(self, y: np.ndarray) -> np.ndarray:
        """Side (+1/-1) of every slab at y (1 for norm contacts)."""
        slab = (self.matrix @ y + self.offset)[self.starts] if self.count else np.zeros(0)
        return np.where(self.is_norm | (slab >= 0.0), 1.0, -1.0)


RESIDUAL_NAMES = ("stationarity", "feasibility", "complementarity", "dual_infeasibility")
"""The columns of :func:`kkt_table`."""


def kkt_table(stationarity: Array, phi: Array, multipliers: Array) -> Array:
    r"""The KKT residuals of N answers (max norms, dimensionless), columns :data:`RESIDUAL_NAMES`:
    stationarity :math:`\lVert f + G^T \lambda \rVert_\infty` of the residual vectors
    ``stationarity`` (N, r), feasibility :math:`\max(\phi, 0)`, complementarity
    :math:`\max |\lambda_j \phi_j|`, dual infeasibility :math:`\max(-\lambda, 0)`, from the
    contacts' values ``phi`` and ``multipliers`` (N, m). The one definition every engine's
    answers are measured by (the compiled kernel computes the same in its loop, tested
    against this)."""
    return np.stack(
        [
            np.abs(stationarity).max(axis=1, initial=0.0),
            np.maximum(phi, 0.0).max(axis=1, initial=0.0),
            np.abs(multipliers * phi).max(axis=1, initial=0.0),
            np.maximum(-multipliers, 0.0).max(axis=1, initial=0.0),
        ],
        axis=1,
    )


def kkt_passed(table: Array, phi: Array, multipliers: Array, accept: float | Array) -> Mask:
    """Per answer (N,): its :func:`kkt_table` row within ``accept`` (a number or (N,)), no
    multiplier below -1e-12 and no contact outside its boundary by more than 1e-13."""
    passed: Mask = (
        (table.max(axis=1) <= accept)
        & (multipliers.min(axis=1, initial=0.0) >= -1e-12)
        & (phi.max(axis=1, initial=-1.0) <= 1e-13)
    )
    return passed


def residuals(
    stack: StackedContacts, objective: Array, y: Array, multipliers: Array, signs: Array
) -> dict[str, float]:
    """Measured KKT residuals of one answer (:func:`kkt_table`), by name."""
    values, gradients = stack.evaluate(y, signs)
    slab = ~stack.is_norm
    values[slab] = np.abs(values[slab] + 1.0) - 1.0  # feasibility of a slab on either side
    table = kkt_table((objective + multipliers @ gradients)[None], values[None], multipliers[None])
    return dict(zip(RESIDUAL_NAMES, map(float, table[0]), strict=True))


def newton(
    stack: StackedContacts,
    objective: Array,
    y: Array,
    multipliers: Array,
    signs: Array,
    active: Index,
    iterations: int = 12,
    accept: float = ACCEPT_KKT,
    projected: bool = False,
) -> NewtonAnswer | None:
    r"""Newton on the KKT system of ``active``; returns (y, lambda_active, G_A) or None.

    When a step meets a singular KKT matrix, Newton starts again with ``projected``: the steps are
    taken in the motions the contacts of the set see (the others leave every gradient and the
    Hessian unchanged, so y is not unique along them), and a still singular matrix (redundant
    contacts) is solved by least squares.

    Values and gradients come from the images :math:`v = P_A y` (accurate to round-off of
    :math:`\|P\|\|y\|`): :math:`\phi_j = \sum_{i \in j} v_i^2 - 1` (ball, disc) or
    :math:`s_j v_i - 1` (slab), :math:`G_j = \sum_{i \in j} w_i P_i` with :math:`w_i = 2 v_i` or
    :math:`s_j`; the Hessian :math:`2 \sum_A \lambda_j P_j^T P_j` from the weighted rows.
    This runs once per re-solve, so it is written for few array operations.
    """
    size, count = stack.size, active.size
    if not projected and active.tobytes() in stack.projection_hints:
        projected = True
    rows, starts, norm_rows, local, seen_rows, seen, offsets = stack.subset(active, projected)

    def retry_projected() -> NewtonAnswer | None:
        return newton(
            stack, objective, y0, multipliers, signs, active, iterations, accept, projected=True
        )

    y0 = y
    slab_signs = (1.0 - norm_rows) * signs[active][local]
    twice_norm = 2.0 * norm_rows
    value_shift = norm_rows  # image * (weight - image) = image^2 (ball, disc), s image (slab)
    # motions no contact of the set sees make the KKT matrix singular (y not unique there):
    # the step is taken in the motions they see, R (the caller centres the flat part)
    steps = size if seen is None else seen.shape[1]
    kkt = np.empty((steps + count, steps + count))
    # proximal term on the multipliers: redundant contacts sharing a load make the KKT matrix
    # singular (forces not unique); this keeps them bounded and leaves y's solution exact
    kkt[steps:, steps:] = -PROXIMAL * np.eye(count)
    unknowns = np.concatenate((y, multipliers[active]))
    y, lam = unknowns[:size], unknowns[size:]  # views: one update moves both
    converged, previous = POLISH_TOL * POLISH_TOL, np.inf
    for iteration in range(iterations + 1):
        image = np.dot(rows, y) + offsets
        weight = twice_norm * image + slab_signs
        gradients = np.add.reduceat(rows * weight[:, None], starts)
        # phi from the images, not from G y: the rows may be large and cancel
        values = np.add.reduceat(image * (weight - value_shift * image), starts) - 1.0
        residual = np.concatenate((objective + np.dot(lam, gradients), values))
        size_now = np.dot(residual, residual)
        # converged; or one step after a residual below 1e-8, where quadratic convergence leaves
        # round-off only (after 1e-6 it left up to 1e-12: answers 1.4e-12 of the play apart)
        if size_now < converged or (previous < 1e-16 and size_now <= accept * accept):
            return y.copy(), lam.copy(), gradients
        previous = size_now
        if iteration == iterations or (iteration >= 6 and size_now > 1e-8):
            break  # quadratic convergence did not set in: a wrong active set, give up early
        kkt[:steps, :steps] = np.dot(seen_rows.T * (twice_norm * lam[local]), seen_rows)
        if seen is None:
            kkt[:steps, steps:] = gradients.T
            kkt[steps:, :steps] = gradients
            step = _lu_step(kkt, residual, size_now)
            if step is None and np.abs(residual).max() <= accept:
                return y.copy(), lam.copy(), gradients  # verified already; K is singular
            if step is None and not projected:
                stack.projection_hints.add(active.tobytes())
                return retry_projected()
            step = _least_squares_step(kkt, residual) if step is None else step
            if step is None:
                return None
            unknowns -= step
            continue
        seen_gradients = np.dot(gradients, seen)
        kkt[:steps, steps:] = seen_gradients.T
        kkt[steps:, :steps] = seen_gradients
        reduced = np.concatenate((np.dot(residual[:size], seen), residual[size:]))
        step = _lu_step(kkt, reduced, np.dot(reduced, reduced))
        step = _least_squares_step(kkt, reduced) if step is None else step
        if step is None:
            return None
        y -= np.dot(seen, step[:steps])
        lam -= step[steps:]
    if np.abs(residual).max() <= accept:
        return y.copy(), lam.copy(), gradients
    if not projected:  # a nearly singular KKT matrix can pass LU with a wrong step
        return retry_projected()
    return None


def _lu_step(kkt: Array, residual: Array, squared: float) -> Array | None:
    """Newton step :math:`K^{-1} r` (to subtract) by LU; None when K is singular (LU then fails
    or returns a huge, wrong step). ``squared``: r^T r."""
    step = _lu_solve(kkt, residual)
    if step is None:
        return None
    size = np.dot(step, step)
    # NaN fails both tests; a step 1e10 times the residual means K is singular to round-off
    # (a motion no contact of the set sees), not that the answer is that far
    if not (size < 1e12 and size <= 1e20 * squared):
        return None
    # a nearly singular K (redundant contacts) gives a step that does not solve K s = r to
    # round-off: refuse it, so that the caller takes the minimum-norm one
    error = np.dot(kkt, step) - residual
    return step if np.dot(error, error) <= 1e-18 * (1.0 + np.dot(residual, residual)) else None


def _least_squares_step(kkt: Array, residual: Array) -> np.ndarray | None:
    """Minimum-norm least-squares Newton step for a singular KKT matrix (redundant contacts
    sharing the load: the multipliers are not unique)."""
    step = np.linalg.lstsq(kkt, residual, rcond=None)[0]
    return step if np.isfinite(step).all() else None


def _numpy_lu_solve(matrix: Array, right: Array) -> np.ndarray | None:
    try:
        return np.linalg.solve(matrix, right)
    except np.linalg.LinAlgError:
        return None


@functools.cache
def _lu_solver() -> Callable[[Array, Array], Array | None]:
    """The LU solver of the Newton steps: SciPy's LAPACK dgesv when installed (the fast extra: a
    third of NumPy's wrapper's cost), chosen at the first step, not when clearance_pin is
    imported (SciPy's import costs about 0.1 s)."""
    try:
        from scipy.linalg.lapack import dgesv
    except ImportError:  # pragma: no cover - depends on the installed extras
        return _numpy_lu_solve

    def lapack_lu_solve(matrix: Array, right: Array) -> Array | None:
        _, _, solution, info = dgesv(matrix, right)
        return solution if info == 0 else None

    return lapack_lu_solve


def _lu_solve(matrix: np.ndarray, right: np.ndarray) -> np.ndarray | None:
    return _lu_solver()(matrix, right)


def active_set_solve(
    stack: StackedContacts,
    objective: Array,
    y: Array,
    multipliers: Array,
    signs: Array | None = None,
    rounds: int = 10,
    accept: float = ACCEPT_KKT,
    iterations: int = 12,
) -> tuple[Array, Array, Array, dict[str, float]] | None:
    """Verified active-set method from a guess (y, multipliers); None if it cannot be verified.

    The active set starts as the contacts in touch or carrying a multiplier. Each round solves its
    KKT system by Newton's method; a contact whose multiplier turns negative is released, a
    violated one is added, and when the set cannot hold the load (the stationarity residual has a
    component along motions that keep every contact of the set), the parts move along that
    motion to the first contact it meets, which joins the set (a primal active-set step).

    Returns:
        (y, multipliers (all contacts), signs, residuals) or None.
    """
    signs = stack.sides(y) if signs is None else signs.copy()
    phi = stack.values(y, None)
    largest = max(1.0, float(np.max(multipliers, initial=0.0)))
    active = np.flatnonzero((phi > -ACTIVE_GAP) | (multipliers > 1e-9 * largest))
    lam = multipliers.copy()
    for _ in range(rounds):
        if active.size == 0:  # nothing touches (a start from the centre): along the load
            stepped = _step_to_next_contact(stack, objective, y, signs, active)
            if stepped is None:
                return None
            y, added = stepped
            signs = stack.sides(y)
            active = np.array([added])
            continue
        start = lam
        if not lam[active].max() > 0.0:  # no multiplier known: the load's least-squares estimate
            _, gradients = stack.evaluate(y, signs)
            start = lam.copy()
            least = np.linalg.lstsq(gradients[active].T, -objective, rcond=None)[0]
            start[active] = np.maximum(least, 0.0)
        solved = newton(
            stack, objective, y, start, signs, active, iterations=iterations, accept=accept
        )
        if solved is None:
            released = _contact_to_release(stack, objective, y, signs, active)
            if released is not None:
                active = np.setdiff1d(active, [released])
                continue
            stepped = _step_to_next_contact(stack, objective, y, signs, active)
            if stepped is None:
                return None
            y, added = stepped
            signs = stack.sides(y)
            active = np.union1d(active, [added])
            continue
        y_new, lam_active, gradients = solved
        lam[active] = np.maximum(lam_active, 0.0)  # the next round's Newton starts from these
        negative = active[lam_active < -1e-12]
        if negative.size:
            active = np.setdiff1d(active, negative)
            continue
        phi_new = stack.values(y_new, None)
        violated = np.flatnonzero(phi_new > max(1e-13, accept))
        if violated.size:
            # towards y_new only as far as the first contact it meets, which joins the set: from
            # y Newton finds y_new again (a cycle), from y_new, outside that contact, it can
            # reach the set's other KKT point, the contact pulling (as the compiled kernel)
            t, reached = _first_contact_along(stack, y, y_new - y, active, 1.0)
            if reached is None:  # y itself outside a contact (round-off)
                active = np.union1d(active, violated)
            else:
                y = y + t * (y_new - y)
                active = np.union1d(active, [reached])
            signs = stack.sides(y)
            continue
        touching = np.union1d(active, np.flatnonzero(phi_new > -max(1e-13, accept)))
        if touching.size > active.size:
            # contacts touching at y_new outside the set (a block's corners on one face, reached
            # one by one) share the load where it is indeterminate: the split over all of them
            extra = np.setdiff1d(touching, active)
            signs = signs.copy()
            signs[extra] = stack.sides(y_new)[extra]
            gradients = stack.evaluate(y_new, signs)[1][touching]
            newton_forces = np.zeros(touching.size)
            newton_forces[np.searchsorted(touching, active)] = lam_active
            lam_active, active = newton_forces, touching
        lam_new = np.zeros(stack.count)
        lam_new[active] = _minimum_norm_forces(gradients, objective, lam_active)
        stationarity = objective + np.dot(lam_new[active], gradients)
        table = kkt_table(stationarity[None], phi_new[None], lam_new[None])
        if table.max() <= accept:
            return y_new, lam_new, signs, dict(zip(RESIDUAL_NAMES, map(float, table[0])))
        return None
    return None


def _contact_to_release(
    stack: StackedContacts, objective: Array, y: Array, signs: Array, active: Index
) -> int | None:
    """When Newton fails on an over-constrained set: the contact whose least-squares multiplier is
    most negative (it pulls), else the most open one if it is not quite touching; None if none."""
    if active.size <= 1:
        return None
    values, gradients = stack.evaluate(y, signs)
    least = np.linalg.lstsq(gradients[active].T, -objective, rcond=None)[0]
    if least.min() < -1e-12:
        return int(active[np.argmin(least)])
    most_open = int(active[np.argmin(values[active])])
    return most_open if values[most_open] < -1e-14 else None


def _minimum_norm_forces(gradients: Array, objective: Array, newton_multipliers: Array) -> Array:
    """Contact multipliers at a solved y: Newton's when the active gradients ``gradients`` (a, r)
    are independent (the forces are unique); otherwise the minimum-norm set balancing the load
    when it is non-negative (statically indeterminate contacts share the load evenly)."""
    singular = np.linalg.svd(gradients, compute_uv=False)
    if gradients.shape[0] <= gradients.shape[1] and singular[-1] > 1e-10 * singular[0]:
        return np.maximum(newton_multipliers, 0.0)
    least = np.linalg.lstsq(gradients.T, -objective, rcond=None)[0]
    if np.all(least >= -1e-14):
        shared: Array = np.maximum(least, 0.0)  # (NumPy's stubs: Any)
        return shared
    return np.maximum(newton_multipliers, 0.0)


def _step_to_next_contact(
    stack: StackedContacts, objective: Array, y: Array, signs: Array, active: Index
) -> tuple[Array, int] | None:
    """Move along the load's unbalanced part, tangent to the active contacts, to the next contact.

    Returns (new y, index of the contact reached) or None when no contact bounds that motion.
    """
    _, gradients = stack.evaluate(y, signs)
    tangent = null_space(gradients[active], rtol=1e-12)
    direction = -tangent @ (tangent.T @ objective)
    if np.linalg.norm(direction) <= 1e-14:
        return None
    best, reached = _first_contact_along(stack, y, direction, active, np.inf)
    if reached is None:
        return None
    return y + best * direction, reached


def _first_contact_along(
    stack: StackedContacts, y: Array, direction: Array, active: Index, limit: float
) -> tuple[float, int | None]:
    """(t, j): the first contact j outside ``active`` that y + t direction meets, 0 <= t <
    ``limit`` (ball, disc: the larger root of |image + t moved|^2 = 1; slab: its side's plane);
    (inf, None) when none does."""
    image = stack.matrix @ y + stack.offset
    image_d = stack.matrix @ direction
    best, reached = np.inf, None
    for j in np.setdiff1d(np.arange(stack.count), active):
        rows = slice(stack.starts[j], stack.starts[j + 1] if j + 1 < stack.count else None)
        if stack.is_norm[j]:
            a = float(image_d[rows] @ image_d[rows])
            b = float(image[rows] @ image_d[rows])
            c = float(image[rows] @ image[rows] - 1.0)
            if a <= 0.0:
                continue
            t = (-b + np.sqrt(max(b * b - a * c, 0.0))) / a
        else:
            slope = image_d[rows][0]
            if slope == 0.0:
                continue
            t = (np.sign(slope) - image[rows][0]) / slope
        if 0.0 <= t < best and t < limit:
            best, reached = float(t), int(j)
    return best, reached
