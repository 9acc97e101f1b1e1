r"""Accuracy-map speed (issue 23: 1000 poses x 10 payloads on a 7-joint arm in at most 1 s).

The Franka Panda of example-robot-data with the corpus clearances (tests/test_corpus_robots.py:
every arm joint a driven journal, radial play 10 um, axial 5 um, length 30 mm; the fingers held by
their drives), and the bundled 6R arm: 1000 random poses within +/- 0.5 rad of the nominal one,
payloads 0 to 9 kg at the tool, the robot's own weight on (gravity=True). Timed in a fresh process
as a user calls it, the mechanism built outside the timing; reported beside it: a loop of
``Mechanism.solve`` over a sample of the same cases (the way without the map), scaled to the
whole map. Each robot runs twice: as it is, and with joint stiffness (every arm drive
``drive_stiffness`` 2e4 N m/rad, every arm journal ``tilt_stiffness`` 2e5 N m/rad: a tree's springs
add to its play by superposition, docs/method.md section 2.2.2).

Usage: ``python benchmarks/accuracy_map.py [--poses 1000] [--payloads 10]``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))

import clearance_pin
from clearance_pin import PointForce

SPRINGS = 'driven="true" drive_stiffness="2e4" tilt_stiffness="2e5"'


def stiffened(text: str) -> str:
    """The clearance block with a spring on every driven journal (fingers excepted)."""
    block = text[text.index("<clearance_pin>") :]
    journals = block.replace('type="revolute" radial_clearance', "SPRUNG radial_clearance")
    sprung = "\n".join(
        line.replace('driven="true"', SPRINGS) if "SPRUNG" in line else line
        for line in journals.splitlines()
    ).replace("SPRUNG", 'type="revolute"')
    return text.replace(block, sprung)


def robots():
    import test_corpus_robots as corpus

    arm = (ROOT / "models/arm_6r.urdf").read_text()
    yield "6R arm (models/arm_6r.urdf)", clearance_pin.loads(arm), "tool"
    yield "6R arm with springs", clearance_pin.loads(stiffened(arm)), "tool"
    try:
        text = corpus.model_text("panda").replace(
            "<clearance_pin>\n",
            "<clearance_pin>\n"  # the fingers held by their drive: they do not slide under gravity
            '  <joint name="panda_finger_joint1" driven="true"/>\n'
            '  <joint name="panda_finger_joint2" driven="true"/>\n',
        )
        panda = clearance_pin.loads(text)
        sprung = clearance_pin.loads(stiffened(text))
    except BaseException:  # pytest.skip without example-robot-data
        return
    yield "Franka Panda (example-robot-data)", panda, corpus.ROBOTS["panda"][2]
    yield "Franka Panda with springs", sprung, corpus.ROBOTS["panda"][2]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=1000)
    parser.add_argument("--payloads", type=int, default=10)
    args = parser.parse_args()
    for name, robot, tool in robots():
        rng = np.random.default_rng(0)
        driven = [  # the arm's revolute drives (not the Panda's fingers)
            robot.model.joints[j.joint_id].idx_q
            for j in robot.tree_joints
            if j.driven and j.motion_component == 3
        ]
        poses = np.tile(robot.q_nominal, (args.poses, 1))
        poses[:, driven] += rng.uniform(-0.5, 0.5, (args.poses, len(driven)))
        masses = list(np.linspace(0.0, 9.0, args.payloads))
        started = time.perf_counter()
        amap = robot.accuracy(tool, poses, payloads=masses, gravity=True)
        seconds = time.perf_counter() - started
        link, point = robot.link_point(tool)
        sample = 50
        started = time.perf_counter()
        for i in range(sample):
            mass = masses[i % len(masses)]
            loads = [PointForce(link, [0, 0, -9.80665 * mass], point)] if mass else []
            robot.solve(loads=loads, q=poses[i], gravity=True)
        loop = (time.perf_counter() - started) / sample * args.poses * args.payloads
        largest, pose, payload = amap.largest()
        top = amap.ranking()[0]
        print(
            f"{name}: {args.poses} poses x {args.payloads} payloads in {seconds:.2f} s "
            f"(a loop of solve: about {loop:.1f} s); all verified {amap.ok.all()}; largest "
            f"{largest * 1e6:.1f} um at pose {pose}, {amap.payloads[payload]}; first contributor "
            f"{top[0]} of {top[1]} {top[2] * 1e6:.1f} um"
        )


if __name__ == "__main__":
    main()
