"""The ``clearance-pin`` command: every sub-command and every documented exit status.

The exit statuses (README, "Command line"): 0 a verified equilibrium, 1 residuals or check out of
tolerance, 2 a bad model, load or option (one line naming the file, the element and the problem)
and bad command-line arguments (argparse), 3 no equilibrium (unbounded load), 4 the solver did not
reach a verified answer. The command runs in-process through ``clearance_pin.cli.main``; one test
runs the installed entry point in a subprocess.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from conftest import MODELS, one_line, run_command

import clearance_pin as cp
from clearance_pin.cli import main
from clearance_pin.errors import SolverError
from clearance_pin.json_documents import schema
from clearance_pin.mechanism import Mechanism

PENDULUM = MODELS / "double_pendulum.urdf"
SHOULDER_DRIVE = ' driven="true" q="0.5235987755982988"'


def _pendulum_variant(tmp_path: Path, name: str, old: str, new: str) -> Path:
    """models/double_pendulum.urdf with one piece of text replaced, written to ``tmp_path``."""
    text = PENDULUM.read_text()
    assert old in text
    path = tmp_path / name
    path.write_text(text.replace(old, new))
    return path


# -- solve ----------------------------------------------------------------------------------------
def test_solve_prints_the_table_and_exits_0(capsys):
    status, out, err = run_command(capsys, "solve", MODELS / "four_bar.urdf")
    assert status == 0 and err == ""
    assert f"from {MODELS / 'four_bar.urdf'}" in out.splitlines()[0]
    for joint in cp.load(MODELS / "four_bar.urdf").joints:
        assert joint in out


def test_solve_json_is_the_library_answer(capsys):
    """--exact --json prints the exact answer and its linear seed, as Mechanism.solve gives them;
    the contacts are the README's (ball, and the journal's right end on the bore)."""
    path = MODELS / "younes_sphere_cylinder.urdf"
    status, out, err = run_command(capsys, "solve", path, "--exact", "--json")
    assert status == 0 and err == ""
    document = json.loads(out)
    assert document["model"] == str(path)
    exact = cp.load(path).solve(exact=True)
    for key, answer in (("equilibrium", exact), ("linear", exact.linear)):
        printed = document[key]
        assert printed["formulation"] == answer.formulation and printed["ok"] is True
        for joint, torsor in printed["torsors"].items():
            both = torsor["translation_m"] + torsor["rotation_rad"]
            np.testing.assert_allclose(both, answer.torsor(joint), rtol=0, atol=1e-15)
    active = sorted(
        f"{c['joint']}:{c['point']}" for c in document["linear"]["contacts"] if c["active"]
    )
    assert active == ["I1:ball", "I2:end+"]
    assert document["equilibrium"]["formulation"] == "exact"


def test_gravity_option_overrides_the_model(capsys):
    """The 6R arm's model switches gravity on; --gravity off solves without the weights, as
    Mechanism.solve(gravity=False) does, and --gravity on as the model does."""
    path = MODELS / "arm_6r.urdf"
    mechanism = cp.load(path)
    answers = {"on": mechanism.solve(), "off": mechanism.solve(gravity=False)}
    printed = {}
    for setting, answer in answers.items():
        status, out, _ = run_command(capsys, "solve", path, "--json", "--gravity", setting)
        assert status == 0
        torsors = json.loads(out)["equilibrium"]["torsors"]
        printed[setting] = {j: t["translation_m"] + t["rotation_rad"] for j, t in torsors.items()}
        for joint, torsor in printed[setting].items():
            np.testing.assert_allclose(torsor, answer.torsor(joint), rtol=0, atol=1e-15)
    moved = max(
        np.abs(np.subtract(printed["on"][j], printed["off"][j])).max() for j in printed["on"]
    )
    assert moved > 1e-7  # the weights move the parts in their play


def test_check_measures_the_exact_pose_and_reports_the_linear_departure(capsys):
    """--check on the default (linear) answer measures the exact pose, where the contacts sit on
    the real boundaries (exit 0), and reports the linear pose's departure from them (second order,
    README) as information, not as a failure; the JSON carries both."""
    path = MODELS / "four_bar.urdf"
    status, out, err = run_command(capsys, "solve", path, "--check")
    assert status == 0 and err == ""
    assert "coal check (the exact pose of the small-displacement answer): ok" in out
    assert "FAIL" not in out
    assert "the small-displacement pose itself sits up to" in out and "information" in out
    status, out, err = run_command(capsys, "solve", path, "--check", "--json")
    document = json.loads(out)
    assert status == 0 and document["check"]["ok"] is True
    assert document["check"]["formulation"] == "exact"
    assert document["linear_departure"]["ok"] is False  # off the boundary at second order
    assert document["linear_departure"]["information"] is True  # not a verdict
    assert document["check"]["information"] is False
    status, out, err = run_command(capsys, "solve", path, "--check", "--exact")
    assert status == 0 and err == ""
    assert "coal check (exact): ok" in out and "FAIL" not in out and "itself sits" not in out
    assert out.index("equilibrium (linear model)") < out.index("equilibrium (exact model)")


def test_a_failing_check_exits_1(monkeypatch, capsys):
    """A check of the exact pose that fails (forced: the report says not ok) exits 1 with one
    line saying so after the tables."""
    from clearance_pin.check import report

    monkeypatch.setattr(report.CheckReport, "ok", property(lambda self: False))
    status, _, err = run_command(capsys, "solve", MODELS / "four_bar.urdf", "--check", "--exact")
    assert status == 1
    assert "coal check out of tolerance" in one_line(err)


def test_output_frames_are_reported(capsys):
    """--output FRAME reports that frame's world displacement (table and JSON), with the exact -
    linear difference when both formulations run."""
    status, out, _ = run_command(
        capsys, "solve", MODELS / "arm_6r.urdf", "--exact", "--output", "wrist_2"
    )
    assert status == 0 and "wrist_2" in out and "exact - linear [um]" in out
    status, out, _ = run_command(
        capsys, "solve", MODELS / "arm_6r.urdf", "--output", "wrist_2", "--json"
    )
    assert "wrist_2" in json.loads(out)["equilibrium"]["outputs"]


# the warnings are the test's subject: shown (printed by the command), and asserted as printed
@pytest.mark.filterwarnings("default::clearance_pin.errors.ClearancePinWarning")
def test_warnings_are_one_line(tmp_path, capsys):
    """A warning (here: clearances typed in mm) reaches the user as one line each, naming the
    joint, without Python's source echo."""
    text = (MODELS / "four_bar.urdf").read_text()
    model = tmp_path / "four_bar_mm.urdf"
    model.write_text(text.replace('radial_clearance="5e-05"', 'radial_clearance="0.05"'))
    _, _, err = run_command(capsys, "solve", model)
    warned = [line for line in err.splitlines() if "SuspectValueWarning" in line]
    assert len(warned) == 4 and all(line.startswith("clearance-pin: warning") for line in warned)
    assert "crank_pivot" in warned[0] and "warnings.warn" not in err


def test_residuals_out_of_tolerance_exit_1(monkeypatch, capsys):
    """An answer whose own residuals fail (forced here: ``ok`` False, the rest the real answer)
    is printed, then one line says so, exit 1."""
    solve = Mechanism.solve

    class Unverified:
        ok = False

        def __init__(self, answer):
            self._answer = answer

        def __getattr__(self, name):
            return getattr(self._answer, name)

    monkeypatch.setattr(Mechanism, "solve", lambda self, **kw: Unverified(solve(self, **kw)))
    path = MODELS / "four_bar.urdf"
    status, out, err = run_command(capsys, "solve", path)
    assert status == 1 and f"from {path}" in out
    assert one_line(err) == f"clearance-pin: {path}: residuals out of tolerance"


# -- refused inputs -------------------------------------------------------------------------------
def test_bad_model_exits_2_with_one_line_naming_file_element_problem(tmp_path, capsys):
    path = _pendulum_variant(
        tmp_path,
        "misnamed.urdf",
        '<joint name="elbow" type="planar_revolute"',
        '<joint name="elbo" type="planar_revolute"',
    )
    status, out, err = run_command(capsys, "solve", path)
    assert status == 2 and out == ""
    line = one_line(err)
    assert line.startswith(f"clearance-pin: {path}: <joint name='elbo'>: ")
    assert "no URDF joint is called 'elbo'" in line and "shoulder, elbow, tip_mount" in line


def test_missing_file_exits_2(tmp_path, capsys):
    path = tmp_path / "nowhere.urdf"
    status, _, err = run_command(capsys, "solve", path)
    assert status == 2
    line = one_line(err)
    assert str(path) in line and "cannot be read" in line


def test_unbounded_load_exits_3_naming_the_motion(tmp_path, capsys):
    """The pendulum with its shoulder no longer driven: the tip load turns it freely."""
    path = _pendulum_variant(tmp_path, "free_shoulder.urdf", SHOULDER_DRIVE, "")
    status, out, err = run_command(capsys, "solve", path)
    assert status == 3 and out == ""
    line = one_line(err)
    assert str(path) in line and "no equilibrium" in line
    assert "joint 'shoulder' alpha" in line


def test_solver_failure_exits_4_with_its_residuals(monkeypatch, capsys):
    """A solve that ends in SolverError (forced here) is not a bad input: its own status, 4,
    and one line with the solver's status and the residuals it measured."""

    def failing_solve(self, *args, **kwargs):
        raise SolverError("answer failed verification", "max_iter", {"kkt_stationarity": 3.5e-4})

    monkeypatch.setattr(Mechanism, "solve", failing_solve)
    path = MODELS / "four_bar.urdf"
    status, out, err = run_command(capsys, "solve", path)
    assert status == 4 and out == ""
    line = one_line(err)
    assert str(path) in line and "did not reach a verified answer" in line
    assert "max_iter" in line and "kkt_stationarity=0.00035" in line


@pytest.mark.parametrize(
    "argv",
    [
        [],
        ["solve"],
        ["solve", str(MODELS / "four_bar.urdf"), "--gravity", "maybe"],
        ["validate"],  # a script of the source tree (validation/younes2013.py), not a sub-command
    ],
)
def test_bad_command_line_arguments_exit_2(argv, capsys):
    with pytest.raises(SystemExit) as info:
        main(argv)
    assert info.value.code == 2
    assert "usage: clearance-pin" in capsys.readouterr().err


# -- tolerance ------------------------------------------------------------------------------------
def test_tolerance_bands_are_flores_closed_form(tmp_path, capsys):
    """The double pendulum, shoulder swept, elbow at 45 deg: the tip's x moves by
    cos(phi) dl1 + cos(phi + 45 deg) dl2 - l2 sin(phi + 45 deg) da2, so its worst-case half band
    is the sum of those coefficients' magnitudes times the half tolerances (IT9: 130 um at
    300 mm, 115 um at 200 mm; 1e-3 rad)."""
    report = tmp_path / "bands.json"
    status, out, err = run_command(
        capsys,
        "tolerance",
        PENDULUM,
        "--joint",
        "shoulder",
        "--output",
        "tip.x",
        "--positions",
        "5",
        "--samples",
        "200",
        "--no-maxima",
        "--json",
        report,
    )
    assert status == 0 and err == ""
    assert "tip.x" in out and f"JSON written to {report}" in out
    document = json.loads(report.read_text())
    jsonschema = pytest.importorskip("jsonschema")
    jsonschema.validate(document, schema("tolerance"))
    half = {
        d["name"]: d.get("half_tolerance_m", d.get("half_tolerance_rad"))
        for d in document["dimensions"]
    }
    assert half == pytest.approx({"l1": 65e-6, "l2": 57.5e-6, "a2": 5e-4}, rel=1e-12)
    phi = np.array(document["parameter_rad"])
    elbow = math.pi / 4
    expected = (
        np.abs(np.cos(phi)) * half["l1"]
        + np.abs(np.cos(phi + elbow)) * half["l2"]
        + np.abs(0.2 * np.sin(phi + elbow)) * half["a2"]
    )
    np.testing.assert_allclose(document["outputs"]["tip.x"]["worst_m"], expected, rtol=1e-9)


def test_tolerance_unknown_output_exits_2_listing_the_frames(capsys):
    status, _, err = run_command(
        capsys, "tolerance", PENDULUM, "--joint", "shoulder", "--output", "hand.x"
    )
    assert status == 2
    line = one_line(err)
    assert str(PENDULUM) in line and "unknown frame 'hand'" in line
    assert "link1" in line and "tip" in line


def test_tolerance_without_dimensions_exits_2(capsys):
    status, _, err = run_command(capsys, "tolerance", MODELS / "four_bar.urdf")
    assert status == 2
    assert "no <dimension> element" in one_line(err)


# -- the installed entry point --------------------------------------------------------------------
def test_installed_entry_point_solves():
    """The console script of the installed package (pyproject [project.scripts])."""
    script = Path(sys.executable).with_name("clearance-pin")
    if not script.exists():
        pytest.skip(f"no console script next to {sys.executable} (package not installed)")
    done = subprocess.run(
        [str(script), "solve", str(MODELS / "four_bar.urdf")],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    assert "four_bar" in done.stdout and done.stderr == ""


def test_envelope_sub_command(tmp_path, capsys):
    """`clearance-pin envelope MODEL --output FRAME --json F` prints the certified maxima and writes
    them; the four-bar rocker's pivot frame moves at most its own pin's play, 50 um (closed form:
    the frame origin is the pivot's centre), and Mechanism.envelope gives the same answer."""
    written = tmp_path / "envelope.json"
    status, out, _ = run_command(
        capsys, "envelope", MODELS / "four_bar.urdf", "--output", "rocker", "--json", written
    )
    assert status == 0 and "translation" in out and written.stat().st_size > 0
    envelope = cp.load(MODELS / "four_bar.urdf").envelope("rocker", kinds=("translation",))
    assert envelope.max_translation.upper == pytest.approx(50e-6, rel=1e-6)


def test_solve_plot_draws_the_settled_pose(tmp_path, capsys):
    """`solve MODEL --plot FILE.png` writes the settled-pose picture (the plot extra)."""
    pytest.importorskip("matplotlib")
    picture = tmp_path / "four_bar.png"
    status, out, _ = run_command(capsys, "solve", MODELS / "four_bar.urdf", "--plot", picture)
    assert status == 0 and f"drawn in {picture}" in out
    assert picture.stat().st_size > 10_000


def test_clearances_beside_an_unmodified_urdf(tmp_path, capsys):
    """`solve URDF --clearances FILE`: the four-bar's block moved to a file of its own beside the
    URDF without it gives the same table as the file with its block (self-consistency)."""
    text = (MODELS / "four_bar.urdf").read_text()
    start, end = text.index("<clearance_pin>"), text.index("</clearance_pin>")
    (tmp_path / "four_bar.urdf").write_text(text[:start] + text[end + len("</clearance_pin>") :])
    (tmp_path / "play.xml").write_text(text[start : end + len("</clearance_pin>")])
    _, with_block, _ = run_command(capsys, "solve", MODELS / "four_bar.urdf", "--json")
    status, beside, _ = run_command(
        capsys, "solve", tmp_path / "four_bar.urdf", "--clearances", tmp_path / "play.xml", "--json"
    )
    assert status == 0
    assert (
        json.loads(beside)["equilibrium"]["torsors"]
        == json.loads(with_block)["equilibrium"]["torsors"]
    )


# -- every sub-command reads the model the same way --------------------------------------------
def _beside(tmp_path: Path, model: Path) -> tuple[Path, Path]:
    """The model's URDF without its block, and the block as a clearance file beside it."""
    from test_clearance_file import split

    bare, block = split(model.read_text())
    urdf, clearances = tmp_path / model.name, tmp_path / f"{model.stem}_play.xml"
    urdf.write_text(bare)
    clearances.write_bytes(ET.tostring(block))
    return urdf, clearances


def test_envelope_and_tolerance_read_a_clearance_file_beside_the_model(tmp_path, capsys):
    """`envelope` and `tolerance` take --clearances like `solve` (they took the model file only,
    so a vendor URDF had no envelope or tolerance sweep from the command line): the four-bar
    rocker's pivot moves at most its pin's play, 50 um (closed form, as above), and the
    pendulum's bands are those of the file with its block inside."""
    urdf, clearances = _beside(tmp_path, MODELS / "four_bar.urdf")
    written = tmp_path / "envelope.json"
    status, _, err = run_command(
        capsys, "envelope", urdf, "--clearances", clearances, "--output", "rocker",
        "--kind", "translation", "--json", written,
    )  # fmt: skip
    assert status == 0, err
    translation = json.loads(written.read_text())["envelopes"][0]["kinds"]["translation"]
    assert translation["largest_upper_m"] == pytest.approx(50e-6, rel=1e-6)
    urdf, clearances = _beside(tmp_path, PENDULUM)
    options = ["--joint", "shoulder", "--output", "tip.x", "--positions", "5", "--samples", "0",
               "--no-maxima"]  # fmt: skip
    bands = []
    for arguments in ([urdf, "--clearances", clearances], [PENDULUM]):
        report = tmp_path / "bands.json"
        status, _, err = run_command(capsys, "tolerance", *arguments, *options, "--json", report)
        assert status == 0, err
        bands.append(json.loads(report.read_text())["outputs"]["tip.x"]["worst_m"])
    np.testing.assert_allclose(bands[0], bands[1], rtol=1e-12)


def test_envelope_of_an_output_without_bound_says_unbounded_and_exits_3(tmp_path, capsys):
    """The 6R arm with an empty clearance file (ideal joints, none driven): every joint turns
    freely, so the tool moves without bound; it printed "largest 0.000000 <= max <= 0.000000 um"
    and exited 0."""
    urdf, _ = _beside(tmp_path, MODELS / "arm_6r.urdf")
    empty = tmp_path / "ideal.xml"
    empty.write_text("<clearance_pin/>")
    status, out, err = run_command(
        capsys, "envelope", urdf, "--output", "tool", "--clearances", empty
    )
    assert status == 3
    assert "translation: UNBOUNDED along 3 free direction(s)" in out
    line = one_line(err)
    assert "unbounded" in line and "tool translation" in line


def test_version_and_python_dash_m():
    """`clearance-pin --version` and `python -m clearance_pin --version`: the package's version."""
    done = subprocess.run(
        [sys.executable, "-m", "clearance_pin", "--version"],
        capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == f"clearance-pin {cp.__version__}"
