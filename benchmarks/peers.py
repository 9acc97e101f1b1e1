r"""Peers: the shaft problem of Younes, Dal Santo & Potiron written directly, as a user would.

Each peer solves the 12-variable problem of docs/method.md section 2 for a shaft held on the ground by
two joints in parallel (the cases of [Y] section 6), in the paper's units (mm, N, N mm, rad):

.. math::
    \min_{T_1, T_2}\ -(F\cdot U_B + C\cdot\Omega_1) \quad \text{s.t.}\quad
    \Omega_2 = \Omega_1,\ V_2 = V_1 + \Omega_1\times \vec{O_1O_2},\ \text{clearance sets},

with :math:`T_k = (u, v, w, \alpha, \beta, \gamma)` the shaft's small-displacement torsor at joint
k, :math:`U_B = V_1 + \Omega_1\times\vec{O_1B}`, and the clearance sets (radial clearance c = J/2):

- spherical: :math:`\|V_k\| \le c_k`;
- cylindrical (axis x, length L): :math:`(v + \gamma L/2)^2 + (w - \beta L/2)^2 \le c^2` and
  :math:`(v - \gamma L/2)^2 + (w + \beta L/2)^2 \le c^2`.

The spin about the shaft axis :math:`\vec{O_1O_2}` is free; it is fixed at zero
(:math:`\Omega_1\cdot e = 0`), and so is the axial slide :math:`u_1` when both joints are
cylindrical: that picks the minimum-norm optimum that clearance_pin reports.

Peers (one function or class each, the same signature: a load in, a :class:`PeerSolution` out):

- :func:`solve_slsqp`: ``scipy.optimize.minimize(method="SLSQP")`` with analytic gradients (the
  paper used SQP); the clearance sets as smooth quadratic inequalities.
- :func:`solve_cvxpy`: CVXPY with the Clarabel solver, the problem re-built for every load.
- :class:`CvxpyParametric`: CVXPY built once with the load as ``cp.Parameter`` (DPP re-use).
- :func:`solve_clarabel`: Clarabel called directly, the second-order-cone data built per solve.
- :class:`ClarabelPrebuilt`: the peer an expert writes: Clarabel built once per shaft (data,
  cones, symbolic factorisation) and re-solved for each new load after ``solver.update(q=...)``,
  at Clarabel's default settings or at tight tolerances.

For the arms, whose problem is not a shaft, :class:`ReducedClarabel` is the same prebuilt peer on
the reduced cone programme clearance_pin itself solves (read through
``clearance_pin.equilibrium.prepared``), so that both solve the same numbers.

Source: M. Younes, P. Dal Santo, A. Potiron, "Three-dimensional study for the relative
positioning of mechanical elements in mechanisms constituted by parallel joints with clearances",
section 6.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

MM = 1e3


@dataclass(frozen=True)
class ShaftJoint:
    """One joint of a shaft case, paper units: kind, centre [mm], radial clearance c [mm], L [mm]."""

    kind: str
    center: tuple[float, float, float]
    radial: float
    length: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in ("spherical", "cylindrical"):
            raise ValueError(f"peer shafts take spherical or cylindrical joints, got {self.kind!r}")
        if not self.radial > 0.0:
            raise ValueError(f"radial clearance must be > 0 mm, got {self.radial}")
        if self.kind == "cylindrical" and not self.length > 0.0:
            raise ValueError(f"a cylindrical joint needs a length L > 0 mm, got {self.length}")


@dataclass(frozen=True)
class Shaft:
    """A shaft on two joints (axes along x) and the point B where the force acts [mm].

    Attributes:
        joints: joint 1 (where T1 is written) and joint 2.
        point: B [mm], world.
    """

    joints: tuple[ShaftJoint, ShaftJoint]
    point: tuple[float, float, float]

    @classmethod
    def from_case(cls, case: dict) -> Shaft:
        """From a case of validation/younes2013_cases.toml (SI inputs)."""
        joints = []
        for joint in case["joint"]:
            axis = np.asarray(joint.get("axis", (1.0, 0.0, 0.0)), dtype=float)
            if not np.allclose(axis, [1.0, 0.0, 0.0]):
                raise ValueError(f"case {case['id']}: peers assume joint axes along x, got {axis}")
            joints.append(
                ShaftJoint(
                    joint["kind"],
                    tuple(MM * np.asarray(joint["center_m"])),
                    MM * joint["diametral_clearance_m"] / 2.0,
                    MM * joint.get("length_m", 0.0),
                )
            )
        return cls(tuple(joints), tuple(MM * np.asarray(case["load"]["point_m"])))

    @property
    def span(self) -> np.ndarray:
        """O1O2 [mm], (3,)."""
        return np.subtract(self.joints[1].center, self.joints[0].center)

    @property
    def lever(self) -> np.ndarray:
        """O1B [mm], (3,)."""
        return np.subtract(self.point, self.joints[0].center)

    def gauge_rows(self) -> np.ndarray:
        """Rows G (g, 12) of the gauge G x = 0: spin about O1O2, and u1 for two cylinders."""
        rows = []
        spin = np.zeros(12)
        spin[3:6] = self.span / np.linalg.norm(self.span)
        rows.append(spin)
        if all(j.kind == "cylindrical" for j in self.joints):
            slide = np.zeros(12)
            slide[0] = 1.0
            rows.append(slide)
        return np.array(rows)

    def transport_rows(self) -> np.ndarray:
        """Rows A (6, 12) of A x = 0: Omega2 - Omega1 = 0, V2 - V1 + [O1O2]x Omega1 = 0."""
        rows = np.zeros((6, 12))
        rows[0:3, 6:9] = np.eye(3)
        rows[0:3, 0:3] = -np.eye(3)
        rows[0:3, 3:6] = skew(self.span)  # Omega x d = -[d]x Omega
        rows[3:6, 9:12] = np.eye(3)
        rows[3:6, 3:6] = -np.eye(3)
        return rows

    def cones(self) -> list[tuple[float, np.ndarray]]:
        """Clearance sets as (c [mm], M (k, 12)) with ||M x|| <= c."""
        sets = []
        for k, joint in enumerate(self.joints):
            offset = 6 * k
            if joint.kind == "spherical":
                rows = np.zeros((3, 12))
                rows[:, offset : offset + 3] = np.eye(3)
                sets.append((joint.radial, rows))
                continue
            half = joint.length / 2.0
            for side in (1.0, -1.0):  # end at x = +L/2, then -L/2
                rows = np.zeros((2, 12))
                rows[0, offset + 1] = 1.0  # v
                rows[0, offset + 5] = side * half  # + gamma L/2
                rows[1, offset + 2] = 1.0  # w
                rows[1, offset + 4] = -side * half  # - beta L/2
                sets.append((joint.radial, rows))
        return sets

    def objective(self, force, torque) -> np.ndarray:
        """Gradient q (12,) of the potential -(F . U_B + C . Omega1) [N mm per unit]."""
        force = np.asarray(force, dtype=float)
        q = np.zeros(12)
        q[0:3] = -force
        q[3:6] = -(np.cross(self.lever, force) + np.asarray(torque, dtype=float))
        return q


def skew(vector) -> np.ndarray:
    """[a]x such that [a]x b = a x b, (3, 3)."""
    a = np.asarray(vector, dtype=float)
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


@dataclass
class PeerSolution:
    """What a peer returns: T1 and T2 [mm, rad] and the solver's own word."""

    t1: np.ndarray
    t2: np.ndarray
    status: str
    iterations: int
    success: bool


def _split(x: np.ndarray, status: str, iterations: int, success: bool) -> PeerSolution:
    x = np.asarray(x, dtype=float).ravel()
    return PeerSolution(x[0:6].copy(), x[6:12].copy(), status, int(iterations), bool(success))


# -- scipy SLSQP -------------------------------------------------------------------------------
def solve_slsqp(
    shaft: Shaft, force, torque, ftol: float = 1e-12, maxiter: int = 500
) -> PeerSolution:
    """SLSQP from the nominal position x = 0, analytic gradients, quadratic clearance constraints."""
    from scipy.optimize import minimize

    q = shaft.objective(force, torque)
    equalities = np.vstack([shaft.transport_rows(), shaft.gauge_rows()])
    constraints = [{"type": "eq", "fun": lambda x: equalities @ x, "jac": lambda x: equalities}]
    for radius, rows in shaft.cones():
        constraints.append(
            {
                "type": "ineq",
                "fun": lambda x, r=radius, m=rows: r * r - float((m @ x) @ (m @ x)),
                "jac": lambda x, m=rows: -2.0 * (m @ x) @ m,
            }
        )
    result = minimize(
        lambda x: float(q @ x),
        np.zeros(12),
        jac=lambda x: q,
        method="SLSQP",
        constraints=constraints,
        options={"ftol": ftol, "maxiter": maxiter},
    )
    return _split(result.x, f"slsqp: {result.message}", result.nit, result.success)


# -- CVXPY + Clarabel --------------------------------------------------------------------------
def clarabel_settings(tol: float) -> dict:
    """Clarabel tolerances set together (gap abs/rel, feasibility, KKT ratio) [dimensionless]."""
    return {
        "tol_gap_abs": tol,
        "tol_gap_rel": tol,
        "tol_feas": tol,
        "tol_ktratio": tol,
        "max_iter": 200,
    }


def _cvxpy_problem(shaft: Shaft, force, torque):
    """The problem written with T1, T2 as CVXPY variables (constants or parameters as loads)."""
    import cvxpy as cp

    t1, t2 = cp.Variable(6, name="T1"), cp.Variable(6, name="T2")
    v1, omega = t1[0:3], t1[3:6]
    constraints = [t2[3:6] == omega, t2[0:3] == v1 - skew(shaft.span) @ omega]
    for joint, torsor in zip(shaft.joints, (t1, t2)):
        if joint.kind == "spherical":
            constraints.append(cp.norm(torsor[0:3]) <= joint.radial)
        else:
            half = joint.length / 2.0
            v, w, beta, gamma = torsor[1], torsor[2], torsor[4], torsor[5]
            constraints.append(
                cp.norm(cp.hstack([v + gamma * half, w - beta * half])) <= joint.radial
            )
            constraints.append(
                cp.norm(cp.hstack([v - gamma * half, w + beta * half])) <= joint.radial
            )
    axis = shaft.span / np.linalg.norm(shaft.span)
    constraints.append(axis @ omega == 0)
    if all(j.kind == "cylindrical" for j in shaft.joints):
        constraints.append(t1[0] == 0)
    displacement_b = v1 - skew(shaft.lever) @ omega  # V1 + Omega x O1B
    problem = cp.Problem(cp.Minimize(-(force @ displacement_b + torque @ omega)), constraints)
    return problem, t1, t2


def solve_cvxpy(shaft: Shaft, force, torque, tol: float = 1e-10) -> PeerSolution:
    """CVXPY + Clarabel, the problem built from scratch for this load (what a script does)."""
    import cvxpy as cp

    problem, t1, t2 = _cvxpy_problem(shaft, np.asarray(force, float), np.asarray(torque, float))
    problem.solve(solver=cp.CLARABEL, **clarabel_settings(tol))
    x = np.concatenate([_value(t1), _value(t2)])
    stats = problem.solver_stats
    return _split(
        x,
        f"cvxpy: {problem.status}",
        stats.num_iters or 0,
        problem.status in ("optimal", "optimal_inaccurate"),
    )


class CvxpyParametric:
    """CVXPY + Clarabel built once with the force and torque as parameters (DPP re-use)."""

    def __init__(self, shaft: Shaft, tol: float = 1e-10):
        import cvxpy as cp

        self._cp = cp
        self.force, self.torque = cp.Parameter(3, name="F"), cp.Parameter(3, name="C")
        self.problem, self.t1, self.t2 = _cvxpy_problem(shaft, self.force, self.torque)
        if not self.problem.is_dpp():
            raise RuntimeError("the parametric shaft problem is not DPP")
        self.settings = clarabel_settings(tol)

    def solve(self, force, torque) -> PeerSolution:
        self.force.value = np.asarray(force, dtype=float)
        self.torque.value = np.asarray(torque, dtype=float)
        self.problem.solve(solver=self._cp.CLARABEL, **self.settings)
        x = np.concatenate([_value(self.t1), _value(self.t2)])
        stats = self.problem.solver_stats
        return _split(
            x,
            f"cvxpy: {self.problem.status}",
            stats.num_iters or 0,
            self.problem.status in ("optimal", "optimal_inaccurate"),
        )


def _value(variable) -> np.ndarray:
    return np.full(variable.shape, np.nan) if variable.value is None else variable.value


# -- Clarabel directly -------------------------------------------------------------------------
def _clarabel_solver_settings(tol: float | None):
    """Clarabel settings: its defaults (``tol=None``) or :func:`clarabel_settings` ``(tol)``."""
    import clarabel

    settings = clarabel.DefaultSettings()
    settings.verbose = False
    if tol is not None:
        for name, value in clarabel_settings(tol).items():
            setattr(settings, name, value)
    return settings


def _shaft_cone_data(shaft: Shaft):
    """(A, b, cones) of the shaft problem: zero cone for the equalities, one SOC per set."""
    import clarabel

    equalities = np.vstack([shaft.transport_rows(), shaft.gauge_rows()])
    blocks, b = [equalities], [np.zeros(equalities.shape[0])]
    cones = [clarabel.ZeroConeT(equalities.shape[0])]
    for radius, rows in shaft.cones():
        blocks.append(np.vstack([np.zeros((1, 12)), -rows]))
        b.append(np.concatenate([[radius], np.zeros(rows.shape[0])]))
        cones.append(clarabel.SecondOrderConeT(rows.shape[0] + 1))
    return np.vstack(blocks), np.concatenate(b), cones


def solve_clarabel(shaft: Shaft, force, torque, tol: float = 1e-10) -> PeerSolution:
    r"""Clarabel on :math:`\min q^T x` s.t. :math:`A x + s = b`, s in {0}^m x SOC x ... (built now).

    Equalities (transport and gauge) go to the zero cone; each clearance set
    :math:`\|M x\| \le c` is :math:`s = (c, M x)` in a second-order cone: rows ``[0; -M]``,
    ``b = [c; 0]``.
    """
    import clarabel
    from scipy import sparse

    matrix, b, cones = _shaft_cone_data(shaft)
    solver = clarabel.DefaultSolver(
        sparse.csc_matrix((12, 12)),
        shaft.objective(force, torque),
        sparse.csc_matrix(matrix),
        b,
        cones,
        _clarabel_solver_settings(tol),
    )
    result = solver.solve()
    status = str(result.status)
    return _split(
        np.asarray(result.x),
        f"clarabel: {status}",
        result.iterations,
        status in ("Solved", "AlmostSolved"),
    )


class ClarabelPrebuilt:
    """Clarabel built once for a shaft, re-solved per load with ``solver.update(q=...)``.

    The constraint data (A, b, cones) of :func:`solve_clarabel` do not depend on the load; only the
    linear cost q does. The solver is built once with the cost of ``load`` (the case's own load:
    Clarabel's equilibration reads the data it is built with) and each :meth:`solve` updates q
    and solves, re-using the data, the equilibration and the symbolic factorisation.

    Args:
        shaft: the case.
        load: (F [N], C [N mm]) the solver is built with.
        tol: None for Clarabel's default settings (gap 1e-8, feasibility 1e-8, KKT ratio 1e-6),
            else every tolerance set to ``tol`` (:func:`clarabel_settings`).
    """

    def __init__(self, shaft: Shaft, load, tol: float | None = None):
        import clarabel
        from scipy import sparse

        self.shaft = shaft
        matrix, b, cones = _shaft_cone_data(shaft)
        self.solver = clarabel.DefaultSolver(
            sparse.csc_matrix((12, 12)),
            shaft.objective(*load),
            sparse.csc_matrix(matrix),
            b,
            cones,
            _clarabel_solver_settings(tol),
        )
        if not self.solver.is_data_update_allowed():
            raise RuntimeError("Clarabel refuses data updates for the shaft problem")

    def solve(self, force, torque) -> PeerSolution:
        self.solver.update(q=self.shaft.objective(force, torque))
        result = self.solver.solve()
        status = str(result.status)
        return _split(
            np.asarray(result.x),
            f"clarabel: {status}",
            result.iterations,
            status in ("Solved", "AlmostSolved"),
        )


class QocoPrebuilt:
    r"""QOCO built once for a shaft, re-solved per load with ``update_vector_data(c=...)``.

    QOCO's standard form: :math:`\min c^T x` s.t. :math:`A x = b`, :math:`G x + s = h`, s in a
    product of second-order cones: the equalities (transport and gauge) are A, b; each clearance
    set :math:`\|M x\| \le c` is a cone with rows ``G = [0; -M]``, ``h = [c; 0]`` (the data of
    :func:`solve_clarabel`). Built with the case's own load; QOCO's default tolerances are 1e-7
    (``tol`` sets its absolute and relative gap and feasibility tolerances).
    """

    def __init__(self, shaft: Shaft, load, tol: float | None = None):
        import qoco
        from scipy import sparse

        self.shaft = shaft
        equalities = np.vstack([shaft.transport_rows(), shaft.gauge_rows()])
        rows, h, sizes = [], [], []
        for radius, matrix in shaft.cones():
            rows.append(np.vstack([np.zeros((1, 12)), -matrix]))
            h.append(np.concatenate([[radius], np.zeros(matrix.shape[0])]))
            sizes.append(matrix.shape[0] + 1)
        g, h_vector = np.vstack(rows), np.concatenate(h)
        settings = {"verbose": 0}
        if tol is not None:
            settings.update(abstol=tol, reltol=tol)
        self.solver = qoco.QOCO()
        self.solver.setup(
            12, g.shape[0], equalities.shape[0], None, shaft.objective(*load),
            sparse.csc_matrix(equalities), np.zeros(equalities.shape[0]),
            sparse.csc_matrix(g), h_vector, 0, len(sizes), np.array(sizes, dtype=np.int32),
            **settings,
        )  # fmt: skip

    def solve(self, force, torque) -> PeerSolution:
        self.solver.update_vector_data(c=self.shaft.objective(force, torque))
        result = self.solver.solve()
        status = str(result.status)
        return _split(np.asarray(result.x), f"qoco: {status}", result.iters,
                      "SOLVED" in status.upper())  # fmt: skip


def qoco_available() -> bool:
    """Whether QOCO is installed (``pip install qoco``, the ``peers`` extra)."""
    try:
        import qoco  # noqa: F401
    except ImportError:
        return False
    return True


class ReducedClarabel:
    r"""Clarabel prebuilt on clearance_pin's reduced cone programme, updated per load.

    The reduced problem (``clearance_pin.equilibrium.prepared.prepared_geometry(mechanism, q)
    .problem(loads)``) is :math:`\min f^T y` s.t. :math:`\|P_j y + o_j\| \le 1` (ball, disc: a
    second-order cone on :math:`(1, P_j y + o_j)`) or :math:`|p_j^T y + o_j| \le 1` (slab: two
    non-negative rows). Its constraint data are those of ``problem.stack`` (``matrix``,
    ``offset``, ``starts``, ``is_norm``); they are the same for every load, and for a mechanism
    without loops for every configuration too. The solver is built on the first problem and each
    :meth:`solve` updates the cost (and rebuilds only when the constraint data change, counted in
    ``rebuilds``).

    Args:
        tol: None for Clarabel's default settings, else every tolerance set to ``tol``.
    """

    def __init__(self, tol: float | None = None):
        self.tol = tol
        self.solver = None
        self._stack = None
        self._matrix = None
        self._offset = None
        self.rebuilds = 0

    @staticmethod
    def cone_data(stack):
        """(A, b, cones) of a reduced problem's stacked contacts."""
        import clarabel

        blocks, b, cones = [], [], []
        rows = stack.matrix.shape[0]
        ends = [*stack.starts[1:], rows]
        for start, end, is_norm in zip(stack.starts, ends, stack.is_norm):
            matrix, offset = stack.matrix[start:end], stack.offset[start:end]
            if is_norm:
                blocks.append(np.vstack([np.zeros((1, stack.size)), -matrix]))
                b.extend([1.0, *offset])
                cones.append(clarabel.SecondOrderConeT(end - start + 1))
            else:
                blocks.append(np.vstack([matrix, -matrix]))
                b.extend([1.0 - offset[0], 1.0 + offset[0]])
                cones.append(clarabel.NonnegativeConeT(2))
        return np.vstack(blocks), np.array(b), cones

    def solve(self, problem) -> tuple[np.ndarray, str, bool]:
        """(y, status, success) of one reduced problem."""
        import clarabel
        from scipy import sparse

        stack = problem.stack
        same = self.solver is not None and (
            stack is self._stack
            or (
                self._matrix.shape == stack.matrix.shape
                and np.array_equal(self._matrix, stack.matrix)
                and np.array_equal(self._offset, stack.offset)
            )
        )
        if not same:
            matrix, b, cones = self.cone_data(stack)
            self.solver = clarabel.DefaultSolver(
                sparse.csc_matrix((problem.size, problem.size)),
                problem.objective,
                sparse.csc_matrix(matrix),
                b,
                cones,
                _clarabel_solver_settings(self.tol),
            )
            self._stack, self._matrix, self._offset = stack, stack.matrix, stack.offset
            self.rebuilds += 1
        else:
            self.solver.update(q=problem.objective)
        result = self.solver.solve()
        status = str(result.status)
        return np.asarray(result.x), f"clarabel: {status}", status in ("Solved", "AlmostSolved")


PEERS = {
    "scipy_slsqp": "scipy.optimize.minimize(method='SLSQP'), analytic gradients, from x = 0",
    "cvxpy_clarabel": "CVXPY + Clarabel, the problem re-built for every load",
    "cvxpy_clarabel_param": "CVXPY + Clarabel, built once, load as cp.Parameter (DPP)",
    "clarabel_direct": "Clarabel called directly, SOC data built per solve",
    "clarabel_prebuilt": "Clarabel built once per case, solver.update(q=...) per load, "
    "tolerances swept (headline 1e-12)",
    "clarabel_prebuilt_default": "Clarabel built once per case, solver.update(q=...) per load, "
    "Clarabel's default settings",
}

__all__ = [
    "Shaft",
    "ShaftJoint",
    "PeerSolution",
    "solve_slsqp",
    "solve_cvxpy",
    "CvxpyParametric",
    "solve_clarabel",
    "ClarabelPrebuilt",
    "ReducedClarabel",
    "clarabel_settings",
    "skew",
    "PEERS",
]
