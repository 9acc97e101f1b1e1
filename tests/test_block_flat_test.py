"""The closed forms' uniqueness test (clearance_pin/equilibrium/blocks.py): its cheap bound and its
exact test grouped by block shape, against singular values computed here with LAPACK, group by
group, on a long journal chain (benchmarks/scaling.py's revolute_chain) and the 6R arm.

- the exact test equals a per-group SVD of B_g = [G_g; H_g] written here from the definitions
  (docs/method.md section 3.2: loaded gradients w_i P_i, w = 2 e / c, Hessian 2 lambda P^T P);
- the bound is conservative: every case it clears, the exact test clears too.
"""

from __future__ import annotations

import numpy as np
import pytest
from test_chain_scaling import SCALING

import clearance_pin as cp
from clearance_pin.equilibrium import blocks
from clearance_pin.equilibrium.kkt import UNLOADED
from clearance_pin.equilibrium.prepared import prepared_geometry

ROOT = __import__("pathlib").Path(__file__).resolve().parents[1]


def _structure(mechanism):
    return blocks.block_structure(prepared_geometry(mechanism).geometry, False)


def _cases(structure, rng, count):
    """Random loads' closed-form images and multipliers (what closed_forms passes on)."""
    n = structure.scale.size
    gradients = rng.standard_normal((count, n)) * rng.uniform(1e-6, 1.0, (count, 1))
    # a few cases with one joint barely loaded, where the bound is too loose to decide
    gradients[: count // 2, : n // 3] *= 1e-7
    a = gradients @ structure.gradient_to_rows
    sizes = np.sqrt((a * a) @ structure.row_sums)
    multipliers = sizes * structure.multiplier_factor
    images = a * (-structure.bounds / np.where(sizes > 0.0, sizes, 1.0))[:, structure.row_contact]
    largest = multipliers.max(axis=1)[:, None]
    loaded = multipliers > blocks.LOADED_SHARE * largest
    all_loaded = loaded @ structure.members == structure.group_size
    unloaded = (multipliers <= blocks.NEGLIGIBLE_SHARE * largest) @ structure.members == (
        structure.group_size
    )
    return images, multipliers, loaded, all_loaded, unloaded


def _exact_here(s, images, multipliers, all_loaded):
    """The flat test group by group with numpy.linalg.svd."""
    out = []
    for k in range(images.shape[0]):
        low, high = [], []
        for g, (rows, matrix) in enumerate(zip(s.group_rows, s.group_matrices)):
            contact = s.row_contact[rows]
            lam = multipliers[k, contact]
            counted = lam > UNLOADED * multipliers[k].max()
            if s.group_is_norm[g]:
                weights = np.where(counted, 2.0 * images[k, rows] / s.row_bound[rows], 0.0)
                hessian = matrix.T @ (2.0 * lam[:, None] * matrix)
            else:
                weights = np.where(counted, np.sign(images[k, rows]), 0.0)
                hessian = np.zeros((matrix.shape[1], matrix.shape[1]))
            gradient_rows = []
            for j in np.unique(contact):
                mine = contact == j
                gradient_rows.append(weights[mine] @ matrix[mine])
            values = np.linalg.svd(np.vstack([*gradient_rows, hessian]), compute_uv=False)
            low.append(values[min(matrix.shape[1], len(values)) - 1])
            high.append(values[0])
        low, high = np.array(low), np.array(high)
        seen = low > blocks.FLAT_MARGIN * high.max()
        unseen = high <= blocks.UNSEEN_MARGIN * high.max()
        out.append(bool(np.all(np.where(all_loaded[k], seen, unseen))))
    return np.array(out)


@pytest.mark.parametrize(
    "build",
    [
        lambda: cp.loads(SCALING.revolute_chain(30)),
        lambda: cp.load(str(ROOT / "models/arm_6r.urdf")),
    ],
    ids=["revolute_chain_30", "arm_6r"],
)
def test_exact_flat_test_equals_a_per_group_svd_and_the_bound_is_conservative(build):
    structure = _structure(build())
    assert structure is not None
    images, multipliers, loaded, all_loaded, unloaded = _cases(
        structure, np.random.default_rng(7), 40
    )
    exact = blocks._unique_exactly(structure, images, multipliers, all_loaded)
    assert np.array_equal(exact, _exact_here(structure, images, multipliers, all_loaded))
    assert exact.any() and not exact.all()  # both verdicts exercised (3 / 40 and 16 / 40 cleared)
    cleared = blocks._unique(structure, multipliers, loaded, all_loaded, unloaded)
    assert not np.any(cleared & ~exact), "the bound cleared a case the exact test refuses"
