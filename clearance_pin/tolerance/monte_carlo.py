r"""Monte Carlo and exact worst case of the tolerance stack-up, with the exact loop closure.

The linear bands of [F] (P. Flores, "A methodology for quantifying the kinematic position errors
due to manufacturing and assembly tolerances", Strojniski vestnik - J. Mech. Eng. (2011)) rest
on ``dq = S dd``. Here each sample of the dimensions ``d + dd`` is a manufactured mechanism whose
loops are closed *exactly* (``Phi(q, d + dd) = 0``), and the outputs are read from it:

- :func:`monte_carlo`: ``dd_j ~ U(-T_j/2, T_j/2)`` (every sample inside the worst-case box) or
  ``dd_j ~ N(0, (T_j/6)^2)`` (process spread ``6 sigma = T``, whose output ``3 sigma`` the RSS
  band predicts), summary statistics per output;
- :func:`exact_worst_case`: the true extremes of each output over the tolerance box
  ``|dd_j| <= T_j/2``, by optimisation (vertex enumeration, then projected Newton).

The closure of each sample is :class:`~.batch_closure.BatchClosure`.
"""

from __future__ import annotations

import contextlib
import itertools
import os
import time
from collections import deque
from collections.abc import Callable, Iterable
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

import numpy as np

from ..errors import ArgumentError
from ..progress import Progress
from .batch_closure import BatchClosure
from .sensitivity import Output
from .statistics import monte_carlo_inputs

Distribution = Literal["uniform", "normal"]  # of the toleranced dimensions

if TYPE_CHECKING:
    from ..mechanism import Mechanism

#: a function of points (k, n_dim) of the tolerance box, one value per point (k,)
Objective = Callable[[np.ndarray], np.ndarray]

__all__ = ["BatchClosure", "MonteCarloResult", "WorstCase", "exact_worst_case", "monte_carlo"]


@dataclass(frozen=True)
class MonteCarloResult:
    """Statistics of the exact output deviations over the samples, per output.

    Attributes:
        outputs: the outputs.
        distribution: ``"uniform"`` or ``"normal"``.
        samples: number of samples.
        mean, std, minimum, maximum: per output [m or rad], shape (n_out,); ``std`` with ``n - 1``.
        points: a random subset of the deviations, shape (k, n_out), for plots.
        seconds: wall time.
        beyond: per output, how many samples deviate by more than its spec limit
            (``|deviation| > limit``; None: no limits given), shape (n_out,).
    """

    outputs: tuple[Output, ...]
    distribution: str
    samples: int
    mean: np.ndarray
    std: np.ndarray
    minimum: np.ndarray
    maximum: np.ndarray
    points: np.ndarray
    seconds: float
    beyond: np.ndarray | None = None

    @property
    def share_beyond(self) -> np.ndarray | None:
        """The share of samples out of spec per output (None: no limits given)."""
        return None if self.beyond is None else self.beyond / self.samples

    @property
    def three_sigma(self) -> np.ndarray:
        """``3 s`` per output [m or rad]: compare with the RSS band (normal inputs)."""
        three: np.ndarray = 3.0 * self.std
        return three

    @property
    def max_abs(self) -> np.ndarray:
        """Largest ``|deviation|`` per output: inside the worst case band (uniform inputs)."""
        largest: np.ndarray = np.maximum(np.abs(self.minimum), np.abs(self.maximum))
        return largest


def monte_carlo(
    mechanism: Mechanism,
    outputs: Iterable[Output | str],
    q: np.ndarray | None = None,
    samples: int = 100_000,
    distribution: Distribution = "uniform",
    seed: int = 0,
    chunk: int = 1 << 16,
    keep: int = 2000,
    progress: bool | None = None,
    closure: BatchClosure | None = None,
    workers: int | None = None,
    limits: np.ndarray | None = None,
) -> MonteCarloResult:
    """Monte Carlo of the outputs with the loops closed exactly for every sample [F].

    Args:
        mechanism: :class:`~clearance_pin.mechanism.Mechanism` with dimensions.
        outputs: output specs or :class:`Output` objects (ignored if ``closure`` is given).
        q: configuration (default nominal); ignored if ``closure`` is given.
        samples: number of manufactured mechanisms.
        distribution: ``"uniform"`` (``U(-T/2, T/2)``) or ``"normal"`` (``sigma = T/6``).
        seed: seed of ``numpy.random.default_rng``; the results depend only on the seed and
            ``chunk`` (not on ``workers``).
        chunk: samples drawn per block.
        keep: how many deviations to keep for plots.
        progress: progress bar on stderr (None: only on a terminal and for long runs).
        closure: a prebuilt :class:`BatchClosure` of the configuration.
        workers: threads closing blocks in parallel (NumPy releases the GIL in its loops);
            default ``min(4, cpu_count)``; the draws stay sequential.
        limits: per output a spec limit [m or rad] (inf: none): the samples with
            ``|deviation| > limit`` are counted (:attr:`MonteCarloResult.beyond`).

    Returns:
        :class:`MonteCarloResult`.
    """
    started = time.perf_counter()
    closure = closure or BatchClosure(mechanism, outputs, q)
    if isinstance(samples, bool) or int(samples) != samples or samples < 2:
        raise ArgumentError("samples", "an integer >= 2", samples)
    rng = np.random.default_rng(seed)
    half = np.array([d.half_tolerance for d in closure.dimensions])
    stats = _Moments(len(closure.outputs), keep, limits)
    bar = Progress(
        samples,
        "Monte Carlo mechanisms",
        unit="sample",
        enabled=progress if progress is not None else (None if samples >= 1_000_000 else False),
    )
    workers = min(4, os.cpu_count() or 1) if workers is None else max(1, int(workers))
    counts = [min(chunk, samples - start) for start in range(0, samples, chunk)]
    with ThreadPoolExecutor(workers) if workers > 1 else contextlib.nullcontext() as pool:
        pending: deque[tuple[int, Future[np.ndarray]]] = deque()
        for count in counts:
            dd = monte_carlo_inputs(rng, half, count, distribution)
            if pool is None:
                stats.add(closure.solve(dd))
                bar.update(count)
                continue
            pending.append((count, pool.submit(closure.solve, dd)))
            while len(pending) > 2 * workers:
                done, future = pending.popleft()
                stats.add(future.result())
                bar.update(done)
        while pending:
            done, future = pending.popleft()
            stats.add(future.result())
            bar.update(done)
    bar.close()
    return MonteCarloResult(
        closure.outputs,
        distribution,
        samples,
        stats.mean(),
        stats.std(),
        stats.low,
        stats.high,
        np.vstack(stats.kept) if stats.kept else np.zeros((0, len(closure.outputs))),
        time.perf_counter() - started,
        stats.beyond,
    )


class _Moments:
    """Running mean, variance (shifted sums), extremes, the first ``keep`` samples and how many
    exceed the ``limits``."""

    def __init__(self, n_out: int, keep: int, limits: np.ndarray | None = None) -> None:
        self.count, self.keep = 0, keep
        self.limits = None if limits is None else np.asarray(limits, dtype=float)
        self.beyond = None if limits is None else np.zeros(n_out, dtype=int)
        self.total, self.total_sq = np.zeros(n_out), np.zeros(n_out)
        self.low, self.high = np.full(n_out, np.inf), np.full(n_out, -np.inf)
        self.shift: np.ndarray | None = None
        self.kept: list[np.ndarray] = []

    def add(self, y: np.ndarray) -> None:
        if self.shift is None:
            self.shift = y.mean(axis=0)
        centred = y - self.shift
        self.total += centred.sum(axis=0)
        self.total_sq += np.sum(centred * centred, axis=0)
        self.low, self.high = (
            np.minimum(self.low, y.min(axis=0)),
            np.maximum(self.high, y.max(axis=0)),
        )
        if self.beyond is not None:
            self.beyond += np.sum(~(np.abs(y) <= self.limits), axis=0)  # NaN: out of spec
        room = self.keep - sum(len(k) for k in self.kept)
        if room > 0:
            self.kept.append(y[:room])
        self.count += len(y)

    def mean(self) -> np.ndarray:
        assert self.shift is not None  # set by the first add (a run has samples >= 2)
        mean: np.ndarray = self.shift + self.total / self.count
        return mean

    def std(self) -> np.ndarray:
        centred_mean = self.total / self.count
        variance = (self.total_sq - self.count * centred_mean**2) / (self.count - 1)
        std: np.ndarray = np.sqrt(np.maximum(variance, 0.0))
        return std


# --------------------------------------------------------------------------------------------
# Exact worst case over the tolerance box
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class WorstCase:
    """True extremes of the output deviations over the tolerance box ``|dd_j| <= T_j/2``.

    Attributes:
        outputs: the outputs.
        lower, upper: smallest and largest deviation per output [m or rad], shape (n_out,).
        argmin, argmax: the deviations ``dd`` [m or rad] reaching them, shape (n_out, n_dim).
        linear: the first-order worst-case half band per output (for comparison).
        projected_gradient: optimality check, the largest projected gradient component times
            the half tolerance [output units] at the answers (0 at a vertex optimum).
    """

    outputs: tuple[Output, ...]
    lower: np.ndarray
    upper: np.ndarray
    argmin: np.ndarray
    argmax: np.ndarray
    linear: np.ndarray
    projected_gradient: np.ndarray

    @property
    def half_band(self) -> np.ndarray:
        """``max(|lower|, |upper|)`` per output: the exact worst-case half band."""
        band: np.ndarray = np.maximum(np.abs(self.lower), np.abs(self.upper))
        return band


def exact_worst_case(
    mechanism: Mechanism,
    outputs: Iterable[Output | str],
    q: np.ndarray | None = None,
    closure: BatchClosure | None = None,
    max_vertices: int = 4096,
    max_iterations: int = 50,
) -> WorstCase:
    """Exact (nonlinear) extremes of every output over the tolerance box, by optimisation.

    For each output and sign: the best vertex of the box (all ``2^n`` vertices when
    ``2^n <= max_vertices``, else the linear worst-case vertex and its one-coordinate flips),
    then a projected Newton ascent with finite-difference derivatives of the exact closure
    (free coordinates: Newton step on the concave part, gradient step otherwise; backtracking
    on the true value) until the projected gradient vanishes.

    Returns:
        :class:`WorstCase`.
    """
    closure = closure or BatchClosure(mechanism, outputs, q)
    half = np.array([d.half_tolerance for d in closure.dimensions])
    n_out, n_dim = len(closure.outputs), len(half)
    lower, upper = np.zeros(n_out), np.zeros(n_out)
    argmin, argmax = np.zeros((n_out, n_dim)), np.zeros((n_out, n_dim))
    kkt = np.zeros(n_out)
    vertices = _vertices(half, closure.linear.matrix, max_vertices)
    values = closure.solve(vertices) if len(vertices) else np.zeros((0, n_out))
    for i in range(n_out):
        for sign in (1.0, -1.0):

            def f(x: np.ndarray, i: int = i, sign: float = sign) -> np.ndarray:
                return sign * closure.solve(np.atleast_2d(x))[:, i]

            start = vertices[int(np.argmax(sign * values[:, i]))]
            x, value, pg = _projected_newton(f, start, half, max_iterations)
            if sign > 0:
                upper[i], argmax[i] = value, x
            else:
                lower[i], argmin[i] = -value, x
            kkt[i] = max(kkt[i], pg)
    return WorstCase(
        closure.outputs, lower, upper, argmin, argmax, closure.linear.worst_case(), kkt
    )


def _vertices(half: np.ndarray, matrix: np.ndarray, max_vertices: int) -> np.ndarray:
    n = len(half)
    if 2**n <= max_vertices:
        signs = np.array(list(itertools.product((-1.0, 1.0), repeat=n)))
        corners: np.ndarray = signs * half
        return corners
    starts: list[np.ndarray] = []
    for row in matrix:
        for sign in (1.0, -1.0):
            base = np.where(sign * row >= 0, 1.0, -1.0)
            starts.append(base)
            for j in range(n):
                flipped = base.copy()
                flipped[j] = -flipped[j]
                starts.append(flipped)
    chosen: np.ndarray = np.unique(np.array(starts), axis=0) * half
    return chosen


def _projected_newton(
    f: Objective, x: np.ndarray, half: np.ndarray, max_iterations: int
) -> tuple[np.ndarray, float, float]:
    """Maximise ``f`` over ``|x_j| <= half_j`` from ``x``; returns (x, f(x), projected gradient)."""
    n = len(x)
    scale = np.where(half > 0, half, 1.0)
    active = half > 0
    h = 1e-3 * scale
    value = float(f(x)[0])
    pg = 0.0
    for _ in range(max_iterations):
        g, hessian = _derivatives(f, x, h)
        g_scaled = g * scale
        at_hi = x >= half - 1e-12 * scale
        at_lo = x <= -half + 1e-12 * scale
        free = active & ~((at_hi & (g > 0)) | (at_lo & (g < 0)))
        pg = float(np.max(np.abs(g_scaled[free]), initial=0.0))
        if not free.any():
            break
        step = np.zeros(n)
        hff = hessian[np.ix_(free, free)]
        try:
            chol = np.linalg.cholesky(-hff)
            step[free] = np.linalg.solve(chol.T, np.linalg.solve(chol, g[free]))
        except np.linalg.LinAlgError:
            step[free] = (
                g[free] * scale[free] ** 2 / max(np.linalg.norm(g_scaled[free]), 1e-300) * 2
            )
        trials = np.array([np.clip(x + t * step, -half, half) for t in 0.5 ** np.arange(30)])
        trial_values = f(trials)
        best = int(np.argmax(trial_values))
        gain = float(trial_values[best]) - value
        if gain <= 1e-15 * max(abs(value), 1e-300) or gain <= 0.0:
            break
        x, value = trials[best], float(trial_values[best])
    return x, value, pg


def _derivatives(f: Objective, x: np.ndarray, h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Central finite-difference gradient and Hessian of ``f`` at ``x`` (one batched call)."""
    n = len(x)
    points = [x]
    for i in range(n):
        for si in (1.0, -1.0):
            e = np.zeros(n)
            e[i] = si * h[i]
            points.append(x + e)
    pairs = [(i, j) for i in range(n) for j in range(i)]
    for i, j in pairs:
        for si, sj in ((1, 1), (1, -1), (-1, 1), (-1, -1)):
            e = np.zeros(n)
            e[i], e[j] = si * h[i], sj * h[j]
            points.append(x + e)
    y = f(np.array(points))
    g = np.array([(y[1 + 2 * i] - y[2 + 2 * i]) / (2 * h[i]) for i in range(n)])
    hessian = np.zeros((n, n))
    for i in range(n):
        hessian[i, i] = (y[1 + 2 * i] - 2 * y[0] + y[2 + 2 * i]) / (h[i] ** 2)
    base = 1 + 2 * n
    for p, (i, j) in enumerate(pairs):
        pp, pm, mp, mm = y[base + 4 * p : base + 4 * p + 4]
        hessian[i, j] = hessian[j, i] = (pp - pm - mp + mm) / (4 * h[i] * h[j])
    return g, hessian
