"""Positioning discontinuities (issue 24 item 4): a pin flipping across its play is a change of
contact mode, located by bisection, with the outputs' jumps.

The four-bar's rocker carries a fixed force along world -y at its tip, its weight and the
coupler's off: the coupler is a two-force member whose force passes through zero where the
rocker is along y (the force's moment about the rocker pivot vanishes), and there every pin flips
across its play. That place is found here from the rocker's placement alone (Pinocchio's
forward kinematics of the closed configurations; no solver code), and the located change must sit
on it to within the bisection's width.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin

import clearance_pin as cp
from clearance_pin.mode_changes import locate_changes
from clearance_pin.plot.trajectory import contact_modes, plot_trajectory

MODELS = Path(__file__).resolve().parent.parent / "models"
PLAY = 5e-5  # [m] every pin's radial clearance


def _sweep(out_and_back: bool = False):
    four_bar = cp.load(str(MODELS / "four_bar.urdf"))
    model = four_bar.model
    crank = model.joints[model.getJointId("crank_pivot")].idx_q
    angles = np.linspace(0.0, 2.0 * np.pi, 73)
    if out_and_back:
        angles = np.concatenate([angles[:37], angles[35::-1]])
    turn = np.tile(four_bar.q_nominal, (len(angles), 1))
    turn[:, crank] = angles
    loads = [cp.PointForce("rocker", [0.0, -30.0, 0.0], [0.12, 0, 0])]
    return four_bar, four_bar.solve_many([loads] * len(angles), configurations=turn, gravity=False)


def test_a_pin_flip_is_located_where_the_coupler_force_vanishes():
    four_bar, batch = _sweep()
    modes = contact_modes(batch)
    assert len(modes.changes) == 2 and all(len(labels) == 3 for _, labels in modes.flips)
    changes = locate_changes(batch, outputs=["rocker_B"], tolerance=1e-6)
    rocker = four_bar.model.getJointId("rocker_pivot")
    for change in changes:
        assert set(change.flipped) == {"crank_pivot:pin", "pin_A:pin", "pin_B:pin"}
        q0 = batch[change.index - 1].configuration.q
        q1 = batch[change.index].configuration.q

        def along_x(s: float, q0=q0, q1=q1) -> float:  # the rocker's axis, world x component
            q = four_bar.configure((1.0 - s) * q0 + s * q1).q
            data = four_bar.model.createData()
            pin.forwardKinematics(four_bar.model, data, q)
            return float(data.oMi[rocker].rotation[0, 0])

        low, high = 0.0, 1.0  # bisection of the geometry alone
        for _ in range(40):
            middle = 0.5 * (low + high)
            if np.sign(along_x(middle)) == np.sign(along_x(low)):
                low = middle
            else:
                high = middle
        assert abs(change.fraction - low) <= change.width
        # the tip jumps across its pins' plays: each flip moves a pin by up to 2 c (4 pins)
        jump = np.linalg.norm(change.jumps["rocker_B"])
        assert 2 * PLAY < jump < 10 * PLAY
        assert change.largest_rotation_jump() > 0.0  # the rocker turns as its pins flip
        # the jump is that of two single solves either side of the change (the bisection's
        # answers are single solves at those poses; solved again here, the same numbers)
        s_near = change.fraction - 0.5 * change.width
        s_far = change.fraction + 0.5 * change.width
        loads = [cp.PointForce("rocker", [0.0, -30.0, 0.0], [0.12, 0, 0])]
        either = [
            four_bar.solve(loads, q=(1.0 - s) * q0 + s * q1, gravity=False).frame_displacement(
                "rocker_B"
            )
            for s in (s_near, s_far)
        ]
        np.testing.assert_allclose(
            either[1].linear - either[0].linear, change.jumps["rocker_B"], rtol=0, atol=1e-12
        )
        np.testing.assert_allclose(
            either[1].angular - either[0].angular,
            change.rotation_jumps["rocker_B"],
            rtol=0,
            atol=1e-12,
        )


def test_out_and_back_paths_draw_against_the_path(tmp_path):
    """An out-and-back sweep draws against the point along the path, its contact panel filled."""
    _, batch = _sweep(out_and_back=True)
    figure = plot_trajectory(batch, outputs=["rocker_B"], path=tmp_path / "back.png")
    assert "point along the path" in figure.axes[2].get_xlabel()
    assert len(figure.axes[2].patches) > 0  # the contact rows are drawn
