"""Tolerance sweeps of a prismatic driven joint: a slider-crank driven at its slider and a leg of
the 6-UPS Stewart platform (tests/data/stewart_6ups.urdf), swept in metres.

References, none of them from the tolerance package:

- the slider-crank's closed form theta2(s) and its derivatives with respect to r2, r3 (derived in
  :func:`crank_angle` and :func:`crank_sensitivities`);
- central finite differences of the outputs, each deviation applied by editing the joint origin
  in the URDF text and re-loading the model, the loops closed by ``Mechanism.configure`` with the
  driven joint at the swept value;
- for the Stewart platform, the forward kinematics (Newton on the six leg lengths) and the implicit
  differentiation of the leg-length equations in plain numpy, from the joint origins of the file.
"""

from __future__ import annotations

import json
import math
import re
import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import clearance_pin
from clearance_pin.cli import main as cli_main
from clearance_pin.errors import ArgumentError, ClearancePinError, SuspectValueWarning
from clearance_pin.tolerance.sweep import (
    closed_configuration,
    cycle_maximum,
    driven_joint,
    plot_sweep,
    step_limit,
    sweep,
)

DATA = Path(__file__).resolve().parent / "data"
R2, R3 = 0.05, 0.12  # crank and rod [m]
S_NOMINAL = 0.14  # slider position in the file [m]
HALF_R2, HALF_R3 = 5e-5, 7e-5  # half tolerances [m]
LIMITS = (0.075, 0.165)  # URDF limits of the slider [m]; dead centres at r3 - r2, r3 + r2
H = 1e-5  # finite-difference step [m]: truncation (H / 0.05 m)^2 ~ 4e-8, round-off ~ 1e-9


# -- the slider-crank driven at its slider ------------------------------------------------------
def crank_angle(s: float, r2: float = R2, r3: float = R3) -> float:
    """Crank angle theta2 [rad] with the slider at ``s`` [m], crank above the guide.

    Crank pivot O at the origin, pin A = r2 (cos theta, sin theta), slider pin B = (s, 0) on the
    x axis; the rod closes the loop, |B - A| = r3:
        (s - r2 cos theta)^2 + (r2 sin theta)^2 = r3^2
        F(theta, s, r2, r3) = s^2 - 2 s r2 cos theta + r2^2 - r3^2 = 0,
    so cos theta = (s^2 + r2^2 - r3^2) / (2 s r2), theta in (0, pi) on the file's branch.
    """
    return math.acos((s * s + r2 * r2 - r3 * r3) / (2.0 * s * r2))


def crank_sensitivities(s: float) -> np.ndarray:
    """(d theta2/d r2, d theta2/d r3) [rad/m] at a fixed slider position ``s`` [m].

    Implicit differentiation of F = 0 above, s held by the drive:
        F_theta = 2 s r2 sin theta,  F_r2 = 2 r2 - 2 s cos theta,  F_r3 = -2 r3,
        d theta/d r2 = -F_r2 / F_theta = (s cos theta - r2) / (s r2 sin theta),
        d theta/d r3 = -F_r3 / F_theta = r3 / (s r2 sin theta).
    """
    theta = crank_angle(s)
    denominator = s * R2 * math.sin(theta)
    return np.array([(s * math.cos(theta) - R2) / denominator, R3 / denominator])


def slider_driven_urdf(r2: float = R2, r3: float = R3) -> str:
    """The slider-crank with the slider on a driven prismatic joint of the tree, the crank and
    the rod passive, the loop cut at the slider's pin B; dimensions r2 (pin A on the crank) and
    r3 (the rod's end B). Written as models/slider_crank.urdf is."""
    theta = crank_angle(S_NOMINAL, r2, r3)
    rod = math.atan2(-r2 * math.sin(theta), S_NOMINAL - r2 * math.cos(theta))
    return f"""<?xml version="1.0"?>
<robot name="slider_driven_crank">
  <link name="ground"/><link name="crank"/><link name="rod"/><link name="rod_end"/>
  <link name="slider"/>
  <joint name="crank_pivot" type="revolute">
    <parent link="ground"/><child link="crank"/><axis xyz="0 0 1"/>
    <limit lower="-7" upper="7" effort="100" velocity="10"/>
  </joint>
  <joint name="pin_A" type="revolute">
    <parent link="crank"/><child link="rod"/><origin xyz="{r2!r} 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-7" upper="7" effort="100" velocity="10"/>
  </joint>
  <joint name="rod_end_mount" type="fixed">
    <parent link="rod"/><child link="rod_end"/><origin xyz="{r3!r} 0 0"/>
  </joint>
  <joint name="slide" type="prismatic">
    <parent link="ground"/><child link="slider"/><axis xyz="1 0 0"/>
    <limit lower="{LIMITS[0]!r}" upper="{LIMITS[1]!r}" effort="100" velocity="1"/>
  </joint>
  <clearance_pin>
    <joint name="slide" driven="true" q="{S_NOMINAL!r}"/>
    <joint name="crank_pivot" q="{theta!r}"/>
    <joint name="pin_A" q="{rod - theta!r}"/>
    <loop_joint name="pin_B" type="planar_revolute" frame_a="slider" frame_b="rod_end"
                radial_clearance="0" axis="0 0 1"/>
    <dimension name="r2" joint="pin_A" direction="1 0 0" half_tolerance="{HALF_R2!r}"/>
    <dimension name="r3" joint="rod_end_mount" direction="1 0 0" half_tolerance="{HALF_R3!r}"/>
  </clearance_pin>
</robot>
"""


@pytest.fixture(scope="module")
def slider_driven():
    return clearance_pin.loads(slider_driven_urdf(), source="slider-driven crank")


def shifted(text: str, joint: str, delta) -> str:
    """``text`` with the origin xyz of URDF joint ``joint`` moved by ``delta`` [m] (3,)."""
    pattern = re.compile(rf'(<joint name="{re.escape(joint)}".*?<origin xyz=")([^"]*)"', re.S)
    match = pattern.search(text)
    assert match, joint
    xyz = np.array([float(v) for v in match.group(2).split()]) + np.asarray(delta, float)
    return text[: match.start(2)] + " ".join(repr(float(v)) for v in xyz) + text[match.end(2) :]


def placed(text: str, joint: str, value: float):
    """The model of ``text`` re-loaded, its loops closed with ``joint`` at ``value`` [m]."""
    with warnings.catch_warnings():
        # a deviation of a zero nominal (p2 below) is "500 % of its size": expected here
        warnings.simplefilter("ignore", SuspectValueWarning)
        mechanism = clearance_pin.loads(text, source="finite difference")
    q = mechanism.q_nominal.copy()
    q[mechanism.model.joints[mechanism.model.getJointId(joint)].idx_q] = value
    return mechanism, mechanism.configure(q)


def finite_difference(
    text, dimension_joint, direction, joint, value, read, subtract=np.subtract
) -> np.ndarray:
    """Central difference ``subtract(read(+H), read(-H)) / 2H`` of ``read(mechanism,
    configuration)`` for a deviation of the origin of ``dimension_joint`` along ``direction``,
    the driven ``joint`` at ``value`` [m]."""
    ends = []
    for sign in (1.0, -1.0):
        edited = shifted(text, dimension_joint, sign * H * np.asarray(direction, float))
        ends.append(read(*placed(edited, joint, value)))
    return subtract(ends[0], ends[1]) / (2.0 * H)


def crank_and_rod_angles(mechanism, configuration) -> np.ndarray:
    """theta2 (the crank joint) and theta3 (the rod's angle about z) [rad]."""
    q = configuration.q
    crank = q[mechanism.model.joints[mechanism.model.getJointId("crank_pivot")].idx_q]
    rotation = configuration.oMf[mechanism.model.getFrameId("rod")].rotation
    return np.array([crank, math.atan2(rotation[1, 0], rotation[0, 0])])


def test_slider_sweep_matches_the_closed_form(slider_driven):
    """At every slider position the crank angle and its sensitivities to r2, r3 are the closed
    form's, and the worst-case and RSS bands are the bands of those sensitivities."""
    result = sweep(
        slider_driven,
        ["theta2=crank_pivot", "theta3=rod.rz"],
        positions=9,
        start=0.08,
        stop=0.16,
    )
    assert result.unit == "m" and result.symbol == "s" and result.display_unit == "mm"
    assert np.allclose(result.phi, np.linspace(0.08, 0.16, 9), rtol=0, atol=1e-15)
    assert np.allclose(result.display(), np.linspace(80.0, 160.0, 9), rtol=0, atol=1e-12)
    half = np.array([HALF_R2, HALF_R3])
    for k, s in enumerate(result.phi):
        assert result.values[k, 0] == pytest.approx(crank_angle(s), abs=1e-12)
        expected = crank_sensitivities(s)
        # atol: at s = 130 mm = sqrt(r2^2 + r3^2) crank and rod are square, d theta/d r2 = 0
        assert np.allclose(result.matrix[k, 0], expected, rtol=1e-9, atol=1e-9), (s, expected)
        assert result.worst[k, 0] == pytest.approx(np.abs(expected) @ half, rel=1e-9)
        assert result.rss[k, 0] == pytest.approx(np.linalg.norm(expected * half), rel=1e-9)


def test_slider_sweep_matches_finite_differences_of_the_edited_urdf(slider_driven):
    """The sensitivities of both angles at each position against central differences, each
    dimension moved in the URDF text and the model re-loaded."""
    text = slider_driven_urdf()
    result = sweep(
        slider_driven, ["theta2=crank_pivot", "theta3=rod.rz"], positions=4, start=0.09, stop=0.16
    )
    for j, joint in enumerate(("pin_A", "rod_end_mount")):
        for k, s in enumerate(result.phi):
            reference = finite_difference(text, joint, (1, 0, 0), "slide", s, crank_and_rod_angles)
            assert np.allclose(result.matrix[k, :, j], reference, rtol=1e-6, atol=1e-6), (
                joint,
                s,
                reference,
            )


def test_prismatic_steps_are_a_fraction_of_the_length_scale(slider_driven, monkeypatch):
    """The walk to a far slider position closes the loops in steps of at most 0.05 of the
    mechanism's length scale (not 5 degrees read as 0.087 m), and lands on the closed form."""
    joint_id = driven_joint(slider_driven)
    scale = slider_driven.length_scale()
    assert scale == pytest.approx(S_NOMINAL)  # the farthest joint origin: the slider's
    assert step_limit(slider_driven, joint_id) == pytest.approx(0.05 * scale)
    start = slider_driven.configure().q
    calls = []
    configure = slider_driven.configure
    monkeypatch.setattr(slider_driven, "configure", lambda q=None: calls.append(1) or configure(q))
    q = closed_configuration(slider_driven, joint_id, 0.08, start)
    assert len(calls) == math.ceil((S_NOMINAL - 0.08) / (0.05 * scale)) == 9
    idx = slider_driven.model.joints[slider_driven.model.getJointId("crank_pivot")].idx_q
    assert q[idx] == pytest.approx(crank_angle(0.08), abs=1e-12)


def test_reversed_sweep_and_offset(slider_driven):
    """``clockwise`` with an offset runs the slider backwards: q = offset - s."""
    forward = sweep(slider_driven, ["crank_pivot"], positions=5, start=0.08, stop=0.16)
    backward = sweep(
        slider_driven,
        ["crank_pivot"],
        positions=5,
        start=0.0,
        stop=0.08,
        clockwise=True,
        offset=0.16,
    )
    assert np.allclose(backward.values[::-1], forward.values, rtol=0, atol=1e-12)
    assert np.allclose(backward.matrix[::-1], forward.matrix, rtol=1e-9, atol=0)


def test_maxima_over_the_stroke(slider_driven):
    """No cycle for a slider: the largest worst-case band of theta2 over [80, 160] mm is at the
    end nearer the inner dead centre (s = 80 mm), where the closed form gives its value."""
    result = sweep(slider_driven, ["theta2=crank_pivot"], positions=5, start=0.08, stop=0.16)
    fine = sweep(slider_driven, result.outputs, result.joint, 41, 0.08, 0.16)
    value, where = cycle_maximum(slider_driven, result, "theta2", "worst", fine=fine)
    assert where == pytest.approx(0.08, abs=1e-9)
    expected = np.abs(crank_sensitivities(0.08)) @ np.array([HALF_R2, HALF_R3])
    assert value == pytest.approx(expected, rel=1e-9)


def test_prismatic_range_errors(slider_driven):
    """A prismatic sweep needs its range, stays within the URDF limits, and is no angle."""
    with pytest.raises(ArgumentError, match=r"prismatic joint 'slide'.*no cycle") as info:
        sweep(slider_driven, ["crank_pivot"], positions=3)
    assert info.value.argument == "start"
    with pytest.raises(ArgumentError, match=r"'slide' within its URDF limits \[0.075, 0.165\] m"):
        sweep(slider_driven, ["crank_pivot"], positions=3, start=0.08, stop=0.17)
    with pytest.raises(ArgumentError, match=r"\[0.075, 0.165\] m.*reach \[0.05, 0.15\] m"):
        sweep(slider_driven, ["crank_pivot"], positions=3, start=0.05, stop=0.15)
    with pytest.raises(ArgumentError, match="finite"):
        sweep(slider_driven, ["crank_pivot"], positions=3, start=0.08, stop=math.nan)
    result = sweep(slider_driven, ["crank_pivot"], positions=2, start=0.08, stop=0.16)
    with pytest.raises(ClearancePinError, match="travel in m, not an angle"):
        _ = result.phi_deg


def test_revolute_range_outside_limits_is_refused():
    """The bundled slider-crank's crank has URDF limits of +/- 7 rad: a sweep past them is an
    ArgumentError naming the joint and the limits (one turn clockwise stays inside)."""
    mechanism = clearance_pin.load(DATA.parent.parent / "models" / "slider_crank.urdf")
    with pytest.raises(ArgumentError, match=r"'crank_pivot' within its URDF limits \[-7, 7\] rad"):
        sweep(mechanism, ["slider.x"], positions=3, stop=8.0)
    result = sweep(mechanism, ["slider.x"], positions=3, stop=2.0 * math.pi, clockwise=True)
    assert result.unit == "rad" and result.phi_deg[-1] == pytest.approx(360.0)


def test_plot_of_a_prismatic_sweep(slider_driven, tmp_path):
    """The plot of a slider sweep is drawn against s [mm] (phi_deg would raise)."""
    pytest.importorskip("matplotlib")
    result = sweep(slider_driven, ["crank_pivot"], positions=3, start=0.08, stop=0.16)
    path = tmp_path / "slider.png"
    plot_sweep(result, path)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_command_on_the_slider_driven_crank(tmp_path, capsys):
    """``clearance-pin tolerance`` reads --start/--stop of a prismatic joint in mm, prints an
    ``s[mm]`` column and the maxima over the stroke, and writes s [m] and the closed form's
    sensitivities to the JSON."""
    model, out = tmp_path / "slider_driven.urdf", tmp_path / "slider.json"
    model.write_text(slider_driven_urdf())
    common = ["tolerance", str(model), "--output", "theta2=crank_pivot", "--positions", "5"]
    status = cli_main(
        [*common, "--start", "80", "--stop", "160", "--samples", "200", "--json", str(out)]
    )
    assert status == 0
    text = capsys.readouterr().out
    assert "(q = +0 mm + s)" in text
    assert re.search(r"^\s+s\[mm\]\s+theta2\[deg\]", text, re.M), text
    rows = [
        float(line.split()[0]) for line in text.splitlines() if re.match(r"^\s+\d+\.\d{3} ", line)
    ]
    assert rows == [80.0, 100.0, 120.0, 140.0, 160.0]
    assert "max worst band over s in [80, 160] mm" in text and "at s = 80.0000 mm" in text
    document = json.loads(out.read_text())
    assert document["schema"] == "clearance_pin/tolerance/1" and "parameter_rad" not in document
    assert np.allclose(document["parameter_m"], np.linspace(0.08, 0.16, 5), rtol=0, atol=1e-15)
    theta2 = document["outputs"]["theta2"]
    for k, s in enumerate(document["parameter_m"]):
        expected = crank_sensitivities(s)
        r2 = theta2["sensitivities"]["r2"]["values_rad_per_m"]
        r3 = theta2["sensitivities"]["r3"]["values_rad_per_m"]
        assert r2[k] == pytest.approx(expected[0], rel=1e-9)
        assert r3[k] == pytest.approx(expected[1], rel=1e-9)
    assert theta2["worst_max_parameter_m"] == pytest.approx(0.08, abs=1e-9)
    # exact closures inside the first-order band, to its second-order terms: at 80 mm, 12 mm
    # from the dead centre, the exact worst case is 0.33 % above it (4714.9 against 4699.2 urad)
    mc, worst = np.array(theta2["mc_uniform_max_abs_rad"]), np.array(theta2["worst_rad"])
    assert np.all(mc <= 1.01 * worst) and np.all(mc > 0.5 * worst)

    assert cli_main([*common, "--samples", "0"]) == 2
    assert "--start, --stop" in capsys.readouterr().err
    assert cli_main([*common, "--start", "60", "--stop", "160", "--samples", "0"]) == 2
    err = capsys.readouterr().err
    assert "'slide' within its URDF limits [0.075, 0.165] m" in err
    assert "s [mm] of a prismatic joint" in _help(capsys)


def _help(capsys) -> str:
    with pytest.raises(SystemExit):
        cli_main(["tolerance", "--help"])
    return " ".join(capsys.readouterr().out.split())


# -- the 6-UPS Stewart platform, one leg swept ---------------------------------------------------
STEWART = DATA / "stewart_6ups.urdf"
LEG = "leg1"
STROKE = (0.205, 0.235)  # leg 1's travel [m], nominal 0.2194 m
OUTPUTS = ("platform.x", "platform.y", "platform.z", "platform.rz")
# (joint whose origin moves, direction in its parent frame): as the file's <dimension>s b1, p2
DIMENSIONS = {
    "b1": ("u1_1", np.array([0.965925826289068, -0.258819045102521, 0.0])),
    "p2": ("platform_2_mount", np.array([1.0, 0.0, 0.0])),
}


def origin(text: str, joint: str) -> np.ndarray:
    match = re.search(rf'<joint name="{re.escape(joint)}".*?<origin xyz="([^"]*)"', text, re.S)
    return np.array([float(v) for v in match.group(1).split()])


def stewart_geometry(text: str):
    """Base points (world), platform points (platform frame), leg 1's axis and the nominal leg
    lengths, read from the file: the universal joints' origins on the base, the ball mounts on
    the platform (ball 1 at its origin), the driven values of the legs."""
    base = np.array([origin(text, f"u{k}_1") for k in range(1, 7)])
    top = np.array([np.zeros(3)] + [origin(text, f"platform_{k}_mount") for k in range(2, 7)])
    axis = re.search(r'<joint name="leg1".*?<axis xyz="([^"]*)"', text, re.S).group(1)
    lengths = [
        float(re.search(rf'<joint name="leg{k}"[^/]*driven="true" q="([^"]*)"', text).group(1))
        for k in range(1, 7)
    ]
    return base, top, np.array([float(v) for v in axis.split()]), np.array(lengths)


def stewart_forward(base, top, lengths, centre, rotation):
    """Platform pose (origin, rotation) with legs of ``lengths`` [m]: Newton on
    |c + R p_k - b_k| = L_k from a nearby pose, R <- exp(dphi) R, the rows
    (n_k, (R p_k) x n_k) with n_k the unit leg vector."""
    for _ in range(50):
        legs = centre + top @ rotation.T - base
        norms = np.linalg.norm(legs, axis=1)
        units = legs / norms[:, None]
        jacobian = np.hstack([units, np.cross(top @ rotation.T, units)])
        step = np.linalg.solve(jacobian, lengths - norms)
        centre, rotation = centre + step[:3], pin.exp3(step[3:]) @ rotation
        if np.max(np.abs(step)) < 1e-15:
            break
    return centre, rotation


def stewart_sensitivities(base, top, centre, rotation) -> np.ndarray:
    """d(x, y, z, rz of the platform)/d(b1, p2) by implicit differentiation of the leg lengths
    held by their drives: n_k . (dc + dphi x R p_k + R dp_k - db_k) = 0 for every leg."""
    legs = centre + top @ rotation.T - base
    units = legs / np.linalg.norm(legs, axis=1)[:, None]
    jacobian = np.hstack([units, np.cross(top @ rotation.T, units)])
    columns = []
    for name, (_, direction) in DIMENSIONS.items():
        moved = np.zeros((6, 3))  # R dp_k - db_k per unit deviation
        if name == "b1":
            moved[0] = -direction
        else:
            moved[1] = rotation @ direction
        columns.append(np.linalg.solve(jacobian, -np.sum(units * moved, axis=1)))
    return np.array(columns).T[[0, 1, 2, 5]]


def platform_placement(mechanism, configuration) -> pin.SE3:
    """World placement of the platform frame."""
    return configuration.oMf[mechanism.model.getFrameId("platform")]


def pose_difference(a: pin.SE3, b: pin.SE3) -> np.ndarray:
    """(translation [m], small world rotation [rad]) from ``b`` to ``a``."""
    return np.concatenate([a.translation - b.translation, pin.log3(a.rotation @ b.rotation.T)])


def test_stewart_leg_sweep_against_numpy_and_finite_differences():
    """Leg 1 swept over 30 mm, the five other legs held: the platform's position at each leg
    length is the numpy forward kinematics', its sensitivities to b1 and p2 are the implicit
    differentiation's and the finite differences' of the edited URDF."""
    text = STEWART.read_text()
    mechanism = clearance_pin.loads(text, source=str(STEWART))
    result = sweep(mechanism, OUTPUTS, LEG, positions=4, start=STROKE[0], stop=STROKE[1])
    assert result.unit == "m" and [d.name for d in result.dimensions] == list(DIMENSIONS)
    base, top, axis, lengths = stewart_geometry(text)
    # the file's nominal pose: leg 1 along its axis from its base point, platform level
    centre, rotation = stewart_forward(base, top, lengths, base[0] + lengths[0] * axis, np.eye(3))
    for k, s in enumerate(result.phi):
        centre, rotation = stewart_forward(base, top, np.r_[s, lengths[1:]], centre, rotation)
        assert np.allclose(result.values[k, :3], centre, rtol=0, atol=1e-12)
        expected = stewart_sensitivities(base, top, centre, rotation)
        assert np.allclose(result.matrix[k], expected, rtol=1e-8, atol=1e-10), (s, expected)
        for j, (joint, direction) in enumerate(DIMENSIONS.values()):
            difference = finite_difference(
                text, joint, direction, LEG, s, platform_placement, pose_difference
            )
            reference = difference[[0, 1, 2, 5]]
            assert np.allclose(result.matrix[k, :, j], reference, rtol=1e-6, atol=1e-7), (
                joint,
                s,
                reference,
            )


def test_command_on_a_stewart_leg(tmp_path, capsys):
    """The CLI sweeps a Stewart leg given in mm (the sweep of the library, s in m, in the
    JSON) and refuses a leg length past its URDF limits [0, 1] m."""
    out = tmp_path / "stewart.json"
    outputs = [arg for o in OUTPUTS[:3] for arg in ("--output", o)]
    common = ["tolerance", str(STEWART), "--joint", LEG, *outputs, "--samples", "0"]
    stroke = ["--start", "205", "--stop", "235", "--positions", "3", "--no-maxima"]
    status = cli_main([*common, *stroke, "--json", str(out)])
    assert status == 0
    text = capsys.readouterr().out
    assert "sweep of leg1 (q = +0 mm + s), 3 positions" in text and "s[mm]" in text
    document = json.loads(out.read_text())
    mechanism = clearance_pin.load(STEWART)
    result = sweep(mechanism, OUTPUTS[:3], LEG, positions=3, start=STROKE[0], stop=STROKE[1])
    assert document["parameter_m"] == result.phi.tolist()
    for i, name in enumerate(OUTPUTS[:3]):
        sensitivity = document["outputs"][name]["sensitivities"]["b1"]
        (values,) = sensitivity.values()
        assert values == result.matrix[:, i, 0].tolist()
    assert cli_main([*common, "--start", "900", "--stop", "1100"]) == 2
    assert "'leg1' within its URDF limits [0, 1] m" in capsys.readouterr().err
