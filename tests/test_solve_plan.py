"""One solve plan (issue 22): the engine is chosen from structure and options, recorded in
``Equilibrium.method``, and every option of ``Mechanism.solve`` works in ``solve_many`` and the
resolver.

These compare the library's entry points with each other (the same algorithm by another door):
they check that the doors agree, not that the answers are right (the answers are checked
independently in test_engines_agree.py, test_oracle*.py and the validation cases).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import clearance_pin as cp
from clearance_pin import ArgumentError, Method, PointForce, Torque
from clearance_pin.equilibrium.plan import plan_linear

MODELS = Path(__file__).resolve().parent.parent / "models"


@pytest.mark.parametrize(
    "structure, expected",
    [
        ({"independent_blocks": True}, (Method.CLOSED_FORM, Method.CLARABEL, Method.IPOPT)),
        ({"independent_blocks": True, "backend": "ipopt"}, (Method.IPOPT,)),
        ({"kernel": True}, (Method.COMPILED, Method.CLARABEL, Method.IPOPT)),
        ({"kernel": True, "solved_before": False}, (Method.CLARABEL, Method.IPOPT)),
        ({"kernel": True, "size": 49}, (Method.CLARABEL, Method.IPOPT)),
        ({"kernel": True, "contacts": 13}, (Method.CLARABEL, Method.IPOPT)),
        ({"kernel": True, "contacts": 12}, (Method.COMPILED, Method.CLARABEL, Method.IPOPT)),
        ({"kernel": True, "backend": "clarabel"}, (Method.COMPILED, Method.CLARABEL, Method.IPOPT)),
        ({"kernel": False}, (Method.CLARABEL, Method.IPOPT)),
        ({"clarabel": False}, (Method.IPOPT,)),
        ({"elastic": True, "kernel": True}, (Method.CLARABEL, Method.IPOPT)),
        ({"elastic": True, "independent_blocks": True}, (Method.CLARABEL, Method.IPOPT)),
        (
            {"kernel": True, "independent_blocks": True},
            (Method.CLOSED_FORM, Method.CLARABEL, Method.IPOPT),
        ),
    ],
)
def test_the_plan_is_a_function_of_structure_and_options(structure, expected):
    arguments = {
        "independent_blocks": False,
        "size": 12,
        "contacts": 6,
        "solved_before": True,
        "backend": "auto",
        "kernel": False,
        "clarabel": True,
        "elastic": False,
        **structure,
    }
    assert plan_linear(**arguments) == expected
    assert plan_linear(**arguments) == expected  # no state: the same answer again


def _four_bar_cases(count: int, seed: int = 3) -> list[list]:
    rng = np.random.default_rng(seed)
    return [
        [
            PointForce("coupler", [0.0, -40.0, 0.0] + 8.0 * rng.standard_normal(3), [0.09, 0, 0]),
            Torque("rocker", [0.0, 0.0, -2.0] + 0.4 * rng.standard_normal(3)),
        ]
        for _ in range(count)
    ]


@pytest.mark.parametrize("setting", ["0", "1"])
def test_the_same_calls_take_the_same_engines_and_give_the_same_bits(setting, monkeypatch):
    """Two mechanisms given the same calls in the same order: the same methods, bit for bit the
    same torsors (nothing depends on clocks or on how many solves the process did before)."""
    monkeypatch.setenv("CLEARANCE_PIN_COMPILED", setting)
    cases = _four_bar_cases(30)
    runs = []
    for _ in range(2):
        mechanism = cp.load(str(MODELS / "four_bar.urdf"))
        answers = [mechanism.solve(loads) for loads in cases]
        runs.append(
            (
                [a.method for a in answers],
                [a.torsors[j].tobytes() for a in answers for j in sorted(a.torsors)],
            )
        )
    assert runs[0] == runs[1]
    methods = set(runs[0][0])
    assert methods == ({Method.CLARABEL, Method.COMPILED} if setting == "1" else {Method.CLARABEL})


def test_every_answer_names_its_engine(monkeypatch):
    monkeypatch.setenv("CLEARANCE_PIN_COMPILED", "0")
    arm = cp.load(str(MODELS / "arm_6r.urdf"))
    assert arm.solve().method is Method.CLOSED_FORM
    assert arm.solve(backend="ipopt").method is Method.IPOPT
    assert arm.solve(backend="clarabel").method is Method.CLARABEL
    unloaded = arm.solve(loads=[], gravity=False)
    assert unloaded.status == "indeterminate" and unloaded.method is Method.NO_LOAD
    four_bar = cp.load(str(MODELS / "four_bar.urdf"))
    exact = four_bar.solve(exact=True)
    assert exact.method in (Method.EXACT_NEWTON, Method.EXACT_IPOPT)
    assert exact.linear.method is Method.CLARABEL
    assert exact.to_dict()["method"] == exact.method.value


@pytest.mark.parametrize("model", ["arm_6r", "four_bar"])
def test_solve_many_takes_every_option_of_solve(model, monkeypatch):
    """outputs, warm_start and accuracy (with exact="auto") in solve_many give what the single
    solves give (they raised TypeError before issue 22): on the arm's closed-form batch and the
    four-bar's batched Newton (20 cases: more than the batch's minimum)."""
    monkeypatch.setenv("CLEARANCE_PIN_COMPILED", "0")
    mechanism = cp.load(str(MODELS / f"{model}.urdf"))
    single = cp.load(str(MODELS / f"{model}.urdf"))
    if model == "four_bar":
        cases, output = _four_bar_cases(20), "rocker_B"
    else:
        rng = np.random.default_rng(4)
        cases = [
            [PointForce("tool", [0, 0, -50.0] + 10 * rng.standard_normal(3))] for _ in range(20)
        ]
        output = "wrist_3"
    batch = mechanism.solve_many(cases, outputs=[output])
    for loads, item in zip(cases, batch):
        reference = single.solve(loads, outputs=[output])
        assert list(item.outputs) == list(reference.outputs)
        for name, (translation, rotation) in reference.outputs.items():
            assert np.allclose(item.outputs[name][0], translation, rtol=0, atol=1e-12 * 1e-3)
            assert np.allclose(item.outputs[name][1], rotation, rtol=0, atol=1e-12)
    cold = mechanism.solve_many(cases[:5], warm_start=False)
    for loads, item in zip(cases[:5], cold):
        reference = single.solve(loads, warm_start=False)
        for joint, torsor in reference.torsors.items():
            assert np.allclose(item.torsors[joint], torsor, rtol=0, atol=1e-15)
    auto = mechanism.solve_many(cases[:3], exact="auto", accuracy=1e-15)
    assert all(item.note.startswith("auto:") for item in auto)
    with pytest.raises(ArgumentError, match="no_such_frame"):
        mechanism.solve_many(cases[:3], outputs=["no_such_frame"])


def test_the_resolver_takes_every_option_of_solve(monkeypatch):
    monkeypatch.setenv("CLEARANCE_PIN_COMPILED", "0")
    mechanism = cp.load(str(MODELS / "four_bar.urdf"))
    loads = _four_bar_cases(1)[0]
    resolver = mechanism.resolver(loads, exact=True, outputs=["rocker_B"])
    values = np.array([[0.0, -35.0, 1.0], [0.0, 0.1, -2.5]])
    answer = resolver.solve(values)
    reference = cp.load(str(MODELS / "four_bar.urdf")).solve(
        resolver._loads_with(values.ravel()), exact=True, outputs=["rocker_B"]
    )
    assert answer.formulation == reference.formulation == "exact"
    assert "rocker_B" in answer.outputs
    for joint, torsor in reference.torsors.items():
        assert np.allclose(answer.torsors[joint], torsor, rtol=0, atol=1e-14)


def test_the_exact_model_reports_its_newton_steps():
    """The exact Newton from the linear answer counts its steps (it reported 0, hard-coded): a
    second-order correction takes a few, and fewer than its limit of 12."""
    answer = cp.load(MODELS / "four_bar.urdf").solve(exact=True)
    assert answer.method is Method.EXACT_NEWTON
    assert 1 <= answer.iterations <= 12
