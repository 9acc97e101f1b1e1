"""Positioning discontinuities of a two-loop linkage: the pins of a Watt six-bar flipping across
their play over a crank turn, located by bisection, with the output's jumps.

The mechanism (tests/data/watt_six_bar.urdf) is a Watt II six-bar: the crank-rocker four-bar of
models/four_bar.urdf (ground O2-O4 200 mm, crank 60 mm, coupler A-B 180 mm, rocker O4-B 120 mm)
whose rocker is ternary and drives a second four-bar (pin C 120 mm from O4 at -90 deg from O4-B,
coupler2 C-D 200 mm, output pivot O6 = (530, 50) mm, O6-D 100 mm, tip 160 mm from O6 on the same
line). Every one of the seven pins has 30 um of radial play, the crank is driven, a constant
30 N force (18, -24) N acts at the output tip, gravity off.

The reference is this file's own rigid-linkage statics, written from the design numbers above
with numpy (no clearance_pin or Pinocchio code): the four passive angles close the two loops by
Newton's method, and the free-body equations of the five moving links (15 equations, 14 pin
force components and the crank's drive torque) give the force through each pin. The two couplers
are two-force members. Coupler2's force vanishes where the tip force passes through O6 (the
output link along the force): then the rocker's balance makes the coupler's force vanish too,
and with it the force in every pin but the output pivot's, so six pins flip at once. The
coupler's force also vanishes alone where O4, C and D are collinear (the output dwells: its
angle is stationary in the rocker's), and there only the crank pivot and pins A and B flip.
Those crank angles are found by root finding (``brentq``) on the couplers' axial forces, and
each located change must sit on one of them to within the bisection's half interval.

The jumps: with the crank held, the linkage with rigid pins is a structure, so the settled
positions decouple: each pin's child centre sits c from the parent's, against the force through
it (opposite the parent's force on the child). A pin that flips moves by 2c along the force's
direction just before the flip, and the output moves by the sum over the flipped pins of that
2c carried through the closure's implicit-function sensitivity (the same linear Newton system,
differentiated by hand). At the dwell changes the output's sensitivity to the flipped pins is
zero to first order (they move only the rocker, and the output is stationary in the rocker's
angle there): the tip does not jump, the rocker's pin B does.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from scipy.optimize import brentq

import clearance_pin as cp
from clearance_pin.mode_changes import locate_changes
from clearance_pin.plot.trajectory import contact_modes

MODEL = Path(__file__).parent / "data" / "watt_six_bar.urdf"
STEPS = 72  # a crank turn in 5 deg steps
TOLERANCE = 1e-6  # the bisection's, of the driven range

# the design (m, N), as the model file's comment states it
O2, O4, O6 = np.zeros(2), np.array([0.2, 0.0]), np.array([0.53, 0.05])
CRANK, COUPLER, ROCKER, ROCKER_C, BETA = 0.06, 0.18, 0.12, 0.12, -np.pi / 2
COUPLER2, OUTPUT_D, OUTPUT_TIP = 0.2, 0.1, 0.16
FORCE = np.array([18.0, -24.0])
PLAY = 3e-5  # every pin's radial clearance c [m]
# pin j joins parent and child: the offset d_j is the child's centre minus the parent's
PINS = ("crank_pivot", "pin_A", "pin_B", "rocker_pivot", "pin_C", "pin_D", "output_pivot")
SIX = {"crank_pivot", "pin_A", "pin_B", "rocker_pivot", "pin_C", "pin_D"}
THREE = {"crank_pivot", "pin_A", "pin_B"}


# -- the reference: planar kinematics and statics of the rigid linkage ---------------------------
def _e(angle: float) -> np.ndarray:
    return np.array([np.cos(angle), np.sin(angle)])


def _e_perp(angle: float) -> np.ndarray:
    return np.array([-np.sin(angle), np.cos(angle)])


def _loops(th: np.ndarray, crank: float, d: np.ndarray) -> np.ndarray:
    """Loop-closure residual (4,) of the world angles th = (coupler, rocker, coupler2, output)
    with pin offsets d (7, 2) (child minus parent centre, world axes)."""
    coupler, rocker, coupler2, output = th
    b_coupler = d[0] + CRANK * _e(crank) + d[1] + COUPLER * _e(coupler)
    b_rocker = O4 + d[3] + ROCKER * _e(rocker)
    c_coupler2 = O4 + d[3] + ROCKER_C * _e(rocker + BETA) + d[4]
    d_output = O6 + d[6] + OUTPUT_D * _e(output)
    return np.concatenate(
        [b_coupler - b_rocker - d[2], c_coupler2 + COUPLER2 * _e(coupler2) - d_output - d[5]]
    )


def _loops_by_angles(th: np.ndarray) -> np.ndarray:
    coupler, rocker, coupler2, output = th
    jac = np.zeros((4, 4))
    jac[:2, 0], jac[:2, 1] = COUPLER * _e_perp(coupler), -ROCKER * _e_perp(rocker)
    jac[2:, 1] = ROCKER_C * _e_perp(rocker + BETA)
    jac[2:, 2], jac[2:, 3] = COUPLER2 * _e_perp(coupler2), -OUTPUT_D * _e_perp(output)
    return jac


def _loops_by_offsets() -> np.ndarray:
    """d residual / d (d_0 .. d_6), (4, 14)."""
    one, jac = np.eye(2), np.zeros((4, 14))
    for j, sign in ((0, 1), (1, 1), (2, -1), (3, -1)):
        jac[:2, 2 * j : 2 * j + 2] = sign * one
    for j, sign in ((3, 1), (4, 1), (5, -1), (6, -1)):
        jac[2:, 2 * j : 2 * j + 2] = sign * one
    return jac


def closed(crank: float, guess, d: np.ndarray | None = None) -> np.ndarray:
    """The passive world angles closing both loops (Newton's method from ``guess``)."""
    d = np.zeros((7, 2)) if d is None else d
    th = np.array(guess, dtype=float)
    for _ in range(30):
        step = np.linalg.solve(_loops_by_angles(th), -_loops(th, crank, d))
        th += step
        if np.abs(step).max() < 1e-15:
            break
    assert np.abs(_loops(th, crank, d)).max() < 1e-14
    return th


def pin_forces(crank: float, th: np.ndarray) -> np.ndarray:
    """Force of the parent on the child through each pin (7, 2) [N], world axes, from the
    free-body equations of the five moving links (force and moment about the world origin)."""
    _, rocker, _, output = th
    a, b = CRANK * _e(crank), O4 + ROCKER * _e(rocker)
    c, d = O4 + ROCKER_C * _e(rocker + BETA), O6 + OUTPUT_D * _e(output)
    tip = O6 + OUTPUT_TIP * _e(output)
    rows, rhs = [], []
    # per link: (pin, +1 if the link is the pin's child else -1, the pin's centre)
    links = (
        ([(0, 1, O2), (1, -1, a)], np.zeros(2), 0.0, 1.0),  # crank, its drive torque
        ([(1, 1, a), (2, 1, b)], np.zeros(2), 0.0, 0.0),  # coupler
        ([(2, -1, b), (3, 1, O4), (4, -1, c)], np.zeros(2), 0.0, 0.0),  # rocker
        ([(4, 1, c), (5, 1, d)], np.zeros(2), 0.0, 0.0),  # coupler2
        ([(5, -1, d), (6, 1, O6)], FORCE, tip[0] * FORCE[1] - tip[1] * FORCE[0], 0.0),  # output
    )
    for pins, force, moment, drive in links:
        balance = np.zeros((3, 15))
        for j, sign, point in pins:
            balance[:2, 2 * j : 2 * j + 2] += sign * np.eye(2)
            balance[2, 2 * j : 2 * j + 2] += sign * np.array([-point[1], point[0]])
        balance[2, 14] = drive
        rows.append(balance)
        rhs.append(-np.append(force, moment))
    x = np.linalg.solve(np.vstack(rows), np.concatenate(rhs))
    return x[:14].reshape(7, 2)


def axial(crank: float, member: str, guess) -> float:
    """Signed force along a two-force member: the coupler (pins A, B) or coupler2 (C, D)."""
    th = closed(crank, guess)
    forces = pin_forces(crank, th)
    return float(forces[1] @ _e(th[0]) if member == "coupler" else forces[4] @ _e(th[2]))


def reference_flips() -> list[tuple[float, set[str], np.ndarray]]:
    """Crank angles where a coupler's force passes through zero, with the pins whose force
    vanishes there (|f| below 1e-6 of the load) and the closed passive angles; the assembly
    branch is followed from the nominal one by continuation in 1.25 deg steps."""
    grid = np.linspace(0.0, 2.0 * np.pi, 4 * STEPS + 1)
    guesses, guess = [], (0.39, 1.6, 0.7, 2.18)
    for crank in grid:
        guess = closed(crank, guess)
        guesses.append(guess)
    roots = []
    for member in ("coupler", "coupler2"):
        values = [axial(t, member, g) for t, g in zip(grid, guesses)]
        for i in np.flatnonzero(np.diff(np.sign(values))):
            root = brentq(axial, grid[i], grid[i + 1], (member, guesses[i]), xtol=1e-14)
            roots.append((root, guesses[i]))
    flips: list[tuple[float, set[str], np.ndarray]] = []
    for root, guess in sorted(roots, key=lambda r: r[0]):
        if flips and abs(root - flips[-1][0]) < 1e-9:  # both couplers: the same place
            continue
        th = closed(root, guess)
        vanishing = np.linalg.norm(pin_forces(root, th), axis=1) < 1e-6 * np.linalg.norm(FORCE)
        flips.append((root, {PINS[j] for j in np.flatnonzero(vanishing)}, th))
    return flips


def reference_jumps(crank: float, th: np.ndarray, h: float = 1e-6) -> dict[str, np.ndarray]:
    """The jumps across a flip at ``crank`` [m, rad]: every pin whose force vanishes there moves
    by 2c along its force's direction just before (far side minus near side, the crank angle
    increasing), carried to the tip, pin B on the rocker and the output's angle; ``th``: the
    passive angles closed at ``crank``."""
    before, after = (pin_forces(t, closed(t, th)) for t in (crank - h, crank + h))
    at = pin_forces(crank, th)
    offsets = np.zeros(14)
    for j in np.flatnonzero(np.linalg.norm(at, axis=1) < 1e-6 * np.linalg.norm(FORCE)):
        slope = (after[j] - before[j]) / (2 * h)  # the force goes through zero along it
        # the child sits against the force: d = -c f / |f|, from +c slope/|slope| to its opposite
        offsets[2 * j : 2 * j + 2] = -2 * PLAY * slope / np.linalg.norm(slope)
    angles = -np.linalg.solve(_loops_by_angles(th), _loops_by_offsets())  # d th / d offsets
    tip = np.outer(OUTPUT_TIP * _e_perp(th[3]), angles[3])
    tip[:, 12:14] += np.eye(2)  # the output pivot's own offset
    pin_b = np.outer(ROCKER * _e_perp(th[1]), angles[1])
    pin_b[:, 6:8] += np.eye(2)  # the rocker pivot's
    return {"output_tip": tip @ offsets, "rocker_B": pin_b @ offsets, "turn": angles[3] @ offsets}


# -- the library's sweep --------------------------------------------------------------------------
@pytest.fixture(scope="module")
def reference():
    return reference_flips()


@pytest.fixture(scope="module")
def sweep():
    six_bar = cp.load(str(MODEL))
    model = six_bar.model
    crank = model.joints[model.getJointId("crank_pivot")].idx_q
    turn = np.tile(six_bar.q_nominal, (STEPS + 1, 1))
    turn[:, crank] = np.linspace(0.0, 2.0 * np.pi, STEPS + 1)
    batch = six_bar.solve_many(configurations=turn)  # the file's load, gravity off
    assert batch.ok.all()
    changes = locate_changes(batch, outputs=["output_tip", "rocker_B"], tolerance=TOLERANCE)
    return six_bar, crank, batch, changes


def test_the_file_is_the_reference_linkage(sweep):
    """The library's closed configurations put the pins and the tip where the reference's loop
    closure does (Pinocchio forward kinematics of ``batch[i].configuration.q``), and its
    reactions are the reference's free-body pin forces (rigid-linkage statics: the play does
    not change the small-displacement model's forces)."""
    six_bar, crank, batch, _ = sweep
    model = six_bar.model
    data = model.createData()
    guess = (0.39, 1.6, 0.7, 2.18)
    for i in range(STEPS + 1):
        q = batch[i].configuration.q
        th = guess = closed(q[crank], guess)
        if i % 6:
            continue
        pin.framesForwardKinematics(model, data, q)
        where = {
            "coupler_B": CRANK * _e(q[crank]) + COUPLER * _e(th[0]),
            "rocker_B": O4 + ROCKER * _e(th[1]),
            "coupler2_D": O4 + ROCKER_C * _e(th[1] + BETA) + COUPLER2 * _e(th[2]),
            "output_tip": O6 + OUTPUT_TIP * _e(th[3]),
        }
        for frame, point in where.items():
            placed = data.oMf[model.getFrameId(frame)].translation
            np.testing.assert_allclose(placed, [*point, 0.0], rtol=0, atol=1e-10)
        forces = pin_forces(q[crank], th)
        for j, joint in enumerate(PINS):
            reaction = batch[i].reaction(joint, frame="world").force
            np.testing.assert_allclose(reaction, [*forces[j], 0.0], rtol=0, atol=1e-8)


def test_six_changes_a_turn_and_which_pins_flip_together(sweep, reference):
    """Six changes over the turn, all flips (no contact leaves: every pin stays loaded): four
    where the output is along the tip force (six pins), two where the output dwells (three
    pins); the output pivot, which carries the tip force, never flips."""
    *_, batch, _ = sweep
    modes = contact_modes(batch)
    expected = [pins for _, pins, _ in reference]
    assert expected == [SIX, SIX, THREE, SIX, SIX, THREE]
    assert [i for i, _ in modes.flips] == list(modes.changes)
    assert [{label.split(":")[0] for label in labels} for _, labels in modes.flips] == expected


def test_changes_sit_where_the_couplers_forces_vanish(sweep, reference):
    """Each located change is on the reference's root, to within the bisection's half
    interval (at most ``TOLERANCE`` of the crank's turn), and flips the reference's pins."""
    _, crank, batch, changes = sweep
    assert len(changes) == len(reference)
    step = 2.0 * np.pi / STEPS
    for change, (angle, pins, _) in zip(changes, reference):
        located = change.configuration[crank]
        assert abs(located - angle) <= 0.5 * change.width * step + 1e-12
        assert abs(located - angle) <= TOLERANCE * 2.0 * np.pi
        assert {label.split(":")[0] for label in change.flipped} == pins
        assert not change.touched and not change.left
        assert batch[change.index - 1].configuration.q[crank] < angle
        assert angle < batch[change.index].configuration.q[crank]


def test_jumps_are_the_flipped_plays_carried_to_the_outputs(sweep, reference):
    """The tip's and pin B's jumps, and the output's turn, are the reference's 2c per flipped
    pin through the closure's sensitivities (the library's are two solves ``width`` apart, so
    they also hold the motion across that width: far below 1e-3 of a jump). Where the output
    dwells the tip does not jump to first order: what is left is that drift, below 1e-3 of 2c,
    while pin B (on the rocker) jumps by its share of the three flipped plays."""
    *_, changes = sweep
    assert len(changes) == len(reference)
    for change, (angle, pins, th) in zip(changes, reference):
        expected = reference_jumps(angle, th)
        rocker = change.jumps["rocker_B"]
        np.testing.assert_allclose(
            rocker[:2],
            expected["rocker_B"],
            rtol=0,
            atol=1e-3 * np.linalg.norm(expected["rocker_B"]),
        )
        assert abs(rocker[2]) < 1e-12  # in the plane
        tip = change.jumps["output_tip"]
        if pins == SIX:
            scale = np.linalg.norm(expected["output_tip"])
            assert scale > 4 * PLAY  # six plays add up at the tip, each carried with its lever
            np.testing.assert_allclose(tip[:2], expected["output_tip"], rtol=0, atol=1e-3 * scale)
            turn = change.rotation_jumps["output_tip"]
            np.testing.assert_allclose(
                turn, [0.0, 0.0, expected["turn"]], rtol=0, atol=1e-3 * abs(expected["turn"])
            )
        else:
            assert np.linalg.norm(expected["output_tip"]) < 1e-12
            assert np.linalg.norm(tip) < 1e-3 * 2 * PLAY
