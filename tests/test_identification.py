"""Issue 35: a robot's drive backlash and stiffness identified from measured deflections.

Independent references: the measurements are made by tests/identification_synthetic.py from
Pinocchio's Jacobians alone (J (sign(tau) b / 2 + tau / k), tau = J^T F - g(q)), which shares
nothing with the identification (that reads its model from clearance_pin's solver: its drive
torques, its backlash sides and displacements, and the library's joint levers). The robots are
the UR5 and the Franka Panda of example-robot-data as shipped (the vendor URDF, unedited; the
clearance files written beside it into tmp_path). Noise is seeded; the number of poses is stated
in each test.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import clearance_pin as cp
from clearance_pin.identification import Measurements

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "benchmarks"))
import arms  # benchmarks/arms.py: where the vendor files are
import identification_synthetic as synthetic  # tests/, Pinocchio only

G = 9.80665
# per robot: its vendor file and nominal pose [rad] (benchmarks/arms.py, shared with the
# corpus tests), the measured frame and offset [m], the rated payload [kg]
ROBOTS = {
    "ur5": (*arms.VENDOR["ur5"][:2], ("tool0", [0.2, 0.0, 0.1]), 5.0),
    "panda": (*arms.VENDOR["panda"][:2], ("panda_hand_tcp", [0.25, 0.0, 0.0]), 3.0),
}
# the "true" drives (a cobot's harmonic drives: 1.4-3 arcmin of lost motion, 4e3-3e4 N m/rad)
TRUE = {
    "ur5": (
        np.array([5e-4, 4e-4, 6e-4, 8e-4, 7e-4, 9e-4]),
        np.array([3.0e4, 2.5e4, 1.5e4, 6e3, 5e3, 4e3]),
    ),
    "panda": (
        np.array([5e-4, 4e-4, 6e-4, 5e-4, 8e-4, 7e-4, 9e-4]),
        np.array([2.5e4, 3.0e4, 1.5e4, 1.2e4, 5e3, 4.5e3, 3e3]),
    ),
}
DATASHEET = (3e-4, 1e4)  # the clearance file's values for every drive: backlash [rad], k


def vendor(robot: str) -> Path:
    path = arms.vendor_file(ROBOTS[robot][0])
    if path is None:
        pytest.skip("example-robot-data is not installed (pip install clearance_pin[test])")
    return path


def datasheet_file(folder: Path, robot: str, backlash: float, stiffness: float) -> Path:
    """A clearance file beside nothing in particular: every revolute joint driven, with the
    datasheet's backlash and drive stiffness (no bearing play), the nominal pose."""
    lines = [
        'unit = "mm"',
        "[defaults.revolute]",
        "driven = true",
        f"backlash = {backlash!r}",
        f"drive_stiffness = {stiffness!r}",
    ]
    for name, q in ROBOTS[robot][1].items():
        lines += [f"[joints.{name}]", f"q = {q!r}"]
    path = folder / f"{robot}_datasheet.toml"
    path.write_text("\n".join(lines) + "\n")
    return path


def robot_and_truth(tmp_path: Path, robot: str):
    mechanism = cp.load(str(vendor(robot)), clearances=datasheet_file(tmp_path, robot, *DATASHEET))
    names = list(ROBOTS[robot][1])
    return mechanism, names, *TRUE[robot]


def synthetic_measurements(mechanism, robot, names, b, k, poses, forces, **options):
    frame, offset = ROBOTS[robot][2]
    rows = synthetic.measurements(
        mechanism.model, frame, offset, names, b, k, poses, forces, **options
    )
    return Measurements.from_arrays(
        rows["pose"], rows["q"], rows["force"], rows["position"], rows.get("rotation")
    )


def five_loads(payload: float) -> np.ndarray:
    f = G * payload  # hung, then pulled along +-x, +-y (docs/identification.md)
    return np.array([[0, 0, -f], [f, 0, 0], [-f, 0, 0], [0, f, 0], [0, -f, 0]])


def random_poses(mechanism, count: int, seed: int) -> np.ndarray:
    """Poses with every driven joint uniform within its URDF limits (the test's own sampling),
    the others (the Panda's fingers) nominal."""
    model = mechanism.model
    rng = np.random.default_rng(seed)
    poses = np.tile(mechanism.q_nominal, (count, 1))
    for joint in mechanism.tree_joints:
        if joint.driven:
            i = model.joints[joint.joint_id].idx_q
            low, high = model.lowerPositionLimit[i], model.upperPositionLimit[i]
            poses[:, i] = rng.uniform(low, high, count)
    return poses


@pytest.mark.parametrize("robot", ["ur5", "panda"])
def test_noise_free_measurements_give_every_parameter_back(tmp_path, robot):
    """20 random poses x 5 loads, no noise: every drive's backlash and stiffness to 1e-6."""
    mechanism, names, b, k = robot_and_truth(tmp_path, robot)
    poses = random_poses(mechanism, 20, seed=1)
    data = synthetic_measurements(mechanism, robot, names, b, k, poses, five_loads(2.0))
    result = mechanism.identify(data, point=ROBOTS[robot][2])
    assert result.status == "ok" and result.rank == 2 * len(names)
    for j, name in enumerate(names):
        assert result.parameter(name, "backlash").value == pytest.approx(b[j], rel=1e-6)
        assert result.parameter(name, "drive_stiffness").value == pytest.approx(k[j], rel=1e-6)
    assert result.rms["fitted"]["after_m"] < 1e-12
    assert result.rms["fitted"]["before_m"] > 1e-5  # the datasheet's values miss by far
    assert result.solver_check < 1e-15  # the linear model is the solver's
    # a quarter of the poses held out: fitted on 15, predicted on 5
    split = mechanism.identify(data, point=ROBOTS[robot][2], held_out=0.25, seed=2)
    assert (split.poses, split.held_out_poses) == (15, 5)
    assert split.rms["held_out"]["after_m"] < 1e-12
    assert split.rms["held_out"]["before_m"] > 1e-5


@pytest.mark.parametrize("robot", ["ur5", "panda"])
def test_noisy_measurements_at_the_designed_poses(tmp_path, robot):
    """10 um of noise per coordinate (seeded), 120 designed poses x 5 loads (the rated payload,
    5 kg for the UR5 and 3 kg for the Panda, hung and pulled along +-x, +-y): the design
    promises standard errors within a third of the tolerances, the fit gives every stiffness
    within 1 % and every backlash within 5 %, its standard errors the design's to 10 %, and on
    60 held-out random poses the prediction error (against the noise-free truth) is cut by more
    than 70 % from the datasheet's."""
    mechanism, names, b, k = robot_and_truth(tmp_path, robot)
    point, payload = ROBOTS[robot][2], ROBOTS[robot][3]
    design = mechanism.design_measurements(point, 120, 10e-6, payload=payload, seed=0)
    assert design.configurations.shape == (120, mechanism.model.nq) and design.status == "ok"
    expected_b, expected_c = design.standard_errors[0::2], design.standard_errors[1::2]
    # the expected errors, 10 um sqrt(diag((A^T A)^-1)), from the test's own design matrix
    a = synthetic.columns(mechanism.model, *point, names, design.configurations, design.forces)
    a = a - np.repeat(a.reshape(120, -1, *a.shape[1:]).mean(axis=1), len(design.forces), axis=0)
    a = a.reshape(-1, a.shape[2])
    own = 10e-6 * np.sqrt(np.diag(np.linalg.inv(a.T @ a)))
    assert np.allclose(design.standard_errors, own, rtol=1e-6, atol=0)
    assert np.all(expected_b < 0.05 / 3 * b) and np.all(expected_c * k < 0.01 / 3)
    data = synthetic_measurements(
        mechanism, robot, names, b, k, design.configurations, design.forces,
        noise=10e-6, seed=7,
    )  # fmt: skip
    held = synthetic_measurements(
        mechanism, robot, names, b, k, random_poses(mechanism, 60, seed=11), design.forces,
        noise=10e-6, seed=8,
    )  # fmt: skip
    result = mechanism.identify(data, point=point, held_out=held)
    assert result.status == "ok"
    for j, name in enumerate(names):
        backlash = result.parameter(name, "backlash")
        stiffness = result.parameter(name, "drive_stiffness")
        assert backlash.value == pytest.approx(b[j], rel=0.05), name
        assert stiffness.value == pytest.approx(k[j], rel=0.01), name
        assert backlash.standard_error == pytest.approx(expected_b[j], rel=0.1)
        assert stiffness.compliance_error == pytest.approx(expected_c[j], rel=0.1)
    assert result.sigma == pytest.approx(10e-6, rel=0.05)
    # held out, against the noise-free truth: the datasheet's error and the identified one
    truth = synthetic_measurements(
        mechanism, robot, names, b, k, random_poses(mechanism, 60, seed=11), design.forces
    )
    sheet = synthetic_measurements(
        mechanism, robot, names, np.full(len(names), DATASHEET[0]),
        np.full(len(names), DATASHEET[1]),
        truth.configurations[::5], design.forces,
    )  # fmt: skip
    fitted_b = [result.parameter(n, "backlash").value for n in names]
    fitted_k = [result.parameter(n, "drive_stiffness").value for n in names]
    fitted = synthetic_measurements(
        mechanism, robot, names, np.array(fitted_b), np.array(fitted_k),
        truth.configurations[::5], design.forces,
    )  # fmt: skip

    def spread(m: Measurements) -> np.ndarray:  # each position less its pose's mean
        means = np.array([m.positions[m.pose_of_row == p].mean(0) for p in m.pose_of_row])
        return m.positions - means

    before = np.sqrt(np.mean((spread(sheet) - spread(truth)) ** 2))
    after = np.sqrt(np.mean((spread(fitted) - spread(truth)) ** 2))
    assert after < 0.3 * before
    assert result.rms["held_out"]["after_m"] < 0.3 * result.rms["held_out"]["before_m"]


def test_a_preloaded_shoulder_is_reported_unobservable(tmp_path):
    """The UR5 with its own weight on and small loads (0.5 kg hung, 5 N pulls): the shoulder's
    torque is the arm's weight's at every pose and never changes sign, so its backlash is
    reported unobservable (its stiffness is still identified); the joints whose torque does
    change sign (found here from Pinocchio's torques, the test's own) are identified to 1e-6."""
    robot = "ur5"
    mechanism, names, b, k = robot_and_truth(tmp_path, robot)
    forces = np.array([[0, 0, -0.5 * G], [5, 0, 0], [-5, 0, 0], [0, 5, 0], [0, -5, 0]])
    # which torques change sign within a pose, from Pinocchio alone; the poses kept: those
    # where the arm's weight preloads the shoulder (its torque keeps its sign)
    import pinocchio as pin

    model = mechanism.model
    pdata = model.createData()
    frame, offset = ROBOTS[robot][2]
    poses, flips = [], np.zeros(6, dtype=bool)
    for q in random_poses(mechanism, 200, seed=3):
        _, jacobian = synthetic.point_jacobian(model, pdata, model.getFrameId(frame), offset, q)
        tau = jacobian[:3].T @ forces.T - pin.computeGeneralizedGravity(model, pdata, q)[:, None]
        flip = (tau.max(axis=1) > 0) & (tau.min(axis=1) < 0)
        if not flip[1] and len(poses) < 30:
            poses.append(q)
            flips |= flip
    assert len(poses) == 30 and not flips[1] and flips.sum() >= 3  # others do flip
    data = synthetic_measurements(mechanism, robot, names, b, k, poses, forces, gravity=True)
    result = mechanism.identify(data, point=ROBOTS[robot][2], gravity=True)
    assert result.status == "partial"
    for j, name in enumerate(names):
        backlash = result.parameter(name, "backlash")
        if flips[j]:
            assert backlash.status == "identified"
            assert backlash.value == pytest.approx(b[j], rel=1e-6)
        else:
            assert backlash.status == "unobservable"
            assert "never changes sign" in backlash.reason
            assert backlash.value == DATASHEET[0] and np.isnan(backlash.standard_error)
        stiffness = result.parameter(name, "drive_stiffness")
        assert stiffness.status == "identified"
        assert stiffness.value == pytest.approx(k[j], rel=1e-6)


def test_hung_masses_alone_leave_the_base_unobservable(tmp_path):
    """Only hung masses, the arm's weight off: no torque changes sign (every backlash
    unobservable), and the vertical base axis carries no torque at all (its stiffness too)."""
    robot = "ur5"
    mechanism, names, b, k = robot_and_truth(tmp_path, robot)
    forces = np.array([[0, 0, -G], [0, 0, -3 * G], [0, 0, -5 * G]])
    data = synthetic_measurements(
        mechanism, robot, names, b, k, random_poses(mechanism, 10, seed=4), forces
    )
    result = mechanism.identify(data, point=ROBOTS[robot][2])
    statuses = {(p.joint, p.kind): p.status for p in result.parameters}
    assert all(statuses[(n, "backlash")] == "unobservable" for n in names)
    assert statuses[("shoulder_pan_joint", "drive_stiffness")] == "unobservable"
    for j, name in enumerate(names[1:], start=1):
        assert result.parameter(name, "drive_stiffness").value == pytest.approx(k[j], rel=1e-6)


def test_the_written_clearance_file_loads_back(tmp_path):
    """The identified values written into the datasheet's file (TOML) load back bitwise, the
    rest of the file (nominal pose) unchanged; only backlash asked for keeps the stiffness."""
    robot = "panda"
    mechanism, names, b, k = robot_and_truth(tmp_path, robot)
    data = synthetic_measurements(
        mechanism, robot, names, b, k, random_poses(mechanism, 15, seed=5), five_loads(3.0)
    )
    result = mechanism.identify(data, point=ROBOTS[robot][2])
    written = tmp_path / "identified.toml"
    result.write_clearances(written, base=tmp_path / "panda_datasheet.toml")
    again = cp.load(str(vendor(robot)), clearances=written)
    assert np.array_equal(again.q_nominal, mechanism.q_nominal)
    for name in names:
        joint = again.joint(name)
        m = joint.motion_component
        assert joint.clearance.backlash == result.parameter(name, "backlash").value
        assert joint.clearance.stiffness[m][m] == result.parameter(name, "drive_stiffness").value
    only = mechanism.identify(data, point=ROBOTS[robot][2], parameters=("backlash",))
    assert all(p.status == "not fitted" for p in only.parameters if p.kind == "drive_stiffness")
    # the stiffness held at the datasheet's (wrong) values: the backlash fit absorbs the misfit
    assert only.rms["fitted"]["after_m"] > 100 * result.rms["fitted"]["after_m"]


def test_bad_measurement_files_name_the_line_and_column(tmp_path):
    mechanism = cp.load(str(vendor("ur5")), clearances=datasheet_file(tmp_path, "ur5", *DATASHEET))
    header = "pose,shoulder_pan_joint,mass,x,y,z"

    def error(text: str) -> cp.MeasurementError:
        path = tmp_path / "m.csv"
        path.write_text(text)
        with pytest.raises(cp.MeasurementError) as caught:
            mechanism.identify(path, point="tool0")
        return caught.value

    bad = error(f"{header}\nA,0.1,1,0,0,0\nA,0.1,2,0.001,abc,0\n")
    assert (bad.row, bad.column) == (3, "y") and "'abc' is not a finite number" in str(bad)
    bad = error("pose,shoulder_pan_jiont,mass,x,y,z\nA,0.1,1,0,0,0\n")
    assert (bad.row, bad.column) == (1, "shoulder_pan_jiont") and "unknown column" in str(bad)
    bad = error("pose,mass,x,y\nA,1,0,0\n")
    assert bad.column == "z" and "missing" in str(bad)
    bad = error(f"{header}\nA,0.1,1,0,0,0\nB,0.1,1,0,0,0\nB,0.1,2,0,0,0\n")
    assert (bad.row, bad.column) == (2, "pose") and "one row" in str(bad)
    bad = error(f"{header}\n# a comment\nA,0.1,1,0,0,0\nA,0.2,2,0,0,0\n")
    assert (bad.row, bad.column) == (4, "shoulder_pan_joint") and "differs" in str(bad)
    bad = error(f"{header}\nA,0.1,-1,0,0,0\nA,0.1,2,0,0,0\n")
    assert (bad.row, bad.column) == (2, "mass")
    bad = error(f"{header}\nA,0.1,1,0,0\n")
    assert bad.row == 2 and "5 values for the 6 columns" in str(bad)


def test_a_design_too_small_and_one_of_backlash_alone(tmp_path):
    """One pose cannot determine 12 parameters (its 5 loads x 3 coordinates less the pose's mean
    are 12 equations, but the sides the loads take up are not independent enough): every
    parameter has a share in what it leaves undetermined, so none gets a standard error and the
    design says it failed; asking for backlash alone lists backlash only."""
    mechanism, names, _, _ = robot_and_truth(tmp_path, "ur5")
    small = mechanism.design_measurements(ROBOTS["ur5"][2], 1, 10e-6, payload=5.0, candidates=50)
    assert small.status == "failed" and np.isnan(small.standard_errors).all()
    only = mechanism.design_measurements(
        ROBOTS["ur5"][2], 10, 10e-6, payload=5.0, candidates=50, parameters="backlash"
    )
    assert only.labels == tuple(f"{n} backlash" for n in names) and only.status == "ok"


def test_a_measurement_error_pickles_with_its_data():
    import pickle

    error = cp.MeasurementError("m.csv", 5, "y", "'abc' is not a finite number")
    copy = pickle.loads(pickle.dumps(error))
    assert type(copy) is cp.MeasurementError and vars(copy) == vars(error)
    assert str(copy) == "m.csv: line 5, column 'y': 'abc' is not a finite number"


def test_rotations_measured_too(tmp_path):
    """With the rotation vector measured (rx, ry, rz), from a point on the last wrist's axis:
    noise-free, the other drives come back to 5e-3. The measured rotations are finite (the
    generator composes them, exp3) and the model is of first order: the difference of two
    rotations within a pose, log3(exp(m_l) exp(-m_1)) = m_l - m_1 - (m_l x m_1) / 2 + ...,
    carries a second-order term of the size of the backlash turns (1e-3 rad here; without the
    rotation columns the same data give 1e-12, tests above). A force through that axis exerts
    no torque on it: the last wrist is reported unobservable."""
    robot = "ur5"
    mechanism, names, b, k = robot_and_truth(tmp_path, robot)
    point = ("tool0", [0.0, 0.0, 0.1])  # on wrist_3's axis
    frame, offset = point
    rows = synthetic.measurements(
        mechanism.model, frame, offset, names, b, k, random_poses(mechanism, 20, seed=6),
        five_loads(5.0), rotations=True,
    )  # fmt: skip
    data = Measurements.from_arrays(
        rows["pose"], rows["q"], rows["force"], rows["position"], rows["rotation"]
    )
    result = mechanism.identify(data, point=point)
    # a force on the axis exerts no torque on wrist_3: its parameters are unobservable
    for kind in ("backlash", "drive_stiffness"):
        assert result.parameter("wrist_3_joint", kind).status == "unobservable"
    for j, name in enumerate(names[:5]):
        assert result.parameter(name, "backlash").value == pytest.approx(b[j], rel=5e-3)
        assert result.parameter(name, "drive_stiffness").value == pytest.approx(k[j], rel=5e-3)
    assert result.rms["fitted"]["after_rad"] < 1e-2 * result.rms["fitted"]["before_rad"]


def test_bearing_play_in_the_file_is_held_fixed(tmp_path):
    """UR5 whose clearance file also gives every journal 10 um of radial and 5 um of axial play
    (30 mm long): the play moves the point under each load (here from the journals' closed form
    of tests/test_corpus_robots.py, the wrench at each joint's centre, no solver code), the fit
    holds it at the file's values and still gives every drive back to 1e-6, noise-free."""
    corpus = pytest.importorskip("test_corpus_robots")

    robot = "ur5"
    lines = [
        'unit = "um"',
        "[defaults.revolute]",
        'type = "revolute"',
        f"radial_clearance = {corpus.RADIAL * 1e6!r}",
        f"axial_clearance = {corpus.AXIAL * 1e6!r}",
        f"length = {corpus.LENGTH * 1e6!r}",
        "driven = true",
        f"backlash = {DATASHEET[0]!r}",
        f"drive_stiffness = {DATASHEET[1]!r}",
    ]
    for name, q in ROBOTS[robot][1].items():
        lines += [f"[joints.{name}]", f"q = {q!r}"]
    (tmp_path / "played.toml").write_text("\n".join(lines) + "\n")
    mechanism = cp.load(str(vendor(robot)), clearances=tmp_path / "played.toml")
    names = list(ROBOTS[robot][1])
    b, k = TRUE[robot]
    frame, offset = ROBOTS[robot][2]
    poses = random_poses(mechanism, 15, seed=9)
    forces = five_loads(5.0)
    data = synthetic_measurements(mechanism, robot, names, b, k, poses, forces)
    model = mechanism.model
    pdata = model.createData()
    fid = model.getFrameId(frame)
    played = data.positions.copy()
    for i, (q, force) in enumerate(zip(data.configurations, data.forces)):
        point, _ = synthetic.point_jacobian(model, pdata, fid, np.array(offset), q)
        for name in names:
            joint = mechanism.joint(name)
            placed = pdata.oMi[joint.joint_id]
            axes = placed.rotation @ joint.rotation  # the clearance frame in the world
            arm = point - placed.translation
            local = axes.T @ force
            torsor = corpus.journal_torsor(
                local, axes.T @ np.cross(arm, force), corpus.RADIAL, corpus.AXIAL, corpus.LENGTH
            )
            if abs(local[0]) <= 1e-9 * np.linalg.norm(force):
                torsor[0] = 0.0  # no axial load: the least-norm place, as the solver's
            played[i] += axes @ torsor[:3] + np.cross(axes @ torsor[3:], arm)
    measured = Measurements.from_arrays(data.pose_of_row, data.configurations, data.forces, played)
    result = mechanism.identify(measured, point=(frame, offset))
    assert result.status == "ok"
    for j, name in enumerate(names):
        assert result.parameter(name, "backlash").value == pytest.approx(b[j], rel=1e-6)
        assert result.parameter(name, "drive_stiffness").value == pytest.approx(k[j], rel=1e-6)
    assert result.rms["fitted"]["after_m"] < 1e-12
    # a model without the play cannot explain the same measurements: a residual of microns
    bare = cp.load(str(vendor(robot)), clearances=datasheet_file(tmp_path, robot, *DATASHEET))
    assert bare.identify(measured, point=(frame, offset)).rms["fitted"]["after_m"] > 1e-6
