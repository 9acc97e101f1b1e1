"""Batch solving for planners: solve_many over loads and trajectories, executors, warm vs cold."""

from __future__ import annotations

from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

import clearance_pin as cp
from clearance_pin import PointForce, Torque

MODELS = Path(__file__).resolve().parent.parent / "models"


def _load_cases(count: int, seed: int = 3) -> list:
    rng = np.random.default_rng(seed)
    return [
        [
            PointForce(
                "shaft",
                force=np.array([1.0, 1.0, 1.0]) + 0.6 * rng.standard_normal(3),
                point=[0.3, 0.0, 0.0],
            )
        ]
        for _ in range(count)
    ]


def test_batched_load_cases_equal_single_cold_solves():
    """Every case of a stacked-array batch equals a cold single solve of the same load (1e-15 m)."""
    mechanism = cp.load(MODELS / "younes_sphere_cylinder.urdf")
    cases = _load_cases(60)
    batch = mechanism.solve_many(cases)
    assert len(batch) == 60 and batch.ok.all()
    reference = cp.load(MODELS / "younes_sphere_cylinder.urdf")
    for i in (0, 7, 31, 59):
        single = reference.solve(loads=cases[i], warm_start=False)
        for joint in ("I1", "I2"):
            assert np.allclose(batch.torsors(joint)[i], single.torsor(joint), rtol=0, atol=1e-15)
            assert np.allclose(batch[i].torsor(joint), single.torsor(joint), rtol=0, atol=1e-15)


def test_batch_items_are_verified_equilibria():
    """Items assembled from a batch carry residuals and statics like a single solve."""
    mechanism = cp.load(MODELS / "younes_sphere_cylinder.urdf")
    batch = mechanism.solve_many(_load_cases(20))
    for item in batch:
        assert item.ok
        assert item.residuals["statics"] < 1e-9


def test_trajectory_warm_equals_cold():
    """A trajectory of the driven joints solved warm-started equals independent cold solves."""
    arm = cp.load(MODELS / "arm_6r.urdf")
    phases = np.linspace(0.0, 2.0 * np.pi, 6)
    trajectory = [arm.q_nominal + 0.2 * np.sin(phases + k / 10.0) for k in range(12)]
    warm = arm.solve_many(configurations=trajectory)
    for k in (0, 5, 11):
        cold = cp.load(MODELS / "arm_6r.urdf").solve(q=trajectory[k], warm_start=False)
        for joint in arm.joints:
            assert np.allclose(warm[k].torsor(joint), cold.torsor(joint), rtol=0, atol=1e-15)


def test_executor_gives_the_same_answers():
    """Chunks run on an executor give the same answers as the in-process batch."""
    mechanism = cp.load(MODELS / "younes_sphere_cylinder.urdf")
    cases = _load_cases(24)
    local = mechanism.solve_many(cases)
    with ThreadPoolExecutor(2) as executor:
        remote = mechanism.solve_many(cases, executor=executor, chunks=3)
    assert np.allclose(local.torsors("I2"), remote.torsors("I2"), rtol=0, atol=1e-15)


def test_errors_returned_in_place():
    """With errors='return', an unbounded case holds its UnboundedLoadError and others solve."""
    mechanism = cp.load(MODELS / "younes_sphere_cylinder.urdf")
    cases = [*_load_cases(3), [Torque("shaft", [1.0, 0.0, 0.0])], *_load_cases(2)]
    results = mechanism.solve_many(cases, errors="return")
    assert isinstance(results[3], cp.UnboundedLoadError)
    assert "alpha" in str(results[3])
    assert [r.ok for i, r in enumerate(results) if i != 3] == [True] * 5
    # the whole-batch arrays: NaN in the error's row, each other row the case's own answer
    torsors = results.torsors("I1")
    assert np.isnan(torsors[3]).all() and results.ok.tolist() == [True] * 3 + [False] + [True] * 2
    for i in (0, 1, 2, 4, 5):
        assert np.allclose(torsors[i], results[i].torsor("I1"), rtol=0, atol=1e-15)
    with pytest.raises(cp.UnboundedLoadError):
        mechanism.solve_many(cases)


def test_dask_local_cluster():
    """solve_many runs on a real Dask scheduler with worker processes (distributed extra)."""
    distributed = pytest.importorskip("distributed")
    mechanism = cp.load(MODELS / "younes_sphere_cylinder.urdf")
    cases = _load_cases(12)
    with (
        distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        results = mechanism.solve_many(cases, executor=client.get_executor(), chunks=4)
    local = mechanism.solve_many(cases)
    assert np.allclose(results.torsors("I1"), local.torsors("I1"), rtol=0, atol=1e-15)
    assert results[0].frame_displacement("shaft")[0].shape == (3,)


def test_configure_stays_on_the_assembly_branch():
    """Driving the slider-crank's crank from 60 deg to 0 deg in one call keeps the rod on the
    nominal branch: the slider at x = r2 + r3 = 0.17 m, not folded back (closed form)."""
    mechanism = cp.load(MODELS / "slider_crank.urdf")
    q = mechanism.q_nominal.copy()
    for degrees in (0.0, 200.0, 330.0):
        q[0] = -np.radians(degrees)
        x = mechanism.configure(q).oMf[mechanism.model.getFrameId("slider")].translation[0]
        theta = -np.radians(degrees)
        expected = 0.05 * np.cos(theta) + np.sqrt(0.12**2 - (0.05 * np.sin(theta)) ** 2)
        assert x == pytest.approx(expected, abs=1e-12)


def test_results_pickle_and_travel_through_a_process_pool():
    """Answers (whose contacts, motions and placements are computed when read) pickle with plain
    pickle, so solve_many runs on a ProcessPoolExecutor and gives the serial answers."""
    import pickle

    mechanism = cp.load(MODELS / "four_bar.urdf")
    equilibrium = mechanism.solve()
    copy = pickle.loads(pickle.dumps(equilibrium))
    assert [c.label for c in copy.contacts] == [c.label for c in equilibrium.contacts]
    assert len(copy.body_placements) == mechanism.model.njoints
    trajectory = [mechanism.q_nominal + np.array([0.05 * k, 0.0, 0.0]) for k in range(4)]
    with ProcessPoolExecutor(2) as pool:
        remote = mechanism.solve_many(configurations=trajectory, executor=pool)
    local = mechanism.solve_many(configurations=trajectory)
    for name in mechanism.joints:
        assert np.allclose(remote.torsors(name), local.torsors(name), rtol=0, atol=1e-15)


def test_threads_share_one_mechanism_safely():
    """solve_many on a thread pool gives the serial answers: placing the mechanism at a
    configuration (which uses its one pin.Data) is done by one thread at a time (without that,
    a geometry could be built from another thread's configuration and verified against itself)."""
    from concurrent.futures import ThreadPoolExecutor

    q0 = cp.load(MODELS / "four_bar.urdf").q_nominal
    trajectory = [q0 + np.array([0.3 * np.sin(0.37 * k), 0.0, 0.0]) for k in range(60)]
    serial = cp.load(MODELS / "four_bar.urdf").solve_many(configurations=trajectory)
    threaded_mechanism = cp.load(MODELS / "four_bar.urdf")
    with ThreadPoolExecutor(2) as pool:
        threaded = threaded_mechanism.solve_many(
            configurations=trajectory, executor=pool, chunks=30
        )
    for name in threaded_mechanism.joints:
        assert np.allclose(threaded.torsors(name), serial.torsors(name), rtol=0, atol=1e-12)


def test_cases_read_as_pairs_from_two_columns():
    """solve_many keeps its cases as two columns (batch.Cases: no pair per case is built); read
    by index, slice or iteration they are the (loads, configuration) pairs, None where a column
    is absent."""
    from clearance_pin.equilibrium.batch import Cases

    loads = [[Torque("shaft", [0.0, 0.0, float(k)])] for k in range(5)]
    configurations = [np.full(2, float(k)) for k in range(5)]
    both = Cases(loads, configurations, 5)
    assert len(both) == 5 and both[2] == (loads[2], configurations[2]) and both[-1][0] is loads[4]
    assert [pair[0] for pair in both] == loads
    part = both[1:4]
    assert len(part) == 3 and part[0][1] is configurations[1] and list(part)[-1][0] is loads[3]
    only_loads = Cases(loads, None, 5)
    assert list(only_loads)[3] == (loads[3], None) and only_loads.load_column() is loads
    only_configurations = Cases(None, configurations, 5)
    assert only_configurations[4] == (None, configurations[4])
    assert only_configurations.load_column() == [None] * 5
    with pytest.raises(IndexError):
        both[5]


@pytest.mark.parametrize("model", ["arm_6r", "four_bar", "younes_sphere_cylinder"])
def test_an_error_raised_names_its_case(model):
    """With errors="raise" the first failing case's error carries a note naming its index: on a
    tree (the closed forms' batch), a loop mechanism (the compiled or NumPy batch) and a shaft, in
    this process and through a thread executor."""
    mechanism = cp.load(MODELS / f"{model}.urdf")
    good = [[load] for load in mechanism.loads if isinstance(load, (PointForce, Torque))][:1]
    cases = good * 20 + [[PointForce("nowhere", [1.0, 0.0, 0.0])]] + good * 3
    with pytest.raises(cp.LoadError) as caught:
        mechanism.solve_many(cases)
    assert caught.value.__notes__ == ["solve_many: in case 20 (counting from 0)"]
    with ThreadPoolExecutor(2) as pool, pytest.raises(cp.LoadError) as caught:
        mechanism.solve_many(cases, executor=pool, chunks=3)
    assert caught.value.__notes__ == ["solve_many: in case 20 (counting from 0)"]


def test_compiled_batch_with_gravity_carries_each_case_and_gravity():
    """A loop mechanism's compiled batch with gravity on: each case equals a single solve of its
    loads with gravity (1e-11 of the play: the kernel's chain and a single solve's start differ
    at round-off), its ``loads`` are the case's then the gravity, and a case with another
    loaded point sends the batch back to the NumPy path with the same answers."""
    path = MODELS / "four_bar.urdf"
    mechanism, reference = cp.load(path), cp.load(path)
    base = [load for load in mechanism.loads if isinstance(load, (PointForce, Torque))]
    assert base
    rng = np.random.default_rng(5)
    cases = []
    for _ in range(40):
        case = []
        for load in base:
            scale = 1.0 + 0.2 * rng.standard_normal()
            case.append(
                PointForce(load.link, force=load.force * scale, point=load.point)
                if isinstance(load, PointForce)
                else Torque(load.link, load.torque * scale)
            )
        cases.append(case)
    play = max(joint.clearance.max_play for joint in mechanism.joints.values())
    for variant in (
        cases,
        [*cases[:20], [*cases[20], Torque(base[0].link, (0.0, 0.0, 0.0))], *cases[21:]],
    ):
        batch = mechanism.solve_many(variant, gravity=True)
        assert batch.ok.all()
        compiled = sum(status == "batched Newton (compiled)" for status in batch.statuses)
        assert compiled > 30 if variant is cases else compiled == 0, batch.statuses
        for i in (1, 17, 20, 39):
            single = reference.solve(variant[i], gravity=True)
            assert isinstance(batch[i].loads[-1], cp.Gravity)
            assert len(batch[i].loads) == len(variant[i]) + 1
            for joint, torsor in single.torsors.items():
                assert np.abs(batch.torsors(joint)[i] - torsor).max() <= 1e-11 * play
                assert np.abs(batch[i].torsors[joint] - torsor).max() <= 1e-11 * play


def test_compiled_batch_in_chunks_on_threads(monkeypatch):
    """A compiled batch of 300 cases runs as two chunks on two threads: its answers equal single
    solves (1e-11 of the play), and the same chunks solved in turn on one thread (a one-core
    machine) give the same answers bit for bit: they depend on the case count, not the machine."""
    from clearance_pin.equilibrium import batch as batch_module

    path = MODELS / "younes_sphere_cylinder.urdf"
    cases = _load_cases(300, seed=9)
    threaded, alone, reference = cp.load(path), cp.load(path), cp.load(path)
    for mechanism in (threaded, alone):
        mechanism.solve(cases[0])
    on_threads = threaded.solve_many(cases)
    monkeypatch.setattr(batch_module, "_helper_threads", lambda: None)
    in_turn = alone.solve_many(cases)
    assert batch_module.THREAD_CASES * 2 <= len(cases) - 1  # two chunks
    compiled = sum(status == "batched Newton (compiled)" for status in on_threads.statuses)
    assert compiled > 250 and on_threads.ok.all()
    play = max(joint.clearance.max_play for joint in threaded.joints.values())
    for joint in ("I1", "I2"):
        assert np.array_equal(on_threads.torsors(joint), in_turn.torsors(joint))
        for i in (1, 149, 150, 151, 299):
            single = reference.solve(cases[i], warm_start=False)
            assert (
                np.abs(on_threads.torsors(joint)[i] - single.torsors[joint]).max() <= 1e-11 * play
            )


def test_a_process_executor_returns_the_chunks_batches():
    """With a process executor each chunk runs solve_many in its task (the arm's closed forms:
    the chunk's batch travels as arrays) and the caller reads one batch: every whole-batch reader
    equals the in-process batch's, items point at the caller's mechanism (issue 22: 2500 arm
    cases took 4.5 s on a ProcessPoolExecutor(2) against 0.06 s in process, 0.16 s now)."""
    arm = cp.load(MODELS / "arm_6r.urdf")
    rng = np.random.default_rng(8)
    cases = [[PointForce("tool", [0, 0, -50.0] + 15 * rng.standard_normal(3))] for _ in range(300)]
    local = arm.solve_many(cases)
    with ProcessPoolExecutor(2) as pool:
        remote = arm.solve_many(cases, executor=pool, chunks=3)
    assert len(remote) == len(local) and remote.ok.all()
    assert remote.methods == local.methods
    for joint in arm.joints:
        assert np.allclose(remote.torsors(joint), local.torsors(joint), rtol=0, atol=1e-15)
        assert np.allclose(remote.reactions(joint), local.reactions(joint), rtol=1e-12, atol=1e-9)
    for name, torques in local.drive_torques().items():
        assert np.allclose(remote.drive_torques()[name], torques, rtol=1e-12, atol=1e-9)
    translation, _ = remote.frame_displacements("tool")
    assert np.allclose(translation, local.frame_displacements("tool")[0], rtol=0, atol=1e-15)
    assert remote[150].mechanism is arm and remote[299].torsor("elbow").shape == (6,)


def test_a_closed_form_batch_travels_without_its_copies():
    """An executor's task returns its batch pickled: a closed-form batch sends its unknowns once
    and its slab sides as bytes (the batch's x and the reduced unknowns y are formed again where
    it is unpickled, by the same computation: 159 -> 99 MB for 1e5 UR5 cases), and reads the
    same bits there: every whole-batch reader and the assembled answers."""
    import dataclasses
    import pickle

    arm = cp.load(MODELS / "arm_6r.urdf")
    rng = np.random.default_rng(11)
    values = np.array([0.0, 0.0, -50.0]) + 10.0 * rng.normal(size=(3000, 3))
    batch = arm.resolver([PointForce("tool", [0.0, 0.0, -50.0])]).solve_many(values)
    assembler = batch._assembler  # private: what travels
    sent = pickle.dumps(batch)
    terms, closed = assembler.terms, assembler.closed
    arrays = [getattr(terms, f.name) for f in dataclasses.fields(terms)]
    arrays += [getattr(closed, name) for name in closed.FIELDS]
    arrays += [assembler.y, assembler.table, batch._arrays["x"]]
    everything = sum(np.asarray(a).nbytes for a in arrays)
    assert len(sent) < everything - batch._arrays["x"].nbytes - assembler.y.nbytes
    back = pickle.loads(sent)
    assert np.array_equal(back._assembler.y, assembler.y)
    assert back._assembler.closed.signs.dtype == np.float64
    for joint in arm.joints:
        for read in ("torsors", "reactions", "contact_forces"):
            assert np.array_equal(getattr(back, read)(joint), getattr(batch, read)(joint))
    for i in (0, 1777, 2999):
        for joint in arm.joints:
            assert np.array_equal(back[i].torsor(joint), batch[i].torsor(joint))
            assert np.array_equal(back[i].reaction(joint).wrench, batch[i].reaction(joint).wrench)
