"""A robot's accuracy over its workspace: where the 6R arm's tool settles in the joint play over
200 poses and three payloads, and which joint moves it most.

Run from the repository's root: ``.venv/bin/python examples/robot_accuracy_map.py [OUT_DIR]``.
"""

import sys
from pathlib import Path

import numpy as np

import clearance_pin
from clearance_pin.accuracy.plot import plot_accuracy

out = Path(sys.argv[1] if len(sys.argv) > 1 else "out")
out.mkdir(parents=True, exist_ok=True)

arm = clearance_pin.load("models/arm_6r.urdf")
poses = arm.q_nominal + np.random.default_rng(0).uniform(-0.5, 0.5, (200, arm.model.nq))
amap = arm.accuracy("tool", poses, payloads=[0.0, 2.0, 5.0])  # masses [kg] at the tool
largest, pose, payload = amap.largest()
print(f"largest deviation {largest * 1e6:.0f} um (pose {pose}, {amap.payloads[payload]})")
for source, joint, share in amap.ranking()[:3]:
    print(f"  {joint}'s {source}: up to {share * 1e6:.0f} um")
plot_accuracy(amap, arm, out / "robot_accuracy_map.png")
print(f"picture: {out / 'robot_accuracy_map.png'}")
