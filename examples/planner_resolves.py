"""A planner's loop: build the mechanism once, then re-solve thousands of loads.

``mechanism.resolver(loads)`` binds one set of loads once; ``resolver.solve(vectors)`` takes the
new force and torque vectors, one case at a time (``resolver.solve``) or many as an array
(``resolver.solve_many``). ``answer.method`` says which engine answered (the compiled kernel
when ``clearance-pin compile`` has run at set-up, as ``make`` does).

Run from the repository's root: ``.venv/bin/python examples/planner_resolves.py``.
"""

import collections
import time

import numpy as np

import clearance_pin
from clearance_pin import PointForce, Torque
from clearance_pin.equilibrium import fast_path

if fast_path.kernel_installed():  # compiled at set-up: load it now, not in the loop (~0.5 s)
    print(f"compiled kernel loaded in {fast_path.load_kernel():.2f} s")

four_bar = clearance_pin.load("models/four_bar.urdf")
loads = [PointForce("coupler", [0.0, -40.0, 0.0], [0.09, 0, 0]), Torque("rocker", [0, 0, -2.0])]
resolver = four_bar.resolver(loads)  # checks, load maps and geometry built once

rng = np.random.default_rng(0)
vectors = np.array([[0.0, -40.0, 0.0], [0.0, 0.0, -2.0]]) + rng.normal(0, 5, (2000, 2, 3))
engines = collections.Counter()
started = time.perf_counter()
for vector in vectors:
    answer = resolver.solve(vector)  # (k, 3): a force or torque per load, in the loads' order
    engines[answer.method.value] += 1
seconds = time.perf_counter() - started
print(f"{len(vectors)} re-solves in {seconds:.2f} s ({seconds / len(vectors) * 1e6:.0f} us each)")
print(f"engines that answered: {dict(engines)}")
assert answer.ok

# all at once from the array: no load object built, the answers read as arrays
started = time.perf_counter()
batch = resolver.solve_many(vectors)
seconds = time.perf_counter() - started
crank = batch.torsors("crank_pivot")  # (2000, 6): the crank pivot's torsor in every case
print(f"{len(batch)} cases in one call: {seconds * 1e3:.1f} ms, all verified: {batch.ok.all()}")
assert np.abs(crank[-1] - answer.torsors["crank_pivot"]).max() < 1e-12  # the same answers
