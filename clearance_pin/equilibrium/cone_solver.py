r"""Solve the reduced cone programme: IPOPT through CasADi, then an active-set Newton polish.

Problem (see :mod:`.reduction`), dimensionless:

.. math::  \min_y f^T y \quad \text{s.t.} \quad \phi_j(y) \le 0,\qquad
           \phi_j = \|P_j y\|^2 - 1 \ (\text{ball, disc}),\quad \phi_j = |P_j y| - 1 \ (\text{slab})

IPOPT (interior point) finds the optimum and the contact set; the polish then solves the KKT
system of the active contacts,

.. math::  f + \sum_{j \in A} \lambda_j \nabla\phi_j(y) = 0, \qquad \phi_j(y) = 0 \ (j \in A)

by Newton's method to machine precision, and is accepted only if every multiplier is >= 0 and every
contact is feasible. The built IPOPT problem takes f and the P_j as parameters, so a new load,
clearance or nominal configuration re-uses it (one build per problem signature).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from .reduction import ReducedProblem

ACTIVE_GAP = 1e-6
POLISH_TOL = 1e-14


@dataclass
class ConeSolution:
    """Solution of the reduced problem with its own measured residuals (dimensionless).

    Attributes:
        y: reduced unknowns, (r,).
        multipliers: lambda_j >= 0 per contact (scaled by the objective scale).
        signs: +1/-1 for the side of a slab contact in touch (1 for balls and discs).
        status: IPOPT's return status (or ``"newton"`` when the warm active-set step sufficed).
        iterations: IPOPT iterations (0 for the Newton path).
        polished: the active-set Newton polish was accepted.
        stationarity, feasibility, complementarity, dual_infeasibility: max-norm residuals.
        solve_time: wall time [s] of this solve.
    """

    y: np.ndarray
    multipliers: np.ndarray
    signs: np.ndarray
    status: str
    iterations: int
    polished: bool
    stationarity: float = 0.0
    feasibility: float = 0.0
    complementarity: float = 0.0
    dual_infeasibility: float = 0.0
    solve_time: float = 0.0
    extra: dict = field(default_factory=dict)

    @property
    def kkt_residual(self) -> float:
        """Largest of the four residuals."""
        return max(self.stationarity, self.feasibility, self.complementarity, self.dual_infeasibility)


class ConeSolver:
    """IPOPT solver of reduced problems with one signature (built once, solved many times)."""

    def __init__(self, signature: tuple, tol: float = 1e-12, max_iter: int = 200):
        self.signature = signature
        size, shapes = signature
        started = time.perf_counter()
        y = ca.SX.sym("y", size)
        f = ca.SX.sym("f", size)
        total_rows = sum(k for _, k in shapes)
        p_matrix = ca.SX.sym("P", total_rows, size)
        constraints, lower, upper = [], [], []
        row = 0
        for shape, k in shapes:
            image = ca.mtimes(p_matrix[row:row + k, :], y)
            row += k
            if shape == "norm":
                constraints.append(ca.sumsqr(image))
                lower.append(-ca.inf)
            else:
                constraints.append(image)
                lower.append(-1.0)
            upper.append(1.0)
        nlp = {"x": y, "p": ca.vertcat(f, ca.vec(p_matrix)), "f": ca.dot(f, y),
               "g": ca.vertcat(*constraints) if constraints else ca.SX(0, 1)}
        options = {
            "print_time": False,
            "ipopt.print_level": 0,
            "ipopt.sb": "yes",
            "ipopt.tol": tol,
            "ipopt.acceptable_tol": tol,
            "ipopt.bound_relax_factor": 0.0,
            "ipopt.max_iter": max_iter,
            "ipopt.mu_strategy": "adaptive",
        }
        self._solver = ca.nlpsol("clearance_cone", "ipopt", nlp, options)
        self._lower = np.array(lower, dtype=float)
        self._upper = np.array(upper, dtype=float)
        self.build_time = time.perf_counter() - started

    def solve(self, problem: ReducedProblem, y0: np.ndarray | None = None,
              warm: ConeSolution | None = None) -> ConeSolution:
        """Solve the problem; IPOPT from ``y0`` (default: the nominal y = 0), then polish.

        With ``warm`` (a previous solution of a problem with the same signature), first try the
        active-set Newton step from its contact set and multipliers; it is accepted only when its
        multipliers are >= 0, every contact is feasible and the KKT residual is at round-off.
        Otherwise IPOPT runs as usual.
        """
        started = time.perf_counter()
        if warm is not None and warm.y.shape == (problem.size,):
            seed = ConeSolution(warm.y, warm.multipliers, warm.signs, "warm active-set Newton",
                                0, False)
            candidate = polish(problem, seed)
            if candidate is not None:
                candidate.solve_time = time.perf_counter() - started
                return candidate
        parameters = np.concatenate(
            [problem.objective] + [m.ravel(order="F") for m in _stacked(problem)]
        )
        start = np.zeros(problem.size) if y0 is None else np.asarray(y0, dtype=float)
        result = self._solver(x0=start, p=parameters, lbg=self._lower, ubg=self._upper)
        stats = self._solver.stats()
        y = np.asarray(result["x"], dtype=float).ravel()
        lam_g = np.asarray(result["lam_g"], dtype=float).ravel()
        signs = np.where(lam_g < 0.0, -1.0, 1.0)
        shapes = [c.contact.shape for c in problem.contacts]
        for j, shape in enumerate(shapes):
            if shape == "abs" and abs(lam_g[j]) == 0.0:
                signs[j] = 1.0 if (problem.contact_matrices[j] @ y)[0] >= 0.0 else -1.0
        solution = ConeSolution(
            y, np.abs(lam_g), signs, stats["return_status"], int(stats.get("iter_count", 0)), False
        )
        polished = polish(problem, solution)
        final = polished if polished is not None else solution
        measure(problem, final)
        final.solve_time = time.perf_counter() - started
        return final


def _stacked(problem: ReducedProblem) -> list[np.ndarray]:
    if not problem.contact_matrices:
        return [np.zeros((0, problem.size))]
    return [np.vstack(problem.contact_matrices)]


def constraint_values(problem: ReducedProblem, y: np.ndarray) -> np.ndarray:
    """phi_j(y) for every contact (<= 0 when feasible, 0 in contact)."""
    values = []
    for contact, matrix in zip(problem.contacts, problem.contact_matrices):
        image = matrix @ y
        values.append(image @ image - 1.0 if contact.contact.shape == "norm" else abs(image[0]) - 1.0)
    return np.array(values)


def constraint_gradients(problem: ReducedProblem, y: np.ndarray, signs: np.ndarray) -> np.ndarray:
    """Gradients of phi_j (rows), (m, r); slabs use the side in ``signs``."""
    rows = []
    for j, (contact, matrix) in enumerate(zip(problem.contacts, problem.contact_matrices)):
        if contact.contact.shape == "norm":
            rows.append(2.0 * matrix.T @ (matrix @ y))
        else:
            rows.append(signs[j] * matrix[0])
    return np.array(rows).reshape(-1, problem.size)


def measure(problem: ReducedProblem, solution: ConeSolution) -> None:
    """Fill the residuals of ``solution`` from the problem data (not from the solver's report)."""
    phi = constraint_values(problem, solution.y)
    gradients = constraint_gradients(problem, solution.y, solution.signs)
    stationary = problem.objective + gradients.T @ solution.multipliers
    solution.stationarity = float(np.max(np.abs(stationary), initial=0.0))
    solution.feasibility = float(np.max(phi, initial=0.0))
    solution.complementarity = float(np.max(np.abs(solution.multipliers * phi), initial=0.0))
    solution.dual_infeasibility = float(max(0.0, -np.min(solution.multipliers, initial=0.0)))


def polish(problem: ReducedProblem, start: ConeSolution, rounds: int = 4) -> ConeSolution | None:
    """Active-set Newton on the KKT system from ``start``; None if it cannot be verified."""
    phi = constraint_values(problem, start.y)
    largest = max(1.0, float(np.max(start.multipliers, initial=0.0)))
    active = np.flatnonzero((phi > -ACTIVE_GAP) | (start.multipliers > 1e-9 * largest))
    y, lam, signs = start.y.copy(), start.multipliers.copy(), start.signs.copy()
    for _ in range(rounds):
        y_new, lam_active = _newton(problem, y, lam[active], signs, active)
        if y_new is None:
            return None
        lam_new = np.zeros_like(lam)
        lam_new[active] = lam_active
        negative = active[lam_active < -1e-12]
        if negative.size:
            active = np.setdiff1d(active, negative)
            continue
        phi_new = constraint_values(problem, y_new)
        violated = np.flatnonzero(phi_new > 1e-13)
        if violated.size:
            active = np.union1d(active, violated)
            continue
        candidate = ConeSolution(y_new, np.maximum(lam_new, 0.0), signs, start.status,
                                 start.iterations, True)
        measure(problem, candidate)
        if candidate.kkt_residual <= 1e-10:
            return candidate
        return None
    return None


def _newton(problem, y, lam_active, signs, active, iterations: int = 30):
    matrices = problem.contact_matrices
    is_norm = [problem.contacts[j].contact.shape == "norm" for j in active]
    y, lam = y.copy(), lam_active.copy()
    size, count = problem.size, len(active)
    for _ in range(iterations):
        gradients = constraint_gradients(problem, y, signs)[active] if count else np.zeros((0, size))
        phi = constraint_values(problem, y)[active] if count else np.zeros(0)
        residual = np.concatenate([problem.objective + gradients.T @ lam, phi])
        if np.max(np.abs(residual), initial=0.0) < POLISH_TOL:
            return y, lam
        hessian = np.zeros((size, size))
        for lam_j, j, norm in zip(lam, active, is_norm):
            if norm:
                hessian += 2.0 * lam_j * matrices[j].T @ matrices[j]
        kkt = np.block([[hessian, gradients.T], [gradients, np.zeros((count, count))]])
        step = np.linalg.lstsq(kkt, -residual, rcond=None)[0]
        if not np.all(np.isfinite(step)):
            return None, None
        y += step[:size]
        lam += step[size:]
    final = np.concatenate([problem.objective + constraint_gradients(problem, y, signs)[active].T @ lam,
                            constraint_values(problem, y)[active]])
    if np.max(np.abs(final), initial=0.0) < 1e-11:
        return y, lam
    return None, None


_CACHE: dict[tuple, ConeSolver] = {}


def solver_for(problem: ReducedProblem, tol: float = 1e-12) -> tuple[ConeSolver, bool]:
    """The built solver for this problem's signature, and whether it was built now."""
    key = (problem.signature(), tol)
    if key in _CACHE:
        return _CACHE[key], False
    solver = ConeSolver(problem.signature(), tol=tol)
    _CACHE[key] = solver
    return solver, True
