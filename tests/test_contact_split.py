"""The least-norm split of dependent contact forces (clearance_pin/equilibrium/contact_split.py)
against an independent quadratic programme (cvxpy + Clarabel): min |mu|^2 s.t. G mu = G mu0,
mu >= 0, on random dependent columns, including cases where the pseudo-inverse answer has a
negative component (the non-negative least-squares path)."""

from __future__ import annotations

import cvxpy as cp
import numpy as np
import pytest

from clearance_pin.equilibrium.contact_split import least_norm_split


def _reference(columns: np.ndarray, forces: np.ndarray) -> np.ndarray:
    mu = cp.Variable(forces.size)
    constraints = [columns @ mu == columns @ forces, mu >= 0]
    cp.Problem(cp.Minimize(cp.sum_squares(mu)), constraints).solve(
        solver=cp.CLARABEL, tol_gap_abs=1e-10, tol_gap_rel=1e-10, tol_feas=1e-10
    )
    return np.asarray(mu.value)


def test_independent_columns_keep_the_forces():
    """Independent gradients: the split is unique, the engine's forces are returned as given."""
    rng = np.random.default_rng(3)
    columns = rng.standard_normal((6, 4))
    forces = np.array([1.0, 0.0, 2.5, 0.3])
    assert least_norm_split(columns, forces) is forces


def test_coinciding_columns_share_evenly():
    """Two identical columns (two corners at one place): the force splits in halves."""
    columns = np.array([[1.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    split = least_norm_split(columns, np.array([0.0, 395.0, 2.0]))
    assert np.abs(split - [197.5, 197.5, 2.0]).max() <= 1e-12 * 395.0


def test_pseudo_inverse_with_a_negative_component_goes_non_negative():
    """G = [[1 1 1 1], [0 1 2 3]] (forces along a lever), mu0 = (0, 0, 0, 1): the pseudo-inverse
    split is (-0.2, 0.1, 0.4, 0.7); the least-norm non-negative one is mu0 itself (worked by
    hand: with mu1 = 0 the pseudo-inverse on the rest is again negative, with mu1 = mu2 = 0 the
    split is unique)."""
    columns = np.array([[1.0, 1.0, 1.0, 1.0], [0.0, 1.0, 2.0, 3.0]])
    split = least_norm_split(columns, np.array([0.0, 0.0, 0.0, 1.0]))
    assert np.abs(split - [0.0, 0.0, 0.0, 1.0]).max() <= 1e-9


@pytest.mark.parametrize("seed", range(40))
def test_random_dependent_columns_match_the_quadratic_programme(seed):
    """Random dependent columns (fewer rows than columns, some repeated), random non-negative
    forces with zeros: the same split as the independent programme, to 1e-6 of the largest
    force, and the same resultant to 1e-9."""
    rng = np.random.default_rng(seed)
    rows, count = rng.integers(2, 6), rng.integers(4, 9)
    columns = rng.standard_normal((rows, count))
    if seed % 2:
        columns[:, 1] = columns[:, 0]  # two coinciding contacts
    forces = rng.uniform(0.0, 10.0, count) * (rng.uniform(size=count) < 0.6)
    split = least_norm_split(columns, forces)
    expected = _reference(columns, forces)
    size = max(float(forces.max()), 1e-300)
    assert split.min() >= 0.0
    assert np.abs(columns @ split - columns @ forces).max() <= 1e-9 * size * np.abs(columns).max()
    assert np.abs(split - expected).max() <= 1e-6 * size
