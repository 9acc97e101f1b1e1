"""Random mechanisms against an independent formulation (tests/oracle.py).

Hypothesis draws trees of 2..8 bodies on random joint kinds, closed by 0..2 loop joints, with
clearances from 1e-6 to 1e-3 m and random loads (tests/mechanism_strategies.py); three times in four
the load is first cleared of its components along the motions that nothing blocks, so that an
equilibrium exists. clearance_pin and the oracle (cvxpy + Clarabel on body twists, Newton-polished)
must agree: same energy to 1e-8, no penetration beyond 1e-9 of a clearance, torsors within 1e-7 of
the largest clearance in the directions the load sees, the reported contact forces balancing the
load (virtual work, checked by the oracle) to 1e-9, ``ok``; an unbounded load must be unbounded for
the oracle too. A clear diagnosis (``SolverError``) is accepted and counted.

Outcomes that hit a known library issue are recognised from the mechanism alone and reported as
such (each has a reproducer in test_stability.py, a strict xfail while the issue is open, a
regression test once fixed):

- ``no-work-*``: the load does no work on any admissible motion up to round-off (it passes
  through a pivot); the library takes the round-off as a load;
- ``ambiguous-closure``: a loop condition holds up to round-off or to a 1e-9 misalignment, and
  the library's rank decision differs from the oracle's (the round-off case was a bug, fixed; a
  1e-10 misalignment is a genuinely ambiguous rank);
- ``known-unpolished``: the active-set polish failed; the answer is optimal but the torsors differ
  from the oracle's by more than 1e-7 of the clearance along a flat (non-unique) direction that
  the library then does not report (fixed: unverified answers now raise SolverError);
- ``known-no-motion-crash``: no tree joint can move (ValueError instead of 'indeterminate');
- ``known-skewed-frame``: a joint axis within ~1e-4 rad of -x gives a clearance frame that is not
  a rotation (joints.rotation_x_to), and the answer violates the closure.

Not judged either: ``ambiguous-free-motion`` (a motion the contacts see only to 1e-8, e.g. two
journals misaligned by 1e-9 rad: free for clearance_pin, bounded with a 1e7 lever for the oracle)
``oracle-inaccurate`` (the oracle's own answer violates a contact or a closure by 1e-9), and
``weakly-bounded-unbounded`` (clearance_pin says unbounded where the oracle's optimum moves the
parts by more than 100 clearances: a diagnosis is then the useful answer).

The CI run is small (30 examples); ``python benchmarks/stability.py`` runs thousands.
"""

from __future__ import annotations

from hypothesis import HealthCheck, event, example, given, settings
from hypothesis import strategies as st
from mechanism_strategies import (
    BodySpec,
    JointSpec,
    LoadSpec,
    LoopSpec,
    MechanismSpec,
    mechanisms,
)
from oracle import Oracle, bounded_loads, judge

import clearance_pin

ACCEPTED = {
    "agree",
    "agree-flat",
    "agree-energy",
    "agree-certified",
    "unbounded",
    "indeterminate",
    "diagnosed",
    "refused-load",
    "oracle-failed",
    "oracle-inaccurate",
    "ambiguous-free-motion",
    "weakly-bounded-unbounded",
}
KNOWN = {
    "no-work-unbounded": "test_stability.py::test_load_through_a_pivot_is_not_unbounded",
    "no-work-moved": "test_stability.py::test_load_through_a_pivot_is_not_unbounded",
    "ambiguous-closure": "test_stability.py::test_coaxial_loop_in_rotated_frames",
    "known-unpolished": "test_stability.py::test_flat_optimum_is_reported_with_its_minimum_norm_point",
    "known-no-motion-crash": "test_stability.py::test_mechanism_without_motion",
    "known-skewed-frame": "test_stability.py::test_clearance_frame_is_a_rotation",
    "known-below-unbounded-threshold": (
        "test_equilibrium_degenerate.py::test_a_neglected_load_share_along_a_free_motion_is_reported"
    ),
}
SETTINGS = settings(
    max_examples=30,
    deadline=None,
    derandomize=True,
    print_blob=True,
    suppress_health_check=[
        HealthCheck.too_slow,
        HealthCheck.filter_too_much,
        HealthCheck.data_too_large,
    ],
)

# A shaft on a spherical joint and a cylindrical loop joint, loaded off-axis (the first loading
# case of Younes et al. written as a random-mechanism spec).
SHAFT = MechanismSpec(
    bodies=(
        BodySpec(
            0, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), JointSpec("spherical", (1.0, 0.0, 0.0), 1e-4)
        ),
    ),
    loops=(LoopSpec(0, 1, (0.2, 0.0, 0.0), JointSpec("cylindrical", (1.0, 0.0, 0.0), 1e-4, 0.04)),),
    loads=(LoadSpec(1, (1.0, 1.0, 1.0), (0.3, 0.0, 0.0)),),
)
# Two bodies in series on journal bearings with axial play, the first driven, closed to the
# ground by a planar pin: every kind of contact (disc, slab) in one small loop.
CHAIN = MechanismSpec(
    bodies=(
        BodySpec(
            0,
            (0.0, 0.0, 0.0),
            (0.0, 0.0, 0.0),
            JointSpec("revolute", (0.0, 0.0, 1.0), 2e-5, 0.03, 1e-5, driven=True),
        ),
        BodySpec(
            1,
            (0.1, 0.0, 0.0),
            (0.0, 0.0, 0.0),
            JointSpec("revolute", (0.0, 0.0, 1.0), 5e-5, 0.02, 2e-5),
        ),
    ),
    loops=(LoopSpec(0, 2, (0.2, 0.05, 0.0), JointSpec("planar_revolute", (0.0, 0.0, 1.0), 1e-3)),),
    loads=(LoadSpec(2, (3.0, -40.0, 5.0), (0.05, 0.0, 0.0)), LoadSpec(1, (0.0, 0.0, 0.7))),
)


def run_case(spec: MechanismSpec, project: bool, record: bool = False) -> str:
    """Judge one random mechanism; returns the verdict kind (raises on a failure)."""
    mechanism = clearance_pin.loads(spec.urdf(), source="<random mechanism>")
    loads = mechanism.resolve_loads(None, None)
    if project:
        loads = bounded_loads(Oracle(mechanism), loads)
    verdict = judge(mechanism, loads)
    if record:
        event(verdict.kind)
    assert verdict.kind in ACCEPTED or verdict.kind in KNOWN, (
        f"{verdict.kind}: {verdict.errors}\n{verdict.detail}\nloads: {loads}\n{spec.urdf()}"
    )
    return verdict.kind


@SETTINGS
@given(spec=mechanisms(), project=st.integers(0, 3).map(bool))
@example(spec=SHAFT, project=False)
@example(spec=CHAIN, project=False)
@example(spec=CHAIN, project=True)
def test_random_mechanism_agrees_with_the_oracle(spec, project):
    """clearance_pin and the independent oracle agree on a random mechanism (or the outcome is a
    diagnosis, or a recognised known issue)."""
    run_case(spec, project, record=True)


def test_hand_written_examples_agree_exactly():
    """The two hand-written specs above are solved, verified and agree with the oracle (not merely
    diagnosed): they guard the comparison itself against vacuous passes."""
    assert run_case(SHAFT, False) == "agree"
    assert run_case(CHAIN, False) in ("agree", "agree-flat")
    assert run_case(CHAIN, True) in ("agree", "agree-flat")


@settings(
    max_examples=10,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
@given(spec=mechanisms(min_bodies=1, max_bodies=3, max_loops=1))
def test_generated_model_files_load(spec):
    """Every generated model file is a valid model (the generator writes what the format allows)."""
    mechanism = clearance_pin.loads(spec.urdf())
    assert len(mechanism.tree_joints) == len(spec.bodies)
    assert len(mechanism.loop_joints) == len(spec.loops)
