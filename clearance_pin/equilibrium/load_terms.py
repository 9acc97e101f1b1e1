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

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Protocol, TypedDict

import numpy as np
import pinocchio as pin

from ..errors import LoadError
from ..model.loads import Gravity, Load, PointForce, Torque
from ..numerics import Array, cross

# a loaded link: (body, R, t of the link frame in the body, R, t of the body in the world)
LinkPlacement = tuple[int, Array, Array, Array, Array]
# a body with mass: (body, mass [kg], centre of mass in the body [m], R, t of the body)
BodyMass = tuple[int, float, Array, Array, Array]


class Placed(Protocol):
    """Anything with ``oMi``, the world placement of every joint frame (a
    :class:`~clearance_pin.mechanism.Configuration`, a placed ``pin.Data``)."""

    @property
    def oMi(self) -> Sequence[pin.SE3]: ...


class PlacementMemo(TypedDict, total=False):
    """What :func:`gather_body_loads` keeps for one configuration: the placements of the loaded
    links (link name -> placement, None on the ground) and the bodies with mass."""

    links: dict[str, LinkPlacement | None]
    masses: list[BodyMass]


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
    model: pin.Model,
    placed: Placed,
    loads: Sequence[Load],
    link_frames: Mapping[str, int],
    memo: PlacementMemo | None = None,
) -> dict[int, BodyLoad]:
    """Gather loads per body at a configuration: the one gathering of loads of both models.

    Args:
        placed: anything with ``oMi``, the world placement of every joint frame (a
            :class:`~clearance_pin.mechanism.Configuration`, a placed ``pin.Data``).
        link_frames: URDF link name -> Pinocchio BODY frame id.
        memo: a dict kept by the caller for one configuration (the placements of the loaded
            links and of the bodies' centres of mass are read from it after the first call).
    """
    memo = PlacementMemo() if memo is None else memo
    acc: dict[int, list[np.ndarray]] = {}

    def entry(body: int) -> list[np.ndarray]:
        slot = acc.get(body)
        if slot is None:
            slot = acc[body] = [np.zeros(3), np.zeros((3, 3)), np.zeros(3), np.zeros(6)]
        return slot

    for load in loads:
        if isinstance(load, Gravity):
            for body, mass, lever, rotation, origin in _masses(model, placed, memo):
                _add_force(entry(body), rotation, origin, lever, mass * load.acceleration)
            continue
        placement = _link(model, placed, load.link, link_frames, memo)
        if placement is None:
            continue  # a load on the fixed ground does no work
        body, frame_rotation, frame_origin, rotation, origin = placement
        if isinstance(load, PointForce):
            point_in_body = frame_rotation @ load.point + frame_origin
            _add_force(entry(body), rotation, origin, point_in_body, load.force)
        elif isinstance(load, Torque):
            slot = entry(body)
            slot[2] += load.torque
            slot[3][3:] += load.torque
    return {body: BodyLoad(body, f, g, c, w) for body, (f, g, c, w) in acc.items()}


def _link(
    model: pin.Model,
    placed: Placed,
    link: str,
    link_frames: Mapping[str, int],
    memo: PlacementMemo,
) -> LinkPlacement | None:
    """(body, R, t of the link frame in the body, R, t of the body in the world), None on the
    ground; memoised."""
    links = memo.setdefault("links", {})
    if link not in links:
        if link not in link_frames:
            known = ", ".join(sorted(link_frames))
            raise LoadError(f"on {link!r}", f"unknown link; the model's links are: {known}")
        frame = model.frames[link_frames[link]]
        body = frame.parentJoint
        links[link] = (
            None
            if body == 0
            else (
                body,
                frame.placement.rotation.copy(),
                frame.placement.translation.copy(),
                placed.oMi[body].rotation.copy(),
                placed.oMi[body].translation.copy(),
            )
        )
    return links[link]


def _masses(model: pin.Model, placed: Placed, memo: PlacementMemo) -> list[BodyMass]:
    """(body, mass [kg], centre of mass in the body [m], R, t of the body) of every body with
    mass; memoised."""
    if "masses" not in memo:
        memo["masses"] = [
            (
                body,
                model.inertias[body].mass,
                np.array(model.inertias[body].lever),
                placed.oMi[body].rotation.copy(),
                placed.oMi[body].translation.copy(),
            )
            for body in range(1, model.njoints)
            if model.inertias[body].mass > 0.0
        ]
    return memo["masses"]


def _add_force(
    slot: list[np.ndarray],
    rotation: np.ndarray,
    origin: np.ndarray,
    point_in_body: np.ndarray,
    force: np.ndarray,
) -> None:
    world_point = rotation @ point_in_body + origin
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
