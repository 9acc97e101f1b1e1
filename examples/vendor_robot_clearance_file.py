"""A vendor robot as shipped (the UR5 URDF of example-robot-data) with its play, its drives'
backlash and stiffness stated in a TOML clearance file beside it: the headline workflow, its
settled pose and its accuracy map drawn. Needs ``pip install example-robot-data``.

Run from the repository's root: ``.venv/bin/python examples/vendor_robot_clearance_file.py``.
"""

import importlib.metadata
import sys
from pathlib import Path

import numpy as np

import clearance_pin

out = Path(sys.argv[1] if len(sys.argv) > 1 else "out")
out.mkdir(parents=True, exist_ok=True)

try:
    files = importlib.metadata.distribution("example-robot-data").files or []
except importlib.metadata.PackageNotFoundError:
    sys.exit("this example needs example-robot-data: pip install example-robot-data")
urdf = next(
    (f.locate() for f in files if str(f).endswith("ur_description/urdf/ur5_robot.urdf")), None
)
if urdf is None:
    sys.exit("example-robot-data has no ur5_robot.urdf")

clearances = out / "ur5_play.toml"  # what a designer writes: the play of each joint
clearances.write_text(
    """unit = "um"

[defaults.revolute]          # every revolute joint: a journal held by its drive
type = "revolute"
radial_clearance = 10
axial_clearance = 5
length = 30_000
driven = true
backlash = 2e-4              # rad: the drive's lost motion
drive_stiffness = 4e4        # N m/rad, SI whatever the unit line says

[joints.shoulder_lift_joint]
q = -1.0                     # rad
[joints.elbow_joint]
q = 1.2

[[forces]]
link = "tool0"
point = [0, 0, 50_000]       # um, in the link frame
value = [20.0, -30.0, -50.0] # N, world axes
"""
)
ur5 = clearance_pin.load(str(urdf), clearances=str(clearances))
answer = ur5.solve(outputs=["tool0"])
assert answer.ok
translation, rotation = answer.outputs["tool0"]
print(f"UR5 tool0 moves {np.linalg.norm(translation) * 1e6:.1f} um under 62 N")
print(answer.table().splitlines()[0])

# the pictures: the settled pose, and the accuracy over 300 poses and three payloads
from clearance_pin.accuracy.plot import plot_accuracy  # noqa: E402  (the plot extra)
from clearance_pin.plot import plot_equilibrium  # noqa: E402

plot_equilibrium(answer, out / "ur5_settled.png")
poses = ur5.q_nominal + np.random.default_rng(0).uniform(-0.6, 0.6, (300, ur5.model.nq))
amap = ur5.accuracy("tool0", poses, payloads=[0.0, 2.0, 5.0])
for source, joint, share in amap.ranking()[:3]:
    print(f"  {joint}'s {source}: up to {share * 1e6:.0f} um")
plot_accuracy(amap, ur5, out / "ur5_accuracy_map.png")
print(f"pictures: {out / 'ur5_settled.png'}, {out / 'ur5_accuracy_map.png'}")
