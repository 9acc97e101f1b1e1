"""Shared helpers of the equilibrium, model-file and model tests.

Everything here is written from docs/method.md section 2 and the model-file format, not from the
engine's internals: the paper cases are built from their SI inputs with the shaft builder, the
model files are transformed as XML text (scaled, moved rigidly, clearances shrunk), and small URDFs
are written out by hand.
"""

from __future__ import annotations

import os
import tomllib
import warnings
import xml.etree.ElementTree as ET
from pathlib import Path

import mechanism_strategies  # noqa: F401  (keeps Hypothesis's examples independent of imports)
import numpy as np
import pytest

import clearance_pin as cp
from clearance_pin.model.builders import JointSpec, shaft_urdf

# every re-solve of the suite goes the compiled way first (the kernel loads on the first one),
# so that the whole suite checks it; tests/test_compiled_resolve.py compares it with the NumPy path
os.environ.setdefault("CLEARANCE_PIN_COMPILED", "1")

ROOT = Path(__file__).resolve().parent.parent
MODELS = ROOT / "models"
MODEL_FILES = sorted(MODELS.glob("*.urdf"))
CASE_FILE = ROOT / "validation" / "younes2013_cases.toml"
CASES = {case["id"]: case for case in tomllib.loads(CASE_FILE.read_text())["case"]}
EXPECTED_CASES = sorted(i for i, case in CASES.items() if "expected_mm" in case)
MM = 1e3

# clearance-carrying attributes of the <clearance_pin> block (lengths [m])
CLEARANCE_ATTRIBUTES = (
    "radial_clearance",
    "diametral_clearance",
    "axial_clearance",
    "play_z",
)
LENGTH_ATTRIBUTES = ("length", "width", "height")


# -- paper cases --------------------------------------------------------------------------------
def case_specs(case: dict, length: float = 1.0, clearance: float = 1.0) -> list[JointSpec]:
    """The two joints of a paper case; lengths times ``length``, clearances times ``clearance``."""
    return [
        JointSpec(
            j["name"],
            j["kind"],
            tuple(length * np.asarray(j["center_m"], dtype=float)),
            length * clearance * j["diametral_clearance_m"],
            length * j.get("length_m", 0.0),
            tuple(j.get("axis", (1.0, 0.0, 0.0))),
        )
        for j in case["joint"]
    ]


def case_text(case: dict, length: float = 1.0, clearance: float = 1.0, load=None) -> str:
    """Model-file text of a paper case (SI unless ``length`` rescales every length).

    Forces are kept, torques are multiplied by ``length`` (a torque is a force times a length).
    ``load`` = (point, force, torque) replaces the case's load.
    """
    first, second = case_specs(case, length, clearance)
    point, force, torque = load or (
        case["load"]["point_m"],
        case["load"]["force_N"],
        case["load"]["torque_Nm"],
    )
    return shaft_urdf(
        first,
        second,
        length * np.asarray(point, dtype=float),
        np.asarray(force, dtype=float),
        length * np.asarray(torque, dtype=float),
        name=case["id"].replace("=", "_"),
    )


def build_case(case: dict, **options) -> cp.Mechanism:
    """The mechanism of a paper case (see :func:`case_text`)."""
    return cp.loads(case_text(case, **options), source=f"case {case['id']}")


# -- model-file transforms ------------------------------------------------------------------------
def _floats(text: str) -> np.ndarray:
    return np.array([float(v) for v in text.split()], dtype=float)


def _text(vector) -> str:
    return " ".join(repr(float(v)) for v in vector)


def scale_lengths(text: str, factor: float) -> str:
    """The same mechanism with every length [m] multiplied by ``factor`` (e.g. m -> mm).

    Scaled: URDF origins and inertial origins, every clearance, length and load point, torques
    (force x length). Kept: forces, gravity, angles, nominal joint values. Dropped: the
    ``<dimension>`` tolerance specifications (an ISO grade depends on the nominal size in SI, so
    they do not scale; they play no part in the equilibrium).
    """
    root = ET.fromstring(text)
    for origin in root.iter("origin"):
        if origin.get("xyz") is not None:
            origin.set("xyz", _text(factor * _floats(origin.get("xyz"))))
    block = root.find("clearance_pin")
    for dimension in block.findall("dimension"):
        block.remove(dimension)
    for element in block:
        for attribute in (*CLEARANCE_ATTRIBUTES, *LENGTH_ATTRIBUTES):
            if element.get(attribute) is not None:
                element.set(attribute, repr(factor * float(element.get(attribute))))
        if element.tag == "force" and element.get("point") is not None:
            element.set("point", _text(factor * _floats(element.get("point"))))
        if element.tag == "torque":
            element.set("value", _text(factor * _floats(element.get("value"))))
    return ET.tostring(root, encoding="unicode")


def scale_clearances(text: str, factor: float) -> str:
    """The same mechanism with every clearance (not the lengths) multiplied by ``factor``."""
    root = ET.fromstring(text)
    for element in root.find("clearance_pin"):
        for attribute in CLEARANCE_ATTRIBUTES:
            if element.get(attribute) is not None:
                element.set(attribute, repr(factor * float(element.get(attribute))))
    return ET.tostring(root, encoding="unicode")


def move_rigidly(text: str, rotation: np.ndarray, translation: np.ndarray) -> str:
    """The same mechanism placed at (rotation, translation) in the world.

    A new root link ``moved_base`` carries the old root link by a fixed joint with that origin,
    so every joint frame, clearance frame and load point moves with it; loads and gravity are
    given in world axes and are rotated.
    """
    import pinocchio as pin

    root = ET.fromstring(text)
    children = {j.find("child").get("link") for j in root.findall("joint")}
    old_root = next(
        link.get("name") for link in root.findall("link") if link.get("name") not in children
    )
    rpy = pin.rpy.matrixToRpy(rotation)
    root.insert(0, ET.fromstring('<link name="moved_base"/>'))
    root.insert(
        1,
        ET.fromstring(
            f'<joint name="moved_base_mount" type="fixed"><parent link="moved_base"/>'
            f'<child link="{old_root}"/><origin xyz="{_text(translation)}" rpy="{_text(rpy)}"/>'
            "</joint>"
        ),
    )
    for element in root.find("clearance_pin"):
        if element.tag in ("force", "torque", "gravity") and element.get("value") is not None:
            element.set("value", _text(rotation @ _floats(element.get("value"))))
    return ET.tostring(root, encoding="unicode")


def random_rotation(rng: np.random.Generator) -> np.ndarray:
    """A rotation matrix drawn uniformly (QR of a Gaussian matrix, sign-fixed)."""
    q, r = np.linalg.qr(rng.standard_normal((3, 3)))
    q = q * np.sign(np.diag(r))
    if np.linalg.det(q) < 0.0:
        q[:, 0] = -q[:, 0]
    return q


# -- comparisons ----------------------------------------------------------------------------------
def assert_torsors_close(actual: dict, expected: dict, rtol: float, length: float) -> None:
    """Torsors equal to ``rtol`` relative, translations and rotations judged separately.

    Each part is compared against the largest of that part over every joint, and never against
    less than the largest translation divided by ``length`` [m] (the mechanism's size) for the
    rotations: a component that is zero is compared with the torsor's size, not with its own
    round-off.
    """
    assert set(actual) == set(expected)
    translation = max(np.linalg.norm(t[:3]) for t in expected.values())
    rotation = max(np.linalg.norm(t[3:]) for t in expected.values())
    scale_t = max(translation, rotation * length) or 1e-300
    scale_r = max(rotation, translation / length) or 1e-300
    for name, value in expected.items():
        a, e = np.asarray(actual[name]), np.asarray(value)
        assert np.linalg.norm(a[:3] - e[:3]) <= rtol * scale_t, (name, a, e)
        assert np.linalg.norm(a[3:] - e[3:]) <= rtol * scale_r, (name, a, e)


def run_command(capsys, *argv: object) -> tuple[int, str, str]:
    """(exit status, stdout, stderr) of ``clearance-pin ARGV``, run in this process."""
    from clearance_pin.cli import main

    status = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return status, out, err


def one_line(err: str) -> str:
    """The single line the command writes on stderr for a refused input."""
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("clearance-pin: "), err
    return lines[0]


@pytest.fixture
def extremes_warn():
    """For a test that drives values to extremes on purpose (plays from 1e-7 to 10 % of a part,
    a model scaled to mm, random mechanisms with drawn plays and lengths): the plausibility and
    validity warnings it meets are expected there, and asserted to be those and nothing else
    (the suite turns any other warning of the project into an error, pyproject.toml). Yields
    the list of the warnings recorded."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        yield caught
    expected = (cp.SuspectValueWarning, cp.ConditioningWarning, cp.HeldMotionWarning)
    others = [f"{w.category.__name__}: {w.message}" for w in caught
              if not issubclass(w.category, expected)]  # fmt: skip
    assert others == [], others
