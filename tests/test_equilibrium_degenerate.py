"""Degenerate loads and limiting clearances (docs/method.md sections 2-3, the reduction's consequences).

- A load along a motion that nothing blocks has no equilibrium: UnboundedLoadError naming it.
- A load that works on no admissible motion leaves everything indeterminate: zero torsors.
- Ideal joints (zero clearance) and nearly ideal ones are limits of the general case.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import CASES, MODELS, build_case, case_specs, case_text

import clearance_pin as cp
from clearance_pin.model.builders import JointSpec, shaft_urdf

NULL_SPACE_OF_ROUND_OFF = (
    "reduction: a motion that no contact sees is detected by null_space(contact rows x closure "
    "basis) with a purely relative rank tolerance; when those products are pure round-off "
    "(~1e-16) they are ranked as real constraints, the free slide u is kept as an unknown bounded "
    "only by round-off and the optimiser sends it to u = 6.0e10 m; the result says ok=True"
)
TINY_CLEARANCE = (
    "a nearly ideal joint (J2 = 1 nm .. 1 pm beside J1 = 0.3 mm) makes the linear solve raise "
    "SolverError (clarabel AlmostSolved / InsufficientProgress, polish refused) although J2 = 0 "
    "and J2 = 1 um both solve"
)
EXACT_STATUS = (
    "with no load the exact model reports status 'optimal' (hard-coded in exact._assemble) where "
    "the linear one reports 'indeterminate'"
)


# -- unbounded loads --------------------------------------------------------------------------------
@pytest.mark.parametrize("case_id", ["6.3.2", "6.1.6.1a", "6.2.2"])
def test_torque_about_the_free_spin_raises_and_names_it(case_id):
    """A torque about the shaft axis of a shaft whose spin nothing blocks: UnboundedLoadError,
    whose message and ``motions`` name the joints and their spin 'alpha', with the share of the
    load along it (here all of it)."""
    case = CASES[case_id]
    text = case_text(case, load=(case["load"]["point_m"], (0.0, 0.0, 0.0), (2.0, 0.0, 0.0)))
    if case_id == "6.2.2":  # two balls: the free rotation is about the line of centres
        axis = np.asarray(case["joint"][1]["center_m"]) / np.linalg.norm(
            case["joint"][1]["center_m"]
        )
        text = case_text(case, load=(case["load"]["point_m"], (0.0, 0.0, 0.0), 2.0 * axis))
    with pytest.raises(cp.UnboundedLoadError) as caught:
        cp.loads(text).solve()
    error = caught.value
    assert "alpha" in str(error) and "'I1'" in str(error) and "'I2'" in str(error)
    assert any("alpha" in m and "'I1'" in m for m in error.motions)
    assert error.fraction == pytest.approx(1.0, rel=1e-9)


def test_an_unbounded_motion_says_it_names_its_largest_components():
    """A reviewer's four-bar with its crank undriven (tests/data/unbounded/)
    turns freely; the motion turns every pin, the rocker's by 14 % of the largest: the message
    names the three larger ones and says it leaves one smaller component out (the reviewer read
    the list as the whole motion)."""
    # in its own folder: the corpus tests solve every tests/data/*.urdf, and this one has no
    # equilibrium by design
    path = MODELS.parent / "tests" / "data" / "unbounded" / "fourbar_undriven_reviewer.urdf"
    mechanism = cp.load(path)
    with pytest.raises(cp.UnboundedLoadError) as caught:
        mechanism.solve()
    motions = caught.value.motions
    assert len(motions) == 4 and all("alpha" in m for m in motions[:3])
    assert motions[3] == "and 1 smaller component (under 20 % of the largest)"
    assert "rocker_joint" not in str(caught.value) and motions[3] in str(caught.value)


def test_partly_unbounded_load_reports_its_share():
    """A force with an axial component on a shaft on two journals (slide u free): the error names
    the slide 'u' of the joints and reports the share of the load along it (|F_x| / |F| in the
    scaled unknowns, strictly between 0 and 1)."""
    case = CASES["6.3.1"]
    text = case_text(case, load=(case["load"]["point_m"], (0.5, 1.0, 1.0), (0.0, 0.0, 0.0)))
    with pytest.raises(cp.UnboundedLoadError) as caught:
        cp.loads(text).solve()
    assert any("'I1' u" in m for m in caught.value.motions)
    assert "slide" in str(caught.value)
    assert 0.0 < caught.value.fraction < 1.0


def test_off_centre_force_on_a_lone_ball_raises():
    """A part held by one spherical joint and pushed off its centre: the ball's rotations are
    free, the moment turns it without bound: UnboundedLoadError naming rotations of the joint."""
    case = CASES["6.2.2"]
    first, _ = case_specs(case)
    text = f"""<robot name="ball"><link name="ground"/><link name="part"/>
      <joint name="S" type="floating"><parent link="ground"/><child link="part"/></joint>
      <clearance_pin><joint name="S" type="spherical" diametral_clearance="{first.diametral!r}"/>
      <force link="part" point="0.1 0 0" value="0 1 0"/></clearance_pin></robot>"""
    with pytest.raises(cp.UnboundedLoadError) as caught:
        cp.loads(text).solve()
    assert any("'S' gamma" in m for m in caught.value.motions)


def test_unbounded_is_raised_by_the_exact_model_too():
    """exact=True on an unbounded load raises the same UnboundedLoadError (no optimiser run)."""
    case = CASES["6.3.2"]
    text = case_text(case, load=(case["load"]["point_m"], (0.0, 0.0, 0.0), (1.0, 0.0, 0.0)))
    with pytest.raises(cp.UnboundedLoadError):
        cp.loads(text).solve(exact=True)


# -- indeterminate equilibria ---------------------------------------------------------------------------
@pytest.mark.parametrize("case_id", sorted(CASES))
def test_zero_load_is_indeterminate_with_zero_torsors(case_id):
    """No load: status 'indeterminate', every torsor exactly zero, zero energy, no contact force,
    and the result still checks itself as ok."""
    result = build_case(CASES[case_id]).solve(loads=[])
    assert result.status == "indeterminate" and result.ok
    assert result.energy == 0.0
    for torsor in result.torsors.values():
        assert not np.any(torsor)
    assert all(c.force_magnitude == 0.0 and not c.active for c in result.contacts)


def test_zero_force_values_are_indeterminate():
    """Loads given but all zero (force (0, 0, 0), torque (0, 0, 0)) are no load."""
    case = CASES["6.1.6.1a"]
    text = case_text(case, load=(case["load"]["point_m"], (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)))
    result = cp.loads(text).solve()
    assert result.status == "indeterminate"
    assert all(not np.any(t) for t in result.torsors.values())


def test_load_on_the_ground_does_no_work():
    """A force on the fixed ground (a frame of the universe) moves nothing: indeterminate."""
    result = build_case(CASES["6.1.6.1a"]).solve(
        loads=[cp.PointForce("ground_I2", [1.0, 2.0, 3.0])]
    )
    assert result.status == "indeterminate"
    assert all(not np.any(t) for t in result.torsors.values())


def test_zero_load_exact_is_indeterminate():
    """No load, exact model: status 'indeterminate' and zero torsors, as in the linear model."""
    result = build_case(CASES["6.1.6.1a"]).solve(loads=[], exact=True)
    assert all(not np.any(t) for t in result.torsors.values())
    assert result.status == "indeterminate"


# -- ideal and nearly ideal joints ------------------------------------------------------------------------
def ideal_second_joint(case_id: str, diametral: float):
    """A paper case whose joint I2 has the diametral clearance ``diametral`` [m]."""
    case = CASES[case_id]
    first, second = case_specs(case)
    second = JointSpec(
        second.name, second.kind, second.center, diametral, second.length, second.axis
    )
    load = case["load"]
    return cp.loads(shaft_urdf(first, second, load["point_m"], load["force_N"], load["torque_Nm"]))


def test_ideal_ball_as_a_loop_joint():
    """6.2.2 with I2 an ideal ball (J2 = 0): the shaft pivots about O2, I1 moves by c1 along the
    component of F across O1O2 (the force's moment about O2 turns the shaft), I2 does not move."""
    result = ideal_second_joint("6.2.2", 0.0).solve()
    c1 = CASES["6.2.2"]["joint"][0]["diametral_clearance_m"] / 2
    o2 = np.asarray(CASES["6.2.2"]["joint"][1]["center_m"])
    force = np.asarray(CASES["6.2.2"]["load"]["force_N"])
    axis = o2 / np.linalg.norm(o2)
    across = force - (force @ axis) * axis
    np.testing.assert_allclose(
        result.torsor("I1")[:3], c1 * across / np.linalg.norm(across), atol=1e-12 * c1
    )
    np.testing.assert_allclose(result.torsor("I2")[:3], 0.0, atol=1e-12 * c1)
    assert result.ok


def test_ideal_journal_as_a_loop_joint():
    """6.3.1 with I2 an ideal journal (J2 = 0): the shaft can only slide and spin in I2, which
    the load (0, 1, 1) N does not work on: status 'indeterminate', torsors zero. (Found:
    u = 6.0e10 m in both joints, v1 = 8.3e-5 m, status 'optimal', ok=True.)"""
    result = ideal_second_joint("6.3.1", 0.0).solve()
    assert result.ok
    for torsor in result.torsors.values():
        assert np.max(np.abs(torsor[:3])) <= 1e-15
    assert result.status == "indeterminate"


@pytest.mark.parametrize(
    "diametral",
    [
        1e-6,
        pytest.param(1e-9),
        pytest.param(
            1e-12,
            marks=pytest.mark.xfail(raises=cp.SolverError, reason=TINY_CLEARANCE, strict=True),
        ),
    ],
)
def test_nearly_ideal_joint_tends_to_the_ideal_one(diametral, extremes_warn):
    """6.2.2 with J2 -> 0: the equilibrium tends to that of the ideal ball, continuously:
    |T1(J2) - T1(0)| <= J2 (the pivot moves by at most c2 = J2/2, lever ratio <= 2)."""
    ideal = ideal_second_joint("6.2.2", 0.0).solve()
    near = ideal_second_joint("6.2.2", diametral).solve()
    assert near.ok
    assert np.linalg.norm(near.torsor("I1")[:3] - ideal.torsor("I1")[:3]) <= diametral


def test_a_neglected_load_share_along_a_free_motion_is_reported():
    """A load component along a motion nothing blocks that is below 1e-9 of the load (here 3e-10,
    the spec of random mechanism 1601 reduced to a shaft whose spin is free) is neglected by the
    documented rule, and the answer says how much it neglected (it was silent)."""
    mechanism = cp.load(MODELS / "younes_sphere_cylinder.urdf")
    base = mechanism.solve()
    assert base.residuals["unblocked_load"] <= 1e-15  # the file's load passes through the axis
    shares = []
    for torque in (1e-9, 2e-9):  # [N m] about the free spin axis x; the load is 1.7 N at 0.3 m
        answer = mechanism.solve(loads=[*mechanism.loads, cp.Torque("shaft", [torque, 0.0, 0.0])])
        assert answer.ok
        shares.append(answer.residuals["unblocked_load"])
    assert 1e-12 < shares[0] <= 1e-9
    assert shares[1] == pytest.approx(2.0 * shares[0], rel=1e-3)  # the share is the load's
    with pytest.raises(cp.UnboundedLoadError):
        mechanism.solve(loads=[*mechanism.loads, cp.Torque("shaft", [1e-6, 0.0, 0.0])])
