"""`clearance-pin solve --json` as a contract (issue 24 item 2): a versioned document, validated
against the JSON Schema shipped in the package; failures are JSON too. The statics check is by
hand (a shaft on two balls loaded at its middle: each ball carries half the force)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from clearance_pin.cli import main
from clearance_pin.json_documents import SOLVE_SCHEMA, schema

jsonschema = pytest.importorskip("jsonschema")
MODELS = Path(__file__).resolve().parent.parent / "models"


def _solve_json(capsys, *arguments: str) -> tuple[int, dict]:
    status = main(["solve", *arguments, "--json"])
    return status, json.loads(capsys.readouterr().out)


@pytest.mark.parametrize(
    "arguments",
    [
        ("arm_6r.urdf", "--exact", "--check"),
        ("four_bar.urdf",),
        ("slider_crank.urdf", "--output", "slider"),
        ("younes_sphere_cylinder.urdf", "--exact"),
    ],
    ids=["arm-exact-check", "four-bar", "slider-crank", "sphere-cylinder-exact"],
)
def test_every_solve_document_follows_its_schema(arguments, capsys):
    status, document = _solve_json(capsys, str(MODELS / arguments[0]), *arguments[1:])
    assert status == 0
    jsonschema.validate(document, schema("solve"))
    assert document["schema"] == SOLVE_SCHEMA
    if "--exact" in arguments:
        assert document["equilibrium"]["formulation"] == "exact" and "linear" in document


def test_bearing_loads_and_reactions_follow_the_statics(capsys):
    """The paper's shaft on two balls (I1 at the origin, I2 at (0.2, 0.4, 0.6) m) with 1 N along
    each world axis at its middle: each ball holds half of it (moments about either ball; the
    split along the shaft's axis is the least-norm one, also half), world frame."""
    status, document = _solve_json(capsys, str(MODELS / "younes_two_spheres.urdf"))
    assert status == 0
    reactions = document["equilibrium"]["reactions"]
    for joint in ("I1", "I2"):
        assert reactions[joint]["frame"] == "world"
        assert np.allclose(reactions[joint]["force_N"], [-0.5, -0.5, -0.5], rtol=0, atol=1e-9)
    bearing = document["equilibrium"]["bearing_loads"]
    for joint in ("I1", "I2"):  # a ball carries no moment; its force is half of |F| = sqrt(3)
        total = np.hypot(bearing[joint]["radial_N"], bearing[joint]["axial_N"])
        assert total == pytest.approx(np.sqrt(3.0) / 2.0, rel=1e-9)
        assert bearing[joint]["transverse_moment_N_m"] == pytest.approx(0.0, abs=1e-9)


def test_a_failure_with_json_is_a_json_document(capsys):
    status = main(["solve", str(MODELS / "no_such_model.urdf"), "--json"])
    captured = capsys.readouterr()
    document = json.loads(captured.out)
    jsonschema.validate(document, schema("error"))
    assert status == 2 and document["exit_status"] == 2 and document["error"] == "ModelError"
    assert "no_such_model.urdf" in captured.err  # the one line on standard error stays
