"""The accuracy map (issue 23 item 4): where a robot's tool settles over poses and payloads, and
which joint and source moves it.

Independent check: on the Franka Panda of example-robot-data (every joint a driven journal with
play, tests/test_corpus_robots.py), with the robot's own weight off and a payload mass at the
tool, each journal's torsor has a closed form (journal_torsor: the tool wrench at the joint
centre, no solver code), and the tool's displacement is the sum of what each torsor moves it,
from Pinocchio's forward kinematics of the pose (not the library's maps).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import clearance_pin as cp

MODELS = Path(__file__).resolve().parent.parent / "models"
G = 9.80665  # [m/s^2], the map's payload weight


def test_the_panda_tool_follows_the_journals_closed_forms():
    corpus = pytest.importorskip("test_corpus_robots")  # skips without example-robot-data
    robot = "panda"
    mech = corpus.mechanism(robot)
    names, tool = list(corpus.ROBOTS[robot][1]), corpus.ROBOTS[robot][2]
    model = mech.model
    rng = np.random.default_rng(5)
    poses = np.tile(mech.q_nominal, (4, 1))
    for name in names:
        index = model.joints[mech.joint(name).joint_id].idx_q
        poses[:, index] += rng.uniform(-0.3, 0.3, 4)
    masses = [0.0, 0.5, 3.0]
    amap = mech.accuracy(tool, poses, payloads=masses, gravity=False)
    assert amap.translation.shape == amap.rotation.shape == (4, 3, 3) and amap.ok.all()
    data = model.createData()
    frame = model.getFrameId(tool)
    for i, q in enumerate(poses):
        pin.framesForwardKinematics(model, data, q)
        point = data.oMf[frame].translation
        for k, mass in enumerate(masses):
            force = np.array([0.0, 0.0, -G * mass])
            moved, turned = np.zeros(3), np.zeros(3)
            for name in names:
                joint = mech.joint(name)
                placed = data.oMi[joint.joint_id]
                axes = placed.rotation @ joint.rotation  # the clearance frame in the world
                arm = point - placed.translation
                torsor = (
                    corpus.journal_torsor(
                        axes.T @ force,
                        axes.T @ np.cross(arm, force),
                        corpus.RADIAL,
                        corpus.AXIAL,
                        corpus.LENGTH,
                    )
                    if mass
                    else np.zeros(6)
                )
                if abs((axes.T @ force)[0]) <= 1e-9 * np.linalg.norm(force):
                    torsor[0] = 0.0  # no axial load (a horizontal axis): the least-norm point
                share = axes @ torsor[:3] + np.cross(axes @ torsor[3:], arm)
                got = amap.contributions.get("play", {}).get(name, np.zeros((4, 3, 3)))[i, k]
                assert np.allclose(got, share, rtol=0, atol=1e-9 * corpus.RADIAL), (name, i, k)
                moved += share
                turned += axes @ torsor[3:]
            assert np.allclose(amap.translation[i, k], moved, rtol=0, atol=1e-9 * corpus.RADIAL)
            assert np.allclose(amap.rotation[i, k], turned, rtol=0, atol=1e-9)
    assert "backlash" not in amap.contributions  # rigid drives: no lost motion
    largest, pose, payload = amap.largest()
    assert payload == 2 and largest == pytest.approx(
        np.linalg.norm(amap.translation[pose, 2]), rel=1e-15
    )


def test_the_map_equals_the_batch_and_ranks_the_joints():
    """On the bundled 6R arm with its weight on: the map's displacement equals solve_many's
    frame displacements (the library's twist maps, another computation), the shares sum to it,
    and the ranking is sorted."""
    arm = cp.load(str(MODELS / "arm_6r.urdf"))
    rng = np.random.default_rng(2)
    poses = arm.q_nominal + rng.uniform(-0.5, 0.5, (30, arm.model.nq))
    amap = arm.accuracy("tool", poses, payloads=[0.0, 2.0, [cp.Torque("tool", [0, 0, 1.0])]])
    assert amap.payloads == ("0 kg", "2 kg", "1 N m on tool")
    link, point = arm.link_point("tool")
    cases = {1: [cp.PointForce(link, [0, 0, -2.0 * G], point)], 2: [cp.Torque("tool", [0, 0, 1.0])]}
    for k, loads in ((0, []), *cases.items()):
        batch = arm.solve_many([loads] * len(poses), configurations=poses)
        translation, rotation = batch.frame_displacements("tool")
        assert np.allclose(amap.translation[:, k], translation, rtol=0, atol=1e-15)
        assert np.allclose(amap.rotation[:, k], rotation, rtol=0, atol=1e-15)
    total = sum(share for shares in amap.contributions.values() for share in shares.values())
    assert np.allclose(total, amap.translation, rtol=0, atol=1e-16)
    ranking = amap.ranking()
    assert [row[2] for row in ranking] == sorted((row[2] for row in ranking), reverse=True)
    summary = amap.to_dict()
    assert summary["contributors"][0]["joint"] == ranking[0][1]
    assert summary["largest_translation_m"] == amap.largest()[0]


def test_bad_arguments_are_named():
    arm = cp.load(str(MODELS / "arm_6r.urdf"))
    with pytest.raises(cp.NotFoundError, match="no_such_frame"):
        arm.accuracy("no_such_frame", arm.q_nominal)
    with pytest.raises(cp.ArgumentError, match="configurations"):
        arm.accuracy("tool", np.zeros((3, arm.model.nq + 1)))
    with pytest.raises(cp.ArgumentError, match=r"payloads\[1\]"):
        arm.accuracy("tool", arm.q_nominal, payloads=[1.0, -2.0])
    with pytest.raises(cp.ArgumentError, match=r"payloads\[0\]"):
        arm.accuracy("tool", arm.q_nominal, payloads=["heavy"])


def test_the_command_line(tmp_path, capsys):
    """`clearance-pin accuracy`: the table, the JSON summary (its numbers those of the library's
    map of the same poses), the picture; poses from a file; a bad frame exits 2."""
    import json

    from clearance_pin.accuracy.command import random_poses
    from clearance_pin.cli import main

    model = str(MODELS / "arm_6r.urdf")
    out = tmp_path / "map.json"
    status = main(["accuracy", model, "--output", "tool", "--poses", "40", "--payload", "0",
                   "--payload", "3", "--json", str(out), "--poses-json",
                   "--plot", str(tmp_path / "map.png")])  # fmt: skip
    assert status == 0
    assert "what moves the output most" in capsys.readouterr().out
    document = json.loads(out.read_text())
    jsonschema = pytest.importorskip("jsonschema")
    from clearance_pin.json_documents import schema

    jsonschema.validate(document, schema("accuracy"))
    assert document["schema"] == "clearance_pin/accuracy/1"
    arm = cp.load(model)
    amap = arm.accuracy("tool", random_poses(arm, 40, 0.5, 0), payloads=[0.0, 3.0])
    assert document["largest_translation_m"] == pytest.approx(amap.largest()[0], rel=1e-12)
    assert [c["joint"] for c in document["contributors"]] == [r[1] for r in amap.ranking()]
    assert (tmp_path / "map.png").stat().st_size > 10_000
    poses = tmp_path / "poses.txt"
    poses.write_text("\n".join(" ".join(map(str, q)) for q in amap.configurations[:3]))
    assert main(["accuracy", model, "--output", "tool", "--configurations", str(poses)]) == 0
    assert main(["accuracy", model, "--output", "no_such_frame"]) == 2


def test_an_answer_splits_its_output_by_joint():
    """Equilibrium.contributions(frame): the joints' shares sum to the frame's displacement
    (the library's twist maps: another computation of the same first-order motion), largest
    first; the text table ranks them; a loop mechanism's table leaves them out."""
    arm = cp.load(str(MODELS / "arm_6r.urdf"))
    answer = arm.solve(outputs=["tool"])
    shares = answer.contributions("tool")
    moved = answer.frame_displacement("tool")
    assert np.allclose(sum(t for t, _ in shares.values()), moved.linear, rtol=0, atol=1e-16)
    assert np.allclose(sum(r for _, r in shares.values()), moved.angular, rtol=0, atol=1e-16)
    norms = [np.linalg.norm(t) for t, _ in shares.values()]
    assert norms == sorted(norms, reverse=True)
    assert "what moves tool" in answer.table()
    four_bar = cp.load(str(MODELS / "four_bar.urdf")).solve()
    assert "what moves" not in four_bar.table()
