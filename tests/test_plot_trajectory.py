"""Pictures along a trajectory (clearance_pin.plot.plot_trajectory) and the contact modes behind
them: the slider-crank's block changes guide faces where the rod's push across the guide changes
sign, which the closed form of the in-line slider-crank places (crank 50 mm, rod 120 mm)."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import MODELS

import clearance_pin
from clearance_pin.plot import contact_modes

ANGLES = np.radians(np.arange(0.0, 360.0, 6.0))


def _curves(ax):
    """The data curves of a panel (the mode-change marks are unlabelled lines)."""
    return [line for line in ax.get_lines() if not line.get_label().startswith("_")]


def _trajectory(name, angles=ANGLES, **options):
    mechanism = clearance_pin.load(MODELS / f"{name}.urdf")
    joint = mechanism.model.joints[mechanism.model.getJointId("crank_pivot")]
    configurations = []
    for angle in angles:
        q = mechanism.q_nominal.copy()
        q[joint.idx_q] = angle
        configurations.append(q)
    return mechanism.solve_many(configurations=configurations, **options)


@pytest.fixture(scope="module")
def slider_batch():
    return _trajectory("slider_crank")


def test_contact_modes_of_the_slider_crank(slider_batch):
    modes = contact_modes(slider_batch)
    assert "slide:corner(-00).y" in modes.labels and "pin_B:pin" in modes.labels
    assert len(modes.changes) == 2  # the block crosses to the other face and back
    corner = modes.labels.index("slide:corner(-00).y")
    sides = modes.touching[:, corner]
    assert set(np.unique(sides)) == {-1.0, 1.0}
    # the block's face follows the sign of the force across the guide (opposite to it)
    for item, side in zip(slider_batch, sides):
        force = next(c.force for c in item.contacts if c.label == "slide:corner(-00).y")
        assert np.sign(force[1]) == -side
    for change in modes.changes:
        assert modes.modes[change] != modes.modes[change - 1]


def test_trajectory_picture(tmp_path, slider_batch):
    pytest.importorskip("matplotlib")
    from clearance_pin.plot import plot_trajectory

    target = tmp_path / "slider.png"
    figure = plot_trajectory(slider_batch, path=target)
    assert target.stat().st_size > 20_000
    deviation, forces, rows = figure.axes[:3]
    assert rows.get_xlabel() == "crank_pivot [deg]"
    assert "[um]" in deviation.get_ylabel() and "[N]" in forces.get_ylabel()
    first = slider_batch[0]
    assert len(_curves(deviation)) == len(first.outputs)
    np.testing.assert_allclose(_curves(deviation)[0].get_xdata(), np.degrees(ANGLES), atol=1e-9)
    name = next(iter(first.outputs))
    np.testing.assert_allclose(
        _curves(deviation)[0].get_ydata(),
        [np.linalg.norm(item.outputs[name][0]) * 1e6 for item in slider_batch],
    )
    assert len(_curves(forces)) == len(contact_modes(slider_batch).labels)
    assert "2 contact-mode changes" in figure.get_suptitle()
    # the changes are marked on every panel
    for ax in (deviation, forces, rows):
        assert sum(line.get_linestyle() == ":" for line in ax.get_lines()) >= 2


def test_four_bar_trajectory_one_mode(tmp_path):
    pytest.importorskip("matplotlib")
    from clearance_pin.plot import plot_trajectory

    batch = _trajectory("four_bar", np.radians(np.arange(0.0, 360.0, 30.0)))
    figure = plot_trajectory(batch, outputs=["coupler_B", "rocker"], path=tmp_path / "fb.png")
    assert "one contact mode all along" in figure.get_suptitle()
    assert [line.get_label() for line in _curves(figure.axes[0])] == ["coupler_B", "rocker"]


def test_prismatic_abscissa_in_mm_and_named_joint(tmp_path):
    """A mechanism with several driven joints needs the joint named; a frame as an output."""
    pytest.importorskip("matplotlib")
    from clearance_pin.plot import plot_trajectory

    arm = clearance_pin.load(MODELS / "arm_6r.urdf")
    joint = arm.model.joints[arm.model.getJointId("elbow")]
    configurations = []
    for angle in np.linspace(-0.2, 0.2, 5):
        q = arm.q_nominal.copy()
        q[joint.idx_q] += angle
        configurations.append(q)
    batch = arm.solve_many(configurations=configurations)
    figure = plot_trajectory(batch, outputs=["wrist_3"])  # elbow is the only one that moves
    assert figure.axes[2].get_xlabel() == "elbow [deg]"
    with pytest.raises(clearance_pin.NotFoundError):
        plot_trajectory(batch, driven_joint="no_such_joint")
    # 18 contact points: the force panel shows each joint's largest contact force
    assert len(_curves(figure.axes[1])) == 6
