"""Moving spatial loops (issue 10, finding 2), checked by computations of their own.

Three mechanisms whose loops pass through ball joints (URDF floating joints carrying a
``spherical`` clearance), written for these checks by tests/data/make_spatial_loops.py from the
design numbers it holds (tests/data/README.md): an RSSR spatial four-bar, a Delta-like
3-R(SS)2 platform and a 6-UPS Stewart platform. They must close, solve and propagate
tolerances over whole motions, not only at the file pose.

Independent references (no clearance_pin code is used to compute them):

- the RSSR rocker angle in closed form (a circle-sphere intersection,
  ``make_spatial_loops.rssr_rocker_angle``) and the ball centres from a forward kinematics
  written here in numpy from the design numbers;
- the Delta and Stewart targets from their inverse kinematics (numpy), the ball centres placed by
  Pinocchio's forward kinematics of the URDF frames, then plain distances (rod lengths, leg
  lengths, the platform's rigid shape);
- the Stewart platform's forward kinematics solved here (Newton on the six leg lengths);
- per-body statics from the reported contact forces (every moving body: loads + contact forces +
  drive reactions = 0), written here from the model-file conventions.

What compares the library with itself: none of the assertions below; the library's own
residuals (``ok``) are only required to be true as well.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import math
import re
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import clearance_pin as cp
from clearance_pin import PointForce, Torque
from clearance_pin.model.clearance import ALPHA, U

DATA = Path(__file__).resolve().parent / "data"


def _design():
    spec = importlib.util.spec_from_file_location(
        "make_spatial_loops", DATA / "make_spatial_loops.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


design = _design()


@pytest.fixture(scope="module")
def rssr():
    return cp.load(DATA / "spatial_rssr.urdf")


@pytest.fixture(scope="module")
def delta():
    return cp.load(DATA / "spatial_delta.urdf")


@pytest.fixture(scope="module")
def stewart():
    return cp.load(DATA / "spatial_stewart.urdf")


def q_index(mechanism, joint: str) -> int:
    model = mechanism.model
    return model.joints[model.getJointId(joint)].idx_q


def with_values(mechanism, values: dict) -> np.ndarray:
    q = mechanism.q_nominal.copy()
    for joint, value in values.items():
        q[q_index(mechanism, joint)] = value
    return q


def wrapped(angle):
    return (np.asarray(angle) + math.pi) % (2.0 * math.pi) - math.pi


def quaternion_rotation(xyzw) -> np.ndarray:
    """Rotation matrix of a unit quaternion (x, y, z, w) (Pinocchio's order), plain numpy."""
    x, y, z, w = np.asarray(xyzw) / np.linalg.norm(xyzw)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def frame_positions(mechanism, q, names) -> dict[str, np.ndarray]:
    model = mechanism.model
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    return {n: data.oMf[model.getFrameId(n)].translation.copy() for n in names}


def frame_placement(mechanism, q, name) -> pin.SE3:
    model = mechanism.model
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    return data.oMf[model.getFrameId(name)].copy()


# -- RSSR ------------------------------------------------------------------------------------
def rssr_ball_centres(mechanism, q) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(A, coupler's B, rocker's B) [m] from q by a numpy forward kinematics of the design:
    crank Rz(theta) about O, coupler = crank frame at A times the floating joint's (p, quat),
    rocker Rx(psi) about D."""
    a, c = design.RSSR["crank"], design.RSSR["rocker"]
    d = np.asarray(design.RSSR["pivot"])
    theta = q[q_index(mechanism, "crank_pivot")]
    psi = q[q_index(mechanism, "rocker_pivot")]
    free = q[q_index(mechanism, "ball_A") : q_index(mechanism, "ball_A") + 7]
    crank = design.rot_z(theta)
    ball_a = crank @ np.array([a, 0.0, 0.0])
    coupler_origin = ball_a + crank @ free[:3]
    coupler_rotation = crank @ quaternion_rotation(free[3:])
    psi0 = design.rssr_rocker_angle(0.0)
    offset = d + c * np.array([0.0, np.cos(psi0), np.sin(psi0)]) - np.array([a, 0.0, 0.0])
    coupler_b = coupler_origin + coupler_rotation @ offset
    rocker_b = d + design.rot_x(psi) @ np.array([0.0, c, 0.0])
    return ball_a, coupler_b, rocker_b


CRANK_ANGLES = [math.radians(a) for a in (0.5, 15.0, 60.0, 120.0, 181.0, 240.0, 300.0, 359.0)]


@pytest.mark.parametrize("theta", CRANK_ANGLES, ids=lambda t: f"{math.degrees(t):.1f}deg")
def test_rssr_closes_at_any_crank_angle(rssr, theta):
    """configure(q) closes the RSSR away from its file pose (it failed 0.5 deg away): the rocker
    angle is the closed form's, on the file's branch (1e-11 rad); the two ball centres meet
    (1e-13 m), the coupler keeps its length (1e-13 m) and the ball joint's translations, bounded
    by play, are not used to close the loop (they stay 0)."""
    q = rssr.configure(with_values(rssr, {"crank_pivot": theta})).q
    psi = q[q_index(rssr, "rocker_pivot")]
    assert abs(wrapped(psi - design.rssr_rocker_angle(theta))) < 1e-11
    ball_a, coupler_b, rocker_b = rssr_ball_centres(rssr, q)
    assert np.linalg.norm(coupler_b - rocker_b) < 1e-13
    assert abs(np.linalg.norm(coupler_b - ball_a) - design.RSSR["coupler"]) < 1e-13
    start = q_index(rssr, "ball_A")
    assert np.all(q[start : start + 3] == 0.0)


def test_rssr_solves_off_its_file_pose(rssr):
    """The issue's reproduction: solve(q) 0.5 deg from the nominal crank angle returns a verified
    equilibrium whose contact forces balance the loads body by body."""
    q = with_values(rssr, {"crank_pivot": math.radians(0.5)})
    equilibrium = rssr.solve(q=q)
    assert equilibrium.ok
    assert body_statics_residual(equilibrium) < 1e-10


def test_rssr_idle_spin_does_not_drift(rssr):
    """The coupler spins freely about the line through its balls (an idle motion). Walking the
    crank round and back by two different paths gives the same configurations (1e-12), and a full
    turn returns to the file pose: the idle spin is fixed by the configuration, not the path."""
    angles = np.linspace(0.0, 2.0 * math.pi, 25)
    forward = [rssr.configure(with_values(rssr, {"crank_pivot": t})).q for t in angles]
    backward = [rssr.configure(with_values(rssr, {"crank_pivot": t})).q for t in angles[::-1]]
    jumped = [rssr.configure(with_values(rssr, {"crank_pivot": t})).q for t in angles[::6]]
    for q1, q2 in zip(forward, backward[::-1]):
        assert np.max(np.abs(q1 - q2)) < 1e-12
    for q1, q2 in zip(forward[::6], jumped):
        assert np.max(np.abs(q1 - q2)) < 1e-12
    turned = forward[-1].copy()
    turned[q_index(rssr, "crank_pivot")] = 0.0
    assert np.max(np.abs(turned - rssr.q_nominal)) < 1e-12


def test_rssr_trajectory_solves(rssr):
    """solve_many over a full crank revolution (every 15 deg): every point verified, its
    configuration the closed form's, its statics balanced body by body."""
    angles = np.radians(np.arange(0.0, 360.0, 15.0))
    batch = rssr.solve_many(configurations=[with_values(rssr, {"crank_pivot": t}) for t in angles])
    assert len(batch) == len(angles)
    for theta, equilibrium in zip(angles, batch):
        assert equilibrium.ok
        q = equilibrium.configuration.q
        assert (
            abs(wrapped(q[q_index(rssr, "rocker_pivot")] - design.rssr_rocker_angle(theta))) < 1e-11
        )
        assert body_statics_residual(equilibrium) < 1e-10


# -- Delta -------------------------------------------------------------------------------------
def delta_path(points: int = 13):
    """Platform centres on a tilted circle around the nominal one (inverse kinematics targets)."""
    t = np.linspace(0.0, 2.0 * math.pi, points)
    return np.column_stack(
        [0.04 * np.cos(t), 0.04 * np.sin(t), -design.DELTA["height"] - 0.02 * np.sin(2 * t)]
    )


def check_delta_geometry(mechanism, q, centre):
    """The closed Delta, from Pinocchio's placement of the URDF frames and plain distances:
    rod tops where the arm's own forward kinematics puts them, every rod of its design length,
    rod ends on the platform points, the platform parallel to the base at the IK target."""
    dsn = design.DELTA
    angles = design.delta_arm_angles(centre)
    for k, ((p_i, r, t, phi), theta) in enumerate(zip(design.delta_frames(), angles)):
        assert abs(wrapped(q[q_index(mechanism, f"shoulder_{k}")] - theta)) < 1e-12
        elbow = p_i + design.rot_z(phi) @ design.rot_y(theta) @ np.array([dsn["arm"], 0.0, 0.0])
        for side, sign in (("a", 1.0), ("b", -1.0)):
            names = [f"rod_{k}{side}", f"rod_{k}{side}_end"]
            if (k, side) != (0, "a"):
                names.append(f"platform_{k}{side}")
            at = frame_positions(mechanism, q, names)
            top = elbow + sign * 0.5 * dsn["rod_spacing"] * t
            bottom = centre + dsn["platform_radius"] * r + sign * 0.5 * dsn["rod_spacing"] * t
            assert np.linalg.norm(at[names[0]] - top) < 1e-13
            assert abs(np.linalg.norm(at[names[1]] - at[names[0]]) - dsn["rod"]) < 1e-13
            assert np.linalg.norm(at[names[1]] - bottom) < 1e-12
            if len(names) == 3:
                assert np.linalg.norm(at[names[2]] - at[names[1]]) < 1e-13
    tool = frame_placement(mechanism, q, "tool")
    assert np.linalg.norm(tool.translation - centre) < 1e-12
    assert np.max(np.abs(tool.rotation - np.eye(3))) < 1e-12


def test_delta_trajectory_solves(delta):
    """The Delta follows a platform path given by its inverse kinematics (13 points, the driven
    shoulders set, everything else from the file pose): closed as the geometry says, every
    equilibrium verified and balanced body by body."""
    path = delta_path()
    configurations = [
        with_values(
            delta, dict(zip(("shoulder_0", "shoulder_1", "shoulder_2"), design.delta_arm_angles(c)))
        )
        for c in path
    ]
    batch = delta.solve_many(configurations=configurations)
    for centre, equilibrium in zip(path, batch):
        assert equilibrium.ok
        check_delta_geometry(delta, equilibrium.configuration.q, centre)
        assert body_statics_residual(equilibrium) < 1e-10


# -- Stewart -----------------------------------------------------------------------------------
def stewart_pose(t: float) -> tuple[np.ndarray, np.ndarray]:
    """A platform pose on a path around the nominal one: (centre [m], rotation)."""
    centre = np.array(
        [0.03 * np.cos(t), 0.03 * np.sin(t), design.STEWART["height"] + 0.02 * np.sin(t)]
    )
    rotation = pin.rpy.rpyToMatrix(0.1 * np.sin(t), 0.1 * np.cos(t) - 0.1, 0.15 * np.sin(2 * t))
    return centre, rotation


def stewart_leg_lengths(centre, rotation, base=None, top=None) -> np.ndarray:
    """Inverse kinematics: |p + R P_i - B_i| [m]."""
    b0, t0 = design.stewart_points()
    base = b0 if base is None else base
    top = t0 if top is None else top
    return np.array([np.linalg.norm(centre + rotation @ p - b) for b, p in zip(base, top)])


def stewart_forward(lengths, base, top, centre, rotation, iterations: int = 30):
    """Forward kinematics by Newton on the leg lengths, from a nearby pose: the pose update is
    (dp, dphi) with R <- exp(dphi) R; dL_i = u_i . dp + (R P_i x u_i) . dphi."""
    centre, rotation = np.array(centre, float), np.array(rotation, float)
    for _ in range(iterations):
        legs = [centre + rotation @ p - b for b, p in zip(base, top)]
        units = [leg / np.linalg.norm(leg) for leg in legs]
        residual = np.array([np.linalg.norm(leg) for leg in legs]) - lengths
        jacobian = np.array(
            [np.concatenate([u, np.cross(rotation @ p, u)]) for u, p in zip(units, top)]
        )
        step = np.linalg.solve(jacobian, -residual)
        centre = centre + step[:3]
        rotation = pin.exp3(step[3:]) @ rotation
        if np.max(np.abs(step)) < 1e-15:
            break
    return centre, rotation


def stewart_configuration(mechanism, lengths) -> np.ndarray:
    return with_values(mechanism, {f"leg_{k}": length for k, length in enumerate(lengths)})


def test_stewart_trajectory_solves(stewart):
    """The Stewart platform follows a path of poses (its inverse kinematics gives the driven leg
    lengths): the closure finds the target pose (1e-12), every leg joins its base point to its
    platform point at the driven length, every equilibrium is verified and balanced per body."""
    base, top = design.stewart_points()
    poses = [stewart_pose(t) for t in np.linspace(0.0, 2.0 * math.pi, 13)]
    lengths = [stewart_leg_lengths(c, r) for c, r in poses]
    batch = stewart.solve_many(
        configurations=[stewart_configuration(stewart, ls) for ls in lengths]
    )
    for (centre, rotation), legs, equilibrium in zip(poses, lengths, batch):
        assert equilibrium.ok
        q = equilibrium.configuration.q
        tool = frame_placement(stewart, q, "tool")
        assert np.linalg.norm(tool.translation - centre) < 1e-12
        assert np.max(np.abs(tool.rotation - rotation)) < 1e-12
        names = [f"upper_{k}" for k in range(6)] + [f"platform_{k}" for k in range(1, 6)]
        at = frame_positions(stewart, q, names)
        for k in range(6):
            tip = at[f"upper_{k}"]
            assert abs(np.linalg.norm(tip - base[k]) - legs[k]) < 1e-13
            assert np.linalg.norm(tip - (centre + rotation @ top[k])) < 1e-12
            if k:
                assert np.linalg.norm(at[f"platform_{k}"] - tip) < 1e-13
        assert body_statics_residual(equilibrium) < 1e-10


# -- per-body statics ----------------------------------------------------------------------------
def body_statics_residual(equilibrium) -> float:
    r"""Largest per-body imbalance / largest load, for the small-displacement equilibrium.

    Every moving body b (a Pinocchio joint) balances, at the world origin,

    .. math:: \sum W_{loads} + \sum_{joints\ with\ child\ b} W_c - \sum_{with\ parent\ b} W_c
              + \sum_{drives} \lambda_d W_d = 0,

    with :math:`W = (f, p \times f)` for a contact force f [N] (the parent's on the child,
    clearance axes: world ``R_c f``) at its contact point p (the point of the clearance kind
    placed by the clearance frame: ``oMi[joint] * rotation`` for tree joints, ``oMf[frame_a] *
    rotation`` for loop joints, the model's nominal configuration). The drive reactions
    :math:`\lambda_d` (a moment about, or a force along, the driven joint's axis) are the only
    unknowns, solved by least squares; the residual is what they cannot balance.
    """
    mechanism, config = equilibrium.mechanism, equilibrium.configuration
    model = mechanism.model
    wrenches = np.zeros((model.njoints, 6))

    def add(body: int, force: np.ndarray, point: np.ndarray) -> None:
        wrenches[body, :3] += force
        wrenches[body, 3:] += np.cross(point, force)

    scale = 0.0
    for load in mechanism.loads:
        frame = model.getFrameId(load.link)
        body = model.frames[frame].parentJoint
        if isinstance(load, PointForce):
            add(body, load.force, config.oMf[frame].act(np.asarray(load.point)))
            scale = max(scale, float(np.linalg.norm(load.force)))
        elif isinstance(load, Torque):
            wrenches[body, 3:] += load.torque
            scale = max(scale, float(np.linalg.norm(load.torque)) / mechanism.length_scale())
    frames = {}
    for joint in mechanism.tree_joints:
        oMc = config.oMi[joint.joint_id] * pin.SE3(joint.rotation, np.zeros(3))
        frames[joint.name] = (oMc, int(model.parents[joint.joint_id]), joint.joint_id)
    for loop in mechanism.loop_joints:
        oMc = config.oMf[loop.frame_a] * pin.SE3(loop.rotation, np.zeros(3))
        parent = model.frames[loop.frame_a].parentJoint
        frames[loop.name] = (oMc, parent, model.frames[loop.frame_b].parentJoint)
    for contact in equilibrium.contacts:
        oMc, parent, child = frames[contact.joint]
        points = {p.name: p.point for p in mechanism.joint(contact.joint).clearance.contacts}
        force = oMc.rotation @ contact.force
        point = oMc.act(np.asarray(points[contact.point], dtype=float))
        add(child, force, point)
        add(parent, -force, point)
    columns = []
    for joint in mechanism.tree_joints:
        if not joint.driven:
            continue
        oMc, parent, child = frames[joint.name]
        axis, centre = oMc.rotation[:, 0], oMc.translation
        unit = np.zeros((model.njoints, 6))
        if joint.motion_component == U:
            unit[child, :3], unit[child, 3:] = axis, np.cross(centre, axis)
        else:
            assert joint.motion_component == ALPHA
            unit[child, 3:] = axis
        unit[parent] -= unit[child]
        columns.append(unit[1:].reshape(-1))
    rhs = -wrenches[1:].reshape(-1)
    if columns:
        matrix = np.column_stack(columns)
        reactions = np.linalg.lstsq(matrix, rhs, rcond=None)[0]
        rhs = rhs - matrix @ reactions
    return float(np.max(np.abs(rhs))) / max(scale, 1e-300)


@pytest.mark.parametrize("name", ["rssr", "delta", "stewart"])
def test_statics_per_body_at_the_file_pose(name, request):
    """At the file pose too: the contact forces balance the loads on every body."""
    mechanism = request.getfixturevalue(name)
    equilibrium = mechanism.solve()
    assert equilibrium.ok
    assert body_statics_residual(equilibrium) < 1e-10


def test_statics_check_sees_a_wrong_force(rssr):
    """The statics check can fail: a load the solver did not see (the model's loads doubled on
    the rocker) leaves an imbalance of the order of the load."""
    equilibrium = rssr.solve()
    doubled = [PointForce("rocker", [0.0, 0.0, -40.0], [0.0, 0.035, 0.0]), rssr.loads[0]]
    shadow = type(rssr).__new__(type(rssr))
    shadow.__dict__.update(rssr.__dict__)
    shadow.loads = tuple(doubled)
    assert body_statics_residual(dataclasses.replace(equilibrium, mechanism=shadow)) > 0.1


# -- tolerances --------------------------------------------------------------------------------
def rssr_angle_of(design_numbers: dict, theta: float) -> float:
    return design.rssr_rocker_angle(theta, design_numbers)


def perturbed_rssr(da=0.0, db=0.0, dc=0.0, dx=0.0) -> dict:
    numbers = dict(design.RSSR)
    numbers["crank"] += da
    numbers["coupler"] += db
    numbers["rocker"] += dc
    numbers["pivot"] = (numbers["pivot"][0] + dx, *numbers["pivot"][1:])
    return numbers


@pytest.mark.parametrize("theta", CRANK_ANGLES[::2], ids=lambda t: f"{math.degrees(t):.1f}deg")
def test_rssr_sensitivities_match_the_closed_form(rssr, theta):
    """d psi / d(a, b, c, dx) of the rocker angle equal central differences of the closed-form
    rocker angle with the perturbed design (1e-7 relative; the dimensions a, b, c, dx of the model
    file are the crank, coupler and rocker lengths and the pivot's x)."""
    from clearance_pin.tolerance.sensitivity import sensitivities

    q = rssr.configure(with_values(rssr, {"crank_pivot": theta})).q
    result = sensitivities(rssr, ["rocker_pivot"], q, closed=True)
    assert [d.name for d in result.dimensions] == ["a", "b", "c", "dx"]
    h = 1e-6
    expected = []
    for key in ("da", "db", "dc", "dx"):
        up = rssr_angle_of(perturbed_rssr(**{key: h}), theta)
        down = rssr_angle_of(perturbed_rssr(**{key: -h}), theta)
        expected.append(wrapped(up - down) / (2 * h))
    assert np.allclose(result.matrix[0], expected, rtol=1e-7, atol=1e-7)


def test_rssr_exact_monte_carlo_matches_the_closed_form(rssr):
    """The batched exact closure (Monte Carlo) for large deviations (up to 0.5 mm) gives the rocker
    angle of the closed form with the perturbed design (1e-10 rad), at two crank angles."""
    from clearance_pin.tolerance.monte_carlo import BatchClosure

    rng = np.random.default_rng(7)
    deviations = rng.uniform(-5e-4, 5e-4, size=(40, 4))
    for theta in (math.radians(35.0), math.radians(200.0)):
        q = rssr.configure(with_values(rssr, {"crank_pivot": theta})).q
        closure = BatchClosure(rssr, ["rocker_pivot"], q)
        exact = closure.solve(deviations)[:, 0]
        nominal = rssr_angle_of(design.RSSR, theta)
        expected = [
            wrapped(rssr_angle_of(perturbed_rssr(*dd), theta) - nominal) for dd in deviations
        ]
        assert np.max(np.abs(exact - np.array(expected))) < 1e-10


def test_stewart_sensitivities_match_its_forward_kinematics(stewart):
    """Sensitivities of the tool pose to a base point (x, y) and a platform point (z) equal
    central differences of the Stewart platform's forward kinematics solved here (1e-6
    relative), at a pose away from the file's."""
    from clearance_pin.tolerance.sensitivity import sensitivities

    base, top = design.stewart_points()
    centre, rotation = stewart_pose(1.0)
    lengths = stewart_leg_lengths(centre, rotation)
    q = stewart.configure(stewart_configuration(stewart, lengths)).q
    outputs = ["tool.x", "tool.y", "tool.z", "tool.rx", "tool.ry", "tool.rz"]
    result = sensitivities(stewart, outputs, q, closed=True)
    h = 1e-6
    for column, (leg, axis, on_base) in enumerate([(2, 0, True), (2, 1, True), (4, 2, False)]):
        moved = []
        for sign in (1.0, -1.0):
            b, p = [x.copy() for x in base], [x.copy() for x in top]
            (b if on_base else p)[leg][axis] += sign * h
            moved.append(stewart_forward(lengths, b, p, centre, rotation))
        (c1, r1), (c2, r2) = moved
        expected = np.concatenate([(c1 - c2) / (2 * h), pin.log3(r1 @ r2.T) / (2 * h)])
        assert np.allclose(result.matrix[:, column], expected, rtol=1e-6, atol=1e-9), column


def test_tolerance_sweeps_run_on_the_three_mechanisms(rssr, delta, stewart):
    """Tolerance sweeps with exact Monte Carlo move each mechanism along its driven joint: the
    RSSR over a crank revolution, the Delta's shoulder 0 over 20 deg, a Stewart leg over 20 mm.
    The uniform Monte Carlo deviations stay inside the first-order worst-case band (plus 1 %)."""
    from clearance_pin.tolerance import sweep

    cases = [
        (rssr, ["rocker_pivot", "rocker_B.z"], None, 0.0, 0.0, 2.0 * math.pi),
        (
            delta,
            ["tool.x", "tool.y", "tool.z"],
            "shoulder_0",
            q_of(delta, "shoulder_0"),
            -0.17,
            0.17,
        ),
        (stewart, ["tool.x", "tool.z", "tool.rz"], "leg_0", q_of(stewart, "leg_0"), -0.01, 0.01),
    ]
    for mechanism, outputs, joint, offset, start, stop in cases:
        result = sweep(
            mechanism,
            outputs,
            joint,
            positions=5,
            start=start,
            stop=stop,
            offset=offset,
            samples=300,
        )
        assert np.all(np.isfinite(result.worst)) and np.all(result.worst > 0.0)
        for k, run in enumerate(result.uniform):
            assert np.all(run.max_abs <= 1.01 * result.worst[k]), (mechanism.name, k)


def q_of(mechanism, joint: str) -> float:
    return float(mechanism.q_nominal[q_index(mechanism, joint)])


def test_tolerance_command_on_the_rssr(capsys):
    """``clearance-pin tolerance`` runs on the RSSR over its crank cycle (it failed off the file
    pose): exit 0 and a table for every position."""
    from clearance_pin.cli import main

    status = main(
        [
            "tolerance",
            str(DATA / "spatial_rssr.urdf"),
            "--output",
            "psi=rocker_pivot",
            "--output",
            "zB=rocker_B.z",
            "--positions",
            "7",
            "--samples",
            "200",
            "--no-maxima",
            "--budget",
            "zB",
        ]
    )
    assert status == 0
    assert "psi" in capsys.readouterr().out


def test_model_files_are_the_generators_output():
    """The three files are what make_spatial_loops.py writes from its design numbers (which the
    checks above use), so the two cannot drift apart."""
    for name, write in (
        ("spatial_rssr.urdf", design.write_rssr),
        ("spatial_delta.urdf", design.write_delta),
        ("spatial_stewart.urdf", design.write_stewart),
    ):
        stored, generated = (DATA / name).read_text(), write()
        assert NUMBER.sub("#", stored) == NUMBER.sub("#", generated), name  # same elements
        np.testing.assert_allclose(  # numbers to round-off: float text differs between CPUs
            numbers(stored), numbers(generated), rtol=1e-12, atol=1e-15, err_msg=name
        )


NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


def numbers(text: str) -> np.ndarray:
    """Every decimal number in a text, in order."""
    return np.array([float(token) for token in NUMBER.findall(text)])
