r"""The exact finite-displacement equilibrium (docs/method.md section 4).

Each tree joint k moves its child by the finite rigid motion
:math:`\Delta_k = C_k \exp(\widehat{B_k t_k}) C_k^{-1}` (SE(3) exponential of the torsor in the
clearance frame :math:`C_k`), composed along the tree by the CasADi mirror of Pinocchio's forward
kinematics. A loop joint reads the true relative placement :math:`(R, p)` of its two clearance
frames. The contact conditions of :mod:`clearance_pin.model.clearance` are written on the true
positions of the contact points, :math:`d = p + R r - r`; rigid loop components are
:math:`p_i = 0`, and :math:`(R e_x)_{y,z} = 0` or :math:`\mathrm{vee}((R - R^T)/2) = 0` for
rotations. The potential is the exact work of the loads (:mod:`.load_terms`).

The same unknowns as the linear model are used, so the linear solution is the warm start, and the
motions that no contact sees are fixed by the same gauge (minimum-norm in the linear sense).
The difference from the linear model is of second order (rotation x displacement).
"""

from __future__ import annotations

import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import casadi as ca
import numpy as np
import numpy.typing as npt
import pinocchio as pin

from ..errors import SolverError, UnboundedLoadError, UnsupportedError, motions_listed_once
from ..kinematics.casadi_kinematics import CasadiKinematics
from ..kinematics.lie_casadi import Placement, compose, inverse, rotation_vee_antisym, se3_exp
from ..model.clearance import ALPHA, BETA, GAMMA
from ..model.couplings import passive
from ..model.joints import LoopJoint, TreeJoint
from ..model.stiffness import elastic
from ..numerics import Array, Mask, null_space
from . import ipopt
from .contact_split import least_norm_split
from .kkt import ACCEPT_KKT
from .load_terms import BodyLoad
from .method import Method
from .outputs import OutputPoint, output_displacements, resolve_outputs
from .prepared import linear_setup, statics_weights
from .reactions import frames_at
from .reduction import ReducedProblem
from .residuals import STATICS_TOLERANCE, Residuals
from .result import Contact, Equilibrium
from .small_displacement import tree_joint_basis

if TYPE_CHECKING:  # the mechanism module imports this one
    from ..model.loads import Load
    from ..model.mechanism_parts import ConfigurationParts as Configuration
    from ..model.mechanism_parts import MechanismParts as Mechanism


@dataclass(frozen=True)
class ExactParts:
    """The exact model evaluated at (z, lambda): gradient of the scaled potential (n,),
    constraints g (m,), their Jacobian (m, n), Hessian of the Lagrangian (n, n), potential [J],
    loop equations (all, redundant ones included), and the poses: (3, 4) [R | p] of every body,
    then of every joint's relative placement (tree joints, then loop joints)."""

    gradient: np.ndarray
    g: np.ndarray
    jacobian: np.ndarray
    hessian: np.ndarray
    energy: float
    closure: np.ndarray
    poses: list[Array]


# a verified answer of the Newton polish: (z, multipliers, the model evaluated there)
Polished = tuple[Array, Array, ExactParts]


class ExactProblem:
    """The exact NLP of one mechanism structure, built once (parameters: q, loads, clearances)."""

    def __init__(
        self,
        mechanism: Mechanism,
        linear_problem: ReducedProblem,
        equality_rows: tuple[int, ...],
        tol: float,
    ) -> None:
        started = time.perf_counter()
        model = mechanism.model
        self.mechanism = mechanism
        n = linear_problem.gradient.size
        self.n = n
        kin = CasadiKinematics(model)
        z = ca.SX.sym("z", n)
        q = ca.SX.sym("q", model.nq)
        scale = ca.SX.sym("scale", n)
        x = scale * z
        nbody = model.njoints
        load_params = ca.SX.sym("loads", 15, nbody)
        loops = mechanism.loop_joints
        loop_a = ca.SX.sym("loop_a", 12, max(len(loops), 1))  # aMc: [R | p] per loop joint
        loop_b = ca.SX.sym("loop_b", 12, max(len(loops), 1))  # bMc
        contacts = [
            (name, point)
            for name, joint in mechanism.joints.items()
            for point in joint.clearance.contacts
            if point.bound > 0.0
        ]
        bounds = ca.SX.sym("bounds", len(contacts))
        gauge_count = linear_problem.free_motions.shape[1]
        gauge = ca.SX.sym("gauge", n, gauge_count)
        sigma = ca.SX.sym("sigma")

        # relative: each joint's play motion, what its contacts and loop conditions read; a
        # joint with stiffness moves by its play then its spring, exp(B t) exp(D e) (the spring
        # on the child's side), its energy 1/2 sum k_i e_i^2 (docs/method.md section 2.2.2)
        deltas, relative, turns, offset = {}, {}, {}, 0
        motions = {}  # per tree joint, its own motion's exp coordinate (a coupling reads it)
        spring_energy = ca.SX(0)
        springs = 0
        for joint in mechanism.tree_joints:
            basis = tree_joint_basis(joint)
            k = basis.shape[1]
            if joint.motion_component is not None and k:
                along = basis[joint.motion_component]
                if np.count_nonzero(along) == 1 and along.max() == 1.0:
                    motions[joint.name] = x[offset + int(np.argmax(along))]
            torsor = ca.mtimes(ca.DM(basis), x[offset : offset + k]) if k else ca.SX.zeros(6)
            offset += k
            R_t, p_t = se3_exp(torsor)
            relative[joint.name] = (R_t, p_t)
            turns[joint.name] = torsor[3:6]  # exp coordinates: R_t's rotation vector
            directions, stiffnesses = elastic(joint.clearance)
            if stiffnesses.size:
                e = x[offset : offset + stiffnesses.size]
                offset += stiffnesses.size
                springs += stiffnesses.size
                spring_energy += 0.5 * ca.dot(ca.DM(stiffnesses), e * e)
                R_t, p_t = compose((R_t, p_t), se3_exp(ca.mtimes(ca.DM(directions), e)))
            C = ca.DM(joint.rotation)
            deltas[joint.joint_id] = (ca.mtimes([C, R_t, C.T]), ca.mtimes(C, p_t))
        nominal = kin.joint_placements(q)
        placed = kin.joint_placements(q, deltas)
        for index, loop in enumerate(loops):
            C_a = (ca.reshape(loop_a[0:9, index], 3, 3), loop_a[9:12, index])
            C_b = (ca.reshape(loop_b[0:9, index], 3, 3), loop_b[9:12, index])
            oMa = compose(kin.frame_placement(placed, loop.frame_a), C_a)
            oMb = compose(kin.frame_placement(placed, loop.frame_b), C_b)
            relative[loop.name] = compose(inverse(oMa), oMb)
            directions, stiffnesses = elastic(loop.clearance)
            if stiffnesses.size:
                e = x[offset : offset + stiffnesses.size]
                offset += stiffnesses.size
                springs += stiffnesses.size
                spring_energy += 0.5 * ca.dot(ca.DM(stiffnesses), e * e)
                unsprung = se3_exp(-ca.mtimes(ca.DM(directions), e))
                relative[loop.name] = compose(relative[loop.name], unsprung)

        self.springs = springs  # elastic unknowns: the potential has curvature of its own
        energy = spring_energy
        for body in range(1, nbody):
            params = load_params[:, body]
            R, t = placed[body]
            R0, t0 = nominal[body]
            force, moment, torque = params[0:3], ca.reshape(params[3:12], 3, 3), params[12:15]
            energy -= ca.dot(force, t - t0)
            energy -= ca.dot(ca.vec(moment), ca.vec(R - R0))
            energy -= ca.dot(torque, rotation_vee_antisym(ca.mtimes(R, R0.T)))

        inequality = []
        for j, (name, point) in enumerate(contacts):
            R, p = relative[name]
            r = ca.DM(point.point)
            d = point.lever * turns[name] if point.lever else p + ca.mtimes(R, r) - r
            selected = ca.vertcat(*[d[c] for c in point.components])
            if point.shape == "norm":
                inequality.append(ca.sumsqr(selected) / bounds[j] ** 2)
            else:
                inequality.append(selected / bounds[j])
        equality = _loop_equalities(mechanism, relative)
        for coupling in passive(mechanism.couplings, mechanism.joints):  # after the loops'
            leader = motions[coupling.leader]
            equality.append(motions[coupling.follower] - coupling.multiplier * leader)
        kept = [equality[i] for i in equality_rows]
        constraints = ca.vertcat(*inequality, *kept, ca.mtimes(gauge.T, z))
        self.shapes = [point.shape for _, point in contacts]
        self.contacts = contacts
        self.n_equality = len(kept) + gauge_count
        self.gauge_count = gauge_count
        parameters = ca.vertcat(
            q,
            scale,
            ca.vec(load_params),
            ca.vec(loop_a),
            ca.vec(loop_b),
            bounds,
            ca.vec(gauge),
            sigma,
        )
        self.parameter_sizes = (
            model.nq,
            n,
            15 * nbody,
            12 * max(len(loops), 1),
            12 * max(len(loops), 1),
            len(contacts),
            n * gauge_count,
            1,
        )
        nlp = {"x": z, "p": parameters, "f": energy / sigma, "g": constraints}
        options: dict[str, Any] = {
            "print_time": False,
            "ipopt.print_level": 0,
            "ipopt.sb": "yes",
            "ipopt.tol": tol,
            "ipopt.acceptable_tol": 1e3 * tol,
            "ipopt.acceptable_iter": 5,
            "ipopt.max_iter": 300,
            "ipopt.bound_relax_factor": 0.0,
            "ipopt.mu_strategy": "adaptive",
        }
        self.solver = ipopt.build("clearance_exact", "ipopt", nlp, options)
        lower = [-ca.inf if s == "norm" else -1.0 for s in self.shapes] + [0.0] * self.n_equality
        upper = [1.0] * len(self.shapes) + [0.0] * self.n_equality
        self.lower, self.upper = np.array(lower), np.array(upper)
        poses = [ca.horzcat(R, p) for R, p in placed] + [
            ca.horzcat(*relative[name]) for name in mechanism.joints
        ]
        multipliers = ca.SX.sym("lam", constraints.shape[0])
        lagrangian = energy / sigma + ca.dot(multipliers, constraints)
        closure = ca.vertcat(*equality) if equality else ca.SX.zeros(1)
        parts = [
            ca.gradient(energy / sigma, z),
            constraints,
            ca.jacobian(constraints, z),
            ca.hessian(lagrangian, z)[0],
            energy,
            closure,
            *poses,
        ]
        # one function, one flat output: a CasADi call and its conversion cost more than the
        # evaluation itself on problems of this size
        self._part_shapes = [part.shape for part in parts]
        self._all_parts = ca.Function(
            "exact_kkt_parts", [z, parameters, multipliers], [ca.vertcat(*map(ca.vec, parts))]
        )
        self._pose_count = len(poses)
        self.build_time = time.perf_counter() - started

    def evaluate(self, z: np.ndarray, params: ca.DM, lam: np.ndarray) -> ExactParts:
        """Everything the Newton step and the answer need at (z, lambda), from one CasADi call."""
        flat = self._all_parts(z, params, lam).full().ravel()  # params: a ca.DM, converted once
        arrays, offset = [], 0
        for rows, columns in self._part_shapes:
            arrays.append(flat[offset : offset + rows * columns].reshape(rows, columns, order="F"))
            offset += rows * columns
        gradient, g, jacobian, hessian, energy, closure = arrays[:6]
        return ExactParts(
            gradient.ravel(),
            g.ravel(),
            jacobian,
            hessian,
            float(energy[0, 0]),
            closure.ravel(),
            arrays[6:],
        )

    def parameters(
        self,
        configuration: Configuration,
        scale: Array,
        body_loads: Mapping[int, BodyLoad],
        linear_problem: ReducedProblem,
        sigma: float,
    ) -> Array:
        """Numeric parameter vector for one solve."""
        model = self.mechanism.model
        loads = np.zeros((15, model.njoints))
        for body, load in body_loads.items():
            loads[0:3, body] = load.force
            loads[3:12, body] = load.moment_matrix.ravel(order="F")
            loads[12:15, body] = load.torque
        sides = np.zeros((2, 12, max(len(self.mechanism.loop_joints), 1)))
        for index, loop in enumerate(self.mechanism.loop_joints):
            for side, placement in enumerate((configuration.aMc, configuration.bMc)):
                sides[side, 0:9, index] = placement[loop.name].rotation.ravel(order="F")
                sides[side, 9:12, index] = placement[loop.name].translation
        bounds = np.array([point.bound for _, point in self.contacts])
        gauge = linear_problem.free_motions / scale[:, None]
        if gauge.size:
            gauge = gauge / np.linalg.norm(gauge, axis=0)
            # one row per coordinate where the free motions are coordinates (a spin, a slide), so
            # that each can be released alone (solve_exact_model)
            support = np.flatnonzero(np.linalg.norm(gauge, axis=1) > 1e-12)
            if support.size == gauge.shape[1]:
                gauge = np.eye(gauge.shape[0])[:, support]
        return np.concatenate(
            [
                configuration.q,
                scale,
                loads.ravel(order="F"),
                sides[0].ravel(order="F"),
                sides[1].ravel(order="F"),
                bounds,
                gauge.ravel(order="F"),
                [sigma],
            ]
        )


def _loop_equalities(mechanism: Mechanism, relative: Mapping[str, Placement]) -> list[ca.SX]:
    """Rigid conditions of loop joints, in the order of the linear model's equality rows."""
    rows = []
    for loop in mechanism.loop_joints:
        R, p = relative[loop.name]
        rigid = loop.clearance.rigid_components
        rotations = {c for c in rigid if c >= ALPHA}
        for component in rigid:
            if component < ALPHA:
                rows.append(p[component])
        if rotations == {BETA, GAMMA}:
            rows.extend([-R[2, 0], R[1, 0]])
        elif rotations == {ALPHA, BETA, GAMMA}:
            vee = rotation_vee_antisym(R)
            rows.extend([vee[0], vee[1], vee[2]])
        elif rotations:
            raise UnsupportedError(
                f"loop joint {loop.name!r}: rigid rotations {sorted(rotations)} "
                "have no exact form; use beta+gamma or all three"
            )
        for point in loop.clearance.contacts:
            if point.bound == 0.0:
                r = ca.DM(point.point)
                d = p + ca.mtimes(R, r) - r
                rows.extend(d[c] for c in point.components)
    return rows


def independent_rows(equalities: np.ndarray, scale: np.ndarray) -> tuple[int, ...]:
    """Indices of a maximal independent subset of the rows of E Z (redundant closure dropped)."""
    kept: list[int] = []
    for i in range(equalities.shape[0]):
        trial = equalities[[*kept, i]] * scale
        if np.linalg.matrix_rank(trial, tol=1e-10 * max(1.0, np.abs(trial).max())) == len(kept) + 1:
            kept.append(i)
    return tuple(kept)


def solve_exact_model(
    mechanism: Mechanism,
    loads: Sequence[Load],
    q: npt.ArrayLike | None,
    linear: Equilibrium,
    tol: float,
    from_nominal: bool = False,
) -> Equilibrium:
    """Solve the exact model from the linear equilibrium ``linear``; residuals measured.

    ``from_nominal``: ``linear`` is an answer that did not verify near a singular position of the
    closure (:class:`~clearance_pin.errors.NearSingularError`), no start: IPOPT starts from the
    nominal position and no contact (``linear`` is still reported as the answer's ``.linear``)."""
    points = linear.output_points or resolve_outputs(mechanism, linear.loads or ())
    if linear.status == "indeterminate":  # nothing moves: the exact answer is the nominal one
        unmoved = replace(linear, formulation="exact", linear=linear, output_points=points)
        return replace(unmoved, difference=_difference(unmoved, linear, points))
    configuration, _maps, body_loads, problem = linear_setup(mechanism, loads, q)
    rows = independent_rows(problem.equalities, problem.scale)
    key = ("exact", problem.signature(), problem.free_motions.shape[1], rows, tol)
    problems = mechanism.cache.exact_problems
    exact = problems.get(key)
    built_now = exact is None
    if built_now:
        exact = problems[key] = ExactProblem(mechanism, problem, rows, tol)
    sigma = problem.objective_scale or 1.0
    params = ca.DM(exact.parameters(configuration, problem.scale, body_loads, problem, sigma))
    x_linear = np.concatenate(
        [_coordinates(linear, joint) for joint in mechanism.tree_joints]
        + [_spring_coordinates(linear, loop) for loop in mechanism.loop_joints]
    )
    z0 = np.zeros_like(x_linear) if from_nominal else x_linear / problem.scale
    solve_started = time.perf_counter()
    # the exact answer is a second-order correction of the linear one, on the same contacts:
    # Newton on the exact KKT system of those contacts first, IPOPT only if it is not verified
    levers = [point.lever for _, point in exact.contacts]
    at_upper, at_lower, start = _linear_start(linear, exact.shapes, sigma, levers)
    lam0 = np.zeros(exact.lower.size)
    lam0[: start.size] = start
    steps: list[int] = []
    polished = (
        None
        if from_nominal
        else polish_exact(exact, z0, lam0, params, at_upper, at_lower, steps=steps)
    )
    method = Method.EXACT_NEWTON
    if polished is not None:
        z, lam, parts = polished
        stats = {"return_status": "Newton from the linear solution", "iter_count": steps[0]}
    else:
        method = Method.EXACT_IPOPT
        result, stats = ipopt.run(exact.solver, x0=z0, p=params, lbg=exact.lower, ubg=exact.upper)
        z = np.asarray(result["x"], dtype=float).ravel()
        lam = np.asarray(result["lam_g"], dtype=float).ravel()
        polished = polish_exact(exact, z, lam, params)
        if polished is not None:
            z, lam, parts = polished
            stats["return_status"] = f"ipopt: {stats['return_status']}, Newton-polished"
        else:
            parts = exact.evaluate(z, params, lam)
    if polished is not None:
        # a valley of equilibria (the exact potential flat along motions that keep the active
        # contacts) is left where the path reached it: take the point nearest the linear answer
        z, lam, parts = _nearest_on_flat_directions(exact, z0, z, lam, parts, params)
    equilibrium = _assemble(
        mechanism, exact, problem, configuration, z, lam, parts, sigma, stats, polished is not None
    )
    if equilibrium.residuals["held_by_gauge"] > STATICS_TOLERANCE:
        # at the solved pose the load works on a motion the linear answer left free (the spin of
        # a shaft whose axis the play tilted): let that motion settle too, if it does nearby
        settled = _settle_free_motions(exact, problem, z, lam, parts, params)
        if settled is not None:
            z, lam, parts = settled
            polished = settled
            stats = {"return_status": f"{stats['return_status']}, free motions settled"}
            equilibrium = _assemble(
                mechanism, exact, problem, configuration, z, lam, parts, sigma, stats, True
            )
    equilibrium = replace(
        equilibrium,
        method=method,
        polished=polished is not None,
        build_time=exact.build_time if built_now else 0.0,
        solve_time=time.perf_counter() - solve_started,
        linear=linear,
        loads=tuple(loads),
        output_points=points,
    )
    equilibrium = replace(equilibrium, difference=_difference(equilibrium, linear, points))
    held = equilibrium.residuals["held_by_gauge"]
    if held > STATICS_TOLERANCE:
        rotation = max(
            (float(np.linalg.norm(t[3:])) for t in equilibrium.torsors.values()), default=0.0
        )
        if held > HELD_SHARE * max(rotation, 1e-9):
            raise UnboundedLoadError(
                list(problem.free_descriptions),
                held,
                "which works on them at the exact model's solved pose (not in the linear model) "
                "without settling nearby",
            )
        note = (
            f"exact: {held:.2g} of the load works, at the solved pose, along the motions the "
            "linear model leaves free (a torque on a part whose free spin the play has tilted) "
            "and they do not settle nearby; they are held where the linear answer puts them, as a "
            "drive or the least friction would (reported as the reactions' 'held' part)"
        )
        equilibrium = replace(equilibrium, note=note)
        # no contact carries that share: the answer is no equilibrium of the mechanism, and
        # where the gauge holds the motion is a convention, not the mechanism's (issue 21)
        raise SolverError(
            f"no exact equilibrium: {held:.2g} of the load works, at the exact model's solved "
            "pose, along motions the linear model leaves free ("
            + motions_listed_once(problem.free_descriptions)
            + "), which do not settle nearby; only the gauge holds that share (no contact "
            "carries it, and where the gauge holds the motion is a convention, not the "
            "mechanism's). Lock those motions (a drive, an ideal joint) or use the "
            "small-displacement answer (exact=False); the held answer is the error's .answer",
            str(stats["return_status"]),
            equilibrium.residuals,
            equilibrium,
        )
    if not equilibrium.ok:
        raise SolverError(
            "the exact solve did not reach a verified optimum",
            str(stats["return_status"]),
            equilibrium.residuals,
            equilibrium,
        )
    return equilibrium


def _linear_start(
    linear: Equilibrium, shapes: list[str], sigma: float, levers: list[float]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r"""The linear solution's contact set and multipliers as the exact model's starting point.

    Contacts are in the same order in both models. A loaded ball or disc, or a slab pushed on its
    + side, is active at its upper bound; a slab pushed on its - side (the parent pushes the child
    towards +) at its lower bound. Multipliers from the forces, both models' constraints being
    :math:`\|d\|^2 / c^2 \le 1` or :math:`-1 \le d / c \le 1` on the potential over sigma:
    :math:`\lambda = |f| c / (2 \sigma)` (ball, disc), :math:`\pm |f| c / \sigma` (slab).

    A backlash stop (``levers``: its lever [m], 0 for a point) counts its moment over its lever.

    Returns:
        (at upper bound (m,), at lower bound (m,), multipliers (m,)).
    """
    upper, lower, multipliers = [], [], []
    for contact, shape, lever in zip(linear.contacts, shapes, levers):
        force = contact.force if contact.moment is None else contact.moment / lever
        size = float(np.linalg.norm(force))
        loaded = contact.active and size > 0.0
        minus_side = loaded and shape != "norm" and float(force.sum()) > 0.0
        upper.append(loaded and not minus_side)
        lower.append(minus_side)
        if shape == "norm":
            multipliers.append(size * contact.clearance / (2.0 * sigma))
        else:
            multipliers.append((-1.0 if minus_side else 1.0) * size * contact.clearance / sigma)
    return np.array(upper, dtype=bool), np.array(lower, dtype=bool), np.array(multipliers)


def polish_exact(
    exact: ExactProblem,
    z: Array,
    lam: Array,
    params: ca.DM,
    at_upper: Mask | None = None,
    at_lower: Mask | None = None,
    iterations: int = 12,
    released: Mask | None = None,
    steps: list[int] | None = None,
) -> Polished | None:
    r"""Active-set Newton on the exact KKT system from a nearby point; None unless verified
    (``steps``: the Newton steps taken are appended to it).

    Active: the equalities, and the contact constraints ``at_upper`` / ``at_lower`` (default:
    those within 1e-6 of their bound or carrying a multiplier, from IPOPT's answer). The gauge
    rows (the last ``exact.gauge_count`` equalities) marked in ``released`` (bool, (gauges,)) are
    left out: those motions nothing blocks settle where the load holds them at the solved pose.
    Solves :math:`\nabla f + J_A^T \lambda_A = 0`, :math:`g_A = b_A` with the exact
    Lagrangian Hessian, then accepts only if every contact multiplier pushes (>= 0 in the sense of
    its bound), every other contact is feasible, and the residual is at round-off.
    """
    n_in = len(exact.shapes)
    lower, upper = exact.lower, exact.upper
    if at_upper is None:
        g = exact.evaluate(z, params, lam).g
        largest = max(1.0, float(np.max(np.abs(lam[:n_in]), initial=0.0)))
        at_upper = (np.abs(g[:n_in] - upper[:n_in]) < 1e-6) | (lam[:n_in] > 1e-9 * largest)
        at_lower = np.isfinite(lower[:n_in]) & (
            (np.abs(g[:n_in] - lower[:n_in]) < 1e-6) | (lam[:n_in] < -1e-9 * largest)
        )
    assert at_lower is not None  # given with at_upper
    if not (np.any(at_upper) or np.any(at_lower) or exact.springs):
        return None  # nothing touches and nothing curves the potential: no Newton system
    equalities = np.arange(n_in, lower.size)
    if released is not None:
        gauge_rows = equalities[equalities.size - exact.gauge_count :]
        lam = lam.copy()
        lam[gauge_rows[released]] = 0.0
        equalities = np.setdiff1d(equalities, gauge_rows[released])
    active = np.concatenate([np.flatnonzero(at_upper | at_lower), equalities])
    target = np.where(at_lower, lower[:n_in], upper[:n_in])
    targets = np.concatenate([target, np.zeros(lower.size - n_in)])[active]
    z, lam = z.copy(), lam.copy()
    n = z.size
    previous = np.inf
    best: tuple[float, tuple[np.ndarray, np.ndarray, ExactParts] | None] = (np.inf, None)
    taken = 0
    for _ in range(iterations):
        parts = exact.evaluate(z, params, lam)
        j_active = parts.jacobian[active]
        residual = np.concatenate(
            [parts.gradient + j_active.T @ lam[active], parts.g[active] - targets]
        )
        size = np.abs(residual).max()
        if size < best[0]:
            best = (size, (z.copy(), lam.copy(), parts))
        # converged, or at the round-off floor of the exact model's evaluation (a Newton step no
        # longer gains a digit, or followed a residual below 1e-7, so that quadratic convergence
        # left only round-off: the best point is kept), within the linear model's bound
        if size < 1e-14 or (size <= ACCEPT_KKT and (size > 0.1 * previous or previous < 1e-7)):
            break
        previous = size
        kkt = np.block(
            [[parts.hessian, j_active.T], [j_active, np.zeros((active.size, active.size))]]
        )
        step = np.linalg.lstsq(kkt, -residual, rcond=None)[0]
        z += step[:n]
        lam[active] += step[n:]
        taken += 1
    if steps is not None:
        steps.append(taken)
    if best[0] > ACCEPT_KKT or best[1] is None:
        return None
    z, lam, parts = best[1]
    g = parts.g
    inactive = np.setdiff1d(np.arange(n_in), active)
    lam[inactive] = 0.0
    pushes = np.all(lam[:n_in][at_upper] >= -1e-12) and np.all(lam[:n_in][at_lower] <= 1e-12)
    # the exact constraints carry round-off of eps |r| / c (a contact point far from its joint's
    # origin against a small play): the same bound as the KKT residual
    feasible = np.all(g[:n_in] <= upper[:n_in] + ACCEPT_KKT) and np.all(
        g[:n_in] >= lower[:n_in] - ACCEPT_KKT
    )
    return (z, lam, parts) if (feasible and pushes) else None


FLAT_CURVATURE = 1e-9  # of the largest Hessian entry: a direction of no curvature
FLAT_ROUNDS = 6


def _flat_directions(exact: ExactProblem, lam: Array, parts: ExactParts) -> Array:
    r"""Directions (n, k) along which the exact answer is not isolated: they keep the loaded
    contacts and the equalities (null space N of their Jacobian) and the Lagrangian has no
    curvature along them (eigenvectors of :math:`N^T \nabla^2 L\, N` with eigenvalues within
    :data:`FLAT_CURVATURE` of the largest Hessian entry)."""
    n_in = len(exact.shapes)
    rows = np.concatenate([np.flatnonzero(lam[:n_in] != 0.0), np.arange(n_in, exact.lower.size)])
    keep = null_space(parts.jacobian[rows]) if rows.size else np.eye(parts.gradient.size)
    if not keep.shape[1]:
        return keep
    reduced = keep.T @ parts.hessian @ keep
    values, vectors = np.linalg.eigh(0.5 * (reduced + reduced.T))
    size = max(1.0, float(np.abs(parts.hessian).max()))
    flat: Array = keep @ vectors[:, np.abs(values) <= FLAT_CURVATURE * size]
    return flat


def _nearest_on_flat_directions(
    exact: ExactProblem, z0: Array, z: Array, lam: Array, parts: ExactParts, params: ca.DM
) -> Polished:
    r"""The verified answer moved along its flat directions (:func:`_flat_directions`) towards
    the linear answer ``z0``: :math:`z + N N^T (z_0 - z)`, then the Newton polish on the same
    contacts, repeated while it moves (at most :data:`FLAT_ROUNDS` times). Where the potential
    is flat the answer depends on the path (IPOPT's barrier ends anywhere along the valley; the
    Newton steps from z0 near its start): this is the point of the valley nearest z0, the same
    for every backend. The answer given when no move verifies."""
    n_in = len(exact.shapes)
    for _ in range(FLAT_ROUNDS):
        flat = _flat_directions(exact, lam, parts)
        if not flat.shape[1]:
            break
        shift = flat @ (flat.T @ (z0 - z))
        if np.linalg.norm(shift) <= 1e-12 * max(1.0, float(np.linalg.norm(z))):
            break
        upper = lam[:n_in] > 0.0
        lower = np.isfinite(exact.lower[:n_in]) & (lam[:n_in] < 0.0)
        moved = polish_exact(exact, z + shift, lam, params, upper, lower)
        if moved is None:
            break
        z, lam, parts = moved
    return z, lam, parts


NEARBY_ROTATION = 0.1  # [rad] a motion that settles further than this is no settling in the play
# a share of the load along a free motion at the solved pose may be held at the gauge when it is of
# second order: at most this many times the largest joint rotation of the answer [per rad]
HELD_SHARE = 10.0


def _settle_free_motions(
    exact: ExactProblem,
    problem: ReducedProblem,
    z: Array,
    lam: Array,
    parts: ExactParts,
    params: ca.DM,
) -> Polished | None:
    """Release the gauge rows the load pulls on at the solved pose (all of them, else each alone,
    most pulled first) and keep the first answer that settles nearby (:func:`_settles_nearby`);
    None when none does."""
    pull = np.abs(lam[lam.size - exact.gauge_count :])
    pulled = pull > STATICS_TOLERANCE * max(float(np.linalg.norm(parts.gradient)), 1e-300)
    trials = [pulled]
    if pulled.sum() > 1:
        for row in np.argsort(-pull)[: int(pulled.sum())]:
            trials.append(np.arange(pull.size) == row)
    for released in trials:
        answer = polish_exact(exact, z, lam, params, released=released)
        if answer is not None and _settles_nearby(exact, problem, *answer):
            return answer
    return None


def _settles_nearby(
    exact: ExactProblem, problem: ReducedProblem, z: Array, lam: Array, parts: ExactParts
) -> bool:
    r"""The released answer is a stable equilibrium near the nominal pose: the Hessian of the
    Lagrangian is positive semi-definite on the motions that keep the active constraints
    (:math:`N^T \nabla^2 L\, N \succeq 0`, to 1e-9 of its size), no joint turns by more than
    :data:`NEARBY_ROTATION` and none slides by more than ten times the largest scale of the
    unknowns (a dead couple along a tilted free spin turns the part a quarter turn: that is no
    equilibrium in the play)."""
    n_in = len(exact.shapes)
    gauge_rows = np.arange(exact.lower.size - exact.gauge_count, exact.lower.size)
    kept_gauges = gauge_rows[lam[gauge_rows] != 0.0]
    rows = np.concatenate(
        [
            np.flatnonzero(lam[:n_in] != 0.0),
            np.arange(n_in, exact.lower.size - exact.gauge_count),
            kept_gauges,
        ]
    )
    keep = null_space(parts.jacobian[rows]) if rows.size else np.eye(z.size)
    if keep.shape[1]:
        reduced = keep.T @ parts.hessian @ keep
        size = max(1.0, float(np.abs(parts.hessian).max()))
        if np.linalg.eigvalsh(0.5 * (reduced + reduced.T)).min() < -1e-9 * size:
            return False
    relative = parts.poses[len(parts.poses) - len(exact.mechanism.joints) :]
    reach = 10.0 * float(problem.scale.max(initial=0.0))
    return all(
        np.linalg.norm(pin.log3(M[:, :3])) <= NEARBY_ROTATION and np.linalg.norm(M[:, 3]) <= reach
        for M in relative
    )


def _coordinates(linear: Equilibrium, joint: TreeJoint) -> Array:
    """A tree joint's unknowns in the linear answer: its play's, then its spring's (if any)."""
    deflection = linear.deflection(joint.name)
    play = tree_joint_basis(joint).T @ (linear.torsors[joint.name] - deflection)
    return np.concatenate([play, _spring_coordinates(linear, joint)])


def _spring_coordinates(linear: Equilibrium, joint: TreeJoint | LoopJoint) -> Array:
    """A joint's spring unknowns e in the linear answer, D^T (its deflection); none if rigid."""
    directions, _ = elastic(joint.clearance)
    spring: Array = directions.T @ linear.deflection(joint.name)
    return spring


def _statics(
    mechanism: Mechanism,
    problem: ReducedProblem,
    sigma: float,
    gradient: Array,
    contact_part: Array,
    held_rows: Array,
) -> float:
    r"""The statics residual of the exact answer, measured like the linear model's
    (:meth:`.prepared.PreparedGeometry.statics_residual`): what the loads (``gradient``, the
    potential's over sigma in the scaled unknowns z) and the contact forces (``contact_part``)
    leave unbalanced, weighed W / Z (forces and moments in N whatever the joint's play), less
    what the loops' rigid conditions and the gauge rows hold (``held_rows``; the gauge's share is
    ``held_by_gauge``), over the larger of the weighed load and the load size."""
    weights = statics_weights(problem.scale, problem.translational, mechanism.length_scale())
    factor = weights / problem.scale
    weighted = factor * (gradient + contact_part)
    if held_rows.size:
        rows = (held_rows * factor).T
        weighted = weighted - rows @ np.linalg.lstsq(rows, weighted, rcond=None)[0]
    reference = max(float(np.linalg.norm(factor * gradient)), problem.load_size / sigma)
    return float(np.linalg.norm(weighted) / reference) if reference > 0.0 else 0.0


def _assemble(
    mechanism: Mechanism,
    exact: ExactProblem,
    problem: ReducedProblem,
    configuration: Configuration,
    z: Array,
    lam: Array,
    parts: ExactParts,
    sigma: float,
    stats: Mapping[str, Any],
    polished_multipliers: bool = False,
) -> Equilibrium:
    model = mechanism.model
    placed = parts.poses[: model.njoints]
    relatives = dict(zip(mechanism.joints, parts.poses[model.njoints :]))
    torsors, deflections = {}, {}
    x = problem.scale * z
    offset = 0
    for joint in mechanism.tree_joints:
        basis = tree_joint_basis(joint)
        torsors[joint.name] = basis @ x[offset : offset + basis.shape[1]]
        offset += basis.shape[1]
        directions, stiffnesses = elastic(joint.clearance)
        if stiffnesses.size:  # the play then the spring: exp(B t) exp(D e)
            spring = directions @ x[offset : offset + stiffnesses.size]
            offset += stiffnesses.size
            moved = pin.exp6(pin.Motion(torsors[joint.name])) * pin.exp6(pin.Motion(spring))
            torsors[joint.name] = np.array(pin.log6(moved).vector)
            deflections[joint.name] = spring
    for loop in mechanism.loop_joints:
        M = relatives[loop.name]  # its play
        placement = pin.SE3(M[:, :3], M[:, 3])
        directions, stiffnesses = elastic(loop.clearance)
        if stiffnesses.size:  # the parts' relative motion: the play then the spring
            spring = directions @ x[offset : offset + stiffnesses.size]
            offset += stiffnesses.size
            placement = placement * pin.exp6(pin.Motion(spring))
            deflections[loop.name] = spring
        # the child's motion from its nominal place (a misaligned housing's eccentricity E),
        # at the child's clearance frame like the linear torsor: relative = E * motion
        motion = configuration.eccentricity(loop).actInv(placement)
        torsors[loop.name] = np.array(pin.log6(motion).vector)
    body_motions = {}
    for i in range(1, model.njoints):
        R, t = placed[i][:, :3], placed[i][:, 3]
        R0, t0 = configuration.oMi[i].rotation, configuration.oMi[i].translation
        body_motions[model.names[i]] = (t - t0, pin.log3(R @ R0.T))
    contacts = []
    sides = frames_at(mechanism, configuration, placed)  # where the contact points are
    n_inequality = len(exact.contacts)
    lam = lam.copy()
    images, gaps = [], []
    for j, (name, point) in enumerate(exact.contacts):
        M = relatives[name]
        d = point.displacement(M[:, :3], M[:, 3])
        gap = point.bound - float(np.linalg.norm(d) if point.shape == "norm" else abs(d[0]))
        if gap > 1e-7 * point.bound and not polished_multipliers:
            lam[j] = 0.0  # interior-point leftovers on free points: no force there
        images.append(d)
        gaps.append(gap)
    loop_rows = parts.jacobian[
        n_inequality : parts.jacobian.shape[0] - problem.free_motions.shape[1]
    ]
    lam[:n_inequality] = _split_multipliers(exact, parts.jacobian, loop_rows, lam, images, gaps,
                                            sigma)  # fmt: skip
    for j, (name, point) in enumerate(exact.contacts):
        M = relatives[name]
        r = np.array(point.point)
        d, gap = images[j], gaps[j]
        multiplier = abs(lam[j])
        if point.shape == "norm":
            local = -2.0 * sigma * multiplier * d / point.bound**2
        else:
            local = np.array([-sigma * multiplier * np.sign(lam[j]) / point.bound])
        force = np.zeros(3)
        force[list(point.components)] = local
        moment = None
        if point.lever:  # a drive's backlash stop: its moment about the axis
            moment, force = point.lever * force, np.zeros(3)
        active = gap <= 1e-7 * point.bound or (polished_multipliers and lam[j] != 0.0)
        contacts.append(
            Contact(
                name,
                point.name,
                gap,
                point.bound,
                force,
                bool(active),
                M[:, :3] @ r + M[:, 3],  # the child's point where it is, parent clearance frame
                sides[name].child.act(r),
                moment,
            )
        )
    scaled_gradient, jacobian, energy = parts.gradient, parts.jacobian, parts.energy
    inequality_jacobian = jacobian[:n_inequality]
    # the loop joints' rigid conditions hold loads; the gauge rows (the last ones) only pick a
    # point along the motions nothing blocks, so a load they would hold is an imbalance
    gauges = problem.free_motions.shape[1]
    loop_jacobian = jacobian[n_inequality : jacobian.shape[0] - gauges]
    residual = scaled_gradient + inequality_jacobian.T @ lam[:n_inequality]
    if loop_jacobian.size:
        nu = np.linalg.lstsq(loop_jacobian.T, -residual, rcond=None)[0]
        residual = residual + loop_jacobian.T @ nu
    held = residual
    if gauges:
        gauge_jacobian = jacobian[jacobian.shape[0] - gauges :]
        both = np.vstack([loop_jacobian, gauge_jacobian])
        held = residual + both.T @ np.linalg.lstsq(both.T, -residual, rcond=None)[0]
    reference = float(np.linalg.norm(scaled_gradient)) or 1.0
    violation = max((max(-c.gap, 0.0) for c in contacts), default=0.0)
    residuals = {
        "stationarity": float(np.max(np.abs(held), initial=0.0)),
        "statics": _statics(
            mechanism,
            problem,
            sigma,
            scaled_gradient,
            inequality_jacobian.T @ lam[:n_inequality],
            jacobian[n_inequality:],
        ),
        # share of the load only the gauge holds: at the solved pose it works along a motion
        # nothing blocks (a free spin axis the play has tilted)
        "held_by_gauge": float(np.linalg.norm(residual - held) / reference),
        "dual_infeasibility": float(
            max(
                0.0,
                -min(
                    [lam[j] if s == "norm" else abs(lam[j]) for j, s in enumerate(exact.shapes)],
                    default=0.0,
                ),
            )
        ),
        "max_violation_m": violation,
        "max_violation_rel": max((max(-c.gap, 0.0) / c.clearance for c in contacts), default=0.0),
        "clearance_m": max((c.clearance for c in contacts), default=0.0),
        "closure": float(np.max(np.abs(parts.closure), initial=0.0)),
    }
    return Equilibrium(
        formulation="exact",
        torsors=torsors,
        body_motions=body_motions,
        contacts=tuple(contacts),
        energy=energy,
        status="optimal",
        method=Method.EXACT_IPOPT
        if "ipopt" in str(stats["return_status"])
        else Method.EXACT_NEWTON,
        solver_status=stats["return_status"],
        iterations=int(stats.get("iter_count", 0)),
        residuals=Residuals.of(residuals),
        free_motions=problem.free_descriptions,
        build_time=0.0,
        solve_time=0.0,
        body_placements=tuple(
            [pin.SE3.Identity()]
            + [pin.SE3(placed[i][:, :3], placed[i][:, 3]) for i in range(1, model.njoints)]
        ),
        mechanism=mechanism,
        configuration=configuration,
        deflections=deflections or None,
    )


def _split_multipliers(
    exact: ExactProblem,
    jacobian: Array,
    loop_rows: Array,
    lam: Array,
    images: Sequence[Array],
    gaps: Sequence[float],
    sigma: float,
) -> Array:
    r"""The contact multipliers with the forces of the touching contacts (gap within 1e-7 of the
    play) split by least norm (:func:`.contact_split.least_norm_split`), as the linear model's
    (:func:`.linear_answer.split_force_rows`): a unit force [N] at contact j is
    :math:`\lambda_j = c_j^2 / (2 \sigma \lVert d_j \rVert)` (ball, disc) or
    :math:`\pm c_j / \sigma` (slab side), its generalised force :math:`J_j^T \lambda_j` less
    what the loops' rigid conditions (``loop_rows``) hold."""
    count = len(exact.contacts)
    lam = lam[:count].copy()
    touching = [j for j in range(count) if gaps[j] <= 1e-7 * exact.contacts[j][1].bound]
    if len(touching) < 2:
        return lam
    per_newton = np.zeros(count)
    magnitudes = np.zeros(count)
    for j in touching:
        point, d = exact.contacts[j][1], images[j]
        if point.shape == "norm":
            size = float(np.linalg.norm(d))
            per_newton[j] = point.bound**2 / (2.0 * sigma * max(size, 1e-300))
        else:
            side = np.sign(lam[j]) if lam[j] != 0.0 else np.sign(d[0])
            per_newton[j] = side * point.bound / sigma
        magnitudes[j] = abs(lam[j]) / abs(per_newton[j]) if per_newton[j] else 0.0
    columns = jacobian[touching].T * per_newton[touching]
    if loop_rows.size:
        columns = columns - loop_rows.T @ np.linalg.lstsq(loop_rows.T, columns, rcond=None)[0]
    given = magnitudes[touching]
    split = least_norm_split(columns, given)
    if split is not given:
        lam[touching] = split * per_newton[touching]
    return lam


def _difference(
    exact: Equilibrium, linear: Equilibrium, points: tuple[OutputPoint, ...]
) -> dict[str, Any]:
    """Exact - linear at the output ``points``: per output (translation (3,) [m], rotation (3,)
    [rad]), world axes, their largest norms, and the largest difference of a joint torsor
    component (see ``Equilibrium.difference``)."""
    moved_exact = output_displacements(exact, points)
    moved_linear = output_displacements(linear, points)
    outputs = {
        name: (moved_exact[name][0] - t, moved_exact[name][1] - r)
        for name, (t, r) in moved_linear.items()
    }
    joints = exact.torsors
    return {
        "translation_m": max((float(np.linalg.norm(t)) for t, _ in outputs.values()), default=0.0),
        "rotation_rad": max((float(np.linalg.norm(r)) for _, r in outputs.values()), default=0.0),
        "outputs": outputs,
        "torsor_translation_m": max(
            (float(np.max(np.abs(joints[k][:3] - linear.torsors[k][:3]))) for k in joints),
            default=0.0,
        ),
        "torsor_rotation_rad": max(
            (float(np.max(np.abs(joints[k][3:] - linear.torsors[k][3:]))) for k in joints),
            default=0.0,
        ),
    }


__all__ = ["ExactProblem", "independent_rows", "solve_exact_model"]
