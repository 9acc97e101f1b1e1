"""One KKT residual (issue 22): :func:`clearance_pin.equilibrium.kkt.kkt_table` defines it; the
single answers, the NumPy batches, the closed forms' batches and the compiled kernel are
measured by it (the kernel by its compiled copy, compared with it here)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import CASES

from clearance_pin import Method, PointForce, Torque
from clearance_pin.equilibrium import fast_path, kkt
from clearance_pin.equilibrium.prepared import prepared_geometry

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "validation"))
from younes2013 import build


def _by_hand(objective, gradients, contacts, multipliers, phi) -> list[float]:
    """The definition written out (docs/method.md section 3): |f + sum lambda grad phi|_inf over
    the active contacts, max(phi, 0), max |lambda phi|, max(-lambda, 0)."""
    pull = sum(multipliers[c] * gradients[a] for a, c in enumerate(contacts))
    return [
        max(abs(objective + pull)),
        max(0.0, *phi),
        max(abs(multipliers * phi)),
        max(0.0, -min(multipliers)),
    ]


@pytest.mark.parametrize("seed", range(5))
def test_the_compiled_copy_is_the_definition(seed):
    """On random residuals far from zero (multipliers of either sign, contacts outside their
    boundary): the kernel's compiled copy, kkt_table and the definition written out agree."""
    kernel = pytest.importorskip("clearance_pin.equilibrium.kernel")
    rng = np.random.default_rng(seed)
    r, m = 5, 7
    objective = rng.normal(size=r)
    multipliers = rng.normal(size=m)
    phi = rng.normal(size=m)
    contacts = np.sort(rng.choice(m, size=4, replace=False))
    gradients = rng.normal(size=(contacts.size, r))
    expected = _by_hand(objective, gradients, contacts, multipliers, phi)
    compiled = kernel.kkt_residuals(objective, gradients, contacts, multipliers, phi)
    active = np.zeros(m)
    active[contacts] = multipliers[contacts]
    stationarity = objective + active[contacts] @ gradients
    table = kkt.kkt_table(stationarity[None], phi[None], multipliers[None])[0]
    np.testing.assert_allclose(compiled, expected, rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(table, expected, rtol=1e-14, atol=1e-15)
    assert min(expected) > 0.0  # every residual exercised


@pytest.mark.parametrize("case_id", ["6.1.6.1a", "6.2.2", "6.3.1"])
def test_compiled_answers_report_the_defined_residuals(case_id):
    """A compiled re-solve's reported KKT residuals are kkt.residuals of its own answer (y,
    multipliers, sides) to round-off."""
    pytest.importorskip("numba")
    if not fast_path.load_kernel():
        pytest.skip("the compiled kernel cannot load here")
    mechanism = build(CASES[case_id])
    mechanism.solve()
    loads = [
        PointForce(load.link, 1.3 * load.force, load.point)
        if isinstance(load, PointForce)
        else Torque(load.link, 0.7 * load.torque)
        for load in mechanism.loads
    ]
    answer = mechanism.solve(loads)
    assert answer.method is Method.COMPILED
    prepared = prepared_geometry(mechanism)
    problem = prepared.problem(mechanism.resolve_loads(loads, None))
    solution = mechanism.cache.warm[prepared.signature]
    measured = kkt.residuals(
        problem.stack, problem.objective, solution.y, solution.multipliers, solution.signs
    )
    for name in kkt.RESIDUAL_NAMES:
        assert answer.residuals.get(name) == pytest.approx(measured[name], abs=1e-14)
