"""Closed-form equilibria of the small-displacement model (docs/method.md section 2).

Each mechanism here is small enough that its equilibrium follows from the clearance sets by hand:
a ball pushed by a force through its centre, a chain of pins with radial play under a tip force,
a journal tilted by a transverse torque, a shaft on two equal spherical joints.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from conftest import CASES, build_case, case_text, random_rotation

import clearance_pin as cp

RTOL = 1e-12


def _xyz(vector) -> str:
    return " ".join(repr(float(v)) for v in vector)


def one_joint_urdf(clearance: str, xyz=(0.0, 0.0, 0.0), rpy=(0.0, 0.0, 0.0)) -> str:
    """A part on the ground by one floating URDF joint carrying ``clearance`` (attribute text)."""
    return f"""<?xml version="1.0"?>
<robot name="one_joint">
  <link name="ground"/>
  <link name="part"/>
  <joint name="K" type="floating">
    <parent link="ground"/><child link="part"/><origin xyz="{_xyz(xyz)}" rpy="{_xyz(rpy)}"/>
  </joint>
  <clearance_pin>
    <joint name="K" {clearance}/>
  </clearance_pin>
</robot>
"""


# -- a ball in its socket ---------------------------------------------------------------------------
def test_ball_in_world_axes_moves_by_c_along_the_force():
    """A spherical joint (radial play c) under F through its centre: T = (c F/|F|, 0, 0, 0)."""
    c = 1.5e-4
    mechanism = cp.loads(one_joint_urdf(f'type="spherical" radial_clearance="{c!r}"'))
    for values in ([3.0, -1.0, 2.0], [0.0, 0.0, -7.0], [1e-3, 2e-3, 0.0]):
        force = np.array(values)
        result = mechanism.solve(loads=[cp.PointForce("part", force)])
        expected = np.concatenate([c * force / np.linalg.norm(force), np.zeros(3)])
        np.testing.assert_allclose(result.torsor("K"), expected, rtol=0, atol=RTOL * c)
        assert result.ok and result.status == "optimal"
        assert result.energy == pytest.approx(-c * np.linalg.norm(force), rel=1e-12)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_ball_anywhere_moves_by_c_along_the_force(seed):
    """A ball placed and oriented at random (joint origin and clearance axis): the part's origin,
    the ball centre, moves by c F/|F| in world axes without rotating, and |V| = c in the joint
    frame."""
    rng = np.random.default_rng(seed)
    c = 10 ** rng.uniform(-6, -3)
    axis = rng.standard_normal(3)
    text = one_joint_urdf(
        f'type="spherical" diametral_clearance="{2 * c!r}" axis="{_xyz(axis)}"',
        xyz=rng.uniform(-1, 1, 3),
        rpy=rng.uniform(-np.pi, np.pi, 3),
    )
    force = rng.standard_normal(3) * 10
    result = cp.loads(text).solve(loads=[cp.PointForce("part", force)])
    translation, rotation = result.frame_displacement("part")
    np.testing.assert_allclose(translation, c * force / np.linalg.norm(force), atol=RTOL * c)
    np.testing.assert_allclose(rotation, 0.0, atol=1e-15)
    torsor = result.torsor("K")
    assert np.linalg.norm(torsor[:3]) == pytest.approx(c, rel=1e-12)
    np.testing.assert_allclose(torsor[3:], 0.0, atol=1e-15)
    (contact,) = result.active_contacts
    assert contact.point == "ball" and abs(contact.gap) <= 1e-12 * c


# -- a planar chain of locked pins -------------------------------------------------------------------
def planar_chain_urdf(lengths, clearances, angles) -> str:
    """A serial chain of driven revolute joints (axis z) with planar_revolute play, and a tip."""
    links = "".join(f'<link name="l{i}"/>' for i in range(len(lengths) + 1))
    joints, block = [], []
    lengths, clearances, angles = ([float(v) for v in a] for a in (lengths, clearances, angles))
    for i, (c, q) in enumerate(zip(clearances, angles), start=1):
        offset = 0.0 if i == 1 else lengths[i - 2]
        joints.append(
            f'<joint name="j{i}" type="revolute"><parent link="l{i - 1}"/><child link="l{i}"/>'
            f'<origin xyz="{offset!r} 0 0"/><axis xyz="0 0 1"/>'
            '<limit lower="-7" upper="7" effort="1" velocity="1"/></joint>'
        )
        block.append(
            f'<joint name="j{i}" type="planar_revolute" radial_clearance="{c!r}" '
            f'driven="true" q="{q!r}"/>'
        )
    tip = (
        f'<link name="tip"/><joint name="tip_mount" type="fixed"><parent link="l{len(lengths)}"/>'
        f'<child link="tip"/><origin xyz="{lengths[-1]!r} 0 0"/></joint>'
    )
    return (
        f'<robot name="chain">{links}{tip}{"".join(joints)}'
        f"<clearance_pin>{''.join(block)}</clearance_pin></robot>"
    )


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_planar_chain_tip_moves_by_the_sum_of_plays(seed):
    """A serial chain of locked pins with radial plays c_i under an in-plane tip force F: the tip
    translates by (sum c_i) F/|F| and does not rotate; every pin uses its whole play."""
    rng = np.random.default_rng(seed)
    count = 2 + seed
    lengths = rng.uniform(0.05, 0.5, count)
    clearances = 10 ** rng.uniform(-6, -4, count)
    angles = rng.uniform(-np.pi, np.pi, count)
    mechanism = cp.loads(planar_chain_urdf(lengths, clearances, angles))
    force = np.append(rng.standard_normal(2) * 50, 0.0)
    result = mechanism.solve(loads=[cp.PointForce("tip", force)])
    translation, rotation = result.frame_displacement("tip")
    expected = clearances.sum() * force / np.linalg.norm(force)
    np.testing.assert_allclose(translation, expected, atol=RTOL * clearances.sum())
    np.testing.assert_allclose(rotation, 0.0, atol=1e-15)
    for i, c in enumerate(clearances, start=1):
        torsor = result.torsor(f"j{i}")
        assert np.linalg.norm(torsor[1:3]) == pytest.approx(c, rel=1e-12)
        np.testing.assert_allclose(torsor[[0, 3, 4, 5]], 0.0, atol=1e-15)
    assert result.ok and result.residuals["statics"] < 1e-12


def test_planar_chain_ignores_loads_on_blocked_motions():
    """Out-of-plane force components and torques only work on motions a planar pin blocks (axial
    slide, tilts) or a drive locks (rotation): adding them changes nothing."""
    rng = np.random.default_rng(7)
    lengths, clearances, angles = [0.3, 0.2, 0.1], [2e-5, 5e-5, 1e-5], [0.4, -1.1, 2.0]
    mechanism = cp.loads(planar_chain_urdf(lengths, clearances, angles))
    in_plane = np.array([-12.0, 30.0, 0.0])
    plain = mechanism.solve(loads=[cp.PointForce("tip", in_plane)])
    loaded = mechanism.solve(
        loads=[
            cp.PointForce(
                "tip", in_plane + np.array([0.0, 0.0, 80.0]), point=rng.standard_normal(3) * 0.1
            ),
            cp.Torque("l2", rng.standard_normal(3) * 5),
            cp.PointForce("l1", [0.0, 0.0, -40.0], point=[0.1, 0.05, 0.02]),
        ]
    )
    for name in ("j1", "j2", "j3"):
        np.testing.assert_allclose(loaded.torsor(name), plain.torsor(name), atol=1e-12 * 5e-5)
    expected = sum(clearances) * in_plane / np.linalg.norm(in_plane)
    np.testing.assert_allclose(loaded.frame_displacement("tip")[0], expected, atol=1e-12 * 1e-4)


# -- a journal tilted by a torque ---------------------------------------------------------------------
@pytest.mark.parametrize(
    ("torque", "expected_beta_gamma"),
    [((0.0, 1.0, 0.0), (1.0, 0.0)), ((0.0, 0.0, -3.0), (0.0, -1.0)), ((0.0, 3.0, 4.0), (0.6, 0.8))],
)
def test_journal_under_transverse_torque_tilts_by_J_over_L(torque, expected_beta_gamma):
    """A cylindrical joint (length L, diametral clearance J) under a pure transverse torque C tilts
    by J/L = 2c/L about C; the slide u and spin alpha (free, unloaded) stay 0, as do v, w."""
    J, L = 2e-4, 0.04
    text = one_joint_urdf(f'type="cylindrical" diametral_clearance="{J!r}" length="{L!r}"')
    result = cp.loads(text).solve(loads=[cp.Torque("part", torque)])
    expected = np.concatenate([np.zeros(4), (J / L) * np.array(expected_beta_gamma)])
    np.testing.assert_allclose(result.torsor("K"), expected, atol=RTOL * J / L)
    assert result.ok and result.status == "optimal"
    assert any("'K' u" in m for m in result.free_motions)
    assert any("'K' alpha" in m for m in result.free_motions)
    assert {c.point for c in result.active_contacts} == {"end-", "end+"}


@pytest.mark.parametrize("seed", [0, 1])
def test_journal_anywhere_tilts_by_J_over_L_about_the_torque(seed):
    """The same journal placed and oriented at random (origin, rpy, clearance axis), torque
    perpendicular to its axis: the part rotates by (J/L) C/|C| in world axes and the journal's
    centre does not move."""
    rng = np.random.default_rng(seed)
    J, L = float(10 ** rng.uniform(-5, -3)), float(rng.uniform(0.01, 0.1))
    axis_local = rng.standard_normal(3)
    xyz, rpy = rng.uniform(-1, 1, 3), rng.uniform(-np.pi, np.pi, 3)
    text = one_joint_urdf(
        f'type="cylindrical" diametral_clearance="{J!r}" length="{L!r}" axis="{_xyz(axis_local)}"',
        xyz=xyz,
        rpy=rpy,
    )
    axis = pin.rpy.rpyToMatrix(*rpy) @ axis_local
    axis /= np.linalg.norm(axis)
    torque = rng.standard_normal(3)
    torque -= (torque @ axis) * axis
    result = cp.loads(text).solve(loads=[cp.Torque("part", torque)])
    translation, rotation = result.frame_displacement("part")
    np.testing.assert_allclose(
        rotation, (J / L) * torque / np.linalg.norm(torque), atol=1e-12 * J / L
    )
    np.testing.assert_allclose(translation, 0.0, atol=1e-12 * J)
    assert np.linalg.norm(result.torsor("K")[4:]) == pytest.approx(J / L, rel=1e-12)


# -- a shaft on two equal spheres ----------------------------------------------------------------------
def test_two_spheres_translate_by_c_along_the_force():
    """Case 6.2.2 (two spherical joints, J = 0.3 mm, F = (1, 1, 1) N at the middle): both joints
    translate by c F/|F| (c = J/2), no rotation: T1 = T2 = (0.0866..., 0.0866..., 0.0866...) mm."""
    case = CASES["6.2.2"]
    c = case["joint"][0]["diametral_clearance_m"] / 2
    force = np.array(case["load"]["force_N"])
    result = build_case(case).solve()
    expected = np.concatenate([c * force / np.linalg.norm(force), np.zeros(3)])
    for name in ("I1", "I2"):
        np.testing.assert_allclose(result.torsor(name), expected, atol=RTOL * c)
    assert {c.label for c in result.active_contacts} == {"I1:ball", "I2:ball"}


@pytest.mark.parametrize("seed", range(4))
def test_two_spheres_any_force_at_the_middle(seed):
    """Two equal spherical joints, any force at the midpoint of their centres: U_B is the mean of
    the two ball displacements, so |U_B| <= c and the unique optimum is V1 = V2 = c F/|F|; the
    spin about the line of centres is unloaded and left at 0."""
    rng = np.random.default_rng(100 + seed)
    case = CASES["6.2.2"]
    force = rng.standard_normal(3) * 10
    text = case_text(case, load=(case["load"]["point_m"], force, (0.0, 0.0, 0.0)))
    result = cp.loads(text).solve()
    c = case["joint"][0]["diametral_clearance_m"] / 2
    expected = np.concatenate([c * force / np.linalg.norm(force), np.zeros(3)])
    for name in ("I1", "I2"):
        np.testing.assert_allclose(result.torsor(name), expected, atol=1e-11 * c)
    rotation = result.frame_displacement("shaft")[1]
    np.testing.assert_allclose(rotation, 0.0, atol=1e-11 * c)


def test_random_rotation_helper_is_a_rotation():
    """The test helper draws proper rotations (R^T R = I, det R = 1)."""
    R = random_rotation(np.random.default_rng(0))
    np.testing.assert_allclose(R.T @ R, np.eye(3), atol=1e-14)
    assert np.linalg.det(R) == pytest.approx(1.0)
