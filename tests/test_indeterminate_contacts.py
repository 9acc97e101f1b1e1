"""Statically indeterminate contacts share the load by the minimum-norm split (docs/method.md
section 3.2) whichever path found the optimum: a prismatic block whose corners on one face are
reached one by one by the active-set walk from the centre (compiled and NumPy) gets the split
that Clarabel's interior point, polished, gives (the block's corners all touching there).

The reference is the library's Clarabel path (another optimiser, the same polish: a consistency
check); the test also checks the split is the smaller of the two in sum (|f| c)^2, the quantity
it minimises, and that the torsors (unique) agree."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import clearance_pin
from clearance_pin import PointForce, Torque
from clearance_pin.equilibrium import fast_path

MODEL = Path(__file__).resolve().parent / "data" / "indeterminate" / "rpr_arm_block.urdf"
# the reviewer's load on which the walk from the centre put 72 N on one corner of four
LOAD = ((-27.84203747623689, -4.512116615221723, -17.50844516520337),
        (1.0014102256801642, 0.14408536849992318, 0.7820845225598966))  # fmt: skip


def _loads(force, torque):
    return [PointForce("wrist", force, [0.1, 0.0, 0.02]), Torque("wrist", torque)]


def _block_forces(equilibrium):
    return np.array([c.force for c in equilibrium.contacts if c.joint == "slide"])


def _split_size(equilibrium):
    return sum(
        (np.linalg.norm(c.force) * c.clearance) ** 2
        for c in equilibrium.contacts
        if c.joint == "slide"
    )


@pytest.mark.parametrize("compiled", ["1", "0"])
def test_block_corners_share_the_load_on_every_path(compiled, monkeypatch):
    monkeypatch.setenv("CLEARANCE_PIN_COMPILED", compiled)
    if compiled == "1":
        fast_path.load_kernel()
    mechanism = clearance_pin.load(str(MODEL))
    reference = clearance_pin.load(str(MODEL))
    mechanism.solve()
    rng = np.random.default_rng(17)
    loads = [_loads(*LOAD)]
    for _ in range(6):
        force = np.array(LOAD[0]) * (1.0 + 0.2 * rng.standard_normal(3))
        loads.append(_loads(force, np.array(LOAD[1]) * (1.0 + 0.2 * rng.standard_normal(3))))
    for case in loads:
        walked = mechanism.solve(case, warm_start=False)
        polished = reference.solve(case, warm_start=False, backend="clarabel")
        assert walked.ok and polished.ok
        largest = np.abs(_block_forces(polished)).max()
        assert np.abs(_block_forces(walked) - _block_forces(polished)).max() <= 1e-7 * largest
        assert _split_size(walked) <= _split_size(polished) * (1.0 + 1e-9)
        for joint, torsor in polished.torsors.items():
            assert np.abs(walked.torsors[joint] - torsor).max() <= 1e-13
