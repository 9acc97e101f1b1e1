"""Work-precision benchmark: clearance_pin's solve paths against the peers a user would write.

One process, one run: every case of validation/younes2013_cases.toml and every bundled model
(models/*.urdf), each path of ours and, on the paper's shafts, the peers of :mod:`peers`. For every
(case, method, tolerance setting):

- time: median wall time of many solves [s], each solve with a DIFFERENT load (seeded random
  perturbations of the case's load, kept admissible: no component along a motion that nothing
  blocks), nothing answered from a cache (built problems are re-used: that is what "build once,
  solve many" means);
- error [mm]: max abs difference over the torsor components of the compared joints (translations
  in mm, rotations in rad) to the reference solution, worst over all solves of the run, and at the
  case's own load against the published reference values (``expected_mm``) when present.

References: for each perturbed load, our tightest solve of that load (small-displacement model,
tol 1e-12, cold start, KKT-polished), cross-checked against Clarabel called directly at tol 1e-12
(paper shafts) or against our IPOPT backend (other models); for the exact model, our exact solve
at the tightest tolerance that IPOPT accepts (1e-14, else 1e-13, 1e-12).

Also, in the same run: the floor of the paper cases (:mod:`floor`: the Newton solve of the known
active set's KKT system alone), and the arms (:mod:`arms`: the 6R arm, the UR5 and the Panda,
1000-point trajectories and 1e4 to 1e5 tool-load cases against prebuilt Clarabel on the same
reduced problem and a loop of ``Mechanism.solve``, checked against closed forms).

Usage:
    python benchmarks/work_precision.py [--json FILE] [--plots DIR] [--quick] [--cases ID ...]
        [--arms [NAME ...]] [--no-arms] [--arm-points N] [--arm-loads N ...] [--no-floor]

JSON: {"cases": {id: {method: {"median_s", "error_mm", "peer", ...extra keys}}}, "ratios": ...,
"ratio_ranges": ..., "floor": ..., "arms": ...}.
"""

from __future__ import annotations

import os

if __name__ == "__main__":
    # One BLAS thread unless the caller says otherwise: the matrices are small, and multi-threaded
    # OpenBLAS on a busy machine makes them many times slower (README, "Metrics"). Must precede
    # the first import of numpy.
    for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(_variable, "1")

import argparse
import gc
import importlib.util
import json
import math
import platform
import sys
import time
import tomllib
import warnings
import zlib
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))

import arms
import floor
import kernel_cost
import peers

import clearance_pin
from clearance_pin import ClearancePinError, PointForce, Torque
from clearance_pin.equilibrium import fast_path

MM = 1e3


# -- settings ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Tolerances:
    """Thresholds of the benchmark (the role of qpbenchmark's tolerance dataclass).

    Attributes:
        target_error_mm: accuracy a method must reach for the "matched accuracy" comparison: the
            requirement of validation/younes2013.py (1e-9 mm) [mm, and rad for rotations].
        reference_agreement_mm: the reference and its independent cross-check must agree to this,
            else the case is flagged [mm].
        time_shift_s: shift of the shifted geometric mean of times [s] (values are divided by it
            and shifted by 1, as qpbenchmark's ``shgeom(v, sh)`` requires sh >= 1).
        error_floor_mm: errors of exactly 0 are drawn at this value on log plots [mm].
    """

    target_error_mm: float = 1e-9
    reference_agreement_mm: float = 1e-6
    time_shift_s: float = 1e-5
    error_floor_mm: float = 1e-17


@dataclass(frozen=True)
class RunSettings:
    """How long to measure.

    Attributes:
        loads: perturbed loads per case (each timed run walks through them in order).
        budget_s: a run stops after this wall time once it has ``min_solves`` solves [s].
        min_solves: fewest solves of a timed run.
        exact_loads: loads for the exact model (slower).
        batch_repeats: solve_many runs per case (the loads in a new random order each time).
        perturbation: relative size of the random load perturbation (0.3: about 17 degrees).
        seed: seed of the load perturbations.
        sweep: tolerance settings swept per method family.
        arm_points: points of each arm's trajectory (solve_many over configurations).
        arm_loads: sizes of the arms' tool-load runs: the smallest always runs, a larger one when
            the previous size's time per case predicts it within ``arm_budget_s``.
        arm_budget_s: repeats of an arm run (at most ``arm_repeats``) stop once this is spent [s].
        arm_loop_budget_s: the loops of solve and of prebuilt Clarabel over the tool-load cases
            stop after this [s] (the first cases of the run).
        floor_rows: loads of the vectorised floor run (floor.py).
    """

    loads: int = 200
    budget_s: float = 2.0
    min_solves: int = 20
    arm_points: int = 1000
    arm_loads: tuple = (10_000, 100_000)
    arm_budget_s: float = 15.0
    arm_repeats: int = 3
    arm_loop_budget_s: float = 3.0
    floor_rows: int = 10_000
    exact_loads: int = 60
    batch_repeats: int = 5
    perturbation: float = 0.3
    seed: int = 20130601
    sweep: dict = field(
        default_factory=lambda: {
            "tol": (1e-4, 1e-6, 1e-8, 1e-10, 1e-12),
            "exact_tol": (1e-6, 1e-8, 1e-10, 1e-12),
            "ftol": (1e-4, 1e-6, 1e-8, 1e-10, 1e-12, 1e-14),
            # the two slowest methods (IPOPT backend, cvxpy re-built per load): fewer settings
            "slow_tol": (1e-8, 1e-12),
        }
    )


QUICK = RunSettings(
    arm_points=100,
    arm_loads=(500, 2000),
    arm_budget_s=3.0,
    arm_repeats=1,
    arm_loop_budget_s=0.5,
    floor_rows=1000,
    loads=20,
    budget_s=0.3,
    min_solves=5,
    exact_loads=8,
    batch_repeats=2,
    sweep={
        "tol": (1e-6, 1e-12),
        "exact_tol": (1e-8, 1e-12),
        "ftol": (1e-6, 1e-12),
        "slow_tol": (1e-12,),
    },
)
HEADLINE = {"tol": 1e-12, "exact_tol": 1e-12, "ftol": 1e-12, "clarabel": "default"}


# -- cases ---------------------------------------------------------------------------------------
@dataclass
class Case:
    """One benchmark case: a built mechanism, its loads, what to compare, the peers' geometry.

    Attributes:
        id: case id (paper id, or ``model:<file stem>``).
        mechanism: built once.
        joints: joints whose torsors are compared (all joints for the bundled models).
        expected: published reference torsors per joint [mm, rad] (paper cases that have them).
        shaft: the peers' geometry (paper cases only).
        nominal: the case's own loads; perturbed: the loads of the timed runs.
    """

    id: str
    mechanism: object
    joints: tuple[str, ...]
    expected: dict | None
    shaft: peers.Shaft | None
    build_s: float
    nominal: tuple = ()
    perturbed: list = field(default_factory=list)

    def vector(self, equilibrium) -> np.ndarray:
        """Torsors of the compared joints, translations in mm, rotations in rad, (6 k,)."""
        return np.concatenate([paper_units(equilibrium.torsor(j)) for j in self.joints])


def paper_units(torsor: np.ndarray) -> np.ndarray:
    """(u, v, w) m -> mm; rotations stay in rad."""
    out = np.array(torsor, dtype=float)
    out[:3] *= MM
    return out


def _younes_module():
    spec = importlib.util.spec_from_file_location("younes2013", ROOT / "validation/younes2013.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("younes2013", module)
    spec.loader.exec_module(module)
    return module


def load_cases(selected: list[str] | None) -> list[Case]:
    """The paper cases (validation/younes2013_cases.toml) and the bundled models."""
    younes = _younes_module()
    cases = []
    table = tomllib.loads((ROOT / "validation/younes2013_cases.toml").read_text())["case"]
    for spec in table:
        if selected and spec["id"] not in selected:
            continue
        started = time.perf_counter()
        mechanism = younes.build(spec)
        mechanism.solve()
        build = time.perf_counter() - started
        expected = spec.get("expected_mm")
        cases.append(
            Case(
                spec["id"],
                mechanism,
                ("I1", "I2"),
                {"I1": expected["T1"], "I2": expected["T2"]} if expected else None,
                peers.Shaft.from_case(spec),
                build,
            )
        )
    for path in sorted((ROOT / "models").glob("*.urdf")):
        case_id = f"model:{path.stem}"
        if selected and case_id not in selected:
            continue
        started = time.perf_counter()
        mechanism = clearance_pin.load(str(path))
        mechanism.solve()
        build = time.perf_counter() - started
        cases.append(Case(case_id, mechanism, tuple(mechanism.joints), None, None, build))
    return cases


# -- admissible random loads ---------------------------------------------------------------------
def _parameters(loads) -> tuple[np.ndarray, Callable]:
    """The force / torque vectors of ``loads`` as one parameter vector, and its inverse."""
    values = []
    for load in loads:
        values.append(load.force if isinstance(load, PointForce) else load.torque)

    def rebuild(p: np.ndarray) -> tuple:
        out = []
        for k, load in enumerate(loads):
            vector = p[3 * k : 3 * k + 3]
            if isinstance(load, PointForce):
                out.append(PointForce(load.link, force=vector, point=load.point))
            else:
                out.append(Torque(load.link, vector))
        return tuple(out)

    return np.concatenate(values) if values else np.zeros(0), rebuild


def load_vector(loads) -> np.ndarray:
    """The force / torque vectors of ``loads`` as one vector (3 k,), as a resolver takes them."""
    return _parameters(loads)[0]


def perturbed_loads(mechanism, count: int, relative: float, rng) -> list[tuple]:
    """``count`` random loads near the model's, with no component along an unblocked motion.

    Each non-zero force or torque vector v gets ``relative |v|`` times a standard normal vector;
    the perturbation is then projected onto the loads that do no work along the mechanism's free
    motions (the motions that no contact sees), so that every load has an equilibrium.

    Reads the free motions through clearance_pin internals (``linear_setup``); see README,
    "Limitations".
    """
    from clearance_pin.equilibrium.load_terms import gather_body_loads, load_gradient
    from clearance_pin.equilibrium.prepared import linear_setup

    base = tuple(load for load in mechanism.loads if isinstance(load, (PointForce, Torque)))
    params, rebuild = _parameters(base)
    if not params.size:
        raise ValueError(f"{mechanism.name}: no force or torque to perturb (gravity only)")
    resolved = mechanism.resolve_loads(base)
    configuration, maps, _, problem = linear_setup(mechanism, resolved, None)
    free = problem.free_motions
    scales = np.repeat([np.linalg.norm(params[3 * k : 3 * k + 3]) for k in range(len(base))], 3)
    if free.size:
        columns = []
        for i in range(params.size):
            unit = np.zeros(params.size)
            unit[i] = 1.0
            body_loads = gather_body_loads(mechanism, rebuild(unit), configuration.oMi)
            columns.append(load_gradient(body_loads, maps.body_twist))
        work_on_free = free.T @ np.array(columns).T * scales  # (k, p)
        _, s, vt = np.linalg.svd(work_on_free)
        rank = int(np.sum(s > 1e-10 * max(s[0], 1e-300))) if s.size else 0
        keep = vt[rank:].T
    else:
        keep = np.eye(params.size)
    out = []
    for _ in range(count):
        xi = keep @ (keep.T @ rng.standard_normal(params.size))
        out.append(rebuild(params + relative * scales * xi))
    return out


def _describe(load) -> dict:
    """A load as JSON (to reproduce a failure)."""
    if isinstance(load, PointForce):
        return {"force": load.link, "value": load.force.tolist(), "point": load.point.tolist()}
    return {"torque": load.link, "value": load.torque.tolist()}


def peer_load(loads) -> tuple[np.ndarray, np.ndarray]:
    """(F [N], C [N mm]) of a shaft's loads, for the peers."""
    force = sum(
        (np.asarray(load.force) for load in loads if isinstance(load, PointForce)), np.zeros(3)
    )
    torque = sum(
        (np.asarray(load.torque) for load in loads if isinstance(load, Torque)), np.zeros(3)
    )
    return force, torque * MM


# -- errors and timing ---------------------------------------------------------------------------
def error_of(vector, reference) -> tuple[float, float, float]:
    """(max abs over all components, translations [mm], rotations [rad]); NaN if missing."""
    if vector is None or reference is None or not np.all(np.isfinite(vector)):
        return math.nan, math.nan, math.nan
    diff = np.abs(np.asarray(vector) - np.asarray(reference)).reshape(-1, 6)
    translation, rotation = float(diff[:, :3].max()), float(diff[:, 3:].max())
    return max(translation, rotation), translation, rotation


@dataclass
class Run:
    """One timed run of one method at one setting."""

    setting: dict
    times: list = field(default_factory=list)
    cpu_times: list = field(default_factory=list)
    errors: list = field(default_factory=list)
    translation: list = field(default_factory=list)
    rotation: list = field(default_factory=list)
    failures: int = 0
    unconverged: int = 0
    failure_note: str = ""
    nominal_error: float = math.nan
    statuses: dict = field(default_factory=dict)

    def add(
        self,
        seconds,
        vector,
        reference,
        status: str = "",
        converged: bool = True,
        cpu_seconds: float = math.nan,
    ):
        self.times.append(seconds)
        self.cpu_times.append(cpu_seconds)
        total, translation, rotation = error_of(vector, reference)
        self.errors.append(total)
        self.translation.append(translation)
        self.rotation.append(rotation)
        self.unconverged += not converged
        if status:
            self.statuses[status] = self.statuses.get(status, 0) + 1

    def summary(self) -> dict:
        times = np.array(self.times) if self.times else np.array([math.nan])
        errors = np.array(self.errors) if self.errors else np.array([math.nan])
        finite = errors[np.isfinite(errors)]
        worst = float(finite.max()) if finite.size else math.nan
        if not math.isnan(self.nominal_error):
            worst = max(worst, self.nominal_error) if finite.size else self.nominal_error
        return {
            "setting": self.setting,
            "median_s": float(np.median(times)),
            "median_cpu_s": _nanmedian(self.cpu_times),
            "p10_s": float(np.percentile(times, 10)),
            "p90_s": float(np.percentile(times, 90)),
            "error_mm": worst,
            "error_nominal_mm": self.nominal_error,
            "error_perturbed_max_mm": float(finite.max()) if finite.size else math.nan,
            "error_perturbed_median_mm": float(np.median(finite)) if finite.size else math.nan,
            "error_translation_mm": _nanmax(self.translation),
            "error_rotation_rad": _nanmax(self.rotation),
            "solves": len(self.times),
            "failures": self.failures,
            "unconverged": self.unconverged,
            "failure_note": self.failure_note,
            "statuses": self.statuses,
        }


def _nanmedian(values) -> float:
    finite = [v for v in values if np.isfinite(v)]
    return float(np.median(finite)) if finite else math.nan


def _nanmax(values) -> float:
    finite = [v for v in values if np.isfinite(v)]
    return float(max(finite)) if finite else math.nan


def timed_run(
    setting: dict,
    indices,
    call: Callable,
    extract: Callable,
    references,
    settings: RunSettings,
    seconds_of: Callable | None = None,
    nominal: tuple[Callable, object] | None = None,
) -> Run:
    """Time ``call(i)`` for the loads ``indices`` in order; errors against ``references[i]``.

    ``extract(out)`` gives (vector, status, converged); ``seconds_of(out)`` overrides the wall
    time (the exact model's own solve time). ``nominal = (call, reference)``: solved first and
    untimed (it builds what a setting needs: "build once"), its error against the reference of
    the case's own load is kept. Stops after ``settings.budget_s`` once ``settings.min_solves``
    solves are done.
    """
    run = Run(setting)
    if nominal is not None:
        try:
            run.nominal_error = error_of(extract(nominal[0]())[0], nominal[1])[0]
        except Exception as exc:
            run.failure_note = f"nominal load: {type(exc).__name__}: {str(exc)[:160]}"
    gc.collect()
    started = time.perf_counter()
    for count, i in enumerate(indices):
        c0 = time.process_time()
        t0 = time.perf_counter()
        try:
            out = call(i)
        except Exception as exc:
            run.failures += 1
            run.failure_note = f"{type(exc).__name__}: {str(exc)[:160]}"
            continue
        wall = time.perf_counter() - t0
        cpu = time.process_time() - c0 if seconds_of is None else math.nan
        seconds = wall if seconds_of is None else seconds_of(out)
        vector, status, converged = extract(out)
        if vector is None or not np.all(np.isfinite(vector)):
            run.failures += 1
            run.failure_note = f"no finite answer ({status})"
            continue
        run.add(seconds, vector, references[i], status, converged, cpu)
        if count + 1 >= settings.min_solves and time.perf_counter() - started > settings.budget_s:
            break
    return run


# -- the methods ---------------------------------------------------------------------------------
OURS = {
    "clearance_pin_default": "mechanism.solve(loads, warm_start=False): cold start, built once "
    "(compiled: the active-set method from the centre, Clarabel + KKT polish when it does not "
    "verify; NumPy path: Clarabel + KKT polish)",
    "clearance_pin_resolve": "mechanism.solve(loads): warm start (active-set Newton) from the "
    "previous load",
    "clearance_pin_resolver": "mechanism.resolver(loads).solve(vectors): the planner's re-solve "
    "of the same loads with new force and torque vectors (built once, like the prebuilt peer)",
    "clearance_pin_ipopt": "mechanism.solve(loads, backend='ipopt', warm_start=False)",
    "clearance_pin_exact": "mechanism.solve(loads, exact=True): time of the exact part "
    "(equilibrium.solve_time), error against a tight exact solve",
    "clearance_pin_batch": "mechanism.solve_many(loads): time per case of the whole batch",
}


def _ours_extract(case: Case):
    def extract(equilibrium):
        return case.vector(equilibrium), equilibrium.solver_status.split(":")[0], equilibrium.ok

    return extract


def _peer_extract(solution: peers.PeerSolution):
    return np.concatenate([solution.t1, solution.t2]), solution.status[:48], solution.success


def references(case: Case, settings: RunSettings, tolerances: Tolerances) -> dict:
    """Reference torsors of every perturbed load (linear; exact for the first exact_loads)."""
    mechanism = case.mechanism
    linear, fallbacks = [], []
    for index, loads in enumerate(case.perturbed):
        vector = None
        for backend in ("clarabel", "ipopt"):  # named: the backend finds it, not the kernel
            try:
                vector = case.vector(
                    mechanism.solve(loads, tol=1e-12, backend=backend, warm_start=False)
                )
                break
            except ClearancePinError as exc:
                fallbacks.append(
                    {
                        "load": index,
                        "backend": backend,
                        "error": f"{type(exc).__name__}: {str(exc)[:200]}",
                        "loads": [_describe(load) for load in loads],
                    }
                )
        linear.append(vector)
    nominal_linear = case.vector(
        mechanism.solve(case.nominal, tol=1e-12, backend="clarabel", warm_start=False)
    )
    check, check_name = [], ""
    for loads in case.perturbed:
        if linear[len(check)] is None:
            check.append(math.nan)
            continue
        if case.shaft is not None:
            check_name = "clarabel_direct tol 1e-12"
            force, torque = peer_load(loads)
            vector = _peer_extract(peers.solve_clarabel(case.shaft, force, torque, 1e-12))[0]
        else:
            check_name = "clearance_pin backend='ipopt' tol 1e-12"
            try:
                vector = case.vector(
                    mechanism.solve(loads, tol=1e-12, backend="ipopt", warm_start=False)
                )
            except ClearancePinError:
                vector = None
        check.append(error_of(vector, linear[len(check)])[0])
    expected = None
    if case.expected:
        expected = np.concatenate([case.expected[j] for j in case.joints])
    exact, exact_tols = [], []
    for loads in [case.nominal, *case.perturbed[: settings.exact_loads]]:
        vector, used = None, None
        for tol in (1e-14, 1e-13, 1e-12):
            try:
                vector = case.vector(mechanism.solve(loads, exact=True, tol=tol))
                used = tol
                break
            except ClearancePinError:
                continue
        exact.append(vector)
        exact_tols.append(used)
    model_difference = [error_of(ex, li)[0] for ex, li in zip(exact[1:], linear)]
    return {
        "linear": linear,
        "nominal": expected if expected is not None else nominal_linear,
        "nominal_source": "expected_mm (published reference values)"
        if expected is not None
        else "clearance_pin tol 1e-12 (cold, polished)",
        "nominal_vs_expected_mm": error_of(nominal_linear, expected)[0]
        if expected is not None
        else None,
        "exact_nominal": exact[0],
        "exact": exact[1:],
        "summary": {
            "perturbed_source": "clearance_pin tol 1e-12 (cold, polished); IPOPT backend "
            "where the default backend raised",
            "reference_failures": fallbacks,
            "reference_missing": sum(v is None for v in linear),
            "cross_check": check_name,
            "cross_check_max_mm": float(np.nanmax(check)) if check else math.nan,
            "cross_check_median_mm": float(np.nanmedian(check)) if check else math.nan,
            "cross_check_ok": bool(np.nanmax(check) <= tolerances.reference_agreement_mm)
            if check
            else True,
            "exact_reference_tols": sorted({t for t in exact_tols if t is not None}),
            "exact_reference_missing": sum(t is None for t in exact_tols),
            "exact_minus_linear_max_mm": float(np.nanmax(model_difference))
            if model_difference
            else math.nan,
            "nominal_reference": "expected_mm" if expected is not None else "clearance_pin",
            "nominal_vs_expected_mm": error_of(nominal_linear, expected)[0]
            if expected is not None
            else None,
        },
    }


def run_case(case: Case, settings: RunSettings, tolerances: Tolerances, log) -> tuple[dict, dict]:
    """Every method and setting on one case; returns (methods, reference summary)."""
    mechanism = case.mechanism
    refs = references(case, settings, tolerances)
    n = len(case.perturbed)
    order = list(range(n))
    extract = _ours_extract(case)
    results: dict[str, dict] = {}
    scales = play_scales(mechanism)

    def record(name: str, runs: list[Run], headline: dict, peer: bool, description: str):
        sweep = [r.summary() for r in runs]
        head = next((s for s in sweep if s["setting"] == headline), sweep[-1])
        entry = dict(head)
        entry.update(
            {
                "peer": peer,
                "description": description,
                "sweep": sweep,
                "matched": matched(sweep, tolerances),
                "error_rel_play": relative_to_play(head, scales),
            }
        )
        results[name] = entry
        log(
            f"  {name:<24} {entry['median_s'] * 1e3:9.3f} ms  error {entry['error_mm']:.2e} "
            f"({entry['error_rel_play']:.0e} of the play)  ({entry['solves']} solves, "
            f"{entry['failures']} failed)"
        )

    # ours, cold: Clarabel (auto) and IPOPT backends
    for name, backend, sweep_key in (
        ("clearance_pin_default", "auto", "tol"),
        ("clearance_pin_ipopt", "ipopt", "slow_tol"),
    ):
        runs = []
        for tol in settings.sweep[sweep_key]:

            def call(i, tol=tol, backend=backend):
                return mechanism.solve(
                    case.perturbed[i], tol=tol, backend=backend, warm_start=False
                )

            def call_nominal(tol=tol, backend=backend):
                return mechanism.solve(case.nominal, tol=tol, backend=backend, warm_start=False)

            runs.append(
                timed_run(
                    {"tol": tol},
                    order,
                    call,
                    extract,
                    refs["linear"],
                    settings,
                    nominal=(call_nominal, refs["nominal"]),
                )
            )
        record(name, runs, {"tol": HEADLINE["tol"]}, False, OURS[name])

    # ours, warm re-solve: each load warm-started from the nearest answer of this run
    forget_answers(mechanism)
    resolve = timed_run(
        {"tol": HEADLINE["tol"]},
        order,
        lambda i: mechanism.solve(case.perturbed[i]),
        extract,
        refs["linear"],
        settings,
        nominal=(lambda: mechanism.solve(case.nominal), refs["nominal"]),
    )
    record(
        "clearance_pin_resolve",
        [resolve],
        {"tol": HEADLINE["tol"]},
        False,
        OURS["clearance_pin_resolve"],
    )
    results["clearance_pin_resolve"]["paths"] = dict(resolve.statuses)

    # ours, the planner's re-solve: the loads built once, new force and torque vectors each time
    resolver = mechanism.resolver(case.nominal)
    forget_answers(mechanism)
    vectors = [load_vector(loads) for loads in case.perturbed]
    nominal_vector = load_vector(case.nominal)
    planner = timed_run(
        {"tol": HEADLINE["tol"]},
        order,
        lambda i: resolver.solve(vectors[i]),
        extract,
        refs["linear"],
        settings,
        nominal=(lambda: resolver.solve(nominal_vector), refs["nominal"]),
    )
    record(
        "clearance_pin_resolver",
        [planner],
        {"tol": HEADLINE["tol"]},
        False,
        OURS["clearance_pin_resolver"],
    )
    results["clearance_pin_resolver"]["paths"] = dict(planner.statuses)

    # ours, exact model (time of the exact part, warm-started from the linear solution)
    runs = []
    exact_order = list(range(min(settings.exact_loads, n)))
    for tol in settings.sweep["exact_tol"]:

        def call(i, tol=tol):
            return mechanism.solve(case.perturbed[i], exact=True, tol=tol)

        def call_nominal(tol=tol):
            return mechanism.solve(case.nominal, exact=True, tol=tol)

        runs.append(
            timed_run(
                {"tol": tol},
                exact_order,
                call,
                extract,
                refs["exact"],
                settings,
                seconds_of=lambda eq: eq.solve_time,
                nominal=(call_nominal, refs["exact_nominal"]),
            )
        )
    record(
        "clearance_pin_exact",
        runs,
        {"tol": HEADLINE["exact_tol"]},
        False,
        OURS["clearance_pin_exact"],
    )
    results["clearance_pin_exact"]["exact_minus_linear_max_mm"] = refs["summary"][
        "exact_minus_linear_max_mm"
    ]

    # ours, batch: solve_many over all perturbed loads, in a new random order each repeat
    results["clearance_pin_batch"] = batch_run(case, refs, settings, tolerances)
    entry = results["clearance_pin_batch"]
    entry["error_rel_play"] = relative_to_play(entry, scales)
    log(
        f"  {'clearance_pin_batch':<24} {entry['median_s'] * 1e3:9.3f} ms  error "
        f"{entry['error_mm']:.2e} ({entry['error_rel_play']:.0e} of the play)  "
        f"({entry['cases_per_s']:.0f} cases/s)"
    )

    if case.shaft is None:
        return results, refs["summary"]
    shaft = case.shaft
    peer_loads = [peer_load(loads) for loads in case.perturbed]
    nominal_peer = peer_load(case.nominal)

    def peer_runs(name, solve_for_setting, key, values):
        runs = []
        for value in values:
            solve = solve_for_setting(value)
            runs.append(
                timed_run(
                    {key: value},
                    order,
                    lambda i, f=solve: f(*peer_loads[i]),
                    _peer_extract,
                    refs["linear"],
                    settings,
                    nominal=(lambda f=solve: f(*nominal_peer), refs["nominal"]),
                )
            )
        record(name, runs, {key: HEADLINE[key]}, True, peers.PEERS[name])

    peer_runs(
        "scipy_slsqp",
        lambda ftol: lambda f, c: peers.solve_slsqp(shaft, f, c, ftol),
        "ftol",
        settings.sweep["ftol"],
    )
    peer_runs(
        "cvxpy_clarabel",
        lambda tol: lambda f, c: peers.solve_cvxpy(shaft, f, c, tol),
        "tol",
        settings.sweep["slow_tol"],
    )
    peer_runs(
        "cvxpy_clarabel_param",
        lambda tol: peers.CvxpyParametric(shaft, tol).solve,
        "tol",
        settings.sweep["tol"],
    )
    peer_runs(
        "clarabel_direct",
        lambda tol: lambda f, c: peers.solve_clarabel(shaft, f, c, tol),
        "tol",
        settings.sweep["tol"],
    )
    # the expert's peer: built once per setting (with the case's own load), updated per load
    peer_runs(
        "clarabel_prebuilt",
        lambda tol: peers.ClarabelPrebuilt(shaft, nominal_peer, tol).solve,
        "tol",
        settings.sweep["tol"],
    )
    peer_runs(
        "clarabel_prebuilt_default",
        lambda _: peers.ClarabelPrebuilt(shaft, nominal_peer, None).solve,
        "clarabel",
        ("default",),
    )
    if settings.floor_rows:
        results_floor = floor_run(case, refs, settings)
        if results_floor.get("measured"):
            results_floor["error_rel_play"] = relative_to_play(results_floor, scales)
        refs["summary"]["floor"] = results_floor
        log(describe_floor(results_floor))
    return results, refs["summary"]


def forget_answers(mechanism) -> None:
    """Empty the compiled kernel's pools of recent answers (fast_path.FastTerms.forget): a
    timed run starts from what it solved itself, not from the answers of the same loads that an
    earlier run left (the re-solves' warm start, the last verified answer, is kept)."""
    for prepared in list(mechanism.cache.geometries.values()):
        fast = prepared.__dict__.get("_fast_terms")
        if fast is not None:
            fast.forget()


def play_scales(mechanism) -> tuple[float, float]:
    """(largest clearance c [mm], length scale l [mm]) of a mechanism: errors relative to the play
    are max(translation / c, rotation * l / c), the library's scaling of its unknowns."""
    play = max(c.bound for j in mechanism.joints.values() for c in j.clearance.contacts)
    return MM * play, MM * mechanism.length_scale()


def relative_to_play(entry: dict, scales: tuple[float, float]) -> float:
    """An entry's worst error relative to the play (its perturbed loads; NaN when missing)."""
    play, length = scales
    translation = entry.get("error_translation_mm", math.nan)
    rotation = entry.get("error_rotation_rad", math.nan)
    values = [v for v in (translation / play, rotation * length / play) if math.isfinite(v)]
    return max(values) if values else math.nan


def floor_run(case: Case, refs: dict, settings: RunSettings) -> dict:
    """The floor of a paper case (:mod:`floor`), and the parts of a solve around it: the library's
    load -> reduced problem, and Clarabel prebuilt on that reduced problem."""
    from clearance_pin.equilibrium.prepared import prepared_geometry

    mechanism = case.mechanism
    prepared = prepared_geometry(mechanism)
    columns = [prepared.joint_names.index(j) for j in case.joints]
    problems, reduction_times, resolved_loads = [], [], []
    for loads in case.perturbed:
        resolved = mechanism.resolve_loads(loads)
        resolved_loads.append(resolved)
        started = time.perf_counter()
        problems.append(prepared.problem(resolved))
        reduction_times.append(time.perf_counter() - started)
    nominal = prepared.problem(mechanism.resolve_loads(case.nominal))

    def vector_of(x):
        torsors = prepared.torsor_array(x)
        return np.concatenate([paper_units(torsors[c]) for c in columns])

    out = floor.floor_case(
        prepared,
        problems,
        nominal,
        vector_of,
        refs["linear"],
        peers.ReducedClarabel(1e-10),
        error_of,
        rows=settings.floor_rows,
        loads=resolved_loads,
    )
    reduced = peers.ReducedClarabel(1e-12)
    reduced.solve(nominal)  # built once
    times, errors = [], []
    for problem, reference in zip(problems, refs["linear"]):
        started = time.perf_counter()
        y, _, _ = reduced.solve(problem)
        times.append(time.perf_counter() - started)
        errors.append(error_of(vector_of(problem.x_from_y(y)), reference)[0])
    out["reduction_s"] = float(np.median(reduction_times))
    out["clarabel_reduced_s"] = float(np.median(times))
    out["clarabel_reduced_error_mm"] = _nanmax(errors)
    return out


def describe_floor(entry: dict) -> str:
    if not entry.get("measured"):
        return f"  {'floor':<24} not measured: {entry.get('note', '')}"
    return (
        f"  {'floor':<24} Newton alone {entry['single_s'] * 1e3:.3f} ms, vectorised "
        f"{entry['vectorised_per_load_s'] * 1e6:.1f} us per load, one dgesv "
        f"{entry['lapack_call_s'] * 1e6:.1f} us (error {entry['error_mm']:.1e}, "
        f"{entry['loads_on_known_set']}/{entry['loads']} loads on the known set); reduction "
        f"{entry['reduction_s'] * 1e3:.3f} ms, Clarabel on it "
        f"{entry['clarabel_reduced_s'] * 1e3:.3f} ms"
    )


def batch_run(case: Case, refs: dict, settings: RunSettings, tolerances: Tolerances) -> dict:
    """clearance_pin_batch: solve_many over the perturbed loads; time per case [s]."""
    mechanism = case.mechanism
    rng = np.random.default_rng(settings.seed + 1)
    n = len(case.perturbed)
    per_case, per_case_cpu, errors, translation, rotation, failed = [], [], [], [], [], 0
    note = ""
    for _ in range(settings.batch_repeats):
        order = rng.permutation(n)
        loads = [case.perturbed[i] for i in order]
        forget_answers(mechanism)
        gc.collect()
        cpu_started = time.process_time()
        started = time.perf_counter()
        try:
            batch = mechanism.solve_many(loads, progress=False)
            raw = [batch.torsors(j) for j in case.joints]
        except Exception as exc:
            failed += 1
            note = f"{type(exc).__name__}: {str(exc)[:160]}"
            continue
        per_case.append((time.perf_counter() - started) / n)
        per_case_cpu.append((time.process_time() - cpu_started) / n)
        # converted after the timing (a Python loop over the cases, the benchmark's own work)
        torsors = np.concatenate([np.array([paper_units(t) for t in r]) for r in raw], axis=1)
        for row, i in zip(torsors, order):
            total, t, r = error_of(row, refs["linear"][i])
            errors.append(total)
            translation.append(t)
            rotation.append(r)
    finite = [e for e in errors if np.isfinite(e)]
    median = float(np.median(per_case)) if per_case else math.nan
    entry = {
        "setting": {"tol": HEADLINE["tol"], "cases": n},
        "median_s": median,
        "median_cpu_s": _nanmedian(per_case_cpu),
        "cases_per_s": 1.0 / median if per_case else math.nan,
        "error_mm": float(max(finite)) if finite else math.nan,
        "error_nominal_mm": math.nan,
        "error_perturbed_max_mm": float(max(finite)) if finite else math.nan,
        "error_perturbed_median_mm": float(np.median(finite)) if finite else math.nan,
        "error_translation_mm": _nanmax(translation),
        "error_rotation_rad": _nanmax(rotation),
        "unsolved_cases": int(sum(not np.isfinite(e) for e in errors)),
        "solves": len(per_case) * n,
        "failures": failed,
        "failure_note": note,
        "peer": False,
        "description": OURS["clearance_pin_batch"],
    }
    entry["sweep"] = [
        {k: entry[k] for k in ("setting", "median_s", "median_cpu_s", "error_mm", "failures")}
    ]
    entry["matched"] = matched(entry["sweep"], tolerances)
    return entry


def matched(sweep: list[dict], tolerances: Tolerances) -> dict | None:
    """The fastest setting whose error reaches the target (no failed solve), if any."""
    good = [
        s
        for s in sweep
        if s.get("failures", 0) == 0
        and np.isfinite(s["error_mm"])
        and s["error_mm"] <= tolerances.target_error_mm
    ]
    if not good:
        return None
    best = min(good, key=lambda s: s["median_s"])
    return {"setting": best["setting"], "median_s": best["median_s"], "error_mm": best["error_mm"]}


# -- ratios, summary, plots ----------------------------------------------------------------------
def shgeom(values, shift: float) -> float:
    """Shifted geometric mean of non-negative values, shift in the values' unit."""
    v = np.asarray(values, dtype=float) / shift
    return float(np.exp(np.mean(np.log(v + 1.0))) - 1.0) * shift


def ratios(cases: dict) -> dict:
    """Per case, for each of our paths and each peer: time ratio peer / ours and both errors."""
    out = {}
    for case_id, methods in cases.items():
        ours = [m for m, e in methods.items() if not e["peer"]]
        theirs = [m for m, e in methods.items() if e["peer"]]
        if not theirs:
            continue
        table = {}
        for mine in ours:
            row = {}
            for peer in theirs:
                a, b = methods[mine], methods[peer]
                ma, mb = a.get("matched"), b.get("matched")
                cpu_a, cpu_b = a.get("median_cpu_s"), b.get("median_cpu_s")
                row[peer] = {
                    "time_ratio": b["median_s"] / a["median_s"],
                    "cpu_time_ratio": cpu_b / cpu_a
                    if cpu_a and cpu_b and math.isfinite(cpu_a) and math.isfinite(cpu_b)
                    else None,
                    "error_ours_mm": a["error_mm"],
                    "error_peer_mm": b["error_mm"],
                    "matched_time_ratio": mb["median_s"] / ma["median_s"] if ma and mb else None,
                }
            table[mine] = row
        out[case_id] = table
    return out


OUR_PATHS = {
    "clearance_pin_resolve": "re-solve (new load)",
    "clearance_pin_resolver": "re-solve, `resolver.solve(vectors)`",
    "clearance_pin_default": "cold solve, built mechanism",
    "clearance_pin_batch": "batch (`solve_many`)",
    "clearance_pin_exact": "exact model (from the linear answer)",
    "clearance_pin_ipopt": "IPOPT backend",
}
PEER_COLUMNS = (
    ("clarabel_prebuilt_default", "Clarabel prebuilt (default tol)"),
    ("clarabel_prebuilt", "Clarabel prebuilt (tol 1e-12)"),
    ("clarabel_direct", "Clarabel re-built"),
    ("cvxpy_clarabel_param", "cvxpy (parameters)"),
    ("cvxpy_clarabel", "cvxpy re-built"),
    ("scipy_slsqp", "scipy SLSQP"),
)


def _range(values) -> dict | None:
    values = [v for v in values if v is not None and math.isfinite(v)]
    if not values:
        return None
    return {"min": min(values), "median": float(np.median(values)), "max": max(values)}


def ratio_ranges(case_ratios: dict, cases: dict, floors: dict) -> dict:
    """Over the paper cases, per path of ours: the range (min, median, max) of each peer's time
    ratio peer / ours (wall and CPU), of ours / floor (single Newton, vectorised), and the
    issue-12 targets with their worst measured value."""
    out: dict = {"peers": {}, "floor": {}, "targets": {}}
    for mine in OUR_PATHS:
        rows = [table[mine] for table in case_ratios.values() if mine in table]
        if not rows:
            continue
        out["peers"][mine] = {
            peer: {
                "wall": _range(row[peer]["time_ratio"] for row in rows if peer in row),
                "cpu": _range(row[peer]["cpu_time_ratio"] for row in rows if peer in row),
            }
            for peer, _ in PEER_COLUMNS
        }
        measured = [(c, f) for c, f in floors.items() if f.get("measured") and mine in cases[c]]
        out["floor"][mine] = {
            "over_single_newton": _range(
                cases[c][mine]["median_s"] / f["single_s"] for c, f in measured
            ),
            "over_vectorised": _range(
                cases[c][mine]["median_s"] / f["vectorised_per_load_s"] for c, f in measured
            ),
        }

    def worst(mine, peer, scale=1.0):
        entry = out["peers"].get(mine, {}).get(peer, {}).get("wall")
        return None if entry is None else entry["min"] * scale

    for peer in ("clarabel_prebuilt_default", "clarabel_prebuilt"):
        out["targets"][peer] = {
            "re-solve at most 0.5x prebuilt Clarabel (ratio >= 2)": _target(
                worst("clearance_pin_resolve", peer), 2.0
            ),
            "re-solve by the resolver at most 0.5x prebuilt Clarabel (ratio >= 2)": _target(
                worst("clearance_pin_resolver", peer), 2.0
            ),
            "cold solve no slower than prebuilt Clarabel (ratio >= 1)": _target(
                worst("clearance_pin_default", peer), 1.0
            ),
            "solve_many at least 10x prebuilt Clarabel's rate (ratio >= 10)": _target(
                worst("clearance_pin_batch", peer), 10.0
            ),
        }
    out["targets"]["scipy_slsqp"] = {
        "re-solve at least 20x faster than SLSQP (ratio >= 20)": _target(
            worst("clearance_pin_resolve", "scipy_slsqp"), 20.0
        ),
        "re-solve by the resolver at least 20x faster than SLSQP (ratio >= 20)": _target(
            worst("clearance_pin_resolver", "scipy_slsqp"), 20.0
        ),
    }
    return out


def _target(value, required: float) -> dict:
    return {"worst": value, "required": required, "met": value is not None and value >= required}


def _span(entry) -> str:
    if not entry:
        return "-"
    low, high = entry["min"], entry["max"]
    digits = 2 if high < 10 else 1 if high < 100 else 0
    return f"{low:.{digits}f}-{high:.{digits}f}"


def print_markdown(ranges: dict, cases: dict, floors: dict, arm_results: dict) -> None:
    """The tables of benchmarks/README.md, in Markdown."""
    if ranges["peers"]:
        print(
            "\nRatios peer / ours over the paper cases (wall time, > 1: ours faster), "
            "and ours / floor"
        )
        header = [label for _, label in PEER_COLUMNS] + [
            "ours / floor: Newton alone",
            "ours / floor: vectorised Newton",
        ]
        print("\n| ours | " + " | ".join(header) + " |")
        print("|---" * (len(header) + 1) + "|")
        for mine, label in OUR_PATHS.items():
            if mine not in ranges["peers"]:
                continue
            cells = [_span(ranges["peers"][mine][peer]["wall"]) for peer, _ in PEER_COLUMNS]
            cells.append(_span(ranges["floor"][mine]["over_single_newton"]))
            cells.append(_span(ranges["floor"][mine]["over_vectorised"]))
            print(f"| {label} | " + " | ".join(cells) + " |")
        print("\nIssue 12 targets (worst case over the paper cases):\n")
        for peer, targets in ranges["targets"].items():
            for text, t in targets.items():
                value = "n/a" if t["worst"] is None else f"{t['worst']:.2f}"
                print(f"- vs {peer}: {text}: {value} ({'met' if t['met'] else 'not met'})")
    paper = [c for c in cases if c in floors]
    if paper:
        print(
            "\n| case | re-solve | cold | batch | Clarabel prebuilt default / 1e-12 | SLSQP | "
            "reduction | Clarabel on it | Newton alone | vectorised Newton | worst error of ours "
            "[of the play] | prebuilt 1e-12 error |"
        )
        print("|---" * 12 + "|")
        for case_id in paper:
            m, f = cases[case_id], floors[case_id]

            def ms(name, m=m):
                return f"{m[name]['median_s'] * 1e3:.3f}" if name in m else "-"

            ours = [m[k].get("error_rel_play", math.nan) for k in OUR_PATHS if k in m]
            single = f"{f['single_s'] * 1e3:.3f}" if f.get("measured") else "-"
            vector = f"{f['vectorised_per_load_s'] * 1e6:.1f} us" if f.get("measured") else "-"
            print(
                f"| {case_id} | {ms('clearance_pin_resolve')} | {ms('clearance_pin_default')} | "
                f"{ms('clearance_pin_batch')} | {ms('clarabel_prebuilt_default')} / "
                f"{ms('clarabel_prebuilt')} | {ms('scipy_slsqp')} | "
                f"{f.get('reduction_s', math.nan) * 1e3:.3f} | "
                f"{f.get('clarabel_reduced_s', math.nan) * 1e3:.3f} | {single} | {vector} | "
                f"{_nanmax(ours):.0e} | "
                f"{m['clarabel_prebuilt'].get('error_rel_play', math.nan):.0e} |"
            )
    arm_rows = {k: v for k, v in arm_results.items() if "trajectory" in v}
    if arm_rows:
        print(
            "\n| arm | trajectory: solve_many [s] | loop of solve [s] | prebuilt Clarabel [s] "
            "(reduction + Clarabel) | error solve_many / loop / prebuilt [of the play] |"
        )
        print("|---" * 5 + "|")
        for name, entry in arm_rows.items():
            t = entry["trajectory"]
            peer = t["clarabel_prebuilt"]
            print(
                f"| {name} | {t['solve_many']['wall_s']:.3f} ({t['points']} points) | "
                f"{t['solve_loop']['wall_s']:.3f} | {peer['wall_s']:.3f} "
                f"({peer['reduction_median_s'] * 1e3:.2f} + {peer['clarabel_median_s'] * 1e3:.2f}"
                f" ms per point) | {t['solve_many']['error_rel_play']:.0e} / "
                f"{t['solve_loop']['error_rel_play']:.0e} / {peer['error_rel_play']:.0e} |"
            )
        print(
            "\n| arm | load cases: solve_many [ms per case] (cases, rate) | loop of solve [ms] | "
            "prebuilt Clarabel 1e-12 / default [ms] (+ reduction) | solve_many: 1e5 cases [s] | "
            "error solve_many / loop / prebuilt [of the play] |"
        )
        print("|---" * 6 + "|")
        for name, entry in arm_rows.items():
            c = entry["loads"]
            many, peer = c["solve_many"], c["clarabel_prebuilt"]
            projected = "measured" if many["cases"] >= 100_000 else "projected"
            print(
                f"| {name} | {many['per_case_s'] * 1e3:.3f} ({many['cases']}, "
                f"{many['cases_per_s']:.0f}/s) | {c['solve_loop']['median_s'] * 1e3:.3f} | "
                f"{peer['clarabel_median_s'] * 1e3:.3f} / "
                f"{c['clarabel_prebuilt_default']['clarabel_median_s'] * 1e3:.3f} "
                f"(+ {peer['reduction_median_s'] * 1e3:.3f}) | "
                f"{many['per_case_s'] * 1e5:.1f} ({projected}) | {many['error_rel_play']:.0e} / "
                f"{c['solve_loop']['error_rel_play']:.0e} / {peer['error_rel_play']:.0e} |"
            )


def print_kernel(kernel: dict, floors: dict, cases: dict) -> None:
    """The compiled kernel's one-time costs and, per paper case, the kernel alone on the known
    active set beside the whole re-solve and prebuilt Clarabel (Markdown)."""
    if not kernel.get("used"):
        print("\nThe compiled kernel was off (--no-kernel).")
        return
    if "fresh_s" not in kernel:
        print(f"\nCompiled kernel loaded in {kernel['load_s']:.2f} s (costs not measured: --quick)")
        return
    print(
        f"\nCompiled kernel: load with an empty numba cache (compiling) {kernel['fresh_s']:.1f} s, "
        f"with the cache warm {kernel['warm_s']:.2f} s; a new process's import "
        f"{kernel['import_s']:.2f} s, first solve (four_bar) {1e3 * kernel['first_solve_s']:.1f} ms,"
        f" numba loaded by then: {kernel['numba_loaded']}\n"
    )
    print(
        "| case | re-solve [us] | resolver [us] | kernel alone [us] | "
        "prebuilt Clarabel default / 1e-12 [us] |"
    )
    print("|---|---|---|---|---|")
    for case_id, entry in floors.items():
        methods = cases.get(case_id, {})

        def us(name, methods=methods):
            value = methods.get(name, {}).get("median_s")
            return f"{1e6 * value:.0f}" if value is not None else "-"

        alone = entry.get("compiled_s")
        print(
            f"| {case_id} | {us('clearance_pin_resolve')} | {us('clearance_pin_resolver')} | "
            f"{'-' if alone is None else f'{1e6 * alone:.1f}'} | "
            f"{us('clarabel_prebuilt_default')} / {us('clarabel_prebuilt')} |"
        )


def summary(cases: dict, tolerances: Tolerances) -> dict:
    """Across cases: shifted geometric mean of the median times per method, and worst errors."""
    methods = sorted({m for c in cases.values() for m in c})
    out = {}
    for method in methods:
        times = [
            c[method]["median_s"]
            for c in cases.values()
            if method in c and np.isfinite(c[method]["median_s"])
        ]
        errors = [
            c[method]["error_mm"]
            for c in cases.values()
            if method in c and np.isfinite(c[method]["error_mm"])
        ]
        cpu = [
            c[method]["median_cpu_s"]
            for c in cases.values()
            if method in c
            and c[method].get("median_cpu_s") is not None
            and np.isfinite(c[method]["median_cpu_s"])
        ]
        out[method] = {
            "shgeom_median_s": shgeom(times, tolerances.time_shift_s),
            "shgeom_median_cpu_s": shgeom(cpu, tolerances.time_shift_s) if cpu else None,
            "cases": len(times),
            "worst_error_mm": max(errors) if errors else None,
        }
    return out


def print_tables(cases: dict, case_ratios: dict, totals: dict, references_info: dict) -> None:
    print("\nMedian time per solve and worst error (translations mm, rotations rad)")
    for case_id, methods in cases.items():
        ref = references_info[case_id]
        print(
            f"\n{case_id}  (reference check: {ref['cross_check']} max "
            f"{ref['cross_check_max_mm']:.1e} mm"
            + (
                f"; ours vs expected_mm {ref['nominal_vs_expected_mm']:.1e}"
                if ref["nominal_vs_expected_mm"] is not None
                else ""
            )
            + ")"
        )
        print(
            f"  {'method':<24}{'setting':>20}{'median ms':>11}{'cpu ms':>9}{'error':>10}"
            f"{'fail':>6}{'to 1e-9 mm: ms':>16}"
        )
        for name, e in methods.items():
            setting = ", ".join(
                f"{k}={v:g}" if isinstance(v, (int, float)) else f"{k}={v}"
                for k, v in e["setting"].items()
            )
            m = e.get("matched")
            cpu = e.get("median_cpu_s")
            cpu = cpu * 1e3 if cpu is not None and math.isfinite(cpu) else math.nan
            print(
                f"  {name:<24}{setting:>20}{e['median_s'] * 1e3:11.4f}{cpu:9.4f}"
                f"{e['error_mm']:10.1e}{e['failures']:6d}"
                f"{(m['median_s'] * 1e3 if m else math.nan):16.4f}"
            )
    if case_ratios:
        peer_names = sorted({p for t in case_ratios.values() for r in t.values() for p in r})
        print(
            "\nTime ratios peer / ours (> 1: ours faster) at the headline settings: wall / CPU "
            "time, [in brackets] wall at matched accuracy (fastest setting with error <= 1e-9 mm; "
            "n/a: never reached); errors in mm (rotations in rad)"
        )
        print(
            f"  {'case':<14}{'ours':<24}{'our error':>11}" + "".join(f"{p:>27}" for p in peer_names)
        )
        for case_id, table in case_ratios.items():
            first = next(iter(table.values()))
            print(
                f"  {case_id:<14}{'(peer error)':<24}{'':>11}"
                + "".join(
                    f"{first[p]['error_peer_mm']:>27.1e}" if p in first else f"{'-':>27}"
                    for p in peer_names
                )
            )
            for mine, row in table.items():
                cells = []
                for p in peer_names:
                    r = row.get(p)
                    if r is None:
                        cells.append(f"{'-':>27}")
                        continue
                    mt, ct = r["matched_time_ratio"], r["cpu_time_ratio"]
                    matched_text = f"{mt:6.2f}" if mt is not None else "   n/a"
                    cpu_text = f"{ct:.2f}" if ct is not None else "-"
                    cells.append(f"{r['time_ratio']:>12.2f} /{cpu_text:>5} [{matched_text}]")
                error = next(iter(row.values()))["error_ours_mm"]
                print(f"  {case_id:<14}{mine:<24}{error:>11.1e}" + "".join(cells))
    print("\nAcross cases: shifted geometric mean of the median times")
    for method, t in totals.items():
        worst = t["worst_error_mm"]
        cpu = t["shgeom_median_cpu_s"]
        print(
            f"  {method:<27}{t['shgeom_median_s'] * 1e3:10.4f} ms (CPU "
            f"{cpu * 1e3 if cpu is not None else math.nan:8.4f} ms) over {t['cases']:2d} cases, "
            f"worst error {worst if worst is not None else math.nan:.1e}"
        )


def plot(cases: dict, directory: Path, tolerances: Tolerances) -> Path:
    """Work-precision grid: one panel per case, median time vs worst error per setting."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    ids = list(cases)
    columns = 4
    rows = math.ceil(len(ids) / columns)
    figure, axes = plt.subplots(rows, columns, figsize=(4.2 * columns, 3.4 * rows), squeeze=False)
    # ours: solid lines, round markers, tab10's first seven colours; peers: dashed, squares,
    # tab10's last three and three others (thirteen methods, none sharing a colour)
    peer = {m: bool(e.get("peer")) for c in cases.values() for m, e in c.items()}
    ours = sorted(m for m in peer if not peer[m])
    others = sorted(m for m in peer if peer[m])
    palette = [*plt.cm.tab10.colors[:7]]
    peer_palette = [*plt.cm.tab10.colors[7:], "#000000", "#e6ab02", "#1b2a6b"]
    colours = {m: palette[i % len(palette)] for i, m in enumerate(ours)}
    colours.update({m: peer_palette[i % len(peer_palette)] for i, m in enumerate(others)})
    for ax, case_id in zip(axes.flat, ids):
        for name, entry in cases[case_id].items():
            points = [
                (s["median_s"], max(s["error_mm"], tolerances.error_floor_mm))
                for s in entry["sweep"]
                if _finite(s["median_s"]) and _finite(s["error_mm"])
            ]
            if not points:
                continue
            t, e = zip(*points)
            style, marker = ("--", "s") if entry["peer"] else ("-", "o")
            ax.plot(t, e, style, marker=marker, ms=3, color=colours[name], label=name)
            if _finite(entry["error_mm"]) and _finite(entry["median_s"]):
                ax.plot(
                    entry["median_s"],
                    max(entry["error_mm"], tolerances.error_floor_mm),
                    marker="*",
                    ms=9,
                    color=colours[name],
                )
        ax.axhline(tolerances.target_error_mm, color="grey", lw=0.6, ls=":")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.set_title(case_id, fontsize=9)
        ax.set_xlabel("median time per solve [s]", fontsize=7)
        ax.set_ylabel("worst error [mm | rad]", fontsize=7)
        ax.tick_params(labelsize=6)
    for ax in list(axes.flat)[len(ids) :]:
        ax.axis("off")
    handles = {}
    for ax in axes.flat:
        for h, label in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(label, h)
    figure.legend(handles.values(), handles.keys(), loc="lower center", ncol=5, fontsize=8)
    figure.suptitle(
        "clearance_pin work-precision (star: headline setting; dotted: 1e-9 mm; "
        f"errors of 0 drawn at {tolerances.error_floor_mm:g})",
        fontsize=10,
    )
    figure.tight_layout(rect=(0, 0.05, 1, 0.97))
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / "work_precision.png"
    figure.savefig(path, dpi=110)
    plt.close(figure)
    return path


def _finite(value) -> bool:
    """A finite number (JSON null, NaN and inf are not)."""
    return value is not None and math.isfinite(value)


def _git_state() -> str:
    """``git describe --always --dirty`` of the repository (what was measured)."""
    import subprocess

    try:
        return subprocess.run(
            ["git", "describe", "--always", "--dirty"],
            check=False,
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=10,
        ).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return ""


def _clean(value):
    """JSON-safe: NaN and inf as null, numpy numbers as floats."""
    if isinstance(value, dict):
        return {str(k): _clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_clean(v) for v in value]
    if isinstance(value, (np.floating, float)):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.ndarray):
        return _clean(value.tolist())
    return value


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", type=Path, help="write the results to this JSON file")
    parser.add_argument(
        "--plots",
        type=Path,
        default=ROOT / "out" / "work_precision",
        help="directory of the PNG (default: out/work_precision)",
    )
    parser.add_argument("--no-plots", action="store_true")
    parser.add_argument("--quick", action="store_true", help="short run (few loads, 2 settings)")
    parser.add_argument("--cases", nargs="*", help="only these case ids (model:<stem> for models)")
    parser.add_argument("--loads", type=int, help="perturbed loads per case (override)")
    parser.add_argument("--budget", type=float, help="seconds per timed run (override)")
    parser.add_argument("--seed", type=int, help="seed of the load perturbations (override)")
    parser.add_argument("--replot", type=Path, help="only draw the PNG from this JSON file")
    parser.add_argument(
        "--arms",
        nargs="*",
        choices=arms.ARMS,
        help="arm runs of these arms (no name: all; default: all unless --cases is given)",
    )
    parser.add_argument("--no-arms", action="store_true", help="no arm runs")
    parser.add_argument("--arm-points", type=int, help="points of each arm trajectory (override)")
    parser.add_argument(
        "--arm-loads", type=int, nargs="+", help="sizes of the arms' tool-load runs (override)"
    )
    parser.add_argument("--no-floor", action="store_true", help="skip the floor (floor.py)")
    parser.add_argument(
        "--no-kernel",
        action="store_true",
        help="time the NumPy path only (CLEARANCE_PIN_COMPILED=0; default: the compiled kernel is "
        "loaded first, as a planner does, and its one-time costs are measured)",
    )
    args = parser.parse_args(argv)
    if args.replot:
        document = json.loads(args.replot.read_text())
        print(f"wrote {plot(document['cases'], args.plots, Tolerances())}")
        return 0
    settings = QUICK if args.quick else RunSettings()
    overrides = {}
    if args.loads:
        overrides.update(
            loads=args.loads,
            exact_loads=min(args.loads, settings.exact_loads),
            min_solves=min(args.loads, settings.min_solves),
        )
    if args.budget is not None:
        overrides["budget_s"] = args.budget
    if args.seed is not None:
        overrides["seed"] = args.seed
    if args.arm_points:
        overrides["arm_points"] = args.arm_points
    if args.arm_loads:
        overrides["arm_loads"] = tuple(args.arm_loads)
    if args.no_floor:
        overrides["floor_rows"] = 0
    if overrides:
        settings = RunSettings(**{**asdict(settings), **overrides})
    tolerances = Tolerances()
    warnings.simplefilter("ignore", clearance_pin.ConditioningWarning)
    warnings.filterwarnings("ignore", message="Solution may be inaccurate")  # cvxpy: in statuses

    started = time.perf_counter()
    load_start = os.getloadavg()
    git_state = _git_state()  # at the start: what is imported is what is measured
    if args.no_kernel:
        os.environ["CLEARANCE_PIN_COMPILED"] = "0"
        kernel = {"used": False}
    else:  # a quick run loads the kernel (as a planner does) without measuring its costs
        costs = {} if args.quick else kernel_cost.kernel_costs()
        kernel = {"used": True, **costs, "load_s": fast_path.load_kernel()}
        print(f"kernel: {kernel}", flush=True)
    cases = load_cases(args.cases)
    if not cases:
        parser.error(f"no case matches {args.cases}")
    if args.no_arms:
        arm_names = []
    elif args.arms is not None:
        arm_names = list(args.arms) or list(arms.ARMS)
    else:
        arm_names = [] if args.cases else list(arms.ARMS)
    results, refs_info, info, floors = {}, {}, {}, {}
    for case in cases:
        # one stream per case: a case's loads do not depend on which other cases run
        rng = np.random.default_rng([settings.seed, zlib.crc32(case.id.encode())])
        case.nominal = tuple(
            load for load in case.mechanism.loads if isinstance(load, (PointForce, Torque))
        )
        try:
            case.perturbed = perturbed_loads(
                case.mechanism, settings.loads, settings.perturbation, rng
            )
        except ValueError as exc:
            print(f"case {case.id}: skipped, {exc}")
            continue
        print(f"case {case.id}: {len(case.perturbed)} loads", flush=True)
        results[case.id], refs_info[case.id] = run_case(
            case, settings, tolerances, lambda line: print(line, flush=True)
        )
        if "floor" in refs_info[case.id]:
            floors[case.id] = refs_info[case.id].pop("floor")
        info[case.id] = {
            "build_and_first_solve_s": case.build_s,
            "joints": list(case.joints),
            "peers": case.shaft is not None,
            "reference": refs_info[case.id],
        }
    arm_results = arms.arm_benchmarks(arm_names, settings, lambda line: print(line, flush=True))
    case_ratios = ratios(results)
    ranges = ratio_ranges(case_ratios, results, floors)
    totals = summary(results, tolerances)
    print_tables(results, case_ratios, totals, refs_info)
    print_markdown(ranges, results, floors, arm_results)
    print_kernel(kernel, floors, results)
    document = {
        "cases": results,
        "ratios": case_ratios,
        "ratio_ranges": ranges,
        "summary": totals,
        "case_info": info,
        "floor": floors,
        "arms": arm_results,
        "kernel": kernel,
        "settings": asdict(settings),
        "tolerances": asdict(tolerances),
        "machine": {
            "python": platform.python_version(),
            "platform": platform.platform(),
            "processor": platform.processor() or platform.machine(),
            "cpus": os.cpu_count(),
            "load_average_start": load_start,
            "load_average_end": os.getloadavg(),
            "blas_threads": os.environ.get("OPENBLAS_NUM_THREADS"),
            "clearance_pin": clearance_pin.__version__,
            "git": git_state,
        },
        "wall_time_s": time.perf_counter() - started,
    }
    if args.json:
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(_clean(document), indent=1))
        print(f"wrote {args.json}")
    if not args.no_plots:
        print(f"wrote {plot(results, args.plots, tolerances)}")
    print(f"total {time.perf_counter() - started:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
