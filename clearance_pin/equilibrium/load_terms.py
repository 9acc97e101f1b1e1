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

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from ..errors import LoadError
from ..model.loads import Gravity, Load, PointForce, Torque
from ..numerics import cross


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
    model: pin.Model, placed, loads: tuple[Load, ...], link_frames: dict[str, int]
) -> dict[int, BodyLoad]:
    """Gather loads per body at a configuration: the one gathering of loads of both models.

    Args:
        placed: anything with ``oMi``, the world placement of every joint frame (a
            :class:`~clearance_pin.mechanism.Configuration`, a placed ``pin.Data``).
        link_frames: URDF link name -> Pinocchio BODY frame id.
    """
    acc: dict[int, list[np.ndarray]] = {}

    def entry(body: int) -> list[np.ndarray]:
        return acc.setdefault(body, [np.zeros(3), np.zeros((3, 3)), np.zeros(3), np.zeros(6)])

    for load in loads:
        if isinstance(load, Gravity):
            for body in range(1, model.njoints):
                inertia = model.inertias[body]
                if inertia.mass > 0.0:
                    _add_force(
                        entry(body),
                        placed.oMi[body],
                        inertia.lever,
                        inertia.mass * load.acceleration,
                    )
            continue
        if load.link not in link_frames:
            known = ", ".join(sorted(link_frames))
            raise LoadError(f"on {load.link!r}", f"unknown link; the model's links are: {known}")
        frame = model.frames[link_frames[load.link]]
        body = frame.parentJoint
        if body == 0:
            continue  # a load on the fixed ground does no work
        if isinstance(load, PointForce):
            point_in_body = frame.placement.act(np.asarray(load.point))
            _add_force(entry(body), placed.oMi[body], point_in_body, np.asarray(load.force))
        elif isinstance(load, Torque):
            slot = entry(body)
            slot[2] += load.torque
            slot[3][3:] += load.torque
    return {
        body: BodyLoad(body, f.copy(), g.copy(), c.copy(), w.copy())
        for body, (f, g, c, w) in acc.items()
    }


def _add_force(
    slot: list[np.ndarray], oMb: pin.SE3, point_in_body: np.ndarray, force: np.ndarray
) -> None:
    world_point = oMb.act(point_in_body)
    slot[0] += force
    slot[1] += np.outer(force, point_in_body)
    slot[3][:3] += force
    slot[3][3:] += cross(world_point, force)


def load_gradient(body_loads: dict[int, BodyLoad], body_twist: list[np.ndarray]) -> np.ndarray:
    r"""Gradient g of the small-displacement potential :math:`\mathcal{V}(x) = g^T x` [J per unit x]."""
    n = body_twist[0].shape[1]
    gradient = np.zeros(n)
    for body, load in body_loads.items():
        gradient -= body_twist[body].T @ load.wrench
    return gradient
