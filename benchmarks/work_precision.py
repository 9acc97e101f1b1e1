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

Usage:
    python benchmarks/work_precision.py [--json FILE] [--plots DIR] [--quick] [--cases ID ...]

JSON: {"cases": {id: {method: {"median_s", "error_mm", "peer", ...extra keys}}}, "ratios": ...}.
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

import peers

import clearance_pin
from clearance_pin import ClearancePinError, PointForce, Torque

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
        trajectory_points: points of the 6R arm trajectory (solve_many over configurations).
    """

    loads: int = 200
    budget_s: float = 2.0
    min_solves: int = 20
    trajectory_points: int = 1000
    exact_loads: int = 60
    batch_repeats: int = 5
    perturbation: float = 0.3
    seed: int = 20130601
    sweep: dict = field(
        default_factory=lambda: {
            "tol": (1e-4, 1e-6, 1e-8, 1e-10, 1e-12),
            "exact_tol": (1e-6, 1e-8, 1e-10, 1e-12),
            "ftol": (1e-4, 1e-6, 1e-8, 1e-10, 1e-12, 1e-14),
        }
    )


QUICK = RunSettings(
    trajectory_points=200,
    loads=20,
    budget_s=0.3,
    min_solves=5,
    exact_loads=8,
    batch_repeats=2,
    sweep={"tol": (1e-6, 1e-12), "exact_tol": (1e-8, 1e-12), "ftol": (1e-6, 1e-12)},
)
HEADLINE = {"tol": 1e-12, "exact_tol": 1e-12, "ftol": 1e-12}


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
            body_loads = gather_body_loads(
                mechanism.model, configuration, rebuild(unit), mechanism.link_frames
            )
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
    "clearance_pin_default": "mechanism.solve(loads, warm_start=False): Clarabel + KKT polish, "
    "cold start, built once",
    "clearance_pin_resolve": "mechanism.solve(loads): warm start (active-set Newton) from the "
    "previous load",
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
        for backend in ("auto", "ipopt"):
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
    nominal_linear = case.vector(mechanism.solve(case.nominal, tol=1e-12, warm_start=False))
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
            }
        )
        results[name] = entry
        log(
            f"  {name:<24} {entry['median_s'] * 1e3:9.3f} ms  error {entry['error_mm']:.2e}  "
            f"({entry['solves']} solves, {entry['failures']} failed)"
        )

    # ours, cold: Clarabel (auto) and IPOPT backends
    for name, backend in (("clearance_pin_default", "auto"), ("clearance_pin_ipopt", "ipopt")):
        runs = []
        for tol in settings.sweep["tol"]:

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

    # ours, warm re-solve: each load warm-started from the previous one
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
    log(
        f"  {'clearance_pin_batch':<24} {entry['median_s'] * 1e3:9.3f} ms  error "
        f"{entry['error_mm']:.2e}  ({entry['cases_per_s']:.0f} cases/s)"
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
        settings.sweep["tol"],
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
    return results, refs["summary"]


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
        gc.collect()
        cpu_started = time.process_time()
        started = time.perf_counter()
        try:
            batch = mechanism.solve_many(loads, progress=False)
            torsors = np.concatenate(
                [np.array([paper_units(t) for t in batch.torsors(j)]) for j in case.joints], axis=1
            )
        except Exception as exc:
            failed += 1
            note = f"{type(exc).__name__}: {str(exc)[:160]}"
            continue
        per_case.append((time.perf_counter() - started) / n)
        per_case_cpu.append((time.process_time() - cpu_started) / n)
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
            setting = ", ".join(f"{k}={v:g}" for k, v in e["setting"].items())
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
            f"  {'case':<14}{'ours':<24}{'our error':>11}" + "".join(f"{p:>24}" for p in peer_names)
        )
        for case_id, table in case_ratios.items():
            first = next(iter(table.values()))
            print(
                f"  {case_id:<14}{'(peer error)':<24}{'':>11}"
                + "".join(
                    f"{first[p]['error_peer_mm']:>24.1e}" if p in first else f"{'-':>24}"
                    for p in peer_names
                )
            )
            for mine, row in table.items():
                cells = []
                for p in peer_names:
                    r = row.get(p)
                    if r is None:
                        cells.append(f"{'-':>24}")
                        continue
                    mt, ct = r["matched_time_ratio"], r["cpu_time_ratio"]
                    matched_text = f"{mt:6.2f}" if mt is not None else "   n/a"
                    cpu_text = f"{ct:.2f}" if ct is not None else "-"
                    cells.append(f"{r['time_ratio']:>9.2f} /{cpu_text:>5} [{matched_text}]")
                error = next(iter(row.values()))["error_ours_mm"]
                print(f"  {case_id:<14}{mine:<24}{error:>11.1e}" + "".join(cells))
    print("\nAcross cases: shifted geometric mean of the median times")
    for method, t in totals.items():
        worst = t["worst_error_mm"]
        cpu = t["shgeom_median_cpu_s"]
        print(
            f"  {method:<24}{t['shgeom_median_s'] * 1e3:10.4f} ms (CPU "
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
    methods = sorted({m for c in cases.values() for m in c})
    colours = {m: plt.cm.tab10(i % 10) for i, m in enumerate(methods)}
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
            style = "--" if entry["peer"] else "-"
            ax.plot(t, e, style, marker="o", ms=3, color=colours[name], label=name)
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


def trajectory_benchmark(points: int) -> dict:
    """A planner's use: the 6R arm (models/arm_6r.urdf) with its tool load along a trajectory of
    all six joints (each q_i + 0.5 sin(phase + i), one turn of the phase over the points),
    solved by ``solve_many(configurations=...)`` on a freshly loaded mechanism (its first solve
    and every configuration's geometry included). Reference: cold solves (nothing carried
    from the previous point) of every 10th point on another fresh mechanism; the two must agree."""
    mechanism = clearance_pin.load(ROOT / "models" / "arm_6r.urdf")
    phases = np.linspace(0.0, 2.0 * np.pi, points)
    configurations = [
        mechanism.q_nominal + 0.5 * np.sin(phase + np.arange(mechanism.model.nq))
        for phase in phases
    ]
    gc.collect()
    started = time.perf_counter()
    batch = mechanism.solve_many(configurations=configurations, errors="return", progress=False)
    wall = time.perf_counter() - started
    cold_mechanism = clearance_pin.load(ROOT / "models" / "arm_6r.urdf")
    cold_times, worst = [], 0.0
    clearance = max(c.bound for j in cold_mechanism.joints.values() for c in j.clearance.contacts)
    for k in range(0, points, 10):
        started = time.perf_counter()
        cold = cold_mechanism.solve(q=configurations[k], warm_start=False)
        cold_times.append(time.perf_counter() - started)
        if not isinstance(batch[k], Exception):
            differences = [
                float(np.abs(batch[k].torsors[name] - t).max()) for name, t in cold.torsors.items()
            ]
            worst = max(worst, *differences)
    statuses: dict[str, int] = {}
    for status in batch.statuses:
        statuses[status] = statuses.get(status, 0) + 1
    result = {
        "model": "arm_6r",
        "points": points,
        "wall_s": wall,
        "per_point_s": wall / points,
        "seconds_per_1000_points": 1000.0 * wall / points,
        "cold_median_s": float(np.median(cold_times)),
        "max_difference_to_cold_rel": worst / clearance,
        "ok": int(np.sum(batch.ok)),
        "statuses": statuses,
    }
    print(
        f"trajectory arm_6r: {points} points in {wall:.2f} s ({1e3 * wall / points:.2f} ms per "
        f"point; cold solve {1e3 * result['cold_median_s']:.2f} ms), warm = cold to "
        f"{result['max_difference_to_cold_rel']:.1e} of the clearance, {result['ok']} ok",
        flush=True,
    )
    return result


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
    if overrides:
        settings = RunSettings(**{**asdict(settings), **overrides})
    tolerances = Tolerances()
    warnings.simplefilter("ignore", clearance_pin.ConditioningWarning)
    warnings.filterwarnings("ignore", message="Solution may be inaccurate")  # cvxpy: in statuses

    started = time.perf_counter()
    load_start = os.getloadavg()
    git_state = _git_state()  # at the start: what is imported is what is measured
    cases = load_cases(args.cases)
    if not cases:
        parser.error(f"no case matches {args.cases}")
    results, refs_info, info = {}, {}, {}
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
        info[case.id] = {
            "build_and_first_solve_s": case.build_s,
            "joints": list(case.joints),
            "peers": case.shaft is not None,
            "reference": refs_info[case.id],
        }
    trajectory = (
        trajectory_benchmark(settings.trajectory_points)
        if not args.cases or "model:arm_6r" in args.cases
        else None
    )
    case_ratios = ratios(results)
    totals = summary(results, tolerances)
    print_tables(results, case_ratios, totals, refs_info)
    document = {
        "cases": results,
        "ratios": case_ratios,
        "summary": totals,
        "case_info": info,
        "trajectory": trajectory,
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
