"""Synthetic measurements for the identification tests and benchmark, from Pinocchio's Jacobians
alone (nothing of clearance_pin): under a force F at a point of a frame, at pose q, drive j
turns by sign(tau_j) b_j / 2 + tau_j / k_j, tau = J^T F - g(q) (the load's generalised force,
g the arm's gravity torque from computeGeneralizedGravity when the arm's weight is on), and the
point moves by sum_j J_j (that), J the point's Jacobian (LOCAL_WORLD_ALIGNED, the frame's
Jacobian carried to the point: v_p = v + omega x r)."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

G = 9.80665  # [m/s^2], a hung mass's weight
ZERO = 1e-9  # |tau| below this share of the case's torque scale takes up no backlash side


def point_jacobian(model, data, frame: int, offset: np.ndarray, q: np.ndarray):
    """(the point's world position, its 6 x nv Jacobian: translation rows, rotation rows)."""
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    jacobian = pin.getFrameJacobian(model, data, frame, pin.LOCAL_WORLD_ALIGNED)
    r = data.oMf[frame].rotation @ offset
    skew = np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])
    translation = jacobian[:3] - skew @ jacobian[3:]
    return data.oMf[frame].translation + r, np.vstack([translation, jacobian[3:]])


def measurements(
    model, frame: str, offset, joints: list[str], backlash, stiffness, poses, forces,
    gravity: bool = False, noise: float = 0.0, seed: int = 0, rotations: bool = False,
):  # fmt: skip
    """Rows (pose index, q, force, measured position [, rotation vector]) of every pose (P, nq)
    under every force of ``forces`` (L, 3) [N] at the point; ``backlash`` [rad], ``stiffness``
    [N m/rad] per joint of ``joints``; the position in a frame offset from the world by a random
    translation per run, plus Gaussian noise [m] (seeded)."""
    data = model.createData()
    frame_id = model.getFrameId(frame)
    offset = np.asarray(offset, float)
    columns = [model.joints[model.getJointId(name)].idx_v for name in joints]
    rng = np.random.default_rng(seed)
    device = rng.uniform(-1.0, 1.0, 3)
    rows = {"pose": [], "q": [], "force": [], "position": [], "rotation": []}
    reach = 2.0
    for p, q in enumerate(poses):
        position, jacobian = point_jacobian(model, data, frame_id, offset, q)
        weight = pin.computeGeneralizedGravity(model, data, q) if gravity else np.zeros(model.nv)
        rotation = data.oMf[frame_id].rotation
        for force in forces:
            tau = jacobian[:3].T @ force - weight
            scale = np.linalg.norm(force) * reach + np.max(np.abs(tau[columns]))
            moved = np.zeros(6)
            for j, column in enumerate(columns):
                t = tau[column]
                side = np.sign(t) if abs(t) > ZERO * scale else 0.0
                moved += jacobian[:, column] * (side * backlash[j] / 2 + t / stiffness[j])
            rows["pose"].append(p)
            rows["q"].append(q)
            rows["force"].append(force)
            rows["position"].append(device + position + moved[:3] + rng.normal(0, noise, 3))
            turned = pin.exp3(moved[3:]) @ rotation
            rows["rotation"].append(pin.log3(turned))
    out = {key: np.array(value) for key, value in rows.items()}
    if not rotations:
        out.pop("rotation")
    return out


def columns(model, frame: str, offset, joints: list[str], poses, forces) -> np.ndarray:
    """d position / d (b_j, c_j) of every row (pose-major, then force), (M, 3, 2 J): b_j's column
    J_j sign(tau_j) / 2, c_j's J_j tau_j (c = 1/k), the arm's weight off."""
    data = model.createData()
    frame_id = model.getFrameId(frame)
    indices = [model.joints[model.getJointId(name)].idx_v for name in joints]
    out = []
    for q in poses:
        _, jacobian = point_jacobian(model, data, frame_id, np.asarray(offset, float), q)
        for force in forces:
            tau = jacobian[:3].T @ force
            scale = np.linalg.norm(force) * 2.0 + np.max(np.abs(tau[indices]))
            row = np.zeros((3, 2 * len(indices)))
            for j, column in enumerate(indices):
                side = np.sign(tau[column]) if abs(tau[column]) > ZERO * scale else 0.0
                row[:, 2 * j] = jacobian[:3, column] * side / 2
                row[:, 2 * j + 1] = jacobian[:3, column] * tau[column]
            out.append(row)
    return np.array(out)
