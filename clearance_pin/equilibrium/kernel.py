r"""The verified re-solve compiled (numba): load to objective, active-set Newton, verification,
the answer's arithmetic.

The same algorithm as the NumPy path (:mod:`.kkt`, :meth:`.prepared.PreparedGeometry.problem`,
:func:`.linear_answer.assemble_linear`), written as loops over the few unknowns and contacts of a
reduced problem, so that a re-solve is two compiled calls instead of about a hundred array calls
from Python. Problem (:mod:`.kkt`), dimensionless:

.. math::  \min f^T y \quad \text{s.t.} \quad \phi_j = \|P_j y + o_j\|^2 - 1 \le 0 \ (\text{ball,
           disc}), \qquad \phi_j = s_j (p_j^T y + o_j) - 1 \le 0 \ (\text{slab side } s_j)

Newton on :math:`F(y, \lambda_A) = (f + G_A^T \lambda_A, \phi_A(y)) = 0` for the active set A,
:math:`K = [[\nabla^2 L, G_A^T], [G_A, -\epsilon I]]`. Whatever this kernel cannot decide (a
singular KKT matrix, redundant contacts, a set that cannot hold the load, an unbounded or
unloaded problem) it returns undecided and the NumPy path, which handles those, runs instead:
the kernel only answers what it verifies (multipliers >= 0, every contact feasible, KKT residual
<= ``accept``), as the NumPy path does.

Imported only when a mechanism is re-solved (numba loads then, not at ``import clearance_pin``);
compiled once per machine and kept in numba's on-disk cache.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any, ParamSpec, Protocol, TypeVar, overload

import numpy as np

from ..numerics import Array, Index, Mask

_P = ParamSpec("_P")
_R = TypeVar("_R")
_R_co = TypeVar("_R_co", covariant=True)


class CompileStats(Protocol):
    """numba's statistics of a compiled function (its dispatcher's ``stats``), as read here."""

    @property
    def cache_path(self) -> str: ...

    @property
    def cache_misses(self) -> Mapping[object, int]: ...


class Compiled(Protocol[_P, _R_co]):
    """A function compiled by numba (its dispatcher) as mypy reads it: called as the function
    is, and its compile statistics."""

    @property
    def stats(self) -> CompileStats: ...

    def __call__(self, *args: _P.args, **kwargs: _P.kwargs) -> _R_co: ...


if TYPE_CHECKING:
    # numba's njit is untyped, and an untyped decorator leaves the function untyped: its type as
    # used here. At run time njit is numba's own (the decorators and the cache unchanged).
    @overload
    def njit(function: Callable[_P, _R], /) -> Compiled[_P, _R]: ...
    @overload
    def njit(
        *, cache: bool = ..., nogil: bool = ...
    ) -> Callable[[Callable[_P, _R]], Compiled[_P, _R]]: ...
    def njit(*args: Any, **options: Any) -> Any: ...
else:
    from numba import njit

SOLVED = 0
UNDECIDED = 1  # the NumPy path decides
UNBOUNDED = 2  # the load works along a motion nothing blocks (the NumPy path raises)
NO_WORK = 3  # no load works on any admissible motion (the NumPy path answers "indeterminate")

BOUNDARY_STEP = 0.25  # a boundary step moves an active ball's or disc's image by this share of it

# indices into the tolerances array (its values are the NumPy path's constants, see fast_path.py)
POLISH, PROXIMAL, UNLOADED, ACTIVE_GAP, UNBOUNDED_FRACTION, ROUND_OFF_WORK = range(6)

# verified_optimum's answer: (code, y, multipliers, signs, KKT residuals, flat directions)
Optimum = tuple[int, Array, Array, Array, Array, Array]
# answer_arrays': (x, torsors, twists, gaps, force rows, measured residuals)
AnswerArrays = tuple[Array, Array, Array, Array, Array, Array]


@njit
def _norm(v: Array) -> float:
    total = 0.0
    for value in v:
        total += value * value
    return math.sqrt(total)


@njit
def _product(matrix: Array, vector: Array) -> Array:
    out = np.empty(matrix.shape[0])
    for i in range(matrix.shape[0]):
        total = 0.0
        for k in range(vector.size):
            total += matrix[i, k] * vector[k]
        out[i] = total
    return out


@njit(cache=True)
def load_objective(
    params: Array,
    load_matrix: Array,
    load_constant: Array,
    load_rows: Array,
    n: int,
    r: int,
    weights: Array,
    tolerances: Array,
) -> tuple[int, Array, float, Array, float, float]:
    r"""The reduced objective of one load (:meth:`.prepared.PreparedGeometry.problem`).

    Body wrenches at the world origin :math:`W = A p + w_0` (A: the loads' map of their force and
    torque vectors p [N, N m], :math:`w_0` the fixed loads, gravity), stacked rows
    :math:`(Z g, Q^T Z g, K^T Z g) = L W`; load size :math:`\sum_b |F_b| c + |M_b| c / l` [J]
    (``weights`` = (c, c / l)); :math:`\sigma = |Q^T Z g|`, f = Q^T Z g / sigma.

    Returns:
        (code, f (r,), sigma [J], Z g (n,), load size [J], share along unblocked motions).
    """
    wrench = _product(load_matrix, params) + load_constant
    size = 0.0
    for b in range(wrench.size // 6):
        size += weights[0] * _norm(wrench[6 * b : 6 * b + 3])
        size += weights[1] * _norm(wrench[6 * b + 3 : 6 * b + 6])
    stacked = _product(load_rows, wrench)
    scaled = stacked[:n]
    reduced = stacked[n : n + r]
    reference = max(_norm(scaled), size)
    free_size = _norm(stacked[n + r :])
    share = free_size / reference if reference > 0.0 else 0.0
    sigma = _norm(reduced)
    if reference > 0.0 and free_size > tolerances[UNBOUNDED_FRACTION] * reference:
        return UNBOUNDED, reduced, sigma, scaled, size, share
    if sigma <= tolerances[ROUND_OFF_WORK] * reference:
        return NO_WORK, reduced, sigma, scaled, size, share
    return SOLVED, reduced / sigma, sigma, scaled, size, share


@njit
def _phi_abs(matrix: Array, offset: Array, starts: Index, is_norm: Mask, y: Array) -> Array:
    """phi_j(y) of every contact, slabs on either side (|p^T y + o| - 1)."""
    count = is_norm.size
    phi = np.empty(count)
    for j in range(count):
        total = 0.0
        for i in range(starts[j], starts[j + 1]):
            image = offset[i]
            for c in range(y.size):
                image += matrix[i, c] * y[c]
            total += image * image if is_norm[j] else abs(image)
        phi[j] = total - 1.0
    return phi


@njit
def _sides(matrix: Array, offset: Array, starts: Index, is_norm: Mask, y: Array) -> Array:
    """+1 / -1: the side of every slab at y (1 for balls and discs)."""
    count = is_norm.size
    signs = np.ones(count)
    for j in range(count):
        if not is_norm[j]:
            i = starts[j]
            image = offset[i]
            for c in range(y.size):
                image += matrix[i, c] * y[c]
            if image < 0.0:
                signs[j] = -1.0
    return signs


@njit
def _gradients(
    matrix: Array,
    offset: Array,
    starts: Index,
    is_norm: Mask,
    signs: Array,
    contacts: Index,
    y: Array,
) -> tuple[Array, Array]:
    """(phi_j on the sides ``signs``, gradients (k, r)) of the ``contacts``."""
    values = np.empty(contacts.size)
    gradients = np.zeros((contacts.size, y.size))
    _gradients_into(matrix, offset, starts, is_norm, signs, contacts, y, values, gradients)
    return values, gradients


@njit
def _gradients_into(
    matrix: Array,
    offset: Array,
    starts: Index,
    is_norm: Mask,
    signs: Array,
    contacts: Index,
    y: Array,
    values: Array,
    gradients: Array,
) -> None:
    """:func:`_gradients` written into ``values`` (k,) and ``gradients`` (k, r) (Newton's
    iterations re-use them: an allocation costs more than these few products)."""
    r = y.size
    for a in range(contacts.size):
        j = contacts[a]
        total = 0.0
        for c in range(r):
            gradients[a, c] = 0.0
        for i in range(starts[j], starts[j + 1]):
            image = offset[i]
            for c in range(r):
                image += matrix[i, c] * y[c]
            if is_norm[j]:
                weight = 2.0 * image
                total += image * image
            else:
                weight = signs[j]
                total += signs[j] * image
            for c in range(r):
                gradients[a, c] += weight * matrix[i, c]
        values[a] = total - 1.0


@njit
def _hessian(
    matrix: Array, starts: Index, is_norm: Mask, contacts: Index, multipliers: Array, r: int
) -> Array:
    r""":math:`\nabla^2 L = \sum_{j \in A,\ norm} 2 \lambda_j P_j^T P_j`, (r, r)."""
    hessian = np.zeros((r, r))
    _hessian_into(matrix, starts, is_norm, contacts, multipliers, hessian)
    return hessian


@njit
def _hessian_into(
    matrix: Array, starts: Index, is_norm: Mask, contacts: Index, multipliers: Array, out: Array
) -> None:
    """:func:`_hessian` written into the top-left (r, r) block of ``out``."""
    r = matrix.shape[1]
    for c in range(r):
        for d in range(r):
            out[c, d] = 0.0
    for a in range(contacts.size):
        j = contacts[a]
        if not is_norm[j]:
            continue
        weight = 2.0 * multipliers[a]
        for i in range(starts[j], starts[j + 1]):
            for c in range(r):
                scaled = weight * matrix[i, c]
                for d in range(r):
                    out[c, d] += scaled * matrix[i, d]


@njit
def _lu_solve(matrix: Array, right: Array) -> tuple[bool, Array]:
    """x with matrix x = right by Gaussian elimination with partial pivoting; ok False when a
    pivot is zero or not finite (the matrix is singular)."""
    a = np.empty_like(matrix)
    x = np.empty_like(right)
    return _lu_solve_into(matrix, right, a, x), x


@njit
def _lu_solve_into(matrix: Array, right: Array, a: Array, x: Array) -> bool:
    """:func:`_lu_solve` in the workspaces ``a`` (n, n) and ``x`` (n,) (x holds the solution):
    ok."""
    size = right.size
    a[:, :] = matrix
    x[:] = right
    for col in range(size):
        pivot = col
        for row in range(col + 1, size):
            if abs(a[row, col]) > abs(a[pivot, col]):
                pivot = row
        if not (abs(a[pivot, col]) > 0.0) or not np.isfinite(a[pivot, col]):
            return False
        if pivot != col:
            for c in range(size):
                a[col, c], a[pivot, c] = a[pivot, c], a[col, c]
            x[col], x[pivot] = x[pivot], x[col]
        for row in range(col + 1, size):
            factor = a[row, col] / a[col, col]
            if factor != 0.0:
                for c in range(col + 1, size):
                    a[row, c] -= factor * a[col, c]
                x[row] -= factor * x[col]
    for row in range(size - 1, -1, -1):
        total = x[row]
        for c in range(row + 1, size):
            total -= a[row, c] * x[c]
        x[row] = total / a[row, row]
    return True


@njit
def _newton(matrix: Array, offset: Array, starts: Index, is_norm: Mask, objective: Array, y: Array,
            lam: Array, signs: Array, contacts: Index, iterations: int, accept: float,
            tolerances: Array) -> tuple[bool, Array, Array, Array]:  # fmt: skip
    """Newton on the KKT system of ``contacts`` (:func:`.kkt.newton` without its projected and
    least-squares steps); (ok, y, lambda_A, G_A)."""
    r = y.size
    k = contacts.size
    size = r + k
    y = y.copy()
    lam = lam.copy()
    kkt = np.zeros((size, size))
    residual = np.empty(size)
    converged = tolerances[POLISH] * tolerances[POLISH]
    previous = np.inf
    # workspaces of every iteration (allocations would cost more than the arithmetic)
    values = np.empty(k)
    gradients = np.zeros((k, r))
    factors = np.empty((size, size))
    step = np.empty(size)
    for iteration in range(iterations + 1):
        _gradients_into(matrix, offset, starts, is_norm, signs, contacts, y, values, gradients)
        for c in range(r):
            total = objective[c]
            for a in range(k):
                total += lam[a] * gradients[a, c]
            residual[c] = total
        for a in range(k):
            residual[r + a] = values[a]
        size_now = 0.0
        for value in residual:
            size_now += value * value
        # as kkt.newton: converged, or one step after a residual below 1e-8 (round-off left)
        if size_now < converged or (previous < 1e-16 and size_now <= accept * accept):
            return True, y, lam, gradients
        previous = size_now
        if iteration == iterations or (iteration >= 6 and size_now > 1e-8):
            break
        _hessian_into(matrix, starts, is_norm, contacts, lam, kkt)
        for a in range(k):
            for c in range(r):
                kkt[c, r + a] = gradients[a, c]
                kkt[r + a, c] = gradients[a, c]
            for b in range(k):
                kkt[r + a, r + b] = -tolerances[PROXIMAL] if a == b else 0.0
        ok = _lu_solve_into(kkt, residual, factors, step)
        step_size = 0.0
        for value in step:
            step_size += value * value
        if ok:
            ok = step_size < 1e12 and step_size <= 1e20 * size_now
        if ok:  # a nearly singular K gives a step that does not solve K s = r to round-off
            error = 0.0
            for row in range(size):
                total = -residual[row]
                for c in range(size):
                    total += kkt[row, c] * step[c]
                error += total * total
            ok = error <= 1e-18 * (1.0 + size_now)
        if not ok:
            largest = 0.0
            for value in residual:
                largest = max(largest, abs(value))
            return largest <= accept, y, lam, gradients
        for c in range(r):
            y[c] -= step[c]
        for a in range(k):
            lam[a] -= step[r + a]
    largest = 0.0
    for value in residual:
        largest = max(largest, abs(value))
    return largest <= accept, y, lam, gradients


@njit
def _singular_values(matrix: Array) -> tuple[Array, Array, Array]:
    """Singular values and right singular vectors (columns of V) of ``matrix`` (m, n) by one-sided
    Jacobi rotations (Hestenes): the columns of A V become orthogonal, their norms the singular
    values (accurate to round-off of the largest, as LAPACK's)."""
    a = matrix.copy()
    n = a.shape[1]
    v = np.eye(n)
    for _ in range(60):
        rotated = False
        for p in range(n - 1):
            for q in range(p + 1, n):
                alpha = 0.0
                beta = 0.0
                gamma = 0.0
                for i in range(a.shape[0]):
                    alpha += a[i, p] * a[i, p]
                    beta += a[i, q] * a[i, q]
                    gamma += a[i, p] * a[i, q]
                if gamma == 0.0 or abs(gamma) <= 1e-15 * math.sqrt(alpha * beta):
                    continue
                rotated = True
                zeta = (beta - alpha) / (2.0 * gamma)
                t = math.copysign(1.0, zeta) / (abs(zeta) + math.sqrt(1.0 + zeta * zeta))
                cos = 1.0 / math.sqrt(1.0 + t * t)
                sin = cos * t
                for i in range(a.shape[0]):
                    first = a[i, p]
                    a[i, p] = cos * first - sin * a[i, q]
                    a[i, q] = sin * first + cos * a[i, q]
                for i in range(n):
                    first = v[i, p]
                    v[i, p] = cos * first - sin * v[i, q]
                    v[i, q] = sin * first + cos * v[i, q]
        if not rotated:
            break
    singular = np.empty(n)
    for c in range(n):
        singular[c] = _norm(a[:, c])
    return singular, v, a


@njit
def _minimum_norm_solution(matrix: Array, right: Array) -> Array:
    r"""The minimum-norm least-squares solution of ``matrix`` x = ``right`` (numpy.linalg.lstsq's,
    its rank rule: singular values above eps max(m, n) of the largest count), from the Jacobi
    SVD :math:`A V = U \Sigma`: :math:`x = \sum_j V_j (U_j^T b) / \sigma_j`."""
    singular, v, rotated = _singular_values(matrix)
    top = 0.0
    for value in singular:
        top = max(top, value)
    cutoff = 2.220446049250313e-16 * max(matrix.shape[0], matrix.shape[1]) * top
    x = np.zeros(matrix.shape[1])
    for j in range(singular.size):
        if singular[j] > cutoff:
            along = 0.0
            for i in range(matrix.shape[0]):
                along += rotated[i, j] * right[i]
            along /= singular[j] * singular[j]  # U_j = (A V)_j / sigma_j
            for i in range(x.size):
                x[i] += v[i, j] * along
    return x


@njit
def _surely_full_rank(rows: Array, rtol: float) -> bool:
    """:func:`.prepared._surely_full_rank`: a Cholesky factor of R^T R - t I exists,
    t = max(rtol, 1e-6)^2 |R|_F^2 (every squared singular value above t)."""
    n = rows.shape[1]
    gram = np.zeros((n, n))  # loops, not rows.T @ rows: numba's matmul needs SciPy's BLAS
    for c in range(n):
        for d in range(n):
            total = 0.0
            for i in range(rows.shape[0]):
                total += rows[i, c] * rows[i, d]
            gram[c, d] = total
    ratio = max(rtol, 1e-6)
    trace = 0.0
    for c in range(n):
        trace += gram[c, c]
    shift = ratio * ratio * trace
    for c in range(n):
        gram[c, c] -= shift
    for c in range(n):  # Cholesky, lower triangle in place
        total = gram[c, c]
        for k in range(c):
            total -= gram[c, k] * gram[c, k]
        if not total > 0.0:
            return False
        gram[c, c] = math.sqrt(total)
        for row in range(c + 1, n):
            value = gram[row, c]
            for k in range(c):
                value -= gram[row, k] * gram[c, k]
            gram[row, c] = value / gram[c, c]
    return True


@njit
def _row_basis(gradients: Array, rtol: float) -> tuple[Array, Array, int, bool]:
    r"""Modified Gram-Schmidt on the rows g_a of ``gradients`` (k, r), each orthogonalised twice
    (accurate to round-off): (Q (k, r), its first ``rank`` rows an orthonormal basis of the rows'
    span, R (k, k) with :math:`g_a = \sum_b R_{ba} q_b`, rank, independent). A row left with less
    than ``rtol`` of the largest row's norm adds nothing to the basis (independent False)."""
    k, r = gradients.shape
    basis = np.zeros((k, r))
    coefficients = np.zeros((k, k))
    largest = 0.0
    for a in range(k):
        largest = max(largest, _norm(gradients[a]))
    rank = 0
    independent = True
    for a in range(k):
        q = gradients[a].copy()
        for _ in range(2):
            for b in range(rank):
                along = 0.0
                for c in range(r):
                    along += basis[b, c] * q[c]
                coefficients[b, a] += along
                for c in range(r):
                    q[c] -= along * basis[b, c]
        size = _norm(q)
        if size > rtol * largest and size > 0.0:
            for c in range(r):
                basis[rank, c] = q[c] / size
            coefficients[rank, a] = size
            rank += 1
        else:
            independent = False
    return basis, coefficients, rank, independent


@njit
def _least_squares_forces(gradients: Array, objective: Array) -> Array:
    r"""The minimum-norm least-squares solution of :math:`G^T \lambda = -f` (numpy.linalg.lstsq's):
    from the Gram-Schmidt factors when the rows of G are independent to 1e-10 (back
    substitution :math:`R \lambda = -Q f`), else by the Jacobi SVD."""
    basis, coefficients, _, independent = _row_basis(gradients, 1e-10)
    if not independent:
        return _minimum_norm_solution(gradients.T.copy(), -objective)
    k, r = gradients.shape
    right = np.empty(k)
    for b in range(k):
        along = 0.0
        for c in range(r):
            along -= basis[b, c] * objective[c]
        right[b] = along
    forces = np.empty(k)
    for a in range(k - 1, -1, -1):
        total = right[a]
        for b in range(a + 1, k):
            total -= coefficients[a, b] * forces[b]
        forces[a] = total / coefficients[a, a]
    return forces


@njit
def _flat_directions(
    matrix: Array,
    offset: Array,
    starts: Index,
    is_norm: Mask,
    y: Array,
    multipliers: Array,
    signs: Array,
    tolerances: Array,
) -> Array:
    """:meth:`.prepared.PreparedGeometry.flat_directions`: an orthonormal basis (r, k) of the
    directions along which the optimum is not unique (G_loaded d = 0 and Hessian d = 0, to 1e-9
    of the largest)."""
    r = y.size
    count = multipliers.size
    largest = 0.0
    for value in multipliers:
        largest = max(largest, value)
    loaded_count = 0
    for value in multipliers:
        if value > tolerances[UNLOADED] * largest:
            loaded_count += 1
    loaded = np.empty(loaded_count, dtype=np.int64)
    at = 0
    for j in range(count):
        if multipliers[j] > tolerances[UNLOADED] * largest:
            loaded[at] = j
            at += 1
    _, gradients = _gradients(matrix, offset, starts, is_norm, signs, loaded, y)
    every = np.arange(count)
    rows = np.empty((loaded_count + r, r))
    rows[:loaded_count] = gradients
    rows[loaded_count:] = _hessian(matrix, starts, is_norm, every, multipliers, r)
    scale = 1.0
    for value in rows.ravel():
        scale = max(scale, abs(value))
    rows /= scale
    if _surely_full_rank(rows, 1e-9):
        return np.zeros((r, 0))
    singular, v, _ = _singular_values(rows)
    top = 0.0
    for value in singular:
        top = max(top, value)
    flat = 0
    for value in singular:
        if not (top > 0.0 and value > 1e-9 * top):
            flat += 1
    out = np.empty((r, flat))
    at = 0
    for c in range(r):
        if not (top > 0.0 and singular[c] > 1e-9 * top):
            out[:, at] = v[:, c]
            at += 1
    return out


@njit
def _contact_to_release(
    matrix: Array,
    offset: Array,
    starts: Index,
    is_norm: Mask,
    objective: Array,
    y: Array,
    signs: Array,
    contacts: Index,
) -> int:
    """:func:`.kkt._contact_to_release`: the active contact whose least-squares multiplier is most
    negative (it pulls), else the most open one if it is not quite touching; -1 if none."""
    if contacts.size <= 1:
        return -1
    values, gradients = _gradients(matrix, offset, starts, is_norm, signs, contacts, y)
    least = _least_squares_forces(gradients, objective)
    lowest = np.argmin(least)
    if least[lowest] < -1e-12:
        return int(contacts[lowest])
    most_open = np.argmin(values)
    return int(contacts[most_open]) if values[most_open] < -1e-14 else -1


@njit
def _unbalanced_motion(
    matrix: Array,
    offset: Array,
    starts: Index,
    is_norm: Mask,
    objective: Array,
    y: Array,
    signs: Array,
    contacts: Index,
) -> Array:
    """-f projected orthogonally to the gradients of ``contacts`` at y (their Gram-Schmidt
    basis, applied twice: orthogonal to round-off): the motion along which the load is not held."""
    r = y.size
    _, gradients = _gradients(matrix, offset, starts, is_norm, signs, contacts, y)
    basis, _, rank, _ = _row_basis(gradients, 1e-12)
    direction = -objective.copy()
    for _ in range(2):
        for b in range(rank):
            along = 0.0
            for c in range(r):
                along += basis[b, c] * direction[c]
            for c in range(r):
                direction[c] -= along * basis[b, c]
    return direction


@njit
def _step_to_next_contact(
    matrix: Array,
    offset: Array,
    starts: Index,
    is_norm: Mask,
    objective: Array,
    y: Array,
    signs: Array,
    contacts: Index,
    active: Mask,
) -> int:
    """:func:`.kkt._step_to_next_contact`: move y in place along the load's unbalanced part,
    tangent to the active contacts, to the first contact it meets; that contact's index, or -1
    when no contact bounds that motion. Tangent: orthogonal to the active gradients (their
    Gram-Schmidt basis; a gradient left with 1e-12 of the largest's norm adds nothing, as a
    singular value below 1e-12 of the largest did in an SVD, at a tenth of its cost)."""
    r = y.size
    direction = _unbalanced_motion(matrix, offset, starts, is_norm, objective, y, signs, contacts)
    if _norm(direction) <= 1e-14:
        return -1
    best, reached = _first_contact_along(matrix, offset, starts, is_norm, y, direction, active,
                                         np.inf)  # fmt: skip
    if reached < 0:
        return -1
    for k in range(r):
        y[k] += best * direction[k]
    return reached


@njit
def _step_along_boundary(
    matrix: Array,
    offset: Array,
    starts: Index,
    is_norm: Mask,
    objective: Array,
    y: Array,
    signs: Array,
    contacts: Index,
    active: Mask,
) -> int:
    r""":func:`_step_to_next_contact` for the start from the centre, where the parts travel far:
    the tangent step leaves a curved (ball, disc) contact of the set by the square of its
    length, so a step moves no active contact's image by more than :data:`BOUNDARY_STEP` of its
    radius and y then returns onto the set's contacts (minimum-norm Gauss-Newton on
    :math:`\phi_A(y) = 0`): a walk along the boundary. The contact reached, -2 when the step
    was capped (y moved, no contact met), -1 when no contact bounds the motion."""
    r = y.size
    direction = _unbalanced_motion(matrix, offset, starts, is_norm, objective, y, signs, contacts)
    if _norm(direction) <= 1e-14:
        return -1
    cap = np.inf
    for a in range(contacts.size):
        j = contacts[a]
        if not is_norm[j]:
            continue
        moved = 0.0
        for i in range(starts[j], starts[j + 1]):
            along = 0.0
            for c in range(r):
                along += matrix[i, c] * direction[c]
            moved += along * along
        if moved > 0.0:
            cap = min(cap, BOUNDARY_STEP / math.sqrt(moved))
    best, reached = _first_contact_along(matrix, offset, starts, is_norm, y, direction, active,
                                         np.inf)  # fmt: skip
    if reached < 0 and cap == np.inf:
        return -1
    if best > cap:
        best, reached = cap, -2
    for k in range(r):
        y[k] += best * direction[k]
    _restore(matrix, offset, starts, is_norm, y, signs, contacts)
    phi = _phi_abs(matrix, offset, starts, is_norm, y)
    worst = 1e-12  # a contact the walk passed (touching where it starts, or met on the way back)
    for j in range(is_norm.size):
        if not active[j] and phi[j] > worst:
            worst, reached = phi[j], j
    return reached


@njit
def _restore(
    matrix: Array,
    offset: Array,
    starts: Index,
    is_norm: Mask,
    y: Array,
    signs: Array,
    contacts: Index,
) -> None:
    r"""y moved in place back onto the contacts' surfaces, :math:`\phi_A(y) = 0`, by at most 8
    minimum-norm Gauss-Newton steps :math:`\delta = -G_A^+ \phi_A` (Gram-Schmidt factors
    :math:`G_A = R^T Q`: forward substitution :math:`R^T z = -\phi_A`, :math:`\delta = Q^T z`;
    left where it is when the gradients are dependent)."""
    r = y.size
    k = contacts.size
    for _ in range(8):
        values, gradients = _gradients(matrix, offset, starts, is_norm, signs, contacts, y)
        largest = 0.0
        for value in values:
            largest = max(largest, abs(value))
        if largest <= 1e-15:
            return
        basis, coefficients, _, independent = _row_basis(gradients, 1e-10)
        if not independent:
            return
        z = np.empty(k)
        for a in range(k):
            total = -values[a]
            for b in range(a):
                total -= coefficients[b, a] * z[b]
            z[a] = total / coefficients[a, a]
        for a in range(k):
            for c in range(r):
                y[c] += z[a] * basis[a, c]


@njit
def _first_contact_along(
    matrix: Array,
    offset: Array,
    starts: Index,
    is_norm: Mask,
    y: Array,
    direction: Array,
    active: Mask,
    limit: float,
) -> tuple[float, int]:
    """(t, j): the first contact j outside ``active`` that y + t direction meets, 0 <= t <
    ``limit`` (ball, disc: the larger root of |image + t moved|^2 = 1; slab: its side's plane);
    (inf, -1) when none does."""
    r = y.size
    best, reached = np.inf, -1
    for j in range(is_norm.size):
        if active[j]:
            continue
        a, b, c0 = 0.0, 0.0, 0.0
        slope, image0 = 0.0, 0.0
        for i in range(starts[j], starts[j + 1]):
            image = offset[i]
            moved = 0.0
            for k in range(r):
                image += matrix[i, k] * y[k]
                moved += matrix[i, k] * direction[k]
            a += moved * moved
            b += image * moved
            c0 += image * image
            slope, image0 = moved, image
        if is_norm[j]:
            if a <= 0.0:
                continue
            t = (-b + math.sqrt(max(b * b - a * (c0 - 1.0), 0.0))) / a
        else:
            if slope == 0.0:
                continue
            t = (math.copysign(1.0, slope) - image0) / slope
        if 0.0 <= t < best and t < limit:
            best, reached = t, j
    return best, reached


@njit
def _multiplier_estimate(
    matrix: Array,
    offset: Array,
    starts: Index,
    is_norm: Mask,
    objective: Array,
    y: Array,
    signs: Array,
    contacts: Index,
) -> Array:
    r"""Newton's starting multipliers of ``contacts`` at y: the least-squares solution of the
    stationarity :math:`G_A^T \lambda = -f` (minimum norm), negative values set to zero. The new
    load's own estimate, not the previous answer's multipliers: from those, Newton diverged on a
    load turned by 17 degrees (the multiplier of a lightly loaded contact crossed zero)."""
    _, gradients = _gradients(matrix, offset, starts, is_norm, signs, contacts, y)
    least = _least_squares_forces(gradients, objective)
    for a in range(least.size):
        least[a] = max(least[a], 0.0)
    return least


@njit
def kkt_residuals(
    objective: Array, gradients: Array, contacts: Index, multipliers: Array, phi: Array
) -> Array:
    """The kernel's copy of :func:`.kkt.kkt_table` for one answer (tested against it): the
    stationarity :math:`\\lVert f + \\sum_a \\lambda_{c_a} \\nabla\\phi_{c_a} \\rVert_\\infty` over
    the contacts ``contacts`` whose gradients are the rows of ``gradients``, feasibility
    :math:`\\max(\\phi, 0)`, complementarity :math:`\\max |\\lambda_j \\phi_j|` and dual
    infeasibility :math:`\\max(-\\lambda, 0)` over all m contacts; (4,)."""
    measured = np.zeros(4)
    for c in range(objective.size):
        total = objective[c]
        for a in range(contacts.size):
            total += multipliers[contacts[a]] * gradients[a, c]
        measured[0] = max(measured[0], abs(total))
    for j in range(phi.size):
        measured[1] = max(measured[1], phi[j])
        measured[2] = max(measured[2], abs(multipliers[j] * phi[j]))
        measured[3] = max(measured[3], -multipliers[j])
    return measured


@njit
def verified_optimum(matrix: Array, offset: Array, starts: Index, is_norm: Mask, objective: Array,
                     y0: Array, lam0: Array, signs0: Array, accept: float, rounds: int,
                     iterations: int, tolerances: Array,
                     primal: bool | np.bool_) -> Optimum:  # fmt: skip
    """The verified active-set method of :func:`.kkt.active_set_solve` from a guess
    (y0, lambda0, slab sides), then the flat directions, the minimum-norm point along them.
    ``primal`` (the start from the centre): Newton from the least-squares multipliers, steps
    along the boundary (:func:`_step_along_boundary`), and where no step is left the contacts
    touching there join. Its callers pass ``np.bool_``, not a literal True or False: numba
    compiles this function once, not once per value.

    Returns:
        (code, y, multipliers (m,), signs (m,), KKT residuals (stationarity, feasibility,
        complementarity), flat directions (r, k)).
    """
    r = y0.size
    count = is_norm.size
    signs = signs0.copy()
    phi = _phi_abs(matrix, offset, starts, is_norm, y0)
    largest = 1.0
    for value in lam0:
        largest = max(largest, value)
    active = np.zeros(count, dtype=np.bool_)
    for j in range(count):
        active[j] = phi[j] > -tolerances[ACTIVE_GAP] or lam0[j] > 1e-9 * largest
    lam = lam0.copy()
    y = y0.copy()
    residuals = np.zeros(3)
    nothing = np.zeros((r, 0))
    for _ in range(rounds):
        contacts = np.flatnonzero(active)
        if contacts.size == 0:  # nothing touches (a cold start): move along the load to a contact
            reached = _step_to_next_contact(matrix, offset, starts, is_norm, objective, y, signs,
                                            contacts, active)  # fmt: skip
            if reached < 0:
                break
            signs = _sides(matrix, offset, starts, is_norm, y)
            active[reached] = True
            continue
        start = lam[contacts]
        if primal or not start.max() > 0.0:  # from the centre, or none known: the estimate
            start = _multiplier_estimate(matrix, offset, starts, is_norm, objective, y, signs,
                                         contacts)  # fmt: skip
        ok, y_new, lam_active, gradients = _newton(
            matrix, offset, starts, is_norm, objective, y, start, signs, contacts, iterations,
            accept, tolerances,
        )  # fmt: skip
        if not ok:  # an over- or under-constrained set: release a contact, or step to one
            leaving = _contact_to_release(matrix, offset, starts, is_norm, objective, y, signs,
                                          contacts)  # fmt: skip
            if leaving >= 0:
                active[leaving] = False
                continue
            if primal:
                reached = _step_along_boundary(matrix, offset, starts, is_norm, objective, y,
                                               signs, contacts, active)  # fmt: skip
            else:
                reached = _step_to_next_contact(matrix, offset, starts, is_norm, objective, y,
                                                signs, contacts, active)  # fmt: skip
            if reached == -1 and primal:
                # nowhere to go: the contacts touching here join (a point where more contacts
                # touch than a set of independent ones holds: they share the load)
                phi = _phi_abs(matrix, offset, starts, is_norm, y)
                for j in range(count):
                    if not active[j] and phi[j] > -1e-9:
                        active[j] = True
                        reached = j
            if reached == -1:
                break
            signs = _sides(matrix, offset, starts, is_norm, y)
            if reached >= 0:
                active[reached] = True
            continue
        for a in range(contacts.size):  # the next round's Newton starts from these
            lam[contacts[a]] = max(lam_active[a], 0.0)
        released = False
        for a in range(contacts.size):
            if lam_active[a] < -1e-12:
                active[contacts[a]] = False
                released = True
        if released:
            continue
        phi_new = _phi_abs(matrix, offset, starts, is_norm, y_new)
        bar = max(1e-13, accept)
        violated = False
        for j in range(count):
            if phi_new[j] > bar:
                violated = True
        if violated:
            # move towards y_new only as far as the first contact it meets, which joins the set:
            # from y itself Newton finds y_new again (a cycle), and from y_new, outside that
            # contact, it can converge to the set's other KKT point, the contact pulling
            step = y_new - y
            t, reached = _first_contact_along(matrix, offset, starts, is_norm, y, step, active,
                                              1.0)  # fmt: skip
            if reached >= 0:
                for k in range(r):
                    y[k] += t * step[k]
                active[reached] = True
            else:  # y itself outside a contact (round-off): every violated contact joins
                for j in range(count):
                    if phi_new[j] > bar:
                        active[j] = True
            signs = _sides(matrix, offset, starts, is_norm, y)
            continue
        # contacts touching at y_new outside the set (a block's corners on one face, reached
        # one by one) share the load where it is indeterminate: the split over all of them
        touching = active | (phi_new > -bar)
        if np.count_nonzero(touching) > contacts.size:
            sides_new = _sides(matrix, offset, starts, is_norm, y_new)
            newton_forces = np.zeros(count)
            for a in range(contacts.size):
                newton_forces[contacts[a]] = lam_active[a]
            signs = signs.copy()
            for j in range(count):
                if touching[j] and not active[j]:
                    signs[j] = sides_new[j]
            contacts = np.flatnonzero(touching)
            _, gradients = _gradients(matrix, offset, starts, is_norm, signs, contacts, y_new)
            lam_active = newton_forces[contacts]
        # the forces are unique when the active gradients are independent; otherwise the
        # minimum-norm set balancing the load, when no force of it pulls (kkt's
        # _minimum_norm_forces: statically indeterminate contacts share the load evenly)
        forces = lam_active
        independent = contacts.size <= r
        if independent and not _surely_full_rank(gradients.T.copy(), 1e-10):
            singular, _, _ = _singular_values(gradients.T.copy())
            low, high = np.inf, 0.0
            for value in singular:
                low = min(low, value)
                high = max(high, value)
            independent = low > 1e-10 * high
        if not independent:
            least = _minimum_norm_solution(gradients.T.copy(), -objective)
            if least.min() >= -1e-14:
                forces = least
        multipliers = np.zeros(count)
        for a in range(contacts.size):
            multipliers[contacts[a]] = max(forces[a], 0.0)
        # dual infeasibility is 0: the multipliers were clipped at 0 above
        measured = kkt_residuals(objective, gradients, contacts, multipliers, phi_new)
        residuals[0], residuals[1], residuals[2] = measured[0], measured[1], measured[2]
        if max(measured[0], measured[1], measured[2]) > accept:
            break
        flat = _flat_directions(matrix, offset, starts, is_norm, y_new, multipliers, signs,
                                tolerances)  # fmt: skip
        if flat.shape[1]:
            centred = y_new.copy()
            for c in range(flat.shape[1]):
                along = 0.0
                for d in range(r):
                    along += flat[d, c] * y_new[d]
                for d in range(r):
                    centred[d] -= flat[d, c] * along
            phi_centred = _phi_abs(matrix, offset, starts, is_norm, centred)
            worst = -np.inf
            for value in phi_centred:
                worst = max(worst, value)
            if worst <= 1e-13:
                y_new = centred
        return SOLVED, y_new, multipliers, signs, residuals, flat
    return UNDECIDED, y, lam, signs, residuals, nothing


@njit
def answer_arrays(y: Array, multipliers: Array, signs: Array, sigma: float,
                  scaled_gradient: Array, load_size: float, x_from_y: Array, torsor_rows: Array,
                  twist_rows: Array, contact_rows: Array, contact_offsets: Array,
                  contact_starts: Index, bounds: Array, row_contact: Index, norm_force: Array,
                  slab_force: Array, reactions: Array, scale: Array,
                  statics_weights: Array) -> AnswerArrays:  # fmt: skip
    r"""The answer's arrays (:func:`.linear_answer.assemble_linear`): x = Z Q y, joint torsors,
    body twists, contact gaps [m] and force rows [N]
    (:math:`f = -2\sigma\lambda_j (o_j + S_j x) / c_j^2`, slab :math:`-\sigma\lambda_j s_j / c_j`),
    and (statics residual, largest penetration [m], over the play, largest rotation [rad],
    potential g^T x [J]); the statics residual is
    :meth:`.prepared.PreparedGeometry.statics_residual` (weights W: forces and moments in N
    whatever the joint's play)."""
    x = _product(x_from_y, y)
    torsors = _product(torsor_rows, x)
    twists = _product(twist_rows, x)
    image = _product(contact_rows, x) + contact_offsets
    count = bounds.size
    gaps = np.empty(count)
    for j in range(count):
        total = 0.0
        for i in range(contact_starts[j], contact_starts[j + 1]):
            total += image[i] * image[i]
        gaps[j] = bounds[j] - math.sqrt(total)
    forces = np.empty(image.size)
    for i in range(image.size):
        j = row_contact[i]
        forces[i] = sigma * multipliers[j] * (norm_force[i] * image[i] + slab_force[i] * signs[j])
    n = x.size
    imbalance = np.empty(n)
    reference = 0.0
    energy = 0.0
    for c in range(n):
        total = scaled_gradient[c] / scale[c]
        energy += total * x[c]
        for i in range(image.size):
            total -= forces[i] * contact_rows[i, c]
        imbalance[c] = statics_weights[c] * total
        weighted = statics_weights[c] * scaled_gradient[c] / scale[c]
        reference += weighted * weighted
    for k in range(reactions.shape[1]):
        along = 0.0
        for c in range(n):
            along += imbalance[c] * reactions[c, k]
        for c in range(n):
            imbalance[c] -= along * reactions[c, k]
    reference = max(math.sqrt(reference), load_size)
    statics = _norm(imbalance) / (reference if reference > 0.0 else 1.0)
    violation = 0.0
    relative = 0.0
    for j in range(count):
        violation = max(violation, -gaps[j])
        relative = max(relative, -gaps[j] / bounds[j])
    rotation = 0.0
    for joint in range(torsors.size // 6):
        rotation = max(rotation, _norm(torsors[6 * joint + 3 : 6 * joint + 6]))
    measured = np.array([statics, violation, relative, rotation, energy])
    return x, torsors, twists, gaps, forces, measured


@njit
def _nearest_row(rows: Array, count: int, vector: Array) -> int:
    """The index of the row among the first ``count`` of ``rows`` nearest ``vector``."""
    best, nearest = np.inf, 0
    for i in range(count):
        distance = 0.0
        for c in range(vector.size):
            difference = rows[i, c] - vector[c]
            distance += difference * difference
        if distance < best:
            best, nearest = distance, i
    return nearest


# the first columns of solve_cases' rows: code, sigma, load size, share, 3 KKT residuals,
# statics, penetration [m], over the play, largest rotation, energy, the start that verified
ENERGY, START, SCALARS = 11, 12, 13
FLAT_FOUND = 4  # the optimum has flat directions and the caller asked for none (a batch)
# START: the caller's guess, the previous case's answer (chain), the centred position
FROM_GUESS, FROM_NEIGHBOUR, FROM_CENTRE = 0, 1, 2


@njit(cache=True, nogil=True)  # nogil: a batch's chunks run on threads at once
def solve_cases(params: Array, load_matrix: Array, load_constant: Array, load_rows: Array,
                n: int, weights: Array, matrix: Array, offset: Array, starts: Index,
                is_norm: Mask, y0: Array, lam0: Array, signs0: Array, accept: float,
                warm_rounds: int, rounds: int, iterations: int, tolerances: Array,
                x_from_y: Array, torsor_rows: Array, twist_rows: Array, contact_rows: Array,
                contact_offsets: Array, bounds: Array, row_contact: Index, norm_force: Array,
                slab_force: Array, reactions: Array, scale: Array, statics_weights: Array,
                chain: bool, allow_flat: bool, pool_f: Array, pool_y: Array, pool_lam: Array,
                pool_signs: Array, pool_state: Index,
                pooled: bool) -> tuple[Array, Array]:  # fmt: skip
    """Load cases (rows of ``params``, (N, 3 k)) solved in sequence: objective
    (:func:`load_objective`), the verified optimum (:func:`verified_optimum`) in ``warm_rounds``
    active-set rounds from the guess (y0, lambda0, sides) or, with ``chain``, from the previous
    case's answer, else in ``rounds`` rounds from the centred position y = 0 with no contact (a
    primal active-set method: along the load to the first contact, then Newton, release and
    add), the answer's arrays (:func:`answer_arrays`); one compiled call for one re-solve or a
    whole batch. ``warm_rounds`` 0: from the centre only (a cold solve).

    The pool (``pool_f`` (W, r), ``pool_y`` (W, r), ``pool_lam`` (W, m), ``pool_signs`` (W, m),
    ``pool_state`` = (entries, next slot)) keeps the last W answers with their objectives f; it
    is updated in place with every answer. With ``pooled``, a warm case starts from the answer
    whose f is nearest its own (the optimum depends on f alone, so the nearest f is the nearest
    known optimum), the guess only while the pool is empty.

    Returns:
        (rows (N, width): per case :data:`SCALARS` scalars then y (r), multipliers (m), sides
        (m), x (n), torsors, twists, gaps (m), force rows; NaN after a code other than SOLVED;
        the flat directions (r, k) of the last case solved).
    """
    cases = params.shape[0]
    r = y0.size
    m = is_norm.size
    rows_count = offset.size
    torsor_size = torsor_rows.shape[0]
    twist_size = twist_rows.shape[0]
    width = SCALARS + r + 2 * m + n + torsor_size + twist_size + m + rows_count
    out = np.full((cases, width), np.nan)
    flat_last = np.zeros((r, 0))
    y_start, lam_start, signs_start = y0, lam0, signs0
    start = FROM_GUESS
    centre = np.zeros(r)
    no_force = np.zeros(m)
    centre_sides = _sides(matrix, offset, starts, is_norm, centre)
    for k in range(cases):
        code, objective, sigma, scaled, size, share = load_objective(
            params[k], load_matrix, load_constant, load_rows, n, r, weights, tolerances
        )
        out[k, 0] = code
        out[k, 1], out[k, 2], out[k, 3] = sigma, size, share
        if code != SOLVED:
            continue
        found = UNDECIDED
        used = FROM_CENTRE
        if warm_rounds > 0 and pooled and pool_state[0] > 0:
            nearest = _nearest_row(pool_f, pool_state[0], objective)
            y_start, lam_start, signs_start = (
                pool_y[nearest],
                pool_lam[nearest],
                pool_signs[nearest],
            )
            start = FROM_NEIGHBOUR
        if warm_rounds > 0:
            found, y, lam, signs, kkt, flat = verified_optimum(
                matrix, offset, starts, is_norm, objective, y_start, lam_start, signs_start,
                accept, warm_rounds, iterations, tolerances, np.bool_(False),
            )  # fmt: skip
            used = start
        if found != SOLVED:
            # a far guess's contact set can be one the rounds do not leave: from the centre
            found, y, lam, signs, kkt, flat = verified_optimum(
                matrix, offset, starts, is_norm, objective, centre, no_force, centre_sides,
                accept, rounds, iterations, tolerances, np.bool_(True),
            )  # fmt: skip
            used = FROM_CENTRE
        if found != SOLVED:
            out[k, 0] = UNDECIDED
            continue
        if flat.shape[1] and not allow_flat:
            out[k, 0] = FLAT_FOUND
            continue
        x, torsors, twists, gaps, forces, measured = answer_arrays(
            y, lam, signs, sigma, scaled, size, x_from_y, torsor_rows, twist_rows,
            contact_rows, contact_offsets, starts, bounds, row_contact, norm_force, slab_force,
            reactions, scale, statics_weights,
        )  # fmt: skip
        out[k, 4], out[k, 5], out[k, 6] = kkt[0], kkt[1], kkt[2]
        for i in range(measured.size):
            out[k, 7 + i] = measured[i]
        out[k, START] = used
        at = SCALARS
        for block in (y, lam, signs, x, torsors, twists, gaps, forces):
            out[k, at : at + block.size] = block
            at += block.size
        flat_last = flat
        capacity = pool_f.shape[0]
        if capacity > 0:
            slot = pool_state[1]
            pool_f[slot] = objective
            pool_y[slot] = y
            pool_lam[slot] = lam
            pool_signs[slot] = signs
            pool_state[1] = (slot + 1) % capacity
            pool_state[0] = min(pool_state[0] + 1, capacity)
        if chain:
            y_start, lam_start, signs_start = y, lam, signs
            start = FROM_NEIGHBOUR
    return out, flat_last


def warm_up() -> None:
    """Compile (or load from numba's cache) every entry point on a tiny problem (one disc contact
    of one unknown pair, no load map row but the objective's), so that no solve later pays."""
    tolerances = np.array([1e-14, 1e-12, 1e-9, 1e-6, 1e-9, 1e-12])
    matrix, offset = np.eye(2), np.zeros(2)
    starts, is_norm = np.array([0, 2], dtype=np.int64), np.ones(1, dtype=np.bool_)
    load_rows = np.zeros((4, 12))
    load_rows[2, 0] = 1.0  # the load's x component along the first reduced unknown
    arguments = (np.ones((1, 3)), np.eye(12, 3), np.zeros(12), load_rows, 2, np.ones(2))
    load_objective(arguments[0][0], *arguments[1:4], 2, 2, arguments[5], tolerances)
    solve_cases(
        *arguments, matrix, offset, starts, is_norm, np.array([-1.0, 0.0]), np.array([0.5]),
        np.ones(1), 1e-12, 3, 10, 12, tolerances, np.eye(2), np.ones((6, 2)), np.ones((12, 2)),
        np.eye(2), np.zeros(2), np.ones(1), np.zeros(2, dtype=np.int64), np.ones(2), np.zeros(2),
        np.zeros((2, 0)), np.ones(2), np.ones(2), True, True, np.zeros((1, 2)), np.zeros((1, 2)),
        np.zeros((1, 1)), np.ones((1, 1)), np.zeros(2, dtype=np.int64), True,
    )  # fmt: skip
