"""Closed forms of a tree's independent joints (clearance_pin/equilibrium/blocks.py) and the batched
paths built on them (block_batch.py: load cases at one configuration, trajectories at once).

Three references: a hand computation of one journal, one ball and one planar pin from docs/method.md
2.2 (the formulas are written out here, not taken from the library); the general path (Clarabel or
IPOPT, then the Newton polish, ``backend=`` given explicitly), on the bundled trees and on random
trees; Pinocchio for the vectorised forward kinematics, and the prepared geometry for the
vectorised loads and gradients. Answers are compared where the play bounds them: every contact
point's bounded displacement over its clearance, and the translations over the joint's play.
"""

from __future__ import annotations

import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from mechanism_strategies import (
    BodySpec,
    LoadSpec,
    MechanismSpec,
    ball_text,
    joints,
    log_uniform,
    mechanisms,
)
from oracle import Oracle, bounded_loads

import clearance_pin as cp
from clearance_pin import Gravity, Method, PointForce, Torque
from clearance_pin.equilibrium.batch_kinematics import _pinocchio_placements, body_placements
from clearance_pin.equilibrium.block_verify import centred_problem, verify
from clearance_pin.equilibrium.blocks import block_structure, closed_forms, reduced_unknowns
from clearance_pin.equilibrium.load_table import body_wrenches, load_table
from clearance_pin.equilibrium.prepared import prepared_geometry
from clearance_pin.equilibrium.tree_trajectory import tree_gradients, tree_maps

MODELS = Path(__file__).resolve().parent.parent / "models"
PLAY = 1e-12  # of the play: closed forms and the general path agree to round-off
GENERAL = ("clarabel", "ipopt")


def journal_text(
    radial: float = 1e-5, length: float = 0.04, axial: float = 5e-6, axis: str = "1 0 0"
) -> str:
    """A shaft on one driven revolute joint (a journal with axial play) at the world origin."""
    return f"""<?xml version="1.0"?>
<robot name="journal">
  <link name="ground"/><link name="shaft"/>
  <joint name="bore" type="revolute"><parent link="ground"/><child link="shaft"/>
    <axis xyz="{axis}"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <clearance_pin>
    <joint name="bore" type="revolute" radial_clearance="{radial!r}" length="{length!r}"
           axial_clearance="{axial!r}" driven="true"/>
  </clearance_pin>
</robot>
"""


def play_difference(mechanism, a, b) -> float:
    """Largest difference of two answers where the play bounds them, over the mechanism's largest
    play: each translation, and each contact point's bounded displacement S_j (T_a - T_b) (a
    rotation times the distance of a journal's end, for example)."""
    play = max(joint.clearance.max_play for joint in mechanism.joints.values())
    worst = 0.0
    for name, joint in mechanism.joints.items():
        difference = a.torsor(name) - b.torsor(name)
        worst = max(worst, float(np.abs(difference[:3]).max()))
        for contact in joint.clearance.contacts:
            worst = max(worst, float(np.linalg.norm(contact.linear_rows() @ difference)))
    return worst / play


def unknowns_size(mechanism, answer) -> float:
    """The size of an answer's scaled unknowns (docs/method.md 3.1: translations over the play,
    rotations over play / L_ref), at least 1: the general path's round-off is eps times it (a
    5 mm journal on a 0.5 m tree tilts by 2 c / L, a hundred times c / L_ref)."""
    play = max(joint.clearance.max_play for joint in mechanism.joints.values())
    length = mechanism.length_scale()
    size = max(
        max(np.abs(t[:3]).max() / play, np.abs(t[3:]).max() * length / play)
        for t in answer.torsors.values()
    )
    return max(1.0, float(size))


def assert_same_answer(mechanism, closed, general, play: float = PLAY) -> None:
    """The closed form's answer is the general path's: torsors to ``play``, forces to 1e-9 of
    the largest, the same contacts in touch, energy, and as many free (flat) motions."""
    assert closed.method is Method.CLOSED_FORM and general.method is not Method.CLOSED_FORM
    assert closed.ok and general.ok
    assert play_difference(mechanism, closed, general) <= play
    largest = max((c.force_magnitude for c in general.contacts), default=0.0)
    for mine, theirs in zip(closed.contacts, general.contacts, strict=True):
        assert mine.label == theirs.label
        assert np.abs(mine.force - theirs.force).max() <= 1e-9 * largest, mine.label
        if max(mine.force_magnitude, theirs.force_magnitude) > 1e-6 * largest:
            assert mine.active == theirs.active, mine.label
    assert closed.energy == pytest.approx(general.energy, rel=1e-10, abs=1e-300)
    assert len(closed.free_motions) == len(general.free_motions)


def general_solve(text: str, **options):
    """The general path on a fresh mechanism (no warm start, no closed form)."""
    return cp.loads(text).solve(warm_start=False, **options)


# -- hand computations ----------------------------------------------------------------------------
def test_one_journal_matches_the_hand_computation():
    """A driven revolute journal (axis x, length L, radial play c, axial play c_a) under a force
    F at (d, 0, 0) and a torque C: minus the wrench at the centre, g = -(F, r x F + C), gives
    a+- = (g_v/2 +- g_gamma/L, g_w/2 -+ g_beta/L), each end at -c a/|a|, the axial play at
    -c_a sign(g_u), contact forces a+- and g_u (docs/method.md 2.2: e-+ = (v -+ gamma L/2,
    w +- beta L/2))."""
    c, length, axial = 1e-5, 0.04, 5e-6
    text = journal_text(c, length, axial)
    force, d, torque = np.array([3.0, -40.0, 25.0]), 0.07, np.array([0.0, 1.5, -0.8])
    loads = [PointForce("shaft", force, [d, 0.0, 0.0]), Torque("shaft", torque)]
    moment = np.cross([d, 0.0, 0.0], force) + torque
    g_u, g_v, g_w = -force
    g_beta, g_gamma = -moment[1], -moment[2]
    a_plus = np.array([g_v / 2 + g_gamma / length, g_w / 2 - g_beta / length])
    a_minus = np.array([g_v / 2 - g_gamma / length, g_w / 2 + g_beta / length])
    e_plus = -c * a_plus / np.linalg.norm(a_plus)
    e_minus = -c * a_minus / np.linalg.norm(a_minus)
    u = -axial * np.sign(g_u)
    v, w = (e_plus[0] + e_minus[0]) / 2, (e_plus[1] + e_minus[1]) / 2
    gamma, beta = (e_plus[0] - e_minus[0]) / length, (e_minus[1] - e_plus[1]) / length
    answer = cp.loads(text).solve(loads=loads)
    assert answer.method is Method.CLOSED_FORM and answer.ok
    expected = np.array([u, v, w, 0.0, beta, gamma])
    np.testing.assert_allclose(answer.torsor("bore"), expected, rtol=0, atol=1e-15 * c / length)
    forces = {contact.point: contact.force for contact in answer.contacts}
    np.testing.assert_allclose(forces["end+"], [0.0, *a_plus], rtol=1e-13, atol=1e-12)
    np.testing.assert_allclose(forces["end-"], [0.0, *a_minus], rtol=1e-13, atol=1e-12)
    np.testing.assert_allclose(forces["axial"], [g_u, 0.0, 0.0], rtol=1e-13)
    assert [x.point for x in answer.active_contacts] == ["end-", "end+", "axial"]
    for backend in GENERAL:
        assert_same_answer(
            answer.mechanism, answer, general_solve(text, loads=loads, backend=backend)
        )


def test_one_ball_and_one_pin_match_the_hand_computation():
    """A ball pushed through its centre moves by c F/|F| (rotations free and unloaded: zero, and
    reported among the free motions); a planar pin of the double pendulum by c F_vw/|F_vw| of the
    force it carries in its plane (the tip's force for the elbow)."""
    c = 2e-4
    text = ball_text(c, centre=(0.3, 0.1, 0.2))
    force = np.array([1.0, -2.0, 5.0])
    loads = [PointForce("part", force, [0.0, 0.0, 0.0])]
    ball = cp.loads(text).solve(loads=loads)
    assert ball.method is Method.CLOSED_FORM
    np.testing.assert_allclose(
        ball.torsor("ball"), [*(c * force / np.linalg.norm(force)), 0, 0, 0], atol=1e-15 * c
    )
    assert len(ball.free_motions) == 3  # the three rotations nothing sees
    for backend in GENERAL:
        assert_same_answer(ball.mechanism, ball, general_solve(text, loads=loads, backend=backend))
    pendulum = cp.load(MODELS / "double_pendulum.urdf")
    answer = pendulum.solve()
    assert answer.method is Method.CLOSED_FORM
    elbow = pendulum.joint("elbow")
    frame = answer.configuration.oMi[elbow.joint_id].rotation @ elbow.rotation
    carried = frame.T @ np.array([0.0, -10.0, 0.0])  # the tip force, in the elbow's frame
    expected = 2e-5 * carried[1:] / np.linalg.norm(carried[1:])
    np.testing.assert_allclose(answer.torsor("elbow")[1:3], expected, atol=1e-15 * 2e-5)


# -- the bundled trees ----------------------------------------------------------------------------
def random_tool_loads(rng, count: int) -> list:
    """Forces and torques on the 6R arm's tool (gravity stays on, the model's)."""
    return [
        [
            PointForce("tool", 40.0 * rng.standard_normal(3), 0.05 * rng.standard_normal(3)),
            Torque("tool", 2.0 * rng.standard_normal(3)),
        ]
        for _ in range(count)
    ]


@pytest.mark.parametrize("backend", GENERAL)
def test_bundled_trees_equal_the_general_path(backend):
    """models/arm_6r.urdf and models/double_pendulum.urdf, their own loads and random ones, at
    their nominal and at random configurations: the closed form is the general path's answer."""
    rng = np.random.default_rng(5)
    for name, link in (("arm_6r", "tool"), ("double_pendulum", "tip")):
        text = (MODELS / f"{name}.urdf").read_text()
        mechanism = cp.loads(text)
        cases = [None] + [
            [PointForce(link, 20.0 * rng.standard_normal(3), 0.05 * rng.standard_normal(3))]
            for _ in range(6)
        ]
        for k, loads in enumerate(cases):
            q = mechanism.q_nominal + (
                0.0 if k < 2 else 0.7 * rng.standard_normal(mechanism.model.nq)
            )
            closed = mechanism.solve(loads=loads, q=q)
            general = general_solve(text, loads=loads, q=q, backend=backend)
            assert_same_answer(mechanism, closed, general)


def test_the_arm_nominal_answer_leaves_unloaded_axial_plays_at_zero():
    """The 6R arm's own load is vertical: the axial plays of the horizontal joints carry nothing
    (or round-off), and the closed form puts them at the minimum-norm point, zero, listed among
    the free motions, as the general path does."""
    arm = cp.load(MODELS / "arm_6r.urdf")
    answer = arm.solve()
    assert answer.method is Method.CLOSED_FORM
    for joint in ("shoulder_lift", "elbow", "wrist_1", "wrist_3"):
        assert answer.torsor(joint)[0] == 0.0
    assert len(answer.free_motions) == 4


# -- random trees ---------------------------------------------------------------------------------
def driven_bodies(draw, count: int) -> tuple:
    """Bodies on the kinds the closed forms solve, with play: driven journals (with or without
    axial play) and pins, balls and cylindrical joints (their free motions unloaded by
    bounded_loads), now and then a weld."""
    kinds = ("revolute", "revolute", "planar_revolute", "spherical", "cylindrical", "rigid")
    bodies = []
    for index in range(1, count + 1):
        joint = draw(joints(kinds))
        joint = replace(joint, radial=draw(log_uniform(1e-6, 1e-3)), driven=joint.kind != "rigid")
        position = draw(st.tuples(*[st.floats(-0.5, 0.5)] * 3))
        rpy = draw(st.tuples(*[st.floats(-np.pi, np.pi)] * 3))
        bodies.append(BodySpec(draw(st.integers(0, index - 1)), position, rpy, joint))
    return tuple(bodies)


@st.composite
def block_trees(draw):
    """A random tree on the kinds of :func:`driven_bodies`, with one to three random loads."""
    count = draw(st.integers(1, 6))
    bodies = driven_bodies(draw, count)
    force = st.floats(-100.0, 100.0)
    loads = tuple(
        LoadSpec(
            draw(st.integers(1, count)),
            draw(st.tuples(force, force, force)),
            draw(st.one_of(st.none(), st.tuples(*[st.floats(-0.3, 0.3)] * 3))),
        )
        for _ in range(draw(st.integers(1, 3)))
    )
    return MechanismSpec(bodies, (), loads)


def compare_random(spec: MechanismSpec, accepted: list) -> None:
    """One random tree, its load projected off the motions nothing blocks: when the closed form
    answers, it is the general path's answer (both backends) to 1e-12 of the play times the size
    of the scaled unknowns (:func:`unknowns_size`: the general path's round-off; the bundled
    trees are held to 1e-12 of the play). Where the general path cannot verify its own answer
    (SolverError, ill-scaled trees), its unverified answer is still the closed form's to 1e-9 of
    the play."""
    text = spec.urdf()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # suspect values of random models
        mechanism = cp.loads(text)
        loads = bounded_loads(Oracle(mechanism), mechanism.resolve_loads(None, None))
        try:
            closed = mechanism.solve(loads=loads)
        except cp.ClearancePinError:
            return
        if closed.method is not Method.CLOSED_FORM:
            return
        accepted.append(spec)
        for backend in GENERAL:
            try:
                general = general_solve(text, loads=loads, backend=backend)
            except cp.SolverError as error:
                assert error.answer is not None
                assert play_difference(mechanism, closed, error.answer) <= 1e-9
                continue
            assert_same_answer(mechanism, closed, general, PLAY * unknowns_size(mechanism, closed))


def test_random_trees_equal_the_general_path():
    """Random trees of the library's strategy (tests/mechanism_strategies.py, without loops) and
    trees on the closed forms' kinds: every one the closed forms answer is the general path's
    answer, and they answer a fair share of them (the test cannot pass vacuously)."""
    accepted: list = []
    options = settings(
        max_examples=40,
        deadline=None,
        derandomize=True,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
    )
    options(given(mechanisms(max_loops=0))(lambda spec: compare_random(spec, accepted)))()
    from_library = len(accepted)
    options(given(block_trees())(lambda spec: compare_random(spec, accepted)))()
    assert from_library >= 2 and len(accepted) - from_library >= 20, (from_library, len(accepted))


# -- what the closed forms leave to the general path ---------------------------------------------
def test_an_unloaded_end_of_a_loaded_journal_goes_to_the_general_path():
    """A force at the end+ of the journal (d = L/2) leaves end- without load: its minimum-norm
    point depends on the scaling, so the closed form declines the case; the single solve and a
    batch containing it return the general path's answer there."""
    text = journal_text(1e-5, 0.04, 5e-6)
    at_end = [PointForce("shaft", [0.0, 8.0, -4.0], [0.02, 0.0, 0.0])]
    mechanism = cp.loads(text)
    prepared = prepared_geometry(mechanism)
    problem = prepared.problem(tuple(at_end))
    structure = block_structure(prepared.geometry, False)
    cases = closed_forms(structure, problem.gradient[None], np.array([problem.objective_scale]))
    assert not cases.decided[0]
    single = mechanism.solve(loads=at_end)
    assert single.method is not Method.CLOSED_FORM and single.ok
    assert play_difference(mechanism, single, general_solve(text, loads=at_end)) <= PLAY
    off_end = [PointForce("shaft", [0.0, 8.0, -4.0], [0.05, 0.0, 0.0])]
    batch = mechanism.solve_many([off_end, at_end, off_end])
    assert batch.methods[0] == batch.methods[2] == Method.CLOSED_FORM
    assert batch.methods[1] != Method.CLOSED_FORM and batch.ok.all()
    assert play_difference(mechanism, batch[1], single) <= PLAY


def test_a_prismatic_block_keeps_the_general_path():
    """A prismatic joint with a block (width and height: 16 corner slabs on 4 unknowns) is not
    separable: no block structure, the general path solves it."""
    text = """<?xml version="1.0"?>
<robot name="slide">
  <link name="ground"/><link name="carriage"/>
  <joint name="guide" type="prismatic"><parent link="ground"/><child link="carriage"/>
    <axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <clearance_pin>
    <joint name="guide" type="prismatic" radial_clearance="1e-5" length="0.1" width="0.05"
           height="0.03" driven="true"/>
    <force link="carriage" point="0.02 0.01 0" value="0 -30 12"/>
  </clearance_pin>
</robot>
"""
    mechanism = cp.loads(text)
    assert block_structure(prepared_geometry(mechanism).geometry, False) is None
    assert mechanism.solve().method is not Method.CLOSED_FORM


def test_verification_rejects_answers_that_are_not_optimal():
    """The vectorised verification is a real test: the closed forms pass it, the same answers
    moved off the boundary, pushed through it, or with a multiplier changed do not."""
    arm = cp.load(MODELS / "arm_6r.urdf")
    prepared = prepared_geometry(arm)
    structure = block_structure(prepared.geometry, False)
    rng = np.random.default_rng(8)
    problems = [prepared.problem(tuple(arm.resolve_loads(c))) for c in random_tool_loads(rng, 8)]
    gradients = np.array([p.gradient for p in problems])
    sigmas = np.array([p.objective_scale for p in problems])
    objectives = np.array([p.objective for p in problems])
    sizes = np.array([p.load_size for p in problems])
    closed = closed_forms(structure, gradients, sigmas)

    def passes(x, multipliers):
        y = reduced_unknowns(structure, x)
        check = verify(
            prepared,
            structure,
            objectives,
            y,
            x,
            multipliers,
            closed.signs,
            sigmas,
            gradients,
            sizes,
        )
        return check.verified

    assert closed.decided.all() and passes(closed.x, closed.multipliers).all()
    assert not passes(0.999 * closed.x, closed.multipliers).any()
    assert not passes(1.001 * closed.x, closed.multipliers).any()
    changed = closed.multipliers.copy()
    changed[:, 0] *= 1.01
    assert not passes(closed.x, changed).any()


# -- trajectories and load cases at once ----------------------------------------------------------
def test_a_trajectory_equals_single_solves_at_every_point():
    """A trajectory of the 6R arm (every joint moving): every point of solve_many equals a
    general-path single solve there; the items are assembled only when read and equal the arrays
    ``torsors(joint)`` reads."""
    arm = cp.load(MODELS / "arm_6r.urdf")
    phases = np.linspace(0.0, 2.0 * np.pi, 120)
    trajectory = [arm.q_nominal + 0.8 * np.sin(p + np.arange(arm.model.nq)) for p in phases]
    batch = arm.solve_many(configurations=trajectory)
    assert batch.ok.all() and set(batch.methods) == {Method.CLOSED_FORM}
    assert all(item is None for item in batch._items)  # nothing assembled yet
    torsors = {joint: batch.torsors(joint) for joint in arm.joints}
    energies = batch.energy
    assert all(item is None for item in batch._items)
    general = cp.load(MODELS / "arm_6r.urdf")
    for k, q in enumerate(trajectory):
        reference = general.solve(q=q, backend="clarabel")
        item = batch[k]
        assert_same_answer(arm, item, reference)
        for joint in arm.joints:  # the arrays, and the item rebuilt from its reduced unknowns
            np.testing.assert_allclose(
                torsors[joint][k], item.torsor(joint), rtol=1e-14, atol=1e-20
            )
        assert energies[k] == pytest.approx(item.energy, rel=1e-14)
        np.testing.assert_allclose(item.configuration.q, q, rtol=0, atol=0)


def test_a_trajectory_with_a_load_per_point_and_gravity_switched():
    """Configurations paired with load cases, gravity switched off and on: each point is the
    single solve of its own load and configuration."""
    arm = cp.load(MODELS / "arm_6r.urdf")
    rng = np.random.default_rng(21)
    trajectory = [arm.q_nominal + 0.5 * rng.standard_normal(arm.model.nq) for _ in range(12)]
    cases = random_tool_loads(rng, 12)
    for gravity in (False, Gravity([0.0, 0.0, -9.81]), None):
        batch = arm.solve_many(cases, configurations=trajectory, gravity=gravity)
        for k in range(12):
            reference = arm.solve(loads=cases[k], q=trajectory[k], gravity=gravity, backend="ipopt")
            assert_same_answer(arm, batch[k], reference)


def test_load_cases_at_one_configuration_equal_single_solves():
    """300 load cases of the 6R arm at its nominal configuration, one of them on a link that does
    not exist: the closed-form cases equal single general-path solves, the bad case holds its
    LoadError in place (errors="return") or raises it."""
    arm = cp.load(MODELS / "arm_6r.urdf")
    rng = np.random.default_rng(4)
    cases = random_tool_loads(rng, 300)
    cases[17] = [PointForce("nowhere", [1.0, 0.0, 0.0])]
    batch = arm.solve_many(cases, errors="return")
    assert isinstance(batch[17], cp.LoadError)
    with pytest.raises(cp.LoadError):
        arm.solve_many(cases)
    ok = batch.ok
    assert not ok[17] and ok.sum() == 299
    assert batch.methods.count(Method.CLOSED_FORM) == 299
    general = cp.load(MODELS / "arm_6r.urdf")
    for k in range(0, 300, 13):
        if k == 17:
            continue
        assert_same_answer(arm, batch[k], general.solve(loads=cases[k], backend="clarabel"))
    reactions = batch[3].reaction("elbow")
    assert np.isfinite(reactions.force).all()


def test_load_cases_across_chunks_equal_single_solves():
    """2100 load cases of the 6R arm, more than two of block_batch's chunks of CHUNK cases
    (the load terms are sorted by case and cut per chunk), of mixed kinds (a force; a force and a
    torque; a torque and an explicit Gravity; a torque on another link and a force): cases on
    either side of each chunk boundary equal single general-path solves."""
    from clearance_pin.equilibrium.block_batch import CHUNK

    arm = cp.load(MODELS / "arm_6r.urdf")
    rng = np.random.default_rng(8)
    count = 2 * CHUNK + 52
    mixed = []
    for k, (force, torque) in enumerate(random_tool_loads(rng, count)):
        kind = k % 4
        mixed.append(
            [force]
            if kind == 0
            else [force, torque]
            if kind == 1
            else [torque, Gravity([0.0, 0.0, -9.81])]
            if kind == 2
            else [Torque("upper_arm", torque.torque), force]
        )
    batch = arm.solve_many(mixed)
    assert batch.methods.count(Method.CLOSED_FORM) == count
    general = cp.load(MODELS / "arm_6r.urdf")
    for k in (0, 1, 2, 3, CHUNK - 1, CHUNK, CHUNK + 1, 2 * CHUNK - 1, 2 * CHUNK, count - 1):
        assert_same_answer(arm, batch[k], general.solve(loads=mixed[k], backend="clarabel"))
        for joint in arm.joints:  # the whole-batch arrays too
            assert np.allclose(batch.torsors(joint)[k], batch[k].torsor(joint), rtol=0, atol=1e-16)


def test_vectorised_kinematics_loads_and_gradients_equal_the_prepared_geometry():
    """The pieces of the trajectory path against the per-point ones: forward kinematics against
    Pinocchio (revolute, prismatic and free-flyer joints of random trees), body wrenches (about
    the body origins, moved to the world origin: M + t x F) against PreparedGeometry.wrenches,
    gradients (from the wrenches about the joint centres) against the prepared problem's and,
    at one configuration, against the single solve's (block_verify.centred_problem)."""
    rng = np.random.default_rng(9)
    arm = cp.load(MODELS / "arm_6r.urdf")
    trajectory = [arm.q_nominal + rng.standard_normal(arm.model.nq) for _ in range(5)]
    cases = random_tool_loads(rng, 5)
    cases[2] = [*cases[2], Gravity([0.3, 0.0, -9.0])]
    rotations, translations = body_placements(arm, trajectory)
    expected = _pinocchio_placements(arm, trajectory)
    np.testing.assert_allclose(rotations, expected[0], rtol=0, atol=1e-14)
    np.testing.assert_allclose(translations, expected[1], rtol=0, atol=1e-14)
    # the model's gravity (None) shared by the table; False: case 2's own Gravity alone
    for gravity in (None, False):
        table = load_table(arm, cases, gravity)
        # with the model's gravity, case 2's own Gravity stands in for it: its single solve
        assert table.valid.tolist() == [True, True, gravity is False, True, True]
        wrenches, moments = body_wrenches(table, rotations, translations, arm.model.njoints, True)
        moved = wrenches.copy()
        moved[..., 3:] += np.cross(translations, wrenches[..., :3])
        np.testing.assert_allclose(moved[..., 3:], moments, rtol=1e-13, atol=1e-12)
        for k, q in enumerate(trajectory):
            if table.valid[k]:
                loads = arm.resolve_loads(cases[k], gravity)
                np.testing.assert_allclose(
                    moved[k], prepared_geometry(arm, q).wrenches(loads), rtol=1e-13, atol=1e-12
                )
    gradients = tree_gradients(tree_maps(arm), rotations, translations, wrenches)
    for k, q in enumerate(trajectory):
        prepared = prepared_geometry(arm, q)
        loads = arm.resolve_loads(cases[k], False)
        problem = prepared.problem(loads)
        reference = problem.gradient
        np.testing.assert_allclose(
            gradients[k], reference, rtol=0, atol=1e-13 * np.abs(reference).max()
        )
        structure = block_structure(prepared.geometry, False)
        single = centred_problem(prepared, structure, problem, loads)
        np.testing.assert_allclose(
            gradients[k], single.gradient, rtol=0, atol=1e-14 * np.abs(reference).max()
        )

    @settings(max_examples=15, deadline=None, derandomize=True)
    @given(mechanisms(max_loops=0))
    def kinematics(spec):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            mechanism = cp.loads(spec.urdf())
        model = mechanism.model
        configurations = [pin.randomConfiguration(model, -np.ones(model.nq), np.ones(model.nq))]
        configurations.append(mechanism.q_nominal)
        got = body_placements(mechanism, configurations)
        want = _pinocchio_placements(mechanism, configurations)
        np.testing.assert_allclose(got[0], want[0], rtol=0, atol=1e-13)
        np.testing.assert_allclose(got[1], want[1], rtol=0, atol=1e-13)

    kinematics()


def test_gravity_wrenches_gathered_once_per_acceleration():
    """PreparedGeometry.wrenches keeps a gravity's body wrenches per acceleration: solves with
    two gravities in turn, on one mechanism, equal each gravity's solve on a fresh mechanism
    (nothing carried from one acceleration to the other), through the general path too."""
    arm = cp.load(MODELS / "arm_6r.urdf")
    tool = [PointForce("tool", [5.0, -8.0, 3.0], [0.0, 0.0, 0.05])]
    down, sideways = Gravity([0.0, 0.0, -9.81]), Gravity([0.0, -9.81, 2.0])
    for backend in ("auto", "clarabel"):
        for gravity in (down, sideways, down):
            reused = arm.solve(tool, gravity=gravity, backend=backend)
            fresh = cp.load(MODELS / "arm_6r.urdf").solve(tool, gravity=gravity, backend=backend)
            for joint in arm.joints:
                # the same load terms, summed in another order: equal to round-off
                assert np.allclose(
                    reused.torsor(joint), fresh.torsor(joint), rtol=1e-12, atol=1e-20
                )
    assert not np.allclose(
        arm.solve(tool, gravity=down).torsor("shoulder_lift"),
        arm.solve(tool, gravity=sideways).torsor("shoulder_lift"),
    )
