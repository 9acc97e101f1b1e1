"""Where a loop joint's clearance zone sits (clearance_pin.kinematics.loop_frames): on the child
part where it is, whatever frame the housing is written on; a misaligned housing inside its play
is a nominal eccentricity; an ideal URDF prismatic joint holds what its type holds."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import MODELS

import clearance_pin as cp
from clearance_pin import PointForce, Torque
from clearance_pin.errors import ModelError, NotFoundError
from clearance_pin.loading import loads

PLAY = 5e-05  # [m] every joint of models/slider_crank.urdf
GUIDE_AT_ORIGIN = (
    '<joint name="guide_mount" type="fixed"><parent link="ground"/><child link="guide"/></joint>'
)


def slider_crank_with_guide_at(x: float):
    """models/slider_crank.urdf with its guide frame (frame_a of the prismatic loop joint) moved to
    x [m] along the guide's axis: the same mechanism written another way."""
    text = (MODELS / "slider_crank.urdf").read_text()
    assert GUIDE_AT_ORIGIN in text
    moved = GUIDE_AT_ORIGIN.replace("</joint>", f'<origin xyz="{x!r} 0 0"/></joint>')
    return loads(text.replace(GUIDE_AT_ORIGIN, moved), source=f"slider_crank(guide at {x} m)")


@pytest.mark.parametrize("exact", [False, True], ids=["linear", "exact"])
def test_the_guide_frame_may_sit_anywhere_on_the_guide_axis(exact):
    """Regression (issue 10, finding 1): the bundled slider-crank, whose guide frame sits at the
    crank pivot, moved its slider 342 um across a 50 um guide play with ok=True. The answer must not
    depend on where along its axis the guide frame is written (origin, under the slider, 0.5 m
    beyond it): the block's corners are on the slider, where the slider is."""
    answers = [slider_crank_with_guide_at(x).solve(exact=exact) for x in (0.0, 0.1369, 0.5)]
    reference = answers[0]
    assert all(a.ok for a in answers)
    for other in answers[1:]:
        for name in ("crank_pivot", "pin_A", "pin_B"):
            assert np.allclose(other.torsors[name], reference.torsors[name], rtol=0, atol=1e-13)
        assert [c.label for c in other.active_contacts] == [
            c.label for c in reference.active_contacts
        ]


@pytest.mark.parametrize("exact", [False, True], ids=["linear", "exact"])
def test_the_slider_block_settles_against_its_guide_without_tilting(exact):
    """Statics of the slider (independent of the solver): the rod's force and the gas force act at
    the pin at the block's centre, so the guide's reaction has no moment about that centre and is
    shared by the two corners of one side: the block translates across by exactly its play and does
    not tilt (gamma = 0), and never leaves the guide."""
    mechanism = cp.load(MODELS / "slider_crank.urdf")
    equilibrium = mechanism.solve(exact=exact)
    slide = equilibrium.torsors["slide"]
    assert abs(slide[1]) == pytest.approx(PLAY, rel=1e-9)
    assert abs(slide[5]) <= 1e-12 * PLAY / 0.04
    slider = mechanism.model.getFrameId("slider")
    guide = mechanism.model.getFrameId("guide")
    # the slider's lateral world displacement, read from the solved placements with Pinocchio
    solved = equilibrium.body_placements[mechanism.model.frames[slider].parentJoint]
    nominal = equilibrium.configuration.oMi[mechanism.model.frames[slider].parentJoint]
    across = equilibrium.configuration.oMf[guide].rotation[:, 1]
    assert abs(float(across @ (solved.translation - nominal.translation))) <= PLAY * (1 + 1e-9)
    assert equilibrium.check().ok if exact else True


def test_the_coal_check_passes_with_the_guide_far_from_the_slider():
    """The geometric check builds the block on the slider (frame_b's part) and the guide on the
    ground: the exact answer of the slider-crank written with its guide frame 0.5 m away reads
    contact on the guide."""
    equilibrium = slider_crank_with_guide_at(0.5).solve(exact=True)
    report = equilibrium.check()
    assert report.ok, report


IDEAL_SLIDE = """<?xml version="1.0"?>
<robot name="ideal_slide">
  <link name="ground"/>
  <link name="carriage"><inertial><mass value="1"/>
    <inertia ixx="1e-3" iyy="1e-3" izz="1e-3" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="arm"><inertial><mass value="1"/>
    <inertia ixx="1e-3" iyy="1e-3" izz="1e-3" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <joint name="slide" type="prismatic">
    <parent link="ground"/><child link="carriage"/><axis xyz="0 0 1"/>
    <limit lower="-0.1" upper="0.1" effort="100" velocity="1"/>
  </joint>
  <joint name="pivot" type="revolute">
    <parent link="carriage"/><child link="arm"/><origin xyz="0 0 0.1"/><axis xyz="1 0 0"/>
    <limit lower="-3" upper="3" effort="100" velocity="1"/>
  </joint>
  <clearance_pin>
    <joint name="slide" driven="true"/>
    <joint name="pivot" type="revolute" radial_clearance="1e-05" axial_clearance="5e-06"
           length="0.02" driven="true"/>
  </clearance_pin>
</robot>
"""


@pytest.mark.parametrize("exact", [False, True], ids=["linear", "exact"])
def test_an_ideal_prismatic_joint_holds_the_spin_about_its_axis(exact):
    """Regression (issue 10, finding 3): a URDF prismatic joint without clearance left its
    carriage free to spin about the axis (the Panda's fingers raised UnboundedLoadError for any
    torque about the finger axis). It constrains what its URDF type constrains: everything but
    the slide, which its drive holds. A torque about the axis and a force across it move nothing
    but the play of the pin above it (closed form of a journal, below)."""
    mechanism = loads(IDEAL_SLIDE, source="ideal_slide")
    equilibrium = mechanism.solve(
        loads=[Torque("arm", [0.0, 0.0, 2.0]), PointForce("arm", [0.0, 5.0, 0.0], [0, 0, 0.1])],
        exact=exact,
    )
    assert equilibrium.ok
    assert np.abs(equilibrium.torsors["slide"]).max() <= 1e-15
    # the journal above takes the moment: a+- = P f / 2 +- (m x a) / L = (0, 2.5 +- 100, 0) N, so
    # its two ends go to opposite sides of the bore, a tilt of 2 c / L = 1 mrad about z
    assert abs(equilibrium.torsors["pivot"][5]) == pytest.approx(2 * 1e-05 / 0.02, rel=1e-6)


def three_bearing_shaft(offset_y: float, offset_z: float = 0.0):
    """A shaft on three journals 0.1 m apart (radial play 30 um, 20 mm long), the middle housing
    displaced by (offset_y, offset_z) [m], loaded by 100 N downwards (-y) between the second and
    third bearings."""
    return loads(
        f"""<?xml version="1.0"?>
<robot name="shaft3">
  <link name="ground"/>
  <link name="shaft"><inertial><mass value="1"/>
    <inertia ixx="1e-3" iyy="1e-3" izz="1e-3" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="housing_2"/><link name="housing_3"/><link name="journal_2"/><link name="journal_3"/>
  <joint name="B1" type="floating"><parent link="ground"/><child link="shaft"/></joint>
  <joint name="h2" type="fixed"><parent link="ground"/><child link="housing_2"/>
    <origin xyz="0.1 {offset_y!r} {offset_z!r}"/></joint>
  <joint name="h3" type="fixed"><parent link="ground"/><child link="housing_3"/>
    <origin xyz="0.2 0 0"/></joint>
  <joint name="j2" type="fixed"><parent link="shaft"/><child link="journal_2"/>
    <origin xyz="0.1 0 0"/></joint>
  <joint name="j3" type="fixed"><parent link="shaft"/><child link="journal_3"/>
    <origin xyz="0.2 0 0"/></joint>
  <clearance_pin>
    <joint name="B1" type="revolute" radial_clearance="3e-05" axial_clearance="1e-05"
           length="0.02"/>
    <loop_joint name="B2" type="cylindrical" frame_a="housing_2" frame_b="journal_2"
                radial_clearance="3e-05" length="0.02" axis="1 0 0"/>
    <loop_joint name="B3" type="cylindrical" frame_a="housing_3" frame_b="journal_3"
                radial_clearance="3e-05" length="0.02" axis="1 0 0"/>
    <force link="shaft" point="0.15 0 0" value="0 -100 0"/>
  </clearance_pin>
</robot>
""",
        source="shaft3",
    )


@pytest.mark.parametrize("exact", [False, True], ids=["linear", "exact"])
def test_a_misaligned_middle_housing_inside_its_play_is_an_eccentricity(exact):
    """Regression (issue 10, finding 6): the middle housing 20 um high (inside its 30 um play) was
    refused as "the loops cannot be closed". Closed form (rigid-body construction): the straight
    shaft, pushed down between bearings 2 and 3, rests on the bottom of bore 2 (y = 20 - 30 um) at
    the journal's outer end x = 0.11 m and on the bottom of bore 3 (y = -30 um) at x = 0.21 m; the
    line through them has slope -20 um / 0.1 m = -200 urad and passes x = 0 at y = +12 um, inside
    bearing 1, which carries nothing."""
    equilibrium = three_bearing_shaft(20e-6).solve(exact=exact)
    assert equilibrium.ok
    assert sorted(c.label for c in equilibrium.active_contacts) == ["B2:end+", "B3:end+"]
    translation, rotation = equilibrium.body_motions["B1"]
    assert translation[1] == pytest.approx(12e-6, abs=1e-12)
    assert rotation[2] == pytest.approx(-200e-6, abs=1e-11)
    assert np.abs(translation[[2]]).max() <= 1e-15 and np.abs(rotation[:2]).max() <= 1e-15
    # the middle journal's motion is reported from its nominal (eccentric) place: 12 - 20 um
    assert equilibrium.torsors["B2"][1] == pytest.approx(-8e-6, abs=1e-11)


def test_an_offset_beyond_the_play_or_in_a_rigid_direction_is_refused():
    """A housing 40 um off with 30 um of play is not a misalignment the play can take: a clear
    ModelError names the loop joint, the offset and the play."""
    with pytest.raises(ModelError, match=r"B2.*4\.000e-05 m.*play 3\.000e-05 m"):
        three_bearing_shaft(40e-6)


def test_an_offset_in_a_rigid_direction_is_refused():
    """The four-bar's loop pin written 10 um out of the plane of the linkage: a planar pin holds
    the axial direction rigidly, so no play can take that offset: a clear ModelError names the loop
    joint and the direction."""
    text = (MODELS / "four_bar.urdf").read_text()
    mount = '<origin xyz="0.12 0 0"/></joint>'
    assert mount in text
    with pytest.raises(ModelError, match=r"pin_B.*1\.000e-05 m in a rigid direction \(u\)"):
        loads(text.replace(mount, '<origin xyz="0.12 0 1e-05"/></joint>'), source="four_bar")


def test_the_eccentricity_is_reported():
    """The misaligned housing's offset is reported with the answer (in its own frame, in the
    table and the JSON): 20 um across the middle bearing's axis, no tilt; an aligned mechanism
    reports none."""
    equilibrium = three_bearing_shaft(20e-6).solve()
    offset, tilt = equilibrium.eccentricities["B2"]
    assert offset == pytest.approx([0.0, -20e-6, 0.0], abs=1e-15)  # journal below the housing
    assert np.abs(tilt).max() == 0.0
    assert set(equilibrium.eccentricities) == {"B2"}
    assert "eccentric (misaligned housing) B2" in equilibrium.table()
    assert equilibrium.to_dict()["eccentricities"]["B2"]["translation"][1] == pytest.approx(-20e-6)
    assert three_bearing_shaft(0.0).solve().eccentricities == {}


def test_the_eccentricity_by_name_as_the_docs_write_it():
    """`Configuration.eccentricity("B2")`, as docs/model-format.md writes it (an AttributeError
    before: only a LoopJoint was taken): the housing 20 um high, so the journal's clearance frame
    sits 20 um below it in the housing's frame (the construction above); an unknown name is a
    NotFoundError listing the loop joints."""
    mechanism = three_bearing_shaft(20e-6)
    configuration = mechanism.configure(mechanism.q_nominal)
    offset = configuration.eccentricity("B2")
    assert offset.translation == pytest.approx([0.0, -20e-6, 0.0], abs=1e-15)
    assert configuration.eccentricity(mechanism.joint("B3")).isIdentity(1e-15)
    with pytest.raises(NotFoundError, match=r"B9.*B2, B3"):
        configuration.eccentricity("B9")
