"""Spatial loops through ball joints (issue 10, finding 2) and misaligned housings (finding 6).

Models (tests/data/README.md): an RSSR four-bar, a Delta-like platform (three arms, parallelogram
rods with twelve ball joints) and a 6-UPS Stewart platform, each with play in every joint and a
load on its output.

Independent checks (no code shared with clearance_pin.kinematics):
- the closed configurations against plain numpy geometry: the RSSR rocker angle from the closed
  form of the circle-sphere intersection, the Delta platform from a trilateration of its three
  rod spheres, the Stewart platform pose from leg lengths computed by inverse kinematics;
- the equilibria by per-body statics written here: every body's loads, the reported contact
  forces at their points (placed from the model's clearance frames) and the drive efforts
  (fitted: one scalar per driven joint) balance to round-off.
Self-consistency checks (the model against itself): sensitivities against finite differences
of re-closed perturbed models; the batched closure against the per-point closure; the same
closed configuration whatever path leads there (idle spins held).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import clearance_pin
from clearance_pin import PointForce, Torque
from clearance_pin.errors import ModelError
from clearance_pin.tolerance.batch_closure import BatchClosure
from clearance_pin.tolerance.dimensions import with_deviations
from clearance_pin.tolerance.sensitivity import output_deviations, sensitivities
from clearance_pin.tolerance.sweep import sweep

DATA = Path(__file__).resolve().parent / "data"

# design numbers of the models (SI), as written in tests/data/README.md
RSSR_CRANK, RSSR_ROCKER = 0.04, 0.07
RSSR_PIVOT = np.array([0.12, 0.0, 0.03])  # rocker pivot, axis y
RSSR_THETA0, RSSR_PHI0 = math.radians(60.0), math.radians(-120.0)
DELTA = {"base": 0.10, "platform": 0.03, "arm": 0.10, "rod": 0.25, "half_width": 0.02}
STEWART = {"base": 0.15, "platform": 0.08, "height": 0.20}


@pytest.fixture(scope="module")
def rssr():
    return clearance_pin.load(DATA / "rssr.urdf")


@pytest.fixture(scope="module")
def delta():
    return clearance_pin.load(DATA / "delta_3rss.urdf")


@pytest.fixture(scope="module")
def stewart():
    return clearance_pin.load(DATA / "stewart_6ups.urdf")


def position(mechanism, configuration, frame: str) -> np.ndarray:
    return configuration.oMf[mechanism.model.getFrameId(frame)].translation


# -- RSSR ------------------------------------------------------------------------------------
def rssr_ball_1(theta: float) -> np.ndarray:
    return RSSR_CRANK * np.array([math.cos(theta), math.sin(theta), 0.0])


def rssr_ball_2(phi: float) -> np.ndarray:
    # rotation by phi about y of the rocker arm (c, 0, 0)
    return RSSR_PIVOT + RSSR_ROCKER * np.array([math.cos(phi), 0.0, -math.sin(phi)])


RSSR_COUPLER = float(np.linalg.norm(rssr_ball_2(RSSR_PHI0) - rssr_ball_1(RSSR_THETA0)))


def rssr_rocker_roots(theta: float) -> list[float]:
    """Closed form: |S1(theta) - S2(phi)| = b gives A cos(phi) + B sin(phi) = C, two roots
    phi = atan2(B, A) +/- acos(C / hypot(A, B)) (the two assembly branches)."""
    d = rssr_ball_1(theta) - RSSR_PIVOT
    a, b = d[0], -d[2]
    c = (d @ d + RSSR_ROCKER**2 - RSSR_COUPLER**2) / (2.0 * RSSR_ROCKER)
    return [math.atan2(b, a) + s * math.acos(c / math.hypot(a, b)) for s in (1.0, -1.0)]


def wrap(angle: float) -> float:
    return (angle + math.pi) % (2 * math.pi) - math.pi


# the nominal branch: the root through phi0 (|C| < hypot(A, B) all around the cycle, so the
# branches never meet and the sign is the same at every crank angle)
RSSR_BRANCH = int(np.argmin([abs(wrap(r - RSSR_PHI0)) for r in rssr_rocker_roots(RSSR_THETA0)]))


def rssr_rocker_angle(theta: float) -> float:
    return rssr_rocker_roots(theta)[RSSR_BRANCH]


def rssr_at(mechanism, theta: float) -> np.ndarray:
    q = mechanism.q_nominal.copy()
    q[mechanism.model.joints[mechanism.model.getJointId("crank_pivot")].idx_q] = theta
    return q


def test_rssr_nominal_branch_is_the_minus_root():
    assert abs(wrap(rssr_rocker_angle(RSSR_THETA0) - RSSR_PHI0)) < 1e-12


@pytest.mark.parametrize("degrees", [60.5, 0.0, 150.0, 240.0, -100.0])
def test_rssr_closes_away_from_its_file_pose(rssr, degrees):
    """The rocker angle equals the closed form, and the two balls sit at the coupler length."""
    theta = math.radians(degrees)
    configuration = rssr.configure(rssr_at(rssr, theta))
    model = rssr.model
    phi = configuration.q[model.joints[model.getJointId("rocker_pivot")].idx_q]
    assert abs(wrap(phi - rssr_rocker_angle(theta))) < 1e-12
    s1 = position(rssr, configuration, "coupler")
    s2 = position(rssr, configuration, "coupler_S2")
    np.testing.assert_allclose(s1, rssr_ball_1(theta), atol=1e-15)
    np.testing.assert_allclose(s2, rssr_ball_2(phi), atol=1e-14)
    np.testing.assert_allclose(s2, position(rssr, configuration, "rocker_S2"), atol=1e-14)
    assert abs(np.linalg.norm(s2 - s1) - RSSR_COUPLER) < 1e-14


def test_rssr_idle_spin_does_not_drift(rssr):
    """The coupler spins freely about its two ball centres: the closed configuration at a crank
    angle is the same whether reached directly or after a detour of a full turn and back."""
    direct = clearance_pin.load(DATA / "rssr.urdf").configure(rssr_at(rssr, 1.7)).q
    walker = clearance_pin.load(DATA / "rssr.urdf")
    for theta in np.linspace(RSSR_THETA0, RSSR_THETA0 + 2 * math.pi, 9)[1:]:
        walker.configure(rssr_at(walker, theta - 2 * math.pi))
    walked = walker.configure(rssr_at(walker, 1.7)).q
    np.testing.assert_allclose(walked, direct, atol=1e-12)


# -- Delta -----------------------------------------------------------------------------------
def delta_leg(i: int):
    psi = 2 * math.pi * i / 3
    radial = np.array([math.cos(psi), math.sin(psi), 0.0])
    tangent = np.array([-math.sin(psi), math.cos(psi), 0.0])
    return radial, tangent


def delta_elbow(i: int, theta: float) -> np.ndarray:
    radial, _ = delta_leg(i)
    return DELTA["base"] * radial + DELTA["arm"] * (
        math.cos(theta) * radial - math.sin(theta) * np.array([0.0, 0.0, 1.0])
    )


def delta_platform(thetas) -> np.ndarray:
    """Trilateration: the centre p lies at the rod length from each E_i - r_p e_i (the lower of
    the two intersection points of the three spheres)."""
    centres = [
        delta_elbow(i, t) - DELTA["platform"] * delta_leg(i)[0] for i, t in enumerate(thetas)
    ]
    c1, c2, c3 = centres
    ex = (c2 - c1) / np.linalg.norm(c2 - c1)
    i_ = ex @ (c3 - c1)
    ey = c3 - c1 - i_ * ex
    ey /= np.linalg.norm(ey)
    ez = np.cross(ex, ey)
    d, j_ = np.linalg.norm(c2 - c1), ey @ (c3 - c1)
    r = DELTA["rod"]
    x = d / 2
    y = (i_**2 + j_**2 - 2 * i_ * x) / (2 * j_)
    z = math.sqrt(r * r - x * x - y * y)
    candidates = [c1 + x * ex + y * ey + s * z * ez for s in (1.0, -1.0)]
    return min(candidates, key=lambda p: p[2])


def delta_trajectory(mechanism, count: int) -> list[np.ndarray]:
    model = mechanism.model
    indices = [model.joints[model.getJointId(f"arm{i + 1}_pivot")].idx_q for i in range(3)]
    nominal = mechanism.q_nominal[indices]
    path = []
    for t in np.linspace(0.0, 2 * math.pi, count):
        q = mechanism.q_nominal.copy()
        q[indices] = nominal + 0.25 * np.sin(t + 2 * math.pi * np.arange(3) / 3)
        path.append(q)
    return path


def test_delta_follows_a_trajectory(delta):
    """Along a trajectory of the three arms, the platform centre is the trilateration of its rod
    spheres, every rod keeps its length and the platform does not turn (parallelograms)."""
    model = delta.model
    nominal = delta.configure()
    rotation0 = nominal.oMf[model.getFrameId("platform")].rotation
    centre_in_platform = np.array(delta.loads[0].point)
    for q in delta_trajectory(delta, 13):
        configuration = delta.configure(q)
        thetas = [
            configuration.q[model.joints[model.getJointId(f"arm{i + 1}_pivot")].idx_q]
            for i in range(3)
        ]
        placement = configuration.oMf[model.getFrameId("platform")]
        np.testing.assert_allclose(
            placement.act(centre_in_platform), delta_platform(thetas), atol=1e-13
        )
        np.testing.assert_allclose(placement.rotation, rotation0, atol=1e-13)
        for i in range(3):
            for side in "ab":
                elbow = position(delta, configuration, f"rod{i + 1}{side}")
                end = position(delta, configuration, f"rod{i + 1}{side}_end")
                assert abs(np.linalg.norm(end - elbow) - DELTA["rod"]) < 1e-13


# -- Stewart ---------------------------------------------------------------------------------
def stewart_points():
    """Base and platform joint centres (platform frame at its centre, world axes)."""
    base, platform = [], []
    for k in range(3):
        for s in (-1, 1):
            a, b = math.radians(120 * k + 15 * s), math.radians(120 * k + 45 * s)
            base.append(STEWART["base"] * np.array([math.cos(a), math.sin(a), 0.0]))
            platform.append(STEWART["platform"] * np.array([math.cos(b), math.sin(b), 0.0]))
    return base, platform


def stewart_pose(t: float):
    p = np.array([0.01 * math.sin(t), 0.012 * (math.cos(t) - 1), 0.2 + 0.008 * math.sin(2 * t)])
    rotation = pin.exp3(np.array([0.03 * math.sin(2 * t), -0.02 * math.sin(t), 0.05 * math.sin(t)]))
    return p, rotation


def test_stewart_reaches_the_inverse_kinematics_pose(stewart):
    """Leg lengths from a numpy inverse kinematics of a platform path: the closed configuration
    puts the platform at that pose."""
    model = stewart.model
    base, platform = stewart_points()
    legs = [model.joints[model.getJointId(f"leg{k + 1}")].idx_q for k in range(6)]
    frame = model.getFrameId("platform")
    to_centre = stewart.q_nominal  # the platform frame sits at ball 1
    offset = platform[0]
    for t in np.linspace(0.0, 2 * math.pi, 9):
        p, rotation = stewart_pose(t)
        q = to_centre.copy()
        q[legs] = [np.linalg.norm(p + rotation @ platform[k] - base[k]) for k in range(6)]
        placement = stewart.configure(q).oMf[frame]
        np.testing.assert_allclose(placement.rotation, rotation, atol=1e-12)
        np.testing.assert_allclose(placement.translation, p + rotation @ offset, atol=1e-13)


# -- equilibria: per-body statics written here --------------------------------------------------
def clearance_frame(mechanism, configuration, name: str) -> pin.SE3:
    joint = mechanism.joint(name)
    if hasattr(joint, "joint_id"):
        return configuration.oMi[joint.joint_id] * pin.SE3(joint.rotation, np.zeros(3))
    return configuration.oMf[joint.frame_a] * pin.SE3(joint.rotation, np.zeros(3))


def bodies_of(mechanism, name: str) -> tuple[int, int]:
    """(parent body, child body) of a joint: Pinocchio joint ids."""
    model, joint = mechanism.model, mechanism.joint(name)
    if hasattr(joint, "joint_id"):
        return int(model.parents[joint.joint_id]), joint.joint_id
    return model.frames[joint.frame_a].parentJoint, model.frames[joint.frame_b].parentJoint


def wrench(force: np.ndarray, point: np.ndarray) -> np.ndarray:
    return np.concatenate([force, np.cross(point, force)])


def statics_residual(mechanism, equilibrium) -> float:
    """Largest per-body imbalance over the load scale, drive efforts fitted by least squares."""
    model, configuration = mechanism.model, equilibrium.configuration
    known = np.zeros((model.njoints, 6))
    scale = 0.0
    for load in mechanism.loads:
        frame = model.getFrameId(load.link)
        body = model.frames[frame].parentJoint
        if isinstance(load, PointForce):
            point = configuration.oMf[frame].act(np.asarray(load.point, float))
            known[body] += wrench(np.asarray(load.force, float), point)
            scale = max(scale, float(np.linalg.norm(load.force)))
        elif isinstance(load, Torque):
            known[body, 3:] += np.asarray(load.torque, float)
    for contact in equilibrium.contacts:
        oMc = clearance_frame(mechanism, configuration, contact.joint)
        joint = mechanism.joint(contact.joint)
        local = next(c.point for c in joint.clearance.contacts if c.name == contact.point)
        w = wrench(oMc.rotation @ contact.force, oMc.act(np.asarray(local)))
        parent, child = bodies_of(mechanism, contact.joint)
        known[child] += w
        known[parent] -= w
    drives = []
    for joint in mechanism.tree_joints:
        if not joint.driven:
            continue
        oMc = clearance_frame(mechanism, configuration, joint.name)
        axis = oMc.rotation[:, 0]
        column = np.zeros((model.njoints, 6))
        w = (
            np.concatenate([np.zeros(3), axis])
            if joint.motion_component == 3
            else wrench(axis, oMc.translation)
        )
        parent, child = bodies_of(mechanism, joint.name)
        column[child] += w
        column[parent] -= w
        drives.append(column[1:].reshape(-1))
    b = known[1:].reshape(-1)
    if drives:
        a = np.column_stack(drives)
        b = b + a @ np.linalg.lstsq(a, -b, rcond=None)[0]
    return float(np.max(np.abs(b)) / max(scale, 1.0))


@pytest.mark.parametrize("name", ["rssr", "delta", "stewart"])
def test_trajectory_equilibria_balance_every_body(name, rssr, delta, stewart):
    """solve_many over a trajectory: every point verified, and per-body statics hold."""
    mechanism = {"rssr": rssr, "delta": delta, "stewart": stewart}[name]
    if name == "rssr":
        path = [rssr_at(rssr, t) for t in RSSR_THETA0 + np.linspace(-math.pi, math.pi, 13)]
    elif name == "delta":
        path = delta_trajectory(delta, 9)
    else:
        model = stewart.model
        base, platform = stewart_points()
        legs = [model.joints[model.getJointId(f"leg{k + 1}")].idx_q for k in range(6)]
        path = []
        for t in np.linspace(0.0, 2 * math.pi, 9):
            p, rotation = stewart_pose(t)
            q = stewart.q_nominal.copy()
            q[legs] = [np.linalg.norm(p + rotation @ platform[k] - base[k]) for k in range(6)]
            path.append(q)
    batch = mechanism.solve_many(configurations=path)
    assert all(e.ok for e in batch)
    for equilibrium in list(batch)[::4]:
        assert statics_residual(mechanism, equilibrium) < 1e-10
        assert equilibrium.active_contacts


def test_exact_model_solves_away_from_the_file_pose(rssr):
    exact = rssr.solve(q=rssr_at(rssr, math.radians(200.0)), exact=True)
    assert exact.ok and exact.formulation == "exact"


# -- tolerance propagation --------------------------------------------------------------------
@pytest.mark.parametrize(
    "name, outputs",
    [
        ("rssr", ["rocker_pivot", "rocker_S2.z"]),
        ("delta", ["platform.x", "platform.z"]),
        ("stewart", ["platform.x", "platform.rz"]),
    ],
)
def test_sensitivities_and_batch_closure_match_reclosed_models(name, outputs, rssr, delta, stewart):
    """Self-consistency: S matches central differences of re-closed perturbed models (1e-6
    relative), and the batched exact closure matches the per-point closure (1e-14)."""
    mechanism = {"rssr": rssr, "delta": delta, "stewart": stewart}[name]
    q = mechanism.configure().q
    linear = sensitivities(mechanism, outputs, q)
    n, h = len(mechanism.dimensions), 1e-6

    def deviation(dd):
        moved = with_deviations(mechanism, dd)
        return output_deviations(
            mechanism.model, q, moved.model, moved.configure(q).q, linear.outputs
        )

    columns = [
        (deviation(h * np.eye(n)[k]) - deviation(-h * np.eye(n)[k])) / (2 * h) for k in range(n)
    ]
    np.testing.assert_allclose(
        linear.matrix, np.array(columns).T, atol=1e-6 * np.abs(linear.matrix).max()
    )
    closure = BatchClosure(mechanism, outputs, q, linear=linear)
    samples = np.random.default_rng(3).uniform(-1e-3, 1e-3, (3, n))
    batch = closure.solve(samples)
    for k, dd in enumerate(samples):
        np.testing.assert_allclose(batch[k], deviation(dd), atol=1e-14)


def test_rssr_tolerance_sweep_with_monte_carlo(rssr):
    result = sweep(rssr, ["rocker_pivot"], positions=7, samples=64)
    assert result.worst.shape == (7, 1) and np.all(result.worst > 0)
    for run, band in zip(result.uniform, result.worst[:, 0]):
        # exact deviations of uniform samples stay inside the first-order worst case, up to the
        # second order (tolerances of 1e-4 on lengths of 4e-2: 1 % is ample)
        assert max(abs(run.minimum[0]), abs(run.maximum[0])) <= band * 1.01
        assert run.samples == 64


def test_output_on_a_freely_spinning_coupler_is_refused(rssr):
    with pytest.raises(clearance_pin.ClearancePinError, match="idle motion"):
        sensitivities(rssr, ["coupler_S2.rx"])


# -- misaligned housing (finding 6, closure side) ----------------------------------------------
SHAFT = """<?xml version="1.0"?>
<robot name="three_bearings">
  <link name="ground"/>
  <link name="shaft"/>
  <link name="housing_2"/><link name="journal_2"/><link name="housing_3"/><link name="journal_3"/>
  <joint name="bearing_1" type="revolute"><parent link="ground"/><child link="shaft"/>
    <axis xyz="1 0 0"/><limit lower="-7" upper="7" effort="1" velocity="1"/></joint>
  <joint name="housing_2_mount" type="fixed"><parent link="ground"/><child link="housing_2"/>
    <origin xyz="0.2 OFFSET 0"/></joint>
  <joint name="journal_2_mount" type="fixed"><parent link="shaft"/><child link="journal_2"/>
    <origin xyz="0.2 0 0"/></joint>
  <joint name="housing_3_mount" type="fixed"><parent link="ground"/><child link="housing_3"/>
    <origin xyz="0.4 0 0"/></joint>
  <joint name="journal_3_mount" type="fixed"><parent link="shaft"/><child link="journal_3"/>
    <origin xyz="0.4 0 0"/></joint>
  <clearance_pin>
    <joint name="bearing_1" type="revolute" radial_clearance="3e-05" length="0.03" axial_clearance="1e-05"/>
    <loop_joint name="bearing_2" type="cylindrical" frame_a="housing_2" frame_b="journal_2"
                radial_clearance="3e-05" length="0.03"/>
    <loop_joint name="bearing_3" type="cylindrical" frame_a="housing_3" frame_b="journal_3"
                radial_clearance="3e-05" length="0.03"/>
    <force link="shaft" point="0.3 0 0" value="0 -50 -20"/>
    <torque link="shaft" value="0 0 0"/>
  </clearance_pin>
</robot>
"""


def test_housing_offset_inside_the_play_is_accepted_once(monkeypatch):
    """A middle housing 20 um off inside its 30 um play loads; configure does not re-close the
    eccentric loops on every call."""
    mechanism = clearance_pin.loads(SHAFT.replace("OFFSET", "2e-05"), source="three_bearings")
    from clearance_pin.kinematics import closure

    calls = []
    original = closure.close_loops
    monkeypatch.setattr(
        closure, "close_loops", lambda *a, **k: calls.append(1) or original(*a, **k)
    )
    for _ in range(3):
        mechanism.configure()
        mechanism.configure(mechanism.q_nominal.copy())
    assert not calls


def test_housing_offset_beyond_the_play_is_refused():
    with pytest.raises(ModelError, match="bearing_2"):
        clearance_pin.loads(SHAFT.replace("OFFSET", "4e-05"), source="three_bearings")


def test_a_loop_that_cannot_close_keeps_its_error(rssr):
    """A crank 30 mm longer cannot reach the rocker at every angle: refused, loop named."""
    text = (DATA / "rssr.urdf").read_text().replace('origin xyz="0.04 0 0"', 'origin xyz="0.2 0 0"')
    with pytest.raises(ModelError, match="S2"):
        clearance_pin.loads(text, source="long_crank").configure()
