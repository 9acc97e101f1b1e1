"""One case solved in the formulation asked for: the small-displacement model, the exact one, or
``exact="auto"`` deciding between them by the second-order estimate; the core every entry point
calls (:meth:`~clearance_pin.mechanism.Mechanism.solve` after checking its arguments, the batches
for each case they do not solve on stacked arrays, the resolver for an exact re-solve).

The loads are resolved and checked by the caller (the mechanism's load front end,
``resolve_loads``); a NumPy or SciPy failure deep inside a solve becomes a
:class:`~clearance_pin.errors.SolverError` naming the mechanism.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from ..errors import ClearancePinError, NearSingularError, SolverError
from ..model.stiffness import in_part_frame, part_rotation, turned_stiffness, turning
from .cache import LeastRecentlyUsed
from .options import SolveOptions
from .outputs import resolve_outputs
from .result import Equilibrium
from .second_order import estimate_difference
from .solve import solve_linear


def solve_case(
    mechanism: Any, resolved: Any, q: np.ndarray | None, options: SolveOptions
) -> Equilibrium:
    """The equilibrium of ``mechanism`` under the resolved loads ``resolved`` at ``q`` (None:
    nominal) with ``options`` (checked by the entry point)."""
    try:
        return _formulated(mechanism, resolved, q, options)
    except (np.linalg.LinAlgError, OverflowError, FloatingPointError, ValueError) as exc:
        if isinstance(exc, ClearancePinError):
            raise
        raise SolverError(
            f"numerical failure in {mechanism.name!r} ({type(exc).__name__}: {exc}); check the "
            "model's sizes and clearances for extreme values",
            "numerical error",
        ) from None


def solve_with_options(mechanism: Any, loads: Any, q: Any, options: SolveOptions) -> Equilibrium:
    """:func:`solve_case` of one batch case: its ``loads`` (None: the model's) resolved with the
    ``gravity`` option."""
    resolved = mechanism.resolve_loads(loads, options.gravity)
    configuration = None if q is None else np.asarray(q, dtype=float)
    return solve_case(mechanism, resolved, configuration, options)


def _part_stiffness_twin(mechanism: Any, linear: Equilibrium) -> Any:
    """The mechanism the exact model solves: ``mechanism`` itself, or, when a joint's K is stated
    in the housing's frame, is not symmetric about its axis and the joint has turned at the
    answer's configuration, the same mechanism with that K turned into the part's frame there,
    :math:`G^T K G` (:func:`~clearance_pin.model.stiffness.elastic_at`), so that the exact
    model, whose springs' directions are fixed in the part, reads the same K as the
    small-displacement one. Kept per configuration (the last 8) on the mechanism's cache."""
    joints = turning(mechanism.tree_joints)
    if not joints:
        return mechanism
    placed = linear.configuration.oMi  # type: ignore[attr-defined]
    names = set(turned_stiffness(joints, mechanism.model, placed))
    if not names:
        return mechanism
    rotations = {
        joint.name: part_rotation(mechanism.model, joint, placed)
        for joint in joints
        if joint.name in names
    }
    key = b"".join(rotations[name].tobytes() for name in sorted(rotations))
    twins = mechanism.cache.__dict__.setdefault("part_stiffness_twins", LeastRecentlyUsed(8))
    twin = twins.get(key)
    if twin is None:

        def in_part(joint: Any) -> Any:
            if joint.name not in rotations:
                return joint
            clearance = in_part_frame(joint.clearance, rotations[joint.name])  # G^T K G
            return replace(joint, clearance=clearance)

        tree = tuple(in_part(joint) for joint in mechanism.tree_joints)
        twin = twins[key] = mechanism.rebuilt(mechanism.model, tree, mechanism.loop_joints)
    return twin


def _formulated(
    mechanism: Any, resolved: Any, q: np.ndarray | None, options: SolveOptions
) -> Equilibrium:
    exact, tol, accuracy = options.exact, options.tol, options.accuracy
    points = resolve_outputs(mechanism, resolved, options.outputs)
    try:
        linear = solve_linear(
            mechanism, resolved, q, tol, options.backend, options.warm_start, points
        )
    except NearSingularError as near:
        if not exact:
            raise
        # near a toggle the linear model has no meaningful answer; the exact one does
        result = exact_from_linear(mechanism, resolved, q, near.answer, tol, from_nominal=True)
        note = (
            "near a singular position of the loop closure the small-displacement model "
            "has no verified answer (.linear is its unverified one): the exact model was "
            "solved from the nominal position"
        )
        return replace(result, note=f"{note}; {result.note}" if result.note else note)
    if exact == "auto":
        estimate = estimate_difference(linear, resolved, q, points)
        error = max(estimate.translation_m, estimate.rotation_rad * mechanism.length_scale())
        linear = replace(
            linear,
            residuals=replace(linear.residuals, second_order_m=error),
            difference_bound=estimate.as_dict(),
        )
        if error <= accuracy:
            return replace(
                linear,
                note=(
                    f"auto: small-displacement model kept, its estimated difference from the "
                    f"exact model at the outputs {error:.2e} m <= accuracy {accuracy:.0e} m"
                ),
            )
        result = exact_from_linear(mechanism, resolved, q, linear, tol)
        why = (
            f"estimated difference from the exact model at the outputs {error:.2e} m > "
            f"accuracy {accuracy:.0e} m"
            if estimate.reliable
            else f"no reliable second-order estimate ({estimate.reason})"
        )
        note = f"auto: exact model run, {why}" + (f"; {result.note}" if result.note else "")
        return replace(result, difference_bound=linear.difference_bound, note=note)
    if not exact:
        return linear
    return exact_from_linear(mechanism, resolved, q, linear, tol)


def exact_from_linear(
    mechanism: Any, loads: Any, q: np.ndarray | None, linear: Equilibrium, tol: float,
    from_nominal: bool = False,
) -> Equilibrium:  # fmt: skip
    """The exact model's answer for the resolved ``loads`` at ``q``, started from the linear
    answer ``linear`` (``from_nominal``: from the nominal position); imported on first use
    (CasADi loads then, not at import)."""
    from .exact import solve_exact_model

    solved = _part_stiffness_twin(mechanism, linear)  # a housing K turned at q: its twin's
    answer: Equilibrium = solve_exact_model(solved, loads, q, linear, tol, from_nominal)
    return answer if solved is mechanism else replace(answer, mechanism=mechanism)


__all__ = ["exact_from_linear", "solve_case", "solve_with_options"]
