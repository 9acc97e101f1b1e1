"""Equilibrium.outputs: the world displacement of the loaded points and the output frames, in
both formulations, and the exact - linear difference reported there.

Independent references: the exact displacement of a frame is rebuilt by plain Pinocchio, moving
every joint placement of a copy of the model by its solved finite clearance motion
C exp(T) C^-1 and running forward kinematics (no code shared with the solver or with
clearance_pin.equilibrium.outputs); the linear one is the first-order limit of that construction
(central difference along the solved torsors).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import clearance_pin as cp
from clearance_pin import json_documents
from clearance_pin.errors import ArgumentError, ClearancePinError

ROOT = Path(__file__).resolve().parent.parent


def rigid_frame_displacement(mechanism, torsors, frame, scale=1.0):
    """Displacement (translation [m], rotation vector [rad]) of ``frame`` when every tree joint
    moves by exp(scale * T) in its clearance frame: a copy of the pin.Model with each joint
    placement multiplied by C exp(T) C^-1 on the child side, then forward kinematics."""
    model = mechanism.model.copy()
    for joint in mechanism.tree_joints:
        c = pin.SE3(joint.rotation, np.zeros(3))
        delta = c * pin.exp6(pin.Motion(scale * torsors[joint.name])) * c.inverse()
        # the clearance motion follows the joint's own motion M(q); the joint placement can
        # carry it only where M(q) = identity, so the arm below sits at q = 0
        assert abs(mechanism.q_nominal[model.joints[joint.joint_id].idx_q]) == 0.0
        model.jointPlacements[joint.joint_id] = model.jointPlacements[joint.joint_id] * delta
    nominal, moved = mechanism.model.createData(), model.createData()
    pin.framesForwardKinematics(mechanism.model, nominal, mechanism.q_nominal)
    pin.framesForwardKinematics(model, moved, mechanism.q_nominal)
    fid = model.getFrameId(frame)
    start, end = nominal.oMf[fid], moved.oMf[fid]
    return end.translation - start.translation, pin.log3(end.rotation @ start.rotation.T)


LIMIT = '<limit lower="-3" upper="3" effort="1" velocity="1"/>'
ARM = (
    '<robot name="arm3">'
    '<link name="base"/><link name="a"/><link name="b"/><link name="c"/><link name="tool"/>'
    '<joint name="j1" type="revolute"><parent link="base"/><child link="a"/>'
    '<origin xyz="0 0 0.1"/><axis xyz="0 0 1"/>' + LIMIT + "</joint>"
    '<joint name="j2" type="revolute"><parent link="a"/><child link="b"/>'
    '<origin xyz="0 0 0.1" rpy="1.5707963267948966 0 0"/><axis xyz="0 0 1"/>' + LIMIT + "</joint>"
    '<joint name="j3" type="revolute"><parent link="b"/><child link="c"/>'
    '<origin xyz="0.4 0 0"/><axis xyz="0 0 1"/>' + LIMIT + "</joint>"
    '<joint name="mount" type="fixed"><parent link="c"/><child link="tool"/>'
    '<origin xyz="0.3 0.05 0" rpy="0.3 0 0"/></joint>'
    "<clearance_pin>"
    '<joint name="j1" type="revolute" radial_clearance="4e-05" length="0.02" driven="true"/>'
    '<joint name="j2" type="revolute" radial_clearance="4e-05" length="0.02" driven="true"/>'
    '<joint name="j3" type="revolute" radial_clearance="4e-05" length="0.02" driven="true"/>'
    '<force link="c" point="0.2 0 0.01" value="0 -30 5"/>'
    '<torque link="c" value="0.5 0 0"/>'
    "</clearance_pin></robot>"
)


@pytest.fixture(scope="module")
def arm():
    return cp.loads(ARM)


def test_default_outputs_are_loaded_points_and_leaf_links(arm):
    eq = arm.solve()
    assert list(eq.outputs) == ["c@[0.2 0 0.01]", "c", "tool"]


def test_outputs_asked_for_and_unknown_names(arm):
    eq = arm.solve(outputs=["b", "j3"])
    assert list(eq.outputs) == ["c@[0.2 0 0.01]", "c", "b", "j3"]
    with pytest.raises(ArgumentError, match=r"frame of 'arm3'.*base.*tool.*found 'tol'") as info:
        arm.solve(outputs=["tool", "tol"])
    assert isinstance(info.value, ClearancePinError) and info.value.argument == "outputs[1]"
    with pytest.raises(ArgumentError, match="list of Pinocchio frame names"):
        arm.solve(outputs="tool")


def test_exact_outputs_match_a_rigid_pinocchio_construction(arm):
    """Independent: the exact answer's frame displacements equal those of a copy of the model
    whose joint placements carry the solved finite motions (plain Pinocchio)."""
    exact = arm.solve(exact=True, outputs=["tool", "b"])
    for frame in ("tool", "b", "c"):
        translation, rotation = rigid_frame_displacement(arm, exact.torsors, frame)
        t, r = exact.outputs[frame]
        assert np.allclose(t, translation, atol=1e-15, rtol=1e-12)
        assert np.allclose(r, rotation, atol=1e-15, rtol=1e-12)


def test_linear_outputs_are_the_first_order_limit(arm):
    """Independent: the linear displacement is the derivative of the rigid construction along
    the solved torsors (central difference, step 1e-3 of the solution: O(1e-6) relative)."""
    linear = arm.solve(outputs=["tool"])
    h = 1e-3
    for frame in ("tool", "c"):
        plus = rigid_frame_displacement(arm, linear.torsors, frame, h)
        minus = rigid_frame_displacement(arm, linear.torsors, frame, -h)
        t, r = linear.outputs[frame]
        expected_t, expected_r = (plus[0] - minus[0]) / (2 * h), (plus[1] - minus[1]) / (2 * h)
        assert np.allclose(t, expected_t, rtol=1e-5, atol=1e-5 * np.linalg.norm(t))
        assert np.allclose(r, expected_r, rtol=1e-5, atol=1e-5 * np.linalg.norm(r))


def test_load_point_output_is_the_point_not_the_frame(arm):
    """The load point sits 0.2 m along c's x axis: it moves by the frame origin's translation
    plus rotation x lever (linear), checked against the frame c output."""
    eq = arm.solve()
    t_frame, r_frame = eq.outputs["c"]
    t_point, r_point = eq.outputs["c@[0.2 0 0.01]"]
    data = arm.model.createData()
    pin.framesForwardKinematics(arm.model, data, arm.q_nominal)
    oMc = data.oMf[arm.model.getFrameId("c")]
    lever = oMc.rotation @ np.array([0.2, 0.0, 0.01])
    assert np.allclose(t_point, t_frame + np.cross(r_frame, lever), rtol=1e-12, atol=1e-18)
    assert np.array_equal(r_point, r_frame)


def test_difference_is_per_output_and_reported(arm):
    exact = arm.solve(exact=True, outputs=["tool"])
    difference = exact.difference
    for name, (t, r) in exact.outputs.items():
        lt, lr = exact.linear.outputs[name]
        assert np.array_equal(difference["outputs"][name][0], t - lt)
        assert np.array_equal(difference["outputs"][name][1], r - lr)
    norms = [np.linalg.norm(t) for t, _ in difference["outputs"].values()]
    assert difference["translation_m"] == max(norms) > 0.0
    assert difference["torsor_translation_m"] > 0.0
    as_json = json.loads(json.dumps(exact.to_dict(length=1e6, unit="um")))
    reported = as_json["difference_exact_linear"]
    assert reported["translation"] == pytest.approx(difference["translation_m"] * 1e6)
    assert set(reported["outputs"]) == set(exact.outputs)
    assert set(as_json["outputs"]) == set(exact.outputs)
    table = exact.table()
    assert "exact - linear" in table and "tool" in table


def test_auto_reports_its_estimate(arm):
    auto = arm.solve(exact="auto", accuracy=1e-3, outputs=["tool"])
    assert auto.formulation == "linear" and "kept" in auto.note
    bound = auto.difference_bound
    assert bound["reliable"] and set(bound["outputs"]) == set(auto.outputs)
    as_json = json.loads(json.dumps(auto.to_dict()))
    assert as_json["difference_bound"]["translation"] == pytest.approx(bound["translation_m"])
    assert "estimate" in auto.table()


def test_bundled_model_outputs_in_both_formulations():
    mechanism = cp.load(ROOT / "models" / "four_bar.urdf")
    exact = mechanism.solve(exact=True)
    assert set(exact.outputs) == set(exact.linear.outputs) == set(exact.difference["outputs"])


def test_batched_answers_report_the_loaded_points_too():
    """An answer of solve_many (assembled from the batched Newton) reports the same outputs as a
    single solve: its loaded points as well as the leaf links."""
    mechanism = cp.load(ROOT / "models" / "younes_sphere_cylinder.urdf")
    single = mechanism.solve()
    batch = mechanism.solve_many([list(mechanism.loads)] * 3)
    assert list(batch[1].outputs) == list(single.outputs)
    for name, (t, _) in single.outputs.items():
        assert np.allclose(batch[1].outputs[name][0], t, rtol=0, atol=1e-15)


def test_batch_frame_displacements_are_the_items_ones():
    """EquilibriumBatch.frame_displacements(frame): arrays (N, 3) equal to each item's
    frame_displacement (a batch of load cases on the 6R arm)."""
    arm = cp.load(ROOT / "models" / "arm_6r.urdf")
    cases = [
        [cp.PointForce("tool", [0.0, 0.0, -50.0 * (1 + 0.1 * k)], [0, 0, 0])] for k in range(5)
    ]
    batch = arm.solve_many(cases)
    translations, rotations = batch.frame_displacements("tool")
    assert translations.shape == rotations.shape == (5, 3)
    for i in range(5):
        t, r = batch[i].frame_displacement("tool")
        assert np.array_equal(translations[i], t) and np.array_equal(rotations[i], r)
    assert isinstance(batch, cp.EquilibriumBatch) and cp.CheckReport is not None


def test_an_asked_frame_at_a_loaded_point_is_reported_once_under_its_name():
    """The bundled arm's tool load sits at the tool frame's origin: asking for ``tool`` reports
    one output, named ``tool`` (it listed ``tool@[0 0 0]`` and ``tool`` as two equal rows), in
    the table and in the JSON document alike, with the point's displacement."""
    arm = cp.load(str(ROOT / "models" / "arm_6r.urdf"))
    asked = arm.solve(outputs=["tool"])
    assert list(asked.outputs) == ["tool"]
    unasked = arm.solve()
    (point,) = [name for name in unasked.outputs if name.startswith("tool@")]
    assert np.array_equal(asked.outputs["tool"][0], unasked.outputs[point][0])
    assert asked.table().count("\ntool ") == 1
    document = json_documents.equilibrium_document(asked)
    assert list(document["outputs"]) == ["tool"]
