"""exact="auto" decides from an estimate of exact - linear at the outputs that bounds it.

The measured difference comes from the exact model (CasADi, Newton / IPOPT on the finite
displacement KKT system), which shares no code with the estimate (numpy on the linear answer,
clearance_pin/equilibrium/second_order.py): every check below is the estimate against an
independent solve. At every output either the estimate is at least the measured difference or
auto ran the exact model; where the estimate says it is reliable, it bounds the difference
whatever the accuracy asked.
"""

from __future__ import annotations

import sys
import tomllib
import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from hypothesis import HealthCheck, Phase, event, given, settings
from mechanism_strategies import mechanisms, paper_case_text
from oracle import Oracle, bounded_loads

import clearance_pin as cp
from clearance_pin.equilibrium.outputs import resolve_outputs
from clearance_pin.equilibrium.second_order import estimate_difference
from clearance_pin.errors import ClearancePinError, ClearancePinWarning
from clearance_pin.loading import loads as load_text

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "validation"))
from younes2013 import build  # noqa: E402

CASES = {
    c["id"]: c
    for c in tomllib.loads((ROOT / "validation" / "younes2013_cases.toml").read_text())["case"]
}
MODELS = sorted((ROOT / "models").glob("*.urdf"))


def measured_and_estimated(mechanism, loads=None, outputs=None, accuracy=1e-9):
    """(auto answer, exact answer, estimate) for one mechanism and load."""
    auto = mechanism.solve(loads=loads, exact="auto", accuracy=accuracy, outputs=outputs)
    exact = mechanism.solve(loads=loads, exact=True, outputs=outputs)
    return auto, exact, auto.difference_bound


def assert_bounded_or_exact(auto, exact, bound):
    """At every output: the estimate is at least the measured difference, or auto ran exact;
    a reliable estimate bounds the difference in any case."""
    measured = exact.difference.get("outputs")
    if measured is None:  # an indeterminate answer: nothing moves
        linear = exact.linear.outputs
        measured = {k: (t - linear[k][0], r - linear[k][1]) for k, (t, r) in exact.outputs.items()}
    assert set(measured) == set(bound["outputs"])
    for name, (translation, rotation) in measured.items():
        t_bound, r_bound = bound["outputs"][name]
        covered = np.linalg.norm(translation) <= t_bound and np.linalg.norm(rotation) <= r_bound
        assert covered or auto.formulation == "exact", (name, translation, t_bound)
        if bound["reliable"]:
            assert covered, (name, np.linalg.norm(translation), t_bound, bound["reason"])


@pytest.mark.parametrize("path", MODELS, ids=[p.stem for p in MODELS])
def test_bundled_models(path):
    mechanism = cp.load(path)
    assert_bounded_or_exact(*measured_and_estimated(mechanism))


@pytest.mark.parametrize("case_id", sorted(CASES))
def test_paper_cases(case_id):
    assert_bounded_or_exact(*measured_and_estimated(build(CASES[case_id])))


def test_prediction_converges_at_third_order():
    """The unfactored prediction differs from the measured difference at third order: scaling
    the clearances of [Y] 6.1.6.1a (shaft on a ball and a journal) by 1/10 divides the measured
    difference by ~100 and the prediction error by ~1000."""
    errors, differences = [], []
    for ratio in (5e-4, 5e-5):  # largest radial clearance / joint span (the paper's: 5e-4)
        mechanism = cp.loads(paper_case_text(CASES["6.1.6.1a"], ratio))
        loads = mechanism.resolve_loads(None, None)
        exact = mechanism.solve(exact=True)
        points = resolve_outputs(mechanism, loads)
        estimate = estimate_difference(exact.linear, loads, None, points)
        for name, (translation, _) in exact.difference["outputs"].items():
            errors.append(np.linalg.norm(translation - estimate.predicted[name][0]))
            differences.append(np.linalg.norm(translation))
    half = len(errors) // 2
    for i in range(half):
        assert 60 < differences[i] / differences[half + i] < 160
        assert errors[i] / errors[half + i] > 400, errors


RANDOM = settings(
    max_examples=25,
    deadline=None,
    phases=(Phase.explicit, Phase.reuse, Phase.generate),  # no shrinking: each case is slow
    derandomize=True,
    print_blob=True,
    suppress_health_check=[
        HealthCheck.too_slow,
        HealthCheck.filter_too_much,
        HealthCheck.data_too_large,
    ],
)


@RANDOM
@given(spec=mechanisms())
def test_random_mechanisms(spec):
    """Random trees and loops (tests/mechanism_strategies.py), loads cleared of their components
    along unblocked motions; cases the library diagnoses (no equilibrium, failed exact solve)
    are counted, not judged."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ClearancePinWarning)
        mechanism = cp.loads(spec.urdf(), source="<random mechanism>")
        loads = bounded_loads(Oracle(mechanism), mechanism.resolve_loads(None, None))
        try:
            auto, exact, bound = measured_and_estimated(mechanism, loads)
        except ClearancePinError as exc:
            event(f"diagnosed: {type(exc).__name__}")
            return
    event("reliable" if bound["reliable"] else "unreliable: exact run")
    assert_bounded_or_exact(auto, exact, bound)


# A UR5-like arm (the proportions of models/arm_6r.urdf) with radial play only: no flat axial
# plays, so the estimate is the second-order one, tested with its gravity and tool load.
def test_ur5_like_arm_with_radial_play():
    text = (ROOT / "models" / "arm_6r.urdf").read_text().replace('axial_clearance="5e-06"', "")
    mechanism = load_text(text)
    auto, exact, bound = measured_and_estimated(mechanism, accuracy=1e-6)
    assert bound["reliable"], bound["reason"]
    assert_bounded_or_exact(auto, exact, bound)


def test_ur5_like_arm_with_axial_play_runs_exact():
    """models/arm_6r.urdf leaves its axial plays unloaded in the linear model (minimum-norm
    point); the exact model's second-order terms load them and they move by the whole play
    (26 um at the tool): no second-order estimate exists, auto runs the exact model."""
    mechanism = cp.load(ROOT / "models" / "arm_6r.urdf")
    auto, exact, bound = measured_and_estimated(mechanism, accuracy=1e-3)
    assert not bound["reliable"] and "not unique" in bound["reason"]
    assert auto.formulation == "exact" and "no reliable" in auto.note
    assert exact.difference["translation_m"] > 1e-5


# A Panda-like arm: the seven joint origins of the Franka Panda URDF (franka_description,
# Apache-2.0; numbers only), every joint a journal bearing with 10 um radial play, driven, at the
# "ready" pose; 45 N along joint 7's axis and 1 N across it at the tool-centre point.
PANDA_ORIGINS = (
    ("0 0 0.333", (0, 0, 0)),
    ("0 0 0", (-1, 0, 0)),
    ("0 -0.316 0", (1, 0, 0)),
    ("0.0825 0 0", (1, 0, 0)),
    ("-0.0825 0.384 0", (-1, 0, 0)),
    ("0 0 0", (1, 0, 0)),
    ("0.088 0 0", (1, 0, 0)),
)
READY = (0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785)


def panda_like_text(force=(0.0, 0.0, 0.0), radial=1e-5, axial=0.0) -> str:
    links = "".join(f'<link name="link{i}"/>' for i in range(8)) + '<link name="tcp"/>'
    joints = ""
    for i, (xyz, rpy) in enumerate(PANDA_ORIGINS):
        roll = " ".join(f"{a * np.pi / 2:.17g}" for a in rpy)
        joints += (
            f'<joint name="joint{i + 1}" type="revolute"><parent link="link{i}"/>'
            f'<child link="link{i + 1}"/><origin xyz="{xyz}" rpy="{roll}"/><axis xyz="0 0 1"/>'
            '<limit lower="-3" upper="3" effort="1" velocity="1"/></joint>'
        )
    joints += (
        '<joint name="flange" type="fixed"><parent link="link7"/><child link="tcp"/>'
        '<origin xyz="0 0 0.2104"/></joint>'
    )
    play = "".join(
        f'<joint name="joint{i + 1}" type="revolute" radial_clearance="{radial}" length="0.03" '
        f'axial_clearance="{axial}" driven="true" q="{READY[i]}"/>'
        for i in range(7)
    )
    value = " ".join(f"{v:.17g}" for v in force)
    return (
        f'<robot name="panda_like">{links}{joints}<clearance_pin>{play}'
        f'<force link="tcp" point="0 0 0" value="{value}"/></clearance_pin></robot>'
    )


def joint7_axes():
    """World axis of joint 7 and a direction across it, at the ready pose (plain Pinocchio)."""
    mechanism = load_text(panda_like_text((0.0, 0.0, 1.0)))
    data = mechanism.model.createData()
    pin.forwardKinematics(mechanism.model, data, mechanism.q_nominal)
    rotation = data.oMi[mechanism.model.getJointId("joint7")].rotation
    return rotation[:, 2], rotation[:, 0]


@pytest.mark.parametrize("axial", [0.0, 5e-6])
def test_panda_like_axial_load_runs_exact(axial):
    """Regression (issue 10, finding 4): a large axial load with a small radial one on the last
    joint moves the tool-centre point by micrometres more in the exact model; the old estimate
    (boundary errors, rotation x displacement per joint) kept the linear answer at 1e-6."""
    axis, across = joint7_axes()
    mechanism = load_text(panda_like_text(45.0 * axis + 1.0 * across, axial=axial))
    auto, exact, bound = measured_and_estimated(mechanism, outputs=["tcp"], accuracy=1e-6)
    assert auto.formulation == "exact", auto.note
    tcp = np.linalg.norm(exact.difference["outputs"]["tcp"][0])
    assert tcp > 1e-6  # micrometres at the tool-centre point
    assert bound["outputs"]["tcp"][0] >= tcp
    assert_bounded_or_exact(auto, exact, bound)


def example_robot_urdf(path: str) -> str:
    """A URDF of example-robot-data (BSD-3, a test extra), read from the installed package; the
    test skips when it is not installed. Its Python module is optional: the file is found from
    the distribution's file list."""
    import importlib.metadata

    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        pytest.importorskip("example_robot_data")  # skips: not installed
        raise
    found = [f for f in dist.files or () if str(f).endswith(path)]
    if not found:
        pytest.skip(f"example-robot-data has no {path}")
    return Path(dist.locate_file(found[0])).read_text()


def _with_play(urdf: str, joints) -> str:
    """A real robot's URDF with 10 um radial play in every joint listed, driven; the Panda's
    finger mimic coupling removed (the library refuses mimic joints; the fingers carry no load)."""
    import re

    play = "".join(
        f'<joint name="{j}" type="revolute" radial_clearance="1e-05" length="0.03" driven="true"/>'
        for j in joints
    )
    urdf = re.sub(r"<mimic[^>]*/>", "", urdf)
    return urdf.replace("</robot>", f"<clearance_pin>{play}</clearance_pin></robot>")


ARMS = {
    "ur5": (
        "ur_description/urdf/ur5_robot.urdf",
        [f"{j}_joint" for j in ("shoulder_pan", "shoulder_lift", "elbow")]
        + [f"wrist_{i}_joint" for i in (1, 2, 3)],
        "tool0",
    ),
    "panda": (
        "panda_description/urdf/panda.urdf",
        [f"panda_joint{i}" for i in range(1, 8)],
        "panda_hand_tcp",
    ),
}


@pytest.mark.parametrize("robot", sorted(ARMS))
def test_example_robot_data_arms(robot):
    """The real UR5 and Panda, play in every arm joint, 45 N along the last joint's axis and
    1 N across it at the tool (the Panda at its zero pose, arm upright)."""
    path, joints, tool = ARMS[robot]
    mechanism = load_text(_with_play(example_robot_urdf(path), joints))
    data = mechanism.model.createData()
    pin.forwardKinematics(mechanism.model, data, mechanism.q_nominal)
    rotation = data.oMi[mechanism.model.getJointId(joints[-1])].rotation
    force = [cp.PointForce(tool, force=45.0 * rotation[:, 2] + 1.0 * rotation[:, 0])]
    auto, exact, bound = measured_and_estimated(mechanism, force, [tool], accuracy=1e-6)
    assert bound["reliable"], bound["reason"]
    assert_bounded_or_exact(auto, exact, bound)
