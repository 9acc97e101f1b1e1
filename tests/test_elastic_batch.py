"""Batches of a tree with joint stiffness (equilibrium/elastic_batch.py): the rigid twin's batch
plus each spring's deflection under its joint's reaction from the subtree's statics, on arrays.
Every whole-batch reader gives the answers of single solves (each solved on a mechanism of its
own, the superposition of elastic_tree.py), and the tool's deflection of the springs alone is
J K^-1 J^T F from Pinocchio's own Jacobian (independent of the solver)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import clearance_pin
from clearance_pin import PointForce
from clearance_pin.equilibrium.batch_reactions import PARTS

ROOT = Path(__file__).resolve().parents[1]
DRIVE = [4e4, 3e4, 2e4, 8e3, 6e3, 5e3]  # [N m/rad], shoulder to wrist


def _arm(play: bool) -> clearance_pin.Mechanism:
    """The bundled 6R arm with a drive stiffness on every joint, with or without its play."""
    text = (ROOT / "models" / "arm_6r.urdf").read_text()
    lines = iter(DRIVE)
    text = re.sub(
        r'driven="true"', lambda _: f'driven="true" drive_stiffness="{next(lines)!r}"', text
    )
    if not play:  # no type: a driven joint without play (docs/model-format.md)
        head, block = text.split("<clearance_pin>")
        block = re.sub(r' (type|radial_clearance|axial_clearance|length)="[^"]*"', "", block)
        text = head + "<clearance_pin>" + block
    return clearance_pin.loads(text, source="arm_6r with drive stiffness")


@pytest.mark.parametrize("play", [True, False])
def test_the_batch_reads_as_single_solves(play):
    """Load cases at one pose and a payload x pose grid: torsors, deflections, the tool's
    displacement, reactions, energies and items equal single solves to round-off."""
    arm, single = _arm(play), _arm(play)
    tool = next(load for load in arm.loads if isinstance(load, PointForce))
    rng = np.random.default_rng(2)
    values = np.array([0.0, 0.0, -50.0]) + rng.normal(0.0, 20.0, (40, 3))
    resolver = arm.resolver([tool], gravity=True)
    poses = [arm.q_nominal + 0.3 * rng.standard_normal(arm.model.nq) for _ in range(3)]
    for batch, cases in (
        (resolver.solve_many(values), [(n, None) for n in range(40)]),
        (
            resolver.solve_many(values[:4], configurations=poses),
            [(n, q) for q in poses for n in range(4)],
        ),
    ):
        assert batch.ok.all()
        shifts = batch.frame_displacements("tool")
        energies = batch.energy
        for i in (0, 5, len(cases) - 1):
            n, q = cases[i]
            load = PointForce(tool.link, values[n], tool.point)
            expected = single.solve([load], q=q, gravity=True)
            scale = max(np.abs(expected.frame_displacement("tool")[0]).max(), 1e-9)
            np.testing.assert_allclose(
                shifts[0][i], expected.frame_displacement("tool")[0], rtol=0, atol=1e-9 * scale
            )
            np.testing.assert_allclose(
                shifts[1][i], expected.frame_displacement("tool")[1], rtol=0, atol=1e-9 * scale
            )
            assert energies[i] == pytest.approx(expected.energy, rel=1e-9)
            for joint in arm.joints:
                np.testing.assert_allclose(
                    batch.torsors(joint)[i], expected.torsors[joint], rtol=0, atol=1e-9 * scale
                )
                np.testing.assert_allclose(
                    batch.deflections(joint)[i],
                    expected.deflection(joint),
                    rtol=0,
                    atol=1e-9 * scale,
                )
                np.testing.assert_allclose(
                    batch.reactions(joint)[i],
                    expected.reaction(joint).wrench,
                    rtol=0,
                    atol=1e-9 * 100,
                )
                np.testing.assert_allclose(
                    batch[i].torsors[joint], expected.torsors[joint], rtol=0, atol=1e-9 * scale
                )


def test_the_springs_alone_give_pinocchio_compliance():
    """Without play: the tool's displacement in every case is J K^-1 J^T F at the tool point,
    J Pinocchio's LOCAL_WORLD_ALIGNED Jacobian of a frame at that point (gravity off)."""
    arm = _arm(play=False)
    tool = next(load for load in arm.loads if isinstance(load, PointForce))
    rng = np.random.default_rng(4)
    values = rng.normal(0.0, 40.0, (30, 3))
    batch = arm.resolver([tool], gravity=False).solve_many(values)
    model = arm.model.copy()
    frame = model.getFrameId(tool.link)
    placed = model.frames[frame]
    point = pin.Frame(
        "tool_point",
        placed.parentJoint,
        frame,
        placed.placement * pin.SE3(np.eye(3), np.asarray(tool.point)),
        pin.FrameType.OP_FRAME,
    )
    point_id = model.addFrame(point)
    data = model.createData()
    jacobian = pin.computeFrameJacobian(
        model, data, arm.q_nominal, point_id, pin.LOCAL_WORLD_ALIGNED
    )
    compliance = np.diag(1.0 / np.array(DRIVE))
    expected = (jacobian @ compliance @ jacobian.T @ np.hstack([values, np.zeros_like(values)]).T).T
    shifts = batch.frame_displacements(tool.link)
    assert np.abs(expected[:, :3]).max() > 1e-6  # the springs deflect
    # the tool link's origin is the load point here (tool.point is its origin)
    np.testing.assert_allclose(shifts[0], expected[:, :3], rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(shifts[1], expected[:, 3:], rtol=1e-9, atol=1e-15)


@pytest.mark.parametrize("play", [True, False])
def test_a_trees_whole_reactions_are_its_parts_summed(play):
    """A tree's whole reaction read by subtree statics (batch_reactions.whole_tree_reaction)
    equals the sum of its parts (contact, rigid, drive, held) that the reactions reader solves
    from the contact forces, in both frames, on a payload x pose grid (two routes, one
    statics)."""
    arm = _arm(play)
    tool = next(load for load in arm.loads if isinstance(load, PointForce))
    rng = np.random.default_rng(8)
    poses = [arm.q_nominal + 0.3 * rng.standard_normal(arm.model.nq) for _ in range(5)]
    payloads = np.array([[0.0, 0.0, -9.81 * kg] for kg in (0.5, 2.0, 5.0)])
    grid = arm.resolver([tool], gravity=True).solve_many(payloads, configurations=poses)
    play_batch = grid.play if hasattr(grid, "play") else grid
    for joint in arm.joints:
        for frame in ("joint", "world"):
            whole = play_batch.reactions(joint, frame)
            parts = sum(play_batch.reactions(joint, frame, part) for part in PARTS)
            scale = np.abs(whole).max()
            assert scale > 1.0
            np.testing.assert_allclose(whole, parts, rtol=0.0, atol=1e-9 * scale)


def test_a_failed_case_reads_as_nan():
    """With errors="return", a case whose load the rigid twin cannot balance (a force along a
    motion nothing blocks: the arm's base turns freely without its drive) is its error in the
    batch, and every whole-batch reader gives NaN in its row, the others their answers."""
    text = (ROOT / "models" / "arm_6r.urdf").read_text()
    text = text.replace(
        'driven="true" q="0.0"/>\n    <joint name="shoulder_lift"',
        'q="0.0"/>\n    <joint name="shoulder_lift"',
        1,
    )
    lines = iter(DRIVE[1:])
    text = re.sub(
        r'driven="true" q="', lambda m: f'driven="true" drive_stiffness="{next(lines)!r}" q="', text
    )
    arm = clearance_pin.loads(text, source="arm_6r, its base free")
    tool = next(load for load in arm.loads if isinstance(load, PointForce))
    values = np.array([[0.0, 0.0, -50.0], [0.0, 30.0, -50.0], [0.0, 0.0, -20.0]])
    batch = arm.resolver([tool], gravity=False).solve_many(values, errors="return")
    failed = [isinstance(item, Exception) for item in batch]
    assert any(failed) and not all(failed)
    rows = np.array(failed)
    for reader in (
        batch.torsors("elbow"),
        batch.deflections("elbow"),
        batch.frame_displacements("tool")[0],
    ):
        assert np.isnan(reader[rows]).all() and np.isfinite(reader[~rows]).all()


@pytest.mark.parametrize("play", [True, False])
def test_methods_and_statuses_read_as_the_items_say(play):
    """The batch's methods and statuses, read without assembling the items, are the items' own
    (springs alone where nothing moves in the play, by superposition elsewhere)."""
    arm = _arm(play)
    tool = next(load for load in arm.loads if isinstance(load, PointForce))
    values = np.array([[0.0, 0.0, -50.0], [0.0, 0.0, 0.0], [5.0, 0.0, -20.0]])
    batch = arm.resolver([tool], gravity=False).solve_many(values)
    methods, statuses = batch.methods, batch.statuses
    for i in range(len(batch)):
        assert methods[i] == batch[i].method
        assert statuses[i] == batch[i].solver_status


def _panda(tmp_path: Path, clearances: str) -> tuple[clearance_pin.Mechanism, ...]:
    """Two loads of the Panda as shipped (example-robot-data) with the clearance file
    ``clearances``: one for the batch, one for the single solves it is compared with."""
    robots = pytest.importorskip("test_corpus_robots")
    path = robots.vendor_file("panda_description/urdf/panda.urdf")
    if path is None:
        pytest.skip("example-robot-data is not installed")
    written = tmp_path / "panda.toml"
    written.write_text(clearances)
    return tuple(clearance_pin.load(path, clearances=written) for _ in range(2))


def test_a_vendor_arm_with_locked_mimic_fingers_takes_the_arrays(tmp_path):
    """The Panda as shipped (its second finger mimics the first), the fingers held by [locks],
    a drive stiffness on every arm joint: a driven leader's coupling holds its follower as a
    drive does, so the batch is the springs' on arrays (it went one case at a time), and its
    tool displacements and reactions (a finger's included) are the single solves'."""
    arm, single = _panda(
        tmp_path,
        "[defaults.revolute]\ndriven = true\ndrive_stiffness = 2e4\n"
        "[locks.panda_finger_joint1]\nq = 0.02\n[locks.panda_finger_joint2]\nq = 0.02\n",
    )
    assert arm.couplings  # the mimic
    load = PointForce("panda_hand", [0.0, 0.0, -10.0], [0.0, 0.0, 0.1])
    values = np.random.default_rng(6).normal(0.0, 20.0, (40, 1, 3))
    batch = arm.resolver([load], gravity=False).solve_many(values)
    assert type(batch).__name__ == "ElasticTreeBatch" and batch.ok.all()
    shifts = batch.frame_displacements("panda_hand")[0]
    for n in (0, 21, 39):
        expected = single.solve([PointForce(load.link, values[n, 0], load.point)], gravity=False)
        moved = expected.frame_displacement("panda_hand")[0]
        np.testing.assert_allclose(shifts[n], moved, rtol=0.0, atol=1e-9 * np.abs(moved).max())
        for joint in ("panda_joint2", "panda_finger_joint1"):
            wrench = expected.reaction(joint).wrench
            np.testing.assert_allclose(
                batch.reactions(joint)[n],
                wrench,
                rtol=0.0,
                atol=1e-9 * max(1.0, np.abs(wrench).max()),
            )


def test_a_vendor_arm_with_free_mimic_fingers_takes_the_closed_forms(tmp_path):
    """The Panda as shipped, the clearance file naming its arm joints only (play and a drive
    stiffness): its fingers are free and coupled (the mimic: a passive coupling between two
    joints without play). The coupling ties free motions only, so the joints with play still
    split into blocks and the springs' statics hold under it: the batch is closed forms plus
    the springs on arrays (it went one case at a time, 340 cases/s, a tenth through Clarabel).
    Its drive torques are Pinocchio's -J^T F at the tool point (independent), its answers the
    general path's (Clarabel, backend="clarabel"), a finger's reaction the single solve's."""
    arm, single = _panda(
        tmp_path,
        'unit = "m"\n[defaults.revolute]\ntype = "revolute"\ndriven = true\n'
        "drive_stiffness = 2e4\nradial_clearance = 1e-5\naxial_clearance = 5e-6\nlength = 0.03\n",
    )
    assert arm.couplings and not arm.joints["panda_finger_joint1"].driven
    load = PointForce("panda_hand", [0.0, 0.0, -10.0], [0.0, 0.0, 0.1])
    values = np.random.default_rng(7).normal(0.0, 20.0, (60, 1, 3))
    batch = arm.resolver([load]).solve_many(values)
    assert type(batch).__name__ == "ElasticTreeBatch" and batch.ok.all()
    assert set(batch.methods) == {clearance_pin.Method.CLOSED_FORM}
    model = pin.Model(arm.model)
    data = model.createData()
    pin.framesForwardKinematics(model, data, arm.q_nominal)
    pin.computeJointJacobians(model, data, arm.q_nominal)
    frame = model.getFrameId("panda_hand")
    jacobian = pin.getFrameJacobian(model, data, frame, pin.LOCAL_WORLD_ALIGNED)
    lever = data.oMf[frame].rotation @ load.point
    linear = jacobian[:3] - pin.skew(lever) @ jacobian[3:]
    torques = batch.drive_torques()
    shifts = batch.frame_displacements("panda_hand")[0]
    for n in (0, 17, 59):
        force = values[n, 0]
        pushed = linear.T @ force  # the generalised force of the tool load
        for joint in (f"panda_joint{k}" for k in range(1, 8)):
            v = model.joints[model.getJointId(joint)].idx_v
            assert abs(torques[joint][n] + pushed[v]) <= 1e-9 * np.abs(pushed).max()
        loads = [PointForce(load.link, force, load.point)]
        general = single.solve(loads, backend="clarabel", warm_start=False)
        moved = general.frame_displacement("panda_hand")[0]
        np.testing.assert_allclose(shifts[n], moved, rtol=0.0, atol=1e-9 * np.abs(moved).max())
        wrench = single.solve(loads).reaction("panda_finger_joint1").wrench
        np.testing.assert_allclose(
            batch.reactions("panda_finger_joint1")[n], wrench, rtol=0.0, atol=1e-9
        )
