"""Misuse of the library and the command: one named error or one line, never a traceback, a hang
or a silent wrong answer (issue 21, items 6, 7 and 10's second half).

Each test is one finding reproduced on the code before: an exit 0 with bands of a passive joint,
an empty batch reported as all ok, a closure walking 2e7 steps, loads below 1e-154 N solved as no
load, an IndexError for a 1e308 m clearance, a UnicodeEncodeError for a lone surrogate, a
TypeError or AttributeError for an argument of the wrong kind, a traceback (exit 1) for a bad
``--seed``, ``--plot`` or ``--json``, exit 4 for an output point at 1e308 m, numba's RuntimeError
on a read-only install.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
import textwrap
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
from conftest import MODELS, ROOT, one_line, run_command

import clearance_pin as cp
from clearance_pin.kinematics import closure
from clearance_pin.tolerance import command as tolerance_command

SLIDER_CRANK = MODELS / "slider_crank.urdf"


@pytest.fixture(scope="module")
def slider_crank():
    return cp.load(SLIDER_CRANK)


# -- the command: one line, exit 2 ----------------------------------------------------------------
def test_tolerance_refuses_a_passive_joint(capsys):
    """`tolerance --joint pin_A` on the slider-crank: pin_A is passive (the loop sets it), so
    sweeping it is refused with exit 2 naming it; it printed bands and exited 0 before."""
    status, out, err = run_command(
        capsys, "tolerance", SLIDER_CRANK, "--joint", "pin_A", "--samples", 0
    )
    assert status == 2 and out == ""
    line = one_line(err)
    assert "joint" in line and "pin_A is not driven" in line and "crank_pivot" in line


def test_tolerance_names_an_unknown_budget_output_before_sweeping(capsys):
    """`tolerance --budget nope`: refused before the sweep, naming --budget and the outputs there
    are (before: after the whole sweep, as "Sweep.index: unknown output")."""
    status, out, err = run_command(
        capsys, "tolerance", SLIDER_CRANK, "--budget", "nope", "--samples", 0
    )
    assert status == 2 and out == ""
    line = one_line(err)
    assert "--budget" in line and "'nope'" in line and "slider.x" in line
    assert "Sweep.index" not in line


@pytest.mark.parametrize(
    ("arguments", "argument", "shown"),
    [
        ({"joint": "pin_A"}, "joint", "pin_A is not driven"),
        ({"seed": -1, "samples": 10}, "seed", "an integer >= 0"),
        ({"positions": 10**9}, "positions", "from 1 to 10000"),
        ({"samples": 1}, "samples", "from 2 to 1000000"),
    ],
)
def test_the_library_sweep_checks_its_arguments(slider_crank, arguments, argument, shown):
    """`tolerance.sweep` called from Python refuses what the command refuses, with an
    ArgumentError naming the argument (before: bands of a passive joint, NumPy's ValueError for a
    negative seed, an unbounded run)."""
    from clearance_pin.tolerance import sweep

    with pytest.raises(cp.ArgumentError) as caught:
        sweep(slider_crank, ["x4=slider.x"], **arguments)
    assert caught.value.argument == argument
    assert shown in str(caught.value)


@pytest.mark.parametrize(
    ("option", "value", "shown"),
    [
        ("--positions", 1_000_000_000, "from 1 to 10000"),
        ("--samples", 1_000_000_000, "from 2 to 1000000"),
        ("--seed", -1, "an integer >= 0"),
    ],
)
def test_tolerance_counts_and_seed_are_bounded(capsys, monkeypatch, option, value, shown):
    """--positions and --samples have documented upper bounds (10000, 1000000: a billion ran
    unbounded), --seed is >= 0 (NumPy's traceback, exit 1, before): exit 2, one line naming the
    option, before the model is swept (the sweep is replaced by a failure here, so that the code
    before fails at once instead of running for hours)."""

    def no_sweep(*args, **kwargs):
        raise AssertionError("the sweep started")

    monkeypatch.setattr(tolerance_command, "sweep", no_sweep)
    status, out, err = run_command(capsys, "tolerance", SLIDER_CRANK, option, value)
    assert status == 2 and out == ""
    line = one_line(err)
    assert option in line and shown in line


@pytest.mark.parametrize("command", ["solve", "tolerance", "envelope"])
def test_unknown_plot_type_is_refused_before_any_work(tmp_path, capsys, command):
    """--plot x.abc: matplotlib's traceback (exit 1) after the whole computation before; now
    exit 2, one line listing the file types, and nothing computed (no table on stdout)."""
    status, out, err = run_command(capsys, command, SLIDER_CRANK, "--plot", tmp_path / "bands.abc")
    assert status == 2 and out == ""
    line = one_line(err)
    assert "--plot" in line and "bands.abc" in line and ".png" in line


@pytest.mark.parametrize("command", ["tolerance", "envelope"])
def test_json_into_a_missing_folder_is_refused_before_any_work(tmp_path, capsys, command):
    """--json missing/x.json: a FileNotFoundError traceback (exit 1) after the computation
    before; now exit 2, one line naming the folder."""
    target = tmp_path / "missing" / "x.json"
    status, out, err = run_command(capsys, command, SLIDER_CRANK, "--json", target)
    assert status == 2 and out == ""
    line = one_line(err)
    assert "--json" in line and f"no folder {target.parent}" in line


def test_a_file_that_cannot_be_written_is_one_line(tmp_path, capsys, monkeypatch):
    """A write failing at the end (a full disk, simulated: OSError from write_text) is one line
    naming the file, exit 2, not a traceback."""
    from pathlib import Path

    def full(self, *args, **kwargs):
        raise OSError(28, "No space left on device", str(self))

    monkeypatch.setattr(Path, "write_text", full)
    target = tmp_path / "bands.json"
    status, _, err = run_command(
        capsys, "tolerance", SLIDER_CRANK, "--positions", 1, "--samples", 0, "--json", target
    )
    assert status == 2
    line = one_line(err)
    assert str(target) in line and "No space left on device" in line


def test_a_clearance_of_1e308_is_exit_2_naming_the_joint(tmp_path, capsys):
    """radial_clearance="1e308" on pin_A: an IndexError from the reduction (exit 1) before; now
    exit 2, one line naming the file and <joint name='pin_A'>."""
    text = SLIDER_CRANK.read_text()
    old = 'name="pin_A" type="planar_revolute" radial_clearance="5e-05"'
    assert old in text
    path = tmp_path / "huge.urdf"
    path.write_text(text.replace(old, old.replace("5e-05", "1e308")))
    status, _, err = run_command(capsys, "solve", path)
    assert status == 2
    line = one_line(err)
    assert str(path) in line and "<joint name='pin_A'>" in line and "1e+308 m" in line


def test_a_play_many_times_the_mechanism_is_refused(slider_crank):
    """A 10 m play on pin_A of the 0.137 m slider-crank (the others 50 um) was reported as an
    unblocked motion (exit 3); it is now a ModelError: 83x the part it joins (the rod, 0.12 m
    between its pins), beyond any design (model/length_check.py), before the whole-mechanism
    bound of the solver (arguments.check_clearance_sizes) is reached."""
    text = SLIDER_CRANK.read_text().replace(
        'name="pin_A" type="planar_revolute" radial_clearance="5e-05"',
        'name="pin_A" type="planar_revolute" radial_clearance="10"',
    )
    with pytest.raises(cp.ModelError) as caught:
        cp.loads(text, source="ten_metres.urdf")
    assert caught.value.element == "<joint name='pin_A'>"
    assert "radial_clearance 10 m is 83.3x the part it joins (0.12 m" in caught.value.problem


def test_an_output_point_at_1e308_is_exit_2(capsys):
    """`envelope --output rod@[1e308,0,0]`: overflow warnings and exit 4 (the solver) before;
    now exit 2, one line naming the output."""
    status, _, err = run_command(capsys, "envelope", SLIDER_CRANK, "--output", "rod@[1e308,0,0]")
    assert status == 2
    line = one_line(err)
    assert "output" in line and "rod@[1e308,0,0]" in line and "1e+150 m" in line


def test_a_lone_surrogate_in_a_file_is_exit_2_naming_the_file(tmp_path, capsys):
    """A URDF declared unicode_escape with \\ud800 in a comment decodes to a lone surrogate:
    UnicodeEncodeError (exit 1) before; now exit 2 naming the file, and a ModelError from the
    library."""
    text = SLIDER_CRANK.read_text()
    text = text.replace('<?xml version="1.0"?>', '<?xml version="1.0" encoding="unicode_escape"?>')
    text = text.replace(
        '<robot name="slider_crank">', '<robot name="slider_crank"><!-- \\ud800 -->'
    )
    path = tmp_path / "surrogate.urdf"
    path.write_bytes(text.encode("ascii"))
    status, _, err = run_command(capsys, "solve", path)
    assert status == 2
    line = one_line(err)
    assert str(path) in line and "lone surrogate" in line
    with pytest.raises(cp.ModelError, match="lone surrogate"):
        cp.load(path)


# -- the library: a named error ---------------------------------------------------------------------
@pytest.mark.parametrize("chunks", [-1, 0, 1.5, "3"])
def test_solve_many_chunks_is_a_positive_integer(slider_crank, chunks):
    """chunks=-1 with an executor gave an empty batch whose ok.all() is True (1.5 a TypeError):
    an ArgumentError naming chunks now."""
    configurations = [slider_crank.q_nominal] * 3
    with ThreadPoolExecutor(2) as pool, pytest.raises(cp.ArgumentError) as caught:
        slider_crank.solve_many(configurations=configurations, executor=pool, chunks=chunks)
    assert caught.value.argument == "chunks"


def test_solve_many_executor_must_submit(slider_crank):
    """executor="abc": AttributeError ('str' object has no attribute 'submit') before."""
    with pytest.raises(cp.ArgumentError) as caught:
        slider_crank.solve_many(configurations=[slider_crank.q_nominal], executor="abc")
    assert caught.value.argument == "executor"


@pytest.mark.parametrize(("outputs", "argument"), [(123, "outputs"), (["rod", 7], "outputs[1]")])
def test_solve_outputs_are_frame_names(slider_crank, outputs, argument):
    """outputs=123: TypeError ('int' object is not iterable) before; a non-text name too."""
    with pytest.raises(cp.ArgumentError) as caught:
        slider_crank.solve(outputs=outputs)
    assert caught.value.argument == argument


def _scaled_loads(mechanism, factor):
    return [
        cp.PointForce(load.link, force=load.force * factor, point=load.point)
        for load in mechanism.loads
    ]


@pytest.mark.parametrize("factor", [1e-300, 1e160])
def test_loads_beyond_double_precision_are_refused(slider_crank, factor):
    """The model's loads times 1e-300 were solved as no load (ok, no contact), times
    1e160 failed in the solver (SolverError): a LoadError naming the load now."""
    with pytest.raises(cp.LoadError, match="double precision"):
        slider_crank.solve(loads=_scaled_loads(slider_crank, factor))
    with pytest.raises(cp.LoadError, match=r"in loads\[1\]"):
        slider_crank.solve_many(loads=[slider_crank.loads, _scaled_loads(slider_crank, factor)])


@pytest.mark.parametrize("factor", [1e-300, 1e160])
def test_the_resolver_refuses_values_beyond_double_precision(slider_crank, factor):
    """`resolver.solve(values)` checks the new vectors as `solve` checks loads (before: 1e160
    times the loads failed in the solver, 1e-300 times was solved as no load)."""
    resolver = slider_crank.resolver(slider_crank.loads)
    values = np.concatenate([load.force for load in slider_crank.loads])
    np.testing.assert_allclose(
        resolver.solve(values).torsor("pin_A"), slider_crank.solve().torsor("pin_A"), rtol=1e-9
    )
    with pytest.raises(cp.LoadError, match=r"in values.*double precision"):
        resolver.solve(values * factor)


def test_small_loads_give_the_same_pose_or_a_load_error(slider_crank):
    """The settled pose does not depend on the loads' common scale (the equilibrium conditions
    are homogeneous in the load): 1e-150 times the model's loads give the torsors of the loads
    themselves (reference: the same solve at scale 1); 1e-160 times, solved as no load before
    (ok, no contact, every torsor 0), is a LoadError saying to scale them up."""
    with pytest.raises(cp.LoadError, match="multiply them all by one factor"):
        slider_crank.solve(loads=_scaled_loads(slider_crank, 1e-160))
    reference = slider_crank.solve()
    small = slider_crank.solve(loads=_scaled_loads(slider_crank, 1e-150))
    assert small.ok and [c.label for c in small.active_contacts] == [
        c.label for c in reference.active_contacts
    ]
    for joint in ("crank_pivot", "pin_A", "pin_B", "slide"):
        np.testing.assert_allclose(
            small.torsor(joint), reference.torsor(joint), rtol=1e-9, atol=1e-15
        )


def test_a_driven_angle_far_away_walks_the_short_way(slider_crank, monkeypatch):
    """q = nominal + 1e6 rad on the crank: the closure walked 2e7 steps of 0.05 rad (hours);
    it walks at most pi / 0.05 + 1 steps now, and the pose is that of nominal + (1e6 mod 2 pi)
    (the same crank position): equal torsors."""
    calls = [0]
    close = closure.close_loops

    def counted(mechanism, q, *args, **kwargs):
        calls[0] += 1
        if calls[0] > 200:
            raise AssertionError("the closure walks more than 200 steps")
        return close(mechanism, q, *args, **kwargs)

    monkeypatch.setattr(closure, "close_loops", counted)
    far = slider_crank.q_nominal.copy()
    far[0] += 1e6
    near = slider_crank.q_nominal.copy()
    near[0] += math.remainder(1e6, 2 * math.pi)
    with pytest.warns(cp.SuspectValueWarning, match="outside the joint's limits"):
        answer = slider_crank.solve(q=far)
    assert calls[0] <= math.ceil(math.pi / 0.05) + 1
    assert answer.configuration.q[0] == far[0]
    expected = slider_crank.solve(q=near)
    for joint in ("crank_pivot", "pin_A", "pin_B", "slide"):
        np.testing.assert_allclose(
            answer.torsor(joint), expected.torsor(joint), rtol=1e-6, atol=1e-12
        )


def test_an_unwritable_numba_cache_falls_back_to_numpy(tmp_path, slider_crank):
    """A read-only install: numba cannot write its cache and raises RuntimeError ("no locator
    available") from load_kernel(), and from solve() with CLEARANCE_PIN_COMPILED=1. Now one
    KernelUnavailableWarning and the NumPy path's answers. The tests run as root, which writes
    through any permission, so numba's own writability probe (_CacheLocator.ensure_cache_path,
    which makes the folder and a temporary file in it) is made to fail as an unwritable folder
    does; NUMBA_CACHE_DIR points at a fresh folder so that no cached kernel is found. The
    answers are those of this process's solve."""
    script = textwrap.dedent(
        """
        import sys
        import warnings

        import numba.core.caching as caching

        def unwritable(self):
            raise PermissionError(13, "Permission denied", self.get_cache_path())

        caching._CacheLocator.ensure_cache_path = unwritable
        import clearance_pin
        from clearance_pin.equilibrium import fast_path

        mechanism = clearance_pin.load(sys.argv[1])
        with warnings.catch_warnings(record=True) as record:
            warnings.simplefilter("always")
            answers = [mechanism.solve().torsor("pin_A") for _ in range(3)]
            seconds = fast_path.load_kernel()
        kinds = [type(w.message).__name__ for w in record]
        print(kinds.count("KernelUnavailableWarning"), seconds, fast_path.compiled_kernel(1))
        print(*answers[0], *answers[2])
        """
    )
    environment = {
        **os.environ,
        "CLEARANCE_PIN_COMPILED": "1",
        "NUMBA_CACHE_DIR": str(tmp_path / "cache"),
        "PYTHONPATH": str(ROOT),
    }
    done = subprocess.run(
        [sys.executable, "-c", script, str(SLIDER_CRANK)],
        capture_output=True,
        text=True,
        env=environment,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    counts, answers = done.stdout.strip().splitlines()
    assert counts.split() == ["1", "0.0", "None"]
    values = np.array([float(v) for v in answers.split()]).reshape(2, 6)
    np.testing.assert_allclose(values, [slider_crank.solve().torsor("pin_A")] * 2, atol=1e-12)


def test_a_driven_slide_far_away_is_refused_naming_the_joint():
    """leg1 of the Stewart platform (a driven prismatic joint, length scale 0.215 m) at +1000 m:
    the closure walked towards it until a step failed to close (a ModelError on a loop joint,
    saying nothing of q); a walk of more than 2000 steps (100 length scales) is now refused at
    once, an ArgumentError on q naming leg1."""
    stewart = cp.load(ROOT / "tests" / "data" / "stewart_6ups.urdf")
    q = stewart.q_nominal.copy()
    q[stewart.model.joints[stewart.model.getJointId("leg1")].idx_q] += 1e3
    with (
        pytest.raises(cp.ArgumentError) as caught,
        pytest.warns(cp.SuspectValueWarning, match="outside the joint's limits"),
    ):
        stewart.solve(q=q)
    assert caught.value.argument == "q" and "joint 'leg1'" in caught.value.note
