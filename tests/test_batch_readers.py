"""Whole-batch readers of ``solve_many`` (issue 22 item 5): arrays without assembling each item.

Two kinds of check:

- one way: every reader of a batch solved on stacked arrays (frame displacements, reactions and
  their drive part, contact forces) gives the numbers of the items it would assemble
  (``batch[i].reaction(...)`` etc.), relative 1e-12 and absolute 1e-15 of the largest value; the
  cases solved one by one come from their item, failed cases are NaN rows. This shows that the
  two paths agree, not that either is right;
- independent (:func:`test_reactions_balance_every_body`): the per-body statics of the
  reactions the batch reports, with the loads placed by Pinocchio's own forward kinematics at
  each case's configuration and summed here; only the reported reactions come from the library.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import clearance_pin as cp
from clearance_pin import Gravity, PointForce, Torque
from clearance_pin.equilibrium.poses import clearance_frames
from clearance_pin.errors import ArgumentError, NotFoundError

MODELS = Path(__file__).resolve().parents[1] / "models"
RELATIVE, ABSOLUTE = 1e-12, 1e-15  # absolute: of the largest value of the reader


def arm() -> cp.Mechanism:
    return cp.load(MODELS / "arm_6r.urdf")


def tool_load(mechanism: cp.Mechanism) -> PointForce:
    return next(load for load in mechanism.loads if isinstance(load, PointForce))


@pytest.fixture(scope="module")
def trajectory_batch():
    """500 poses of the 6R arm: every joint q_i + 0.5 sin(phase + i) [rad] over one turn."""
    mechanism = arm()
    nominal = np.asarray(mechanism.q_nominal, dtype=float)
    phases = np.linspace(0.0, 2.0 * np.pi, 500, endpoint=False)
    poses = [nominal + 0.5 * np.sin(phase + np.arange(nominal.size)) for phase in phases]
    return mechanism, mechanism.solve_many(configurations=poses)


@pytest.fixture(scope="module")
def load_batch():
    """200 tool loads of the 6R arm at its nominal pose: the model's force plus 0.3 of its size
    times N(0, I)."""
    mechanism = arm()
    tool = tool_load(mechanism)
    rng = np.random.default_rng(5)
    forces = tool.force + 0.3 * np.linalg.norm(tool.force) * rng.standard_normal((200, 3))
    return mechanism, mechanism.solve_many([[replace(tool, force=f)] for f in forces])


def four_bar_cases(compiled: str):
    """200 cases of the four-bar's loads, its point force scaled by 1 + 0.3 N(0, 1), solved by
    the compiled kernel's batch (``compiled="1"``) or the NumPy batched Newton (``"0"``)."""
    mechanism = cp.load(MODELS / "four_bar.urdf")
    force = next(load for load in mechanism.loads if isinstance(load, PointForce))
    others = [load for load in mechanism.loads if load is not force]
    rng = np.random.default_rng(6)
    scales = 1.0 + 0.3 * rng.standard_normal(200)
    cases = [[*others, replace(force, force=force.force * s)] for s in scales]
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv("CLEARANCE_PIN_COMPILED", compiled)
        return mechanism, mechanism.solve_many(cases)


@pytest.fixture(scope="module")
def loop_batch():
    pytest.importorskip("numba")  # the compiled kernel's batch
    return four_bar_cases("1")


@pytest.fixture(scope="module")
def loop_batch_numpy():
    return four_bar_cases("0")


@pytest.fixture(scope="module")
def returned_batch():
    """Tool loads with errors="return", gravity off: case 3 fails (an unknown link), case 5 has
    no load (solved alone: no load works on any admissible motion)."""
    mechanism = arm()
    cases = [[PointForce("tool", [5.0 * k, 10.0 - k, -50.0], [0.0, 0.0, 0.02])] for k in range(40)]
    cases[3] = [PointForce("nowhere", [0.0, 0.0, -50.0], [0.0, 0.0, 0.0])]
    cases[5] = [Torque("tool", [0.0, 0.0, 0.0])]
    cases[7] = [Torque("wrist_3", [5.0, 0.0, 1.0]), *cases[7]]
    return mechanism, mechanism.solve_many(cases, errors="return", gravity=False)


BATCHES = ["trajectory_batch", "load_batch", "loop_batch", "loop_batch_numpy", "returned_batch"]


def items(batch, read, shape) -> np.ndarray:
    """The item-by-item answer (NaN for errors)."""
    return np.array(
        [np.full(shape, np.nan) if isinstance(r, Exception) else read(r) for r in batch]
    ).reshape(len(batch), *shape)


def assert_same(got: np.ndarray, expected: np.ndarray, scale: float | None = None) -> None:
    """Equal NaN rows, and the values to RELATIVE, or ABSOLUTE of ``scale`` (default: the
    largest expected value; a reaction: the largest of the terms summed into it, the whole
    reaction and its contact part, see :func:`reaction_scale`)."""
    assert got.shape == expected.shape
    assert np.array_equal(np.isnan(got), np.isnan(expected))
    if scale is None:
        scale = float(np.nanmax(np.abs(expected), initial=0.0))
    np.testing.assert_allclose(got, expected, rtol=RELATIVE, atol=ABSOLUTE * scale)


@pytest.mark.parametrize("name", BATCHES)
def test_the_batch_is_read_from_its_arrays(name, request):
    """The readers below compare the array path, not items with themselves: most cases of each
    batch are stacked (solved on stacked arrays, assembled only when read)."""
    _, batch = request.getfixturevalue(name)
    answers = batch._stacked_answers()
    assert answers is not None and answers.stacked.sum() >= 0.8 * len(batch)
    # and some come from their item: the batched Newton's first case, the returned batch's
    assert answers.stacked.all() == (name in ("trajectory_batch", "load_batch"))
    engine = {"loop_batch": "batched Newton (compiled)", "loop_batch_numpy": "batched Newton"}
    if name in engine:
        assert batch.statuses.count(engine[name]) >= 0.8 * len(batch)


@pytest.mark.parametrize("name", BATCHES)
def test_frame_displacements_equal_the_items(name, request):
    mechanism, batch = request.getfixturevalue(name)
    for frame in mechanism.model.frames[1:]:
        translations, rotations = batch.frame_displacements(frame.name)
        expected = items(batch, lambda r, f=frame.name: np.hstack(r.frame_displacement(f)), (6,))
        assert_same(np.hstack([translations, rotations]), expected)


def reaction_scale(batch, joint: str, frame: str) -> float:
    """The size of the terms summed into a joint's reaction [N, N m]: the largest of its
    components and of its contact points' forces (the forces at a journal's two ends oppose,
    each up to four times the reaction on the 6R arm, so their sum carries their round-off); a
    part that is zero but for round-off has no scale of its own."""
    whole = float(np.nanmax(np.abs(batch.reactions(joint, frame))))
    return max(whole, float(np.nanmax(np.abs(batch.contact_forces(joint)), initial=0.0)))


@pytest.mark.parametrize("name", BATCHES)
def test_reactions_equal_the_items(name, request):
    mechanism, batch = request.getfixturevalue(name)
    for joint in mechanism.joints:
        for frame in ("joint", "world"):
            expected = items(batch, lambda r, j=joint, f=frame: r.reaction(j, f).wrench, (6,))
            assert_same(
                batch.reactions(joint, frame), expected, reaction_scale(batch, joint, frame)
            )
        scale = reaction_scale(batch, joint, "world")
        for part in ("contact", "rigid", "drive"):

            def read(r, j=joint, p=part):
                return getattr(r.reaction(j, "world"), p)

            assert_same(batch.reactions(joint, "world", part), items(batch, read, (6,)), scale)


@pytest.mark.parametrize("name", BATCHES)
def test_contact_forces_and_drive_torques_equal_the_items(name, request):
    mechanism, batch = request.getfixturevalue(name)
    for joint in mechanism.joints:
        points = batch.contact_points(joint)
        forces = batch.contact_forces(joint)
        assert forces.shape == (len(batch), len(points), 3)

        def read(r, j=joint):
            return np.array([c.force for c in r.contacts if c.joint == j])

        assert_same(forces, items(batch, read, (len(points), 3)))
        first = next(r for r in batch if not isinstance(r, Exception))
        assert points == tuple(c.point for c in first.contacts if c.joint == joint)
    torques = batch.drive_torques()
    driven = [name for name, j in mechanism.joints.items() if getattr(j, "locked_components", ())]
    assert sorted(torques) == sorted(driven)
    for joint, values in torques.items():
        scale = reaction_scale(batch, joint, "joint")
        expected = items(batch, lambda r, j=joint: r.reaction(j).drive[3], ())
        assert_same(values, expected, scale)


def test_failed_and_lone_cases(returned_batch):
    """A failed case is a NaN row; a case solved alone is read from its item."""
    _, batch = returned_batch
    assert isinstance(batch[3], cp.ClearancePinError)
    stacked = batch._stacked_answers().stacked
    assert not stacked[3] and not stacked[5] and stacked[4]
    assert np.isnan(batch.reactions("elbow")[3]).all()
    assert np.isnan(batch.contact_forces("elbow")[3]).all()
    assert np.isnan(batch.frame_displacements("tool")[0][3]).all()
    np.testing.assert_array_equal(batch.reactions("elbow")[5], batch[5].reaction("elbow").wrench)


def test_readers_name_what_is_wrong(load_batch):
    _, batch = load_batch
    with pytest.raises(NotFoundError, match="nowhere"):
        batch.reactions("nowhere")
    with pytest.raises(NotFoundError, match="nowhere"):
        batch.contact_forces("nowhere")
    with pytest.raises(NotFoundError, match="nowhere"):
        batch.frame_displacements("nowhere")
    with pytest.raises(ArgumentError, match="frame"):
        batch.reactions("elbow", frame="base")
    with pytest.raises(ArgumentError, match="part"):
        batch.reactions("elbow", part="friction")


def placed_loads(mechanism, loads, q) -> np.ndarray:
    """Per Pinocchio body, (force [N], moment about the world origin [N m]) of ``loads`` at the
    configuration q, placed by Pinocchio's forward kinematics, (njoints, 6)."""
    model = mechanism.model
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    out = np.zeros((model.njoints, 6))
    for load in loads:
        if isinstance(load, Gravity):
            for body in range(1, model.njoints):
                inertia = model.inertias[body]
                weight = inertia.mass * np.asarray(load.acceleration)
                out[body, :3] += weight
                out[body, 3:] += np.cross(data.oMi[body].act(inertia.lever), weight)
            continue
        frame = mechanism.link_frames[load.link]
        body = model.frames[frame].parentJoint
        if isinstance(load, PointForce):
            point = data.oMf[frame].act(np.asarray(load.point, dtype=float))
            out[body, :3] += load.force
            out[body, 3:] += np.cross(point, load.force)
        else:
            out[body, 3:] += load.torque
    return out


@pytest.mark.parametrize(
    "name", ["trajectory_batch", "load_batch", "loop_batch", "loop_batch_numpy"]
)
def test_reactions_balance_every_body(name, request):
    """Independent check: for every moving body b of every case, its loads (placed here by
    Pinocchio at the case's configuration, gravity included) plus the reactions of the joints
    whose child it is, minus those whose parent it is (``reactions(joint, "world")``), sum to
    zero, to 1e-9 of the load (the statics tolerance of a verified answer is 1e-9 of it).
    For the serial arm this is the closed form of the base joint's reaction, minus the sum of
    every load about the world origin, joint after joint."""
    mechanism, batch = request.getfixturevalue(name)
    model = mechanism.model
    frames = clearance_frames(batch[0])  # the parent and child body of each joint (topology)
    reactions = {joint: batch.reactions(joint, "world") for joint in mechanism.joints}
    length = mechanism.length_scale()
    for i in range(0, len(batch), 7):
        item = batch[i]
        balance = placed_loads(mechanism, item.loads, item.configuration.q)
        size = float(np.abs(balance[:, :3]).sum() + np.abs(balance[:, 3:]).sum() / length)
        for joint, wrench in reactions.items():
            balance[frames[joint].child_body] += wrench[i]
            balance[frames[joint].parent_body] -= wrench[i]
        left = max(np.abs(balance[1:, :3]).max(), np.abs(balance[1:, 3:]).max() / length)
        assert left <= 1e-9 * size, (name, i, left / size)
    assert model.njoints > 1
