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


# A ram on a prismatic joint whose block has no width: its corners pair up at one x and one z
# with identical rows (the z slabs of corners (x, 0, -h/2) and (x, 0, +h/2)); a force and a torque.
FLAT_BLOCK = """<?xml version="1.0"?>
<robot name="flat_block">
  <link name="ground"/><link name="ram"/>
  <joint name="slide" type="prismatic"><parent link="ground"/><child link="ram"/>
    <origin xyz="0 0 0.1"/><axis xyz="1 0 0"/>
    <limit lower="-0.2" upper="0.2" effort="100" velocity="1"/></joint>
  <clearance_pin>
    <joint name="slide" type="prismatic" radial_clearance="2e-05" length="0.08" width="0"
           height="0.02" driven="true"/>
    <force link="ram" point="0.1 0.01 0.02" value="5 -20 -30"/>
    <torque link="ram" value="0.3 -0.2 0.1"/>
  </clearance_pin>
</robot>
"""


def _least_norm_reference(equilibrium) -> np.ndarray:
    """The least-norm non-negative split of the block's contact forces with the same wrench
    about the joint centre, from the reported points and force directions alone: min |mu|^2
    s.t. sum_j mu_j (d_j, p_j x d_j) = the reported wrench, mu >= 0 (cvxpy, Clarabel), over the
    loaded contacts (a contact left unloaded by the least-norm split is unloaded in the least-norm
    split of any subset holding the support); the others must carry nothing."""
    import cvxpy as cp

    contacts = [c for c in equilibrium.contacts if c.joint == "slide" and c.force_magnitude]
    directions = [c.force / c.force_magnitude for c in contacts]
    columns = np.array(
        [np.concatenate([d, np.cross(c.position, d)]) for c, d in zip(contacts, directions)]
    ).T
    given = np.array([c.force @ d for c, d in zip(contacts, directions)])
    mu = cp.Variable(len(contacts))
    cp.Problem(cp.Minimize(cp.sum_squares(mu)), [columns @ mu == columns @ given, mu >= 0]).solve(
        solver=cp.CLARABEL, tol_gap_abs=1e-12, tol_gap_rel=1e-12, tol_feas=1e-12
    )
    return np.array([np.asarray(mu.value)[i] * d for i, d in enumerate(directions)])


@pytest.mark.filterwarnings("ignore::clearance_pin.errors.KernelUnavailableWarning")
def test_coinciding_corners_get_the_least_norm_split_on_every_engine(monkeypatch):
    """Issue 21 item 4: where two corner slabs coincide (a block of width 0), the compiled
    kernel from the centre put the whole force on one of them (-21.25 / 0 N), IPOPT and the
    NumPy path split it otherwise (three engines, three splits of the same wrench). Now every
    engine reports the least-norm split (docs/method.md section 3.3), checked against an
    independent least-norm programme on the reported points and directions."""
    answers = {}
    monkeypatch.setenv("CLEARANCE_PIN_COMPILED", "0")
    for backend in ("auto", "clarabel", "ipopt"):
        answers[backend] = clearance_pin.loads(FLAT_BLOCK).solve(warm_start=False, backend=backend)
    try:
        fast_path.load_kernel()
    except ImportError:
        pass
    monkeypatch.setenv("CLEARANCE_PIN_COMPILED", "1")
    walked = clearance_pin.loads(FLAT_BLOCK)
    walked.solve()
    answers["kernel"] = walked.solve(warm_start=False)
    reference = answers["auto"]
    loaded = np.array([c.force_magnitude > 0.0 for c in reference.contacts if c.joint == "slide"])
    expected = _least_norm_reference(reference)
    largest = np.abs(expected).max()
    for name, answer in answers.items():
        assert answer.ok, name
        forces = _block_forces(answer)
        assert np.abs(forces[loaded] - expected).max() <= 1e-6 * largest, name
        assert np.abs(forces[~loaded]).max(initial=0.0) <= 1e-9 * largest, name
    # the coinciding z slabs at x = -L/2 carry the same force
    z_minus = [
        c.force[2] for c in reference.contacts if c.point in ("corner(-0-).z", "corner(-0+).z")
    ]
    assert z_minus[0] < 0.0 and abs(z_minus[0] - z_minus[1]) <= 1e-9 * largest
