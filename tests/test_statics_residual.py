"""The statics residual sees every joint; a play too small to resolve is a rigid joint; only wrong
answers are refused (issue 21, items 3 and 8).

The statics residual weighs what each joint direction leaves unbalanced in N (forces) and N m / L
(moments), not by the joint's play: a joint of tiny play cannot hide an unbalanced load.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from mechanism_strategies import four_bar_text
from oracle import Oracle, compare

import clearance_pin
from clearance_pin import SingularPositionError, SuspectValueWarning, UnboundedLoadError
from clearance_pin.equilibrium.prepared import prepared_geometry
from clearance_pin.equilibrium.residuals import STATICS_TOLERANCE

TWO_SPHERES = Path(__file__).resolve().parent.parent / "models" / "younes_two_spheres.urdf"
I1 = '<joint name="I1" type="spherical" diametral_clearance="0.0003"'
FORCE = np.array([1.0, 1.0, 1.0])  # [N] on the shaft at POINT (the model file's load)
POINT = np.array([0.1, 0.2, 0.3])  # [m], world (the shaft's frame is the world's at nominal)
CENTRE_I2 = np.array([0.2, 0.4, 0.6])  # [m], ball I2's centre; I1's is the origin


def two_spheres(i1_diametral: str) -> str:
    """The two-spheres case of [Y] 6.2.2 with ball I1's diametral clearance replaced."""
    text = TWO_SPHERES.read_text()
    assert I1 in text
    return text.replace(
        I1, f'<joint name="I1" type="spherical" diametral_clearance="{i1_diametral}"'
    )


def ball_reactions_rigid_i1() -> tuple[np.ndarray, np.ndarray]:
    r"""Independent statics of the shaft on ball I1 without play (at the origin) and ball I2 with
    play (at r): the shaft can only turn about I1, so I2's centre moves by
    :math:`\omega \times r`, perpendicular to r, and I2's contact force (along its normal, that
    motion) is perpendicular to r. Moments about I1: :math:`r \times F_2 + p \times F = 0`, so
    :math:`F_2 = r \times (p \times F) / |r|^2` (the force perpendicular to r with that moment);
    forces: :math:`F_1 = -F - F_2` [N], the housing's force on the shaft through each ball."""
    r = CENTRE_I2
    f2 = np.cross(r, np.cross(POINT, FORCE)) / (r @ r)
    f1 = -FORCE - f2
    # the shaft balances (a check of the derivation itself, not of the library)
    assert np.allclose(f1 + f2 + FORCE, 0.0, atol=1e-15)
    assert np.allclose(np.cross(r, f2) + np.cross(POINT, FORCE), 0.0, atol=1e-15)
    return f1, f2


@pytest.mark.parametrize("backend", ["auto", "ipopt"])
def test_ball_of_negligible_play_carries_its_load(backend):
    """Ball I1 with a 1e-14 m diametral clearance beside I2's 3e-4 m: the answer balances the
    shaft, I1 carrying F1 = (-0.714, -0.929, -1.143) N (the per-body statics above), not 0 N with
    94 % of the load unbalanced; the play is treated as none, with a warning naming the joint."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        mechanism = clearance_pin.loads(two_spheres("1e-14"))
    f1, f2 = ball_reactions_rigid_i1()
    np.testing.assert_allclose(f1, [-5 / 7, -13 / 14, -8 / 7], rtol=1e-12)  # the figures
    eq = mechanism.solve(warm_start=False, backend=backend)
    assert eq.ok and eq.residuals["statics"] <= STATICS_TOLERANCE
    np.testing.assert_allclose(eq.reaction("I1", frame="world").force, f1, atol=1e-9)
    np.testing.assert_allclose(eq.reaction("I2", frame="world").force, f2, atol=1e-9)
    again = mechanism.solve()  # a re-solve (compiled when the kernel is loaded)
    np.testing.assert_allclose(again.reaction("I1", frame="world").force, f1, atol=1e-9)
    warned = [str(w.message) for w in caught if issubclass(w.category, SuspectValueWarning)]
    assert any("'I1'" in text and "rigid" in text for text in warned), warned


def test_exact_model_balances_the_ball_of_negligible_play():
    """The exact model of the same case balances the shaft too: I1's reaction within 1e-3 of the
    linear statics (the finite rotation, 2e-4 rad, changes the lever arms at that order)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SuspectValueWarning)
        mechanism = clearance_pin.loads(two_spheres("1e-14"))
    eq = mechanism.solve(exact=True)
    assert eq.ok and eq.residuals["statics"] <= STATICS_TOLERANCE
    f1, _ = ball_reactions_rigid_i1()
    np.testing.assert_allclose(eq.reaction("I1", frame="world").force, f1, atol=1e-3)
    assert eq.reaction("I1").residual <= 1e-9


def test_statics_residual_sees_a_joint_of_small_play():
    """A deliberately unbalanced answer: the verified answer of I1 at 3e-12 m diametral
    clearance (5e-9 of I2's, resolved, not made rigid) with I1's contact force removed leaves
    I1's share of the load, |F1| = 1.6 N of the 1.7 N load, unbalanced: the statics residual
    reads it (above 0.5), where a residual on clearance-scaled unknowns read 5e-9."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", SuspectValueWarning)  # not made rigid
        mechanism = clearance_pin.loads(two_spheres("3e-12"))
    eq = mechanism.solve(warm_start=False)
    assert eq.ok
    prepared = prepared_geometry(mechanism)
    problem = prepared.problem(mechanism.resolve_loads(None, None))
    terms = prepared.terms
    forces = np.array([c.force for c in eq.contacts])  # (contacts, 3), clearance frames

    def residual(contact_forces: np.ndarray) -> float:
        rows = contact_forces.ravel()[terms.scatter]
        return prepared.statics_residual(problem.gradient, rows, problem.load_size)

    assert residual(forces) <= STATICS_TOLERANCE
    unbalanced = forces.copy()
    unbalanced[[c.joint == "I1" for c in eq.contacts]] = 0.0
    assert residual(unbalanced) > 0.5


def test_toggle_position_is_named_a_singular_position():
    """The four-bar at its toggle (coupler and rocker in line): a singular position of the loop
    closure (still an UnboundedLoadError for callers that catch that), with the way out named,
    not 'no equilibrium ... lock that joint'."""
    mechanism = clearance_pin.loads(four_bar_text(0.0))
    with pytest.raises(SingularPositionError, match="singular position") as caught:
        mechanism.solve()
    assert isinstance(caught.value, UnboundedLoadError)
    assert "exact=True" in str(caught.value) and "Lock" not in str(caught.value)


def test_a_free_motion_away_from_a_toggle_stays_unbounded():
    """A load along a motion nothing blocks at any configuration (a torque about the axis of a
    shaft on two balls) is no singular position: the plain UnboundedLoadError."""
    mechanism = clearance_pin.loads(two_spheres("0.0003"))
    axis = CENTRE_I2 / np.linalg.norm(CENTRE_I2)
    with pytest.raises(UnboundedLoadError) as caught:
        mechanism.solve(loads=[clearance_pin.Torque("shaft", axis)])
    assert not isinstance(caught.value, SingularPositionError)


def test_verified_answer_without_polish_is_returned():
    """The four-bar 1e-3 rad before its toggle: the Newton polish does not converge, but the
    cone solver's answer verifies (statics, penetration, KKT to 1e-9); it is returned (not a
    SolverError), marked unpolished with the engine named, and agrees with the independent
    oracle's energy to 1e-7."""
    mechanism = clearance_pin.loads(four_bar_text(1e-3))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", clearance_pin.ConditioningWarning)
        eq = mechanism.solve(warm_start=False)
    assert eq.ok and not eq.polished
    assert "without the Newton polish" in eq.solver_status
    loads = mechanism.resolve_loads(None, None)
    oracle = Oracle(mechanism)
    assert compare(eq, oracle, oracle.solve(loads), loads)["energy"] <= 1e-7


def test_compiled_kernel_measures_the_same_statics():
    """The compiled kernel's statics residual is the NumPy one
    (:meth:`PreparedGeometry.statics_residual`) on the same answer arrays, balanced or not: I1
    at 3e-12 m diametral clearance, its contact's multiplier zeroed reads above 0.5 in both,
    and both agree to 1e-12."""
    from clearance_pin.equilibrium.fast_path import FastTerms, load_kernel

    load_kernel()
    with warnings.catch_warnings():
        warnings.simplefilter("error", SuspectValueWarning)
        mechanism = clearance_pin.loads(two_spheres("3e-12"))
    mechanism.solve(warm_start=False)
    prepared = prepared_geometry(mechanism)
    problem = prepared.problem(mechanism.resolve_loads(None, None))
    solution = mechanism.cache.warm[prepared.signature]
    fast = FastTerms(prepared)
    i1 = [c.joint == "I1" for c in prepared.geometry.contacts]
    for multipliers in (solution.multipliers, np.where(i1, 0.0, solution.multipliers)):
        *_, forces, measured = fast.kernel.answer_arrays(
            solution.y,
            multipliers,
            solution.signs,
            problem.objective_scale,
            problem.gradient * prepared.geometry.scale,
            problem.load_size,
            *fast.answer[:5],
            fast.cone[2],
            *fast.answer[5:],
        )
        expected = prepared.statics_residual(problem.gradient, forces, problem.load_size)
        assert measured[0] == pytest.approx(expected, rel=1e-12, abs=1e-15)
    assert measured[0] > 0.5


def _displaced(eq, mechanism, frame: str) -> pin.SE3:
    """World placement of ``frame`` in the answer: the nominal placement from a plain Pinocchio
    forward kinematics, moved by the answer's reported finite displacement."""
    model = mechanism.model
    data = model.createData()
    pin.framesForwardKinematics(model, data, mechanism.q_nominal)
    nominal = data.oMf[model.getFrameId(frame)]
    translation, rotation = eq.frame_displacement(frame)
    return pin.SE3(pin.exp3(rotation) @ nominal.rotation, nominal.translation + translation)


@pytest.mark.parametrize("delta", [1e-4, 1e-6])
def test_near_a_toggle_the_exact_model_answers(delta):
    """The four-bar 1e-4 and 1e-6 rad before its toggle: the small-displacement model has no
    verified answer there (a SolverError before; its optimum turns joints by tens of radians),
    now a NearSingularError saying exact=True; exact=True answers (a SolverError too before: it
    started from that answer), from the nominal position.

    Independent check, sharing no code with the solver: the in-plane statics of the coupler and
    the rocker at the displaced pose (Pinocchio's own nominal kinematics moved by the reported
    displacements), with the pin forces read as forces only. A round pin in its hole pushes along
    the line of centres, so its moment is taken about the pin's centre on either part. The loaded
    pin B sits on its play (5e-5 m radial)."""
    mechanism = clearance_pin.loads(four_bar_text(delta))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", clearance_pin.ConditioningWarning)
        with pytest.raises(clearance_pin.NearSingularError, match="exact=True"):
            mechanism.solve()
        eq = mechanism.solve(exact=True)
    assert eq.ok and "nominal position" in eq.note
    crank_on_coupler = eq.reaction("pin_A", frame="world").force
    rocker_on_coupler = eq.reaction("pin_B", frame="world").force  # frame_a: the rocker's
    ground_on_rocker = eq.reaction("rocker_pivot", frame="world").force
    coupler = _displaced(eq, mechanism, "coupler")
    at_b = _displaced(eq, mechanism, "coupler_B").translation
    load_point = coupler.act(np.array([0.075, 0.0, 0.0]))  # b / 2 on the coupler
    # the exact model's torque is the couple of dead loads (docs/method.md, exact model: work
    # sin(theta) n . C): on the rocker, turned by theta about z, its moment is C cos(theta)
    theta = eq.frame_displacement("rocker")[1][2]
    load, torque = np.array([3.0, -40.0, 0.0]), np.array([0.0, 0.0, -2.0 * np.cos(theta)])
    coupler_force = crank_on_coupler + rocker_on_coupler + load
    coupler_moment = np.cross(at_b - coupler.translation, rocker_on_coupler) + np.cross(
        load_point - coupler.translation, load
    )
    rocker = _displaced(eq, mechanism, "rocker")
    rocker_b = _displaced(eq, mechanism, "rocker_B").translation
    rocker_force = ground_on_rocker - rocker_on_coupler
    rocker_moment = np.cross(rocker_b - rocker.translation, -rocker_on_coupler) + torque
    size = np.linalg.norm(load)
    np.testing.assert_allclose(coupler_force[:2], 0.0, atol=1e-9 * size)
    np.testing.assert_allclose(rocker_force[:2], 0.0, atol=1e-9 * size)
    np.testing.assert_allclose(coupler_moment[2], 0.0, atol=1e-9 * size * 0.15)
    np.testing.assert_allclose(rocker_moment[2], 0.0, atol=1e-9 * size * 0.15)
    # bounded forces (the rigid statics at this pose grows as 1 / delta: 2e4 N at 1e-4)
    assert np.linalg.norm(rocker_on_coupler) < 100.0
    assert np.linalg.norm(at_b - rocker_b) == pytest.approx(5e-5, rel=1e-6)
