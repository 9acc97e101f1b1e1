"""Mechanism.resolver: one set of loads re-solved with new force and torque vectors gives the
answers of Mechanism.solve of those loads (the same code after the look-ups it saves), on a
paper shaft (compiled path), a four-bar and the 6R arm with gravity (closed forms); bad values
are refused naming the argument."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import clearance_pin
from clearance_pin import ArgumentError, Method, PointForce, Torque
from clearance_pin.equilibrium.resolver import Resolver, _finite_vector

ROOT = Path(__file__).resolve().parents[1]


def _vectors(loads):
    return np.concatenate(
        [load.force if isinstance(load, PointForce) else load.torque for load in loads
         if isinstance(load, (PointForce, Torque))]
    )  # fmt: skip


def _with(loads, vector):
    out, k = [], 0
    for load in loads:
        if isinstance(load, PointForce):
            out.append(PointForce(load.link, force=vector[k : k + 3], point=load.point))
            k += 3
        elif isinstance(load, Torque):
            out.append(Torque(load.link, vector[k : k + 3]))
            k += 3
    return out


@pytest.mark.parametrize("model", ["younes_two_cylinders", "four_bar", "arm_6r"])
def test_resolver_answers_as_solve(model):
    mechanism = clearance_pin.load(str(ROOT / "models" / f"{model}.urdf"))
    reference = clearance_pin.load(str(ROOT / "models" / f"{model}.urdf"))
    base = [load for load in mechanism.loads if isinstance(load, (PointForce, Torque))]
    resolver = mechanism.resolver(base)
    assert resolver.size == 3 * len(base)
    rng = np.random.default_rng(3)
    start = _vectors(base)
    for _ in range(30):
        vector = start + 0.2 * np.abs(start).max() * rng.standard_normal(start.size)
        try:
            expected = reference.solve(_with(base, vector))
        except clearance_pin.UnboundedLoadError:
            with pytest.raises(clearance_pin.UnboundedLoadError):
                resolver.solve(vector)
            continue
        answer = resolver.solve(vector.reshape(-1, 3))
        assert answer.ok and answer.status == expected.status
        play = max(c.clearance for c in expected.contacts)
        for joint, torsor in expected.torsors.items():
            assert np.abs(answer.torsors[joint] - torsor).max() <= 1e-11 * max(play, 1.0)
        assert answer.loads is not None and len(answer.loads) == len(resolver.loads)
        assert np.array_equal(answer.loads[0].force if isinstance(answer.loads[0], PointForce)
                              else answer.loads[0].torque, vector[:3])  # fmt: skip
        answer.reaction(next(iter(answer.torsors)))  # the loads it carries are usable
        # every field set (answers are filled from a template of their constant fields)
        assert all(value is not dataclasses.MISSING for value in vars(answer).values())


def test_resolver_refuses_bad_values_and_loads():
    mechanism = clearance_pin.load(str(ROOT / "models/four_bar.urdf"))
    resolver = mechanism.resolver()
    with pytest.raises(ArgumentError, match="values"):
        resolver.solve(np.ones(resolver.size + 1))
    with pytest.raises(ArgumentError, match="values"):
        resolver.solve(np.full(resolver.size, np.nan))
    with pytest.raises(ArgumentError, match="values"):
        resolver.solve("12")
    with pytest.raises(ArgumentError, match="loads"):
        mechanism.resolver([clearance_pin.Gravity()])
    with pytest.raises(ArgumentError, match="backend"):
        mechanism.resolver(backend="fast")


def test_resolver_refuses_complex_values():
    resolver = clearance_pin.load(str(ROOT / "models/four_bar.urdf")).resolver()
    with pytest.raises(ArgumentError, match="values"):
        resolver.solve(1j * np.ones(resolver.size))


def test_solve_many_returns_a_refused_case_in_its_place_with_the_kernel(monkeypatch):
    """A case whose loads are refused takes its place as the error (errors="return"), on the
    compiled batch as on the NumPy one."""
    monkeypatch.setenv("CLEARANCE_PIN_COMPILED", "1")
    mechanism = clearance_pin.load(str(ROOT / "models/younes_two_cylinders.urdf"))
    base = [load for load in mechanism.loads if isinstance(load, (PointForce, Torque))]
    mechanism.solve(base)
    cases = [base] * 20
    cases[7] = [*base, PointForce("no_such_link", force=(1.0, 0.0, 0.0))]
    batch = mechanism.solve_many(cases, errors="return")
    assert isinstance(batch[7], clearance_pin.ClearancePinError)
    assert all(batch[i].ok for i in range(20) if i != 7)


def test_resolver_compiled_answers_equal_the_numpy_path(monkeypatch):
    """With the kernel engaged the resolver's re-solve is one compiled call (its status says
    so); its answers equal the NumPy path's (the kernel switched off on a second mechanism: the
    same algorithm written twice, a consistency check), the loads it carries are the vectors
    given even when the caller's array changes afterwards, and every field of the answer is
    set."""
    monkeypatch.setenv("CLEARANCE_PIN_COMPILED", "1")
    path = str(ROOT / "models/younes_two_cylinders.urdf")
    mechanism, reference = clearance_pin.load(path), clearance_pin.load(path)
    base = [load for load in mechanism.loads if isinstance(load, (PointForce, Torque))]
    resolver = mechanism.resolver(base)
    rng = np.random.default_rng(11)
    start = _vectors(base)
    across = np.array([0.0, 1.0, 1.0, 0.0, 0.01, 0.01])  # nothing along the free shaft axis x
    statuses = []
    for _ in range(40):
        vector = start + 0.3 * across * rng.standard_normal(start.size)
        monkeypatch.setenv("CLEARANCE_PIN_COMPILED", "0")
        try:
            expected = reference.solve(_with(base, vector), warm_start=False)
        except clearance_pin.UnboundedLoadError:
            continue  # an axial share the journals do not hold
        finally:
            monkeypatch.setenv("CLEARANCE_PIN_COMPILED", "1")
        given = vector.copy()
        answer = resolver.solve(given)
        given[:] = np.nan  # the answer keeps its own copy
        statuses.append(answer.solver_status)
        assert answer.ok and expected.method is not Method.COMPILED
        play = max(c.clearance for c in expected.contacts)
        for joint, torsor in expected.torsors.items():
            assert np.abs(answer.torsors[joint] - torsor).max() <= 1e-11 * play
        assert np.array_equal(_vectors(answer.loads), vector)
        assert all(value is not dataclasses.MISSING for value in vars(answer).values())
    # the first solve of a mechanism goes the NumPy way, its re-solves the compiled one
    assert len(statuses) > 30 and all(s.endswith("(compiled)") for s in statuses[1:]), statuses


@pytest.mark.parametrize(
    "values, accepted",
    [
        ([1e308, 1e308, 1e308], True),  # finite, though their sum overflows
        ([1.0, np.inf, -np.inf], False),
        ([1.0, np.nan, 0.0], False),
        ([1.0, 2.0], False),
        (np.array([1.0, 2.0, 3.0j]), False),
        (["a", "b", "c"], False),
        (["1", "2", "3"], False),  # numeric strings: not numbers
        (np.array([True, False, True]), False),
        ((1, 2, 3), True),
        (np.array([[1.0, 2.0, 3.0]]), True),  # (k, 3)
        (np.array([[1.0], [2.0], [3.0]]), False),  # (3, k): read row-major it would be wrong
        ([[1.0, 2.0], [3.0]], False),  # ragged
    ],
)
def test_resolver_values_check(values, accepted):
    vector = _finite_vector(values, 3)
    assert (vector is not None) == accepted
    if accepted:
        expected = np.asarray(values, dtype=float).ravel()
        assert vector.dtype == float and np.array_equal(vector, expected)


def test_resolver_refuses_forces_given_as_columns():
    """Two loads given as a (3, 2) array (forces as columns) are refused, not read row-major."""
    mechanism = clearance_pin.load(str(ROOT / "models/younes_two_cylinders.urdf"))
    resolver = mechanism.resolver()
    assert resolver.size == 6
    with pytest.raises(ArgumentError, match="values"):
        resolver.solve(np.ones((3, 2)))
    resolver.solve(np.array([[0.0, 1.0, 1.0], [0.0, 0.0, 0.0]]))  # (k, 3): taken


@pytest.mark.parametrize("model", ["younes_two_cylinders", "four_bar", "arm_6r"])
def test_resolver_solve_many_answers_as_single_solves(model):
    """resolver.solve_many(values (N, k, 3)) gives each case the answer of Mechanism.solve of
    its load objects (solved on a mechanism of its own), whichever batch engine runs (the
    compiled kernel on the paper shaft, the NumPy batch on the four-bar, the closed forms on
    the arm), and its whole-batch readers read them."""
    mechanism = clearance_pin.load(str(ROOT / "models" / f"{model}.urdf"))
    reference = clearance_pin.load(str(ROOT / "models" / f"{model}.urdf"))
    base = [load for load in mechanism.loads if isinstance(load, (PointForce, Torque))]
    rng = np.random.default_rng(5)
    start = _vectors(base)
    values = start * rng.uniform(0.6, 1.4, (60, 1))
    batch = mechanism.resolver(base).solve_many(values.reshape(60, -1, 3))
    assert len(batch) == 60 and batch.ok.all()
    joint = next(iter(reference.joints))
    torsors = batch.torsors(joint)
    for n in (0, 1, 31, 59):
        expected = reference.solve(_with(base, values[n]))
        play = max(c.clearance for c in expected.contacts)
        assert np.abs(torsors[n] - expected.torsors[joint]).max() <= 1e-11 * max(play, 1.0)
        assert np.abs(batch[n].torsors[joint] - expected.torsors[joint]).max() <= 1e-11 * play
        assert np.array_equal(_vectors(batch[n].loads), values[n])
        np.testing.assert_allclose(
            batch.reactions(joint)[n], expected.reaction(joint), rtol=0.0, atol=1e-9
        )


def test_resolver_solve_many_grid_of_payloads_and_poses():
    """configurations (Q, nq) with N payloads: Q N cases, case i N + n pose i under payload n,
    each the single solve of that pose and payload (by Mechanism.solve, gravity on)."""
    path = str(ROOT / "models" / "arm_6r.urdf")
    mechanism, reference = clearance_pin.load(path), clearance_pin.load(path)
    tool = next(load for load in mechanism.loads if isinstance(load, PointForce))
    payloads = np.array([[0.0, 0.0, -9.81 * kg] for kg in (0.5, 2.0, 4.0)])
    rng = np.random.default_rng(1)
    poses = [mechanism.q_nominal + 0.3 * rng.standard_normal(mechanism.model.nq) for _ in range(4)]
    resolver = mechanism.resolver([tool], gravity=True)
    grid = resolver.solve_many(payloads, configurations=poses)
    assert len(grid) == 12 and grid.ok.all()
    shifts = grid.frame_displacements("tool")[0]
    for i, n in ((0, 0), (1, 2), (3, 1)):
        load = PointForce(tool.link, payloads[n], tool.point)
        expected = reference.solve([load], q=poses[i], gravity=True)
        moved = expected.frame_displacement("tool")[0]
        assert np.abs(shifts[i * 3 + n] - moved).max() <= 1e-12 + 1e-9 * np.abs(moved).max()


def test_resolver_solve_many_at_the_resolvers_configuration():
    """A resolver built at a configuration q solves its many cases there, as solve(values)."""
    path = str(ROOT / "models" / "arm_6r.urdf")
    arm = clearance_pin.load(path)
    q = arm.q_nominal + 0.2
    resolver = arm.resolver(q=q)
    values = np.array([[0.0, 0.0, -50.0], [10.0, 0.0, -30.0]])
    batch = resolver.solve_many(values)
    for n in range(2):
        np.testing.assert_allclose(
            batch.frame_displacements("tool")[0][n],
            resolver.solve(values[n]).frame_displacement("tool")[0],
            rtol=0.0,
            atol=1e-15,
        )


def test_resolver_solve_many_refuses_bad_arrays():
    """Wrong shapes, non-finite entries and magnitudes beyond double precision name the
    argument (and the case)."""
    mechanism = clearance_pin.load(str(ROOT / "models" / "four_bar.urdf"))
    base = [load for load in mechanism.loads if isinstance(load, (PointForce, Torque))]
    resolver = mechanism.resolver(base)
    good = np.tile(_vectors(base), (3, 1))
    for bad in (good[0], good[:, :2], good.astype(str), np.zeros((0, resolver.size))):
        with pytest.raises(ArgumentError, match="values"):
            resolver.solve_many(bad)
    infinite = good.copy()
    infinite[1, 0] = np.inf
    with pytest.raises(ArgumentError, match="values"):
        resolver.solve_many(infinite)
    huge = good.copy()
    huge[2] = 1e200
    with pytest.raises(clearance_pin.LoadError, match=r"values\[2\]"):
        resolver.solve_many(huge)
    with pytest.raises(ArgumentError, match=r"configurations\[1\]"):
        resolver.solve_many(good, configurations=[mechanism.q_nominal, ["a"] * mechanism.model.nq])


def test_errors_return_takes_a_bad_row_as_its_case_error():
    """With errors="return" a NaN row or a load beyond double precision is its case's error and
    the other cases are solved (before, the whole call was refused); the same answers as the
    call without those rows, on a payload x pose grid too. errors="raise" still refuses first."""
    arm = clearance_pin.load(ROOT / "models" / "arm_6r.urdf")
    resolver = arm.resolver([PointForce("tool", [0.0, 0.0, -50.0])])
    values = np.array([[0.0, 0.0, -50.0], [np.nan, 0.0, 0.0], [10.0, 0.0, 0.0], [1e200, 0, 0]])
    batch = resolver.solve_many(values, errors="return", progress=False)
    assert isinstance(batch[1], ArgumentError) and batch[1].argument == "values[1]"
    assert isinstance(batch[3], clearance_pin.LoadError) and "values[3]" in str(batch[3])
    good = resolver.solve_many(values[[0, 2]], progress=False)
    for joint in arm.joints:
        torsors = batch.torsors(joint)
        assert np.isnan(torsors[[1, 3]]).all()
        assert np.allclose(torsors[[0, 2]], good.torsors(joint), rtol=1e-12, atol=1e-18)
    poses = [arm.q_nominal, arm.q_nominal + 0.1]
    grid = resolver.solve_many(values, configurations=poses, errors="return", progress=False)
    assert [isinstance(item, Exception) for item in grid] == [False, True, False, True] * 2
    assert np.allclose(grid[6].torsor("elbow"), resolver.solve_many(
        values[[2]], configurations=poses[1:], progress=False)[0].torsor("elbow"),
        rtol=1e-12, atol=1e-18)  # fmt: skip
    with pytest.raises(ArgumentError, match=r"values\[1\]"):
        resolver.solve_many(values, progress=False)
    cases = [[PointForce("tool", row)] for row in ([0, 0, -50.0], [1e200, 0, 0], [10.0, 0, 0])]
    loaded = arm.solve_many(cases, errors="return", progress=False)
    assert isinstance(loaded[1], clearance_pin.LoadError) and "loads[1]" in str(loaded[1])
    assert np.allclose(
        loaded[2].torsor("elbow"), arm.solve(cases[2]).torsor("elbow"), rtol=1e-12, atol=1e-18
    )
    with pytest.raises(clearance_pin.LoadError, match=r"loads\[1\]"):
        arm.solve_many(cases, progress=False)


def test_mechanism_solve_reuses_a_resolver_of_its_loaded_points():
    """mechanism.solve(loads) with default options re-solves through a resolver of the loads'
    links and points from their second solve on (cache.resolvers): the same answers as the
    general path (any option given takes it), the answer's loads the objects given (then
    gravity), and the same errors: an unknown link, a load beyond double precision."""
    arm = clearance_pin.load(ROOT / "models" / "arm_6r.urdf")
    play = max(joint.clearance.max_play for joint in arm.joints.values())
    rng = np.random.default_rng(3)
    for _ in range(6):
        loads = [PointForce("tool", rng.normal(size=3) * 50, [0.0, 0.02, 0.0])]
        answer = arm.solve(loads)
        general = arm.solve(loads, tol=1e-12)  # an option given: the general path
        assert answer.ok and answer.loads[0] is loads[0]
        assert isinstance(answer.loads[-1], clearance_pin.Gravity)  # the file's gravity
        for joint in arm.joints:
            assert np.allclose(answer.torsor(joint), general.torsor(joint), atol=1e-12 * play)
    assert sum(isinstance(kept, Resolver) for kept in arm.cache.resolvers.values()) == 1
    for _ in range(3):
        with pytest.raises(clearance_pin.LoadError, match="unknown link"):
            arm.solve([PointForce("tol", [0.0, 0.0, -1.0])])
        with pytest.raises(clearance_pin.LoadError, match="beyond the largest"):
            arm.solve([PointForce("tool", [1e200, 0.0, 0.0], [0.0, 0.02, 0.0])])


def test_a_batch_of_refused_cases_still_names_its_joints_and_counts_the_gravity():
    """From a break-test: a batch whose every case was refused (errors="return") reads as NaN
    for every driven joint and contact point, and a misspelled joint is still named (it gave
    {}, () and NaN); a tiny force beside the model's gravity is solved in a batch as alone (the
    bulk check left the gravity out); NumPy's booleans are gravity options like Python's."""
    arm = clearance_pin.load(ROOT / "models" / "arm_6r.urdf")
    resolver = arm.resolver([PointForce("tool", [0.0, 0.0, -50.0])])
    refused = resolver.solve_many([[np.nan, 0.0, 0.0]], errors="return", progress=False)
    torques = refused.drive_torques()
    assert set(torques) == set(arm.joints) and np.isnan(torques["elbow"]).all()
    assert refused.contact_points("elbow") == tuple(
        c.point for c in arm.solve().contacts if c.joint == "elbow"
    )
    with pytest.raises(clearance_pin.NotFoundError):
        refused.torsors("elbo")
    tiny = [[PointForce("tool", [0.0, 0.0, -50.0])], [PointForce("tool", [0.0, 0.0, 1e-200])]]
    batch = arm.solve_many(tiny, errors="return", progress=False)
    assert batch[1].ok and np.allclose(
        batch[1].torsor("elbow"), arm.solve(tiny[1]).torsor("elbow"), rtol=1e-12, atol=1e-18
    )
    alone = arm.solve_many(tiny, gravity=False, errors="return", progress=False)
    assert isinstance(alone[1], clearance_pin.LoadError)  # no gravity: the tiny load alone
    for flag in (np.True_, np.False_):
        assert np.array_equal(
            arm.solve(tiny[0], gravity=flag).torsor("elbow"),
            arm.solve(tiny[0], gravity=bool(flag)).torsor("elbow"),
        )
