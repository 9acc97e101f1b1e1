"""Issue 33 items 2 and 8: the accuracy map's reach (indeterminacy is a band, never a silent zero),
its one-pass route for trees of joint blocks, the payload off the tool's origin, CSV and CLI.

Independent references (no solver code):

- the tool's settled displacement: ``peer_map`` of benchmarks/accuracy_map.py, a Pinocchio loop
  (RNEA for the weight each joint carries) and NumPy closed forms of the driven journals
  (sign(tau) b/2 + tau/k on the drive, c a/|a| at each journal end, c_a sign(f_x) axially);
- the reach: the vertices of the free motions' box, each free motion's column from Pinocchio's
  frame Jacobian (a free backlash: the joint's column times b/2) or the joint's world axis (a free
  axial play: a slide c_a along it);
- the free motions: a single solve's ``free_motions`` at the same pose and payload;
- a mass off the tool's origin: single solves of the statically equivalent load at the origin
  (the force and its moment r x F).
"""

from __future__ import annotations

import importlib
import itertools
import json
import re
import sys
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import clearance_pin as cp

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))
MAP_MODULE = "clearance_pin.accuracy.accuracy_map"
G = 9.80665  # [m/s^2], the map's payload weight
AXES = {"backlash": {"alpha"}, "axial play": {"u"}, "radial play": {"v", "w", "beta", "gamma"}}


def ur5() -> cp.Mechanism:
    """The UR5 of example-robot-data, every joint a driven journal with play, backlash and drive
    stiffness (benchmarks/accuracy_map.py: UR5_CLEARANCES); skips without example-robot-data."""
    bench = pytest.importorskip("accuracy_map")
    robot = bench.ur5_with_clearances()
    if robot is None:
        pytest.skip("example-robot-data is not installed")
    return robot


def poses_of(robot: cp.Mechanism, count: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return robot.q_nominal + rng.uniform(-0.5, 0.5, (count, robot.model.nq))


def single_free(answer: cp.Equilibrium) -> tuple[set[tuple[str, str]], bool]:
    """(joint, component) named in a single solve's free motions, and whether every one is
    named (no "smaller components" left out of the description)."""
    named, complete = set(), True
    for text in answer.free_motions:
        named |= set(re.findall(r"joint '([^']+)' (\w+) \(", text))
        complete &= "smaller components" not in text
    return named, complete


def test_the_free_motions_are_a_single_solves():
    """At the same pose and payload, the map's free motions are those a single solve reports:
    the pan's backlash under a vertical load (no torque about a vertical axis), the axial play
    of the joints whose axes are horizontal, the last joint's spin."""
    robot = ur5()
    poses = np.vstack([robot.q_nominal, poses_of(robot, 3, 7)])
    amap = robot.accuracy("tool0", poses, payloads=[5.0], gravity=False)
    link, point = robot.link_point("tool0")
    weight = [0.0, 0.0, -5.0 * G]
    checked = 0
    for i, q in enumerate(poses):
        answer = robot.solve(loads=[cp.PointForce(link, weight, point)], q=q, gravity=False)
        named, complete = single_free(answer)
        ours = {
            (joint, axis)
            for motion in amap.responsible(i, 0)
            for joint, kind in [motion.split(": ")]
            for axis in AXES[kind]
        }
        assert ("shoulder_pan_joint", "alpha") in ours
        if complete:
            assert ours == named, i
            checked += 1
        else:  # a free direction mixing joints: the components named are among ours
            assert named <= ours, i
    assert checked >= 1


def test_the_reach_is_the_vertex_of_the_free_motions_farthest_away():
    """A vertical payload, the robot's weight on: the pan carries no torque and may sit anywhere
    in its backlash. The reach equals the largest |delta p + sum_i s_i J_i| over the vertices of
    the free motions (Pinocchio's Jacobian columns, the joints' axes) around the peer's settled
    displacement, to 1e-12 of it; it is at least |delta p|."""
    bench = pytest.importorskip("accuracy_map")
    robot = ur5()
    poses = poses_of(robot, 6, 3)
    masses = np.array([0.0, 4.0])
    amap = robot.accuracy("tool0", poses, payloads=list(masses), gravity=True)
    settled = bench.peer_map(robot.model, "tool0", poses, masses)  # independent statics
    largest = np.nanmax(np.linalg.norm(settled, axis=2))
    assert np.abs(amap.translation - settled).max() <= 1e-12 * largest
    model, data = robot.model, robot.model.createData()
    frame = model.getFrameId("tool0")
    for i, q in enumerate(poses):
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        full = pin.getFrameJacobian(model, data, frame, pin.LOCAL_WORLD_ALIGNED)
        jacobian, axes = full[:3], full[3:]  # a revolute joint's column: its world axis
        for k in range(len(masses)):
            columns = []
            for motion in amap.responsible(i, k):
                name, kind = motion.split(": ")
                joint = model.getJointId(name)
                if kind == "backlash":  # turns within +/- b/2 of its command
                    columns.append(jacobian[:, model.joints[joint].idx_v] * bench.BACKLASH / 2)
                else:  # slides +/- c_a along its axis
                    assert kind == "axial play"
                    columns.append(axes[:, model.joints[joint].idx_v] * bench.AXIAL)
            assert any(m.startswith("shoulder_pan_joint") for m in amap.responsible(i, k))
            vertices = [
                np.linalg.norm(settled[i, k] + np.array(signs) @ np.array(columns))
                for signs in itertools.product((-1.0, 1.0), repeat=len(columns))
            ]
            assert amap.reach[i, k] == pytest.approx(max(vertices), rel=1e-12)
            alone = [  # the free motions alone, from the settled place
                np.linalg.norm(np.array(signs) @ np.array(columns))
                for signs in itertools.product((-1.0, 1.0), repeat=len(columns))
            ]
            assert amap.free_spread[i, k] == pytest.approx(max(alone), rel=1e-12)
            pan = jacobian[:, model.joints[model.getJointId("shoulder_pan_joint")].idx_v]
            assert amap.free_spread[i, k] >= np.linalg.norm(pan) * bench.BACKLASH / 2
            assert amap.reach[i, k] >= np.linalg.norm(amap.translation[i, k])
    summary = amap.to_dict(poses=True)
    assert summary["largest_reach_m"] == amap.largest_reach()[0] > summary["largest_translation_m"]
    assert "shoulder_pan_joint: backlash" in summary["largest_reach_at"]["free_motions"]


def test_a_payload_without_any_load_leaves_every_motion_free():
    """No load at all (0 kg, no weight): the tool stays at its nominal place but may sit anywhere
    in the play; the reach is the box's farthest vertex, each journal end's disc in its square:
    an upper bound of the envelope of the play."""
    arm = cp.load(str(ROOT / "models/arm_6r.urdf"))
    amap = arm.accuracy("tool", arm.q_nominal, payloads=[0.0], gravity=False)
    assert np.all(amap.translation == 0.0) and amap.ok.all()
    assert amap.reach[0, 0] > 0.0
    assert {m.split(": ")[1] for m in amap.responsible(0, 0)} == {"radial play", "axial play"}
    # sound: at least the certified envelope's largest translation (its own grid and certificate)
    envelope = arm.envelope("tool", q=arm.q_nominal, kinds=("translation",))
    assert amap.reach[0, 0] >= envelope.max_translation.upper
    assert amap.free_spread[0, 0] == amap.reach[0, 0]  # settled at the nominal place


def test_the_one_pass_route_equals_one_solve_many_per_payload(monkeypatch):
    """The tree route (each pose's kinematics once, the payloads as columns) against the general
    route (solve_many per payload) on the UR5 with play, backlash and stiffness and on the
    bundled 6R arm with and without springs: translations, rotations and every share to 1e-12
    of the largest deviation. The UR5's weight alone leaves cases the closed forms' uniqueness
    test does not decide (solve_many solves them alone): they are among them."""
    bench = pytest.importorskip("accuracy_map")
    arm_text = (ROOT / "models/arm_6r.urdf").read_text()
    robots = [("tool", cp.loads(arm_text)), ("tool", cp.loads(bench.stiffened(arm_text)))]
    try:
        robots.append(("tool0", ur5()))
    except pytest.skip.Exception:
        pass
    module = importlib.import_module(MAP_MODULE)
    for tool, robot in robots:
        poses = poses_of(robot, 40, 11)
        payloads = [0.0, 2.0, 9.0]
        fast = robot.accuracy(tool, poses, payloads=payloads, gravity=True)
        with monkeypatch.context() as patch:
            patch.setattr(module, "blocks_of", lambda mechanism: None)
            general = robot.accuracy(tool, poses, payloads=payloads, gravity=True)
        scale = np.nanmax(np.linalg.norm(general.translation, axis=2))
        assert fast.ok.all() and general.ok.all()
        assert np.abs(fast.translation - general.translation).max() <= 1e-12 * scale
        assert np.abs(fast.rotation - general.rotation).max() <= 1e-12 * scale
        for source, shares in general.contributions.items():
            for joint, share in shares.items():
                ours = fast.contributions.get(source, {}).get(joint, np.zeros_like(share))
                assert np.abs(ours - share).max() <= 1e-12 * scale, (tool, source, joint)
        assert np.isnan(general.reach).all() and not general.free_motions
        assert np.all(fast.reach >= np.linalg.norm(fast.translation, axis=2))


def test_the_undecided_cases_are_the_single_solves():
    """The cases whose closed form the uniqueness test leaves undecided (the UR5 under its own
    weight; solve_many solves them alone by its cone solver) keep their verified closed form: the
    tool's displacement equals a single solve's to 1e-12 of the largest deviation. (Their torsors
    differ from the single solve's by up to about 1e-15 rad on a journal whose two ends carry
    nearly the same load, the cone solver's precision: the closed form's tilt is 1e-17 there.)"""
    from clearance_pin.accuracy.tree_map import blocks_of, placements, tree_cases

    robot = ur5()
    poses = poses_of(robot, 300, 0)
    answers = tree_cases(robot, blocks_of(robot), poses, [[]], True, placements(robot, poses))
    undecided = np.flatnonzero(answers.undecided)[:8]
    assert undecided.size and answers.ok.all()
    amap = robot.accuracy("tool0", poses[undecided], payloads=[[]], gravity=True)
    largest = np.linalg.norm(amap.translation, axis=2).max()
    for k, i in enumerate(undecided.tolist()):
        single = robot.solve(loads=[], q=poses[i], gravity=True, outputs=["tool0"])
        moved = single.frame_displacement("tool0").linear
        assert np.abs(amap.translation[k, 0] - moved).max() <= 1e-12 * largest, i


def test_a_mass_off_the_tool_origin():
    """2 kg hung 0.1 m along the tool's z axis: each pose's displacement is a single solve's
    under the statically equivalent load at the tool's origin (the weight W and the moment
    (R p) x W, world axes)."""
    arm = cp.load(str(ROOT / "models/arm_6r.urdf"))
    offset = np.array([0.0, 0.0, 0.1])
    poses = poses_of(arm, 3, 4)
    amap = arm.accuracy("tool", poses, payloads=[2.0], gravity=False, payload_point=offset)
    assert amap.to_dict()["payload_point_m"] == [0.0, 0.0, 0.1]
    link, point = arm.link_point("tool")
    model, data = arm.model, arm.model.createData()
    weight = np.array([0.0, 0.0, -2.0 * G])
    for i, q in enumerate(poses):
        pin.framesForwardKinematics(model, data, q)
        lever = data.oMf[model.getFrameId("tool")].rotation @ offset
        loads = [cp.PointForce(link, weight, point), cp.Torque(link, np.cross(lever, weight))]
        single = arm.solve(loads=loads, q=q, gravity=False, outputs=["tool"])
        expected = single.frame_displacement("tool").linear
        assert amap.translation[i, 0] == pytest.approx(expected, rel=0, abs=1e-12 * 1e-3)
    at_origin = arm.accuracy("tool", poses, payloads=[2.0], gravity=False)
    assert np.abs(at_origin.translation - amap.translation).max() > 1e-7  # it matters
    with pytest.raises(cp.ArgumentError, match="payload_point"):
        arm.accuracy("tool", poses, payloads=[2.0], payload_point=[0.1, 0.0])
    with pytest.raises(cp.ArgumentError, match="payload_point"):
        arm.accuracy("tool", poses, payloads=[2.0], payload_point=["a", 0.0, 0.0])


def test_csv_has_a_row_per_pose_and_payload(tmp_path):
    arm = cp.load(str(ROOT / "models/arm_6r.urdf"))
    amap = arm.accuracy("tool", poses_of(arm, 4, 2), payloads=[0.0, 3.0])
    path = tmp_path / "map.csv"
    amap.to_csv(path)
    rows = path.read_text().splitlines()
    header = rows[0].split(",")
    assert len(rows) == 1 + 4 * 2
    assert header[:6] == [f"q{i}" for i in range(6)] and "reach_m" in header
    last = rows[-1].split(",")
    assert last[6] == "3 kg"
    assert float(last[header.index("translation_m")]) == pytest.approx(
        np.linalg.norm(amap.translation[3, 1]), rel=1e-15
    )
    assert float(last[header.index("reach_m")]) == pytest.approx(amap.reach[3, 1], rel=1e-15)
    with pytest.raises(cp.ArgumentError, match="joint_names"):
        amap.to_csv(path, ["only_one"])


def test_the_command_line_reach_csv_and_workspace(tmp_path, capsys):
    from clearance_pin.cli import main
    from clearance_pin.json_documents import schema

    model = str(ROOT / "models/arm_6r.urdf")
    out = tmp_path / "map.json"
    status = main(["accuracy", model, "--output", "tool", "--poses", "20", "--payload", "0",
                   "--payload", "3", "--payload-point", "0,0,0.05", "--json", str(out),
                   "--poses-json", "--csv", str(tmp_path / "map.csv"),
                   "--plot-workspace", str(tmp_path / "ws.png")])  # fmt: skip
    assert status == 0
    printed = capsys.readouterr().out
    assert "largest reach" in printed and "free motions" in printed
    document = json.loads(out.read_text())
    jsonschema = pytest.importorskip("jsonschema")
    jsonschema.validate(document, schema("accuracy"))
    assert document["largest_reach_m"] >= document["largest_translation_m"]
    assert document["payload_point_m"] == [0.0, 0.0, 0.05]
    assert len((tmp_path / "map.csv").read_text().splitlines()) == 1 + 20 * 2
    assert (tmp_path / "ws.png").stat().st_size > 10_000
    assert main(["accuracy", model, "--output", "tool", "--payload-point", "1,2"]) == 2
    assert "--payload-point" in capsys.readouterr().err


def test_cases_that_do_not_verify_go_to_solve_many(monkeypatch):
    """A closed form that fails its verification is solved by solve_many (the general route):
    every other case, forced here, gives the same map as the general route on the 6R arm with
    springs."""
    bench = pytest.importorskip("accuracy_map")
    from dataclasses import replace

    tree_map = importlib.import_module("clearance_pin.accuracy.tree_map")
    robot = cp.loads(bench.stiffened((ROOT / "models/arm_6r.urdf").read_text()))
    poses = poses_of(robot, 6, 5)
    original = tree_map.verify
    calls = []

    def failing(*arguments, **keywords):
        check = original(*arguments, **keywords)
        calls.append(check.verified.size)
        refused = check.verified.copy()
        refused[::2] = False
        return replace(check, verified=refused)

    monkeypatch.setattr(tree_map, "verify", failing)
    fast = robot.accuracy("tool", poses, payloads=[1.0, 4.0], gravity=True)
    monkeypatch.setattr(importlib.import_module(MAP_MODULE), "blocks_of", lambda mechanism: None)
    general = robot.accuracy("tool", poses, payloads=[1.0, 4.0], gravity=True)
    assert calls and fast.ok.all()
    scale = np.linalg.norm(general.translation, axis=2).max()
    assert np.abs(fast.translation - general.translation).max() <= 1e-12 * scale
    assert np.isfinite(fast.reach).all()


def test_a_mechanism_with_loops_keeps_the_general_route():
    """The four-bar (a loop joint): one solve_many per payload; the reach is not computed (NaN,
    no free motions), the table says so and the JSON summary leaves it out."""
    from clearance_pin.accuracy.command import table

    four_bar = cp.load(str(ROOT / "models/four_bar.urdf"))
    amap = four_bar.accuracy("rocker", np.tile(four_bar.q_nominal, (2, 1)), payloads=[0.0, 1.0])
    assert amap.ok.all() and np.isnan(amap.reach).all() and not amap.free_motions
    assert "reach: not computed" in table(amap)
    assert "largest_reach_m" not in amap.to_dict()


def test_a_payload_on_an_unblocked_motion_is_refused():
    """The double pendulum with its shoulder no longer driven: a tip force across the arm turns
    it freely; the map says so once (UnboundedLoadError, as solve), whichever route."""
    text = (ROOT / "models/double_pendulum.urdf").read_text()
    free = cp.loads(text.replace('driven="true" q="0.5235987755982988"', 'q="0.5235987755982988"'))
    link, point = free.link_point("tip")
    push = [[cp.PointForce(link, [0.0, 5.0, 0.0], point)]]
    with pytest.raises(cp.UnboundedLoadError, match="shoulder"):
        free.accuracy("tip", np.tile(free.q_nominal, (3, 1)), payloads=push)


def test_poses_outside_the_limits_are_warned_once_at_the_callers_line():
    """As solve_many: one SuspectValueWarning naming the joint and how many poses, pointing at
    the line that asked for the map."""
    arm = cp.load(str(ROOT / "models/arm_6r.urdf"))
    poses = np.tile(arm.q_nominal, (3, 1))
    poses[1:, 1] = 7.0  # shoulder_lift's limits: +/- 6.28 rad
    with pytest.warns(cp.SuspectValueWarning, match="2 of 3 put joint 'shoulder_lift'") as caught:
        amap = arm.accuracy("tool", poses, payloads=[1.0])
    assert len(caught) == 1 and caught[0].filename == __file__
    assert amap.ok.all()


def test_payloads_beyond_double_precision_are_refused_by_name():
    arm = cp.load(str(ROOT / "models/arm_6r.urdf"))
    with pytest.raises(cp.LoadError, match=r"payloads\[1\]"):
        arm.accuracy("tool", arm.q_nominal, payloads=[1.0, 1e300])
    huge = [cp.PointForce("tool", [0.0, 0.0, 1e200])]
    with pytest.raises(cp.LoadError, match=r"payloads\[0\]"):
        arm.accuracy("tool", arm.q_nominal, payloads=[huge])


def test_the_benchmark_runs_and_its_peer_agrees():
    """benchmarks/accuracy_map.py --only ur5 on a small map, in a fresh interpreter: it prints
    the ratio and the two maps' largest difference (times are not checked)."""
    import subprocess

    ur5()  # skips without example-robot-data
    script = ROOT / "benchmarks" / "accuracy_map.py"
    arguments = ["--only", "ur5", "--poses", "20", "--payloads", "2"]
    import os

    environment = {**os.environ, "PYTHONPATH": str(ROOT)}  # this checkout's package
    done = subprocess.run([sys.executable, str(script), *arguments], capture_output=True,
                          text=True, timeout=600, check=False, env=environment)  # fmt: skip
    assert done.returncode == 0, done.stderr
    found = re.search(r"largest difference ([0-9.e+-]+) of the largest deviation", done.stdout)
    assert found and float(found.group(1)) <= 1e-12 and "ratio" in done.stdout
