"""MJCF models beside a clearance file (issue 14), through Pinocchio's MJCF reader.

Self-consistency: a two-link arm and a four-bar written here as MJCF (the four-bar's loop cut
between two sites, as a loop joint of the clearance file) and as URDF, with one clearance file,
give the same mechanism and the same answers (both formulations) to 1e-12 of the play (measured
on Pinocchio 4.1: bitwise equal): the two readers build the same tree. The answers on the URDF
side are checked independently elsewhere (tests/test_clearance_file.py's journal closed form;
the four-bar in validation and the oracle). What MJCF says that is not read (equality
constraints, ball joints, several joints in one body, a block inside the MJCF file) and what
Pinocchio's reader drops (a second root body) is refused with a ModelError naming it; placements
are checked against MuJoCo in tests/test_mjcf_orientation.py.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from conftest import ROOT
from test_clearance_file import split

import clearance_pin as cp

ARM_MJCF = """<mujoco model="arm2">
  <compiler angle="radian"/>
  <worldbody>
    <body name="upper" pos="0 0 0.1">
      <joint name="shoulder" type="hinge" axis="0 0 1" range="-3 3" limited="true"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.02"/>
      <body name="fore" pos="0.3 0 0">
        <joint name="elbow" type="hinge" axis="0 1 0" range="-3 3" limited="true"/>
        <geom type="capsule" fromto="0 0 0 0.25 0 0" size="0.02"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""
ARM_URDF = """<robot name="arm2">
  <link name="world"/><link name="upper"/><link name="fore"/>
  <joint name="shoulder" type="revolute"><parent link="world"/><child link="upper"/>
    <origin xyz="0 0 0.1"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/>
  </joint>
  <joint name="elbow" type="revolute"><parent link="upper"/><child link="fore"/>
    <origin xyz="0.3 0 0"/><axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="1" velocity="1"/>
  </joint>
</robot>
"""
ARM_PLAY = """<clearance_pin unit="mm">
  <default joint_type="revolute" type="revolute" radial_clearance="0.02" axial_clearance="0.01"
           length="25" driven="true"/>
  <joint name="shoulder" q="0.4"/>
  <joint name="elbow" q="-0.7" radial_clearance="0.03"/>
  <force link="fore" point="250 0 0" value="3 -40 12"/>
  <torque link="upper" value="0.5 0.2 0"/>
</clearance_pin>
"""
# models/four_bar.urdf as MJCF: the bodies at the joint origins, pin B cut between two sites;
# one tree under a root body at the origin (Pinocchio reads the first body of <worldbody> only)
FOUR_BAR_MJCF = """<mujoco model="four_bar">
  <compiler angle="radian"/>
  <worldbody>
    <body name="ground">
      <body name="crank">
        <joint name="crank_pivot" type="hinge" axis="0 0 1" range="-7 7" limited="true"/>
        <geom type="sphere" size="0.01" pos="0.03 0 0"/>
        <body name="coupler" pos="0.06 0 0">
          <joint name="pin_A" type="hinge" axis="0 0 1" range="-7 7" limited="true"/>
          <geom type="sphere" size="0.01" pos="0.09 0 0"/>
          <site name="coupler_B" pos="0.18 0 0"/>
        </body>
      </body>
      <body name="rocker" pos="0.2 0 0">
        <joint name="rocker_pivot" type="hinge" axis="0 0 1" range="-7 7" limited="true"/>
        <geom type="sphere" size="0.01" pos="0.06 0 0"/>
        <site name="rocker_B" pos="0.12 0 0"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def write(directory: Path, name: str, text: str) -> Path:
    path = directory / name
    path.write_text(text)
    return path


def arm_play(directory: Path) -> Path:
    return write(directory, "play.xml", ARM_PLAY)


def assert_same(got: cp.Mechanism, expected: cp.Mechanism, rtol: float) -> None:
    """Same joints (by name), clearances, drives, loads; answers equal to ``rtol`` of the play."""
    assert sorted(got.joints) == sorted(expected.joints)
    for name, joint in expected.joints.items():
        other = got.joints[name]
        assert other.clearance == joint.clearance, name
        assert getattr(other, "driven", None) == getattr(joint, "driven", None), name
    scale = max(j.clearance.max_play for j in expected.joints.values())
    for exact in (False, True):
        a, b = got.solve(exact=exact), expected.solve(exact=exact)
        assert a.ok and b.ok
        assert {c.label for c in a.active_contacts} == {c.label for c in b.active_contacts}
        for name in expected.joints:
            np.testing.assert_allclose(
                a.torsor(name), b.torsor(name), rtol=0, atol=rtol * scale, err_msg=name
            )


def test_two_link_arm_mjcf_gives_the_urdf_answer(tmp_path):
    play = write(tmp_path, "play.xml", ARM_PLAY)
    mjcf = cp.load(write(tmp_path, "arm.xml", ARM_MJCF), clearances=play)
    urdf = cp.load(write(tmp_path, "arm.urdf", ARM_URDF), clearances=play)
    assert mjcf.name == "arm2" and mjcf.source == f"{tmp_path / 'arm.xml'} + {play}"
    assert [j.name for j in mjcf.tree_joints] == ["shoulder", "elbow"]
    assert mjcf.joint("elbow").clearance == cp.model.Clearance(
        "revolute", 3e-5, length=0.025, axial=1e-5
    )
    np.testing.assert_array_equal(mjcf.q_nominal, urdf.q_nominal)
    assert_same(mjcf, urdf, 1e-12)


def test_two_link_arm_mjcf_text_and_toml(tmp_path):
    """clearance_pin.loads reads MJCF text too; the clearance file may be TOML."""
    play = write(
        tmp_path,
        "play.toml",
        'unit = "um"\n[defaults.revolute]\ntype = "revolute"\nradial_clearance = 20\n'
        "axial_clearance = 10\nlength = 25_000\ndriven = true\n"
        "[joints.shoulder]\nq = 0.4\n[joints.elbow]\nq = -0.7\nradial_clearance = 30\n"
        '[[forces]]\nlink = "fore"\npoint = [250_000, 0, 0]\nvalue = [3, -40, 12]\n'
        '[[torques]]\nlink = "upper"\nvalue = [0.5, 0.2, 0]\n',
    )
    got = cp.loads(ARM_MJCF, source="arm", clearances=play)
    expected = cp.load(write(tmp_path, "arm.urdf", ARM_URDF), clearances=arm_play(tmp_path))
    assert_same(got, expected, 1e-12)


def test_four_bar_mjcf_with_its_loop_cut_between_sites(tmp_path):
    """The four-bar's loop as a loop joint between two MJCF sites: the answers of
    models/four_bar.urdf (the same block as a clearance file)."""
    urdf_text = (ROOT / "models" / "four_bar.urdf").read_text()
    _, block = split(urdf_text)
    play = write(tmp_path, "play.xml", ET.tostring(block, encoding="unicode"))
    got = cp.load(write(tmp_path, "four_bar.xml", FOUR_BAR_MJCF), clearances=play)
    expected = cp.load(ROOT / "models" / "four_bar.urdf")
    np.testing.assert_allclose(
        [got.q_nominal[got.model.joints[got.joint(n).joint_id].idx_q] for n in ("pin_A",)],
        [
            expected.q_nominal[expected.model.joints[expected.joint(n).joint_id].idx_q]
            for n in ("pin_A",)
        ],
        rtol=0,
        atol=1e-12,
    )
    assert_same(got, expected, 1e-12)


def test_mjcf_collision_geometry_is_built_on_demand(tmp_path):
    mechanism = cp.load(write(tmp_path, "arm.xml", ARM_MJCF), clearances=arm_play(tmp_path))
    geometry = mechanism.collision_model
    assert geometry.ngeoms == 2
    assert {mechanism.model.frames[g.parentFrame].name for g in geometry.geometryObjects} == {
        "upper",
        "fore",
    }


# -- refusals --------------------------------------------------------------------------------------
BAD_MJCF = {
    # id: (edits of ARM_MJCF (old, new, ...), element named, words of the problem)
    "equality constraint": (
        (
            "</worldbody>",
            '</worldbody><equality><connect name="loop" body1="fore" anchor="0 0 0"/></equality>',
        ),
        "<equality> <connect name='loop'>",
        ["equality constraints", "not read", "<loop_joint>"],
    ),
    "a block inside the MJCF": (
        ("</worldbody>", "</worldbody><clearance_pin/>"),
        "<clearance_pin>",
        ["clearance file"],
    ),
    "a ball joint": (
        (
            '<joint name="elbow" type="hinge" axis="0 1 0" range="-3 3" limited="true"/>',
            '<joint name="elbow" type="ball"/>',
        ),
        "<joint name='elbow'>",
        ["JointModelSpherical", "not supported", "free joint with a spherical clearance"],
    ),
    "a second root body, which Pinocchio drops": (
        ("</worldbody>", '<body name="box" pos="1 0 0"><freejoint/></body></worldbody>'),
        "<body name='box'>",
        ["did not read 1 of the 3 bodies", "first body under <worldbody>", "upper, box"],
    ),
    "two joints in one body": (
        (
            '<joint name="elbow" type="hinge"',
            '<joint name="twist" type="hinge" axis="1 0 0"/><joint name="elbow" type="hinge"',
        ),
        "<joint name='Composite_twist'>",
        ["JointModelComposite", "one joint per body"],
    ),
}


@pytest.mark.parametrize(("edit", "element", "words"), BAD_MJCF.values(), ids=BAD_MJCF.keys())
def test_what_mjcf_says_and_is_not_read_is_refused(edit, element, words, tmp_path):
    text = ARM_MJCF
    for old, new in zip(edit[::2], edit[1::2]):  # (old, new, old, new, ...)
        assert old in text
        text = text.replace(old, new, 1)
    path = write(tmp_path, "arm.xml", text)
    play = write(
        tmp_path,
        "play.xml",
        '<clearance_pin><default joint_type="revolute" type="revolute" radial_clearance="1e-5" '
        'length="0.02"/></clearance_pin>',
    )
    with pytest.raises(cp.ModelError) as caught:
        cp.load(path, clearances=play)
    assert caught.value.element == element, caught.value
    for word in words:
        assert word in caught.value.problem, (word, caught.value.problem)


def test_an_mjcf_joint_the_clearance_file_misnames(tmp_path):
    play = write(tmp_path, "play.toml", '[joints.knee]\ntype = "revolute"\n')
    with pytest.raises(cp.ModelError) as caught:
        cp.load(write(tmp_path, "arm.xml", ARM_MJCF), clearances=play)
    assert caught.value.source == str(play) and caught.value.element == "[joints.knee]"
    assert "no MJCF joint is called 'knee'; the MJCF joints are: shoulder, elbow" in str(
        caught.value
    )


def test_an_mjcf_include_that_cannot_be_read(tmp_path):
    """An <include> is spliced in by clearance_pin's own reading: a missing file is named."""
    path = write(tmp_path, "bad.xml", '<mujoco><include file="missing.xml"/><worldbody/></mujoco>')
    with pytest.raises(cp.ModelError) as caught:
        cp.load(path)
    assert caught.value.source == str(path)
    assert caught.value.element == "<include file='missing.xml'>"
    assert "cannot be read" in caught.value.problem


def test_an_mjcf_file_pinocchio_cannot_read(tmp_path):
    path = write(
        tmp_path,
        "bad.xml",
        '<mujoco><worldbody><body name="a"><joint name="j" type="weird"/><geom size="0.1"/>'
        "</body></worldbody></mujoco>",
    )
    with pytest.raises(cp.ModelError) as caught:
        cp.load(path)
    assert caught.value.source == str(path) and caught.value.element == "<mujoco>"
    assert "Pinocchio cannot build the MJCF" in caught.value.problem


def test_a_body_pinocchio_misplaces_is_refused():
    """The guard against a misread placement: the placements read from the file against a model
    whose elbow was moved by 10 mm (standing in for a reader error)."""
    import pinocchio as pin

    from clearance_pin.model import mjcf
    from clearance_pin.model.mjcf_placements import read_placements

    placements = read_placements(ET.fromstring(ARM_MJCF), "arm.xml", None)
    model = cp.loads(ARM_MJCF, clearances={}).model  # {}: ideal joints, on purpose
    mjcf.check_placements(model, placements, "arm.xml")  # as read: accepted
    moved = pin.Model(model)
    moved.jointPlacements[2] = pin.SE3(np.eye(3), np.array([0.31, 0.0, 0.0]))
    with pytest.raises(cp.ModelError) as caught:
        mjcf.check_placements(moved, placements, "arm.xml")
    assert caught.value.element == "<body name='fore'>"
    problem = caught.value.problem
    assert "[0.31, 0.0, 0.1] m" in problem and "[0.3, 0.0, 0.1] m" in problem
    assert "pos='0.3 0 0'" in problem


def test_a_load_on_a_site_names_the_link_and_point_to_write(tmp_path):
    """A force on an MJCF site (a Kinova's pinch_site, say): a load is applied to a link at a
    point in its frame, so the LoadError names the site's body and the site's position in it,
    as the file writes it (``pos`` of the site), ready to paste (it said only "unknown link").
    The suggested load is accepted and solved."""
    text = ARM_MJCF.replace(
        '<geom type="capsule" fromto="0 0 0 0.25 0 0" size="0.02"/>',
        '<geom type="capsule" fromto="0 0 0 0.25 0 0" size="0.02"/>\n'
        '        <site name="tip" pos="0.25 0 0.01" quat="0.7071068 0 0.7071068 0"/>',
    )
    mechanism = cp.loads(text, source="arm", clearances=arm_play(tmp_path))
    with pytest.raises(cp.LoadError) as caught:
        mechanism.solve(loads=[cp.PointForce("tip", [0.0, 0.0, -10.0])])
    message = str(caught.value)
    assert "'tip'" in message and "link 'fore'" in message
    written = message.split("write ")[1]
    assert written == "PointForce('fore', force, point=[0.25, 0, 0.01])"
    answer = mechanism.solve(loads=[cp.PointForce("fore", [0.0, 0.0, -10.0], [0.25, 0, 0.01])])
    assert answer.ok
