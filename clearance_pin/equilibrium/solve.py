"""The small-displacement equilibrium of a mechanism [Y]: prepare, optimise, verify, report.

One way: the prepared geometry (:mod:`.prepared`) gives the reduced problem of the loads, a backend
finds its optimum and the Newton polish verifies it (:mod:`.cone_solver`), the answer is assembled
with its measured residuals (:mod:`.linear_answer`). The exact model (:mod:`.exact`) starts from it.
"""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable, Iterable, Sequence
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from ..errors import (
    ClearancePinError,
    ConditioningWarning,
    NearSingularError,
    SingularPositionError,
    SolverError,
    UnboundedLoadError,
)
from ..model.couplings import driven, leader_springs, passive
from ..numerics import norm
from .block_verify import closed_form_answer
from .blocks import block_structure
from .cone_solver import backend_for, clarabel_available, solve_cone
from .elastic_tree import play_twin, superposed
from .fast_path import (
    BoundLoads,
    FastTerms,
    fast_terms,
    kernel_installed,
    resolve_compiled,
    solve_compiled,
)
from .linear_answer import assemble_linear
from .method import NO_LOAD_STATUS, Method
from .plan import plan_linear
from .prepared import PreparedGeometry, prepared_geometry
from .reduction import reduce_geometry
from .result import Equilibrium
from .small_displacement import build_maps

if TYPE_CHECKING:  # the mechanism module imports this one
    from ..model.loads import Load
    from ..model.mechanism_parts import MechanismParts as Mechanism
    from .cache import SolveCache
    from .outputs import OutputPoint

CONDITIONING_WARNING = 1e-6
SINGULAR_PROBE = 1e-6  # [rad or m] how far the singular-position test looks
UNPOLISHED_KKT = 1e-9  # KKT residuals an answer the Newton polish left must meet to be returned
FINITE_ROTATION = 1e-2  # [rad] a linear answer turning a joint more than this is not small


def solve_linear(
    mechanism: Mechanism,
    loads: Sequence[Load],
    q: npt.ArrayLike | None = None,
    tol: float = 1e-12,
    backend: str = "auto",
    warm_start: bool = True,
    output_points: tuple[OutputPoint, ...] = (),
    prepared: PreparedGeometry | None = None,
) -> Equilibrium:
    """Small-displacement equilibrium (docs/method.md sections 2 and 3) with its residuals
    measured; raises SolverError (carrying the unverified answer) when they fail.

    The engines are tried in the order :func:`.plan.plan_linear` gives, each answer judged by the
    same measured residuals. ``warm_start``: the compiled kernel starts from the recent answers
    (False: from the centred position). ``prepared``: the mechanism prepared at ``q``, when the
    caller keeps it (:mod:`.resolver`)."""
    started = time.perf_counter()
    if prepared is None:
        prepared = prepared_geometry(mechanism, q)
    # a tree's springs by superposition, each from its joint's reaction: not a coupling's
    # leader, whose spring also carries its followers' torques
    if (
        prepared.geometry.stiffness is not None
        and not mechanism.loop_joints
        and not leader_springs(mechanism.couplings, mechanism.joints)
    ):
        return _springs_superposed(mechanism, prepared, loads, q, tol, backend, warm_start,
                                   output_points, started)  # fmt: skip
    cache: SolveCache = mechanism.cache
    plan = linear_plan(mechanism, prepared, backend)
    fast = fast_terms(prepared) if Method.COMPILED in plan else None
    if fast is not None:
        answer = _compiled(mechanism, prepared, fast, loads, tol, backend, warm_start, started,
                           output_points)  # fmt: skip
        if answer is not None:
            return answer
    try:
        problem = prepared.problem(loads)
    except UnboundedLoadError as error:
        if mechanism.loop_joints and _singular_position(mechanism, prepared):
            raise SingularPositionError(error.motions, error.fraction) from error
        raise
    count = len(problem.contacts)
    if not (np.isfinite(problem.objective_scale) and np.isfinite(problem.objective).all()):
        raise SolverError(
            f"the load terms of {mechanism.name!r} are not finite numbers; check the model's "
            "sizes, clearances and loads for extreme values",
            "not run",
        )
    if (
        problem.objective_scale == 0.0
        or problem.size == 0
        or not (count or problem.hessian is not None)
    ):
        indeterminate = assemble_linear(
            prepared,
            problem,
            np.zeros(problem.size),
            np.zeros(count),
            np.ones(count),
            "indeterminate",
            Method.NO_LOAD,
            NO_LOAD_STATUS,
            0,
            False,
            0.0,
            time.perf_counter() - started,
            {},
            loads,
            (),
            output_points,
        )
        if not indeterminate.ok:
            raise SolverError(
                "the nominal position fails its own residual checks",
                "not run",
                indeterminate.residuals,
                indeterminate,
            )
        return indeterminate
    closed = (
        closed_form_answer(prepared, problem, loads, started)
        if Method.CLOSED_FORM in plan
        else None
    )
    if closed is not None:  # a tree whose joints are independent blocks (blocks.py), verified
        _warn_if_inaccurate(mechanism, closed, problem.conditioning)
        return replace(closed, output_points=output_points) if output_points else closed
    cold = [method for method in plan if method in (Method.CLARABEL, Method.IPOPT)]
    built, built_now = backend_for(problem, cold[0].value, tol, prepared.signature, cache.backends)
    solution = solve_cone(problem, built)
    if not solution.polished and len(cold) > 1:
        fallback, fallback_built = backend_for(
            problem, cold[1].value, tol, prepared.signature, cache.backends
        )
        second = solve_cone(problem, fallback)
        if second.polished or second.kkt_residual < solution.kkt_residual:
            second.status = f"{solution.status}, unverified; then {second.status}"
            solution, built, built_now = second, fallback, fallback_built
    flat_notes: Sequence[str] = ()
    # an unpolished answer may be returned (below) when it is the minimum-norm optimum: no flat
    # direction, or centred along them like a polished one
    minimum_norm = False
    finite = np.isfinite(solution.y).all() and np.isfinite(solution.multipliers).all()
    if solution.polished or finite:
        if solution.polished:
            cache.warm[prepared.signature] = solution
        flat, flat_notes = prepared.flat_directions(
            solution.y, solution.multipliers, solution.signs, problem.hessian
        )
        minimum_norm = not flat.shape[1]
        if flat.shape[1]:
            centred = solution.y - flat @ (flat.T @ solution.y)
            if np.max(problem.stack.values(centred, None), initial=0.0) <= 1e-13:
                solution.y = centred
                minimum_norm = True
    equilibrium = assemble_linear(
        prepared,
        problem,
        solution.y,
        solution.multipliers,
        solution.signs,
        "optimal",
        solution.method,
        solution.status,
        solution.iterations,
        solution.polished,
        (built.build_time if built_now else 0.0) + solution.setup_time,
        time.perf_counter() - started,
        solution.residuals,
        loads,
        flat_notes,
        output_points,
    )
    _warn_if_inaccurate(mechanism, equilibrium, problem.conditioning)
    if not solution.polished and minimum_norm and equilibrium.ok and _kkt_certified(equilibrium):
        # the polish did not converge, but the answer is the minimum-norm equilibrium by every
        # measured residual: returned, saying so
        return replace(
            equilibrium,
            solver_status=f"{solution.status}; answered by {built.name} without the Newton "
            "polish, its residuals verified (statics, penetration, KKT to "
            f"{UNPOLISHED_KKT:g})",
        )
    if not equilibrium.ok or not solution.polished:
        rotation = toggle_rotation(mechanism, equilibrium)
        if rotation > FINITE_ROTATION:
            raise NearSingularError(
                f"{mechanism.name}: no verified small-displacement answer near a toggle or "
                f"dead-centre position (closure conditioning {problem.conditioning:.1e}: the "
                f"answer would turn joints by about {rotation:.2g} rad, beyond the model's "
                "validity); solve with exact=True",
                solution.status,
                equilibrium.residuals,
                equilibrium,
            )
        raise SolverError(
            "the small-displacement solve did not reach a verified optimum",
            solution.status,
            equilibrium.residuals,
            equilibrium,
        )
    return equilibrium


def _springs_superposed(
    mechanism: Mechanism,
    prepared: PreparedGeometry,
    loads: Sequence[Load],
    q: npt.ArrayLike | None,
    tol: float,
    backend: str,
    warm_start: bool,
    output_points: tuple[OutputPoint, ...],
    started: float,
) -> Equilibrium:
    """A tree with stiffness: its rigid twin's answer (its own plan: closed forms, kernel, cone
    solvers) plus each spring's deflection (:mod:`.elastic_tree`)."""
    twin = play_twin(mechanism)
    play = solve_linear(twin, loads, q, tol, backend, warm_start, output_points)
    answer = superposed(mechanism, prepared, loads, play, started)
    if not answer.ok:
        raise SolverError(
            "the springs' deflection added to the play does not balance the loads",
            answer.solver_status,
            answer.residuals,
            answer,
        )
    return answer


def linear_plan(
    mechanism: Mechanism, prepared: PreparedGeometry, backend: str
) -> tuple[Method, ...]:
    """:func:`.plan.plan_linear` of ``mechanism`` prepared at one configuration (``prepared``)
    with the caller's ``backend``: its structure, whether it has a verified answer, and what is
    installed (kept per backend, answer and installation on ``prepared``: a re-solve reads it)."""
    key = (backend, bool(mechanism.cache.warm), kernel_installed())
    plan: tuple[Method, ...] | None = prepared.plans.get(key)
    if plan is None:
        geometry = prepared.geometry
        elastic = geometry.stiffness is not None
        plan = prepared.plans[key] = plan_linear(
            independent_blocks=backend == "auto"
            and not elastic
            and block_structure(geometry, bool(mechanism.loop_joints)) is not None,
            size=geometry.stack.size,
            contacts=geometry.stack.count,
            solved_before=key[1],
            backend=backend,
            kernel=key[2],
            clarabel=clarabel_available(),
            elastic=elastic,
        )
    return plan


def _singular_position(mechanism: Mechanism, prepared: PreparedGeometry) -> bool:
    """True when the motions nothing blocks at the configuration of ``prepared`` are fewer at a
    configuration 1e-6 [rad or m] away in a fixed random direction: they exist only at this
    configuration (a toggle or dead centre of the loop closure: blocked at second order), not
    as a motion of the mechanism (a free spin stays free nearby)."""
    model = mechanism.model
    step = np.random.default_rng(0).standard_normal(model.nv)
    nearby = pin.integrate(model, prepared.configuration.q, SINGULAR_PROBE * step / norm(step))
    try:
        configuration = mechanism.configure(nearby)
        data = mechanism.cache.data  # this thread's
        pin.framesForwardKinematics(model, data, configuration.q)
        held = driven(mechanism.couplings, mechanism.joints)
        maps = build_maps(
            model, data, mechanism.tree_joints, mechanism.loop_joints, configuration, held
        )
        couplings = passive(mechanism.couplings, mechanism.joints)
        there = reduce_geometry(maps, mechanism.joints, mechanism.length_scale(), couplings)
    except (ClearancePinError, ValueError, np.linalg.LinAlgError):
        return False  # undecided: the general diagnosis stands
    return bool(there.free_motions.shape[1] < prepared.geometry.free_motions.shape[1])


def toggle_rotation(mechanism: Mechanism, equilibrium: Equilibrium) -> float:
    r"""The rotation [rad] the small-displacement model gives a joint near a singular position
    of the loop closure, estimated from the play and the closure's conditioning :math:`\sigma`
    (its smallest singular value, 1 for a well-posed mechanism):
    :math:`\theta \approx (c / L) / \sigma`, c the largest clearance [m], L the mechanism's
    length scale [m] (a play c turns a link of length L by c / L; the closure amplifies it by
    1 / sigma). On a four-bar 1e-1 .. 1e-3 rad before its toggle this is 0.8 .. 1.3 times the
    rotation of the solved linear answers; beyond :data:`FINITE_ROTATION` the linear model is
    outside its validity (its forces grow as 1 / sigma: 2132 N at 1e-3 rad where the exact
    model gives 35 N)."""
    residuals = equilibrium.residuals
    conditioning = residuals.closure_conditioning
    if not conditioning or not residuals.clearance_m:
        return 0.0
    return float(residuals.clearance_m / mechanism.length_scale() / conditioning)


def _kkt_certified(equilibrium: Equilibrium) -> bool:
    """An unpolished answer's KKT residuals (stationarity, complementarity: a force only where a
    contact touches) within :data:`UNPOLISHED_KKT`; its statics, penetration and dual
    feasibility are :attr:`Equilibrium.ok`'s."""
    residuals = equilibrium.residuals
    return all(
        (residuals.get(name) or 0.0) <= UNPOLISHED_KKT
        for name in ("stationarity", "complementarity", "feasibility")
    )


def _compiled(
    mechanism: Mechanism,
    prepared: PreparedGeometry,
    fast: FastTerms,
    loads: Sequence[Load],
    tol: float,
    backend: str,
    warm_start: bool,
    started: float,
    output_points: tuple[OutputPoint, ...],
) -> Equilibrium | None:
    """The compiled answer (:func:`.fast_path.solve_compiled`), warned about like any, or None."""
    cache: SolveCache = mechanism.cache
    answer = solve_compiled(
        fast,
        loads,
        cache.warm.get(prepared.signature) if warm_start else None,
        lambda problem: backend_for(problem, backend, tol, prepared.signature, cache.backends),
        started,
        output_points,
        from_centre=backend == "auto",
    )
    if answer is not None:
        _warn_if_inaccurate(mechanism, answer, prepared.geometry.conditioning)
    return answer


def resolve_linear(
    mechanism: Mechanism,
    fast: FastTerms,
    bound: BoundLoads,
    vector: np.ndarray,
    loads_of: Callable[[], Iterable[Load]],
    output_points: tuple[OutputPoint, ...],
) -> Equilibrium | None:
    """A resolver's warm re-solve by the kernel (:func:`.fast_path.resolve_compiled`) with the
    force and torque vectors ``vector`` of the loads ``bound``, warned about like any, or None
    (no warm start yet, or not verified: the caller solves the general way)."""
    started = time.perf_counter()
    warm = mechanism.cache.warm.get(fast.prepared.signature)
    if warm is None or warm.y.shape != (fast.size,):
        return None
    answer = resolve_compiled(fast, bound, vector, warm, loads_of, started, output_points)
    if answer is not None:
        _warn_if_inaccurate(mechanism, answer, fast.prepared.geometry.conditioning)
    return answer


def _warn_if_inaccurate(
    mechanism: Mechanism, equilibrium: Equilibrium, conditioning: float
) -> None:
    """ConditioningWarning for a finite rotation or a nearly singular loop closure."""
    largest_rotation = equilibrium.residuals.largest_rotation_rad or 0.0
    if largest_rotation > FINITE_ROTATION:
        # a tree has no toggle position: there a large turn is a play large for its journal
        # (or a soft stiffness)
        plays = "its plays are large for their journals (a play in the wrong unit?) or a stiffness "
        plays += "soft for the load"
        cause = (
            f"the mechanism is near a toggle position, or {plays}"
            if mechanism.loop_joints
            else plays
        )
        warnings.warn(
            ConditioningWarning(
                f"{mechanism.name}: the small-displacement answer turns a joint by "
                f"{largest_rotation:.2g} rad, beyond the model's validity (rotations << 1): "
                f"{cause}; solve with exact=True"
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


__all__ = ["linear_plan", "resolve_linear", "solve_linear", "toggle_rotation"]
