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
from .cone_solver import WarmBet, backend_for, solve_cone
from .load_terms import gather_body_loads
from .prepared import LazyMapping, LazySequence, PreparedGeometry, placements
from .reduction import ReducedProblem, reduce_geometry
from .result import Contact, Equilibrium
from .small_displacement import build_maps

ACTIVE_RELATIVE_GAP = 1e-7
CONDITIONING_WARNING = 1e-6
FINITE_ROTATION = 1e-2  # [rad] a linear answer turning a joint more than this is not small


def prepared_geometry(mechanism, q=None) -> PreparedGeometry:
    """The mechanism prepared at ``q`` (default: nominal), cached per configuration: closing the
    loops, the maps and the reduction are done once, so a new load costs a few array products."""
    key = ("geometry", None if q is None else np.asarray(q, dtype=float).tobytes())
    prepared = mechanism._solve_state.get(key)
    if prepared is None:
        with mechanism._placing:  # configure and build_maps read and write mechanism.data
            prepared = mechanism._solve_state.get(key)
            if prepared is not None:
                return prepared
            configuration = mechanism.configure(q)
            maps = build_maps(
                mechanism.model,
                mechanism.data,
                mechanism.tree_joints,
                mechanism.loop_joints,
                configuration,
            )
            geometry = _reduced_geometry(mechanism, maps)
            state = mechanism._solve_state
            if len(state) > 64:
                for stale in [k for k in list(state) if k[0] in ("geometry", "geometry terms")]:
                    state.pop(stale, None)
            prepared = PreparedGeometry(mechanism, configuration, maps, geometry)
            state[key] = prepared
    return prepared


def _reduced_geometry(mechanism, maps):
    """The reduction at the configuration of ``maps``; without loop joints it is the same at every
    configuration (the unknowns are the joints' own torsors and each contact reads its own joint's
    torsor, so no constraint depends on where the parts are), so it is done once."""
    if mechanism.loop_joints:
        return reduce_geometry(maps, mechanism.joints, mechanism.length_scale())
    key = ("tree geometry",)
    geometry = mechanism._solve_state.get(key)
    if geometry is None:
        geometry = reduce_geometry(maps, mechanism.joints, mechanism.length_scale())
        mechanism._solve_state[key] = geometry
    return geometry


def linear_setup(mechanism, loads, q):
    """Configuration, maps, per-body loads (with the exact model's terms) and reduced problem."""
    prepared = prepared_geometry(mechanism, q)
    configuration = prepared.configuration
    with mechanism._placing:
        pin.framesForwardKinematics(mechanism.model, mechanism.data, configuration.q)
        body_loads = gather_body_loads(
            mechanism.model, mechanism.data, loads, mechanism.link_frames
        )
    return configuration, prepared.maps, body_loads, prepared.problem(loads)


def solve_linear(
    mechanism, loads, q=None, tol: float = 1e-12, backend: str = "auto", warm_start: bool = True
) -> Equilibrium:
    """Small-displacement equilibrium (METHOD.md section 1) with its residuals measured."""
    started = time.perf_counter()
    prepared = prepared_geometry(mechanism, q)
    problem = prepared.problem(loads)
    count = len(problem.contacts)
    if not (np.isfinite(problem.objective_scale) and np.isfinite(problem.objective).all()):
        raise SolverError(
            f"the load terms of {mechanism.name!r} are not finite numbers; check the model's "
            "sizes, clearances and loads for extreme values",
            "not run",
        )
    if problem.objective_scale == 0.0 or not count or problem.size == 0:
        indeterminate = _assemble(
            prepared,
            problem,
            np.zeros(problem.size),
            np.zeros(count),
            np.ones(count),
            "indeterminate",
            "no load works on any admissible motion",
            0,
            False,
            0.0,
            time.perf_counter() - started,
            {},
        )
        if not indeterminate.ok:
            raise SolverError(
                "the nominal position fails its own residual checks",
                "not run",
                indeterminate.residuals,
            )
        indeterminate.loads = tuple(loads)  # for the joint reactions
        return indeterminate
    built, built_now = backend_for(problem, backend, tol, prepared.signature)
    warm_key = ("warm", prepared.signature)
    warm = mechanism._solve_state.get(warm_key) if warm_start else None
    bet = mechanism._solve_state.setdefault(("warm bet", prepared.signature), WarmBet())
    if warm is not None and not bet.worth_it():
        warm = None
    solution = solve_cone(problem, built, warm=warm)
    if warm_start:
        bet.record(warm is not None, solution.solve_time)
    if not solution.polished and built.name != "ipopt":
        fallback, fallback_built = backend_for(problem, "ipopt", tol, prepared.signature)
        second = solve_cone(problem, fallback)
        if second.polished or second.kkt_residual < solution.kkt_residual:
            second.status = f"{solution.status}, unverified; then {second.status}"
            solution, built, built_now = second, fallback, fallback_built
    flat_notes = ()
    if solution.polished:
        mechanism._solve_state[warm_key] = solution
        flat, flat_notes = prepared.flat_directions(
            solution.y, solution.multipliers, solution.signs
        )
        if flat.shape[1]:
            centred = solution.y - flat @ (flat.T @ solution.y)
            if np.max(problem.stack.values(centred, None), initial=0.0) <= 1e-13:
                solution.y = centred
    equilibrium = _assemble(
        prepared,
        problem,
        solution.y,
        solution.multipliers,
        solution.signs,
        "optimal",
        solution.status,
        solution.iterations,
        solution.polished,
        (built.build_time if built_now else 0.0) + solution.setup_time,
        time.perf_counter() - started,
        solution.residuals,
        flat_notes,
    )
    _warn_if_inaccurate(mechanism, equilibrium, problem.conditioning)
    if not equilibrium.ok or not solution.polished:
        raise SolverError(
            "the small-displacement solve did not reach a verified optimum",
            solution.status,
            equilibrium.residuals,
        )
    equilibrium.loads = tuple(loads)  # for the joint reactions
    return equilibrium


def _warn_if_inaccurate(mechanism, equilibrium: Equilibrium, conditioning: float) -> None:
    """ConditioningWarning for a finite rotation or a nearly singular loop closure."""
    largest_rotation = equilibrium.residuals.get("largest_rotation_rad", 0.0)
    if largest_rotation > FINITE_ROTATION:
        warnings.warn(
            ConditioningWarning(
                f"{mechanism.name}: the small-displacement answer turns a joint by "
                f"{largest_rotation:.2g} rad, beyond the model's validity (rotations << 1): "
                "the mechanism is near a toggle position; solve with exact=True"
            ),
            stacklevel=5,
        )
    if conditioning < CONDITIONING_WARNING:
        warnings.warn(
            ConditioningWarning(
                f"{mechanism.name}: the loop closure is nearly singular (conditioning "
                f"{conditioning:.1e}; a toggle or dead-centre position?): expect the answer "
                f"to lose about {-np.log10(conditioning):.0f} digits"
            ),
            stacklevel=5,
        )


def _assemble(
    prepared: PreparedGeometry,
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
    flat_notes=(),
) -> Equilibrium:
    x = prepared.x_from_y @ y
    torsor_array = prepared.torsor_array(x)
    twists = prepared.body_twists(x)
    mechanism = prepared.mechanism
    gaps, force_rows = prepared.contact_state(x, multipliers, signs, problem.objective_scale)
    bounds = prepared.bounds
    active = (gaps <= ACTIVE_RELATIVE_GAP * bounds) | (
        (multipliers > 0.0) & (gaps <= 1e-6 * bounds)
    )
    contacts = LazySequence(
        lambda: (
            Contact(
                c.joint,
                c.contact.name,
                float(gap),
                float(bound),
                force,
                bool(touching),
                np.array(c.contact.point),  # nominal place, in the joint's clearance frame
                prepared.maps.joint_centre[c.joint].act(np.array(c.contact.point)),
            )
            for c, gap, bound, force, touching in zip(
                problem.contacts, gaps, bounds, prepared.contact_forces(force_rows), active
            )
        )
    )
    residuals = dict(residuals)
    residuals["statics"] = prepared.statics_residual(
        problem.gradient, force_rows, problem.load_size
    )
    residuals["max_violation_m"] = max(float(-gaps.min(initial=0.0)), 0.0)
    residuals["max_violation_rel"] = max(float((-gaps / bounds).max(initial=0.0)), 0.0)
    residuals["clearance_m"] = float(bounds.max(initial=0.0))
    residuals["closure_conditioning"] = problem.conditioning
    residuals["largest_rotation_rad"] = float(
        np.sqrt((torsor_array[:, 3:] ** 2).sum(axis=1)).max(initial=0.0)
    )
    return Equilibrium(
        formulation="linear",
        torsors=dict(zip(prepared.joint_names, torsor_array)),
        body_motions=LazyMapping(lambda: prepared.body_motions(twists, mechanism.model.names)),
        contacts=contacts,
        energy=float(problem.gradient @ x),
        status=status,
        solver_status=solver_status,
        iterations=iterations,
        residuals=residuals,
        free_motions=problem.free_descriptions + flat_notes,
        build_time=build_time,
        solve_time=solve_time,
        polished=polished,
        body_placements=placements(twists, prepared.configuration.oMi),
        mechanism=mechanism,
        configuration=prepared.configuration,
        body_twists=twists,
    )


def solve_exact(mechanism, loads, q, linear: Equilibrium, tol: float = 1e-12) -> Equilibrium:
    """Exact finite-displacement equilibrium, warm-started from ``linear``."""
    from .exact import solve_exact_model

    return solve_exact_model(mechanism, loads, q, linear, tol)


__all__ = ["prepared_geometry", "solve_exact", "solve_linear"]
