"""Issue 10 finding 9: the stability suite's "ambiguous closure" cases, decided by a certificate.

Three of the 2000 random mechanisms of benchmarks/stability.py (seed 20261122, examples 1468-1470,
one mechanism with two variants) were left undecided: the library's energy differed from the
oracle's by 3.2e-8 to 3.9e-8 relative (tolerance 1e-8), and the loop-closure rows have singular
values of 1e-17 to 1e-20 of the largest (round-off), so the oracle could not say whether the rank
decision was at fault. Diagnosis: only 3.5e-7 of the load (a 3.9 N m torque) works on an
admissible motion; the rest is carried by rigid directions with reactions of about 800 (z units),
and the closure residuals of the two answers, about 7e-18, times those reactions account for the
whole energy difference (1.39e-16 J predicted, 1.38e-16 J measured). The library's answer is a
KKT point of the oracle's own problem (feasible to 1e-13, contact forces balancing the load to
1.6e-13, forces only at touching contacts and pointing back into the play), so it is an optimum;
the torsors differ along the flat directions the library reports ("bounded but not loaded").
tests/oracle.py now checks that certificate (``Oracle.certificate_of``, ``energy_gap_bound``).
"""

from __future__ import annotations

import dataclasses
import types
from pathlib import Path

import numpy as np
from oracle import Oracle, certificate_holds, judge

import clearance_pin

DATA = Path(__file__).parent / "data"
MODELS = Path(__file__).parent.parent / "models"


def test_round_off_closure_case_is_certified():
    mechanism = clearance_pin.load(DATA / "finding9_round_off_closure.urdf")
    loads = mechanism.resolve_loads(None, None)
    verdict = judge(mechanism, loads)
    assert verdict.kind == "agree-flat", (verdict.kind, verdict.errors)
    oracle = Oracle(mechanism)
    equilibrium = mechanism.solve(loads=loads)
    residuals = oracle.certificate_of(equilibrium, loads)
    assert max(residuals.values()) < 1e-9, residuals


def tampered(equilibrium, force_scale=1.0, twist_scale=1.0):
    """A stand-in answer with scaled contact forces and/or body twists."""
    contacts = [
        dataclasses.replace(c, force=np.asarray(c.force) * force_scale)
        for c in equilibrium.contacts
    ]
    return types.SimpleNamespace(
        contacts=contacts,
        body_twists=np.asarray(equilibrium.body_twists) * twist_scale,
        energy=equilibrium.energy * twist_scale,
    )


def test_certificate_rejects_wrong_answers():
    """The certificate can fail: forces that do not balance the load, or a pose pushed through
    the play, or one pulled back from the contacts, are refused."""
    mechanism = clearance_pin.load(MODELS / "younes_two_cylinders.urdf")
    loads = mechanism.resolve_loads(None, None)
    oracle = Oracle(mechanism)
    equilibrium = mechanism.solve(loads=loads)
    result = oracle.solve(loads)
    assert certificate_holds(oracle, equilibrium, loads, result)
    assert oracle.certificate_of(tampered(equilibrium, force_scale=1.01), loads)["statics"] > 1e-3
    assert oracle.certificate_of(tampered(equilibrium, twist_scale=1.01), loads)["violation"] > 1e-3
    pulled = oracle.certificate_of(tampered(equilibrium, twist_scale=0.99), loads)
    assert pulled["complementarity"] > 0.1
    assert not certificate_holds(oracle, tampered(equilibrium, twist_scale=0.99), loads, result)
