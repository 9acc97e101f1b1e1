"""API arguments of the wrong kind raise ArgumentError naming them (issue 10, findings 7 and 8).

Each case was a wrong answer, a traceback from deep inside, or a misleading error before: a string
q taken as radians, gravity="on" appended as a load, a mistyped backend reported as a numerical
failure, a single load not in a list failing in iteration, an unknown keyword a bare TypeError.
The error must name the argument, say what is expected and what was found, and come before any
solve (so the mechanism still solves afterwards).
"""

from __future__ import annotations

import pickle
import re
from pathlib import Path

import numpy as np
import pytest
from conftest import MODELS

import clearance_pin as cp


@pytest.fixture(scope="module")
def pendulum():
    return cp.load(MODELS / "double_pendulum.urdf")


@pytest.mark.parametrize(
    ("options", "argument", "shown"),
    [
        ({"q": "60"}, "q", "'60'"),
        ({"q": ["60", "45"]}, "q", "text"),
        ({"q": [0.5, 0.7, 0.1]}, "q", "shape (3,)"),
        ({"q": [0.5, np.nan]}, "q", "not finite"),
        ({"gravity": "on"}, "gravity", "'on'"),
        ({"backend": "clarabl"}, "backend", "'clarabl'"),
        ({"exact": "yes"}, "exact", "'yes'"),
        ({"tol": 0.0}, "tol", "0.0"),
        ({"tol": -1e-9}, "tol", "-1e-09"),
        ({"tol": "1e-9"}, "tol", "'1e-9'"),
        ({"accuracy": float("inf")}, "accuracy", "inf"),
        ({"warm_start": "no"}, "warm_start", "'no'"),
        ({"loads": "tip"}, "loads", "'tip'"),
    ],
)
def test_solve_argument_errors(pendulum, options, argument, shown):
    """Every wrong argument of solve raises ArgumentError with .argument, .expected and .found,
    all in the message."""
    with pytest.raises(cp.ArgumentError) as caught:
        pendulum.solve(**options)
    error = caught.value
    assert error.argument == argument
    assert error.expected and error.expected in str(error)
    assert str(error).startswith(f"{argument}: expected")
    assert shown in str(error)
    assert pendulum.solve().ok  # nothing was left half-done


def test_mistyped_backend_is_not_a_numerical_failure(pendulum):
    """backend='clarabl' names the valid backends; it is no SolverError."""
    with pytest.raises(cp.ArgumentError, match="'auto', 'clarabel', 'ipopt'") as caught:
        pendulum.solve(backend="clarabl")
    assert not isinstance(caught.value, cp.SolverError)


def test_single_load_not_in_a_list(pendulum):
    """solve(loads=PointForce(...)) says to write loads=[load]; a list of it solves."""
    force = cp.PointForce("tip", force=[0.0, -10.0, 0.0])
    with pytest.raises(cp.ArgumentError, match=r"loads=\[load\]") as caught:
        pendulum.solve(loads=force)
    assert caught.value.found is force
    assert pendulum.solve(loads=[force]).ok


@pytest.mark.parametrize(
    ("make", "argument", "named"),
    [
        (lambda: cp.Torque("tip", value=[0.0, 0.0, 1.0]), "Torque(value=...)", "link, torque"),
        (lambda: cp.PointForce("tip", value=[0.0, 1.0, 0.0]), "PointForce(value=...)", "force"),
        (lambda: cp.Gravity(g=[0.0, 0.0, -9.81]), "Gravity(g=...)", "acceleration"),
        (lambda: cp.Torque("tip"), "Torque(...)", "missing"),
        (lambda: cp.PointForce(7, [0.0, 1.0, 0.0]), "PointForce(link)", "a link name"),
    ],
)
def test_load_constructor_errors(make, argument, named):
    """An unknown keyword, a missing argument or a link that is not a name: ArgumentError naming
    the argument and the valid ones."""
    with pytest.raises(cp.ArgumentError) as caught:
        make()
    assert caught.value.argument == argument
    assert named in str(caught.value)


def test_loads_still_build_and_pickle():
    """The checked constructors keep keywords, positional arguments, replace() and pickle."""
    import dataclasses

    force = cp.PointForce(link="tip", force=[1.0, 2.0, 3.0], point=[0.0, 0.1, 0.0])
    assert np.array_equal(cp.PointForce("tip", [1.0, 2.0, 3.0], [0.0, 0.1, 0.0]).point, force.point)
    copy = pickle.loads(pickle.dumps(force))
    assert copy.link == "tip" and np.array_equal(copy.force, force.force)
    assert dataclasses.replace(force, link="link2").link == "link2"
    assert cp.Torque("tip", torque=[0.0, 0.0, 1.0]).torque[2] == 1.0


def test_solve_many_argument_errors(pendulum):
    """solve_many checks its arguments before any case, even with errors='return': a flat list
    of loads (one case not wrapped), a text configuration, a wrong backend, a wrong errors."""
    force = cp.PointForce("tip", [0.0, -10.0, 0.0])
    with pytest.raises(cp.ArgumentError) as caught:
        pendulum.solve_many([force, force])
    assert caught.value.argument == "loads[0]"
    with pytest.raises(cp.ArgumentError) as caught:  # after well-formed cases of both kinds
        pendulum.solve_many([[force], (force,), None, "tip"])
    assert caught.value.argument == "loads[3]"
    with pytest.raises(cp.ArgumentError) as caught:
        pendulum.solve_many(configurations=[pendulum.q_nominal, ["1", "2"]])
    assert caught.value.argument == "configurations[1]"
    with pytest.raises(cp.ArgumentError) as caught:
        pendulum.solve_many([[force]], backend="clarabl", errors="return")
    assert caught.value.argument == "backend"
    with pytest.raises(cp.ArgumentError) as caught:
        pendulum.solve_many([[force]], errors="ignore")
    assert caught.value.argument == "errors"
    batch = pendulum.solve_many([[force], [force]], errors="return")
    assert all(result.ok for result in batch)


@pytest.mark.parametrize(
    ("force", "point", "words"),
    [
        ([1e-200, 0.0, 0.0], [0.1, 0.0, 0.0], "below the smallest taken"),  # a far point hides none
        ([1e80, 0.0, 0.0], [1e80, 0.0, 0.0], "the moment |p x F|"),
        ([1e151, 0.0, 0.0], [0.0, 0.0, 0.0], "beyond the largest taken"),
    ],
)
def test_solve_many_names_the_case_beyond_double_precision(pendulum, force, point, words):
    """The magnitudes of many cases are checked in bulk; a case beyond the limits is still named
    (its index and load), as one solve names it, and the well-formed cases pass."""
    fine = cp.PointForce("tip", [0.0, -10.0, 0.0])
    with pytest.raises(cp.LoadError, match=re.escape(words)) as caught:
        pendulum.solve_many([[fine], [fine], [cp.PointForce("tip", force, point)]])
    assert "in loads[2]" in str(caught.value)
    assert len(pendulum.solve_many([[fine]] * 3, errors="raise")) == 3


def test_argument_error_pickles():
    """ArgumentError survives pickling (errors cross process pools) with its attributes."""
    error = cp.ArgumentError("tol", "a finite number > 0", -1.0, "negative")
    copy = pickle.loads(pickle.dumps(error))
    assert (copy.argument, copy.expected, copy.found, copy.note) == (
        "tol",
        error.expected,
        -1.0,
        "negative",
    )
    assert str(copy) == str(error)


def test_load_argument_errors(tmp_path):
    """load(): a path that is not a path, package_dirs that are not directories."""
    with pytest.raises(cp.ArgumentError) as caught:
        cp.load(42)
    assert caught.value.argument == "path"
    with pytest.raises(cp.ArgumentError) as caught:
        cp.load(MODELS / "four_bar.urdf", package_dirs=[tmp_path / "missing"])
    assert caught.value.argument == "package_dirs[0]"
    with pytest.raises(cp.ArgumentError) as caught:
        cp.load(MODELS / "four_bar.urdf", package_dirs=3)
    assert caught.value.argument == "package_dirs"
    with pytest.raises(cp.ArgumentError) as caught:
        cp.loads(None)
    assert caught.value.argument == "text"


def test_text_q_in_the_file_is_a_model_error():
    """In the file, q="60deg" is not a number: a ModelError naming the joint (this was already
    so; q="60" is a number, and the limits warning of test_inputs_warnings catches it)."""
    text = (MODELS / "double_pendulum.urdf").read_text()
    text = text.replace('q="0.5235987755982988"', 'q="60deg"')
    with pytest.raises(cp.ModelError) as caught:
        cp.loads(text)
    assert caught.value.element == "<joint name='shoulder'>"
    assert "'60deg' is not a number" in caught.value.problem


def test_many_configurations_checked_as_a_list():
    """solve_many and resolver.solve_many: one configuration (nq,) given alone is refused naming
    the shape expected; values outside the joints' limits give one SuspectValueWarning for the
    list (how many, the first), as one solve's q gives one."""
    arm = cp.load(str(Path(__file__).resolve().parents[1] / "models" / "arm_6r.urdf"))
    resolver = arm.resolver()
    q = arm.q_nominal
    for call in (
        lambda: arm.solve_many(configurations=q),
        lambda: resolver.solve_many([[0.0, 0.0, -5.0]], configurations=q),
    ):
        with pytest.raises(cp.ArgumentError, match=r"shape \(6,\): one configuration"):
            call()
    poses = [q.copy() for _ in range(4)]
    poses[2][1], poses[3][1] = 1e6, 7.0
    for call in (
        lambda: arm.solve_many(configurations=poses),
        lambda: resolver.solve_many([[0.0, 0.0, -5.0]], configurations=poses),
    ):
        with pytest.warns(cp.SuspectValueWarning) as caught:
            call()
        assert len(caught) == 1
        assert "2 of 4 put joint 'shoulder_lift'" in str(caught[0].message)
        assert "configurations[2]" in str(caught[0].message)


ENTRY_POINTS = {
    "solve": lambda mechanism, **options: mechanism.solve(**options),
    "solve_many": lambda mechanism, **options: mechanism.solve_many([None, None], **options),
    "resolver": lambda mechanism, **options: mechanism.resolver(**options),
}


@pytest.mark.parametrize("entry", sorted(ENTRY_POINTS))
@pytest.mark.parametrize(
    ("options", "argument"),
    [
        ({"tolerance": 1e-9}, "tolerance"),  # unknown: named, with the options there are
        ({"backend": "clarabl"}, "backend"),
        ({"exact": "yes"}, "exact"),
        ({"accuracy": -1.0}, "accuracy"),
        ({"outputs": "tip"}, "outputs"),
        ({"warm_start": 1}, "warm_start"),
    ],
)
def test_every_entry_point_checks_the_same_options(pendulum, entry, options, argument):
    """One options object (equilibrium/options.py) for solve, solve_many and the resolver: the
    same wrong option is refused the same way in each (issue 22)."""
    with pytest.raises(cp.ArgumentError) as caught:
        ENTRY_POINTS[entry](pendulum, **options)
    assert caught.value.argument == argument
    if argument == "tolerance":
        assert "one of the options exact, gravity, tol, backend" in str(caught.value)


@pytest.mark.parametrize("entry", sorted(ENTRY_POINTS))
def test_every_option_works_in_every_entry_point(pendulum, entry):
    """exact="auto" with its accuracy, outputs, tol, backend and warm_start given together give
    the answer of solve with them (the resolver's by solve(values) and solve_many(values))."""
    options = {"exact": "auto", "accuracy": 1e-12, "outputs": ["tip"], "tol": 1e-10,
               "backend": "clarabel", "warm_start": False, "gravity": True}  # fmt: skip
    expected = pendulum.solve(**options)
    if entry == "resolver":
        resolver = pendulum.resolver(**options)
        vector = np.concatenate([load.force for load in resolver.loads if hasattr(load, "force")])
        answers = [resolver.solve(vector), resolver.solve_many(vector[None])[0]]
    elif entry == "solve_many":
        answers = list(pendulum.solve_many([None, None], **options))
    else:
        answers = [pendulum.solve(**options)]
    for answer in answers:
        assert answer.formulation == expected.formulation and "tip" in answer.outputs
        np.testing.assert_allclose(answer.outputs["tip"][0], expected.outputs["tip"][0], atol=1e-12)


def test_batch_and_check_arguments_are_named(pendulum):
    """From an API break-test: each of these is an ArgumentError naming the argument (a plain
    ClearancePinError, a TypeError from an inner function or an unnamed row before)."""
    import inspect

    from clearance_pin.check import CHECK_OPTIONS, check_equilibrium

    force = cp.PointForce("tip", [0.0, -10.0, 0.0])
    q = pendulum.q_nominal
    with pytest.raises(cp.ArgumentError) as caught:
        pendulum.solve_many([[force]] * 3, configurations=[q, q])
    assert caught.value.argument == "configurations"
    with pytest.raises(cp.ArgumentError, match=r"solve_many\(configurations=") as caught:
        pendulum.solve_many([[force]], q=q)
    assert caught.value.argument == "q"
    resolver = pendulum.resolver([force])
    values = np.tile(force.force, (3, 1))
    values[1, 2] = np.nan
    with pytest.raises(cp.ArgumentError) as caught:
        resolver.solve_many(values)
    assert caught.value.argument == "values[1]"
    with pytest.raises(cp.ArgumentError, match=r"mechanism.resolver") as caught:
        resolver.solve_many(values[[0]], exact=True)
    assert caught.value.argument == "exact"
    with pytest.raises(cp.ArgumentError) as caught:
        pendulum.solve().check(foo=1)
    assert caught.value.argument == "foo"
    signature = inspect.signature(check_equilibrium).parameters
    assert set(CHECK_OPTIONS) == {n for n, p in signature.items() if p.kind is p.KEYWORD_ONLY}


def test_one_gravity_per_solve():
    """A Gravity among the loads stands in for the model's gravity (arm_6r's file switches it
    on): the drives hold Pinocchio's generalised gravity of that acceleration alone
    (independent: pinocchio.computeGeneralizedGravity), in a single solve, a batch mixing cases
    with and without it, and a resolver; beside a gravity option, or twice among the loads, it
    is refused by name (before, the two added up: a second weight)."""
    import pinocchio as pin

    arm = cp.load(MODELS / "arm_6r.urdf")
    tilted = cp.Gravity([3.0, -2.0, -9.0])
    model = pin.Model(arm.model)
    model.gravity = pin.Motion(tilted.acceleration, np.zeros(3))
    weight = pin.computeGeneralizedGravity(model, model.createData(), arm.q_nominal)
    answer = arm.solve([tilted])
    for joint in arm.joints:
        v = model.joints[model.getJointId(joint)].idx_v
        assert abs(answer.drive_torque(joint) - weight[v]) <= 1e-9 * np.abs(weight).max()
    push = cp.PointForce("tool", [0.0, 20.0, -5.0])
    cases = [[push, tilted], [push], [tilted], [push, tilted]]
    batch = arm.solve_many(cases, progress=False)
    alone = arm.resolver([push, tilted]).solve([0.0, 20.0, -5.0])
    for case, item in zip(cases, batch):
        single = arm.solve(case)
        for joint in arm.joints:
            assert np.allclose(item.torsor(joint), single.torsor(joint), rtol=0, atol=1e-15)
    for joint in arm.joints:
        assert np.allclose(alone.torsor(joint), batch[0].torsor(joint), rtol=0, atol=1e-15)
    for option in (True, cp.Gravity(), [0.0, 0.0, -9.81]):
        with pytest.raises(cp.ArgumentError, match="one gravity per solve") as caught:
            arm.solve([tilted], gravity=option)
        assert caught.value.argument == "gravity"
    with pytest.raises(cp.ArgumentError, match="at most one Gravity") as caught:
        arm.solve([tilted, cp.Gravity()])
    assert caught.value.argument == "loads"
    refused = arm.solve_many(cases, gravity=True, errors="return", progress=False)
    assert [isinstance(item, cp.ArgumentError) for item in refused] == [True, False, True, True]
    assert arm.solve([tilted], gravity=False).ok  # adds none: the loads' gravity alone


def test_gravity_as_an_acceleration(pendulum):
    """gravity= takes an acceleration as 3 numbers [m/s^2], as from_model does: the answer of
    the same Gravity."""
    given = pendulum.solve(gravity=[0.0, 1.0, -5.0])
    same = pendulum.solve(gravity=cp.Gravity([0.0, 1.0, -5.0]))
    for joint in pendulum.joints:
        assert np.array_equal(given.torsor(joint), same.torsor(joint))
    with pytest.raises(cp.ArgumentError, match="3 numbers"):
        pendulum.solve(gravity=[0.0, 1.0])
