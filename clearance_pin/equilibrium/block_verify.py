r"""Verification of closed-form answers (:mod:`.blocks`), vectorised over cases, as a single solve
verifies its own: the same measured quantities and the same tolerances.

In the reduced programme of :mod:`.reduction` (y = Q^T x / Z, images :math:`v = P y + o`):

- KKT (dimensionless): stationarity :math:`\lVert f + \sum_j \lambda_j \nabla\phi_j \rVert_\infty`
  with :math:`\sum_j \lambda_j \nabla\phi_j = (\lambda_{j(i)} w_i)_i^T P`, :math:`w_i = 2 v_i`
  (ball, disc) or :math:`s_j` (slab side); feasibility :math:`\max(\phi_j, 0)`, complementarity
  :math:`|\lambda_j \phi_j|`, dual infeasibility :math:`\max(-\lambda_j, 0)`, all at most the
  single solve's acceptance (:func:`.cone_solver.acceptance`), multipliers >= -1e-12 and every
  contact within 1e-13 of its set;
- statics in N (:meth:`.prepared.PreparedGeometry.statics_residual`) of the contact forces
  :math:`f_j = -2\sigma\lambda_j (o_j + S_j x)/c_j^2` (ball, disc) or
  :math:`-\sigma\lambda_j s_j / c_j` (slab) [N], at most 1e-8, and penetration at most 1e-9 of
  the play (:class:`.residuals.Tolerances`).

A case that fails any of them is solved by the general path.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from ..numerics import Array, Mask
from . import kkt
from .blocks import BlockStructure, block_structure, closed_forms, reduced_unknowns
from .cone_solver import acceptance
from .kkt import RESIDUAL_NAMES, UNLOADED, StackedContacts
from .lazy import LazySequence
from .linear_answer import assemble_linear
from .method import Method
from .reduction import ReducedProblem, describe_motion
from .residuals import verified
from .tree_trajectory import centre_map, tree_maps

if TYPE_CHECKING:
    from ..model.loads import Load
    from .prepared import PreparedGeometry
    from .result import Equilibrium

SOLVER_STATUS = "closed form"


@dataclass(frozen=True)
class Verification:
    """Per case: verified (N,), the KKT table (N, 4) (:data:`RESIDUAL_NAMES`), statics (N,),
    the load neglected on the joints left unloaded (N,) (:func:`kkt_table`)."""

    verified: Mask
    table: Array
    statics: Array
    neglected: Array


def kkt_table(
    prepared: PreparedGeometry,
    structure: BlockStructure,
    objectives: Array,
    y: Array,
    multipliers: Array,
    signs: Array,
    unloaded: Mask | None = None,
) -> tuple[Mask, Array, Array]:
    """The reduced programme's KKT test of N answers (module docstring, first item): objectives
    f (N, r), reduced unknowns y (N, r), multipliers and slab sides (N, m), the groups the closed
    forms left unloaded (N, G); returns (passed (N,), the table (N, 4) of
    :data:`RESIDUAL_NAMES`, the load neglected (N,)).

    A group whose contacts would carry at most 1e-9 of the largest force is left at the centre
    of its play with no force (:func:`.blocks.closed_forms`): its share of the load, at most
    :data:`~.kkt.UNLOADED` of |f| = 1, is neglected (as the share along motions nothing blocks
    is), so stationarity is measured on the other unknowns and the neglected share is returned
    (a torque along a driven joint's axis, turned by a rotation matrix's round-off, leaves 3e-12
    of the load on that journal: it failed the 1e-12 stationarity test)."""
    stack: StackedContacts = prepared.geometry.stack
    image = y @ stack.matrix.T  # + o: zero for a tree (blocks.block_structure)
    squares = (image * image) @ structure.row_sums  # the stack's rows and contacts
    # column gathers by np.take (C-ordered: a [:, index] gather is not, and slows every
    # product after it) and selections by masks (np.where over broadcast masks is slower)
    norm, row_norm = stack.is_norm, stack.row_is_norm
    phi = squares * norm + np.abs(np.take(image, stack.starts, axis=1)) * ~norm - 1.0
    weights = image * (2.0 * row_norm) + np.take(signs, stack.row_contact, axis=1) * ~row_norm
    pull = (np.take(multipliers, stack.row_contact, axis=1) * weights) @ stack.matrix
    residual = np.abs(objectives + pull)
    neglected = np.zeros(len(y))
    columns = _unloaded_columns(structure, unloaded)
    if columns is not None:
        neglected = (residual * columns).max(axis=1, initial=0.0)
        residual = residual * ~columns
    table = kkt.kkt_table(residual, phi, multipliers)
    accept = acceptance(prepared.geometry.conditioning)
    passed = kkt.kkt_passed(table, phi, multipliers, accept) & (neglected <= UNLOADED)
    return passed, table, neglected


def _unloaded_columns(structure: BlockStructure, unloaded: Mask | None) -> Mask | None:
    """The unknowns of the unloaded groups (N, r), or None when there are none or the reduced
    unknowns are not the groups' own (a basis other than the identity: free motions)."""
    if unloaded is None or not unloaded.any() or not structure.plain:
        return None
    owner = np.zeros((len(structure.group_columns), structure.size_x))
    for group, columns in enumerate(structure.group_columns):
        owner[group, columns] = 1.0
    return (unloaded @ owner) > 0.0


def verify(
    prepared: PreparedGeometry,
    structure: BlockStructure,
    objectives: Array,
    y: Array,
    x: Array,
    multipliers: Array,
    signs: Array,
    sigmas: Array,
    gradients: Array,
    load_sizes: Array,
    unloaded: Mask | None = None,
) -> Verification:
    """Verify N answers (module docstring) of the geometry of ``prepared`` and ``structure``
    (:func:`.blocks.block_structure`, its rows stacked as the geometry's): objectives f (N, r),
    reduced unknowns y (N, r),
    unknowns x (N, n), multipliers and slab sides (N, m), objective scales (N,) [J], gradients
    g (N, n), load sizes (N,) [J], the groups left unloaded (N, G) (:func:`kkt_table`)."""
    passed, table, neglected = kkt_table(
        prepared, structure, objectives, y, multipliers, signs, unloaded
    )
    terms = prepared.terms
    rows = terms.contact_of_row
    x_image = x @ terms.contact_rows.T  # + offsets: zero for a tree
    gaps = prepared.bounds - np.sqrt((x_image * x_image) @ structure.row_sums)
    forces = (sigmas[:, None] * np.take(multipliers, rows, axis=1)) * (
        terms.norm_force * x_image + terms.slab_force * np.take(signs, rows, axis=1)
    )
    statics = np.reshape(prepared.statics_residual(gradients, forces, load_sizes), -1)
    violation = np.maximum(-gaps / prepared.bounds, 0.0).max(axis=1, initial=0.0)
    return Verification(
        passed & verified(statics, violation, table[:, 3]), table, statics, neglected
    )


def flat_notes(
    prepared: PreparedGeometry, structure: BlockStructure, unloaded: Mask
) -> Sequence[str]:
    """The free-motion notes of the groups left at zero (``unloaded`` (G,)): one per unknown, as
    :meth:`~.prepared.PreparedGeometry.flat_directions` words them."""
    columns = [int(c) for g in np.flatnonzero(unloaded) for c in structure.group_columns[g]]
    if not columns:
        return ()
    mechanism, size = prepared.mechanism, structure.size_x

    def notes() -> list[str]:
        return [
            "bounded but not loaded (the optimum is not unique; minimum-norm point returned): "
            + "; ".join(
                describe_motion(
                    prepared.maps, mechanism.joints, np.eye(size)[column], prepared.length
                )
            )
            for column in columns
        ]

    return LazySequence(notes)


def centred_problem(
    prepared: PreparedGeometry,
    structure: BlockStructure,
    problem: ReducedProblem,
    loads: Sequence[Load],
) -> ReducedProblem | None:
    r"""``problem`` with the gradient of ``loads`` formed from the wrenches about each joint's
    own centre (:mod:`.tree_trajectory`: :math:`g = W G`, W the body wrenches about the body
    origins, :attr:`.load_map.LoadMap.centred`), rather than from the wrenches about the
    world origin the general path reads (:meth:`.prepared.PreparedGeometry.problem`): the same
    gradient [J per unit], without the round-off of :math:`c \times F` subtracted from a moment
    about the origin; f = Q^T Z g / sigma and sigma [J] follow. None when no load works."""
    gradient_map = prepared.__dict__.get("_centred")
    if gradient_map is None:  # per configuration: the map from the centred wrenches to g
        placed = prepared.configuration.oMi
        rotations = np.array([m.rotation for m in placed])
        translations = np.array([m.translation for m in placed])
        maps = tree_maps(prepared.mechanism, prepared.geometry)
        gradient_map = prepared.__dict__["_centred"] = centre_map(maps, rotations, translations)
    mapped = prepared.load_map(loads)
    if mapped is None:
        return None
    built, _, vectors = mapped
    wrench = built.centred @ vectors
    gradient = wrench.reshape(-1) @ gradient_map
    scaled = gradient * structure.scale
    reduced = scaled if structure.plain else scaled @ structure.basis
    sigma = float(np.sqrt(reduced @ reduced))
    if not sigma > 0.0:
        return None
    return replace(problem, gradient=gradient, objective=reduced / sigma, objective_scale=sigma)


def closed_form_answer(
    prepared: PreparedGeometry,
    problem: ReducedProblem,
    loads: Sequence[Load],
    started: float,
) -> Equilibrium | None:
    """The verified closed-form equilibrium of one load (:mod:`.blocks`), or None when the
    closed forms do not apply to this mechanism or this load (the general path solves it).
    The closed form reads the gradient about the joint centres (:func:`centred_problem`)."""
    structure = block_structure(prepared.geometry, bool(prepared.mechanism.loop_joints))
    if structure is None or not problem.objective_scale > 0.0:
        return None
    centred = centred_problem(prepared, structure, problem, loads)
    if centred is None:
        return None
    problem = centred
    gradients = problem.gradient[None, :]
    sigmas = np.array([problem.objective_scale])
    closed = closed_forms(structure, gradients, sigmas)
    if not closed.decided[0]:
        return None
    y = reduced_unknowns(structure, closed.x)
    passed, table, neglected = kkt_table(
        prepared,
        structure,
        problem.objective[None, :],
        y,
        closed.multipliers,
        closed.signs,
        closed.unloaded,
    )
    if not passed[0]:
        return None
    if neglected[0] > problem.unblocked_share:  # reported with the share nothing blocks
        problem = replace(problem, unblocked_share=float(neglected[0]))
    # statics and penetration: measured by the answer itself (Equilibrium.ok below)
    answer = assemble_linear(
        prepared,
        problem,
        y[0],
        closed.multipliers[0],
        closed.signs[0],
        "optimal",
        Method.CLOSED_FORM,
        SOLVER_STATUS,
        0,
        True,
        0.0,
        time.perf_counter() - started,
        dict(zip(RESIDUAL_NAMES, map(float, table[0]))),
        loads,
        flat_notes(prepared, structure, closed.unloaded[0]),
    )
    return answer if answer.ok else None


__all__ = [
    "SOLVER_STATUS",
    "Verification",
    "centred_problem",
    "closed_form_answer",
    "flat_notes",
    "kkt_table",
    "verify",
]
