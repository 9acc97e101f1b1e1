r"""The accuracy a robot's model predicts at the poses of the ISO 9283 test cube, split by source
(docs/identification.md, section 5).

ISO 9283 (Manipulating industrial robots, performance criteria and related test methods) tests
pose accuracy at five points of a cube placed in the most used part of the workspace, its
edges parallel to the base axes: P1 at the cube's centre and P2-P5 on one of its diagonal
planes, on the plane's diagonals at 10 % of the diagonal's length from its corners, all with
the orientation of P1, the robot under its rated payload.

Placement here: the cube is centred on the measured point at the robot's nominal pose (the
clearance file's ``q``: state there the pose the robot works around), the tool keeping its
orientation there; its diagonal plane is the one through the edges (-a/2, -a/2) and
(+a/2, +a/2) of (y, z), so its corners are c + (a/2)(-1, -1, -1), (+1, -1, -1), (+1, +1, +1),
(-1, +1, +1), and :math:`P_{k+1} = c + 0.8\,(C_k - c)` (10 % of the diagonal :math:`a\sqrt3`
from corner :math:`C_k`). The edge a is the largest of :math:`L/2, 0.8 L/2, 0.8^2 L/2, \ldots`
(L: the robot's length scale) at which every point is reached, by damped least squares on the
driven joints within their limits, to 1e-10 m and 1e-10 rad; or given.

At each pose the model (the identified one, or any) is solved under the rated payload hung at
the point (and the arm's own weight when gravity is on) by the accuracy map
(:func:`~clearance_pin.accuracy.accuracy_map`), whose per-joint shares are summed by source:
``play`` (the bearings'), ``backlash`` and ``compliance`` (the drives' and the bearings').
The predicted error is the point's displacement from where the controller puts it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from ..errors import ArgumentError, SolverError
from ..model.loads import PointForce
from .differences import MeasuredPoint, measured_point
from .measurements import STANDARD_GRAVITY

if TYPE_CHECKING:
    from ..model.mechanism_parts import MechanismParts as Mechanism

SOURCES = ("play", "backlash", "compliance")
CORNERS = np.array([[-1, -1, -1], [1, -1, -1], [1, 1, 1], [-1, 1, 1]], dtype=float)
REACHED = 1e-10  # [m, rad]: the inverse kinematics' tolerance

__all__ = ["Iso9283Prediction", "Cube", "iso9283_prediction", "iso9283_cube"]


@dataclass(frozen=True)
class Cube:
    """The ISO 9283 test cube's five poses.

    Attributes:
        centre: the cube's centre, P1 [m] (world).
        edge: its edge a [m].
        positions: P1-P5 (5, 3) [m].
        orientation: the point's frame's orientation at every pose (3, 3).
        configurations: the robot's pose at each (5, nq).
    """

    centre: np.ndarray
    edge: float
    positions: np.ndarray
    orientation: np.ndarray
    configurations: np.ndarray


def cube_positions(centre: np.ndarray, edge: float) -> np.ndarray:
    """P1-P5 (5, 3) of a cube of ``edge`` centred at ``centre`` (module docstring)."""
    corners = centre + 0.5 * edge * CORNERS
    return np.vstack([centre, centre + 0.8 * (corners - centre)])


def iso9283_cube(
    mechanism: Mechanism, point: Any, edge: float | None = None, q: Any = None
) -> Cube:
    """The test cube centred on ``point`` at pose ``q`` (default: nominal); ``edge`` [m]
    (default: the largest reachable, module docstring)."""
    where = point if isinstance(point, MeasuredPoint) else measured_point(mechanism, point)
    model = mechanism.model
    data = model.createData()
    start = mechanism.q_nominal if q is None else np.asarray(q, dtype=float)
    position, rotation, _ = _point(model, data, where, start)
    edges = [float(edge)] if edge is not None else [
        0.5 * mechanism.length_scale() * 0.8**k for k in range(12)
    ]  # fmt: skip
    if edge is not None and not (np.isfinite(edge) and edge > 0.0):
        raise ArgumentError("edge", "a cube edge > 0 [m]", edge)
    driven = [
        model.joints[j.joint_id].idx_v
        for j in mechanism.tree_joints
        if j.driven and model.joints[j.joint_id].nq == 1
    ]
    for size in edges:
        targets = cube_positions(position, size)
        poses = [_reach(mechanism, data, where, start, t, rotation, driven) for t in targets]
        if all(p is not None for p in poses):
            return Cube(position, size, targets, rotation, np.array(poses))
    raise SolverError(
        f"no ISO 9283 cube of edge {edges[-1]:.3g} m or more is reachable around the point's "
        "nominal position with its nominal orientation (give a smaller edge)",
        "unreachable",
    )


def _point(
    model: pin.Model, data: pin.Data, point: MeasuredPoint, q: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(position, orientation, 6 x nv Jacobian: translation rows then rotation rows, world axes)
    of the point at ``q``."""
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    placed = data.oMf[point.frame_id]
    jacobian = np.array(
        pin.getFrameJacobian(model, data, point.frame_id, pin.LOCAL_WORLD_ALIGNED)
    ).reshape(6, model.nv)  # (a one-coordinate model's comes back flat)
    r = placed.rotation @ point.offset
    jacobian[:3] -= pin.skew(r) @ jacobian[3:]
    return placed.translation + r, placed.rotation.copy(), jacobian


def _reach(
    mechanism: Mechanism,
    data: pin.Data,
    point: MeasuredPoint,
    start: np.ndarray,
    target: np.ndarray,
    orientation: np.ndarray,
    driven: list[int],
) -> np.ndarray | None:
    """Damped least squares from ``start`` to the point at ``target`` with ``orientation``,
    the driven joints within their limits; None when it does not get there."""
    model = mechanism.model
    q = start.copy()
    low, high = model.lowerPositionLimit, model.upperPositionLimit
    for _ in range(500):
        position, rotation, jacobian = _point(model, data, point, q)
        error = np.concatenate([target - position, pin.log3(orientation @ rotation.T)])
        if np.all(np.abs(error[:3]) < REACHED) and np.all(np.abs(error[3:]) < REACHED):
            return q
        j = jacobian[:, driven]
        damping = 1e-6 * min(1.0, float(error @ error) * 1e4)  # Levenberg-Marquardt-like
        step = j.T @ np.linalg.solve(j @ j.T + damping * np.eye(6), error)
        step *= min(1.0, 0.2 / max(float(np.max(np.abs(step))), 1e-300))  # at most 0.2 rad
        velocity = np.zeros(model.nv)
        velocity[driven] = step
        q = pin.integrate(model, q, velocity)
        q = np.where(np.isfinite(low), np.maximum(q, low), q)
        q = np.where(np.isfinite(high), np.minimum(q, high), q)
    return None


@dataclass(frozen=True)
class Iso9283Prediction:
    """The predicted position error at P1-P5 under the rated payload, by source.

    Attributes:
        cube: the test cube.
        payload: the rated payload [kg].
        errors: source (``"play"``, ``"backlash"``, ``"compliance"``) -> its displacement of
            the point at each pose (5, 3) [m], world axes.
        total: their sum (5, 3) [m].
        ok: every pose's answer verified (5,).
    """

    cube: Cube
    payload: float
    errors: dict[str, np.ndarray]
    total: np.ndarray
    ok: np.ndarray

    def to_dict(self) -> dict[str, Any]:
        return {
            "centre_m": self.cube.centre.tolist(),
            "edge_m": self.cube.edge,
            "payload_kg": self.payload,
            "poses": [
                {
                    "name": f"P{k + 1}",
                    "position_m": self.cube.positions[k].tolist(),
                    "configuration": self.cube.configurations[k].tolist(),
                    "error_m": float(np.linalg.norm(self.total[k])),
                    "error_vector_m": self.total[k].tolist(),
                    "by_source_m": {
                        source: float(np.linalg.norm(values[k]))
                        for source, values in self.errors.items()
                    },
                    "verified": bool(self.ok[k]),
                }
                for k in range(len(self.total))
            ],
        }

    def table(self) -> str:
        lines = [
            f"ISO 9283 test cube: centre {np.round(self.cube.centre, 4).tolist()} m, edge "
            f"{self.cube.edge:.3g} m, rated payload {self.payload:g} kg; predicted position error [um]",
            f"{'pose':<5} {'total':>9} " + " ".join(f"{s:>10}" for s in SOURCES),
        ]
        for k in range(len(self.total)):
            parts = " ".join(f"{np.linalg.norm(self.errors[s][k]) * 1e6:10.2f}" for s in SOURCES)
            lines.append(f"P{k + 1:<4} {np.linalg.norm(self.total[k]) * 1e6:9.2f} {parts}")
        return "\n".join(lines)


def iso9283_prediction(
    mechanism: Mechanism,
    point: Any,
    payload: float,
    cube: Cube | None = None,
    gravity: bool | None = None,
) -> Iso9283Prediction:
    """The position error ``mechanism`` predicts at the ISO 9283 poses (module docstring)
    under ``payload`` [kg] hung at the point (gravity: the arm's own weight, as
    :func:`~.identify.identify`)."""
    if not (np.isfinite(payload) and payload >= 0.0):
        raise ArgumentError("payload", "a rated payload >= 0 [kg]", payload)
    where = point if isinstance(point, MeasuredPoint) else measured_point(mechanism, point)
    cube = iso9283_cube(mechanism, where) if cube is None else cube
    weight = [0.0, 0.0, -STANDARD_GRAVITY * float(payload)]
    loads = [PointForce(where.link, weight, where.link_point)] if payload else []
    amap = mechanism.accuracy(where.frame, cube.configurations, payloads=[loads], gravity=gravity)
    model = mechanism.model
    data = model.createData()
    offsets = np.zeros((len(cube.configurations), 3))  # frame origin -> point, world axes
    for k, q in enumerate(cube.configurations):
        pin.forwardKinematics(model, data, q)
        offsets[k] = pin.updateFramePlacement(model, data, where.frame_id).rotation @ where.offset
    errors = {source: np.zeros((len(offsets), 3)) for source in SOURCES}
    by_source = {"play": "play", "backlash": "backlash"}
    for source, shares in amap.contributions.items():
        target = by_source.get(source, "compliance")
        for joint, share in shares.items():
            turned = amap.rotation_contributions[source][joint][:, 0]
            errors[target] += share[:, 0] + np.cross(turned, offsets)
    for source, turns in amap.rotation_contributions.items():  # a turn without a share
        target = by_source.get(source, "compliance")
        for joint, turned in turns.items():
            if joint not in amap.contributions.get(source, {}):
                errors[target] += np.cross(turned[:, 0], offsets)
    total = sum(errors.values(), np.zeros((len(offsets), 3)))
    return Iso9283Prediction(cube, float(payload), errors, total, amap.ok[:, 0].copy())
