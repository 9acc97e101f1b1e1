"""The published cases of Younes, Dal Santo & Potiron, section 6 (validation/younes2013_cases.toml).

Inputs are SI in the case file; the reference values are in the paper's units (mm, rad, N mm).
Every case is built from its inputs with the shaft builder and read by the model-file reader.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import CASES, EXPECTED_CASES, MM, build_case

TOLERANCE_MM = 1e-9
TOLERANCE_RAD = 1e-11


def test_the_case_file_has_reference_values():
    """The three cases with published numbers are present (6.1.6.1a, 6.2.2, 6.3.1)."""
    assert EXPECTED_CASES == ["6.1.6.1a", "6.2.2", "6.3.1"]


@pytest.mark.parametrize("case_id", EXPECTED_CASES)
def test_torsors_match_the_reference_values(case_id):
    """T1 and T2 of the small-displacement model equal the reference to 1e-9 mm and 1e-11 rad."""
    case = CASES[case_id]
    result = build_case(case).solve()
    assert result.ok and result.status == "optimal"
    for joint, key in (("I1", "T1"), ("I2", "T2")):
        torsor = result.torsor(joint)
        expected = np.array(case["expected_mm"][key])
        np.testing.assert_allclose(torsor[:3] * MM, expected[:3], rtol=0, atol=TOLERANCE_MM)
        np.testing.assert_allclose(torsor[3:], expected[3:], rtol=0, atol=TOLERANCE_RAD)


@pytest.mark.parametrize("case_id", EXPECTED_CASES)
def test_energy_matches_the_reference_value(case_id):
    """The potential of the load at the equilibrium [N mm] equals the reference to 1e-9 relative."""
    case = CASES[case_id]
    energy_nmm = build_case(case).solve().energy * MM
    assert energy_nmm == pytest.approx(case["expected_mm"]["energy"], rel=1e-9, abs=0)


@pytest.mark.parametrize("case_id", EXPECTED_CASES)
def test_torsors_agree_with_the_printed_digits(case_id):
    """The digits the paper prints agree with ours to its own rounding (7 significant digits on
    the components it resolves, |value| > 1e-9; its round-off noise ~1e-15..1e-306 is not
    compared)."""
    case = CASES[case_id]
    result = build_case(case).solve()
    for joint, key in (("I1", "T1"), ("I2", "T2")):
        ours = np.concatenate([result.torsor(joint)[:3] * MM, result.torsor(joint)[3:]])
        for value, printed in zip(ours, case["expected_mm"][f"paper_{key}"]):
            if abs(printed) > 1e-9:
                assert value == pytest.approx(printed, rel=1e-6), (joint, ours, printed)
            else:
                assert abs(value) < 1e-12


@pytest.mark.parametrize("case_id", sorted(CASES))
def test_every_paper_case_solves_in_both_formulations(case_id):
    """Every case of section 6 (with or without published numbers) has a verified equilibrium in
    both formulations, and the two agree to within the largest clearance."""
    mechanism = build_case(CASES[case_id])
    linear = mechanism.solve()
    exact = mechanism.solve(exact=True)
    assert linear.ok and exact.ok
    assert exact.formulation == "exact" and exact.linear is not None
    c = max(j["diametral_clearance_m"] for j in CASES[case_id]["joint"]) / 2
    for joint in ("I1", "I2"):
        assert np.max(np.abs(exact.torsor(joint)[:3] - linear.torsor(joint)[:3])) < c


def test_case_6_3_2_variant_has_no_contact_in_joint_1():
    """6.3.2 with J1 = 0.5 mm: the paper states that joint 1 carries no contact (the torque is
    taken by joint 2 alone, whose tilt J2/L2 fits inside joint 1's play)."""
    result = build_case(CASES["6.3.2-J1=0.5"]).solve()
    joints = {c.joint for c in result.active_contacts}
    assert joints == {"I2"}
    np.testing.assert_allclose(result.torsor("I2")[5], 1e-4 / 0.06, rtol=1e-12)
