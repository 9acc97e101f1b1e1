"""Every bundled model (models/*.urdf) loads, is documented, and solves in both formulations with
contacts that are consistent: touching and pushing, or apart and force-free."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import MODEL_FILES, MODELS

import clearance_pin as cp

LINEAR_GAP = 1e-10  # of the play: the linear answer is polished to round-off
EXACT_GAP = 1e-7  # of the play: the exact model's own threshold for a contact (IPOPT barrier)


@pytest.fixture(scope="module", params=MODEL_FILES, ids=lambda p: p.stem)
def solved(request):
    """(mechanism, linear, exact) of one bundled model."""
    mechanism = cp.load(request.param)
    return mechanism, mechanism.solve(), mechanism.solve(exact=True)


def test_there_are_models():
    """The six bundled models are there."""
    assert {p.stem for p in MODEL_FILES} >= {
        "arm_6r",
        "four_bar",
        "slider_crank",
        "younes_sphere_cylinder",
        "younes_two_cylinders",
        "younes_two_spheres",
    }


@pytest.mark.parametrize("path", MODEL_FILES, ids=lambda p: p.stem)
def test_every_model_is_listed_in_the_readme(path):
    """models/README.md has a row for every model file (where it comes from, what it is)."""
    assert f"`{path.name}`" in (MODELS / "README.md").read_text()


def test_both_formulations_are_verified(solved):
    """Linear and exact equilibria are 'optimal' and check themselves ok; the exact one records
    the linear one it started from and their difference."""
    _, linear, exact = solved
    assert linear.formulation == "linear" and exact.formulation == "exact"
    assert linear.status == exact.status == "optimal"
    assert linear.ok and exact.ok
    assert exact.linear is not None and exact.difference is not None
    assert linear.residuals["statics"] < 1e-9 and exact.residuals["statics"] < 1e-9


def test_every_joint_has_a_torsor(solved):
    """Both results hold a finite torsor (6,) for every tree and loop joint, and nothing else."""
    mechanism, linear, exact = solved
    for result in (linear, exact):
        assert set(result.torsors) == set(mechanism.joints)
        for torsor in result.torsors.values():
            assert torsor.shape == (6,) and np.all(np.isfinite(torsor))


@pytest.mark.parametrize(
    ("which", "tolerance"), [(1, LINEAR_GAP), (2, EXACT_GAP)], ids=["linear", "exact"]
)
def test_contacts_touch_and_push_or_are_free(solved, which, tolerance):
    """Every active contact has a gap ~ 0 (linear: 1e-10 of its play; exact: 1e-7, the model's
    threshold) and a force > 0; every inactive one a positive gap and a zero force; no contact
    penetrates its play by more than 1e-12 of it."""
    result = solved[which]
    assert result.active_contacts, "a loaded mechanism touches somewhere"
    for contact in result.contacts:
        if contact.active:
            assert abs(contact.gap) <= tolerance * contact.clearance, contact
            assert contact.force_magnitude > 0.0, contact
        else:
            assert contact.gap > 0.0 and contact.force_magnitude == 0.0, contact
        assert contact.gap >= -1e-12 * contact.clearance
    assert result.residuals["max_violation_m"] <= 1e-12 * result.residuals["clearance_m"]


def test_exact_complementarity(solved):
    """Exact model: the work of the contact forces across their gaps, sum |f| gap, is below 1e-9
    of the load's work |V| (force and gap are complementary)."""
    _, _, exact = solved
    slack_work = sum(c.force_magnitude * max(c.gap, 0.0) for c in exact.contacts)
    assert slack_work <= 1e-9 * abs(exact.energy)


def test_energy_is_negative_and_linear_is_first_order_close(solved):
    """The load does positive work when the parts settle (V < 0), and the exact and linear
    energies agree to 1e-2 relative (their difference is second order in clearance / size)."""
    _, linear, exact = solved
    assert linear.energy < 0.0 and exact.energy < 0.0
    assert exact.energy == pytest.approx(linear.energy, rel=1e-2)


def test_reports_are_complete(solved):
    """to_dict and table render every joint and contact (JSON-ready numbers, readable text)."""
    import json

    mechanism, linear, exact = solved
    for result in (linear, exact):
        record = json.loads(json.dumps(result.to_dict(length=1e3, unit="mm")))
        assert set(record["torsors"]) == set(mechanism.joints)
        assert len(record["contacts"]) == len(result.contacts)
        text = result.table()
        assert all(name in text for name in mechanism.joints)
