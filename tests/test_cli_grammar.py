"""One command-line grammar (issue 37 item 1): the options that mean the same thing are spelt
the same way in every sub-command: ``--json [FILE]`` (no FILE: the document alone on standard
output), ``--gravity on|off``, ``--output FRAME|LINK@[X Y Z]``; the top-level help says what the
tool does, lists the sub-commands and the exit statuses; every non-zero exit says why in one
line on standard error. The points' displacements are checked against Pinocchio's placements
(t + omega x (R p)), not against the solver's own output code."""

from __future__ import annotations

import json

import numpy as np
import pinocchio as pin
import pytest
from conftest import MODELS, run_command

from clearance_pin.cli import build_parser, main

ARM = MODELS / "arm_6r.urdf"
SLIDER_CRANK = MODELS / "slider_crank.urdf"


@pytest.mark.parametrize(
    "argv",
    [
        ["solve", ARM],
        ["envelope", MODELS / "four_bar.urdf", "--output", "rocker", "--kind", "translation"],
        ["accuracy", ARM, "--output", "tool", "--poses", 3, "--payload", 2],
        ["tolerance", SLIDER_CRANK, "--positions", 2, "--samples", 0, "--no-maxima"],
    ],
    ids=["solve", "envelope", "accuracy", "tolerance"],
)
def test_json_without_a_file_is_the_document_alone_on_stdout(argv, capsys, tmp_path):
    """``--json`` alone: standard output is one JSON document (no table); ``--json FILE``:
    the same document in FILE, the table on standard output."""
    status, out, _ = run_command(capsys, *argv, "--json")
    assert status == 0
    document = json.loads(out)  # nothing but the document
    written = tmp_path / "out.json"
    status, out, _ = run_command(capsys, *argv, "--json", written)
    assert status == 0 and out.strip()  # the table
    assert json.loads(written.read_text()).keys() == document.keys()


def test_gravity_is_one_option_and_the_accuracy_map_says_what_loads_it(capsys):
    """``--gravity on|off`` in solve and accuracy alike; the map says its loads (0 kg and no
    weight: nothing moves it, and it says so instead of a bare 0.00 um)."""
    common = ["accuracy", ARM, "--output", "tool", "--poses", 3]
    status, out, _ = run_command(capsys, *common, "--gravity", "off")
    assert status == 0 and "own weight off (--gravity)" in out and "stays at 0 um" in out
    _, off, _ = run_command(capsys, *common, "--gravity", "off", "--json")
    _, on, _ = run_command(capsys, *common, "--gravity", "on", "--json")
    assert json.loads(off)["largest_translation_m"] == 0.0
    assert json.loads(on)["largest_translation_m"] > 1e-6  # the arm's own weight moves it
    with pytest.raises(SystemExit) as bare:  # no bare flag: on or off, as in solve
        main([str(a) for a in (*common, "--gravity")])
    assert bare.value.code == 2


def _point_moved(mechanism, frame: str, point: np.ndarray, translation, rotation) -> np.ndarray:
    """t + omega x (R p): a point of a frame from the frame's small motion (Pinocchio's
    placement at the nominal configuration gives R)."""
    data = mechanism.model.createData()
    pin.framesForwardKinematics(mechanism.model, data, mechanism.q_nominal)
    link = mechanism.model.getFrameId(frame, pin.FrameType.BODY)  # a joint shares its name
    lever = data.oMf[link].rotation @ point
    return np.asarray(translation) + np.cross(rotation, lever)


def test_an_output_point_is_spelt_the_same_in_solve_and_accuracy(capsys):
    """``--output wrist_3@[0 0 0.05]`` in solve and accuracy: the point's displacement is the
    link's, moved by its rotation over the lever (Pinocchio's placement), in both."""
    import clearance_pin as cp

    arm = cp.load(str(ARM))
    point = np.array([0.0, 0.0, 0.05])
    name = "wrist_3@[0 0 0.05]"
    _, out, _ = run_command(capsys, "solve", ARM, "--output", "wrist_3", "--output", name,
                            "--json")  # fmt: skip
    outputs = json.loads(out)["equilibrium"]["outputs"]
    link = outputs["wrist_3"]
    expected = _point_moved(arm, "wrist_3", point, link["translation_m"], link["rotation_rad"])
    np.testing.assert_allclose(outputs[name]["translation_m"], expected, atol=1e-15)
    frame_map = arm.accuracy("wrist_3", [arm.q_nominal], payloads=[2.0], gravity=False)
    point_map = arm.accuracy(name, [arm.q_nominal], payloads=[2.0], gravity=False)
    hung = arm.accuracy("wrist_3", [arm.q_nominal], payloads=[2.0], gravity=False,
                        payload_point=point)  # fmt: skip
    expected = _point_moved(arm, "wrist_3", point, hung.translation[0, 0], hung.rotation[0, 0])
    np.testing.assert_allclose(point_map.translation[0, 0], expected, rtol=1e-12, atol=1e-18)
    assert not np.allclose(point_map.translation, frame_map.translation)  # the lever counts


def test_the_top_level_help_says_what_it_does_and_its_exit_statuses():
    text = build_parser().format_help()
    assert "where the parts of a mechanism or robot settle" in text
    for command in ("solve", "envelope", "accuracy", "tolerance", "compile"):
        assert f"    {command}" in text
    for status in range(6):
        assert f"\n  {status}  " in text


def test_a_failed_spec_says_why_on_stderr(capsys):
    """tolerance exits 1 on a spec its worst case exceeds, with one line on standard error (it
    said nothing there)."""
    status, _, err = run_command(
        capsys, "tolerance", SLIDER_CRANK, "--clockwise", "--output", "x4=slider.x",
        "--spec", "x4=1um", "--positions", 2, "--samples", 0, "--no-maxima",
    )  # fmt: skip
    assert status == 1
    assert err.strip().splitlines()[-1].startswith("clearance-pin: ")
    assert "out of spec" in err and "x4" in err
