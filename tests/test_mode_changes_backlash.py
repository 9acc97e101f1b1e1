"""A drive's backlash stop switching side is a mode change (issue 33 item 3): along a path where a
driven joint's load torque changes sign, the joint crosses its whole backlash at once and the
tool jumps. The references share no code with the solver: where the torque vanishes is the
root (brentq) of the joint's generalized load torque from Pinocchio's own
``computeGeneralizedGravity`` and frame Jacobian, and the jump is that Jacobian's column times
the backlash, |J_j| b (the small-displacement model moves the tool by J x at the nominal pose).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from scipy.optimize import brentq

import clearance_pin as cp
from clearance_pin.mode_changes import locate_changes
from clearance_pin.plot.trajectory import contact_modes

MODELS = Path(__file__).resolve().parent.parent / "models"
BACKLASH = 2e-4  # [rad] every drive's lost motion
PAYLOAD = np.array([0.0, 0.0, -50.0])  # [N] at the tool flange's origin, world axes
UR5_PLAY = """[defaults.revolute]
type = "revolute"
radial_clearance = 1e-5
axial_clearance = 5e-6
length = 0.03
driven = true
backlash = 2e-4

[gravity]
value = [0.0, 0.0, -9.81]
enabled = true
"""


def load_torque(model: pin.Model, q: np.ndarray, frame: str, force: np.ndarray) -> np.ndarray:
    """The generalized load (nv,) [N m] of gravity and ``force`` at ``frame``'s origin:
    -g(q) + J(q)^T F (Pinocchio's generalized gravity is the torque that holds it)."""
    data = model.createData()
    gravity = pin.computeGeneralizedGravity(model, data, q)
    jacobian = pin.computeFrameJacobian(
        model, data, q, model.getFrameId(frame), pin.LOCAL_WORLD_ALIGNED
    )
    torque: np.ndarray = -gravity + jacobian[:3].T @ force
    return torque


def tool_column(model: pin.Model, q: np.ndarray, frame: str, joint: str) -> np.ndarray:
    """The translation column (3,) [m/rad] of ``joint`` in ``frame``'s Jacobian (world axes)."""
    data = model.createData()
    jacobian = pin.computeFrameJacobian(
        model, data, q, model.getFrameId(frame), pin.LOCAL_WORLD_ALIGNED
    )
    column: np.ndarray = jacobian[:3, model.joints[model.getJointId(joint)].idx_v]
    return column


def check_stop_changes(mechanism, batch, frame, force, tolerance):
    """Every sign change of a backlash joint's load torque between two poses of ``batch`` is
    located where Pinocchio's torque vanishes, with the tool's jump J_j b; returns the
    (joint, located value of the swept joint, root, jump [m]) of each."""
    model = mechanism.model
    modes = contact_modes(batch)
    changes = {c.index: c for c in locate_changes(batch, outputs=[frame], tolerance=tolerance)}
    joints = [j.name for j in mechanism.tree_joints if j.clearance.backlash]
    qs = np.array([answer.configuration.q for answer in batch])
    torques = np.array([load_torque(model, q, frame, force) for q in qs])
    found = []
    for name in joints:
        v = model.joints[model.getJointId(name)].idx_v
        if np.abs(torques[:, v]).max() < 1e-9 * np.abs(torques).max():
            continue  # no load about this axis anywhere (a vertical axis under vertical loads)
        for i in np.flatnonzero(np.sign(torques[1:, v]) != np.sign(torques[:-1, v])) + 1:
            assert i in changes, f"{name}'s torque changes sign before pose {i}: no change found"
            assert (i, (f"{name}:backlash",)) in modes.stops
            change = changes[i]
            assert change.stops == (f"{name}:backlash",)

            def torque(s, q0=qs[i - 1], q1=qs[i], v=v):
                return load_torque(model, (1.0 - s) * q0 + s * q1, frame, force)[v]

            root = brentq(torque, 0.0, 1.0, xtol=1e-14)
            assert abs(change.fraction - root) <= change.width
            if change.touched or change.left or change.flipped:
                continue  # other contacts change at the same place: their jump adds (wrist_2
                # upright makes wrist_3's axial load vanish too); located, not compared
            column = tool_column(model, (1.0 - root) * qs[i - 1] + root * qs[i], frame, name)
            # the stop moves from sign(tau before) b/2 to sign(tau after) b/2
            expected = np.sign(torques[i, v]) * BACKLASH * column
            # to 1e-5 of the jump: what moves continuously over the located interval (wider
            # where the torque crosses zero slowly: the stop is free over a short zone)
            scale = float(np.linalg.norm(expected))
            assert change.jumps[frame] == pytest.approx(expected, rel=0.0, abs=1e-5 * scale)
            swept = np.flatnonzero(np.ptp(qs, axis=0))[0]
            found.append(
                (name, change.configuration[swept], (1 - root) * qs[i - 1, swept] + root * qs[i, swept],
                 float(np.linalg.norm(change.jumps[frame])))
            )  # fmt: skip
    stops = {i for i, _ in modes.stops}
    assert stops == {c.index for c in changes.values() if c.stops}
    return found


def test_ur5_shoulder_lift_sweep_under_a_payload(tmp_path):
    """The UR5 of example-robot-data as shipped, its play and backlash in a TOML clearance file,
    swept along its shoulder lift under gravity and 50 N at the flange: the elbow's and the
    shoulder lift's stops switch side where Pinocchio's torque of each vanishes, and the tool
    jumps by |J_j| b there (about 100 and 140 um)."""
    from test_auto_bound import example_robot_urdf

    urdf = tmp_path / "ur5.urdf"
    urdf.write_text(example_robot_urdf("ur_description/urdf/ur5_robot.urdf"))
    play = tmp_path / "play.toml"
    play.write_text(UR5_PLAY)
    ur5 = cp.load(str(urdf), clearances=str(play))
    qs = np.tile([0.3, -1.2, 1.4, -0.75, 1.1, 0.4], (41, 1))
    qs[:, 1] = np.linspace(-3.0, 0.0, 41)
    batch = ur5.solve_many([[cp.PointForce("tool0", PAYLOAD, [0, 0, 0])]] * 41, configurations=qs)
    assert batch.ok.all()
    found = check_stop_changes(ur5, batch, "tool0", PAYLOAD, tolerance=1e-9)
    assert {name for name, *_ in found} >= {"elbow_joint", "shoulder_lift_joint"}
    for name, located, root, jump in found:
        assert abs(located - root) < 1e-8  # [rad] of the shoulder lift
        if name in ("elbow_joint", "shoulder_lift_joint"):
            assert jump > 5e-5  # a tenth of a millimetre at the flange


def test_one_journal_of_the_bundled_arm():
    """The bundled 6R arm with backlash on its elbow only (a single revolute journal with lost
    motion), swept along its shoulder lift under its own loads (50 N at the tool, gravity)."""
    text = (MODELS / "arm_6r.urdf").read_text()
    text = text.replace('driven="true" q="1.2"/>', f'driven="true" q="1.2" backlash="{BACKLASH}"/>')
    arm = cp.loads(text)
    assert [j.name for j in arm.tree_joints if j.clearance.backlash] == ["elbow"]
    lift = arm.model.joints[arm.model.getJointId("shoulder_lift")].idx_q
    qs = np.tile(arm.q_nominal, (31, 1))
    qs[:, lift] = np.linspace(-3.0, 0.5, 31)
    batch = arm.solve_many(configurations=qs)
    assert batch.ok.all()
    tool = next(f for f in arm.loads if isinstance(f, cp.PointForce))
    assert np.allclose(tool.point, 0.0)
    found = check_stop_changes(arm, batch, tool.link, tool.force, tolerance=1e-9)
    assert {name for name, *_ in found} == {"elbow"}  # its torque crosses zero twice


def test_exact_model_bisected_in_the_exact_model():
    """A batch of the exact model is bisected in the exact model: the located change is the
    exact model's (its near and far answers are exact), and the jump is still about |J_j| b (the
    finite rotation b about the joint differs from J_j b by O(b^2))."""
    text = (MODELS / "arm_6r.urdf").read_text()
    text = text.replace('driven="true" q="1.2"/>', f'driven="true" q="1.2" backlash="{BACKLASH}"/>')
    arm = cp.loads(text)
    lift = arm.model.joints[arm.model.getJointId("shoulder_lift")].idx_q
    qs = np.tile(arm.q_nominal, (31, 1))
    qs[:, lift] = np.linspace(-3.0, 0.5, 31)
    batch = arm.solve_many(configurations=qs, exact=True)
    changes = [c for c in locate_changes(batch, outputs=["tool"], tolerance=1e-7) if c.stops]
    assert len(changes) == 2  # as in the small-displacement model: the torque's two zeros
    for change in changes:
        assert change.stops == ("elbow:backlash",)
        assert change.near.formulation == "exact" and change.far.formulation == "exact"
        column = tool_column(arm.model, change.configuration, "tool", "elbow")
        assert np.linalg.norm(change.jumps["tool"]) == pytest.approx(
            np.linalg.norm(column) * BACKLASH, rel=1e-3
        )
