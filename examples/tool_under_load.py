"""Where does the 6R arm's tool settle in its joint play under its 50 N load and its weight?

Run from the repository's root: ``.venv/bin/python examples/tool_under_load.py [OUT_DIR]``.
"""

import sys
from pathlib import Path

import pinocchio as pin

import clearance_pin
from clearance_pin.plot import plot_equilibrium

out = Path(sys.argv[1] if len(sys.argv) > 1 else "out")
out.mkdir(parents=True, exist_ok=True)

arm = clearance_pin.load("models/arm_6r.urdf")  # journals with 10 um radial, 5 um axial play
exact = arm.solve(
    exact=True, outputs=["tool"]
)  # finite displacements; exact.linear: the linear one
assert exact.ok  # residuals measured by the library: statics, penetration, KKT

moved = exact.frame_displacement("tool")  # a pin.Motion, world axes (LOCAL_WORLD_ALIGNED)
print(f"tool moves {moved.linear * 1e6} um and turns {moved.angular * 1e6} urad")
local = exact.frame_displacement("tool", pin.LOCAL)  # the same in the tool's own axes
print(f"in the tool's axes: {local.linear * 1e6} um")
print(f"exact - linear at the tool: {exact.difference['outputs']['tool'][0] * 1e6} um")

for joint in arm.joints:  # bearing loads: the wrench the parent exerts through each joint
    force = exact.reaction(joint).as_force()  # a pin.Force in the joint's clearance frame
    radial = (force.linear[1] ** 2 + force.linear[2] ** 2) ** 0.5
    print(f"{joint:>14}: radial {radial:8.2f} N, axial {force.linear[0]:8.2f} N")

print(f"answered by {exact.method.value}; linear answer by {exact.linear.method.value}")
plot_equilibrium(exact, out / "tool_under_load.png")
print(f"picture: {out / 'tool_under_load.png'}")
