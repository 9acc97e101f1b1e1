r"""How far a small-displacement solution sits off the true clearance boundaries.

Place every part rigidly at the linear solution (:math:`oM_b = \exp(\xi_b)\, oM_{b0}`), read each
joint's true relative placement :math:`(R, p)` of its child clearance frame in its parent clearance
frame, and evaluate the contact conditions on the true contact points, :math:`d = p + R r - r`:

.. math::  e_j = \big|\, \|d_{sel}\| - c_j \big| \ \text{(contacts)}, \qquad
           e_j = \max(\|d_{sel}\| - c_j, 0) \ \text{(free points)}

The largest :math:`e_j` [m] measures how far the linear solution violates the true contact
conditions. A solution can also slide along the boundary at second order without violating it,
so the estimate also takes the dropped terms themselves, rotation x displacement per joint.
It is an order-of-magnitude estimate (tested against the exact model on the paper's cases), not a
bound. ``Mechanism.solve(exact="auto")`` runs the exact model only when it exceeds the requested
accuracy.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from .poses import clearance_frames


def relative_placements(equilibrium) -> dict[str, pin.SE3]:
    """Child clearance frame in the parent clearance frame, per joint, at the solved pose."""
    return {name: frames.relative for name, frames in clearance_frames(equilibrium).items()}


def boundary_errors(equilibrium) -> dict[str, float]:
    """Per contact ``joint:point``: distance [m] of the true contact point from where the model
    puts it (on the boundary for contacts; inside it for free points)."""
    relative = relative_placements(equilibrium)
    errors = {}
    for contact in equilibrium.contacts:
        joint = equilibrium.mechanism.joints[contact.joint]
        point = next(p for p in joint.clearance.contacts if p.name == contact.point)
        placement = relative[contact.joint]
        r = np.asarray(point.point)
        d = (placement.translation + placement.rotation @ r - r)[list(point.components)]
        reach = float(np.linalg.norm(d)) if point.shape == "norm" else abs(float(d[0]))
        if contact.active:
            errors[contact.label] = abs(reach - point.bound)
        else:
            errors[contact.label] = max(reach - point.bound, 0.0)
    return errors


def second_order_terms(equilibrium) -> dict[str, float]:
    r"""Per joint: :math:`\|\Omega_k\| \max_j \|V_k + \Omega_k \times r_j\|` [m], the size of the
    rotation x displacement terms the linear model drops (over the joint's contact points)."""
    terms = {}
    for name, joint in equilibrium.mechanism.joints.items():
        torsor = equilibrium.torsors[name]
        rotation = float(np.linalg.norm(torsor[3:]))
        reach = max(
            (
                float(np.linalg.norm(torsor[:3] + np.cross(torsor[3:], point.point)))
                for point in joint.clearance.contacts
            ),
            default=float(np.linalg.norm(torsor[:3])),
        )
        terms[name] = rotation * reach
    return terms


def linear_model_error(equilibrium) -> float:
    """Estimate [m] of the small-displacement model's error at its solution: the larger of the
    boundary errors and the dropped second-order terms (see module docstring)."""
    boundary = max(boundary_errors(equilibrium).values(), default=0.0)
    return max(boundary, max(second_order_terms(equilibrium).values(), default=0.0))
