r"""Solve the reduced cone programme: a backend finds the optimum, a verified Newton step polishes it.

Problem (see :mod:`.reduction`), dimensionless:

.. math::  \min_y f^T y \quad \text{s.t.} \quad \|P_j y + o_j\| \le 1 \ (\text{ball, disc}),\quad
           |p_j^T y + o_j| \le 1 \ (\text{slab})

(:math:`o_j`: a misaligned housing's nominal eccentricity over its play, usually 0).

Two steps:

1. *backend*: Clarabel (interior point for cones, when installed: ``pip install clearance_pin[fast]``)
   or IPOPT through CasADi (always available), from the nominal position;
2. *polish*: the active-set Newton step of :mod:`.kkt` from the backend's answer, to machine
   precision.

(A NumPy Newton step from the previous answer's contact set was tried first until issue 22: on
the paper cases and the bundled models, 200 re-solves each interleaved in one process, it took
0.94 to 1.05 times the cold backend's time, so it was dropped; the compiled kernel is the warm
path, :mod:`.fast_path`.)

Every answer is verified (multipliers >= 0, contacts feasible, KKT residual at round-off) before it
is accepted; an unverified backend answer is returned with its measured residuals, and the caller
decides (``solve_linear`` raises :class:`~clearance_pin.errors.SolverError`).
"""

from __future__ import annotations

import functools
import importlib.util
import threading
import time
from collections.abc import MutableMapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import ArgumentError
from . import ipopt
from .elastic_newton import curvature_scaled, elastic_residuals, polish_elastic
from .kkt import (
    ACCEPT_KKT,
    ACTIVE_GAP,
    NEARLY_TOUCHING,
    StackedContacts,
    active_set_solve,
    residuals,
)
from .method import Method, backend_method
from .reduction import ReducedProblem, Signature

BACKENDS = ("auto", "clarabel", "ipopt")
WARM_MAX_SIZE = 48  # dense Newton steps cost O(size^3): larger problems go to the sparse backend
KEPT_SOLVERS = 8  # Clarabel solvers kept per backend, one per geometry (configuration)


@dataclass
class ConeSolution:
    """Solution of the reduced problem with its own measured residuals (dimensionless).

    Attributes:
        y: reduced unknowns, (r,).
        multipliers: lambda_j >= 0 per contact (squared-norm form, scaled by the objective scale).
        signs: +1/-1 for the side of a slab contact in touch (1 for balls and discs).
        status: the backend's own status (``"ipopt: Solve_Succeeded"``).
        iterations: backend iterations (0 for a Newton start).
        polished: the Newton step was accepted (the answer is verified at round-off).
        residuals: stationarity, feasibility, complementarity, dual_infeasibility.
        solve_time: wall time [s] of this solve.
        setup_time: part of it [s] spent building the backend's solver for a new geometry.
    """

    y: np.ndarray
    multipliers: np.ndarray
    signs: np.ndarray
    status: str
    iterations: int
    polished: bool
    residuals: dict[str, float] = field(default_factory=dict)
    solve_time: float = 0.0
    setup_time: float = 0.0
    method: Method = Method.CLARABEL

    @property
    def kkt_residual(self) -> float:
        """Largest measured residual."""
        return max(self.residuals.values(), default=0.0)


@functools.cache
def clarabel_available() -> bool:
    """Whether the Clarabel backend is installed (clarabel and SciPy found, not imported: the
    plan asks on a first solve, which the closed forms may answer without them; importing
    SciPy's sparse module took 110 ms there)."""
    return all(importlib.util.find_spec(name) is not None for name in ("clarabel", "scipy"))


BackendAnswer = tuple[np.ndarray, np.ndarray, str, int]


class IpoptBackend:
    """IPOPT on reduced problems with one signature (built once; f and P_j are parameters)."""

    name = "ipopt"

    def __init__(self, signature: Signature, tol: float = 1e-12, max_iter: int = 200) -> None:
        import casadi as ca

        started = time.perf_counter()
        size, shapes = signature[:2]
        self._elastic = len(signature) > 2 and bool(signature[2])  # f y + y H y / 2
        y = ca.SX.sym("y", size)
        f = ca.SX.sym("f", size)
        h = ca.SX.sym("H", size, size) if self._elastic else ca.SX(size, size)
        total_rows = sum(k for _, k in shapes)
        p_matrix = ca.SX.sym("P", total_rows, size)
        offset = ca.SX.sym("o", total_rows)
        constraints, lower = [], []
        row = 0
        for shape, k in shapes:
            image = ca.mtimes(p_matrix[row : row + k, :], y) + offset[row : row + k]
            row += k
            constraints.append(ca.sumsqr(image) if shape == "norm" else image)
            lower.append(-ca.inf if shape == "norm" else -1.0)
        parameters = [f, ca.vec(p_matrix), offset] + ([ca.vec(h)] if self._elastic else [])
        nlp = {
            "x": y,
            "p": ca.vertcat(*parameters),
            "f": ca.dot(f, y) + 0.5 * ca.dot(y, ca.mtimes(h, y)),
            "g": ca.vertcat(*constraints) if constraints else ca.SX(0, 1),
        }
        options: dict[str, Any] = {
            "print_time": False,
            "ipopt.print_level": 0,
            "ipopt.sb": "yes",
            "ipopt.tol": tol,
            "ipopt.acceptable_tol": tol,
            "ipopt.bound_relax_factor": 0.0,
            "ipopt.max_iter": max_iter,
            "ipopt.mu_strategy": "adaptive",
        }
        self._solver = ipopt.build("clearance_cone", "ipopt", nlp, options)
        self._lower = np.array(lower, dtype=float)
        self._upper = np.ones(len(shapes))
        self.build_time = time.perf_counter() - started

    def run(self, problem: ReducedProblem) -> BackendAnswer:
        """(y, multipliers, status, iterations) from the nominal start y = 0."""
        stack = problem.stack
        parts = [problem.objective, stack.matrix.ravel(order="F"), stack.offset]
        if self._elastic and problem.hessian is not None:
            parts.append(problem.hessian.ravel(order="F"))
        parameters = np.concatenate(parts)
        result, stats = ipopt.run(
            self._solver, x0=np.zeros(problem.size), p=parameters, lbg=self._lower, ubg=self._upper
        )
        y = np.asarray(result["x"], dtype=float).ravel()
        lam = np.abs(np.asarray(result["lam_g"], dtype=float).ravel())
        return y, lam, f"ipopt: {stats['return_status']}", int(stats.get("iter_count", 0))


class ClarabelBackend:
    """Clarabel on the second-order-cone form: (1, P_j y + o_j) in SOC, 1 -/+ (p_j^T y + o_j) >= 0."""

    name = "clarabel"

    def __init__(self, signature: Signature, tol: float = 1e-12) -> None:
        import clarabel
        from scipy import sparse

        self._clarabel, self._sparse = clarabel, sparse
        size, shapes = signature[:2]
        self.build_time = 0.0
        settings = clarabel.DefaultSettings()
        settings.verbose = False
        settings.tol_gap_abs = settings.tol_gap_rel = tol
        settings.tol_feas = settings.tol_ktratio = tol
        settings.max_iter = 100
        settings.presolve_enable = False  # keeps the data updatable (a new load updates q only)
        self._settings = settings
        # per contact: its cone, its rows of b, and how its dual variables give the multiplier
        # (d||Py||/dy = (1/2) d||Py||^2/dy on the sphere; a slab's two sides add)
        cones: list[Any] = []  # Clarabel's cone objects
        b: list[float] = []
        weights: list[float] = []
        starts: list[int] = []
        for shape, k in shapes:
            starts.append(len(b))
            if shape == "norm":
                cones.append(clarabel.SecondOrderConeT(k + 1))
                b.extend([1.0] + [0.0] * k)
                weights.extend([0.5] + [0.0] * k)
            else:
                cones.append(clarabel.NonnegativeConeT(2))
                b.extend([1.0, 1.0])
                weights.extend([1.0, 1.0])
        self._cones = cones
        self._zero = sparse.csc_matrix((size, size))
        self._b = np.array(b)
        self._z_weights = np.array(weights)
        self._z_starts = np.array(starts, dtype=int)
        self._local = threading.local()  # a Clarabel solver may not be shared across threads
        self.setup_time = 0.0  # [s] building the solver for a new geometry in the last run

    def run(self, problem: ReducedProblem) -> BackendAnswer:
        """(y, multipliers, status, iterations).

        The cone data depend on the geometry only, so one Clarabel solver is kept per geometry
        and thread (the last :data:`KEPT_SOLVERS`); a new load only updates the linear cost.
        """
        stack = problem.stack
        if problem.hessian is not None:
            return self._run_elastic(problem)
        solvers = self._local.__dict__.setdefault("solvers", {})
        entry = solvers.pop(id(stack), None)
        started = time.perf_counter()
        self.setup_time = 0.0
        if entry is None or entry[0] is not stack:
            # built on a fixed cost, then updated like every later solve: Clarabel's data scaling
            # depends on the cost it was built with, and repeated solves must agree bitwise
            solver = self._clarabel.DefaultSolver(
                self._zero,
                np.ones(problem.size),
                self._cone_matrix(problem),
                self._offset_b(stack),
                self._cones,
                self._settings,
            )
            self.setup_time = time.perf_counter() - started
        else:
            solver = entry[1]
        solver.update(q=problem.objective)
        solvers[id(stack)] = (stack, solver)  # most recent last
        if len(solvers) > KEPT_SOLVERS:
            del solvers[next(iter(solvers))]
        result = solver.solve()
        z = np.asarray(result.z, dtype=float)
        multipliers = np.add.reduceat(z * self._z_weights, self._z_starts)
        return (
            np.asarray(result.x, dtype=float),
            multipliers,
            f"clarabel: {result.status}",
            int(result.iterations),
        )

    def _run_elastic(self, problem: ReducedProblem) -> BackendAnswer:
        """(y, multipliers, status, iterations) of the quadratic problem of a mechanism with
        stiffness: H changes with the load (it is the elastic energy over the load's scale), so
        the solver is built for each solve."""
        started = time.perf_counter()
        stack = problem.stack
        upper = self._sparse.triu(self._sparse.csc_matrix(problem.hessian), format="csc")
        cones = self._cone_matrix(problem) if stack.count else None
        solver = self._clarabel.DefaultSolver(
            upper,
            np.asarray(problem.objective, dtype=float),
            cones if cones is not None else self._sparse.csc_matrix((0, problem.size)),
            self._offset_b(stack) if stack.count else np.zeros(0),
            self._cones,
            self._settings,
        )
        self.setup_time = time.perf_counter() - started
        result = solver.solve()
        z = np.asarray(result.z, dtype=float)
        multipliers = (
            np.add.reduceat(z * self._z_weights, self._z_starts) if stack.count else np.zeros(0)
        )
        return (
            np.asarray(result.x, dtype=float),
            multipliers,
            f"clarabel: {result.status}",
            int(result.iterations),
        )

    def _offset_b(self, stack: StackedContacts) -> np.ndarray:
        """b with the eccentricities o: (1, o_j) for a cone, (1 - o_j, 1 + o_j) for a slab."""
        if not stack.offset.any():
            return self._b
        b = self._b.copy()
        for j, start in enumerate(self._z_starts):
            first = stack.starts[j]
            if stack.is_norm[j]:
                k = (stack.starts[j + 1] if j + 1 < stack.count else stack.matrix.shape[0]) - first
                b[start + 1 : start + 1 + k] = stack.offset[first : first + k]
            else:
                b[start] -= stack.offset[first]
                b[start + 1] += stack.offset[first]
        return b

    def _cone_matrix(self, problem: ReducedProblem) -> Any:  # a SciPy sparse matrix
        blocks = []
        for contact, matrix in zip(problem.contacts, problem.contact_matrices):
            if contact.contact.shape == "norm":
                blocks.append(np.vstack([np.zeros((1, problem.size)), -matrix]))
            else:
                blocks.append(np.vstack([matrix, -matrix]))
        return self._sparse.csc_matrix(np.vstack(blocks))


# a built backend, and what its run returns: (y, multipliers, status, iterations)
Backend = IpoptBackend | ClarabelBackend


def backend_for(
    problem: ReducedProblem,
    backend: str,
    tol: float,
    signature: Signature | None,
    kept: MutableMapping[tuple[str, Signature, float], Backend],
) -> tuple[Backend, bool]:
    """The built backend for this problem's ``signature`` (``problem.signature()`` when None),
    kept in ``kept`` (the mechanism's :attr:`~.cache.SolveCache.backends`), and whether it was
    built now."""
    if backend not in BACKENDS:
        raise ArgumentError("backend", f"one of {', '.join(BACKENDS)}", backend)
    if backend == "auto":
        backend = "clarabel" if clarabel_available() else "ipopt"
    signature = problem.signature() if signature is None else signature
    if problem.hessian is not None and len(signature) == 2:
        signature = (*signature, True)  # a quadratic objective: IPOPT takes H as a parameter
    key = (backend, signature, tol)
    built = kept.get(key)
    if built is not None:
        return built, False
    built = ClarabelBackend(key[1], tol) if backend == "clarabel" else IpoptBackend(key[1], tol)
    kept[key] = built
    return built, True


def acceptance(conditioning: float) -> float:
    """KKT residual accepted: round-off grows as 1 / conditioning (a ConditioningWarning says so)."""
    return max(ACCEPT_KKT, 1e-16 / max(conditioning, 1e-300))


def solve_cone(problem: ReducedProblem, backend: Backend) -> ConeSolution:
    """Solve ``problem`` by the backend from the nominal position, then the active-set Newton
    polish (the answer verified at round-off, or returned unpolished with its residuals)."""
    started = time.perf_counter()
    stack = problem.stack
    accept = acceptance(problem.conditioning)
    if problem.hessian is not None:
        return _elastic_solution(problem, backend, accept, started)
    y, lam, status, iterations = backend.run(problem)
    setup_time = getattr(backend, "setup_time", 0.0)
    signs = stack.sides(y)
    phi = stack.values(y, None)
    verified = active_set_solve(stack, problem.objective, y, lam, signs, accept=accept)
    if verified is None:
        # a contact the backend left barely open (a load component of 1e-7 pressing it) may
        # belong to the set: start again with every nearly touching contact in it
        nearly = np.where(phi > -NEARLY_TOUCHING, np.maximum(lam, 1e-12), lam)
        verified = active_set_solve(stack, problem.objective, y, nearly, signs, accept=accept)
    if verified is not None:
        y, lam, signs, measured = verified
        return ConeSolution(
            y,
            lam,
            signs,
            status,
            iterations,
            True,
            measured,
            time.perf_counter() - started,
            setup_time,
            backend_method(backend.name),
        )
    lam = np.where(phi > -ACTIVE_GAP, lam, 0.0)
    measured = residuals(stack, problem.objective, y, lam, signs)
    return ConeSolution(
        y,
        lam,
        signs,
        status,
        iterations,
        False,
        measured,
        time.perf_counter() - started,
        setup_time,
        backend_method(backend.name),
    )


def _elastic_solution(
    problem: ReducedProblem, backend: Backend, accept: float, started: float
) -> ConeSolution:
    """The backend's answer of a problem with stiffness, polished by :mod:`.elastic_newton`
    (verified at round-off) or returned unpolished with its measured residuals; both on the
    problem rescaled by its curvature (:func:`.elastic_newton.curvature_scaled`), the residuals
    measured there, y mapped back."""
    problem, transform = curvature_scaled(problem)
    y, lam, status, iterations = backend.run(problem)
    setup_time = getattr(backend, "setup_time", 0.0)
    stack = problem.stack
    hessian = problem.hessian
    assert hessian is not None  # a problem with stiffness (curvature_scaled keeps its H)
    verified = polish_elastic(stack, problem.objective, hessian, y, lam, accept)
    if verified is not None:
        y, lam, signs, measured = verified
        polished = True
    else:
        signs = stack.sides(y) if stack.count else np.zeros(0)
        phi = stack.values(y, None) if stack.count else np.zeros(0)
        lam = np.where(phi > -ACTIVE_GAP, lam, 0.0)
        measured = elastic_residuals(stack, problem.objective, hessian, y, lam, signs)
        polished = False
    return ConeSolution(
        y if transform is None else transform @ y,
        lam,
        signs,
        status,
        iterations,
        polished,
        measured,
        time.perf_counter() - started,
        setup_time,
        backend_method(backend.name),
    )
