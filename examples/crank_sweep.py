"""A four-bar's crank turned through a cycle: where do the pins sit in their play at each angle?

Run from the repository's root: ``.venv/bin/python examples/crank_sweep.py [OUT_DIR]``.
"""

import sys
from pathlib import Path

import numpy as np

import clearance_pin
from clearance_pin.plot import plot_trajectory

out = Path(sys.argv[1] if len(sys.argv) > 1 else "out")
out.mkdir(parents=True, exist_ok=True)

four_bar = clearance_pin.load("models/four_bar.urdf")
crank = four_bar.model.joints[four_bar.model.getJointId("crank_pivot")].idx_q
angles = np.linspace(0.0, 2.0 * np.pi, 73)
configurations = []
for angle in angles:
    q = four_bar.q_nominal.copy()
    q[crank] = angle  # the passive joints are closed for each by solve_many
    configurations.append(q)
batch = four_bar.solve_many(configurations=configurations)
assert batch.ok.all()
translation, _ = batch.frame_displacements("rocker_B")  # (73, 3) [m]
worst = int(np.argmax(np.linalg.norm(translation, axis=1)))
print(
    f"rocker_B moves up to {np.linalg.norm(translation[worst]) * 1e6:.1f} um "
    f"(crank at {np.degrees(angles[worst]):.0f} deg)"
)
plot_trajectory(
    batch, driven_joint="crank_pivot", outputs=["rocker_B"], path=out / "crank_sweep.png"
)
print(f"picture: {out / 'crank_sweep.png'}")
