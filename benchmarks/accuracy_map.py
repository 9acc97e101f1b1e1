r"""Accuracy-map speed (issue 23: 1000 poses x 10 payloads on a 7-joint arm in at most 1 s).

The Franka Panda of example-robot-data with the corpus clearances (tests/test_corpus_robots.py:
every arm joint a driven journal, radial play 10 um, axial 5 um, length 30 mm; the fingers held by
their drives), and the bundled 6R arm: 1000 random poses within +/- 0.5 rad of the nominal one,
payloads 0 to 9 kg at the tool, the robot's own weight on (gravity=True). Timed in a fresh process
as a user calls it, the mechanism built outside the timing; reported beside it: a loop of
``Mechanism.solve`` over a sample of the same cases (the way without the map), scaled to the
whole map. Each robot runs twice: as it is, and with joint stiffness (every arm drive
``drive_stiffness`` 2e4 N m/rad, every arm journal ``tilt_stiffness`` 2e5 N m/rad: a tree's springs
add to its play by superposition, docs/method.md section 2.2.2).

Issue 33 item 8: the UR5 of example-robot-data with play, backlash and drive stiffness
(``UR5_CLEARANCES``: every joint a driven journal, radial play 10 um, axial 5 um, length 30 mm,
backlash 0.2 mrad, drive stiffness 4e4 N m/rad), the same map timed against the peer a user
would write (:func:`peer_map`): a Pinocchio loop over the poses (forward kinematics, RNEA for the
weight each joint carries) and NumPy over poses x payloads x joints for the journals' closed
forms, the backlash :math:`\mathrm{sign}(\tau)\, b/2`, the deflection :math:`\tau / k` and the
tool's displacement; the two maps' largest difference is printed (relative to the largest
deviation). Each timed path is run twice after one warm-up call, the faster run reported.

Usage: ``python benchmarks/accuracy_map.py [--poses 1000] [--payloads 10] [--only ur5]``.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT / "benchmarks"))

import clearance_pin
from clearance_pin import PointForce

SPRINGS = 'driven="true" drive_stiffness="2e4" tilt_stiffness="2e5"'
G = 9.80665  # [m/s^2], the map's payload weight
RADIAL, AXIAL, LENGTH, BACKLASH, DRIVE = 1e-5, 5e-6, 0.03, 2e-4, 4e4  # [m, m, m, rad, N m/rad]
UR5_CLEARANCES = f"""unit = "m"

[defaults.revolute]
type = "revolute"
radial_clearance = {RADIAL!r}
axial_clearance = {AXIAL!r}
length = {LENGTH!r}
driven = true
backlash = {BACKLASH!r}
drive_stiffness = {DRIVE!r}
"""
UNLOADED = 1e-9  # a contact below this share of the case's largest work is left free (centre)


def peer_map(model, tool: str, poses: np.ndarray, masses: np.ndarray) -> np.ndarray:
    r"""The tool's displacement (Q, P, 3) [m], world axes, of a serial arm of driven journals
    (every joint: radial play RADIAL at both ends of a journal of length LENGTH, axial play
    AXIAL, backlash BACKLASH, drive stiffness DRIVE), its weight on and a mass ``masses`` [kg]
    at the tool frame's origin, as a user writes it with Pinocchio and NumPy.

    Per pose, one Pinocchio pass: forward kinematics, the tool's position p, each joint's axes
    A_j (x = its axis) and centre c_j, and the wrench its subtree's weight puts on it (RNEA at
    rest: minus the joint's transmitted force ``data.f``; its placements ``liMi`` composed into
    ``oMi``). Then for every pose, payload and joint
    at once, in the joint's axes (f, m) = the weight's plus the payload's (m g, (p - c) x m g):
    the journal ends settle at :math:`\delta_\pm = c\, a_\pm / |a_\pm|`,
    :math:`a_\pm = (0, f_y/2 \pm m_z/L, f_z/2 \mp m_y/L)`; the axial play
    :math:`u = c_a \mathrm{sign}(f_x)`; the drive :math:`lpha = \mathrm{sign}(m_x) b/2 + m_x/k`;
    a contact whose work :math:`c |a|/2`, :math:`c_a |f_x|`, :math:`b/2 |m_x|` is at most
    UNLOADED of the case's largest stays at its centre; the tool moves by
    :math:`\sum_j A_j v_j + (A_j \omega_j) 	imes (p - c_j)`.
    """
    import pinocchio as pin

    data = model.createData()
    frame = model.getFrameId(tool)
    joints = range(1, model.njoints)
    zero = np.zeros(model.nv)
    axes = np.empty((len(poses), len(joints), 3, 3))
    centres = np.empty((len(poses), len(joints), 3))
    carried = np.empty((len(poses), len(joints), 6))
    points = np.empty((len(poses), 3))
    turn = [_axis_frame(model, j) for j in joints]  # the joint frame to the journal's axes
    for i, q in enumerate(poses):
        pin.rnea(model, data, q, zero, zero)
        pin.updateGlobalPlacements(model, data)  # oMi from the liMi RNEA computed
        points[i] = pin.updateFramePlacement(model, data, frame).translation
        for k, j in enumerate(joints):
            placed = data.oMi[j]
            axes[i, k] = placed.rotation @ turn[k]
            centres[i, k] = placed.translation
            carried[i, k, :3] = -turn[k].T @ data.f[j].linear
            carried[i, k, 3:] = -turn[k].T @ data.f[j].angular
    weight = np.array([0.0, 0.0, -G])
    arms = points[:, None] - centres  # (Q, J, 3)
    f_payload = np.einsum("qjab,a->qjb", axes, weight)
    m_payload = np.einsum("qjab,qja->qjb", axes, np.cross(arms, weight))
    f = carried[:, None, :, :3] + masses[None, :, None, None] * f_payload[:, None]
    m = carried[:, None, :, 3:] + masses[None, :, None, None] * m_payload[:, None]
    ends = []
    for sign in (1.0, -1.0):
        a = np.stack([f[..., 1] / 2 + sign * m[..., 2] / LENGTH,
                      f[..., 2] / 2 - sign * m[..., 1] / LENGTH], axis=-1)  # fmt: skip
        size = np.linalg.norm(a, axis=-1)
        ends.append((a, size))
    works = np.concatenate([RADIAL * ends[0][1][..., None] / 2, RADIAL * ends[1][1][..., None] / 2,
                            AXIAL * np.abs(f[..., :1]), BACKLASH / 2 * np.abs(m[..., :1])],
                           axis=-1)  # (Q, P, J, 4)  # fmt: skip
    loaded = works > UNLOADED * works.max(axis=(2, 3), keepdims=True)
    delta = [
        np.where(loaded[..., e, None], RADIAL * a / np.where(size > 0, size, 1)[..., None], 0.0)
        for e, (a, size) in enumerate(ends)
    ]
    v = np.zeros(f.shape)
    w = np.zeros(f.shape)
    v[..., 0] = np.where(loaded[..., 2], AXIAL * np.sign(f[..., 0]), 0.0)
    v[..., 1:] = (delta[0] + delta[1]) / 2
    w[..., 0] = np.where(loaded[..., 3], BACKLASH / 2 * np.sign(m[..., 0]), 0.0) + m[..., 0] / DRIVE
    gap = delta[0] - delta[1]
    w[..., 1], w[..., 2] = -gap[..., 1] / LENGTH, gap[..., 0] / LENGTH
    turned = np.einsum("qjab,qpjb->qpja", axes, w)
    moved = np.einsum("qjab,qpjb->qpja", axes, v) + np.cross(turned, arms[:, None])
    return moved.sum(axis=2)


def _axis_frame(model, joint: int) -> np.ndarray:
    """Axes (3, 3) in the joint's frame whose x is the joint's axis (a revolute joint)."""
    import pinocchio as pin

    data = model.createData()
    q = pin.neutral(model)
    pin.computeJointJacobians(model, data, q)
    local = pin.getJointJacobian(model, data, joint, pin.LOCAL)[3:, model.joints[joint].idx_v]
    x = local / np.linalg.norm(local)
    helper = np.array([1.0, 0.0, 0.0]) if abs(x[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    y = np.cross(x, helper)
    y /= np.linalg.norm(y)
    return np.column_stack([x, y, np.cross(x, y)])


def ur5_with_clearances():
    """The UR5 of example-robot-data with UR5_CLEARANCES (None without example-robot-data)."""
    import tempfile

    import arms

    urdf = arms.vendor_file("ur_description/urdf/ur5_robot.urdf")
    if urdf is None:
        return None
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "ur5_play.toml"
        path.write_text(UR5_CLEARANCES)
        return clearance_pin.load(str(urdf), clearances=str(path))


def best_of(runs: int, work):
    """(the shortest wall time of ``runs`` calls [s], the last call's result)."""
    times, result = [], None
    for _ in range(runs):
        started = time.perf_counter()
        result = work()
        times.append(time.perf_counter() - started)
    return min(times), result


def ur5_against_the_peer(count: int, payloads: int) -> None:
    """The UR5 map under the payloads 0 to 9 kg at the tool, weight on, against
    :func:`peer_map` (module docstring)."""
    robot = ur5_with_clearances()
    if robot is None:
        print("UR5: example-robot-data is not installed")
        return
    rng = np.random.default_rng(0)
    poses = robot.q_nominal + rng.uniform(-0.5, 0.5, (count, robot.model.nq))
    masses = np.linspace(0.0, 9.0, payloads)
    robot.accuracy("tool0", poses[:3], payloads=list(masses[:2]), gravity=True)  # warm up
    peer_map(robot.model, "tool0", poses[:3], masses[:2])
    ours, amap = best_of(2, lambda: robot.accuracy("tool0", poses, list(masses), gravity=True))
    peer, moved = best_of(2, lambda: peer_map(robot.model, "tool0", poses, masses))
    largest = np.nanmax(np.linalg.norm(amap.translation, axis=2))
    differs = np.linalg.norm(amap.translation - moved, axis=2) / largest
    reach, pose, payload = amap.largest_reach()
    band = amap.reach - np.linalg.norm(amap.translation, axis=2)  # what the free motions add
    at = np.unravel_index(int(np.nanargmax(band)), band.shape)
    print(
        f"UR5 (play, backlash, drive stiffness): {count} poses x {payloads} payloads: map "
        f"{ours * 1e3:.0f} ms, peer (Pinocchio loop + NumPy) {peer * 1e3:.0f} ms, ratio "
        f"{ours / peer:.2f}; largest difference {np.nanmax(differs):.1e} of the largest "
        f"deviation {largest * 1e6:.1f} um, in {int((differs > 1e-12).sum())} cases above 1e-12 "
        f"(cases the closed forms leave to single solves); largest reach {reach * 1e6:.1f} um "
        f"(pose {pose}, {amap.payloads[payload]}: {', '.join(amap.responsible(pose, payload))}); "
        f"free motions alone: up to {np.nanmax(amap.free_spread) * 1e6:.1f} um; "
        f"widest band reach - |delta p| {band[at] * 1e6:.1f} um (pose {at[0]}, "
        f"{amap.payloads[at[1]]}: {', '.join(amap.responsible(*at))})"
    )


def stiffened(text: str) -> str:
    """The clearance block with a spring on every driven journal (fingers excepted)."""
    block = text[text.index("<clearance_pin>") :]
    journals = block.replace('type="revolute" radial_clearance', "SPRUNG radial_clearance")
    sprung = "\n".join(
        line.replace('driven="true"', SPRINGS) if "SPRUNG" in line else line
        for line in journals.splitlines()
    ).replace("SPRUNG", 'type="revolute"')
    return text.replace(block, sprung)


def robots():
    import test_corpus_robots as corpus

    arm = (ROOT / "models/arm_6r.urdf").read_text()
    yield "6R arm (models/arm_6r.urdf)", clearance_pin.loads(arm), "tool"
    yield "6R arm with springs", clearance_pin.loads(stiffened(arm)), "tool"
    try:
        text = corpus.model_text("panda").replace(
            "<clearance_pin>\n",
            "<clearance_pin>\n"  # the fingers held by their drive: they do not slide under gravity
            '  <joint name="panda_finger_joint1" driven="true"/>\n'
            '  <joint name="panda_finger_joint2" driven="true"/>\n',
        )
        panda = clearance_pin.loads(text)
        sprung = clearance_pin.loads(stiffened(text))
    except BaseException:  # pytest.skip without example-robot-data
        return
    yield "Franka Panda (example-robot-data)", panda, corpus.ROBOTS["panda"][2]
    yield "Franka Panda with springs", sprung, corpus.ROBOTS["panda"][2]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=1000)
    parser.add_argument("--payloads", type=int, default=10)
    parser.add_argument("--only", choices=("ur5",), help="only the UR5 against the peer")
    args = parser.parse_args()
    ur5_against_the_peer(args.poses, args.payloads)
    if args.only:
        return
    for name, robot, tool in robots():
        rng = np.random.default_rng(0)
        driven = [  # the arm's revolute drives (not the Panda's fingers)
            robot.model.joints[j.joint_id].idx_q
            for j in robot.tree_joints
            if j.driven and j.motion_component == 3
        ]
        poses = np.tile(robot.q_nominal, (args.poses, 1))
        poses[:, driven] += rng.uniform(-0.5, 0.5, (args.poses, len(driven)))
        masses = list(np.linspace(0.0, 9.0, args.payloads))
        started = time.perf_counter()
        amap = robot.accuracy(tool, poses, payloads=masses, gravity=True)
        seconds = time.perf_counter() - started
        link, point = robot.link_point(tool)
        sample = 50
        started = time.perf_counter()
        for i in range(sample):
            mass = masses[i % len(masses)]
            loads = [PointForce(link, [0, 0, -9.80665 * mass], point)] if mass else []
            robot.solve(loads=loads, q=poses[i], gravity=True)
        loop = (time.perf_counter() - started) / sample * args.poses * args.payloads
        largest, pose, payload = amap.largest()
        top = amap.ranking()[0]
        print(
            f"{name}: {args.poses} poses x {args.payloads} payloads in {seconds:.2f} s "
            f"(a loop of solve: about {loop:.1f} s); all verified {amap.ok.all()}; largest "
            f"{largest * 1e6:.1f} um at pose {pose}, {amap.payloads[payload]}; first contributor "
            f"{top[0]} of {top[1]} {top[2] * 1e6:.1f} um"
        )


if __name__ == "__main__":
    main()
