"""Solve a mechanism's equilibrium: assemble, reduce, optimise, verify, report.

The small-displacement path (:func:`solve_linear`) is the paper's model [Y]; the exact path
(:func:`solve_exact`) re-solves with finite rigid motions from the linear answer.
"""

from __future__ import annotations

import time
import warnings

import numpy as np
import pinocchio as pin

from ..errors import ConditioningWarning, SolverError
from ..numerics import cross
from .cone_solver import backend_for, solve_cone
from .kkt import UNLOADED
from .load_terms import gather_body_loads, load_gradient
from .reduction import ReducedProblem, describe_motion, reduce_geometry, with_load
from .result import Contact, Equilibrium
from .small_displacement import SmallDisplacementMaps, build_maps, null_space

ACTIVE_RELATIVE_GAP = 1e-7
CONDITIONING_WARNING = 1e-6
FINITE_ROTATION = 1e-2  # [rad] a linear answer turning a joint more than this is not small


def linear_setup(mechanism, loads, q):
    """Configuration, maps, per-body loads and reduced problem for one solve.

    Everything but the load terms is cached per nominal configuration, so a new load costs a
    matrix-vector product and the unbounded-load test.
    """
    key = ("geometry", None if q is None else np.asarray(q, dtype=float).tobytes())
    cached = mechanism._solve_state.get(key)
    if cached is None:
        configuration = mechanism.configure(q)
        maps = build_maps(
            mechanism.model, mechanism.data, mechanism.tree_joints, mechanism.loop_joints
        )
        geometry = reduce_geometry(maps, mechanism.joints, mechanism.length_scale())
        if len(mechanism._solve_state) > 64:
            mechanism._solve_state = {
                k: v for k, v in mechanism._solve_state.items() if k[0] != "geometry"
            }
        cached = mechanism._solve_state[key] = (configuration, maps, geometry)
    configuration, maps, geometry = cached
    pin.framesForwardKinematics(mechanism.model, mechanism.data, configuration.q)
    body_loads = gather_body_loads(mechanism.model, mechanism.data, loads, mechanism.link_frames)
    gradient = load_gradient(body_loads, maps.body_twist)
    problem = with_load(
        geometry,
        gradient,
        maps,
        mechanism.joints,
        mechanism.length_scale(),
        load_size(body_loads, geometry.scale, mechanism.length_scale()),
    )
    return configuration, maps, body_loads, problem


def load_size(body_loads, scale, length: float) -> float:
    """The whole load on the clearance scale [J]: sum of |F| c + |M| c / L over the bodies, with
    c the median variable scale, M the moment at the world origin and L the length scale."""
    play = float(np.median(scale)) if scale.size else 0.0
    return sum(
        float(np.linalg.norm(b.wrench[:3])) * play
        + float(np.linalg.norm(b.wrench[3:])) * play / max(length, 1e-300)
        for b in body_loads.values()
    )


def solve_linear(
    mechanism, loads, q=None, tol: float = 1e-12, backend: str = "auto", warm_start: bool = True
) -> Equilibrium:
    """Small-displacement equilibrium (METHOD.md section 1) with its residuals measured."""
    started = time.perf_counter()
    configuration, maps, _, problem = linear_setup(mechanism, loads, q)
    if problem.objective_scale == 0.0 or not problem.contacts or problem.size == 0:
        y = np.zeros(problem.size)
        return _assemble(
            mechanism,
            configuration,
            maps,
            problem,
            y,
            np.zeros(len(problem.contacts)),
            np.ones(len(problem.contacts)),
            "indeterminate",
            "no load works on any admissible motion",
            0,
            False,
            0.0,
            time.perf_counter() - started,
            {},
        )
    built, built_now = backend_for(problem, backend, tol)
    warm_key = ("warm", problem.signature())
    warm = mechanism._solve_state.get(warm_key) if warm_start else None
    solution = solve_cone(problem, built, warm=warm)
    if not solution.polished and built.name != "ipopt":
        fallback, fallback_built = backend_for(problem, "ipopt", tol)
        second = solve_cone(problem, fallback)
        if second.polished or second.kkt_residual < solution.kkt_residual:
            second.status = f"{solution.status}, unverified; then {second.status}"
            solution, built, built_now = second, fallback, fallback_built
    if solution.polished:
        mechanism._solve_state[warm_key] = solution
    flat = flat_directions(problem, solution)
    if flat.shape[1]:
        centred = solution.y - flat @ (flat.T @ solution.y)
        if np.max(problem.stack.values(centred, None), initial=0.0) <= 1e-13:
            solution.y = centred
    equilibrium = _assemble(
        mechanism,
        configuration,
        maps,
        problem,
        solution.y,
        solution.multipliers,
        solution.signs,
        "optimal",
        solution.status,
        solution.iterations,
        solution.polished,
        built.build_time if built_now else 0.0,
        time.perf_counter() - started,
        solution.residuals,
    )
    if flat.shape[1]:
        equilibrium.free_motions = equilibrium.free_motions + tuple(
            "bounded but not loaded (the optimum is not unique; minimum-norm point returned): "
            + "; ".join(
                describe_motion(
                    maps, mechanism.joints, problem.x_from_y(flat[:, i]), mechanism.length_scale()
                )
            )
            for i in range(flat.shape[1])
        )
    largest_rotation = max(
        (float(np.linalg.norm(t[3:])) for t in equilibrium.torsors.values()), default=0.0
    )
    if largest_rotation > FINITE_ROTATION:
        warnings.warn(
            ConditioningWarning(
                f"{mechanism.name}: the small-displacement answer turns a joint by "
                f"{largest_rotation:.2g} rad, beyond the model's validity (rotations << 1): "
                "the mechanism is near a toggle position; solve with exact=True"
            ),
            stacklevel=3,
        )
    if problem.conditioning < CONDITIONING_WARNING:
        warnings.warn(
            ConditioningWarning(
                f"{mechanism.name}: the loop closure is nearly singular (conditioning "
                f"{problem.conditioning:.1e}; a toggle or dead-centre position?): expect the answer "
                f"to lose about {-np.log10(problem.conditioning):.0f} digits"
            ),
            stacklevel=3,
        )
    if not equilibrium.ok or not solution.polished:
        raise SolverError(
            "the small-displacement solve did not reach a verified optimum",
            solution.status,
            equilibrium.residuals,
        )
    return equilibrium


def flat_directions(problem: ReducedProblem, solution) -> np.ndarray:
    r"""Directions (r, k) along which the optimum is not unique although the play bounds them.

    A contact carrying less than :data:`~.kkt.UNLOADED` (1e-9) of the largest contact force counts
    as unloaded, the same share below which a load component along an unblocked motion is
    neglected (:data:`~.reduction.UNBOUNDED_FRACTION`): the answer then moves continuously to
    the minimum-norm point as that share falls through 1e-9, with an energy change of that order.

    At a verified optimum with contact set A, a direction d with :math:`G_A d = 0` (it keeps every
    contact) and :math:`\nabla^2 L\, d = 0` (no curvature of the active cones along it) changes
    neither the potential nor feasibility to second order: the load does not see it (for example
    the axial play of a journal loaded only radially).
    """
    if not solution.polished:
        return np.zeros((problem.size, 0))
    stack = problem.stack
    largest = float(np.max(solution.multipliers, initial=0.0))
    active = np.flatnonzero(solution.multipliers > UNLOADED * largest)
    _, gradients = stack.evaluate(solution.y, solution.signs)
    rows = np.vstack([gradients[active], stack.hessian(solution.multipliers)])
    scale = max(1.0, float(np.abs(rows).max(initial=0.0)))
    return null_space(rows / scale, rtol=1e-9) if rows.size else np.eye(problem.size)


def _assemble(
    mechanism,
    configuration,
    maps: SmallDisplacementMaps,
    problem: ReducedProblem,
    y,
    multipliers,
    signs,
    status,
    solver_status,
    iterations,
    polished,
    build_time,
    solve_time,
    residuals,
) -> Equilibrium:
    x = problem.x_from_y(y)
    torsors = {name: maps.joint_torsor[name] @ x for name in mechanism.joints}
    model = mechanism.model
    twists = [maps.body_twist[i] @ x for i in range(model.njoints)]
    oMi = configuration.oMi
    body_motions = {
        model.names[i]: (twists[i][:3] + cross(twists[i][3:], oMi[i].translation), twists[i][3:])
        for i in range(1, model.njoints)
    }
    contacts = _contacts(problem, x, multipliers, signs)
    residuals = dict(residuals)
    residuals["statics"] = statics_residual(problem, x, contacts)
    residuals["max_violation_m"] = max((max(-c.gap, 0.0) for c in contacts), default=0.0)
    residuals["max_violation_rel"] = max(
        (max(-c.gap, 0.0) / c.clearance for c in contacts), default=0.0
    )
    residuals["clearance_m"] = max((c.clearance for c in contacts), default=0.0)
    residuals["closure_conditioning"] = problem.conditioning
    placements = tuple(
        [oMi[0]] + [pin.exp6(pin.Motion(twists[i])) * oMi[i] for i in range(1, model.njoints)]
    )
    return Equilibrium(
        formulation="linear",
        torsors=torsors,
        body_motions=body_motions,
        contacts=contacts,
        energy=float(problem.gradient @ x),
        status=status,
        solver_status=solver_status,
        iterations=iterations,
        residuals=residuals,
        free_motions=problem.free_descriptions,
        build_time=build_time,
        solve_time=solve_time,
        polished=polished,
        body_placements=placements,
        mechanism=mechanism,
        configuration=configuration,
        body_twists=np.array(twists),
    )


def _contacts(problem: ReducedProblem, x, multipliers, signs) -> tuple[Contact, ...]:
    contacts = []
    for j, constraint in enumerate(problem.contacts):
        point = constraint.contact
        image = constraint.rows @ x
        bound = point.bound
        if point.shape == "norm":
            gap = bound - float(np.linalg.norm(image))
            local = -2.0 * problem.objective_scale * multipliers[j] * image / bound**2
        else:
            gap = bound - abs(float(image[0]))
            local = np.array([-problem.objective_scale * multipliers[j] * signs[j] / bound])
        force = np.zeros(3)
        force[list(point.components)] = local
        active = gap <= ACTIVE_RELATIVE_GAP * bound or (
            multipliers[j] > 0.0 and gap <= 1e-6 * bound
        )
        contacts.append(Contact(constraint.joint, point.name, gap, bound, force, bool(active)))
    return tuple(contacts)


def statics_residual(problem: ReducedProblem, x: np.ndarray, contacts) -> float:
    r"""Relative virtual-work residual of the load and the reported contact forces.

    For every admissible motion the load and the contact forces do no net work:
    :math:`g = \sum_j S_j^T f_j + E^T \nu` with the rigid reactions :math:`\nu` fitted by least
    squares; returns :math:`\|Z (g - \sum S_j^T f_j - E^T\nu)\| / \|Z g\|` (Z: variable scales).
    """
    residual = problem.gradient.copy()
    for constraint, contact in zip(problem.contacts, contacts):
        residual -= constraint.rows.T @ contact.force[list(constraint.contact.components)]
    scale = problem.scale
    if problem.equalities.size:
        reactions = problem.equalities.T * scale[:, None]
        nu = np.linalg.lstsq(reactions, scale * residual, rcond=None)[0]
        scaled = scale * residual - reactions @ nu
    else:
        scaled = scale * residual
    reference = float(np.linalg.norm(scale * problem.gradient))
    return float(np.linalg.norm(scaled) / reference) if reference > 0.0 else 0.0


def solve_exact(mechanism, loads, q, linear: Equilibrium, tol: float = 1e-12) -> Equilibrium:
    """Exact finite-displacement equilibrium, warm-started from ``linear``."""
    from .exact import solve_exact_model

    return solve_exact_model(mechanism, loads, q, linear, tol)


__all__ = ["solve_linear", "solve_exact", "statics_residual"]
