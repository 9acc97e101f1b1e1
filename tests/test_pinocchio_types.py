"""Results as Pinocchio types (issue 24 item 3): frame placements as pin.SE3, displacements as
pin.Motion in LOCAL, WORLD and LOCAL_WORLD_ALIGNED, reactions as pin.Force.

The change of reference frame is checked against Pinocchio's own SE3 action on a Motion (not the
library's formula): WORLD = SE3(I, p0).act(m), LOCAL = SE3(R0, 0).actInv(m), for m the
LOCAL_WORLD_ALIGNED displacement of a frame whose nominal placement is (R0, p0).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import clearance_pin as cp

MODELS = Path(__file__).resolve().parent.parent / "models"


@pytest.fixture(scope="module", params=[False, True], ids=["linear", "exact"])
def answer(request):
    arm = cp.load(str(MODELS / "arm_6r.urdf"))
    return arm.solve(exact=request.param)


def test_frame_displacement_is_a_motion_in_each_reference_frame(answer):
    model = answer.mechanism.model
    nominal = answer.configuration.oMf[model.getFrameId("tool")]
    aligned = answer.frame_displacement("tool")
    assert isinstance(aligned, pin.Motion)
    translation, rotation = aligned  # still unpacks as before
    assert np.array_equal(translation, aligned.linear) and np.array_equal(rotation, aligned.angular)
    assert np.linalg.norm(translation) > 1e-7  # the tool moves (play of 10 um per joint)
    world = answer.frame_displacement("tool", pin.WORLD)
    expected = pin.SE3(np.eye(3), nominal.translation).act(pin.Motion(aligned.vector))
    assert np.allclose(world.vector, expected.vector, rtol=0, atol=1e-15)
    local = answer.frame_displacement("tool", pin.LOCAL)
    expected = pin.SE3(nominal.rotation, np.zeros(3)).actInv(pin.Motion(aligned.vector))
    assert np.allclose(local.vector, expected.vector, rtol=0, atol=1e-15)
    with pytest.raises(cp.ArgumentError, match="reference_frame"):
        answer.frame_displacement("tool", "world")


def test_frame_placement_is_the_displaced_frame(answer):
    """The placement's translation moved from the nominal one by the displacement (exactly for
    the exact model; for the linear one, whose placement is the rigid motion exp(xi) of the
    body's twist, to second order: |theta|^2 |p0|), its rotation by the rotation vector."""
    model = answer.mechanism.model
    nominal = answer.configuration.oMf[model.getFrameId("tool")]
    placed = answer.frame_placement("tool")
    assert isinstance(placed, pin.SE3)
    moved = answer.frame_displacement("tool")
    second_order = np.dot(moved.angular, moved.angular) * np.linalg.norm(nominal.translation)
    bound = 1e-15 if answer.formulation == "exact" else second_order
    assert np.abs(placed.translation - nominal.translation - moved.linear).max() <= bound
    turned = pin.log3(placed.rotation @ nominal.rotation.T)
    assert np.allclose(turned, moved.angular, rtol=0, atol=1e-12)
    with pytest.raises(cp.NotFoundError):
        answer.frame_placement("no_such_frame")


def test_reaction_as_force(answer):
    for frame in ("joint", "world"):
        reaction = answer.reaction("elbow", frame)
        force = reaction.as_force()
        assert isinstance(force, pin.Force)
        assert np.array_equal(force.linear, reaction.force)
        assert np.array_equal(force.angular, reaction.moment)
    # world: the tool load (-50 N along z, plus gravity) passes to the base through every joint
    assert abs(answer.reaction("shoulder_pan", "world").as_force().linear[2]) > 50.0
