"""Drive backlash (issue 23 item 1): a driven joint's lost motion, a 1-D clearance on its own
motion. References are closed forms and statics computed here, sharing no code with the solver.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import clearance_pin as cp
from clearance_pin import Method, PointForce, Torque

MODELS = Path(__file__).resolve().parent.parent / "models"
BACKLASH = 0.002  # [rad] total lost motion of the drive
ARM = 0.5  # [m] where the cantilever's tip is


def cantilever(backlash: str = f'backlash="{BACKLASH}"', extra: str = "") -> cp.Mechanism:
    """A driven journal about z carrying a 0.5 m cantilever along x."""
    return cp.loads(f"""<?xml version="1.0"?>
<robot name="cantilever">
  <link name="base"/>
  <link name="arm"/>
  <joint name="drive" type="revolute"><parent link="base"/><child link="arm"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="10" velocity="1"/></joint>
  <clearance_pin>
    <joint name="drive" type="revolute" radial_clearance="1e-5" axial_clearance="5e-6"
           length="0.04" driven="true" {backlash} {extra}/>
  </clearance_pin>
</robot>""")


@pytest.mark.parametrize("torque", [2.0, -3.0])
def test_a_driven_journal_turns_by_half_its_backlash(torque):
    """A torque T about the axis turns the joint by sign(T) b/2 (closed form: the stop is the
    only thing that holds a moment about the axis), the tip moves ARM b/2 across, the stop holds
    -T (statics of the arm), on every engine and in the exact model."""
    mechanism = cantilever()
    loads = [Torque("arm", [0.0, 0.0, torque])]
    expected = np.sign(torque) * BACKLASH / 2.0
    answers = [
        mechanism.solve(loads, gravity=False),
        mechanism.solve(loads, gravity=False, backend="ipopt"),
        mechanism.solve(loads, gravity=False, backend="clarabel"),
        mechanism.solve(loads, gravity=False, exact=True),
    ]
    assert answers[0].method is Method.CLOSED_FORM and answers[1].method is Method.IPOPT
    assert answers[2].method in (Method.CLARABEL, Method.COMPILED)  # a named backend: warm kernel
    assert answers[3].method is Method.EXACT_NEWTON
    for answer in answers:
        assert answer.ok
        assert answer.torsor("drive")[3] == pytest.approx(expected, abs=1e-12)
        stop = next(c for c in answer.contacts if c.point == "backlash")
        assert stop.active and np.array_equal(stop.force, np.zeros(3))
        # the parent holds -T about the axis (exact model: the couple's work is T sin(angle))
        held = -torque * (np.cos(expected) if answer.formulation == "exact" else 1.0)
        assert stop.moment == pytest.approx([held, 0.0, 0.0], abs=1e-9)
        assert answer.reaction("drive").moment[0] == pytest.approx(held, abs=1e-9)
    tip, _ = answers[0].frame_displacement("arm")  # the arm's origin is on the axis
    tip = tip + np.cross(answers[0].frame_displacement("arm").angular, [ARM, 0.0, 0.0])
    assert tip[1] == pytest.approx(ARM * expected, abs=1e-9)


def test_without_a_torque_about_the_axis_the_joint_stays_centred():
    """A force across the arm that makes no moment about the axis leaves the lost motion
    unloaded: the least-norm answer keeps the joint at its command."""
    answer = cantilever().solve([PointForce("arm", [0.0, 0.0, -20.0], [ARM, 0, 0])], gravity=False)
    assert answer.ok and answer.torsor("drive")[3] == 0.0
    assert any("alpha" in note for note in answer.free_motions)


def test_no_backlash_is_the_rigid_drive_bit_for_bit():
    loads = [Torque("arm", [0.0, 0.0, 2.0]), PointForce("arm", [0.0, 10.0, -5.0], [ARM, 0, 0])]
    rigid = cantilever(backlash="").solve(loads, gravity=False)
    zero = cantilever(backlash='backlash="0"').solve(loads, gravity=False)
    for joint, torsor in rigid.torsors.items():
        assert np.array_equal(zero.torsors[joint], torsor)
    assert np.array_equal(zero.reaction("drive").wrench, rigid.reaction("drive").wrench)


def test_a_prismatic_drive_slides_by_half_its_backlash_in_the_file_unit():
    """backlash of a prismatic drive is a length, in the file's unit (here mm)."""
    mechanism = cp.loads("""<?xml version="1.0"?>
<robot name="slide">
  <link name="base"/>
  <link name="carriage"/>
  <joint name="rail" type="prismatic"><parent link="base"/><child link="carriage"/>
    <axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="10" velocity="1"/></joint>
  <clearance_pin unit="mm">
    <joint name="rail" type="prismatic" radial_clearance="0.01" length="100" width="40"
           height="30" driven="true" backlash="0.05"/>
    <force link="carriage" point="0 0 0" value="-30 0 0"/>
  </clearance_pin>
</robot>""")
    answer = mechanism.solve(gravity=False)
    assert answer.ok and answer.torsor("rail")[0] == pytest.approx(-0.025e-3, abs=1e-15)
    stop = next(c for c in answer.contacts if c.point == "backlash")
    assert stop.moment is None and stop.force[0] == pytest.approx(30.0, rel=1e-12)


def test_the_four_bar_crank_stop_holds_the_drive_torque():
    """The four-bar's driven crank with backlash: the stop's moment equals the rigid drive's
    torque (the torque the statics of the linkage ask of the drive), the crank turns by
    -sign(that torque) b/2 (the load pushes it back against its stop); the same on the compiled
    kernel, Clarabel, IPOPT, in a batch and in the exact model."""
    text = (MODELS / "four_bar.urdf").read_text()
    text = text.replace('driven="true" q=', f'driven="true" backlash="{BACKLASH}" q=', 1)
    with_backlash, rigid = cp.loads(text), cp.load(str(MODELS / "four_bar.urdf"))
    drive = rigid.solve().reaction("crank_pivot").drive[3]
    answer = with_backlash.solve()
    stop = next(c for c in answer.contacts if c.point == "backlash" and c.joint == "crank_pivot")
    assert stop.moment[0] == pytest.approx(drive, rel=1e-9)
    turn = -np.sign(drive) * BACKLASH / 2.0
    assert answer.torsor("crank_pivot")[3] == pytest.approx(turn, abs=1e-12)
    rng = np.random.default_rng(3)
    cases = [[PointForce("coupler", [0.0, -40.0, 0.0] + 8.0 * rng.standard_normal(3),
                         [0.09, 0, 0])] for _ in range(20)]  # fmt: skip
    batch = with_backlash.solve_many(cases)
    for k, loads in enumerate(cases):
        ipopt = with_backlash.solve(loads, backend="ipopt")
        for joint, torsor in ipopt.torsors.items():
            assert np.allclose(batch.torsors(joint)[k], torsor, rtol=0, atol=1e-12)
    exact = with_backlash.solve(exact=True)
    assert exact.ok and exact.torsor("crank_pivot")[3] == pytest.approx(turn, abs=1e-12)


def test_backlash_on_every_arm_joint_against_the_axis_moments():
    """The Panda with backlash on every drive (a <default>) and a tool force: each joint turns
    by -sign(tau_j) b/2 and its stop holds tau_j, tau_j the tool wrench's moment about joint j's
    axis from Pinocchio's placements (statics of the child subtree, no solver code)."""
    corpus = pytest.importorskip("test_corpus_robots")
    text = corpus.model_text("panda")
    text = re.sub(r'driven="true"', f'driven="true" backlash="{BACKLASH}"', text)
    mech = cp.loads(text)
    names, tool = corpus.ROBOTS["panda"][1], corpus.ROBOTS["panda"][2]
    answer = mech.solve(loads=corpus.tool_loads("panda"), gravity=False)
    assert answer.ok
    data = mech.model.createData()
    pin.framesForwardKinematics(mech.model, data, mech.configure(None).q)
    point = data.oMf[mech.model.getFrameId(tool)].act(corpus.TOOL_POINT)
    for name in names:
        joint = mech.joint(name)
        placed = data.oMi[joint.joint_id]
        axis = placed.rotation @ joint.rotation[:, 0]
        tau = float(axis @ np.cross(point - placed.translation, corpus.TOOL_FORCE))
        stop = next(c for c in answer.contacts if c.joint == name and c.point == "backlash")
        assert stop.moment[0] == pytest.approx(-tau, rel=1e-9, abs=1e-9), name
        # a joint whose axis the tool wrench does not turn (tau at round-off) stays centred
        turn = np.sign(tau) * BACKLASH / 2 if abs(tau) > 1e-9 else 0.0
        assert answer.torsor(name)[3] == pytest.approx(turn, abs=1e-12), (name, tau)
    amap = mech.accuracy(tool, mech.q_nominal, payloads=[2.0], gravity=False)
    assert "backlash" in amap.contributions and amap.ok.all()


def test_the_envelope_grows_by_the_lever_of_the_backlash():
    """The cantilever's tip: its range across the arm (world y) grows by ARM b/2 each way."""
    rigid = cantilever(backlash="").envelope("arm@[0.5 0 0]", kinds=("translation",))
    lost = cantilever().envelope("arm@[0.5 0 0]", kinds=("translation",))
    across = [0.0, 1.0, 0.0]
    (low0, high0), (low1, high1) = rigid.range(across), lost.range(across)
    assert high1 - high0 == pytest.approx(ARM * BACKLASH / 2, rel=1e-6)
    assert low0 - low1 == pytest.approx(ARM * BACKLASH / 2, rel=1e-6)


def one_journal(attributes: str) -> str:
    """A URDF of one revolute joint 'j' about z with a journal clearance and ``attributes``."""
    return f"""<?xml version="1.0"?>
<robot name="r"><link name="a"/><link name="b"/>
  <joint name="j" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <clearance_pin><joint name="j" type="revolute" radial_clearance="1e-5" length="0.02"
    {attributes}/></clearance_pin></robot>"""


@pytest.mark.parametrize(
    "attributes, message",
    [
        ('driven="false" backlash="0.002"', "not driven"),
        ('driven="true" backlash="-0.002"', "backlash"),
    ],
)
def test_bad_backlash_is_named(attributes, message):
    with pytest.raises(cp.ModelError, match=message):
        cp.loads(one_journal(attributes))


def test_the_report_and_the_coal_check_read_the_stop():
    """The text table gives the drive torque the stop holds and a row for the stop; the coal
    check (which has no surface for a lost motion) leaves it out and passes; JSON carries the
    moment."""
    answer = cantilever().solve(
        [Torque("arm", [0.0, 0.0, 3.0]), PointForce("arm", [0.0, 0.0, -20.0], [ARM, 0, 0])],
        gravity=False,
        exact=True,
    )
    table = answer.table()
    assert "drive backlash" in table and "-3 N m" in table  # 4 significant digits
    report = answer.check()  # the exact pose, as the command line's --check
    assert report.ok and any("backlash" in note for note in report.notes)
    assert all(reading.point != "backlash" for reading in report.joints["drive"].points)
    stop = next(c for c in answer.to_dict()["contacts"] if c["point"] == "backlash")
    assert stop["moment_N_m"] == pytest.approx([-3.0, 0.0, 0.0], abs=1e-5)  # T cos(angle)


def test_a_batch_reads_the_drive_torques_its_stops_hold():
    """solve_many's drive_torques lists every driven joint with backlash and gives what its
    stop holds, as each answer's drive_torque (the Panda with backlash on every drive, random
    tool forces; it listed none of them before)."""
    corpus = pytest.importorskip("test_corpus_robots")
    text = re.sub(
        r'driven="true"', f'driven="true" backlash="{BACKLASH}"', corpus.model_text("panda")
    )
    mech = cp.loads(text)
    names = corpus.ROBOTS["panda"][1]
    base = corpus.tool_loads("panda")
    rng = np.random.default_rng(3)
    cases = [
        [cp.PointForce(load.link, load.force * rng.uniform(0.5, 1.5), load.point) for load in base]
        for _ in range(6)
    ]
    batch = mech.solve_many(cases, gravity=False)
    torques = batch.drive_torques()
    assert set(names) <= set(torques)
    for i in range(len(cases)):
        for name in names:
            assert torques[name][i] == pytest.approx(
                batch[i].drive_torque(name), rel=1e-9, abs=1e-9
            )
