"""The small-displacement answer: an :class:`~.result.Equilibrium` assembled from a reduced solution.

Torsors, body twists, contact gaps and forces come from the stacked maps of the prepared geometry;
the residuals the answer carries are measured here, not taken from the solver: statics (virtual
work of the loads and the contact forces), penetration, closure conditioning, largest rotation.
Used by a single solve (:mod:`.solve`) and by the batched Newton (:mod:`.batch`).
"""

from __future__ import annotations

import numpy as np

from .lazy import LazyMapping, LazySequence, placements
from .prepared import PreparedGeometry
from .reduction import ReducedProblem
from .residuals import Residuals
from .result import Contact, Equilibrium

ACTIVE_RELATIVE_GAP = 1e-7  # of the play: a contact closer than this touches


def assemble_linear(
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
    loads: tuple,
    flat_notes=(),
) -> Equilibrium:
    """The answer of the reduced solution (y, multipliers, slab sides ``signs``) for ``loads``,
    with the solver's KKT ``residuals`` and the ones measured here (module docstring)."""
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
    measured = Residuals.of(
        {
            **residuals,
            "statics": prepared.statics_residual(problem.gradient, force_rows, problem.load_size),
            "max_violation_m": max(float(-gaps.min(initial=0.0)), 0.0),
            "max_violation_rel": max(float((-gaps / bounds).max(initial=0.0)), 0.0),
            "clearance_m": float(bounds.max(initial=0.0)),
            "closure_conditioning": problem.conditioning,
            "unblocked_load": problem.unblocked_share,
            "largest_rotation_rad": float(
                np.sqrt((torsor_array[:, 3:] ** 2).sum(axis=1)).max(initial=0.0)
            ),
        }
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
        residuals=measured,
        free_motions=problem.free_descriptions + flat_notes,
        build_time=build_time,
        solve_time=solve_time,
        polished=polished,
        body_placements=placements(twists, prepared.configuration.oMi),
        mechanism=mechanism,
        configuration=prepared.configuration,
        body_twists=twists,
        loads=tuple(loads),
    )


__all__ = ["ACTIVE_RELATIVE_GAP", "assemble_linear"]
