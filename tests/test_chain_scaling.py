"""Long serial chains (issue 12, benchmarks/scaling.py): the reduction decided block by block.

The reduction (:mod:`clearance_pin.equilibrium.reduction`) finds the motions no contact sees from
the contact rows on the closed motions. A tree's contact rows read only their own joint's unknowns,
so those rows split into small blocks; the reduction ranks them block by block
(``_split_blocks``) instead of by one dense SVD over all unknowns (cubic in the number of joints).
Checked here:

- the block split against the one dense SVD (``_split_rows``) on the same rows: the same rank
  (every singular value against the largest of all blocks), the same free and seen spaces, the
  same conditioning;
- the long chains of benchmarks/scaling.py against closed forms written here from world vectors
  only (no clearance frame): a planar chain of discs moves every body by its joint count times the
  play along the tip force; a 3-D chain of journals has the energy
  :math:`-\\sum_k c (|f_\\perp/2 + m_k \\times a_k / L| + |f_\\perp/2 - m_k \\times a_k / L|)
  + c_a |f \\cdot a_k|`;
- the reduced geometry and the answers with the block split against those of the dense path
  (the reduction before the split): bitwise for trees without free motions (the basis stays the
  identity), to round-off of the play for trees with free motions and for loops.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import clearance_pin as cp
from clearance_pin.equilibrium import reduction
from clearance_pin.equilibrium.prepared import prepared_geometry

ROOT = Path(__file__).resolve().parent.parent
BENCHMARKS = ROOT / "benchmarks"


def _scaling():
    """benchmarks/scaling.py (a script directory, not a package): its model generators."""
    if str(BENCHMARKS) not in sys.path:
        sys.path.insert(0, str(BENCHMARKS))
    spec = importlib.util.spec_from_file_location(
        "benchmark_scaling_models", BENCHMARKS / "scaling.py"
    )
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


SCALING = _scaling()
PLANAR_PLAY = 5e-5  # [m], radial clearance of planar_chain
JOURNAL_PLAY, AXIAL_PLAY, JOURNAL_LENGTH = 1e-5, 5e-6, 0.03  # revolute_chain [m]


def _projector(basis: np.ndarray) -> np.ndarray:
    return basis @ basis.T


def _dense(monkeypatch) -> None:
    """The reduction as before the block split: one SVD over all unknowns."""
    monkeypatch.setattr(reduction, "_split_blocks", lambda rows, rtol=1e-10: None)


# -- the block split against one dense SVD -----------------------------------------------------
def _block_rows(rng, shapes, ranks, scales, unread: int) -> np.ndarray:
    """Rows made of blocks (height, width) of the given ranks and sizes, plus ``unread``
    columns no row reads, the columns shuffled."""
    blocks = []
    for (height, width), rank, size in zip(shapes, ranks, scales):
        left = rng.standard_normal((height, rank))
        right = rng.standard_normal((rank, width))
        blocks.append(size * left @ right)
    rows = np.zeros((sum(b.shape[0] for b in blocks), sum(b.shape[1] for b in blocks) + unread))
    r = c = 0
    for block in blocks:
        rows[r : r + block.shape[0], c : c + block.shape[1]] = block
        r, c = r + block.shape[0], c + block.shape[1]
    return rows[:, rng.permutation(rows.shape[1])][rng.permutation(rows.shape[0])]


@pytest.mark.parametrize(
    ("shapes", "ranks", "scales", "unread"),
    [
        ([(4, 4), (1, 1)] * 6, [4, 1] * 6, [1.0, 0.3] * 6, 0),  # journals with axial play
        ([(4, 4), (1, 1), (3, 3)], [4, 1, 3], [1.0, 2.0, 0.5], 3),  # and columns no row reads
        ([(4, 4), (2, 3), (5, 2)], [4, 1, 2], [1.0, 1.0, 1.0], 1),  # rank-deficient blocks
        ([(3, 3), (3, 3)], [3, 3], [1.0, 1e-11], 0),  # a block below 1e-10 of the largest
        ([(2, 2), (2, 2), (2, 2)], [2, 2, 2], [1e-12, 1e-12, 1e-12], 2),  # below RANK_ATOL
    ],
)
def test_block_split_equals_one_dense_svd(shapes, ranks, scales, unread):
    """Rank, free space, seen space and conditioning of ``_split_blocks`` are those of the one
    dense SVD (``_split_rows``) of the same rows."""
    rng = np.random.default_rng(len(shapes) * 31 + unread)
    _assert_same_split(_block_rows(rng, shapes, ranks, scales, unread))


def _assert_same_split(rows: np.ndarray) -> None:
    d = rows.shape[1]
    dense_free, dense_seen, dense_conditioning = reduction._split_rows(rows, d)
    free, seen, conditioning, seen_columns = reduction._split_blocks(rows)
    assert free.shape == dense_free.shape and seen.shape == dense_seen.shape
    np.testing.assert_allclose(free.T @ free, np.eye(free.shape[1]), atol=1e-13)
    np.testing.assert_allclose(seen.T @ seen, np.eye(seen.shape[1]), atol=1e-13)
    np.testing.assert_allclose(seen.T @ free, 0.0, atol=1e-13)
    np.testing.assert_allclose(_projector(free), _projector(dense_free), atol=1e-10)
    assert conditioning == pytest.approx(dense_conditioning, rel=1e-9)
    if seen_columns is not None:  # coordinate vectors: the identity's columns
        np.testing.assert_array_equal(seen, np.eye(d)[:, seen_columns])


def _staircase(width: int) -> np.ndarray:
    """width - 1 rows, row i reading columns i and i + 1: one block, one free direction."""
    rows = np.zeros((width - 1, width))
    rows[np.arange(width - 1), np.arange(width - 1)] = 1.0
    rows[np.arange(width - 1), np.arange(1, width)] = -2.0
    return rows


def test_blocks_joined_through_chains_of_rows():
    """Columns joined only through a chain of rows (a staircase, columns shuffled) are one
    block: two staircases of 9 and 6 columns and 2 columns no row reads give 4 free directions,
    as the dense SVD; one staircase over every column is left to the dense SVD."""
    rng = np.random.default_rng(11)
    rows = np.zeros((8 + 5, 9 + 6 + 2))
    rows[:8, :9], rows[8:, 9:15] = _staircase(9), _staircase(6)
    rows = rows[:, rng.permutation(rows.shape[1])]
    labels = reduction._column_blocks(*np.nonzero(rows), rows.shape[1])
    assert sorted(np.bincount(labels[labels >= 0]).tolist()) == [6, 9]
    assert int(np.sum(labels < 0)) == 2
    _assert_same_split(rows)
    assert reduction._split_blocks(_staircase(12)[:, rng.permutation(12)]) is None


def test_one_block_over_every_column_keeps_the_dense_svd():
    """Rows that join every column (a closed loop's) are left to the one dense SVD."""
    rows = np.random.default_rng(3).standard_normal((6, 5))
    assert reduction._split_blocks(rows) is None


def test_no_row_reads_anything():
    """Zero rows: every column is free, conditioning 1 (as the dense rule)."""
    free, seen, conditioning, _ = reduction._split_blocks(np.zeros((3, 4)))
    np.testing.assert_array_equal(free, np.eye(4))
    assert seen.shape == (4, 0) and conditioning == 1.0


# -- long chains against closed forms ----------------------------------------------------------
def test_planar_chain_moves_every_body_by_its_joint_count_times_the_play():
    """planar_chain(60): every disc goes to its play along the tip force (the only load every
    joint transmits), the rotations are driven: body k moves by k c F/|F| and the energy is
    -n c |F|."""
    n = 60
    equilibrium = cp.loads(SCALING.planar_chain(n)).solve()
    force = np.array([-10.0, -20.0, 0.0])
    direction = force / np.linalg.norm(force)
    assert equilibrium.energy == pytest.approx(-n * PLANAR_PLAY * np.linalg.norm(force), rel=1e-12)
    for k in range(1, n + 1):
        translation, rotation = equilibrium.body_motions[f"j{k}"]
        np.testing.assert_allclose(
            translation, k * PLANAR_PLAY * direction, atol=1e-12 * PLANAR_PLAY
        )
        np.testing.assert_allclose(rotation, 0.0, atol=1e-12 * PLANAR_PLAY / SCALING.LINK)


def _journal_chain_energy(mechanism, n: int) -> float:
    """Energy of revolute_chain(n) from world vectors: joint k (centre o_k, axis a_k) carries the
    tip force f and its moment m_k = (p - o_k) x f; its journal's two ends, at -+ L/2 along the
    axis, each go to the play along f_perp / 2 -+ m_k x a_k / L, its axial play along f . a_k."""
    model = mechanism.model
    data = model.createData()
    q = mechanism.configure().q
    pin.forwardKinematics(model, data, q)
    axes = (np.array([0.0, 0.0, 1.0]), np.array([0.0, 1.0, 0.0]), np.array([1.0, 0.0, 0.0]))
    force = np.array([10.0, -20.0, 30.0])
    tip = model.getJointId(f"j{n}")
    point = data.oMi[tip].act(np.array([SCALING.LINK, 0.0, 0.0]))
    energy = 0.0
    for k in range(1, n + 1):
        placement = data.oMi[model.getJointId(f"j{k}")]
        axis = placement.rotation @ axes[k % 3]
        moment = np.cross(point - placement.translation, force)
        across = force - (force @ axis) * axis
        turn = np.cross(moment, axis) / JOURNAL_LENGTH
        energy -= JOURNAL_PLAY * (
            np.linalg.norm(across / 2 + turn) + np.linalg.norm(across / 2 - turn)
        )
        energy -= AXIAL_PLAY * abs(force @ axis)
    return energy


def test_revolute_chain_energy_is_the_journals_closed_form():
    """revolute_chain(60) (300 unknowns, no free motion): the energy of the answer is that of
    the journals' closed form written from world vectors (to 1e-12 of it)."""
    n = 60
    mechanism = cp.loads(SCALING.revolute_chain(n))
    equilibrium = mechanism.solve()
    assert equilibrium.ok
    assert equilibrium.energy == pytest.approx(_journal_chain_energy(mechanism, n), rel=1e-12)


# -- the block split against the dense reduction ------------------------------------------------
def _geometry(mechanism):
    return prepared_geometry(mechanism).geometry


@pytest.mark.parametrize(("family", "size"), [("revolute_chain", 40), ("planar_chain", 40)])
def test_chain_reduction_and_answers_are_those_of_the_dense_reduction(monkeypatch, family, size):
    """A chain without free motions keeps the identity as its basis either way: the reduced
    geometry (basis, contact matrices) and the answers of a cold solve, a re-solve and
    solve_many are bitwise those of the dense reduction; the conditioning to round-off."""
    text = getattr(SCALING, family)(size)
    block = cp.loads(text)
    nominal = block.loads[0]
    rng = np.random.default_rng(5)
    in_plane = np.array([1.0, 1.0, family == "revolute_chain"])  # the planar chain stays planar
    loads = [
        (
            cp.PointForce(
                nominal.link, nominal.force + 3.0 * rng.standard_normal(3) * in_plane, nominal.point
            ),
        )
        for _ in range(4)
    ]

    def answers(mechanism):
        out = [mechanism.solve(loads[0], warm_start=False), mechanism.solve(loads[1])]
        out.extend(mechanism.solve_many(loads, progress=False))
        return [np.concatenate([a.torsors[name] for name in sorted(a.torsors)]) for a in out]

    geometry = _geometry(block)
    got = answers(block)
    _dense(monkeypatch)
    dense = cp.loads(text)
    reference = _geometry(dense)
    assert geometry.free_scaled.shape[1] == reference.free_scaled.shape[1] == 0
    np.testing.assert_array_equal(geometry.basis, np.eye(geometry.basis.shape[0]))
    np.testing.assert_array_equal(geometry.basis, reference.basis)
    for mine, theirs in zip(geometry.contact_matrices, reference.contact_matrices):
        np.testing.assert_array_equal(mine, theirs)
    assert geometry.conditioning == pytest.approx(reference.conditioning, rel=1e-12)
    for mine, theirs in zip(got, answers(dense)):
        np.testing.assert_array_equal(mine, theirs)


@pytest.mark.parametrize(
    "source",
    [
        "models/younes_two_cylinders.urdf",
        "models/younes_sphere_cylinder.urdf",
        "models/arm_6r.urdf",
        "tests/data/finding9_round_off_closure.urdf",
        "models/four_bar.urdf",
        "ladder",
    ],
)
def test_free_motions_and_loops_answer_as_the_dense_reduction(monkeypatch, source):
    """Mechanisms with free motions (the split keeps seen coordinates where the dense SVD rotated
    them) and with loops: the same number of free motions, the same free space, and answers
    equal to 1e-12 of the play."""

    def build():
        if source == "ladder":
            return cp.loads(SCALING.four_bar_ladder(3))
        return cp.load(ROOT / source)

    block = build()
    geometry = _geometry(block)
    got = block.solve()
    _dense(monkeypatch)
    dense = build()
    reference = _geometry(dense)
    expected = dense.solve()
    assert geometry.free_scaled.shape == reference.free_scaled.shape
    np.testing.assert_allclose(
        _projector(geometry.free_scaled), _projector(reference.free_scaled), atol=1e-12
    )
    np.testing.assert_allclose(_projector(geometry.basis), _projector(reference.basis), atol=1e-12)
    assert geometry.conditioning == pytest.approx(reference.conditioning, rel=1e-12)
    play = max(c.contact.bound for c in geometry.contacts)  # [m]; a rotation's: play / L
    per_component = np.r_[np.full(3, play), np.full(3, play / block.length_scale())]
    assert got.status == expected.status
    for name, torsor in expected.torsors.items():
        np.testing.assert_allclose(
            got.torsors[name] / per_component, torsor / per_component, rtol=0.0, atol=1e-12
        )
