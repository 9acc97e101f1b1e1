"""Small numeric helpers: 3-vector products faster than NumPy's generics on tiny arrays, and the
library's one rank rule (row, null and column spaces by one SVD, tolerances stated by each caller).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

#: the largest load [N, N m, m/s^2], point coordinate or model origin [m] taken: every product
#: of two of them stays within double precision (clearance_pin.arguments' docstring)
LARGEST_MAGNITUDE = 1e150

# the array types the solver's annotations name (equilibrium/ and what it reads)
Array = npt.NDArray[np.float64]
Mask = npt.NDArray[np.bool_]
Index = npt.NDArray[np.intp]


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product a x b of two 3-vectors (numpy.cross costs ~20x more on shape (3,))."""
    return np.array(
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    )


def norm(v: np.ndarray) -> float:
    """Euclidean norm of a 1-D array as a float (numpy.linalg.norm's cost is mostly its checks)."""
    return math.sqrt(float(np.dot(v, v)))


@dataclass(frozen=True)
class RowSpaces:
    """One SVD of a matrix A (m, n), split by its rank.

    Attributes:
        row: orthonormal basis (n, rank) of the row space of A (the motions its rows see).
        null: orthonormal basis (n, n - rank) of its null space (A d = 0).
        singular: the singular values, largest first.
        rank: how many singular values count (:func:`row_spaces`).
    """

    row: np.ndarray
    null: np.ndarray
    singular: np.ndarray
    rank: int


def row_spaces(matrix: np.ndarray, rtol: float, atol: float = 0.0) -> RowSpaces:
    r"""Row and null spaces of ``matrix`` (m, n) by one SVD: the one rank rule of the library.

    A singular value :math:`s_i` counts towards the rank when :math:`s_i > rtol\, s_0` and
    :math:`s_i > atol` (:math:`s_0` the largest). Every caller states its tolerances: ``atol``
    where the rows have a known natural size (normalised rows), so that a block of rows that are
    all round-off has rank 0, which a purely relative test cannot see.
    """
    matrix = np.atleast_2d(matrix)
    m, n = matrix.shape
    if matrix.size == 0:
        return RowSpaces(np.zeros((n, 0)), np.eye(n), np.zeros(0), 0)
    _, singular, vt = np.linalg.svd(matrix, full_matrices=m < n)
    if singular.size == 0 or singular[0] == 0.0:
        return RowSpaces(np.zeros((n, 0)), np.eye(n), singular, 0)
    rank = int(np.sum((singular > rtol * singular[0]) & (singular > atol)))
    return RowSpaces(vt[:rank].T.copy(), vt[rank:].T.copy(), singular, rank)


def null_space(matrix: np.ndarray, rtol: float = 1e-10, atol: float = 0.0) -> np.ndarray:
    """Orthonormal basis (n, n - rank) of the null space of ``matrix`` (m, n)
    (:func:`row_spaces`' rule)."""
    return row_spaces(matrix, rtol, atol).null


def column_space(matrix: np.ndarray, rtol: float) -> np.ndarray:
    """Orthonormal basis (m, rank) of the column space of ``matrix`` (m, n) by one thin SVD, with
    :func:`row_spaces`' rule (a singular value counts above ``rtol`` of the largest)."""
    if matrix.size == 0:
        return np.zeros((matrix.shape[0], 0))
    u, singular, _ = np.linalg.svd(matrix, full_matrices=False)
    if singular.size == 0 or singular[0] == 0.0:
        return np.zeros((matrix.shape[0], 0))
    return u[:, : int(np.sum(singular > rtol * singular[0]))].copy()
