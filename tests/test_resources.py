"""Bounded resources (issue 21, item 9): what a mechanism and a batch keep stays bounded.

- the gathered gravity wrenches of a prepared configuration and the built optimisers of a
  mechanism are kept for the few most recent keys (a tilting base, a swept ``tol``), and an
  answer after an entry was dropped equals the first one;
- a read trajectory keeps a few kB per point, not a prepared geometry each (80 kB per point of
  the 6R arm before);
- a batch pickles (a Dask or process task may return one), to the same numbers;
- a mechanism whose Pinocchio data cannot fit in memory is refused before it is allocated.
"""

from __future__ import annotations

import gc
import json
import pickle
import subprocess
import sys
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

import clearance_pin as cp
import clearance_pin.mechanism as mechanism_module
from clearance_pin import Gravity, PointForce
from clearance_pin.equilibrium.cache import BACKENDS_KEPT, LeastRecentlyUsed
from clearance_pin.equilibrium.prepared import prepared_geometry
from clearance_pin.model import footprint

MODELS = Path(__file__).resolve().parent.parent / "models"
PLAY = 1e-5  # [m], the 6R arm's radial play (models/arm_6r.urdf)


def _tilted(angle: float) -> Gravity:
    """Gravity seen from a base tilted by ``angle`` [rad] about y."""
    return Gravity(acceleration=[9.81 * np.sin(angle), 0.0, -9.81 * np.cos(angle)])


# -- least recently used -------------------------------------------------------------------------
def test_least_recently_used_drops_the_oldest_unread():
    """Reading an entry keeps it; storing beyond the limit drops the one read longest ago."""
    kept: LeastRecentlyUsed[str, int] = LeastRecentlyUsed(2)
    kept["a"], kept["b"] = 1, 2
    assert kept.get("a") == 1  # "b" is now the least recently used
    kept["c"] = 3
    assert list(kept) == ["a", "c"] and kept.get("b") is None
    assert pickle.loads(pickle.dumps(kept)).limit == 2
    with pytest.raises(cp.ArgumentError, match="at least 1"):
        LeastRecentlyUsed(0)


def test_load_maps_stay_bounded_for_a_tilting_base():
    """100 distinct gravity vectors share one load map (a gravity acts through its acceleration,
    a column of the map: one signature; one map each before), and the first gravity solved
    again gives the torsors of the first solve."""
    arm = cp.load(MODELS / "arm_6r.urdf")
    first = arm.solve(gravity=_tilted(0.0))
    for k in range(100):
        arm.solve(gravity=_tilted(0.01 * (k + 1)))
    kept = prepared_geometry(arm)._load_maps  # private: what the bound is about
    assert len(kept) == 1
    again = arm.solve(gravity=_tilted(0.0))
    for joint in arm.joints:  # the same computation: equal to round-off of the play
        assert np.allclose(again.torsor(joint), first.torsor(joint), rtol=0, atol=1e-9 * PLAY)


def test_backends_stay_bounded_over_tolerances():
    """100 distinct ``tol`` values keep at most BACKENDS_KEPT built optimisers (100 before)."""
    four_bar = cp.load(MODELS / "four_bar.urdf")
    first = four_bar.solve(warm_start=False)
    for k in range(100):
        four_bar.solve(tol=1e-12 * (1.0 + 0.01 * k), warm_start=False)
    assert 1 <= len(four_bar.cache.backends) <= BACKENDS_KEPT
    again = four_bar.solve(tol=1e-12, warm_start=False)  # its optimiser was dropped: built again
    play = max(j.clearance.max_play for j in four_bar.joints.values())
    for joint in four_bar.joints:
        assert np.allclose(again.torsor(joint), first.torsor(joint), rtol=0, atol=1e-9 * play)


# -- trajectories ----------------------------------------------------------------------------------
POINTS = 1000
PER_POINT_LIMIT = 8 * 1024  # [bytes] issue 21's bound; about 2.7 kB measured (a 3x margin)


def _sweep(arm, count: int) -> list[np.ndarray]:
    return [arm.q_nominal + np.full(arm.model.nq, 1e-3 * k) for k in range(count)]


def test_a_read_trajectory_keeps_a_few_kilobytes_per_point():
    """After every point's torsors and tool displacement are read, the batch holds less than
    8 KiB per point (tracemalloc; 80 kB per point before: a prepared geometry each)."""
    arm = cp.load(MODELS / "arm_6r.urdf")
    warm = arm.solve_many(configurations=_sweep(arm, 8))  # code and caches loaded first
    for item in warm:
        item.torsor("elbow"), item.frame_displacement("tool")
    del warm, item
    gc.collect()
    tracemalloc.start()
    try:
        start = tracemalloc.get_traced_memory()[0]
        batch = arm.solve_many(configurations=_sweep(arm, POINTS))
        first = batch[0].frame_displacement("tool")[0]
        for item in batch:
            assert item.ok
            item.torsor("elbow"), item.frame_displacement("tool")
        del item
        gc.collect()
        per_point = (tracemalloc.get_traced_memory()[0] - start) / POINTS
    finally:
        tracemalloc.stop()
    assert per_point < PER_POINT_LIMIT, f"{per_point:.0f} bytes per point"
    # a point read again (assembled again) has the numbers of its first reading
    assert np.array_equal(batch[0].frame_displacement("tool")[0], first)
    _equal_single_solves(arm, batch, _sweep(arm, POINTS), (0, 517, POINTS - 1))


def _equal_single_solves(arm, batch, sweep, points) -> None:
    """Points assembled from the shared nominal geometry equal single solves at their
    configurations (each its own prepared geometry): torsors, tool displacement, contacts."""
    reference = cp.load(MODELS / "arm_6r.urdf")
    for k in points:
        item, single = batch[k], reference.solve(q=sweep[k], warm_start=False)
        for joint in arm.joints:
            assert np.allclose(item.torsor(joint), single.torsor(joint), rtol=0, atol=1e-9 * PLAY)
        assert np.allclose(
            item.frame_displacement("tool")[0],
            single.frame_displacement("tool")[0],
            rtol=0,
            atol=1e-9 * PLAY,
        )
        forces = np.array([c.force for c in item.contacts])
        expected = np.array([c.force for c in single.contacts])
        assert np.allclose(forces, expected, rtol=0, atol=1e-9 * np.abs(expected).max())
        positions = np.array([c.world_position for c in item.contacts])
        assert np.allclose(positions, [c.world_position for c in single.contacts], atol=1e-12)


# -- pickling ------------------------------------------------------------------------------------
def _same_numbers(batch, copy, joints, frame: str) -> None:
    assert len(copy) == len(batch)
    for joint in joints:
        assert np.array_equal(copy.torsors(joint), batch.torsors(joint), equal_nan=True)
    assert np.array_equal(copy.ok, batch.ok)
    assert np.array_equal(copy.energy, batch.energy, equal_nan=True)
    assert copy.statuses == batch.statuses
    for mine, theirs in zip(batch.frame_displacements(frame), copy.frame_displacements(frame)):
        assert np.array_equal(mine, theirs, equal_nan=True)


def test_a_trajectory_batch_pickles_to_the_same_numbers():
    """A closed-form trajectory (items assembled when read) pickles, read or not, and unpickles
    to the same torsors, energies, statuses and tool displacements (AttributeError before: a
    local closure)."""
    arm = cp.load(MODELS / "arm_6r.urdf")
    batch = arm.solve_many(configurations=_sweep(arm, 30))
    batch[4].frame_displacement("tool")
    copy = pickle.loads(pickle.dumps(batch))
    _same_numbers(batch, copy, arm.joints, "tool")
    assert np.array_equal(copy[7].body_twists, batch[7].body_twists)


def test_a_batched_load_case_batch_pickles_to_the_same_numbers():
    """Load cases of a loop mechanism (batched Newton, items kept as closures until read) and a
    batch with an error in a case's place pickle to the same numbers."""
    four_bar = cp.load(MODELS / "four_bar.urdf")
    force = next(load for load in four_bar.loads if isinstance(load, PointForce))
    cases = [
        [PointForce(force.link, force=force.force * (1.0 + 0.05 * k), point=force.point)]
        for k in range(24)
    ]
    cases[5] = [PointForce("no_such_link", force=[0.0, 0.0, 1.0], point=[0.0, 0.0, 0.0])]
    batch = four_bar.solve_many(cases, errors="return")
    assert isinstance(batch[5], cp.ClearancePinError) and batch.ok.sum() == 23
    copy = pickle.loads(pickle.dumps(batch))
    _same_numbers(batch, copy, four_bar.joints, "coupler")
    assert type(copy[5]) is type(batch[5]) and str(copy[5]) == str(batch[5])


# -- long chains -----------------------------------------------------------------------------------
def _chain(joints: int) -> str:
    """A serial chain of ``joints`` driven revolute joints (axes z, y, x in turn, 0.1 m links),
    each a journal with 10 um radial and 5 um axial play, a force at its tip; URDF text."""
    axes, offsets = ("0 0 1", "0 1 0", "1 0 0"), ("0.1 0 0", "0 0.1 0", "0 0 0.1")
    inertial = (
        '<inertial><mass value="0.1"/><origin xyz="0 0 0"/>'
        '<inertia ixx="1e-4" iyy="1e-4" izz="1e-4" ixy="0" ixz="0" iyz="0"/></inertial>'
    )
    links = "".join(f'<link name="l{k}">{inertial if k else ""}</link>' for k in range(joints + 1))
    tree, block = "", ""
    for k in range(1, joints + 1):
        tree += (
            f'<joint name="j{k}" type="revolute"><parent link="l{k - 1}"/><child link="l{k}"/>'
            f'<origin xyz="{"0 0 0" if k == 1 else offsets[k % 3]}"/><axis xyz="{axes[k % 3]}"/>'
            '<limit lower="-7" upper="7" effort="100" velocity="10"/></joint>'
        )
        block += (
            f'<joint name="j{k}" type="revolute" radial_clearance="1e-05" length="0.03" '
            f'axial_clearance="5e-06" driven="true" q="{0.3 * (-1) ** k}"/>'
        )
    return (
        f'<robot name="chain_{joints}">{links}{tree}<clearance_pin>{block}'
        f'<force link="l{joints}" point="0.1 0 0" value="10 -20 30"/></clearance_pin></robot>'
    )


def test_a_mechanism_that_cannot_fit_is_refused_before_its_data(monkeypatch):
    """With less memory available than the estimate (Pinocchio's data, cubic in the coordinates,
    and the maps of a solve), loading raises a ModelError naming the joints and the size (the
    process was killed by the system before, after allocating 1.7 GB at 300 joints)."""
    monkeypatch.setattr(footprint, "available_bytes", lambda: 1e6)  # 1 MB
    assert cp.load(MODELS / "four_bar.urdf")  # under 64 MB: not compared (ALWAYS_FITS)
    monkeypatch.setattr(footprint, "ALWAYS_FITS", 0.0)
    with pytest.raises(cp.ModelError, match=r"3 joints \(3 coordinates\) need .*Pinocchio's"):
        cp.load(MODELS / "four_bar.urdf")  # a loop mechanism keeps a pin.Data: 4 MB and more
    with pytest.raises(cp.ModelError, match=r"120 joints \(120 coordinates\).*0.001 GB available"):
        cp.loads(_chain(120), source="chain")
    # the estimate itself: a tree of 500 joints is placed without data, 1.4 GB of maps; a loop
    # mechanism of the same size would need Pinocchio's 8 GB (64 nv^3 bytes, measured)
    assert footprint.data_bytes(500) == pytest.approx(8.25e9, rel=0.01)
    monkeypatch.setattr(footprint, "available_bytes", lambda: 64e9)
    assert cp.loads(_chain(3), source="chain").solve().ok


def test_a_long_tree_is_solved_without_pinocchio_data(monkeypatch):
    """A chain of 120 joints (Pinocchio's data: 110 MB, 1.7 GB at 300) is placed and solved
    without a pin.Data, to the answer of the same chain solved with one."""
    text = _chain(120)
    light = cp.loads(text, source="chain")
    answer = light.solve()
    assert answer.ok
    assert getattr(light.cache._threads, "data", None) is None  # private: what is allocated
    monkeypatch.setattr(mechanism_module, "DATA_KEPT_UP_TO", float("inf"))
    placed = cp.loads(text, source="chain")
    reference = placed.solve()
    assert getattr(placed.cache._threads, "data", None) is not None
    for joint in ("j1", "j60", "j120"):
        assert np.allclose(answer.torsor(joint), reference.torsor(joint), rtol=0, atol=1e-14)
    tip, expected = answer.frame_displacement("l120")[0], reference.frame_displacement("l120")[0]
    assert np.allclose(tip, expected, rtol=0, atol=1e-14)


def test_the_memory_benchmark_reports_its_figures(tmp_path):
    """benchmarks/memory.py (the figures of benchmarks/README.md) runs on a small case and writes
    every figure, each measured in its own interpreter."""
    out = tmp_path / "memory.json"
    script = Path(__file__).resolve().parent.parent / "benchmarks" / "memory.py"
    arguments = ["--points", "20", "--chains", "4", "--json", str(out)]
    completed = subprocess.run([sys.executable, str(script), *arguments], timeout=600, check=False)
    assert completed.returncode == 0
    document = json.loads(out.read_text())
    assert document["trajectory"]["points"] == 20
    assert document["trajectory"]["bytes_per_point_held"] > 0.0
    assert document["chains"][0]["joints"] == 4 and document["chains"][0]["ok"]
