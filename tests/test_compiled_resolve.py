"""The compiled re-solve (clearance_pin/equilibrium/kernel.py, fast_path.py) against the NumPy path
and against the independent oracle.

- Its linear-algebra pieces against NumPy / LAPACK (independent implementations).
- Every published case of [Y] section 6 and every bundled model with loops, over perturbed loads:
  the compiled answers equal the NumPy path's to 1e-11 of the play (the same algorithm written
  twice: a consistency check, not an independent one), carry passing residuals, and most of
  them were found by the kernel (not handed back).
- Random mechanisms against tests/oracle.py (cvxpy + Clarabel on body twists: independent), the
  second solve of each mechanism going the compiled way.
- Loads the kernel does not decide (unbounded, no work) end as on the NumPy path.
- ``import clearance_pin`` and a first solve do not load numba.
"""

from __future__ import annotations

import importlib.util
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from mechanism_strategies import mechanisms
from oracle import Oracle, bounded_loads, judge
from test_random_mechanisms import ACCEPTED, KNOWN

import clearance_pin
from clearance_pin import Method, PointForce, Torque, UnboundedLoadError
from clearance_pin.equilibrium import fast_path

pytest.importorskip("numba")
from clearance_pin.equilibrium import kernel

ROOT = Path(__file__).resolve().parents[1]
RNG_SEED = 20261201
# two writings of one algorithm differ by round-off in a different order, amplified by the loop
# closure's conditioning: up to 2e-12 of the play on four_bar, as between the NumPy path's own
# backends (benchmarks/README.md, "Results")
AGREEMENT = 1e-11


@pytest.fixture
def compiled(monkeypatch):
    """Every re-solve goes the compiled way first (the kernel loads on the first re-solve)."""
    monkeypatch.setenv("CLEARANCE_PIN_COMPILED", "1")
    fast_path.load_kernel()


def _younes():
    spec = importlib.util.spec_from_file_location("younes2013", ROOT / "validation/younes2013.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _mechanisms():
    younes = _younes()
    table = tomllib.loads((ROOT / "validation/younes2013_cases.toml").read_text())["case"]
    for case in table:
        yield case["id"], lambda case=case: younes.build(case)
    for name in ("four_bar", "slider_crank", "younes_sphere_cylinder", "younes_two_cylinders"):
        yield name, lambda name=name: clearance_pin.load(str(ROOT / "models" / f"{name}.urdf"))


def _perturbed(loads, rng, count):
    """``count`` loads near ``loads``: each force or torque vector v gets 0.3 |v| times a normal
    vector (the contact set may change; a load may turn unbounded: both paths must say so)."""
    out = []
    for _ in range(count):
        moved = []
        for load in loads:
            if isinstance(load, PointForce):
                size = np.linalg.norm(load.force)
                force = load.force + 0.3 * size * rng.standard_normal(3)
                moved.append(PointForce(load.link, force=force, point=load.point))
            elif isinstance(load, Torque):
                size = np.linalg.norm(load.torque)
                moved.append(Torque(load.link, load.torque + 0.3 * size * rng.standard_normal(3)))
            else:
                moved.append(load)
        out.append(tuple(moved))
    return out


def _assert_agree(answer, reference, play, length):
    """Every joint torsor of ``answer`` equals ``reference``'s to AGREEMENT of the play
    (rotations times the length scale)."""
    for joint, torsor in reference.torsors.items():
        difference = answer.torsors[joint] - torsor
        assert np.abs(difference[:3]).max() <= AGREEMENT * play, joint
        assert np.abs(difference[3:]).max() * length <= AGREEMENT * play, joint


def _outcome(mechanism, loads, **options):
    try:
        return mechanism.solve(loads, **options)
    except UnboundedLoadError:
        return "unbounded"


def _both_paths(build, count, seed, monkeypatch, **options):
    """``count`` perturbed loads of a mechanism solved in sequence by two instances, the NumPy
    path (numba off) and the compiled one (after a first solve of the model's load):
    (references, answers, play [m] (1 when every load is unbounded), length scale [m])."""
    reference_mechanism, compiled_mechanism = build(), build()
    base = tuple(
        load for load in reference_mechanism.loads if isinstance(load, (PointForce, Torque))
    )
    loads = _perturbed(base, np.random.default_rng(seed), count)
    monkeypatch.setenv("CLEARANCE_PIN_COMPILED", "0")
    references = [_outcome(reference_mechanism, load, **options) for load in loads]
    monkeypatch.setenv("CLEARANCE_PIN_COMPILED", "1")
    fast_path.load_kernel()
    compiled_mechanism.solve(base)
    answers = [_outcome(compiled_mechanism, load, **options) for load in loads]
    solved = [r for r in references if not isinstance(r, str)]
    # 6.3.1: every load turned off the model's has a part along the shaft's free spin
    play = max((c.clearance for r in solved[:1] for c in r.contacts), default=1.0)
    return references, answers, play, compiled_mechanism.length_scale()


@pytest.mark.parametrize("name, build", list(_mechanisms()), ids=[n for n, _ in _mechanisms()])
def test_compiled_answers_equal_the_numpy_path(name, build, monkeypatch):
    """Paper cases and bundled loop models: over 40 perturbed loads solved in sequence, the
    compiled re-solve gives the NumPy path's answer to 1e-11 of the play."""
    references, answers, play, length = _both_paths(build, 40, RNG_SEED, monkeypatch)
    by_kernel = 0
    for reference, answer in zip(references, answers):
        if isinstance(reference, str) or isinstance(answer, str):
            assert reference == answer
            continue
        assert answer.ok and answer.polished
        by_kernel += answer.method is Method.COMPILED
        _assert_agree(answer, reference, play, length)
        assert [c.active for c in answer.contacts] == [c.active for c in reference.contacts]
        assert answer.residuals["stationarity"] <= 1e-12
        assert answer.residuals["statics"] <= 1e-9
    solved = sum(not isinstance(r, str) for r in references)
    assert by_kernel >= 0.8 * solved, f"{name}: only {by_kernel} of {solved} by the kernel"


@settings(
    max_examples=20,
    deadline=None,
    derandomize=True,
    suppress_health_check=[
        HealthCheck.too_slow,
        HealthCheck.data_too_large,
        HealthCheck.function_scoped_fixture,  # extremes_warn records over every example
    ],
)
@given(spec=mechanisms())
def test_compiled_resolve_agrees_with_the_oracle(spec, extremes_warn):
    """Random mechanisms: after a first solve of another load, the compiled re-solve of the
    model's load agrees with the independent oracle (or both diagnose the load alike)."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("CLEARANCE_PIN_COMPILED", "1")
        fast_path.load_kernel()
        mechanism = clearance_pin.loads(spec.urdf(), source="<random mechanism>")
        loads = bounded_loads(Oracle(mechanism), mechanism.resolve_loads(None, None))
        turned = _perturbed(loads, np.random.default_rng(RNG_SEED), 1)[0]
        try:
            mechanism.solve(turned)
        except clearance_pin.ClearancePinError:
            pass  # the first solve only leaves a previous solution (or none) behind
        verdict = judge(mechanism, loads)
    assert verdict.kind in ACCEPTED or verdict.kind in KNOWN, (
        f"{verdict.kind}: {verdict.errors}\n{verdict.detail}\n{spec.urdf()}"
    )


def test_undecided_loads_end_as_on_the_numpy_path(compiled):
    """A load along the shaft's free spin is unbounded and a zero load does no work: the kernel
    hands both back, and the NumPy path raises / answers "indeterminate" as without it."""
    mechanism = clearance_pin.load(str(ROOT / "models/younes_two_cylinders.urdf"))
    mechanism.solve()
    link = next(load.link for load in mechanism.loads if isinstance(load, PointForce))
    with pytest.raises(UnboundedLoadError):
        mechanism.solve([Torque(link, (5.0, 0.0, 0.0))])
    assert mechanism.solve([Torque(link, (0.0, 0.0, 0.0))]).status == "indeterminate"


def test_lu_solve_against_lapack():
    rng = np.random.default_rng(1)
    for size in (1, 3, 8, 20):
        matrix = rng.standard_normal((size, size))
        right = rng.standard_normal(size)
        ok, solution = kernel._lu_solve(matrix, right)
        assert ok
        assert np.allclose(solution, np.linalg.solve(matrix, right), rtol=1e-10, atol=1e-12)
    assert not kernel._lu_solve(np.zeros((3, 3)), np.ones(3))[0]


def test_singular_values_and_minimum_norm_solution_against_lapack():
    rng = np.random.default_rng(2)
    for rows, columns, rank in ((6, 4, 4), (4, 6, 4), (8, 5, 2), (3, 3, 1)):
        matrix = rng.standard_normal((rows, rank)) @ rng.standard_normal((rank, columns))
        singular, v, _ = kernel._singular_values(matrix)
        expected = np.linalg.svd(matrix, compute_uv=False)
        assert np.allclose(np.sort(singular)[::-1][: expected.size], expected, atol=1e-12)
        assert np.allclose(v.T @ v, np.eye(columns), atol=1e-13)
        right = rng.standard_normal(rows)
        least = kernel._minimum_norm_solution(matrix, right)
        assert np.allclose(least, np.linalg.lstsq(matrix, right, rcond=None)[0], atol=1e-10)


def _fresh_process(script: str, cache_home: Path) -> str:
    """Run ``script`` in a new interpreter left to itself (no CLEARANCE_PIN_COMPILED) with the
    user cache folder ``cache_home`` (where the kernel's installation record lives); its stdout."""
    environment = {
        k: v for k, v in __import__("os").environ.items() if k != "CLEARANCE_PIN_COMPILED"
    }
    environment["XDG_CACHE_HOME"] = str(cache_home)
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, env=environment,
        timeout=300, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    return done.stdout


def test_import_and_a_first_solve_do_not_load_numba(tmp_path):
    """Import and a first solve never load numba (and import loads no SciPy, CasADi, Clarabel or
    matplotlib: 0.2 s of SciPy at import before; nor does a closed form's first solve: asking
    whether Clarabel is installed imported SciPy's sparse module, 110 ms); without the kernel's
    installation record the re-solves go the NumPy way (no counter switches the kernel on: 50
    re-solves, one engine)."""
    script = (
        "import sys, clearance_pin\n"
        "assert 'numba' not in sys.modules\n"
        "heavy = {'scipy', 'casadi', 'clarabel', 'matplotlib'} & set(sys.modules)\n"
        "assert not heavy, f'imported by import clearance_pin: {heavy}'\n"
        f"arm = clearance_pin.load({str(ROOT / 'models/arm_6r.urdf')!r})\n"
        "assert arm.solve().method.value == 'closed form'\n"
        "heavy = {'scipy', 'casadi', 'clarabel', 'numba'} & set(sys.modules)\n"
        "assert not heavy, f'imported by a closed form first solve: {heavy}'\n"
        f"m = clearance_pin.load({str(ROOT / 'models/four_bar.urdf')!r})\n"
        "first = m.solve()\n"
        "assert 'numba' not in sys.modules, 'numba loaded by a first solve'\n"
        "methods = {m.solve(loads=None).method for _ in range(50)}\n"
        "assert 'numba' not in sys.modules, 'numba loaded without its installation record'\n"
        "print(first.method.value, sorted(x.value for x in methods))\n"
    )
    out = _fresh_process(script, tmp_path)
    assert out.split() == ["clarabel", "['clarabel']"], out


def test_the_kernel_is_an_installation_fact(tmp_path):
    """After load_kernel() has recorded numba's cache (what `clearance-pin compile` does at
    set-up), a new process takes the compiled kernel from its first re-solve, and two new
    processes give the same engines and the same bits (issue 22: one plan, no counter)."""
    _fresh_process(
        "from clearance_pin.equilibrium import fast_path\nfast_path.load_kernel()\n", tmp_path
    )
    assert list((tmp_path / "clearance_pin").glob("kernel-*.json")), "no installation record"
    script = (
        "import sys, clearance_pin\n"
        f"m = clearance_pin.load({str(ROOT / 'models/four_bar.urdf')!r})\n"
        "answers = [m.solve(), m.solve(), m.solve()]\n"
        "print([a.method.value for a in answers])\n"
        "print([a.torsors[j].tobytes().hex() for a in answers for j in sorted(a.torsors)])\n"
    )
    first, second = _fresh_process(script, tmp_path), _fresh_process(script, tmp_path)
    assert first == second
    assert first.splitlines()[0] == "['clarabel', 'compiled Newton', 'compiled Newton']"


def test_load_kernel_reports_its_time(compiled):
    assert fast_path.kernel_load_time() is not None and fast_path.kernel_load_time() >= 0.0
    assert fast_path.load_kernel() == fast_path.kernel_load_time()


@pytest.mark.parametrize(
    "name, build", list(_mechanisms())[:4], ids=[n for n, _ in _mechanisms()][:4]
)
def test_compiled_batch_equals_single_solves(name, build, compiled):
    """solve_many over 60 perturbed loads in one compiled call (each case warm-started from the
    previous one) gives the single solves' answers (NumPy path) to 1e-11 of the play, verified;
    half or more in the compiled batch (the others, whose contact set differs too much from their
    neighbour's, solved alone), most by the kernel."""
    rng = np.random.default_rng(RNG_SEED + 1)
    mechanism, reference = build(), build()
    base = tuple(load for load in mechanism.loads if isinstance(load, (PointForce, Torque)))
    loads = [case for case in _perturbed(base, rng, 60)]
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("CLEARANCE_PIN_COMPILED", "0")
        expected = [_outcome(reference, case) for case in loads]
    keep = [i for i, e in enumerate(expected) if not isinstance(e, str)]
    mechanism.solve(base)
    batch = mechanism.solve_many([loads[i] for i in keep])
    play = max(c.clearance for c in expected[keep[0]].contacts)
    length = mechanism.length_scale()
    assert batch.ok.all()
    for joint in expected[keep[0]].torsors:
        difference = batch.torsors(joint) - np.array([expected[i].torsors[joint] for i in keep])
        assert np.abs(difference[:, :3]).max() <= AGREEMENT * play
        assert np.abs(difference[:, 3:]).max() * length <= AGREEMENT * play
    batched = sum(item.solver_status == "batched Newton (compiled)" for item in batch)
    compiled_cases = sum(item.method is Method.COMPILED for item in batch)
    assert batched >= 0.5 * len(keep), f"{name}: {batched} of {len(keep)} in the batch"
    assert compiled_cases >= 0.8 * len(keep), f"{name}: {compiled_cases} of {len(keep)}"
    for item, i in zip(batch, keep):
        assert item.ok and len(item.free_motions) == len(expected[i].free_motions)


@pytest.mark.parametrize("name, build", list(_mechanisms()), ids=[n for n, _ in _mechanisms()])
def test_cold_solves_from_the_centre_equal_clarabel(name, build, monkeypatch):
    """A cold solve (``warm_start=False``) of a built mechanism: the kernel's active-set method
    from the centred position, no backend, answers 30 perturbed loads, and its answers equal
    Clarabel's polished ones (the NumPy path, numba off) to 1e-11 of the play. Clarabel's
    interior-point iterates do not share the active-set method (the polish does)."""
    references, answers, play, length = _both_paths(
        build, 30, RNG_SEED + 2, monkeypatch, warm_start=False
    )
    solved = [r for r in references if not isinstance(r, str)]
    from_centre = 0
    for reference, answer in zip(references, answers):
        if isinstance(reference, str) or isinstance(answer, str):
            assert reference == answer
            continue
        assert answer.ok and answer.polished
        assert reference.method is Method.CLARABEL
        from_centre += answer.solver_status == "active set from the centre (compiled)"
        _assert_agree(answer, reference, play, length)
    assert from_centre >= 0.9 * len(solved), f"{name}: {from_centre} of {len(solved)}"


def test_a_named_backend_finds_the_cold_answer(compiled):
    """backend="clarabel" on a cold solve: the backend answers (the kernel polishes it), not
    the kernel's start from the centre."""
    mechanism = clearance_pin.load(str(ROOT / "models/four_bar.urdf"))
    mechanism.solve()
    answer = mechanism.solve(warm_start=False, backend="clarabel")
    assert answer.method is Method.CLARABEL and answer.ok
    centred = mechanism.solve(warm_start=False)
    assert centred.method is Method.COMPILED
    assert centred.solver_status == "active set from the centre (compiled)"


def test_active_set_method_from_the_centre_does_not_cycle():
    """Case 6.1.6.1b of [Y]: from the centre, Newton on two of the three bearings' contacts moves
    the shaft outside the third; adding it at that point gave the set's other KKT point (the
    third contact pulling), releasing it gave the first point again: a cycle (the kernel
    verified 49 of 200 loads from the centre). Moving only to where the third contact is met
    ends it. Both writings (kernel,
    kkt.active_set_solve) reach the same verified optimum from the centre on 40 loads."""
    from clearance_pin.equilibrium.kkt import active_set_solve
    from clearance_pin.equilibrium.prepared import prepared_geometry

    case = next(
        c
        for c in tomllib.loads((ROOT / "validation/younes2013_cases.toml").read_text())["case"]
        if c["id"] == "6.1.6.1b"
    )
    mechanism = _younes().build(case)
    base = tuple(load for load in mechanism.loads if isinstance(load, (PointForce, Torque)))
    prepared = prepared_geometry(mechanism)
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("CLEARANCE_PIN_COMPILED", "1")
        fast_path.load_kernel()
        mechanism.solve(base)
        fast = fast_path.fast_terms(prepared)
    count = fast.cone[3].size
    for loads in _perturbed(base, np.random.default_rng(RNG_SEED + 3), 40):
        resolved = mechanism.resolve_loads(loads)
        params, matrix, constant = fast.load_map(resolved)
        rows, _ = fast.solve_cold(params.reshape(1, -1), matrix, constant)
        assert rows[0, 0] == kernel.SOLVED and rows[0, kernel.START] == kernel.FROM_CENTRE
        problem = prepared.problem(resolved)
        numpy_answer = active_set_solve(
            problem.stack, problem.objective, np.zeros(fast.size), np.zeros(count),
            rounds=fast.centre_rounds,
        )  # fmt: skip
        assert numpy_answer is not None
        y = fast.parts(rows[0])["y"]
        assert np.abs(numpy_answer[0] - y).max() <= 1e-12


def test_gram_schmidt_pieces_against_lapack():
    """kernel._row_basis spans the rows' space (its projector equals the SVD's) and
    kernel._least_squares_forces is numpy.linalg.lstsq's minimum-norm solution, for independent
    and dependent rows."""
    rng = np.random.default_rng(4)
    for rows, columns, rank in ((3, 5, 3), (5, 5, 5), (4, 6, 2), (2, 4, 1)):
        gradients = rng.standard_normal((rows, rank)) @ rng.standard_normal((rank, columns))
        basis, _, found, independent = kernel._row_basis(gradients, 1e-12)
        assert found == rank and independent == (rank == rows)
        vt = np.linalg.svd(gradients)[2]
        span = vt[:rank]
        assert np.allclose(basis[:found].T @ basis[:found], span.T @ span, atol=1e-12)
        objective = rng.standard_normal(columns)
        expected = np.linalg.lstsq(gradients.T, -objective, rcond=None)[0]
        assert np.allclose(kernel._least_squares_forces(gradients, objective), expected,
                           atol=1e-10)  # fmt: skip


def test_load_cases_gathers_the_vectors_of_one_structure(compiled):
    """FastTerms.load_cases: the force and torque vectors of cases with the first case's loaded
    points, as load_map gives them one by one; None when a case moves a point or adds a load
    (solve_many then takes its NumPy batch, whose answers equal single solves)."""
    from clearance_pin.equilibrium.prepared import prepared_geometry

    mechanism = clearance_pin.load(str(ROOT / "models/four_bar.urdf"))
    base = tuple(load for load in mechanism.loads if isinstance(load, (PointForce, Torque)))
    mechanism.solve(base)
    fast = fast_path.fast_terms(prepared_geometry(mechanism))
    cases = [mechanism.resolve_loads(c) for c in _perturbed(base, np.random.default_rng(5), 6)]
    params, matrix, constant = fast.load_cases(cases)
    singles = [fast.load_map(c) for c in cases]
    assert np.array_equal(params, np.array([s[0] for s in singles]))
    assert matrix is singles[0][1] and constant is singles[0][2]
    force = next(load for load in base if isinstance(load, PointForce))
    moved = PointForce(force.link, force=force.force, point=force.point + 1e-3)
    mixed = [*cases, mechanism.resolve_loads((moved,))]
    assert fast.load_cases(mixed) is None
    batch = mechanism.solve_many([base, *[(moved,)] * 3, *cases[:3]])
    play, length = max(c.clearance for c in batch[0].contacts), mechanism.length_scale()
    for item, loads in zip(batch, [base, *[(moved,)] * 3, *cases[:3]]):
        single = mechanism.solve(loads)
        _assert_agree(item, single, play, length)


def test_the_centre_start_walks_along_the_boundary(compiled):
    """A reviewer's offset slider-crank (tests/data/offset_slider_crank.urdf, written from the
    docs): 40 random planar loads, cold. The kernel's start from the centre answers at least 90 %
    of them (before the boundary walk: about half), and every answer equals Clarabel's polished
    one (backend="clarabel") to 1e-11 of the play; each carries passing residuals."""
    mechanism = clearance_pin.load(str(ROOT / "tests/data/offset_slider_crank.urdf"))
    mechanism.solve()
    rng = np.random.default_rng(RNG_SEED + 6)
    play, length = 4e-5, mechanism.length_scale()
    from_centre = 0
    for _ in range(40):
        slider, rod = rng.normal(size=2) * 100.0, rng.normal(size=2) * 50.0
        loads = [
            PointForce("slider", [slider[0], slider[1], 0.0]),
            PointForce("rod", [rod[0], rod[1], 0.0], point=[rng.uniform(0, 0.15), 0.0, 0.0]),
            Torque("rod", [0.0, 0.0, rng.normal()]),
        ]
        answer = mechanism.solve(loads, warm_start=False)
        reference = mechanism.solve(loads, warm_start=False, backend="clarabel")
        assert answer.ok and reference.method is Method.CLARABEL
        from_centre += answer.solver_status == "active set from the centre (compiled)"
        _assert_agree(answer, reference, play, length)
    assert from_centre >= 36, f"{from_centre} of 40 from the centre"


def test_a_warm_solve_starts_from_the_nearest_recent_answer(compiled):
    """The kernel keeps the last answers of a geometry (FastTerms.pool) and starts a warm solve
    from the one whose objective is nearest. On 6.1.6.1b, load A's answer and then load B's
    (another contact set) in the pool: A solved again in one active-set round verifies from the
    pool (B, the most recent, as the guess fails in one round), and equals A's first answer.
    The pool is a ring of POOL answers; forget() empties it."""
    from clearance_pin.equilibrium.prepared import prepared_geometry

    case = next(
        c
        for c in tomllib.loads((ROOT / "validation/younes2013_cases.toml").read_text())["case"]
        if c["id"] == "6.1.6.1b"
    )
    mechanism = _younes().build(case)
    base = tuple(load for load in mechanism.loads if isinstance(load, (PointForce, Torque)))
    mechanism.solve(base)
    fast = fast_path.fast_terms(prepared_geometry(mechanism))

    def cold(loads):
        params, matrix, constant = fast.load_map(mechanism.resolve_loads(loads))
        rows, _ = fast.solve_cold(params.reshape(1, -1), matrix, constant)
        assert rows[0, 0] == kernel.SOLVED
        return (params.reshape(1, -1), matrix, constant), fast.parts(rows[0])

    fast.forget()
    assert fast.pool[4].tolist() == [0, 0]
    loads = _perturbed(base, np.random.default_rng(RNG_SEED + 7), 60)
    a_case, a = cold(loads[0])
    a_set = a["multipliers"] > 0.0
    b_loads = next(
        x for x in loads[1:] if (cold(x)[1]["multipliers"] > 0.0).tolist() != a_set.tolist()
    )
    fast.forget()
    cold(loads[0])
    _, b = cold(b_loads)
    assert fast.pool[4].tolist() == [2, 2]
    guess = (b["y"], b["multipliers"], b["signs"])
    rows, _ = fast.solve(*a_case, *guess, warm_rounds=1, centre=False)
    assert rows[0, 0] != kernel.SOLVED  # B's contact set is not left in one round
    rows, _ = fast.solve(*a_case, *guess, warm_rounds=1, centre=False, pooled=True)
    assert rows[0, 0] == kernel.SOLVED and rows[0, kernel.START] == kernel.FROM_NEIGHBOUR
    assert np.abs(fast.parts(rows[0])["y"] - a["y"]).max() <= 1e-14
    for k in range(fast_path.POOL):  # 3 answers in, then POOL more: full, the oldest overwritten
        cold(loads[k % len(loads)])
    assert fast.pool[4].tolist() == [fast_path.POOL, 3]
    fast.forget()
    assert fast.pool[4].tolist() == [0, 0]
