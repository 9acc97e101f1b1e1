r"""Joint stiffness in a tree, by superposition: the play's answer plus each spring's deflection.

In a tree (no loop joints) no contact and no closure equation reads an elastic unknown
(:mod:`.small_displacement`: a tree joint's contacts read its play :math:`B_k t_k` only), so the
potential :math:`g_t^T t + g_e^T e + \tfrac12 \sum_i k_i e_i^2` splits: the play t is the answer of
the same tree with rigid joints (whatever engine the plan gives it: closed forms, the compiled
kernel, a cone solver), and each elastic unknown is at its own minimum,

.. math::  e_i = -g_i / k_i ,

the deflection of a spring under the joint's reaction (the virtual joint method). The answer is
assembled on the mechanism's own geometry and measured there (statics with the springs' forces),
like any other.
"""

from __future__ import annotations

import time
from dataclasses import replace
from typing import Any

import numpy as np

from ..model.stiffness import elastic
from .kkt import RESIDUAL_NAMES
from .linear_answer import answer_of_x
from .method import Method
from .prepared import PreparedGeometry
from .result import Equilibrium
from .small_displacement import tree_joint_basis


def play_twin(mechanism: Any) -> Any:
    """The mechanism's rigid twin (:meth:`~clearance_pin.mechanism.Mechanism.without_stiffness`),
    built once and kept in its cache."""
    cache = mechanism.cache
    if cache.play_twin is None:
        cache.play_twin = mechanism.without_stiffness()
    return cache.play_twin


def superposed(
    mechanism: Any, prepared: PreparedGeometry, loads: Any, play: Equilibrium, started: float
) -> Equilibrium:
    """The answer of ``mechanism`` (a tree with stiffness, prepared at the configuration of
    ``prepared``) for ``loads`` from ``play``, the answer of its rigid twin
    (:meth:`~clearance_pin.mechanism.Mechanism.without_stiffness`) for the same loads."""
    problem = prepared.problem(loads)
    maps = prepared.maps
    x = np.zeros(prepared.size_x)
    elastic = maps.stiffness > 0.0
    x[~elastic] = np.concatenate(
        [tree_joint_basis(joint).T @ play.torsors[joint.name] for joint in mechanism.tree_joints]
    )
    x[elastic] = -problem.gradient[elastic] / maps.stiffness[elastic]
    contacts = prepared.geometry.contacts
    forces = np.zeros((len(contacts), 3))
    carried = np.zeros(len(contacts))
    for index, (constraint, contact) in enumerate(zip(contacts, play.contacts)):
        lever = constraint.contact.lever
        moment = contact.moment
        forces[index] = moment / lever if lever and moment is not None else contact.force
        carried[index] = float(np.linalg.norm(forces[index]))
    force_rows = forces.reshape(-1)[prepared.terms.scatter]
    gaps, _ = prepared.contact_state(x, np.zeros(len(contacts)), np.ones(len(contacts)), 0.0)
    residuals = {name: play.residuals[name] for name in RESIDUAL_NAMES if name in play.residuals}
    status, method, solver_status = play.status, play.method, play.solver_status
    alone = status == "indeterminate" and bool(np.any(x[elastic]))
    if alone:
        # nothing moves in the play (none, or no load on it) but the springs deflect: answered
        # by the springs' closed form alone
        status, method = "optimal", Method.CLOSED_FORM
    solver_status = superposed_status(solver_status, alone)
    answer = answer_of_x(
        prepared,
        problem,
        x,
        (gaps, force_rows, carried),
        (status, method, solver_status, play.iterations, play.polished),
        (play.build_time, time.perf_counter() - started),
        residuals,
        loads,
        (),
        play.output_points,
    )
    return replace(answer, free_motions=play.free_motions)  # the play's, flat directions named


def superposed_status(play: str, alone: bool) -> str:
    """The solver status of a superposed answer from its play's: the springs alone (nothing
    moves in the play) or by superposition."""
    return (
        f"springs alone ({play} in the play)"
        if alone
        else f"{play}; springs by superposition (a tree)"
    )


def spring_deflections(
    joint: Any, reactions: np.ndarray, turns: np.ndarray | None = None
) -> np.ndarray:
    r"""The deflection (N, 6) [m, rad] of ``joint``'s spring under its reactions (N, 6) [N, N m]
    (the parent's wrench on the child, clearance frame): :math:`e = -K^+ W`, K's inverse on the
    directions that deflect. In a tree this is the :math:`e_i = -g_i / k_i` of the module
    docstring, from the joint's reactions (a batch reads them from the statics of each joint's
    subtree, :func:`.batch_reactions.tree_reactions`). ``turns`` (N or 1, 3, 3): per case the
    part's rotation R relative to its housing (:func:`~clearance_pin.model.stiffness.
    part_rotation`) for a K stated in the housing's frame, :math:`e = -G^T K^+ G W` with
    :math:`G = \mathrm{diag}(R, R)`; None: K in the clearance frame as it is."""
    directions, stiffnesses = elastic(joint.clearance)
    compliance = directions @ (directions.T / stiffnesses[:, None])
    if turns is None:
        deflections: np.ndarray = -reactions @ compliance.T
        return deflections
    housing = turned(turns, reactions)  # G W: the wrench in the housing's axes
    return turned(turns, -housing @ compliance.T, back=True)


def turned(turns: np.ndarray, rows: np.ndarray, back: bool = False) -> np.ndarray:
    """Rows (N, 6) of torsors or wrenches turned by G = diag(R, R) per case (``back``: by
    G^T), ``turns`` (N or 1, 3, 3)."""
    spec = "kji,kj->ki" if back else "kij,kj->ki"
    count = max(len(turns), len(rows))
    turns = np.broadcast_to(turns, (count, 3, 3))
    rows = np.broadcast_to(rows, (count, 6))
    out: np.ndarray = np.concatenate(
        [np.einsum(spec, turns, rows[:, :3]), np.einsum(spec, turns, rows[:, 3:])], axis=1
    )
    return out


__all__ = ["play_twin", "spring_deflections", "superposed", "superposed_status"]
