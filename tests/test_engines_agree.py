"""One answer whatever the path: every engine gives the same torsors, energy and contact forces,
and both exact paths the same exact answer, on random mechanisms (issue 21, item 4).

The engines, each forced on its own copy of the mechanism (cold caches):

- ``default``: ``solve(warm_start=False)`` with the compiled kernel off: the closed forms
  (``blocks.py``) for trees of independent joints, else Clarabel and the NumPy active-set polish;
- ``numpy_warm``: the NumPy active-set Newton from the answer to another load;
- ``clarabel`` and ``ipopt``: ``backend=...``, ``warm_start=False``;
- ``kernel`` and ``kernel_centre``: the compiled kernel (``CLEARANCE_PIN_COMPILED=1``), warm from
  the answer to another load, then from the centre (``warm_start=False``); left out when numba is
  missing or cannot load it (counted);
- ``solve_many``: the batched paths (``batch.py``, ``block_batch.py``), the load as the second of
  two cases;
- exact: ``exact=True`` by the default path and with ``backend="ipopt"``.

A mechanism whose loops are near a toggle position (closure conditioning below 1e-6: the library
warns that the answer loses about -log10 of it in digits) is counted, not compared. Where the
linear optimum is not unique (``free_motions`` names directions "bounded but not loaded") the
torsors are counted, not compared: the answer is projected to the minimum-norm point only when
that projection stays inside the play, so the point returned along those directions depends on
the engine (a known limitation, docs/method.md section 3.2); energies and forces are compared.

The load is the mechanism's own, cleared of its components along the motions nothing blocks
(tests/oracle.py ``bounded_loads``), so that an equilibrium exists; the other load is a perturbed
copy, cleared the same way. A path that refuses (any ClearancePinError) is counted, not compared.
Where statically indeterminate contacts share a load (a prismatic block's corners at one x) the
forces are the documented least-norm split (docs/method.md section 3.3), whichever engine found
the optimum; on the old code the kernel and IPOPT put the whole force on one corner and the NumPy
path split it.

Tolerances: torsors to 1e-7 of the largest clearance (the agreement test_random_mechanisms.py
asks of the oracle), energies to 1e-8 of the energy, contact forces to 1e-6 of the largest force.
"""

from __future__ import annotations

import os
from collections import Counter

import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, given, settings
from mechanism_strategies import mechanisms
from oracle import Oracle, bounded_loads

import clearance_pin
from clearance_pin import ClearancePinError, PointForce, Torque
from clearance_pin.equilibrium import fast_path
from clearance_pin.equilibrium.solve import CONDITIONING_WARNING

MECHANISMS = 200  # compared (a drawn mechanism without a bounded load is drawn again)
EXAMPLES = 250  # drawn, to reach MECHANISMS
TORSOR = 1e-7  # of the largest clearance
ENERGY = 1e-8  # of the energy
FORCE = 1e-6  # of the largest contact force


def _perturbed(loads, rng) -> list:
    """The loads with every force and torque component scaled by a factor in [0.5, 1.5]."""
    out = []
    for load in loads:
        if type(load) is PointForce:
            out.append(PointForce(load.link, load.force * rng.uniform(0.5, 1.5, 3), load.point))
        else:
            out.append(Torque(load.link, load.torque * rng.uniform(0.5, 1.5, 3)))
    return out


def _forces(equilibrium) -> np.ndarray:
    return np.array([c.force for c in equilibrium.contacts]).reshape(-1, 3)


class Engines:
    """Runs every engine on one mechanism and load; counts refusals."""

    def __init__(self, kernel: bool):
        self.kernel = kernel
        self.refused: Counter = Counter()

    def _run(self, name: str, compiled: str, solve, answers: dict) -> None:
        previous = os.environ.get("CLEARANCE_PIN_COMPILED")
        os.environ["CLEARANCE_PIN_COMPILED"] = compiled
        try:
            answers[name] = solve()
        except ClearancePinError:
            self.refused[name] += 1
        finally:
            if previous is None:
                del os.environ["CLEARANCE_PIN_COMPILED"]
            else:
                os.environ["CLEARANCE_PIN_COMPILED"] = previous

    def linear(self, text: str, loads, other) -> dict:
        answers: dict = {}
        copies = [clearance_pin.loads(text, source="<random mechanism>") for _ in range(5)]
        options = {"gravity": False}
        self._run("default", "0", lambda: copies[0].solve(loads, warm_start=False, **options),
                  answers)  # fmt: skip

        def warm(mechanism):
            mechanism.solve(other, **options)
            return mechanism.solve(loads, **options)

        self._run("numpy_warm", "0", lambda: warm(copies[1]), answers)
        for backend in ("clarabel", "ipopt"):
            self._run(backend, "0", lambda b=backend: copies[2].solve(loads, warm_start=False,
                      backend=b, **options), answers)  # fmt: skip
        if self.kernel:
            self._run("kernel", "1", lambda: warm(copies[3]), answers)
            self._run("kernel_centre", "1",
                      lambda: copies[3].solve(loads, warm_start=False, **options), answers)  # fmt: skip
        self._run("solve_many", "0",
                  lambda: copies[4].solve_many([other, loads], errors="raise", **options)[1],
                  answers)  # fmt: skip
        return answers

    def exact(self, text: str, loads) -> dict:
        answers: dict = {}
        mechanism = clearance_pin.loads(text, source="<random mechanism>")
        self._run("exact", "0", lambda: mechanism.solve(loads, exact=True, gravity=False),
                  answers)  # fmt: skip
        self._run("exact_ipopt", "0", lambda: mechanism.solve(loads, exact=True, gravity=False,
                  backend="ipopt", warm_start=False), answers)  # fmt: skip
        return answers


def _flat(answer) -> bool:
    """The (linear) optimum is not unique: directions bounded by the play but not loaded."""
    linear = answer.linear if answer.formulation == "exact" else answer
    return any(note.startswith("bounded but not loaded") for note in linear.free_motions)


def _disagreements(reference, other, clearance: float) -> dict[str, float]:
    """Torsor, energy and contact-force differences of ``other`` from ``reference``, each over
    its tolerance's scale (above 1: a disagreement); torsors left out (None) where either
    optimum is not unique."""
    energy = abs(other.energy - reference.energy)
    forces, reference_forces = _forces(other), _forces(reference)
    largest = float(np.abs(reference_forces).max(initial=0.0))
    torsor = None
    if not (_flat(reference) or _flat(other)):
        torsor = max(np.abs(other.torsors[k] - t).max() for k, t in reference.torsors.items())
        torsor /= max(TORSOR * clearance, 1e-300)
    return {
        "torsors": torsor,
        "energies": energy / max(ENERGY * abs(reference.energy), 1e-300),
        "contact forces": float(np.abs(forces - reference_forces).max(initial=0.0))
        / max(FORCE * largest, 1e-300),
    }


@pytest.mark.filterwarnings("ignore::clearance_pin.ConditioningWarning")
def test_every_engine_gives_the_same_answer(extremes_warn):
    """Torsors, energies and contact forces of every linear engine against the default path's,
    and the exact answers of the default and IPOPT paths against each other: no disagreement on
    at least 200 random mechanisms (counts printed)."""
    try:
        fast_path.load_kernel()
        kernel = fast_path.kernel_load_time() is not None
    except ImportError:
        kernel = False
    engines = Engines(kernel)
    counts: Counter = Counter()
    failures: list = []

    @settings(
        max_examples=EXAMPLES,
        deadline=None,
        derandomize=True,
        phases=[Phase.explicit, Phase.generate],
        suppress_health_check=list(HealthCheck),
    )
    @given(spec=mechanisms(max_bodies=6))
    def compare(spec):
        if counts["mechanisms"] >= MECHANISMS:
            return
        text = spec.urdf()
        mechanism = clearance_pin.loads(text, source="<random mechanism>")
        oracle = Oracle(mechanism)
        loads = bounded_loads(oracle, mechanism.resolve_loads(None, None))
        if not loads:
            return
        rng = np.random.default_rng(counts["mechanisms"])
        other = bounded_loads(oracle, _perturbed(loads, rng)) or loads
        counts["mechanisms"] += 1
        clearance = max(
            (c.bound for j in mechanism.joints.values() for c in j.clearance.contacts),
            default=0.0,
        )
        answers = engines.linear(text, loads, other)
        default = answers.get("default")
        if default is not None and (
            default.residuals.get("closure_conditioning", 1.0) < CONDITIONING_WARNING
        ):
            # a loop near a toggle: the library warns that the answer loses digits
            counts["ill-conditioned (warned, not compared)"] += 1
            return
        groups = [("default", answers)]
        groups.append(("exact", engines.exact(text, loads)))
        for reference_name, group in groups:
            reference = group.get(reference_name)
            if reference is None:
                continue
            for name, answer in group.items():
                if name == reference_name:
                    continue
                for quantity, ratio in _disagreements(reference, answer, clearance).items():
                    key = f"{quantity}{' (exact)' if reference_name == 'exact' else ''}"
                    if ratio is None:
                        counts[f"not compared, optimum not unique: {key}"] += 1
                        continue
                    counts[f"pairs: {key}"] += 1
                    if not ratio <= 1.0:
                        counts[f"disagreements: {key}"] += 1
                        failures.append((name, key, ratio, text))

    compare()
    report = dict(sorted(counts.items())) | {"refused": dict(sorted(engines.refused.items()))}
    report["kernel"] = kernel
    print(f"\nengines agree: {report}")
    assert counts["mechanisms"] >= MECHANISMS, report
    assert not failures, (report, failures[:3])


if __name__ == "__main__":  # pragma: no cover
    pytest.main([__file__, "-s"])
