"""Issue 35 as a new user meets it: ``clearance-pin identify`` on a measurement file written by
hand from docs/identification.md, checked by hand; the design's plan filled in and identified;
the ISO 9283 prediction against Pinocchio's Jacobians and the cube's geometry.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import clearance_pin as cp
from clearance_pin.cli import main
from clearance_pin.json_documents import schema

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "benchmarks"))
import identification_synthetic as synthetic  # tests/, Pinocchio only
import test_identification as corpus  # the UR5 of example-robot-data

HINGE = """<robot name="hinge">
  <link name="base"/>
  <link name="arm">
    <inertial><mass value="1"/><origin xyz="0.25 0 0"/>
      <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>
  </link>
  <joint name="hinge" type="revolute">
    <parent link="base"/><child link="arm"/><axis xyz="0 1 0"/>
    <limit lower="-3" upper="3" effort="100" velocity="1"/>
  </joint>
</robot>
"""
# the datasheet: 1 mrad of backlash, 500 N m/rad
DATASHEET = """unit = "mm"
[joints.hinge]
driven = true
backlash = 0.001
drive_stiffness = 500.0
"""
# Written by hand. The arm turns about y at the origin, the point 0.5 m along x: a vertical
# force Fz there exerts tau = -0.5 Fz about y, which turns the arm by sign(tau) b/2 + tau/k,
# and the point moves along z by dz = -0.5 theta = 0.5 sign(Fz) b/2 + 0.25 Fz / k.
# With b = 0.002 rad and k = 1000 N m/rad: Fz = -10 N: dz = -0.0005 - 0.0025 = -0.003 m;
# +10: +0.003; -20: -0.0005 - 0.005 = -0.0055; +20: +0.0055; -5: -0.0005 - 0.00125 = -0.00175;
# no force: no torque, the drive in the middle of its backlash (no side), dz = 0.
# The laser tracker's origin is elsewhere (x = 1.2, z = 1.0 and 2.0 at the two poses).
MEASUREMENTS = """# the hinge's point 0.5 m out, pulled up and down
pose,hinge,fx,fy,fz,x,y,z
A,0,0,0,-10,1.2,0,0.997
A,0,0,0,10,1.2,0,1.003
A,0,0,0,-20,1.2,0,0.9945
B,0,0,0,20,1.2,0,2.0055
B,0,0,0,-5,1.2,0,1.99825
B,0,0,0,0,1.2,0,2.0
"""


def test_a_hand_written_file_identified_by_the_command(tmp_path, capsys):
    """The hand-computed backlash (0.002 rad) and stiffness (1000 N m/rad) come back to 1e-9,
    the JSON follows its schema, the written clearance file loads back with them."""
    (tmp_path / "hinge.urdf").write_text(HINGE)
    (tmp_path / "datasheet.toml").write_text(DATASHEET)
    (tmp_path / "m.csv").write_text(MEASUREMENTS)
    out, report = tmp_path / "identified.toml", tmp_path / "identify.json"
    status = main([
        "identify", str(tmp_path / "hinge.urdf"), "--clearances", str(tmp_path / "datasheet.toml"),
        "--point", "arm@[0.5 0 0]", "--measurements", str(tmp_path / "m.csv"),
        "--write", str(out), "--json", str(report),
    ])  # fmt: skip
    printed = capsys.readouterr().out
    assert status == 0, printed
    assert "hinge" in printed and "identified" in printed
    document = json.loads(report.read_text())
    jsonschema = pytest.importorskip("jsonschema")
    jsonschema.validate(document, schema("identify"))
    values = {p["kind"]: p for p in document["identification"]["parameters"]}
    assert values["backlash"]["value"] == pytest.approx(0.002, rel=1e-9)
    assert values["drive_stiffness"]["value"] == pytest.approx(1000.0, rel=1e-9)
    assert values["backlash"]["prior"] == 0.001
    assert document["identification"]["rms"]["fitted"]["after_m"] < 1e-12
    # the correlation of b and c by hand: dz's columns 0.5 sign(Fz) / 2 and 0.25 Fz, each less
    # its pose's mean; corr = -(A^T A)_bc / sqrt((A^T A)_bb (A^T A)_cc)
    forces = {"A": [-10.0, 10.0, -20.0], "B": [20.0, -5.0, 0.0]}
    a = np.vstack([
        np.column_stack([0.25 * np.sign(f), 0.25 * np.array(f)])
        - np.column_stack([0.25 * np.sign(f), 0.25 * np.array(f)]).mean(axis=0)
        for f in map(np.array, forces.values())
    ])  # fmt: skip
    gram = a.T @ a
    by_hand = -gram[0, 1] / np.sqrt(gram[0, 0] * gram[1, 1])
    (pair,) = document["identification"]["correlated"]
    assert pair["correlation"] == pytest.approx(by_hand, rel=1e-9) and abs(by_hand) > 0.9
    again = cp.load(str(tmp_path / "hinge.urdf"), clearances=out)
    joint = again.joint("hinge")
    assert joint.clearance.backlash == values["backlash"]["value"]
    assert joint.clearance.stiffness[3][3] == values["drive_stiffness"]["value"]


def test_bad_input_exits_2_naming_the_line(tmp_path, capsys):
    (tmp_path / "hinge.urdf").write_text(HINGE)
    (tmp_path / "datasheet.toml").write_text(DATASHEET)
    (tmp_path / "m.csv").write_text(MEASUREMENTS.replace("1.2,0,0.9945", "1.2,0,0,9945"))
    status = main([
        "identify", str(tmp_path / "hinge.urdf"), "--clearances", str(tmp_path / "datasheet.toml"),
        "--point", "arm@[0.5 0 0]", "--measurements", str(tmp_path / "m.csv"),
    ])  # fmt: skip
    assert status == 2
    assert "line 5" in capsys.readouterr().err


def test_a_design_and_a_cube_out_of_reach(tmp_path, capsys):
    """The hinge under the default loads (hung, pulled along +-x and +-y; the x pulls turn it
    wherever it is not horizontal): a design of 4 poses prints its expected standard errors;
    an ISO 9283 cube is out of a one-joint arm's reach: exit 4 with one line saying so."""
    (tmp_path / "hinge.urdf").write_text(HINGE)
    (tmp_path / "datasheet.toml").write_text(DATASHEET)
    common = [
        "identify", str(tmp_path / "hinge.urdf"), "--clearances", str(tmp_path / "datasheet.toml"),
        "--point", "arm@[0.5 0 0]",
    ]  # fmt: skip
    design = ["--design", "4", "--noise", "10um", "--payload", "2", "--candidates", "30"]
    report = tmp_path / "design.json"
    assert main([*common, *design, "--json", str(report)]) == 0
    printed = capsys.readouterr().out
    assert "hinge backlash" in printed and "hinge drive_stiffness" in printed
    document = json.loads(report.read_text())
    jsonschema = pytest.importorskip("jsonschema")
    jsonschema.validate(document, schema("identify"))
    assert document["identification"] is None and document["design"]["poses"] == 4
    assert document["design"]["noise_m"] == pytest.approx(1e-5, rel=1e-12)
    assert main([*common, "--payload", "2", "--iso9283"]) == 4
    assert "no ISO 9283 cube" in capsys.readouterr().err
    assert main([*common, "--iso9283"]) == 2  # without the rated payload
    assert "--payload" in capsys.readouterr().err


def test_the_plan_filled_in_and_identified(tmp_path, capsys):
    """UR5: --design writes a plan (pose, joints, force, empty x y z); filled in here from
    Pinocchio's Jacobians (noise-free) and given back: the drives come back to 1e-6, and the
    ISO 9283 prediction of the identified robot is printed and in the JSON."""
    robot = "ur5"
    urdf = corpus.vendor(robot)
    sheet = corpus.datasheet_file(tmp_path, robot, *corpus.DATASHEET)
    plan, report = tmp_path / "plan.csv", tmp_path / "identify.json"
    frame, offset = corpus.ROBOTS[robot][2]
    point = f"{frame}@[{' '.join(map(str, offset))}]"
    common = ["identify", str(urdf), "--clearances", str(sheet), "--point", point]
    assert main([*common, "--design", "25", "--payload", "5", "--plan", str(plan),
                 "--candidates", "200"]) == 0  # fmt: skip
    lines = plan.read_text().splitlines()
    header = lines[0].split(",")
    assert header[0] == "pose" and header[-6:] == ["fx", "fy", "fz", "x", "y", "z"]
    assert len(lines) == 1 + 25 * 5
    mechanism = cp.load(str(urdf), clearances=sheet)
    names = list(corpus.ROBOTS[robot][1])
    b, k = corpus.TRUE[robot]
    rows = [line.split(",") for line in lines[1:]]
    poses = np.array([[float(v) for v in row[1:7]] for row in rows[::5]])
    forces = np.array([[float(v) for v in row[7:10]] for row in rows[:5]])
    made = synthetic.measurements(mechanism.model, frame, offset, names, b, k, poses, forces)
    filled = [lines[0]] + [
        ",".join(row[:10] + [repr(float(v)) for v in made["position"][i]])
        for i, row in enumerate(rows)
    ]
    (tmp_path / "filled.csv").write_text("\n".join(filled) + "\n")
    capsys.readouterr()
    status = main([*common, "--measurements", str(tmp_path / "filled.csv"), "--payload", "5",
                   "--iso9283", "--json", str(report)])  # fmt: skip
    printed = capsys.readouterr().out
    assert status == 0, printed
    assert "ISO 9283" in printed and "P5" in printed
    document = json.loads(report.read_text())
    jsonschema = pytest.importorskip("jsonschema")
    jsonschema.validate(document, schema("identify"))
    found = {(p["joint"], p["kind"]): p["value"] for p in document["identification"]["parameters"]}
    for j, name in enumerate(names):
        assert found[(name, "backlash")] == pytest.approx(b[j], rel=1e-6)
        assert found[(name, "drive_stiffness")] == pytest.approx(k[j], rel=1e-6)
    assert len(document["iso9283"]["poses"]) == 5


def test_the_iso9283_cube_and_its_predicted_errors(tmp_path):
    """UR5 with the true drives (no bearing play): the cube's five points as ISO 9283 places them
    (P1 the centre, P2-P5 at 10 % of the diagonal from the diagonal plane's corners), reached
    with P1's orientation (Pinocchio's forward kinematics), and at each the backlash and
    compliance errors of J (sign(tau) b / 2 + tau / k) under the rated 5 kg hung at the point."""
    from clearance_pin.identification.iso9283 import iso9283_prediction

    robot = "ur5"
    b, k = corpus.TRUE[robot]
    names = list(corpus.ROBOTS[robot][1])
    sheet = corpus.datasheet_file(tmp_path, robot, 3e-4, 1e4)
    mechanism = cp.load(str(corpus.vendor(robot)), clearances=sheet)
    from clearance_pin.identification.differences import with_drives

    robot_true = with_drives(mechanism, {n: (b[j], k[j]) for j, n in enumerate(names)})
    frame, offset = corpus.ROBOTS[robot][2]
    prediction = iso9283_prediction(robot_true, (frame, offset), 5.0)
    cube = prediction.cube
    model = mechanism.model
    data = model.createData()
    fid = model.getFrameId(frame)
    position, _ = synthetic.point_jacobian(model, data, fid, np.array(offset), model_q(mechanism))
    assert np.allclose(cube.centre, position, atol=1e-12)
    a = cube.edge
    corners = cube.centre + 0.5 * a * np.array([[-1, -1, -1], [1, -1, -1], [1, 1, 1], [-1, 1, 1]])
    assert np.allclose(cube.positions[0], cube.centre)
    for p, c in zip(cube.positions[1:], corners):
        assert np.linalg.norm(p - c) == pytest.approx(0.1 * a * np.sqrt(3), rel=1e-12)
        assert np.linalg.norm(p - cube.centre) == pytest.approx(0.4 * a * np.sqrt(3), rel=1e-12)
    force = np.array([0.0, 0.0, -5.0 * synthetic.G])
    columns = [model.joints[model.getJointId(n)].idx_v for n in names]
    pin.framesForwardKinematics(model, data, model_q(mechanism))
    orientation = data.oMf[fid].rotation.copy()
    for i, q in enumerate(cube.configurations):
        reached, jacobian = synthetic.point_jacobian(model, data, fid, np.array(offset), q)
        assert np.allclose(reached, cube.positions[i], atol=1e-9)
        assert np.allclose(data.oMf[fid].rotation, orientation, atol=1e-9)
        tau = jacobian[:3].T @ force
        backlash = sum(jacobian[:3, c] * np.sign(tau[c]) * b[j] / 2 for j, c in enumerate(columns))
        compliance = sum(jacobian[:3, c] * tau[c] / k[j] for j, c in enumerate(columns))
        assert np.allclose(prediction.errors["backlash"][i], backlash, rtol=0, atol=1e-12)
        assert np.allclose(prediction.errors["compliance"][i], compliance, rtol=0, atol=1e-12)
        assert not prediction.errors["play"][i].any()
    assert prediction.ok.all()
    assert np.allclose(
        prediction.total, prediction.errors["backlash"] + prediction.errors["compliance"]
    )


def model_q(mechanism) -> np.ndarray:
    return mechanism.q_nominal


def test_the_clearance_file_written_from_xml_and_from_the_block_in_the_urdf(tmp_path):
    """The identified values written over an XML clearance file, and over the block inside the
    URDF (base=None), as TOML: both load back with them, the rest of the block kept (the
    nominal value q = 0.1, the force); a vendor-like URDF without a block and no base is
    refused, naming the argument."""
    from clearance_pin.identification import Measurements

    xml = (
        '<clearance_pin unit="mm">\n  <joint name="hinge" driven="true" backlash="0.001" '
        'drive_stiffness="500" q="0.1"/>\n  <force link="arm" point="500 0 0" value="0 0 -1"/>\n'
        "</clearance_pin>\n"
    )
    (tmp_path / "hinge.urdf").write_text(HINGE)
    (tmp_path / "play.xml").write_text(xml)
    inner = HINGE.replace("</robot>", xml + "</robot>")
    (tmp_path / "inner.urdf").write_text(inner)
    q = np.array([[0.1], [0.1], [0.1]])
    forces = np.array([[0, 0, -10.0], [0, 0, 10.0], [0, 0, -20.0]])
    # the hinge at q = 0.1: the point at 0.5 (cos q, 0, -sin q); a vertical force's torque
    # about y is -0.5 cos(q) Fz; the point moves by theta (y x r) = theta 0.5 (-sin q, 0, -cos q)
    theta = [np.sign(-f) * 0.001 + (-0.5 * np.cos(0.1) * f) / 1000.0 for f in forces[:, 2]]
    positions = np.array([t * 0.5 * np.array([-np.sin(0.1), 0, -np.cos(0.1)]) for t in theta])
    data = Measurements.from_arrays([0, 0, 0], q, forces, positions)
    for model, base in (
        (tmp_path / "hinge.urdf", tmp_path / "play.xml"),
        (tmp_path / "inner.urdf", None),
    ):
        robot = cp.load(str(model), clearances=base)
        result = robot.identify(data, point=("arm", [0.5, 0, 0]))
        assert result.parameter("hinge", "backlash").value == pytest.approx(0.002, rel=1e-9)
        written = tmp_path / "out.toml"
        result.write_clearances(written, base=base)
        again = cp.load(str(tmp_path / "hinge.urdf"), clearances=written)
        joint = again.joint("hinge")
        assert joint.clearance.backlash == result.parameter("hinge", "backlash").value
        stiffness = result.parameter("hinge", "drive_stiffness").value
        assert (
            stiffness == pytest.approx(1000.0, rel=1e-9)
            and joint.clearance.stiffness[3][3] == stiffness
        )
        assert again.q_nominal[0] == 0.1 and len(again.loads) == 1
    bare = cp.load(str(tmp_path / "hinge.urdf"), clearances=tmp_path / "play.xml")
    with pytest.raises(cp.ArgumentError, match="base"):
        bare.identify(data, point=("arm", [0.5, 0, 0])).write_clearances(tmp_path / "x.toml")
