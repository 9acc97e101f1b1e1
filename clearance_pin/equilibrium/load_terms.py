r"""Loads as wrenches on bodies, for the small-displacement and the exact potential.

Small displacements: a force F at world point p and a torque C on body b do the work
:math:`F\cdot(v_b + \omega_b \times p) + C\cdot\omega_b = W_b \cdot \xi_b` with the wrench
:math:`W_b = (F, p \times F + C)` at the world origin, so :math:`\mathcal{V} = -\sum_b W_b\cdot\xi_b`.

Exact: body b placed at :math:`(R_b, t_b)` from its nominal :math:`(R_{b0}, t_{b0})`; the force F at
the body-frame point :math:`p_\ell` moves by :math:`(R_b - R_{b0}) p_\ell + t_b - t_{b0}`; a torque does
the work :math:`C\cdot\mathrm{vee}((R R_0^T - R_0 R^T)/2)` (the work of a couple of dead loads;
equal to :math:`C\cdot\Theta` up to third order). Per body this is a linear form in
:math:`(t_b, R_b)` with coefficients :math:`F_b` (3), :math:`G_b = \sum F p_\ell^T` (3, 3), :math:`C_b` (3).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from .load_table import body_wrenches, check_links, load_table

if TYPE_CHECKING:
    from ..model.mechanism_parts import MechanismParts as Mechanism


@dataclass(frozen=True)
class BodyLoad:
    """Loads gathered on one body (Pinocchio joint index ``body``), world axes, SI.

    Attributes:
        force: resultant force F_b [N], (3,).
        moment_matrix: G_b = sum F p_local^T [N m], (3, 3), p_local in the body (joint) frame.
        torque: resultant pure torque C_b [N m], (3,).
        wrench: (F, sum p x F + C) at the world origin [N, N m], (6,).
    """

    body: int
    force: np.ndarray
    moment_matrix: np.ndarray
    torque: np.ndarray
    wrench: np.ndarray


def gather_body_loads(
    mechanism: Mechanism, loads: Sequence[object], placements: Sequence[pin.SE3]
) -> dict[int, BodyLoad]:
    """The loads per body with the body frames at ``placements`` (every joint frame's world
    placement, ground first: a configuration's ``oMi`` or a moved pose), from the one reading
    of loads (:func:`.load_table.load_table`: a row per force, torque and body weight) and its
    wrench formula (:func:`.load_table.body_wrenches`); a LoadError names an unknown link."""
    check_links(mechanism, loads)
    table = load_table(mechanism, [tuple(loads)], False)
    rotations = np.array([placement.rotation for placement in placements])
    translations = np.array([placement.translation for placement in placements])
    centred, about = body_wrenches(
        table, rotations[None], translations[None], len(placements), False
    )
    gathered = {}
    for body in np.unique(table.body).tolist():
        rows = table.body == body
        force = table.force[rows]
        gathered[body] = BodyLoad(
            body,
            force.sum(axis=0),
            force.T @ table.point[rows],
            table.torque[rows].sum(axis=0),
            np.concatenate((centred[0, body, :3], about[0, body])),
        )
    return gathered


def load_gradient(body_loads: dict[int, BodyLoad], body_twist: list[np.ndarray]) -> np.ndarray:
    r"""Gradient g of the small-displacement potential :math:`\mathcal{V}(x) = g^T x` [J per unit x]."""
    n = body_twist[0].shape[1]
    gradient = np.zeros(n)
    for body, load in body_loads.items():
        gradient -= body_twist[body].T @ load.wrench
    return gradient
