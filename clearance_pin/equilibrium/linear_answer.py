"""The small-displacement answer: an :class:`~.result.Equilibrium` assembled from a reduced solution.

Torsors, body twists, contact gaps and forces come from the stacked maps of the prepared geometry;
the residuals the answer carries are measured here, not taken from the solver: statics (the
wrench balance of the loads and the contact forces in N, per joint direction), penetration,
closure conditioning, largest rotation.
Used by a single solve (:mod:`.solve`) and by the batched Newton (:mod:`.batch`); every engine's
answer (closed forms, compiled kernel, NumPy active set, Clarabel, IPOPT) passes through
:func:`linear_equilibrium`, where statically indeterminate contacts get the least-norm split of
their forces (:mod:`.contact_split`), whichever engine found the optimum.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from ..numerics import Array, Mask
from .contact_split import least_norm_split
from .frozen import FieldTemplate
from .lazy import LazyMapping, LazySequence, placements
from .method import Method
from .prepared import PreparedGeometry
from .reduction import ReducedProblem
from .residuals import Residuals
from .result import Contact, Equilibrium, Status

if TYPE_CHECKING:
    from ..model.loads import Load
    from .outputs import OutputPoint

# how a solve ended: (status, the Method that answered, solver status, iterations, polished)
Outcome = tuple[Status, Method, str, int, bool]
# a solution's contacts: (gaps [m], stacked force rows [N], multipliers)
ContactArrays = tuple[Array, Array, Array]

ACTIVE_RELATIVE_GAP = 1e-7  # of the play: a contact closer than this touches


def assemble_linear(
    prepared: PreparedGeometry,
    problem: ReducedProblem,
    y: Array,
    multipliers: Array,
    signs: Array,
    status: Status,
    method: Method,
    solver_status: str,
    iterations: int,
    polished: bool,
    build_time: float,
    solve_time: float,
    residuals: dict[str, float],
    loads: Sequence[Load],
    flat_notes: Sequence[str] = (),
    output_points: tuple[OutputPoint, ...] = (),
) -> Equilibrium:
    """The answer of the reduced solution (y, multipliers, slab sides ``signs``) for ``loads``,
    with the solver's KKT ``residuals`` and the ones measured here (module docstring)."""
    x = prepared.x_from_y @ y
    gaps, force_rows = prepared.contact_state(x, multipliers, signs, problem.objective_scale)
    outcome: Outcome = (status, method, solver_status, iterations, polished)
    return answer_of_x(prepared, problem, x, (gaps, force_rows, multipliers), outcome,
                       (build_time, solve_time), residuals, loads, flat_notes, output_points)  # fmt: skip


def answer_of_x(
    prepared: PreparedGeometry,
    problem: ReducedProblem,
    x: Array,
    contacts: ContactArrays,
    outcome: Outcome,
    times: tuple[float, float],
    residuals: dict[str, float],
    loads: Sequence[Load],
    flat_notes: Sequence[str] = (),
    output_points: tuple[OutputPoint, ...] = (),
) -> Equilibrium:
    """The answer of the unknowns x (n,) with its ``contacts`` = (gaps [m], stacked force rows
    [N], multipliers) (:meth:`.prepared.PreparedGeometry.contact_state`), ``outcome`` and
    ``times`` as :func:`linear_equilibrium` takes them, the residuals measured here."""
    gaps, force_rows, multipliers = contacts
    torsor_array = prepared.torsor_array(x)
    twists = prepared.body_twists(x)
    stiffness = prepared.geometry.stiffness
    springs = None if stiffness is None else stiffness * x  # K x [N or N m]
    elastic_energy = 0.0 if springs is None else 0.5 * float(springs @ x)
    measured = Residuals.of(
        {
            **residuals,
            "statics": prepared.statics_residual(
                problem.gradient, force_rows, problem.load_size, springs
            ),
            "max_violation_m": max(float(-gaps.min(initial=0.0)), 0.0),
            "max_violation_rel": max(float((-gaps / prepared.bounds).max(initial=0.0)), 0.0),
            "clearance_m": float(prepared.bounds.max(initial=0.0)),
            "closure_conditioning": problem.conditioning,
            "unblocked_load": problem.unblocked_share,
            "largest_rotation_rad": float(
                np.sqrt((torsor_array[:, 3:] ** 2).sum(axis=1)).max(initial=0.0)
            ),
        }
    )
    return linear_equilibrium(
        prepared,
        torsor_array,
        twists,
        gaps,
        force_rows,
        multipliers,
        measured,
        float(problem.gradient @ x) + elastic_energy,
        outcome,
        times,
        problem.free_descriptions + flat_notes,
        loads,
        output_points,
        x,
    )


def linear_equilibrium(
    prepared: PreparedGeometry,
    torsor_array: np.ndarray,
    twists: np.ndarray,
    gaps: np.ndarray,
    force_rows: np.ndarray,
    multipliers: np.ndarray,
    measured: Residuals,
    energy: float,
    outcome: Outcome,
    times: tuple[float, float],
    free_motions: Sequence[str],
    loads: Sequence[Load],
    output_points: tuple[OutputPoint, ...] = (),
    x: np.ndarray | None = None,
) -> Equilibrium:
    """The :class:`~.result.Equilibrium` of computed answer arrays: joint torsors (joints, 6)
    [m, rad], body twists (bodies, 6), contact gaps (m,) [m] and stacked force rows [N], the
    multipliers, the measured residuals, the potential [J], ``outcome`` = (status, method (the
    :class:`~.method.Method` that answered), solver status, iterations, polished), ``times`` =
    (build, solve) [s], the unknowns ``x`` (n,) (None: the forces are reported as given);
    contacts and body motions are computed when read (:mod:`.lazy`), the contact forces of
    statically indeterminate contacts split by least norm (:func:`split_force_rows`)."""
    mechanism = prepared.mechanism
    owner = getattr(prepared, "nominal", prepared)  # the points of a trajectory share one
    template: FieldTemplate | None = owner.__dict__.get("_answer_template")
    if template is None:
        template = owner.__dict__["_answer_template"] = FieldTemplate(
            Equilibrium, {"formulation": "linear", "mechanism": mechanism}
        )
    answer, state = template.new()
    equilibrium: Equilibrium = answer  # (FieldTemplate.new: an instance of its class)
    state["configuration"] = prepared.configuration
    (state["status"], state["method"], state["solver_status"], state["iterations"],
     state["polished"]) = outcome  # fmt: skip
    state["torsors"] = dict(zip(prepared.joint_names, torsor_array))
    state["body_motions"] = LazyMapping(
        lambda: prepared.body_motions(twists, mechanism.model.names)
    )
    state["contacts"] = LazySequence(lambda: _contacts(prepared, gaps, force_rows, multipliers, x))
    state["energy"] = energy
    state["residuals"] = measured
    state["free_motions"] = free_motions
    state["build_time"], state["solve_time"] = times
    state["body_placements"] = placements(twists, prepared.configuration.oMi)
    state["body_twists"] = twists
    state["loads"] = loads if isinstance(loads, (tuple, LazySequence)) else tuple(loads)
    state["output_points"] = output_points
    if x is not None and prepared.deflection_rows:
        state["deflections"] = {name: rows @ x for name, rows in prepared.deflection_rows.items()}
    return equilibrium


def _contacts(
    prepared: PreparedGeometry, gaps: Array, force_rows: Array, multipliers: Array, x: Array | None
) -> tuple[Contact, ...]:
    """Every contact point with its gap, force (:func:`split_force_rows`) and whether it
    touches (gap within 1e-7 of the play, or 1e-6 while it carries a force)."""
    bounds = prepared.bounds
    active = (gaps <= ACTIVE_RELATIVE_GAP * bounds) | (
        (multipliers > 0.0) & (gaps <= 1e-6 * bounds)
    )
    if x is not None:
        force_rows = split_force_rows(prepared, x, force_rows, active)
    centres = prepared.joint_centres()
    return tuple(
        Contact(
            c.joint,
            c.contact.name,
            float(gap),
            float(bound),
            np.zeros(3) if c.contact.lever else force,
            bool(touching),
            np.array(c.contact.point),  # nominal place, in the joint's clearance frame
            centres[c.joint].act(np.array(c.contact.point)),
            c.contact.lever * force if c.contact.lever else None,  # a stop's moment [N m]
        )
        for c, gap, bound, force, touching in zip(
            prepared.geometry.contacts, gaps, bounds, prepared.contact_forces(force_rows), active
        )
    )


def split_force_rows(
    prepared: PreparedGeometry, x: Array, force_rows: Array, active: Mask
) -> Array:
    r"""The stacked force rows [N] with the forces of the touching contacts (``active``, (m,))
    split by least norm (:func:`.contact_split.least_norm_split`); ``force_rows`` itself when the
    split is unique.

    A unit force at contact j acts along :math:`d_j`: :math:`-(o_j + S_j x) / \lVert o_j + S_j x
    \rVert` (ball, disc), :math:`-\mathrm{sign}(o_j + s_j^T x)` (slab); its generalised force on
    the reduced unknowns is :math:`G_{:,j} = (Z Q)^T S_j^T d_j`, so two splits with the same
    :math:`G \mu` differ only by what the loops' rigid conditions hold (range of :math:`E^T`)."""
    touching = np.flatnonzero(active)
    if touching.size < 2:
        return force_rows
    terms = prepared.terms
    row_contact = terms.contact_of_row
    rows = np.flatnonzero(active[row_contact])
    owner = row_contact[rows]
    starts = np.flatnonzero(np.r_[True, owner[1:] != owner[:-1]])
    image = terms.contact_rows[rows] @ x + terms.contact_offsets[rows]
    sizes = np.sqrt(np.add.reduceat(image * image, starts))
    counts = np.diff(np.r_[starts, rows.size])
    directions = np.where(
        terms.is_norm[owner], -image / np.repeat(np.where(sizes > 0.0, sizes, 1.0), counts),
        -np.sign(image),
    )  # fmt: skip
    given = np.sqrt(np.add.reduceat(force_rows[rows] ** 2, starts))
    reduced = terms.contact_rows[rows] @ terms.x_from_y  # S_j Z Q: on the reduced unknowns
    columns = np.add.reduceat(reduced * directions[:, None], starts, axis=0).T
    split = least_norm_split(columns, given)
    if split is given:
        return force_rows
    out = force_rows.copy()
    out[rows] = np.repeat(split, counts) * directions
    return out


__all__ = [
    "ACTIVE_RELATIVE_GAP",
    "answer_of_x",
    "assemble_linear",
    "linear_equilibrium",
    "split_force_rows",
]
