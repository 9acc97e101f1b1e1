"""IPOPT from several threads (issue 21, item 5): every Executor kind and ``Mechanism.solve`` from
threads give the serial answers with cases that reach IPOPT (``backend="ipopt"``), and the process
survives. Before the process-wide IPOPT lock (:mod:`clearance_pin.equilibrium.ipopt`) the threaded
runs below ended in a segmentation fault in libipopt, so they run in a child process whose exit
status the test reads (a crash fails the test instead of killing pytest)."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest
from conftest import MODELS, ROOT

import clearance_pin as cp
from clearance_pin import PointForce

MODEL = MODELS / "younes_sphere_cylinder.urdf"
TOLERANCE = 1e-16  # [m, rad]: 1e-11 of the plays (10 um); paths differ in round-off only

# the loads of every run: 40 random tool forces on the shaft of the paper's sphere-cylinder case
LOADS = textwrap.dedent(
    f"""
    import numpy as np
    import clearance_pin as cp
    from clearance_pin import PointForce

    mechanism = cp.load({str(MODEL)!r})
    forces = np.random.default_rng(0).normal(size=(40, 3))
    cases = [[PointForce("shaft", force=f, point=[0.3, 0, 0])] for f in forces]
    serial = mechanism.solve_many(cases, backend="ipopt")
    assert serial.ok.all()
    TOLERANCE = {TOLERANCE!r}
    """
)


def _run_child(body: str) -> None:
    """Run LOADS then ``body`` in a fresh interpreter; fail on a crash or a failed assertion."""
    completed = subprocess.run(
        [sys.executable, "-c", LOADS + textwrap.dedent(body)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=600,
        check=False,
    )
    assert completed.returncode == 0, (
        f"exit {completed.returncode} (-11: segmentation fault)\n{completed.stderr[-2000:]}"
    )


def test_solve_many_on_a_thread_pool_with_ipopt():
    """solve_many(backend="ipopt") spread over 4 threads in 20-case chunks: the serial torsors to
    1e-11 of the play, the process alive (it crashed in 3 of 3 runs before)."""
    _run_child(
        """
        from concurrent.futures import ThreadPoolExecutor

        with ThreadPoolExecutor(4) as pool:
            threaded = mechanism.solve_many(cases, backend="ipopt", executor=pool, chunks=2)
        assert threaded.ok.all()
        for name in mechanism.joints:
            assert np.allclose(threaded.torsors(name), serial.torsors(name), rtol=0, atol=TOLERANCE)
        """
    )


def test_mechanism_solve_from_threads_with_ipopt():
    """Mechanism.solve(backend="ipopt") called by 4 threads at once on one mechanism, small and
    exact model: each answer equals the serial one (the IPOPT statistics read are its own)."""
    _run_child(
        """
        from concurrent.futures import ThreadPoolExecutor

        def both(case):
            linear = mechanism.solve(loads=case, backend="ipopt", warm_start=False)
            exact = mechanism.solve(loads=case, backend="ipopt", exact=True, warm_start=False)
            return linear, exact

        with ThreadPoolExecutor(4) as pool:
            answers = list(pool.map(both, cases))
        for k, (linear, exact) in enumerate(answers):
            assert linear.ok and exact.ok
            reference = mechanism.solve(loads=cases[k], backend="ipopt", exact=True)
            assert np.allclose(linear.torsor("I2"), serial[k].torsor("I2"), rtol=0, atol=TOLERANCE)
            assert np.allclose(exact.torsor("I2"), reference.torsor("I2"), rtol=0, atol=TOLERANCE)
        """
    )


def test_solve_many_on_a_process_pool_with_ipopt():
    """solve_many(backend="ipopt") on a ProcessPoolExecutor: the serial torsors."""
    mechanism = cp.load(MODEL)
    forces = np.random.default_rng(1).normal(size=(6, 3))
    cases = [[PointForce("shaft", force=f, point=[0.3, 0, 0])] for f in forces]
    serial = mechanism.solve_many(cases, backend="ipopt")
    with ProcessPoolExecutor(2) as pool:
        remote = mechanism.solve_many(cases, backend="ipopt", executor=pool, chunks=2)
    assert remote.ok.all()
    for name in mechanism.joints:
        np.testing.assert_allclose(
            remote.torsors(name), serial.torsors(name), rtol=0, atol=TOLERANCE
        )


def test_dask_threads_with_ipopt():
    """A Dask client with one worker of 4 threads as the Executor (distributed extra): the serial
    answers, the process alive."""
    pytest.importorskip("distributed")
    _run_child(
        """
        import distributed

        with distributed.Client(
            processes=False, n_workers=1, threads_per_worker=4, dashboard_address=None
        ) as client:
            threaded = mechanism.solve_many(
                cases, backend="ipopt", executor=client.get_executor(), chunks=4
            )
        assert threaded.ok.all()
        assert np.allclose(threaded.torsors("I2"), serial.torsors("I2"), rtol=0, atol=TOLERANCE)
        """
    )
