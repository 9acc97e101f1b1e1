r"""Arm runs: the 6R arm (models/arm_6r.urdf), the UR5 and the Franka Panda (example-robot-data).

Every revolute joint of these arms is a driven journal with play (the UR5 and the Panda get the
``<clearance_pin>`` block of tests/test_corpus_robots.py, inserted into the vendor file's text
here: radial play 10 um, axial play 5 um, length 30 mm, one force at the tool). Two uses:

- **trajectory**: ``points`` configurations of the driven joints (each q_i + A_i sin(phase + i),
  one turn of the phase, A_i = 0.5 rad or less to stay inside the URDF limits), the model's
  loads, configuration included (a freshly loaded mechanism: every configuration's geometry and
  the first solve are in the time);
- **load cases**: ``N`` random tool forces (the model's tool force plus 0.3 of its size times a
  standard normal vector) at the nominal configuration, on a built mechanism (loaded and solved
  once, untimed; a new one for each repeat).

Paths, each timed in the same process and run:

- ``solve_many``: ``Mechanism.solve_many(configurations=...)`` or ``solve_many(loads)``;
- ``solve_loop``: a loop of ``Mechanism.solve`` (warm start as it chooses);
- ``clarabel_prebuilt`` / ``clarabel_prebuilt_default`` (peer): Clarabel built once on the
  reduced cone programme the library solves (:class:`peers.ReducedClarabel`; read through
  ``clearance_pin.equilibrium.prepared.prepared_geometry(mechanism, q).problem(loads)``),
  re-solved after ``update(q=...)`` per load or configuration, at tolerances 1e-12 and at
  Clarabel's defaults. Its time is split into ``reduction`` (the library's prepared geometry and
  reduced problem: configuration and load to cone data) and ``clarabel`` (update, solve, answer
  mapped to joint torsors). Along a trajectory the peer's time is both (the configuration's
  geometry is part of the problem); over load cases it is ``clarabel`` alone (an expert maps a
  load to the cost by one precomputed product; the library's reduction is reported beside it).

Reference: the closed form of a driven journal (each journal is its own problem when every joint
is driven: the work of the loads is a sum over the joints of the wrench carried by the joint's
child subtree times the joint's torsor), from Pinocchio's placements and the URDF inertias only
(:class:`ClosedForm`); its own round-off is measured against the same formulas in 40-digit
decimal arithmetic (``reference_arithmetic_rel_play``), and the prebuilt Clarabel peers are an
independent check of it (their error). Errors are relative to the play, in the library's scaling
of the unknowns: max(|dt| / c, |dr| l / c) over every joint, c the largest clearance, l the
mechanism's length scale (``Mechanism.length_scale()``), dt and dr the torsor's translation [m]
and rotation [rad] errors.
"""

from __future__ import annotations

import gc
import importlib.metadata
import math
import re
import time
import zlib
from pathlib import Path

import numpy as np
import pinocchio as pin

import clearance_pin
from clearance_pin import PointForce

ROOT = Path(__file__).resolve().parent.parent
RADIAL, AXIAL, LENGTH = 1e-5, 5e-6, 0.03  # [m], the block inserted into the vendor files
TOOL_FORCE = np.array([20.0, -30.0, -50.0])  # [N], world axes
TOOL_POINT = np.array([0.0, 0.0, 0.05])  # [m], tool frame
UNLOADED = 1e-9  # an axial load below this share of the joint's force leaves the axial play free
AMPLITUDE = 0.5  # [rad] of the trajectories
PERTURBATION = 0.3  # relative size of the random tool forces

VENDOR = {
    # vendor file, driven joints with their nominal values [rad] (inside the URDF limits), tool
    "ur5": (
        "ur_description/urdf/ur5_robot.urdf",
        {
            "shoulder_pan_joint": 0.3,
            "shoulder_lift_joint": -1.0,
            "elbow_joint": 1.2,
            "wrist_1_joint": -0.8,
            "wrist_2_joint": 0.6,
            "wrist_3_joint": 0.4,
        },
        "tool0",
    ),
    "panda": (
        "panda_description/urdf/panda.urdf",
        {
            "panda_joint1": 0.2,
            "panda_joint2": -0.4,
            "panda_joint3": 0.1,
            "panda_joint4": -2.0,
            "panda_joint5": 0.3,
            "panda_joint6": 1.6,
            "panda_joint7": 0.5,
        },
        "panda_hand_tcp",
    ),
}
ARMS = ("arm_6r", "ur5", "panda")


# -- models --------------------------------------------------------------------------------------
def vendor_file(relative: str) -> Path | None:
    """Path of a file of the installed example-robot-data, found in the distribution's own file
    list (every version's wheel lists its files; None when it is not installed or has no such
    file). Not through ``getModelPath``: its return value changed meaning between releases (the
    data folder's parent in 4-5, the ``robots`` folder itself in example-robot-data-loaders)."""
    try:
        distribution = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        return None
    for file in distribution.files or ():
        if str(file).endswith(relative):
            return Path(distribution.locate_file(file))
    return None


def model_text(robot: str) -> str | None:
    """The vendor URDF with a <clearance_pin> block inserted before </robot> (None when the
    vendor file is not installed)."""
    relative, joints, tool = VENDOR[robot]
    path = vendor_file(relative)
    if path is None:
        return None
    text = path.read_text()
    lines = [
        f'<joint name="{name}" type="revolute" radial_clearance="{RADIAL!r}" '
        f'axial_clearance="{AXIAL!r}" length="{LENGTH!r}" driven="true" q="{q!r}"/>'
        for name, q in joints.items()
    ]
    force = " ".join(repr(float(v)) for v in TOOL_FORCE)
    point = " ".join(repr(float(v)) for v in TOOL_POINT)
    lines.append(f'<force link="{tool}" point="{point}" value="{force}"/>')
    block = "<clearance_pin>\n  " + "\n  ".join(lines) + "\n</clearance_pin>\n"
    if text.count("</robot>") != 1:
        raise ValueError(f"{relative}: expected one </robot>")
    # the Panda's second finger mimics the first; clearance_pin refuses mimic joints and the
    # fingers are not studied here: drop the coupling (an independent finger)
    text = re.sub(r"<mimic[^>]*/>", "", text)
    return text.replace("</robot>", block + "</robot>")


def loader(name: str):
    """A function returning a freshly loaded mechanism of arm ``name``, or None (not installed)."""
    if name == "arm_6r":
        path = ROOT / "models" / "arm_6r.urdf"
        return lambda: clearance_pin.load(path)
    text = model_text(name)
    if text is None:
        return None
    return lambda: clearance_pin.loads(text, source=name)


def tool_load(mechanism) -> PointForce:
    """The model's one point force (the tool load)."""
    forces = [load for load in mechanism.loads if isinstance(load, PointForce)]
    if len(forces) != 1:
        raise ValueError(f"{mechanism.name}: expected one tool force, got {len(forces)}")
    return forces[0]


def trajectory(mechanism, points: int) -> list[np.ndarray]:
    """``points`` configurations: every driven joint q_i + A_i sin(phase + i) over one turn."""
    model = mechanism.model
    nominal = np.asarray(mechanism.q_nominal, dtype=float)
    phases = np.linspace(0.0, 2.0 * np.pi, points)
    out = [nominal.copy() for _ in phases]
    for k, joint in enumerate(mechanism.tree_joints):
        if not joint.driven:
            continue
        index = model.idx_qs[joint.joint_id]
        low, high = model.lowerPositionLimit[index], model.upperPositionLimit[index]
        room = min(nominal[index] - low, high - nominal[index])
        amplitude = AMPLITUDE if not np.isfinite(room) else min(AMPLITUDE, 0.9 * room)
        for q, phase in zip(out, phases):
            q[index] += amplitude * math.sin(phase + k)
    return out


def tool_forces(mechanism, count: int, seed: int) -> np.ndarray:
    """``count`` random tool forces (count, 3) [N] around the model's."""
    rng = np.random.default_rng([seed, zlib.crc32(mechanism.name.encode())])
    force = tool_load(mechanism).force
    return force + PERTURBATION * np.linalg.norm(force) * rng.standard_normal((count, 3))


# -- the reference: closed forms of driven journals ----------------------------------------------
class ClosedForm:
    r"""Torsors of every driven journal of a serial arm, from the wrench its child subtree carries.

    For joint j with clearance frame R (x = axis e) at centre c, the external wrench on the
    bodies of its subtree, at c in the clearance frame, is (f, m). The two journal ends settle at
    :math:`c_r a_\pm / |a_\pm|`, :math:`a_\pm = P f / 2 \pm (m \times e) / L` (P: projector across
    the axis), the axial play at :math:`c_a\,\mathrm{sign}(f \cdot e)` (0, the minimum-norm point,
    when :math:`|f\cdot e|` is below 1e-9 of |f|: the axial play is then not loaded), and the spin
    about the axis is held by the drive (derivation in tests/test_corpus_robots.py,
    ``journal_torsor``). Loads: the tool force, and gravity on every body's centre of mass when
    the model switches it on. Written from Pinocchio's kinematics and the model's inertias only.
    An ideal joint (no play: the Panda's fingers) has the torsor 0.
    """

    def __init__(self, mechanism):
        self.model = mechanism.model
        self.data = self.model.createData()
        self.names = tuple(mechanism.joints)
        self.joints = []
        for name in self.names:
            joint = mechanism.joint(name)
            clearance = joint.clearance
            if clearance.max_play == 0.0:
                self.joints.append(None)  # an ideal joint (the Panda's fingers): no torsor
                continue
            if getattr(joint, "driven", False) is not True or clearance.kind != "revolute":
                raise ValueError(f"{name}: the closed form needs driven revolute journals")
            subtree = set(self.model.subtrees[joint.joint_id])
            self.joints.append(
                (joint.joint_id, joint.rotation, clearance.radial, clearance.axial,
                 clearance.length, subtree)
            )  # fmt: skip
        tool = tool_load(mechanism)
        self.tool_frame = mechanism.link_frames[tool.link]
        self.tool_point = np.asarray(tool.point, dtype=float)
        gravity = mechanism.gravity
        self.gravity = None if not gravity else np.asarray(gravity.acceleration, dtype=float)
        self.near_threshold = 0  # axial shares within a factor 10 of UNLOADED (ambiguous)

    def wrenches(self, q, forces: np.ndarray) -> list:
        """Per joint (None for an ideal one): the wrench (f (N, 3) [N], m (N, 3) [N m]) that its
        child subtree carries, at its centre, in its clearance frame, for the tool forces (N, 3)
        at configuration q."""
        model, data = self.model, self.data
        pin.framesForwardKinematics(model, data, np.asarray(q, dtype=float))
        frame = model.frames[self.tool_frame]
        tool_body = frame.parentJoint
        # levers about each joint centre composed from body placements, (t_b - c) + R_b p_b:
        # not from the world point minus the centre, which loses the digits both share
        tool_lever = frame.placement.act(self.tool_point)  # in the tool body [m]
        forces = np.atleast_2d(forces)
        out = []
        for joint in self.joints:
            if joint is None:
                out.append(None)
                continue
            joint_id, rotation, _, _, _, subtree = joint
            placement = data.oMi[joint_id]
            centre = placement.translation
            frame_rotation = placement.rotation @ rotation  # clearance frame in the world
            force, moment = np.zeros((len(forces), 3)), np.zeros((len(forces), 3))
            if tool_body in subtree:
                body = data.oMi[tool_body]
                arm = (body.translation - centre) + body.rotation @ tool_lever
                force += forces
                moment += np.cross(arm, forces)
            if self.gravity is not None:
                for body_id in subtree:
                    inertia = model.inertias[body_id]
                    if inertia.mass > 0.0:
                        weight = inertia.mass * self.gravity
                        body = data.oMi[body_id]
                        arm = (body.translation - centre) + body.rotation @ inertia.lever
                        force += weight
                        moment += np.cross(arm, weight)
            out.append((force @ frame_rotation, moment @ frame_rotation))
        return out

    def torsors(self, q, forces: np.ndarray) -> np.ndarray:
        """(N, joints, 6) [m, rad] for the tool forces (N, 3) [N] at configuration q."""
        forces = np.atleast_2d(forces)
        out = np.zeros((len(forces), len(self.joints), 6))
        for k, (joint, wrench) in enumerate(zip(self.joints, self.wrenches(q, forces))):
            if joint is not None:
                out[:, k] = self._journal(*wrench, *joint[2:5])
        return out

    def arithmetic_check(self, q, forces: np.ndarray, play: float, length: float) -> float:
        """The closed form's own round-off: its double-precision torsors against the same formulas
        in 40-digit decimal arithmetic on the same wrenches, relative to the play (as
        :func:`relative_errors`). Pinocchio's placements are not re-checked."""
        import decimal

        context = decimal.Context(prec=40)
        decimal_of = context.create_decimal
        doubles = self.torsors(q, forces)
        worst = 0.0
        for k, (joint, wrench) in enumerate(zip(self.joints, self.wrenches(q, forces))):
            if joint is None:
                continue
            radial, axial, span = (decimal_of(v) for v in joint[2:5])
            for n, (force, moment) in enumerate(zip(*wrench)):
                f = [decimal_of(float(v)) for v in force]
                m = [decimal_of(float(v)) for v in moment]
                ends = []
                for sign in (1, -1):
                    a = (f[1] / 2 + sign * m[2] / span, f[2] / 2 - sign * m[1] / span)
                    size = context.sqrt(a[0] * a[0] + a[1] * a[1])
                    ends.append((radial * a[0] / size, radial * a[1] / size))
                (py, pz), (my, mz) = ends
                share = abs(f[0]) / context.sqrt(sum(v * v for v in f))
                slide = axial * (1 if f[0] > 0 else -1) if share > decimal_of(UNLOADED) else 0
                exact = [slide, (py + my) / 2, (pz + mz) / 2, 0]
                exact += [-(pz - mz) / span, (py - my) / span]
                got = doubles[n, k]
                for c, value in enumerate(exact):
                    scale = 1.0 / play if c < 3 else length / play
                    error = abs(decimal_of(float(got[c])) - value)
                    worst = max(worst, float(error) * scale)
        return worst

    def _journal(self, f, m, radial, axial, length) -> np.ndarray:
        a_plus = np.stack((f[:, 1] / 2 + m[:, 2] / length, f[:, 2] / 2 - m[:, 1] / length), 1)
        a_minus = np.stack((f[:, 1] / 2 - m[:, 2] / length, f[:, 2] / 2 + m[:, 1] / length), 1)
        plus = radial * a_plus / np.linalg.norm(a_plus, axis=1, keepdims=True)
        minus = radial * a_minus / np.linalg.norm(a_minus, axis=1, keepdims=True)
        translation = (plus + minus) / 2.0
        d = plus - minus
        share = np.abs(f[:, 0]) / np.maximum(np.linalg.norm(f, axis=1), 1e-300)
        self.near_threshold += int(np.sum((share > 0.1 * UNLOADED) & (share < 10 * UNLOADED)))
        slide = np.where(share > UNLOADED, axial * np.sign(f[:, 0]), 0.0)
        zeros = np.zeros(len(f))
        return np.stack(
            (slide, translation[:, 0], translation[:, 1], zeros, -d[:, 1] / length,
             d[:, 0] / length),
            axis=1,
        )  # fmt: skip


def relative_errors(torsors: np.ndarray, reference: np.ndarray, play: float, length: float):
    """Per case, the largest error relative to the play: max(|dt| / c, |dr| l / c), (N,)."""
    difference = np.abs(torsors - reference)
    translation = difference[..., :3].max(axis=(-1, -2)) / play
    rotation = difference[..., 3:].max(axis=(-1, -2)) * length / play
    return np.maximum(translation, rotation)


def _scales(mechanism) -> tuple[float, float]:
    play = max(c.bound for j in mechanism.joints.values() for c in j.clearance.contacts)
    return play, mechanism.length_scale()


def _worst(errors) -> float:
    errors = np.asarray(errors, dtype=float)
    finite = errors[np.isfinite(errors)]
    return float(finite.max()) if finite.size else math.nan


def _equilibrium_torsors(equilibrium, names) -> np.ndarray:
    return np.array([equilibrium.torsor(name) for name in names])


# -- the runs ------------------------------------------------------------------------------------
def _repeat(run, budget_s: float, repeats: int) -> list:
    """``run()`` once, and again while the time spent stays within ``budget_s`` (at most
    ``repeats`` times); the list of its results."""
    results, started = [], time.perf_counter()
    while True:
        gc.collect()
        t0 = time.perf_counter()
        results.append(run())
        last = time.perf_counter() - t0
        if len(results) >= repeats or time.perf_counter() - started + last > budget_s:
            return results


def _peer_entry(clarabel_s, reduction_s, errors, statuses, rebuilds) -> dict:
    clarabel_s, reduction_s = np.asarray(clarabel_s), np.asarray(reduction_s)
    return {
        "solves": len(clarabel_s),
        "clarabel_median_s": float(np.median(clarabel_s)),
        "reduction_median_s": float(np.median(reduction_s)),
        "median_s": float(np.median(clarabel_s + reduction_s)),
        "total_s": float(np.sum(clarabel_s + reduction_s)),
        "clarabel_total_s": float(np.sum(clarabel_s)),
        "error_rel_play": _worst(errors),
        "statuses": {s: statuses.count(s) for s in sorted(set(statuses))},
        "solver_builds": rebuilds,
    }


def _peer_loop(items, problem_of, names, references, play, length, budget_s):
    """The prebuilt Clarabel peers (1e-12 and default) over ``items``: per item the reduced
    problem (timed once, shared) then each peer's update + solve + torsors (timed)."""
    import peers

    tight, default = peers.ReducedClarabel(1e-12), peers.ReducedClarabel(None)
    columns = None
    timing = {"reduction": [], "tight": [], "default": []}
    errors = {"tight": [], "default": []}
    statuses = {"tight": [], "default": []}
    started = time.perf_counter()
    for k, item in enumerate(items):
        t0 = time.perf_counter()
        prepared, problem = problem_of(item)
        timing["reduction"].append(time.perf_counter() - t0)
        if columns is None:
            columns = [prepared.joint_names.index(name) for name in names]
        for key, solver in (("tight", tight), ("default", default)):
            t0 = time.perf_counter()
            y, status, _ = solver.solve(problem)
            torsors = prepared.torsor_array(problem.x_from_y(y))[columns]
            timing[key].append(time.perf_counter() - t0)
            statuses[key].append(status)
            errors[key].append(relative_errors(torsors, references[k], play, length))
        if time.perf_counter() - started > budget_s and k + 1 >= 20:
            break
    return {
        "clarabel_prebuilt": _peer_entry(
            timing["tight"], timing["reduction"], errors["tight"], statuses["tight"],
            tight.rebuilds,
        ),
        "clarabel_prebuilt_default": _peer_entry(
            timing["default"], timing["reduction"], errors["default"], statuses["default"],
            default.rebuilds,
        ),
    }  # fmt: skip


def trajectory_run(name: str, load, points: int, settings) -> dict:
    """The trajectory of arm ``name`` by every path (see the module docstring)."""
    probe = load()
    names = tuple(probe.joints)
    play, length = _scales(probe)
    configurations = trajectory(probe, points)
    closed = ClosedForm(probe)
    force = tool_load(probe).force
    reference = np.array([closed.torsors(q, force)[0] for q in configurations])
    out: dict = {
        "points": points,
        "joints": len(names),
        "reference": "closed form",
        "reference_arithmetic_rel_play": max(
            closed.arithmetic_check(q, force, play, length)
            for q in configurations[:: max(1, points // 10)]
        ),
    }

    def many():
        mechanism = load()
        t0 = time.perf_counter()
        batch = mechanism.solve_many(configurations=configurations, errors="return", progress=False)
        wall = time.perf_counter() - t0
        torsors = np.stack([batch.torsors(n) for n in names], axis=1)
        return wall, batch, torsors

    runs = _repeat(many, settings.arm_budget_s, settings.arm_repeats)
    walls = [r[0] for r in runs]
    _, batch, torsors = runs[-1]
    out["solve_many"] = {
        "wall_s": float(np.median(walls)),
        "walls_s": walls,
        "per_point_s": float(np.median(walls)) / points,
        "ok": int(np.sum(batch.ok)),
        "statuses": _count(batch.statuses),
        "error_rel_play": _worst(relative_errors(torsors, reference, play, length)),
    }

    def loop():
        mechanism = load()
        errors, ok, times = [], 0, []
        t0 = time.perf_counter()
        for q, ref in zip(configurations, reference):
            t1 = time.perf_counter()
            equilibrium = mechanism.solve(q=q)
            times.append(time.perf_counter() - t1)
            ok += bool(equilibrium.ok)
            errors.append(
                relative_errors(_equilibrium_torsors(equilibrium, names), ref, play, length)
            )
        return time.perf_counter() - t0, ok, errors, times

    runs = _repeat(loop, settings.arm_budget_s, settings.arm_repeats)
    walls = [r[0] for r in runs]
    out["solve_loop"] = {
        "wall_s": float(np.median(walls)),
        "walls_s": walls,
        "per_point_s": float(np.median(walls)) / points,
        "median_point_s": float(np.median(runs[-1][3])),
        "ok": runs[-1][1],
        "error_rel_play": _worst(runs[-1][2]),
    }

    from clearance_pin.equilibrium.prepared import prepared_geometry

    mechanism = load()
    loads = mechanism.resolve_loads(None)

    def problem_of(q):
        prepared = prepared_geometry(mechanism, q)
        return prepared, prepared.problem(loads)

    gc.collect()
    t0 = time.perf_counter()
    peer = _peer_loop(configurations, problem_of, names, reference, play, length, math.inf)
    peer_wall = time.perf_counter() - t0
    for key, entry in peer.items():
        entry["wall_s"] = entry["total_s"]  # its own parts: reduction + this peer's Clarabel
        entry["per_point_s"] = entry["total_s"] / points
        entry["loop_wall_s_both_peers"] = peer_wall
        out[key] = entry
    out["closed_form_near_threshold"] = closed.near_threshold
    out["ratios"] = _ratios(out, "wall_s")
    return out


def loads_run(name: str, load, sizes, settings) -> dict:
    """Tool-load cases of arm ``name`` at the nominal configuration by every path."""
    mechanism = load()
    mechanism.solve()
    names = tuple(mechanism.joints)
    play, length = _scales(mechanism)
    closed = ClosedForm(mechanism)
    tool = tool_load(mechanism)
    forces = tool_forces(mechanism, max(sizes), settings.seed)
    reference = closed.torsors(mechanism.q_nominal, forces)
    cases: list = []

    def first(count: int) -> list:
        """The first ``count`` load cases (built when first needed)."""
        cases.extend(
            (PointForce(tool.link, force=f, point=tool.point),) for f in forces[len(cases) : count]
        )
        return cases[:count]

    def each():
        """Every load case in order, built when first needed."""
        for k in range(len(forces)):
            if k == len(cases):
                first(min(len(forces), 2 * k + 16))
            yield cases[k]

    out: dict = {
        "reference": "closed form",
        "reference_arithmetic_rel_play": closed.arithmetic_check(
            mechanism.q_nominal, forces[:20], play, length
        ),
        "joints": len(names),
        "sizes": {},
    }

    # solve_many on growing sizes while the previous one predicts the next within the budget
    previous = None
    for size in sorted(sizes):
        if previous is not None and previous * size > settings.arm_budget_s:
            out["sizes"][str(size)] = {"skipped": f"predicted {previous * size:.0f} s"}
            continue

        chosen = first(size)

        def many(chosen=chosen):
            built = load()  # a new built mechanism per repeat: nothing carried between repeats
            built.solve()
            t0 = time.perf_counter()
            batch = built.solve_many(chosen, errors="return", progress=False)
            wall = time.perf_counter() - t0
            torsors = np.stack([batch.torsors(n) for n in names], axis=1)
            return wall, batch, torsors

        runs = _repeat(many, settings.arm_budget_s, settings.arm_repeats)
        walls = [r[0] for r in runs]
        _, batch, torsors = runs[-1]
        per_case = float(np.median(walls)) / size
        previous = per_case
        out["sizes"][str(size)] = {
            "wall_s": float(np.median(walls)),
            "walls_s": walls,
            "per_case_s": per_case,
            "cases_per_s": 1.0 / per_case,
            "ok": int(np.sum(batch.ok)),
            "statuses": _count(batch.statuses),
            "error_rel_play": _worst(relative_errors(torsors, reference[:size], play, length)),
        }
    done = [int(s) for s, e in out["sizes"].items() if "wall_s" in e]
    headline = out["sizes"][str(max(done))]
    out["solve_many"] = {**headline, "cases": max(done), "median_s": headline["per_case_s"]}

    # a loop of solve on the first cases, within the budget
    times, errors, ok = [], [], 0
    started = time.perf_counter()
    for k, case in enumerate(each()):
        t0 = time.perf_counter()
        equilibrium = mechanism.solve(case)
        times.append(time.perf_counter() - t0)
        ok += bool(equilibrium.ok)
        errors.append(
            relative_errors(_equilibrium_torsors(equilibrium, names), reference[k], play, length)
        )
        if time.perf_counter() - started > settings.arm_loop_budget_s and k + 1 >= 20:
            break
    out["solve_loop"] = {
        "solves": len(times),
        "median_s": float(np.median(times)),
        "mean_s": float(np.mean(times)),
        "ok": ok,
        "error_rel_play": _worst(errors),
    }

    from clearance_pin.equilibrium.prepared import prepared_geometry

    prepared = prepared_geometry(mechanism)

    def problem_of(case):
        return prepared, prepared.problem(mechanism.resolve_loads(case))

    peer = _peer_loop(
        each(), problem_of, names, reference, play, length, settings.arm_loop_budget_s
    )
    for key, entry in peer.items():
        # the expert's peer computes the objective of a load by one product: its time per case
        # is Clarabel's (update, solve, torsors); the library's reduction is reported beside it
        entry["median_s"] = entry["clarabel_median_s"]
        out[key] = entry
    out["closed_form_near_threshold"] = closed.near_threshold
    out["ratios"] = _ratios(out, "median_s")
    return out


def _count(statuses) -> dict:
    out: dict = {}
    for status in statuses:
        out[status] = out.get(status, 0) + 1
    return out


def _ratios(entries: dict, key: str) -> dict:
    """Time ratios other / ours for ours in (solve_many, solve_loop) (> 1: ours faster)."""
    out = {}
    for mine in ("solve_many", "solve_loop"):
        row = {}
        for other in ("clarabel_prebuilt", "clarabel_prebuilt_default", "solve_loop"):
            if other == mine:
                continue
            row[other] = entries[other][key] / entries[mine][key]
        out[mine] = row
    return out


def arm_benchmarks(names, settings, log=print) -> dict:
    """Every arm of ``names``: trajectory and load cases; arms whose model is missing are noted."""
    out = {}
    for name in names:
        load = loader(name)
        if load is None:
            out[name] = {"skipped": "example-robot-data is not installed"}
            log(f"arm {name}: skipped (example-robot-data is not installed)")
            continue
        started = time.perf_counter()
        entry = {
            "trajectory": trajectory_run(name, load, settings.arm_points, settings),
            "loads": loads_run(name, load, settings.arm_loads, settings),
        }
        entry["wall_s"] = time.perf_counter() - started
        out[name] = entry
        log(describe(name, entry))
    return out


def describe(name: str, entry: dict) -> str:
    """Two lines of one arm's results."""
    t, c = entry["trajectory"], entry["loads"]
    peer_t, peer_c = t["clarabel_prebuilt"], c["clarabel_prebuilt"]
    return (
        f"arm {name}: trajectory {t['points']} points: solve_many {t['solve_many']['wall_s']:.3f} s"
        f" [{t['solve_many']['error_rel_play']:.0e}], loop of solve {t['solve_loop']['wall_s']:.3f}"
        f" s, prebuilt Clarabel {peer_t['wall_s']:.3f} s (reduction "
        f"{peer_t['reduction_median_s'] * 1e3:.3f} ms + Clarabel "
        f"{peer_t['clarabel_median_s'] * 1e3:.3f} ms per point) [{peer_t['error_rel_play']:.0e}]"
        f"\n  load cases: solve_many {c['solve_many']['cases']} cases "
        f"{c['solve_many']['per_case_s'] * 1e3:.3f} ms each ({c['solve_many']['cases_per_s']:.0f}"
        f"/s) [{c['solve_many']['error_rel_play']:.0e}], loop of solve "
        f"{c['solve_loop']['median_s'] * 1e3:.3f} ms, prebuilt Clarabel "
        f"{peer_c['clarabel_median_s'] * 1e3:.3f} ms (+ reduction "
        f"{peer_c['reduction_median_s'] * 1e3:.3f} ms) [{peer_c['error_rel_play']:.0e}]"
    )
