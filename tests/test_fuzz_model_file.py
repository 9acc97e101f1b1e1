"""Fuzzing ``clearance_pin.loads``: bad input is rejected with a ClearancePinError naming the element.

Inputs (hypothesis): malformed XML (random text, truncated and corrupted model files), random
mutations of the bundled models (attributes deleted or set to odd values: negative, zero, NaN,
inf, huge, tiny, not a number, wrong vector length, unknown names; elements deleted or duplicated),
and a template whose clearance block is filled with random values. For every input:

- ``loads`` returns a mechanism or raises a ClearancePinError subclass; a ModelError names its
  element (``exc.element`` is an element tag and appears in the message), a LoadError its load;
- a mechanism that loads solves to a finite, verified equilibrium or raises a ClearancePinError;
- nothing else escapes. Failures of a known kind (each with a strict-xfail reproducer below) are
  recognised from the traceback and counted apart by :func:`outcome`.
"""

from __future__ import annotations

import traceback
import warnings
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

import clearance_pin
from clearance_pin import ClearancePinError, LoadError, ModelError

MODELS = {
    p.stem: p.read_text()
    for p in sorted((Path(__file__).resolve().parent.parent / "models").glob("*.urdf"))
}
ODD_NUMBERS = [
    "nan",
    "NaN",
    "inf",
    "-inf",
    "-1",
    "-1e-9",
    "0",
    "-0",
    "1e308",
    "1e-308",
    "5e-324",
    "1e300",
    "1e-300",
    "1e400",
    "",
    " ",
    "abc",
    "1 2",
    "0x10",
    "+1",
    "1_000",
    "1e5",
    "0.5",
    "true",
    "3.0e-5",
]
ODD_VECTORS = [
    "0 0 0",
    "nan 0 0",
    "inf 0 0",
    "1 2",
    "1 2 3 4",
    "1e308 1e308 1e308",
    "1e-320 0 0",
    "",
    "a b c",
    "1,2,3",
    "0 0 1",
    "1 0 0",
    "0.6 0.8 0",
    "-1 -1 -1",
]
ODD_NAMES = [
    "",
    "nowhere",
    "ground",
    "shaft",
    "crank",
    "coupler",
    "rocker",
    "slider",
    "I1",
    "I2",
    "pin_A",
    "pin_B",
    "base",
    "tool",
    "fixed",
    "floating",
    "continuous",
    "revolute",
    "prismatic",
    "spherical",
    "cylindrical",
    "planar_revolute",
    "rigid",
    "free",
    "planar",
    "helical",
    "<",
    "&amp;",
]
ATTRIBUTES = [
    "name",
    "type",
    "link",
    "value",
    "point",
    "xyz",
    "rpy",
    "radial_clearance",
    "diametral_clearance",
    "axial_clearance",
    "length",
    "width",
    "height",
    "play_z",
    "driven",
    "q",
    "axis",
    "frame_a",
    "frame_b",
    "enabled",
    "lower",
    "upper",
    "mass",
    "color",
]
KNOWN = {  # (exception type name, function in the traceback) -> reproducer of the known issue
    (
        "AttributeError",
        "_pin_axis",
    ): "test_stability.py::test_continuous_joint_with_an_oblique_axis_loads",
    ("ValueError", "reduce_geometry"): "test_stability.py::test_mechanism_without_motion",
    ("LinAlgError", "solve"): "test_huge_or_tiny_lengths_are_rejected",
    ("OverflowError", "solve"): "test_huge_or_tiny_lengths_are_rejected",
}


def fuzz_settings(examples: int) -> settings:
    """Fixed-seed settings of a CI fuzz test (``examples`` inputs)."""
    return settings(
        max_examples=examples,
        deadline=None,
        derandomize=True,
        suppress_health_check=[
            HealthCheck.too_slow,
            HealthCheck.data_too_large,
            HealthCheck.filter_too_much,
            HealthCheck.function_scoped_fixture,  # extremes_warn records over every example
        ],
    )


def _known(exc: BaseException) -> str | None:
    functions = [frame.name for frame in traceback.extract_tb(exc.__traceback__)]
    for (name, function), reproducer in KNOWN.items():
        if type(exc).__name__ == name and function in functions:
            return reproducer
    return None


def _check_rejection(exc: ClearancePinError) -> None:
    if isinstance(exc, ModelError):
        assert exc.element.startswith("<") and exc.element in str(exc), exc
        assert exc.problem, exc
    if isinstance(exc, LoadError):
        assert exc.load and exc.load in str(exc), exc


def outcome(text: str, solve: bool = True) -> str:
    """What clearance_pin does with a model file text.

    Returns ``rejected`` (a ClearancePinError naming its element), ``loaded`` (``solve=False``),
    ``solved``, ``diagnosed`` (the solve raised a ClearancePinError), ``known: <reproducer>`` (an
    exception of a known issue), or ``UNHANDLED <type>: <message>`` / ``GARBAGE ...`` (failures).
    """
    try:
        mechanism = clearance_pin.loads(text, source="<fuzz>")
    except ClearancePinError as exc:
        _check_rejection(exc)
        return "rejected"
    except Exception as exc:
        return (
            f"known: {_known(exc)}"
            if _known(exc)
            else f"UNHANDLED {type(exc).__name__} in loads: {exc}"
        )
    if not solve:
        return "loaded"
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            eq = mechanism.solve()
    except ClearancePinError:
        return "diagnosed"
    except Exception as exc:
        return (
            f"known: {_known(exc)}"
            if _known(exc)
            else f"UNHANDLED {type(exc).__name__} in solve: {exc}"
        )
    finite = np.isfinite(eq.energy) and all(np.all(np.isfinite(t)) for t in eq.torsors.values())
    if not finite:
        return "GARBAGE: a non-finite answer reported as ok" if eq.ok else "diagnosed"
    if not eq.ok:
        return "GARBAGE: an equilibrium returned although not ok"
    return "solved"


def assert_handled(text: str, solve: bool = True) -> str:
    result = outcome(text, solve)
    assert not result.startswith(("UNHANDLED", "GARBAGE")), f"{result}\n{text}"
    return result


# -- strategies ---------------------------------------------------------------------------------
@st.composite
def mutated_models(draw, max_mutations: int = 3) -> str:
    """A bundled model with 1..max_mutations random edits of its elements and attributes."""
    root = ET.fromstring(MODELS[draw(st.sampled_from(sorted(MODELS)))])
    for _ in range(draw(st.integers(1, max_mutations))):
        elements = [e for e in root.iter() if e is not root]
        element = draw(st.sampled_from(elements))
        operation = draw(
            st.sampled_from(
                [
                    "delete_attribute",
                    "set_attribute",
                    "set_attribute",
                    "delete_element",
                    "duplicate_element",
                ]
            )
        )
        if operation == "delete_attribute" and element.attrib:
            del element.attrib[draw(st.sampled_from(sorted(element.attrib)))]
        elif operation == "set_attribute":
            attribute = draw(st.sampled_from(sorted(element.attrib) + ATTRIBUTES))
            value = draw(
                st.one_of(
                    st.sampled_from(ODD_NUMBERS),
                    st.sampled_from(ODD_VECTORS),
                    st.sampled_from(ODD_NAMES),
                    st.text(
                        st.characters(codec="utf-8", exclude_categories=("Cs", "Cc")), max_size=8
                    ),
                )
            )
            element.set(attribute, value)
        elif operation in ("delete_element", "duplicate_element"):
            parent = next(p for p in root.iter() if element in list(p))
            if operation == "delete_element":
                parent.remove(element)
            else:
                parent.append(ET.fromstring(ET.tostring(element)))
    return ET.tostring(root, encoding="unicode")


@st.composite
def corrupted_texts(draw) -> str:
    """A bundled model truncated, or with a few characters replaced, inserted or deleted."""
    text = MODELS[draw(st.sampled_from(sorted(MODELS)))]
    if draw(st.booleans()):
        return text[: draw(st.integers(0, len(text)))]
    for _ in range(draw(st.integers(1, 4))):
        position = draw(st.integers(0, len(text)))
        piece = draw(st.sampled_from(["<", ">", '"', "/", "&", " ", "x", "0", "-", "\x00", "é"]))
        if draw(st.booleans()):
            text = text[:position] + piece + text[position + 1 :]
        else:
            text = text[:position] + piece + text[position:]
    return text


TEMPLATE = """<robot name="fuzz">
  <link name="ground"/><link name="shaft"/><link name="ground_I2"/><link name="shaft_I2"/>
  <joint name="I1" type="floating"><parent link="ground"/><child link="shaft"/></joint>
  <joint name="g2" type="fixed"><parent link="ground"/><child link="ground_I2"/>
    <origin xyz="0.2 0 0"/></joint>
  <joint name="s2" type="fixed"><parent link="shaft"/><child link="shaft_I2"/>
    <origin xyz="0.2 0 0"/></joint>
  <clearance_pin>
    <joint name="{j1}" type="{kind1}" radial_clearance="{c1}" length="{l1}" axis="{a1}"/>
    <loop_joint name="I2" type="{kind2}" frame_a="{fa}" frame_b="{fb}" radial_clearance="{c2}"
                length="{l2}" axis="{a2}"/>
    <force link="{link}" point="{p}" value="{f}"/>
  </clearance_pin>
</robot>"""
KINDS = ["spherical", "cylindrical", "revolute", "prismatic", "planar_revolute", "rigid", "free"]
good_number = st.sampled_from(["1e-4", "0.04", "2e-6", "0.1"])
good_vector = st.sampled_from(["1 0 0", "0 1 0", "1 1 1", "0.3 0 0"])


@st.composite
def template_texts(draw) -> str:
    """The sphere-cylinder shaft with every value of its clearance block drawn, good or odd."""

    def value(good, odd):
        return draw(st.one_of(good, st.sampled_from(odd)))

    return TEMPLATE.format(
        j1=value(st.just("I1"), ODD_NAMES),
        kind1=value(st.sampled_from(KINDS), ODD_NAMES),
        c1=value(good_number, ODD_NUMBERS),
        l1=value(good_number, ODD_NUMBERS),
        a1=value(good_vector, ODD_VECTORS),
        kind2=value(st.sampled_from(KINDS), ODD_NAMES),
        fa=value(st.just("ground_I2"), [*ODD_NAMES, "shaft_I2", "shaft"]),
        fb=value(st.just("shaft_I2"), [*ODD_NAMES, "ground_I2", "ground"]),
        c2=value(good_number, ODD_NUMBERS),
        l2=value(good_number, ODD_NUMBERS),
        a2=value(good_vector, ODD_VECTORS),
        link=value(st.just("shaft"), ODD_NAMES),
        p=value(good_vector, ODD_VECTORS),
        f=value(good_vector, ODD_VECTORS),
    )


# -- tests --------------------------------------------------------------------------------------
@fuzz_settings(100)
@given(text=st.text(max_size=200))
@example(text="")
@example(text="<robot")
@example(text="<?xml version='1.0'?><robot name='x'/>")
@example(text="<foo/>")
def test_random_text_is_rejected_cleanly(text):
    """Random text is rejected with a ModelError (never another exception)."""
    assert assert_handled(text, solve=False) in ("rejected", "loaded")


@fuzz_settings(100)
@given(text=corrupted_texts())
def test_corrupted_model_files_are_handled(text):
    """Truncated or corrupted model files are rejected, or load and solve cleanly."""
    assert_handled(text)


@fuzz_settings(150)
@given(text=mutated_models())
def test_mutated_model_files_are_handled(text):
    """Bundled models with attributes deleted or set to odd values, and elements deleted or
    duplicated, are rejected naming the element, or load and solve cleanly."""
    assert_handled(text)


@fuzz_settings(150)
@given(text=template_texts())
def test_clearance_block_values_are_validated(text, extremes_warn):
    """Every value of a clearance block (kinds, clearances, lengths, axes, frames, load) is
    validated: odd values are rejected naming the element, good ones solve cleanly."""
    assert_handled(text)


# the template's values for a valid two-joint shaft (each test varies one of them)
VALID_FIELDS = dict(
    j1="I1",
    kind1="spherical",
    c1="1e-4",
    l1="0.04",
    a1="1 0 0",
    kind2="cylindrical",
    fa="ground_I2",
    fb="shaft_I2",
    c2="1e-4",
    l2="0.04",
    a2="1 0 0",
    link="shaft",
    p="0.3 0 0",
    f="1 1 1",
)


@pytest.mark.parametrize(
    "attribute, value, element",
    [
        ("radial_clearance", "-1e-4", "<joint name='I1'>"),
        ("radial_clearance", "nan", "<joint name='I1'>"),
        ("radial_clearance", "inf", "<joint name='I1'>"),
        ("length", "0", "<loop_joint name='I2'>"),
        ("length", "-0.04", "<loop_joint name='I2'>"),
        ("axis", "0 0 0", "<joint name='I1'>"),
        ("axis", "1 0", "<joint name='I1'>"),
        ("link", "nowhere", "<force link='nowhere'>"),
        ("value", "nan 0 0", "<force link='shaft'>"),
        ("frame_a", "shaft", "<loop_joint name='I2'>"),  # both frames on the shaft
        ("frame_b", "nowhere", "<loop_joint name='I2'>"),
    ],
)
def test_each_bad_value_names_its_element(attribute, value, element):
    """A single bad value is rejected with a ModelError naming the element it sits on."""
    fields = dict(VALID_FIELDS)
    key = {
        "radial_clearance": "c1",
        "length": "l2",
        "axis": "a1",
        "link": "link",
        "value": "f",
        "frame_a": "fa",
        "frame_b": "fb",
    }[attribute]
    fields[key] = value
    with pytest.raises(ModelError) as caught:
        clearance_pin.loads(TEMPLATE.format(**fields))
    assert caught.value.element == element, caught.value


def test_the_unmutated_template_and_models_solve():
    """The fuzzing bases themselves load and solve (so rejections are caused by the mutations)."""
    fields = dict(VALID_FIELDS)
    assert outcome(TEMPLATE.format(**fields)) == "solved"
    for text in MODELS.values():
        assert outcome(text) == "solved"


def fuzz_counts(examples: int, seed: int = 0) -> dict:
    """Run every fuzz strategy ``examples`` times (benchmark): inputs, outcomes, unhandled."""
    from hypothesis import Phase
    from hypothesis import seed as hypothesis_seed

    counts: dict[str, int] = {}

    def record(text, solve=True):
        result = outcome(text, solve)
        key = result.split(":")[0] if not result.startswith("known") else result
        counts[key] = counts.get(key, 0) + 1

    for strategy, solve in (
        (st.text(max_size=200), False),
        (corrupted_texts(), True),
        (mutated_models(), True),
        (template_texts(), True),
    ):

        def make(strategy, solve_it: bool):
            @hypothesis_seed(seed)
            @settings(
                max_examples=examples,
                deadline=None,
                database=None,
                phases=[Phase.generate],
                suppress_health_check=list(HealthCheck),
            )
            @given(text=strategy)
            def run(text):
                record(text, solve_it)

            return run

        make(strategy, solve)()
    return counts


# -- known issues -------------------------------------------------------------------------------
FOUR_BAR = MODELS["four_bar"]


def test_non_finite_answer_is_not_ok():
    """A load point at 1e308 m gives no finite answer: rejected, diagnosed, or not ok.

    Regression: the energy was NaN with ok=True (a NaN stationarity passed every check)."""
    text = FOUR_BAR.replace('point="0.09 0 0"', 'point="1e308 0 0"')
    try:
        eq = clearance_pin.loads(text).solve()
    except ClearancePinError:
        return
    assert not eq.ok or np.isfinite(eq.energy)


@pytest.mark.parametrize(
    "old, new",
    [
        ('<origin xyz="0.06 0 0"/>', '<origin xyz="1e308 0 0"/>'),
        ('radial_clearance="5e-05"', 'radial_clearance="5e-320"'),
        ('radial_clearance="5e-05"', 'radial_clearance="1e300"'),
    ],
)
def test_huge_or_tiny_lengths_are_rejected(old, new):
    """Lengths far outside any mechanism are rejected or diagnosed with a ClearancePinError."""
    text = FOUR_BAR.replace(old, new)
    assert outcome(text) in ("rejected", "diagnosed", "solved")


def test_unreadable_inertial_is_rejected():
    """A link inertial that cannot be read is rejected with a ModelError naming the link."""
    text = MODELS["arm_6r"].replace('<mass value="3.7"/>', '<mass value="abc"/>', 1)
    assert text != MODELS["arm_6r"]
    with pytest.raises(ModelError, match="shoulder"):
        clearance_pin.loads(text)
