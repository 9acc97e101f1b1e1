"""The clearance envelope (issue 13): closed forms, an independent formulation, every model.

Which checks are independent of the envelope's own code:

- closed forms written in this file (docs/method.md, "The clearance envelope"): the planar serial
  arm's disc of radius sum c_i; the pin in a bore, 2 c L / l across the arm and 2 c / l of tilt; a
  shaft on a ball and a journal, c sqrt(11/6) (Lagrange multipliers by hand, below);
- the four-bar against a rigid four-bar solved in plain numpy here (two circles' intersection):
  the linear range 4 r / (L4 |sin mu|) and the exact extremes, the rigid four-bar with coupler
  L3 -/+ 4 r, for the numbers of issue 13;
- the duality on the spatial RSSR and the Stewart platform: support values against a convex
  programme of tests/oracle.py's own admissible set (its constraint rows, cvxpy + Clarabel: the
  maximum of d . delta, no equilibrium in it) and against the oracle's own equilibrium;
- the four-bar coupler's parallelogram (no multiplier certificate there: the direction grid
  decides) against the vertices of a polygon of 3600 oracle support lines.

The remaining checks (every bundled and corpus model certified to 1e-6, bounds that contain
every support point, the certificate refusing a state that is not the maximum, loads inside the
envelope, the command) test the envelope against the equilibrium engine it is built on.
"""

from __future__ import annotations

import json
import math
import warnings
from pathlib import Path

import cvxpy as cp
import numpy as np
import pinocchio as pin
import pytest
from oracle import Oracle

import clearance_pin
from clearance_pin import ArgumentError, NotFoundError, PointForce, Torque
from clearance_pin.envelope import envelope
from clearance_pin.envelope.certificate import multiplier_bound
from clearance_pin.envelope.loads import LoadSpread, deviation_range, usage
from clearance_pin.equilibrium.outputs import leaf_links
from clearance_pin.json_documents import schema

ROOT = Path(__file__).resolve().parent.parent
MODELS = sorted((ROOT / "models").glob("*.urdf"))
DATA = sorted((ROOT / "tests" / "data").glob("*.urdf"))
GAP = 1e-6


def revolute(name: str, parent: str, child: str, xyz: str, axis: str = "0 0 1") -> str:
    return (
        f'<joint name="{name}" type="revolute"><parent link="{parent}"/><child link="{child}"/>'
        f'<origin xyz="{xyz}"/><axis xyz="{axis}"/>'
        '<limit lower="-7" upper="7" effort="1" velocity="1"/></joint>'
    )


# -- planar serial arm: a disc of radius sum c_i ------------------------------------------------
ARM_PLAYS = (30e-6, 20e-6, 15e-6)  # [m] radial plays of the three pins
ARM_LENGTHS = (0.3, 0.25, 0.15)  # [m]


def planar_arm() -> clearance_pin.Mechanism:
    """Three links in series on planar pins, all driven (docs/model-format.md)."""
    links = ["base", "l1", "l2", "l3", "tip"]
    joints = [
        revolute("j1", "base", "l1", "0 0 0"),
        revolute("j2", "l1", "l2", f"{ARM_LENGTHS[0]} 0 0"),
        revolute("j3", "l2", "l3", f"{ARM_LENGTHS[1]} 0 0"),
        f'<joint name="tip_mount" type="fixed"><parent link="l3"/><child link="tip"/>'
        f'<origin xyz="{ARM_LENGTHS[2]} 0 0"/></joint>',
    ]
    block = "".join(
        f'<joint name="j{i + 1}" type="planar_revolute" radial_clearance="{c}" driven="true" '
        f'q="{q}"/>'
        for i, (c, q) in enumerate(zip(ARM_PLAYS, (0.4, -0.9, 0.5)))
    )
    text = (
        '<?xml version="1.0"?><robot name="planar_arm">'
        + "".join(f'<link name="{n}"/>' for n in links)
        + "".join(joints)
        + f"<clearance_pin>{block}</clearance_pin></robot>"
    )
    return clearance_pin.loads(text)


def test_planar_arm_tip_envelope_is_a_disc_of_radius_the_sum_of_the_plays():
    arm = planar_arm()
    radius = sum(ARM_PLAYS)
    env = envelope(arm, "tip")
    translation = env.kinds["translation"]
    assert translation.dimension == 2
    assert np.allclose(np.abs(translation.basis.T), [[1, 0, 0], [0, 1, 0]], atol=1e-12)
    top = env.max_translation
    assert top.certified and top.gap <= GAP
    assert top.lower == pytest.approx(radius, rel=1e-10)
    assert top.upper == pytest.approx(radius, rel=1e-8)
    assert env.kinds["rotation"].dimension == 0  # every pin is driven: no rotation
    rng = np.random.default_rng(3)
    for angle in rng.uniform(0, 2 * np.pi, 5):
        d = np.array([math.cos(angle), math.sin(angle), 0.0])
        assert env.support(d) == pytest.approx(radius, rel=1e-10)
    assert env.range([0, 0, 1]) == (0.0, 0.0) or max(map(abs, env.range([0, 0, 1]))) < 1e-15
    boundary = env.boundary("translation", level=2)
    assert np.allclose(np.linalg.norm(boundary.points, axis=1), radius, rtol=1e-10)


def test_planar_arm_under_any_tip_force_moves_by_the_sum_along_it():
    arm = planar_arm()
    radius = sum(ARM_PLAYS)
    rng = np.random.default_rng(11)
    for _ in range(6):
        angle, size = rng.uniform(0, 2 * np.pi), rng.uniform(0.1, 500.0)
        force = size * np.array([math.cos(angle), math.sin(angle), 0.0])
        eq = arm.solve(loads=[PointForce("tip", force=force)])
        moved, _ = eq.frame_displacement("tip")
        assert np.allclose(moved, radius * force / size, rtol=0, atol=1e-15)


# -- four-bar: 4 r / (L4 |sin mu|), exactly the rigid four-bar with coupler L3 -/+ 4 r ------------
L1, L2, L3, L4 = 0.100, 0.040, 0.120, 0.080  # [m]
THETA2, PLAY = math.radians(60.0), 50e-6


def rigid_four_bar(coupler: float) -> tuple[float, np.ndarray, np.ndarray, np.ndarray]:
    """(theta4, A, B, O4) of the rigid four-bar with this coupler length, the open branch
    (B above the line A O4): B is the intersection of the circles |B - A| = coupler and
    |B - O4| = L4."""
    a = L2 * np.array([math.cos(THETA2), math.sin(THETA2)])
    o4 = np.array([L1, 0.0])
    d = o4 - a
    distance = float(np.linalg.norm(d))
    along = (coupler**2 - L4**2 + distance**2) / (2.0 * distance)
    height = math.sqrt(coupler**2 - along**2)
    b = a + along * d / distance + height * np.array([-d[1], d[0]]) / distance
    return math.atan2(b[1] - o4[1], b[0] - o4[0]), a, b, o4


def four_bar() -> clearance_pin.Mechanism:
    """The four-bar of issue 13 (ground L1, crank L2 driven at 60 deg, coupler L3, rocker L4),
    a planar pin of radial play r in each of its four joints; pin B closes the loop."""
    theta4, a, b, _ = rigid_four_bar(L3)
    theta3 = math.atan2(b[1] - a[1], b[0] - a[0])
    links = ["ground", "crank", "coupler", "rocker", "coupler_B", "rocker_B"]
    text = (
        '<?xml version="1.0"?><robot name="four_bar_issue13">'
        + "".join(f'<link name="{n}"/>' for n in links)
        + revolute("crank_pivot", "ground", "crank", "0 0 0")
        + revolute("pin_A", "crank", "coupler", f"{L2} 0 0")
        + revolute("rocker_pivot", "ground", "rocker", f"{L1} 0 0")
        + f'<joint name="coupler_B_mount" type="fixed"><parent link="coupler"/>'
        f'<child link="coupler_B"/><origin xyz="{L3} 0 0"/></joint>'
        + f'<joint name="rocker_B_mount" type="fixed"><parent link="rocker"/>'
        f'<child link="rocker_B"/><origin xyz="{L4} 0 0"/></joint>'
        + "<clearance_pin>"
        + f'<joint name="crank_pivot" type="planar_revolute" radial_clearance="{PLAY}" '
        f'driven="true" q="{THETA2}"/>'
        + f'<joint name="pin_A" type="planar_revolute" radial_clearance="{PLAY}" '
        f'q="{theta3 - THETA2}"/>'
        + f'<joint name="rocker_pivot" type="planar_revolute" radial_clearance="{PLAY}" '
        f'q="{theta4}"/>' + '<loop_joint name="pin_B" type="planar_revolute" frame_a="rocker_B" '
        f'frame_b="coupler_B" radial_clearance="{PLAY}" axis="0 0 1"/>' + "</clearance_pin></robot>"
    )
    return clearance_pin.loads(text)


def test_four_bar_rigid_reference_matches_the_issue_numbers():
    theta4, a, b, o4 = rigid_four_bar(L3)
    coupler, rocker = b - a, b - o4
    mu = math.acos(float(coupler @ rocker) / (L3 * L4))  # transmission angle
    linear = 4 * PLAY / (L4 * abs(math.sin(mu)))
    low = rigid_four_bar(L3 - 4 * PLAY)[0] - theta4
    high = rigid_four_bar(L3 + 4 * PLAY)[0] - theta4
    assert round(linear, 9) == 3.442652e-3
    assert (round(min(low, high), 9), round(max(low, high), 9)) == (-3.445698e-3, 3.439620e-3)


def test_four_bar_rocker_range_linear_and_exact():
    mechanism = four_bar()
    theta4, a, b, o4 = rigid_four_bar(L3)
    assert mechanism.configure().q[2] == pytest.approx(theta4, abs=1e-12)
    mu = math.acos(float((b - a) @ (b - o4)) / (L3 * L4))
    linear = 4 * PLAY / (L4 * abs(math.sin(mu)))
    reach = sorted(rigid_four_bar(L3 + s * 4 * PLAY)[0] - theta4 for s in (-1, 1))
    env = envelope(mechanism, "rocker", exact=True)
    rotation = env.kinds["rotation"]
    assert rotation.dimension == 1 and abs(rotation.basis[2, 0]) == pytest.approx(1.0)
    low, high = rotation.world[2]
    assert (low, high) == (pytest.approx(-linear, rel=1e-10), pytest.approx(linear, rel=1e-10))
    # range() and support() of an envelope built with exact=True are the exact model's (they
    # returned the linear numbers): the rigid four-bar with coupler L3 -/+ 4r, asymmetric
    exact_range = env.range([0, 0, 1], "rotation")
    assert exact_range == (pytest.approx(reach[0], abs=1e-12), pytest.approx(reach[1], abs=1e-12))
    assert env.support([0, 0, -1], "rotation") == pytest.approx(-reach[0], abs=1e-12)
    linear_only = envelope(mechanism, "rocker", kinds=("rotation",))
    assert linear_only.range([0, 0, 1], "rotation") == (
        pytest.approx(-linear, rel=1e-10),
        pytest.approx(linear, rel=1e-10),
    )
    assert env.max_rotation.lower == pytest.approx(linear, rel=1e-10)
    assert env.max_rotation.gap == 0.0
    assert sorted(env.max_rotation.contacts) == sorted(
        ["crank_pivot:pin", "pin_A:pin", "rocker_pivot:pin", "pin_B:pin"]
    )
    exact = env.exact["rotation"]
    exact_low, exact_high = exact.world[2]
    assert exact_low == pytest.approx(reach[0], abs=1e-12)
    assert exact_high == pytest.approx(reach[1], abs=1e-12)
    assert exact.largest == pytest.approx(max(abs(reach[0]), abs(reach[1])), abs=1e-12)
    # every eccentricity along the coupler, a two-force member: pin A's play at the high end
    state = exact.state if exact.largest == abs(reach[1]) else None
    if state is not None:
        shift = state.torsor("pin_A")[1:3]
        direction = (b - a) / L3
        assert abs(shift[0] * direction[1] - shift[1] * direction[0]) < 1e-9 * PLAY


# -- a pin in a bore carrying an arm: 2 c L / l across the arm ---------------------------------
BORE_PLAY, ENGAGEMENT, ARM = 20e-6, 0.025, 0.2  # [m]: c, l, L (tip from the bore's centre)


def pin_in_bore(axial: float = 0.0) -> clearance_pin.Mechanism:
    text = (
        '<?xml version="1.0"?><robot name="pin_in_bore">'
        '<link name="housing"/><link name="pin"/><link name="tip"/>'
        + revolute("bore", "housing", "pin", "0 0 0", axis="1 0 0")
        + f'<joint name="tip_mount" type="fixed"><parent link="pin"/><child link="tip"/>'
        f'<origin xyz="{ARM} 0 0"/></joint>'
        + f'<clearance_pin><joint name="bore" type="revolute" radial_clearance="{BORE_PLAY}" '
        f'length="{ENGAGEMENT}" axial_clearance="{axial}" driven="true" q="0"/></clearance_pin>'
        + "</robot>"
    )
    return clearance_pin.loads(text)


def test_pin_in_bore_tip_reaches_2cL_over_l_across_the_arm():
    across = 2 * BORE_PLAY * ARM / ENGAGEMENT
    env = envelope(pin_in_bore(), "tip")
    translation = env.kinds["translation"]
    assert translation.dimension == 2
    assert np.allclose(np.abs(translation.basis[0]), 0.0, atol=1e-12)  # nothing along the axis
    assert env.max_translation.lower == pytest.approx(across, rel=1e-10)
    assert env.max_translation.upper <= across * (1 + GAP)
    for angle in np.linspace(0.1, 6.0, 5):
        d = np.array([0.0, math.cos(angle), math.sin(angle)])
        assert env.support(d) == pytest.approx(across, rel=1e-10)
    assert env.max_rotation.lower == pytest.approx(2 * BORE_PLAY / ENGAGEMENT, rel=1e-10)
    assert env.max_rotation.certified


def test_pin_in_bore_with_axial_play_is_a_cylinder():
    axial = 8e-6
    across = 2 * BORE_PLAY * ARM / ENGAGEMENT
    env = envelope(pin_in_bore(axial), "tip")
    assert env.kinds["translation"].dimension == 3
    assert env.range([1, 0, 0]) == (
        pytest.approx(-axial, rel=1e-10),
        pytest.approx(axial, rel=1e-10),
    )
    top = env.max_translation
    assert top.certified and top.gap <= GAP
    assert top.lower == pytest.approx(math.hypot(across, axial), rel=1e-9)


def test_shaft_on_a_ball_and_a_journal_closed_form():
    """models/younes_sphere_cylinder.urdf at the journal's centre (ball at I1, journal L = 40 mm
    at 200 mm, c = 0.1 mm both): with a ball offset a along the axis's normal and the journal's
    centre offset b, the journal ends ask 1.1 b + 0.1 a <= c, the ball u^2 + a^2 <= c^2;
    maximising u^2 + b^2 by hand gives a = -c / 12, b = 11 c / 12, the largest displacement
    c sqrt(11 / 6), reached on a circle about the axis (no unique maximiser)."""
    mechanism = clearance_pin.load(ROOT / "models" / "younes_sphere_cylinder.urdf")
    c = 1e-4
    env = envelope(mechanism, "shaft_I2")
    top = env.max_translation
    assert top.certified and top.gap <= GAP
    assert top.lower == pytest.approx(c * math.sqrt(11 / 6), rel=1e-7)
    assert top.upper >= c * math.sqrt(11 / 6) * (1 - 1e-12)
    rotation = env.kinds["rotation"]
    assert rotation.free.shape[1] == 1 and abs(rotation.free[0, 0]) == pytest.approx(1.0)
    assert env.support([1, 0, 0], "rotation") == math.inf  # the shaft's spin
    assert env.max_rotation.lower == pytest.approx(2 * c / 0.22, rel=1e-9)  # tilt about the ball


# -- duality on spatial parallel mechanisms, against the oracle's own formulation ----------------
def oracle_support(mechanism, link: str, d: np.ndarray, kind: str) -> float:
    """max d . delta over the admissible states of tests/oracle.py (its rows, its closure), as a
    convex programme of its own: no equilibrium, no load. As the oracle's own solve does, the
    equalities are eliminated (its closure basis) and the motions no contact sees left out (d is
    taken off the directions they move)."""
    oracle = Oracle(mechanism)
    model = mechanism.model
    frame = model.getFrameId(link)
    body = model.frames[frame].parentJoint
    basis = oracle.closure_basis()
    seen = np.vstack([c.rows / c.bound for c in oracle.contacts]) @ basis
    _, singular, vt = np.linalg.svd(seen, full_matrices=True)
    basis = basis @ vt[: int(np.sum(singular > 1e-10 * singular[0]))].T
    w = cp.Variable(basis.shape[1])
    constraints = []
    for contact in oracle.contacts:
        image = (contact.offset + contact.rows @ basis @ w) / contact.bound
        if contact.shape == "norm":
            constraints.append(cp.norm(image, 2) <= 1.0)
        else:
            constraints.append(cp.abs(image[0]) <= 1.0)
    twist = oracle.twist_map[body] @ basis
    p = oracle.oMf[frame].translation
    skew = np.array([[0.0, -p[2], p[1]], [p[2], 0.0, -p[0]], [-p[1], p[0], 0.0]])
    deviation = twist[:3] - skew @ twist[3:] if kind == "translation" else twist[3:]
    scale = float(np.linalg.norm(d @ deviation))
    problem = cp.Problem(cp.Maximize((d @ deviation / scale) @ w), constraints)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        problem.solve(
            solver="CLARABEL", tol_gap_abs=1e-11, tol_gap_rel=1e-11, tol_feas=1e-11, max_iter=400
        )
    assert problem.status in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE), problem.status
    return float(problem.value) * scale


@pytest.mark.parametrize("name", ["rssr", "stewart_6ups"])
def test_support_function_is_the_equilibrium_under_the_output_wrench(name):
    mechanism = clearance_pin.load(ROOT / "tests" / "data" / f"{name}.urdf")
    link = "rocker" if name == "rssr" else "platform"
    env = envelope(mechanism, link)
    rng = np.random.default_rng(5)
    oracle = Oracle(mechanism)
    for kind in ("translation", "rotation"):
        part = env.kinds[kind]
        for _ in range(3):
            d = part.basis @ rng.normal(size=part.dimension)
            d /= np.linalg.norm(d)
            ours = env.support(d, kind)
            direct = oracle_support(mechanism, link, d, kind)
            assert ours == pytest.approx(direct, rel=1e-6), (kind, d)
            load = PointForce(link, force=d) if kind == "translation" else Torque(link, torque=d)
            equilibrium = oracle.solve([load])
            assert equilibrium.status == "optimal"
            assert -equilibrium.energy == pytest.approx(ours, rel=1e-6)
            assert ours <= part.maximum.upper * (1 + 1e-12)
        assert part.maximum.certified and part.maximum.gap <= GAP


# -- the direction grid where no certificate applies: the four-bar coupler's parallelogram ------
def test_direction_grid_bound_contains_a_brute_force_polygon():
    mechanism = clearance_pin.load(ROOT / "models" / "four_bar.urdf")
    certified = envelope(mechanism, "coupler_B", kinds=("translation",)).max_translation
    env = envelope(mechanism, "coupler_B", kinds=("translation",), certificate=False)
    top = env.max_translation
    assert top.method == "direction grid" and top.certified and top.gap <= GAP
    assert certified.lower <= top.upper and top.lower <= certified.upper
    oracle = Oracle(mechanism)
    angles = np.linspace(0, 2 * np.pi, 3600, endpoint=False)
    normals = np.column_stack([np.cos(angles), np.sin(angles)])
    values = []
    for n in normals[::40]:  # the oracle's equilibria on a coarse fan (cvxpy is slow)
        d = np.array([n[0], n[1], 0.0])
        values.append(-oracle.solve([PointForce("coupler_B", force=d)]).energy)
    coarse = normals[::40]
    # the polygon of the oracle's support lines contains the envelope: its vertices bound it
    vertices = []
    for i in range(len(coarse)):
        j = (i + 1) % len(coarse)
        vertices.append(np.linalg.solve(np.array([coarse[i], coarse[j]]), [values[i], values[j]]))
    outer = max(np.linalg.norm(v) for v in vertices)
    assert top.lower <= outer * (1 + 1e-9)
    assert top.upper <= outer * (1 + 1e-9)
    # and the largest support value is below the maximum
    assert max(values) <= top.upper * (1 + 1e-9)


# -- every bundled model and the corpus: certified to 1e-6 --------------------------------------
def corpus_cases() -> list[tuple[str, str]]:
    """(model file, output): the first two leaf links of every bundled and test-data model."""
    cases = []
    for path in [*MODELS, *DATA]:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", clearance_pin.ClearancePinWarning)
            leaves = leaf_links(clearance_pin.load(path).model)[:2]
        cases.extend((str(path.relative_to(ROOT)), leaf) for leaf in leaves)
    return cases


LOADED: dict[str, clearance_pin.Mechanism] = {}


def _mechanism(path: str) -> clearance_pin.Mechanism:
    if path not in LOADED:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", clearance_pin.ClearancePinWarning)
            LOADED[path] = clearance_pin.load(ROOT / path)
    return LOADED[path]


def check_certified(mechanism, output) -> None:
    env = envelope(mechanism, output)
    for kind, part in env.kinds.items():
        top = part.maximum
        assert top.certified and top.gap <= GAP, (output, kind, top.gap, top.method)
        assert top.lower <= top.upper
        if top.state is not None:
            assert top.state.ok
            # the lower bound is the state's own deviation, read again from the equilibrium
            again = env.output.deviation(top.state, kind)
            inside = part.basis @ (part.basis.T @ again)
            assert np.linalg.norm(inside) == pytest.approx(top.lower, rel=1e-12)
            # the deviation has nothing outside the span and the free directions
            whole = np.hstack([part.basis, part.free])
            off = again - whole @ np.linalg.lstsq(whole, again, rcond=None)[0]
            assert np.linalg.norm(off) <= 1e-9 * max(top.lower, 1e-300) + 1e-18
        values = part.evaluations.values
        assert np.all(values <= top.upper * (1 + 1e-9))
        assert np.all(np.linalg.norm(part.evaluations.points, axis=1) <= top.upper * (1 + 1e-9))


@pytest.mark.parametrize(("path", "output"), corpus_cases())
def test_every_model_is_certified(path, output):
    check_certified(_mechanism(path), output)


def test_corpus_three_bearings_and_slider_cranks_are_certified():
    import test_corpus_slider_crank as slider_crank
    import test_corpus_three_bearings as three_bearings

    for offset in (0.0, three_bearings.MISALIGNMENT):
        shaft = clearance_pin.loads(three_bearings.model_text(offset))
        for leaf in leaf_links(shaft.model)[:1]:
            check_certified(shaft, leaf)
    for variant in ("tree", *slider_crank.VARIANTS):
        for angle in slider_crank.ANGLES_DEG[:2]:
            crank = clearance_pin.loads(slider_crank.model_text(variant, math.radians(angle)))
            check_certified(crank, "slider")


def test_corpus_robots_are_certified():
    """The UR5 and the Panda of test_corpus_robots.py (skipped without example-robot-data)."""
    robots = pytest.importorskip("test_corpus_robots")
    for name, (_, _, tool) in sorted(robots.ROBOTS.items()):
        check_certified(robots.mechanism(name), tool)


# -- the certificate does not certify what is not the maximum -----------------------------------
def test_multiplier_certificate_never_falls_below_the_maximum():
    from clearance_pin.envelope.output import resolve_output
    from clearance_pin.envelope.state_space import build_state_space

    mechanism = clearance_pin.load(ROOT / "models" / "arm_6r.urdf")
    env = envelope(mechanism, "tool", kinds=("translation",))
    top = env.max_translation
    configuration = mechanism.configure()
    space = build_state_space(
        mechanism, configuration, resolve_output(mechanism, "tool", configuration)
    )
    part = env.kinds["translation"]
    projected = space.projected_map("translation", part.basis)
    rng = np.random.default_rng(2)
    for _ in range(6):
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        state = mechanism.solve(loads=[PointForce("tool", force=d)], gravity=False)
        moved = np.linalg.norm(env.output.deviation(state, "translation"))
        bound = multiplier_bound(space, projected, state, moved)
        assert bound >= top.lower * (1 - 1e-12)


# -- loads ---------------------------------------------------------------------------------------
def test_loads_stay_inside_the_envelope_and_the_usage_reads_the_boundary():
    mechanism = clearance_pin.load(ROOT / "models" / "four_bar.urdf")
    env = envelope(mechanism, "coupler_B")
    spread = LoadSpread(
        PointForce("coupler", force=[0, -40, 0], point=[0.09, 0, 0]), (0.5, 1.5), spread=0.4
    )
    found = deviation_range(mechanism, "coupler_B", spread, fixed=[Torque("rocker", [0, 0, -2])])
    assert len(found.cases) == 3 * (1 + 6 + 12 + 18 + 24)
    assert found.largest <= env.max_translation.upper * (1 + 1e-9)
    for axis in np.eye(3):
        low, high = found.along(axis)
        env_low, env_high = env.range(axis)
        assert env_low - 1e-15 <= low <= high <= env_high + 1e-15
    # one force alone: its size does not move the parts (the potential is linear)
    alone = LoadSpread(PointForce("coupler", force=[0, -40, 0]), (0.2, 5.0))
    sized = deviation_range(mechanism, "coupler_B", alone)
    assert np.allclose(sized.deviations, sized.deviations[0], atol=1e-18)
    # a support point is on the boundary: gauge 1; half of it: 1/2
    point = env.max_translation.deviation
    on = usage(env, point)
    assert on.gauge[0] == pytest.approx(1.0, rel=1e-6) and on.gauge[1] <= 1 + 1e-6
    half = usage(env, 0.5 * point)
    assert half.gauge[0] == pytest.approx(0.5, rel=1e-6)
    assert half.share == pytest.approx(
        0.5 * point @ point / np.linalg.norm(point) / env.max_translation.upper, rel=1e-9
    )
    equilibrium = mechanism.solve()
    used = usage(env, equilibrium)
    assert 0.0 < used.gauge[0] <= used.gauge[1] * (1 + 1e-12) <= 1 + 1e-9
    assert used.support_fraction <= used.gauge[1] + 1e-9


# -- exact model on the arm, timing, errors, command ---------------------------------------------
def test_arm_tool_envelope_exact_and_timing():
    mechanism = clearance_pin.load(ROOT / "models" / "arm_6r.urdf")
    mechanism.solve()  # loading and the first solve are not the envelope's
    env = envelope(mechanism, "tool", exact=True)
    assert env.max_translation.certified and env.max_rotation.certified
    assert env.timings["translation"] + env.timings["rotation"] < 3.0  # target < 1 s, shared CPU
    for kind in ("translation", "rotation"):
        exact = env.exact[kind]
        assert exact.state.formulation == "exact" and exact.state.ok
        # second order: the exact extremes differ from the linear ones by (rotation)^2 terms
        assert abs(exact.largest - exact.linear_largest) <= 1e-2 * exact.linear_largest
        assert np.all(np.abs(exact.world - exact.linear_world) <= 1e-2 * exact.linear_largest)


def test_bad_arguments_name_the_problem():
    mechanism = clearance_pin.load(ROOT / "models" / "four_bar.urdf")
    with pytest.raises(NotFoundError, match="frame"):
        envelope(mechanism, "no_such_frame")
    with pytest.raises(NotFoundError, match="link"):
        envelope(mechanism, "nolink@[0 0 0]")
    with pytest.raises(ArgumentError, match="ground"):
        envelope(mechanism, "ground")
    with pytest.raises(ArgumentError, match="kind"):
        envelope(mechanism, "rocker", kinds=("twist",))
    with pytest.raises(ArgumentError, match="tol"):
        envelope(mechanism, "rocker", tol=0.0)
    with pytest.raises(ArgumentError, match="output"):
        envelope(mechanism, ("rocker", (0, 1)))
    env = envelope(mechanism, "rocker@[0.05 0 0]", kinds=("rotation",))
    with pytest.raises(ArgumentError, match="direction"):
        env.support([0, 0, 0], "rotation")
    with pytest.raises(ArgumentError, match="kind"):
        env.support([1, 0, 0], "translation")


def test_point_of_a_link_is_the_frame_at_that_point():
    mechanism = clearance_pin.load(ROOT / "models" / "four_bar.urdf")
    frame = envelope(mechanism, "rocker_B", kinds=("translation",))
    point = envelope(mechanism, "rocker@[0.12 0 0]", kinds=("translation",))
    assert point.max_translation.lower == pytest.approx(frame.max_translation.lower, rel=1e-12)
    assert np.allclose(point.output.position, frame.output.position, atol=1e-15)


def test_command_writes_json_and_a_plot(tmp_path):
    import argparse

    from clearance_pin.envelope import command

    parser = argparse.ArgumentParser(prog="clearance-pin")
    command.register(parser.add_subparsers(dest="command"))
    target = tmp_path / "fb.json"
    picture = tmp_path / "fb.png"
    args = parser.parse_args(
        ["envelope", str(ROOT / "models" / "four_bar.urdf"), "--output", "rocker",
         "--json", str(target), "--plot", str(picture)]
    )  # fmt: skip
    assert args.run(args) == 0
    document = json.loads(target.read_text())
    jsonschema = pytest.importorskip("jsonschema")
    jsonschema.validate(document, schema("envelope"))
    assert document["schema"] == "clearance_pin/envelope/1"
    rotation = document["envelopes"][0]["kinds"]["rotation"]
    assert rotation["certified"] and rotation["relative_gap"] <= GAP
    # the same numbers as the library's
    kind = clearance_pin.load(ROOT / "models" / "four_bar.urdf").envelope("rocker").kinds
    assert rotation["largest_upper_rad"] == pytest.approx(kind["rotation"].maximum.upper, rel=1e-9)
    if pytest.importorskip("matplotlib"):
        assert picture.stat().st_size > 10_000


def test_frame_axes_of_a_turned_frame():
    mechanism = clearance_pin.load(ROOT / "models" / "four_bar.urdf")
    env = envelope(mechanism, "rocker_B", kinds=("translation",))
    axes = env.output.axes
    for i in range(3):
        assert env.kinds["translation"].frame[i, 1] == pytest.approx(
            env.support(axes[:, i]), rel=1e-12
        )
    assert np.allclose(
        axes, mechanism.configure().oMf[mechanism.model.getFrameId("rocker_B")].rotation
    )
    assert isinstance(pin.SE3.Identity(), pin.SE3)


# -- the grid's cell bound on shapes of known support -------------------------------------------
def test_cell_bound_of_a_disc_is_the_circumscribed_polygon():
    from clearance_pin.envelope.cells import cell_bounds, circle

    for count in (8, 16, 360):
        directions, arcs = circle(count)
        bounds = cell_bounds(directions, np.full(count, 2.0), arcs)
        assert np.allclose(bounds, 2.0 / math.cos(math.pi / count), rtol=1e-12)


def test_cell_bound_of_a_cube_is_exact_in_a_corner_cone_and_valid_elsewhere():
    from clearance_pin.envelope.cells import cell_bounds, icosphere

    directions, triangles = icosphere(2)
    support = np.abs(directions).sum(axis=1)  # the cube [-1, 1]^3: h(d) = |d|_1
    bounds = cell_bounds(directions, support, triangles)
    # every cell bounds the cube's points in its cone: the corners' norm sqrt(3) where it holds
    # one, exactly so when the whole cell lies in that corner's normal cone (its octant)
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    exact = 0
    for corner in corners:
        u = corner / np.linalg.norm(corner)
        inside = [
            i
            for i, t in enumerate(triangles)
            if np.all(np.linalg.solve(directions[t].T, u) >= -1e-12)
        ]
        assert inside and all(bounds[i] >= math.sqrt(3.0) * (1 - 1e-12) for i in inside)
        for i in inside:
            if np.all(directions[triangles[i]] * corner > 0.0):
                assert bounds[i] == pytest.approx(math.sqrt(3.0), rel=1e-12)
                exact += 1
    assert exact >= 8


def test_the_envelope_says_what_moves_the_output_at_its_largest():
    """The 6R arm's tool: each joint's share of the deviation that reaches the largest (the
    library's contributions of that state, so a self-consistency check: they sum to the
    certified extreme's deviation); a point that is no frame and a loop give none."""
    mechanism = clearance_pin.load(ROOT / "models" / "arm_6r.urdf")
    env = envelope(mechanism, "tool")
    for kind in ("translation", "rotation"):
        shares = env.contributors(kind)
        assert len(shares) == 6
        total = sum(shares.values())
        assert total == pytest.approx(env.kinds[kind].maximum.deviation, abs=1e-12)
    assert "what moves it there" in env.table()
    loop = clearance_pin.load(ROOT / "models" / "four_bar.urdf")
    assert envelope(loop, "rocker", kinds=("translation",)).contributors("translation") == {}
