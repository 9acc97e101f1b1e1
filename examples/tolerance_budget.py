"""How far do the slider-crank's dimensional tolerances (its two link lengths, ISO 286 IT10) move
the slider over a crank turn? Worst case, RSS and Monte Carlo (Flores' sensitivities).

Run from the repository's root: ``.venv/bin/python examples/tolerance_budget.py``.
"""

import numpy as np

import clearance_pin
from clearance_pin.tolerance.sweep import sweep

slider_crank = clearance_pin.load("models/slider_crank.urdf")  # its <dimension> elements
result = sweep(slider_crank, ["x4=slider.x"], clockwise=True, positions=25, samples=2000)
worst = int(np.argmax(result.worst[:, 0]))
print(
    f"slider position band, worst case: {result.worst[worst, 0] * 1e6:.1f} um "
    f"at {result.phi_deg[worst]:.0f} deg; RSS there {result.rss[worst, 0] * 1e6:.1f} um"
)
for j, dimension in enumerate(result.dimensions):
    share = np.abs(result.matrix[worst, 0, j]) * dimension.half_tolerance
    print(f"  {dimension.name}: contributes {share * 1e6:.1f} um of the worst case there")
