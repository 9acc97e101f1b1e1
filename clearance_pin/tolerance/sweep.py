r"""Tolerance bands over a motion: a driven joint swept through a cycle or a stroke [F].

P. Flores, "A methodology for quantifying the kinematic position errors due to manufacturing
and assembly tolerances", Strojniski vestnik - J. Mech. Eng. (2011) [F], tabulates the
sensitivities and bands of a slider-crank at 25 crank positions. :func:`sweep` does this for
any mechanism: the driven joint takes the values

.. math:: q_{drive}(\varphi) = q_0 + s \, \varphi, \qquad \varphi_k = \varphi_0 + k\,\Delta\varphi

(``s = -1`` for a clockwise crank: the convention of the Flores case, ``theta2 = -phi`` with
``phi`` from top dead centre), the loops are closed on the same assembly branch all along
(steps of at most :func:`step_limit` from the model's nominal configuration), and at every
position it gives the sensitivities (:mod:`.sensitivity`), the worst-case and RSS bands, and
optionally exact Monte Carlo runs and the exact worst case (:mod:`.monte_carlo`).

The motion parameter is in the swept joint's own unit (:func:`joint_unit`): an angle ``phi``
[rad] of a revolute or continuous joint (one turn by default), a travel ``s`` [m] of a prismatic
one (a Stewart platform's leg, a slider driven instead of a crank), whose range must be given:
a slider has no cycle. A range that takes the joint out of its URDF ``<limit>`` is refused.

:func:`cycle_maximum` finds the largest band over the *continuous* range of a sweep (a grid,
then a golden-section refinement), :func:`clearance_budget` sets the clearance-induced deviation
of the equilibrium engine (docs/method.md section 2) beside the tolerance bands, and
:func:`plot_sweep` draws them (matplotlib, the ``plot`` extra).
"""

from __future__ import annotations

import math
import numbers
import os
import time
import warnings
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, overload

import numpy as np
import pinocchio as pin

from ..arguments import MOST_POSITIONS, MOST_SAMPLES, check_count, check_seed
from ..errors import ArgumentError, ClearancePinError, NotFoundError
from ..model.clearance import ALPHA, U
from ..model.dimensions import Dimension
from ..model.joints import MOTION_COMPONENT_BY_PIN_JOINT
from ..model.plausibility import LIMIT_SLACK, limits_of
from ..progress import Progress
from .monte_carlo import (
    BatchClosure,
    Distribution,
    MonteCarloResult,
    WorstCase,
    exact_worst_case,
    monte_carlo,
)
from .sensitivity import Output, Sensitivities, parse_output, sensitivities

if TYPE_CHECKING:
    from ..mechanism import Mechanism
    from ..model.loads import Gravity, Load

__all__ = [
    "Budget",
    "Sweep",
    "clearance_budget",
    "closed_configuration",
    "cycle_maximum",
    "driven_joint",
    "joint_unit",
    "plot_sweep",
    "step_limit",
    "sweep",
]

#: largest step of a revolute driven joint between two loop closures [rad] (keeps the branch)
MAX_STEP = math.radians(5.0)
#: largest step of a prismatic driven joint between two loop closures, as a fraction of the
#: mechanism's length scale [-]: the step of ``clearance_pin.kinematics.closure.follow_branch``
PRISMATIC_STEP = 0.05
#: name and display unit of the motion parameter, by the joint's unit
_DISPLAY = {"rad": ("phi", "deg"), "m": ("s", "mm")}
_GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0


@dataclass(frozen=True)
class Sweep:
    """Sensitivities and bands at every position of a motion.

    Attributes:
        joint: the driven joint swept.
        phi: the motion parameter at each position [rad, or m for a prismatic joint: ``s``],
            shape (n_pos,).
        sign, offset: ``q_drive = offset + sign * phi`` [rad or m].
        configurations: closed configurations, shape (n_pos, nq).
        outputs, dimensions: as in :class:`~.sensitivity.Sensitivities`.
        values: nominal outputs [m or rad], shape (n_pos, n_out).
        matrix: sensitivities ``S`` [output/dimension], shape (n_pos, n_out, n_dim).
        worst, rss: half bands [output units], shape (n_pos, n_out).
        uniform, normal: Monte Carlo results per position (empty without samples).
        exact: exact worst cases per position (empty unless asked).
        seconds: wall time of the sweep.
        unit: the swept joint's unit, ``"rad"`` (revolute, continuous) or ``"m"`` (prismatic).
    """

    joint: str
    phi: np.ndarray
    sign: float
    offset: float
    configurations: np.ndarray
    outputs: tuple[Output, ...]
    dimensions: tuple[Dimension, ...]
    values: np.ndarray
    matrix: np.ndarray
    worst: np.ndarray
    rss: np.ndarray
    uniform: tuple[MonteCarloResult, ...] = ()
    normal: tuple[MonteCarloResult, ...] = ()
    exact: tuple[WorstCase, ...] = ()
    seconds: float = 0.0
    unit: str = "rad"

    @property
    def phi_deg(self) -> np.ndarray:
        """The motion parameter [deg] of a revolute joint's sweep."""
        if self.unit != "rad":
            raise ClearancePinError(
                f"the sweep of prismatic joint {self.joint!r} is a travel in m, not an angle: "
                "read phi [m] or display()"
            )
        degrees: np.ndarray = np.degrees(self.phi)
        return degrees

    @property
    def symbol(self) -> str:
        """Name of the motion parameter: ``"phi"`` (an angle) or ``"s"`` (a travel)."""
        return _DISPLAY[self.unit][0]

    @property
    def display_unit(self) -> str:
        """Unit of :meth:`display`: ``"deg"`` or ``"mm"``."""
        return _DISPLAY[self.unit][1]

    @overload
    def display(self, value: None = None) -> np.ndarray: ...
    @overload
    def display(self, value: float) -> float: ...
    @overload
    def display(self, value: np.ndarray) -> np.ndarray | float: ...
    def display(self, value: float | np.ndarray | None = None) -> np.ndarray | float:
        """A motion parameter value (default: every position's) in :attr:`display_unit`
        [deg or mm], from [rad or m] (a float for a float or a 0-d array)."""
        value = self.phi if value is None else value
        if self.unit == "rad":
            return np.degrees(value) if np.ndim(value) else math.degrees(float(value))
        return 1e3 * np.asarray(value) if np.ndim(value) else 1e3 * float(value)

    def index(self, name: str) -> int:
        """Row of the output called ``name``."""
        for i, output in enumerate(self.outputs):
            if output.name == name:
                return i
        raise NotFoundError("output", name, [o.name for o in self.outputs], "Sweep.index")


def driven_joint(mechanism: Mechanism, joint: str | None = None) -> int:
    """Pinocchio id of the joint to sweep: ``joint``, which must be driven (the sweep moves it and
    holds it there, which only a drive does), or the mechanism's only driven joint."""
    model = mechanism.model
    if joint is not None:
        if not model.existJointName(joint) or model.getJointId(joint) == 0:
            raise NotFoundError("joint", joint, model.names[1:], mechanism.source)
        joint_id: int = model.getJointId(joint)
        driven_names = [j.name for j in mechanism.tree_joints if j.driven]
        if (
            joint not in driven_names
        ):  # a passive joint's value is the loop's to set, not the sweep's
            raise ArgumentError(
                "joint",
                f'a driven joint (driven="true" in its <joint> element; the driven joints are: '
                f"{', '.join(driven_names) or '(none)'})",
                joint,
                f"{joint} is not driven",
            )
    else:
        driven = [j.joint_id for j in mechanism.tree_joints if j.driven]
        if len(driven) != 1:
            raise ClearancePinError(
                f"{mechanism.source}: {len(driven)} driven joints; name the joint to sweep"
            )
        joint_id = driven[0]
    if model.joints[joint_id].nv != 1:
        raise ArgumentError(
            "joint",
            "a 1-DOF joint (revolute or prismatic)",
            model.names[joint_id],
            f"{model.joints[joint_id].nv} degrees of freedom",
        )
    return joint_id


def joint_unit(mechanism: Mechanism, joint_id: int) -> str:
    """Unit of a 1-DOF joint's value: ``"rad"`` (revolute, continuous) or ``"m"`` (prismatic).

    Raises:
        ClearancePinError: another kind of joint (it has no sweep).
    """
    model = mechanism.model
    kind = model.joints[joint_id].shortname()
    component = MOTION_COMPONENT_BY_PIN_JOINT.get(kind)
    if component == ALPHA:
        return "rad"
    if component == U:
        return "m"
    raise ClearancePinError(
        f"joint {model.names[joint_id]!r} ({kind}) is neither revolute nor prismatic; "
        "only those joints are swept"
    )


def step_limit(mechanism: Mechanism, joint_id: int) -> float:
    """Largest step of the joint between two loop closures [rad or m]: :data:`MAX_STEP` for a
    revolute joint, :data:`PRISMATIC_STEP` of the mechanism's length scale for a prismatic one."""
    if joint_unit(mechanism, joint_id) == "rad":
        return MAX_STEP
    return PRISMATIC_STEP * mechanism.length_scale()


def _joint_value(model: pin.Model, q: np.ndarray, joint_id: int) -> float:
    joint = model.joints[joint_id]
    if joint.nq == 2:
        return math.atan2(q[joint.idx_q + 1], q[joint.idx_q])
    return float(q[joint.idx_q])


def _set_joint(model: pin.Model, q: np.ndarray, joint_id: int, value: float) -> np.ndarray:
    q = q.copy()
    joint = model.joints[joint_id]
    if joint.nq == 2:
        q[joint.idx_q : joint.idx_q + 2] = (math.cos(value), math.sin(value))
    else:
        q[joint.idx_q] = value
    return q


def closed_configuration(
    mechanism: Mechanism,
    joint_id: int,
    value: float,
    q_from: np.ndarray,
    value_from: float | None = None,
) -> np.ndarray:
    """Close the loops with the joint at ``value`` [rad or m], walking from ``q_from`` (a closed
    configuration, the joint at ``value_from``, default read from it) in steps of at most
    :func:`step_limit`, so that the branch is kept."""
    model = mechanism.model
    start = _joint_value(model, q_from, joint_id) if value_from is None else value_from
    steps = max(1, math.ceil(abs(value - start) / step_limit(mechanism, joint_id)))
    q = q_from
    for k in range(1, steps + 1):
        q = mechanism.configure(
            _set_joint(model, q, joint_id, start + (value - start) * k / steps)
        ).q
    return q


def sweep(
    mechanism: Mechanism,
    outputs: Iterable[Output | str],
    joint: str | None = None,
    positions: int = 25,
    start: float | None = None,
    stop: float | None = None,
    clockwise: bool = False,
    offset: float = 0.0,
    samples: int = 0,
    seed: int = 0,
    exact: bool = False,
    progress: bool | None = None,
    limits: Sequence[float] | None = None,
) -> Sweep:
    """Sensitivities and bands over a cycle or a stroke of a driven joint [F].

    The motion parameter ``phi`` is in the joint's unit: [rad] for a revolute or continuous
    joint, [m] for a prismatic one (its travel ``s``).

    Args:
        mechanism: :class:`~clearance_pin.mechanism.Mechanism` with ``<dimension>`` elements.
        outputs: output specs (``"x4=slider.x"``) or :class:`~.sensitivity.Output` objects.
        joint: the joint to sweep (default: the only driven joint).
        positions: number of positions, ``phi`` from ``start`` to ``stop`` inclusive.
        start, stop: range of ``phi`` [rad or m]; a revolute joint's default is one turn,
            0 to 2 pi, a prismatic joint has none (it has no cycle).
        clockwise: ``q_drive = offset - phi`` (else ``offset + phi``).
        offset: ``q_drive`` at ``phi = 0`` [rad or m].
        samples: Monte Carlo samples per position and distribution (0: none).
        seed: seed of the Monte Carlo runs (position k uses ``seed + k``).
        exact: also the exact worst case at every position.
        progress: progress bar on stderr (None: on a terminal, for runs with Monte Carlo).
        limits: per output a spec limit [m or rad] (inf: none): the Monte Carlo runs count the
            samples out of spec (:attr:`.monte_carlo.MonteCarloResult.beyond`).

    Returns:
        :class:`Sweep`.

    Raises:
        ArgumentError: ``positions`` outside 1 to ``MOST_POSITIONS``, ``samples`` outside 2 to
            ``MOST_SAMPLES`` (0: none), a negative ``seed``, a passive ``joint``, a range
            missing (prismatic joint) or not finite, or
            one that takes the joint out of its URDF limits; a joint of more than 1 DOF.
        NotFoundError: ``joint`` or an output names no joint or frame (the message lists them).
    """
    started = time.perf_counter()
    model = mechanism.model
    check_count("positions", positions, 1, MOST_POSITIONS)
    if samples != 0:  # 0: no Monte Carlo; one sample has no spread
        check_count("samples", samples, 2, MOST_SAMPLES)
    check_seed("seed", seed)
    joint_id = driven_joint(mechanism, joint)
    unit = joint_unit(mechanism, joint_id)
    start, stop = _sweep_range(model, joint_id, unit, start, stop, offset)
    parsed = tuple(o if isinstance(o, Output) else parse_output(model, o) for o in outputs)
    sign = -1.0 if clockwise else 1.0
    phi = np.linspace(start, stop, positions) if positions > 1 else np.array([start])
    _check_limits(model, joint_id, unit, offset + sign * phi, (start, stop))
    q = mechanism.configure().q
    current = _joint_value(model, q, joint_id)
    bar = Progress(
        positions,
        "sweeping the driven joint",
        unit="position",
        enabled=progress if progress is not None else (None if samples else False),
    )
    rows: list[Sensitivities] = []
    uniform: list[MonteCarloResult] = []
    normal: list[MonteCarloResult] = []
    worst_cases: list[WorstCase] = []
    configurations: list[np.ndarray] = []
    for k, parameter in enumerate(phi):
        target = offset + sign * parameter
        q = closed_configuration(mechanism, joint_id, target, q, current)
        current = target
        configurations.append(q)
        linear = sensitivities(mechanism, parsed, q, closed=True)
        rows.append(linear)
        if samples or exact:
            closure = BatchClosure(mechanism, parsed, q, linear=linear)
            if samples:
                laws: tuple[tuple[list[MonteCarloResult], Distribution], ...] = (
                    (uniform, "uniform"),
                    (normal, "normal"),
                )
                for runs, law in laws:
                    runs.append(
                        monte_carlo(
                            mechanism,
                            parsed,
                            samples=samples,
                            distribution=law,
                            seed=seed + k,
                            closure=closure,
                            progress=False,
                            limits=None if limits is None else np.asarray(limits, dtype=float),
                        )
                    )
            if exact:
                worst_cases.append(exact_worst_case(mechanism, parsed, closure=closure))
        bar.update()
    bar.close()
    return Sweep(
        model.names[joint_id],
        phi,
        sign,
        offset,
        np.array(configurations),
        parsed,
        rows[0].dimensions,
        np.array([r.values for r in rows]),
        np.array([r.matrix for r in rows]),
        np.array([r.worst_case() for r in rows]),
        np.array([r.rss() for r in rows]),
        tuple(uniform),
        tuple(normal),
        tuple(worst_cases),
        time.perf_counter() - started,
        unit,
    )


def _sweep_range(
    model: pin.Model,
    joint_id: int,
    unit: str,
    start: float | None,
    stop: float | None,
    offset: float,
) -> tuple[float, float]:
    """``(start, stop)`` [rad or m] of a sweep: a revolute joint's default turn, checked finite."""
    if unit == "rad":
        start = 0.0 if start is None else start
        stop = 2.0 * math.pi if stop is None else stop
    for argument, value in (("start", start), ("stop", stop)):
        if value is None:
            raise ArgumentError(
                argument,
                f"the {argument} of the travel of prismatic joint {model.names[joint_id]!r} [m] "
                "(a prismatic joint has no cycle: give start and stop)",
                value,
            )
    for argument, value in (("start", start), ("stop", stop), ("offset", offset)):
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            raise ArgumentError(argument, f"a number [{unit}]", value)
        if not math.isfinite(value):
            raise ArgumentError(argument, f"a finite number [{unit}]", value)
    assert start is not None and stop is not None  # refused above
    return start, stop


def _check_limits(
    model: pin.Model, joint_id: int, unit: str, values: np.ndarray, span: tuple[float, float]
) -> None:
    """Refuse joint values [rad or m] of a sweep outside the joint's URDF limits."""
    limits = limits_of(model, joint_id)
    if limits is None:
        return
    lowest, highest = float(np.min(values)), float(np.max(values))
    if limits[0] - LIMIT_SLACK <= lowest and highest <= limits[1] + LIMIT_SLACK:
        return
    raise ArgumentError(
        "start, stop",
        f"a range keeping joint {model.names[joint_id]!r} within its URDF limits "
        f"[{limits[0]:.6g}, {limits[1]:.6g}] {unit}",
        tuple(float(v) for v in span),
        f"the joint would reach [{lowest:.6g}, {highest:.6g}] {unit}",
    )


def _band_at(
    mechanism: Mechanism, result: Sweep, output: int, band: str, parameter: float
) -> float:
    """The band of one output with the motion parameter at ``parameter`` [rad or m]."""
    joint_id = driven_joint(mechanism, result.joint)
    nearest = int(np.argmin(np.abs(result.phi - parameter)))
    q = closed_configuration(
        mechanism,
        joint_id,
        result.offset + result.sign * parameter,
        result.configurations[nearest],
        result.offset + result.sign * result.phi[nearest],
    )
    linear = sensitivities(mechanism, (result.outputs[output],), q, closed=True)
    return float((linear.worst_case() if band == "worst" else linear.rss())[0])


def cycle_maximum(
    mechanism: Mechanism,
    result: Sweep,
    output: str,
    band: str = "worst",
    grid: int = 361,
    tol: float = 1e-9,
    fine: Sweep | None = None,
) -> tuple[float, float]:
    """Largest band of an output over the continuous range of the sweep, and where.

    Over ``[phi_0, phi_end]`` of the sweep and nothing else (one turn for the default sweep of a
    revolute joint, the stroke given for a prismatic one): a grid of ``grid`` positions, then a
    golden-section search
    in the two grid intervals around each grid maximum within ``1e-6`` of the best; ties
    (symmetric mechanisms) go to the smallest ``phi``.

    Args:
        mechanism: the mechanism of the sweep.
        result: a :class:`Sweep` (its range and output definitions).
        output: output name.
        band: ``"worst"`` or ``"rss"``.
        grid: grid size.
        tol: golden-section tolerance on ``phi`` [rad or m].
        fine: a prebuilt grid sweep of the same range and outputs (re-use it for several
            outputs and bands), else one is computed.

    Returns:
        ``(maximum band [output units], phi [rad or m])``.
    """
    if band not in ("worst", "rss"):
        raise ArgumentError("band", "'worst' or 'rss'", band)
    if fine is None:
        fine = sweep(
            mechanism,
            result.outputs,
            result.joint,
            grid,
            result.phi[0],
            result.phi[-1],
            result.sign < 0,
            result.offset,
        )
    i = fine.index(output)
    values = (fine.worst if band == "worst" else fine.rss)[:, i]
    top = float(np.max(values))
    best_value, best_phi = -math.inf, math.nan
    step = fine.phi[1] - fine.phi[0] if len(fine.phi) > 1 else 0.0
    for k in np.flatnonzero(values >= top * (1.0 - 1e-6)):
        lo, hi = max(fine.phi[k] - step, fine.phi[0]), min(fine.phi[k] + step, fine.phi[-1])
        phi_k, value_k = _golden(lambda a: _band_at(mechanism, fine, i, band, a), lo, hi, tol)
        if value_k < values[k]:
            phi_k, value_k = float(fine.phi[k]), float(values[k])
        if value_k > best_value * (1.0 + 1e-12):
            best_value, best_phi = value_k, phi_k
    return best_value, best_phi


def _golden(f: Callable[[float], float], lo: float, hi: float, tol: float) -> tuple[float, float]:
    """Maximise a unimodal ``f`` on ``[lo, hi]``; returns (x, f(x))."""
    a, b = lo, hi
    c, d = b - _GOLDEN * (b - a), a + _GOLDEN * (b - a)
    fc, fd = f(c), f(d)
    while b - a > tol:
        if fc >= fd:
            b, d, fd = d, c, fc
            c = b - _GOLDEN * (b - a)
            fc = f(c)
        else:
            a, c, fc = c, d, fd
            d = a + _GOLDEN * (b - a)
            fd = f(d)
    candidates = [(fc, c), (fd, d), (f(lo), lo), (f(hi), hi)]
    value, x = max(candidates, key=lambda t: (t[0], -t[1]))
    return x, value


@dataclass(frozen=True)
class Budget:
    """Clearance-induced deviation beside the tolerance bands, per position [m or rad].

    Attributes:
        phi: positions [rad or m, the sweep's unit], shape (n_pos,).
        output: the output name.
        clearance: deviation of the loaded mechanism in its clearances (equilibrium engine,
            signed), shape (n_pos,).
        worst, rss: tolerance half bands, shape (n_pos,).
    """

    phi: np.ndarray
    output: str
    clearance: np.ndarray
    worst: np.ndarray
    rss: np.ndarray

    @property
    def total_worst(self) -> np.ndarray:
        """``|clearance| + worst``: the largest deviation from nominal, worst case."""
        total: np.ndarray = np.abs(self.clearance) + self.worst
        return total

    @property
    def total_rss(self) -> np.ndarray:
        """``|clearance| + rss``: the same with the statistical band."""
        total: np.ndarray = np.abs(self.clearance) + self.rss
        return total


def clearance_budget(
    mechanism: Mechanism,
    result: Sweep,
    output: str,
    loads: Sequence[Load] | None = None,
    gravity: bool | Gravity | None = None,
) -> Budget:
    """The combined budget of an output: clearance deviation and tolerance bands over a sweep.

    At each position the equilibrium engine (:meth:`Mechanism.solve`, the model's loads unless
    ``loads`` is given) places the parts in their clearances; the output's deviation is read
    from :meth:`Equilibrium.frame_displacement` (a frame position or orientation output) and
    set beside the tolerance bands; deviations add (clearances shift the mean, tolerances
    spread around it).
    """
    i = result.index(output)
    target = result.outputs[i]
    if target.kind == "joint":
        raise ClearancePinError(
            "the clearance budget needs a frame output (position or "
            "orientation), not a joint coordinate"
        )
    deviations: list[float] = []
    for q in result.configurations:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # near dead centres the engine warns; values hold
            equilibrium = mechanism.solve(loads=loads, q=q, gravity=gravity)
        translation, rotation = equilibrium.frame_displacement(target.target)
        vector = translation if target.kind == "position" else rotation
        deviations.append(float(vector[target.component]))
    return Budget(
        result.phi.copy(),
        output,
        np.array(deviations),
        result.worst[:, i].copy(),
        result.rss[:, i].copy(),
    )


def plot_sweep(
    result: Sweep,
    path: str | os.PathLike[str],
    budget: Budget | None = None,
    scale: dict[str, tuple[float, str]] | None = None,
    title: str = "",
    limits: dict[str, float] | None = None,
) -> None:
    """Write a PNG of the bands over the sweep, with the Monte Carlo points and the budget.

    One panel per output: the worst-case band (shaded), the RSS band (lines), the uniform Monte
    Carlo deviations (points), the exact worst case (markers) and the spec limits ``limits``
    (output name -> L [m or rad], dashed at +/- L); beside it, with Monte Carlo, the histogram
    of the deviations where the worst band is largest, with the same bands and limits. With
    ``budget``, a last panel with the clearance deviation and the total bands around it. The
    abscissa is the motion parameter, ``phi`` [deg] or ``s`` [mm] (a prismatic joint).

    Args:
        result: a :class:`Sweep`.
        path: PNG file.
        budget: optional :func:`clearance_budget` result.
        scale: unit per output kind, default ``{"m": (1e6, "um"), "rad": (1e3, "mrad")}``.
        title: figure title.

    Raises:
        ClearancePinError: matplotlib is missing (``pip install clearance_pin[plot]``).
    """
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise ClearancePinError(
            "plotting needs matplotlib: pip install clearance_pin[plot]"
        ) from None
    scale = scale or {"m": (1e6, "um"), "rad": (1e3, "mrad")}
    limits = limits or {}
    panels = len(result.outputs) + (budget is not None)
    histograms = bool(result.uniform)
    fig, axes = plt.subplots(
        panels,
        2 if histograms else 1,
        figsize=(12 if histograms else 10, (3.6 if histograms else 2.8) * panels),
        squeeze=False,
        gridspec_kw={"width_ratios": [3, 1]} if histograms else None,
    )
    for ax in axes[1:, 0]:
        ax.sharex(axes[0, 0])
    phi = result.display()
    for i, output in enumerate(result.outputs):
        ax = axes[i, 0]
        factor, unit = scale[output.unit]
        limit = limits.get(output.name)
        if limit is not None:
            for sign in (1.0, -1.0):
                ax.axhline(sign * factor * limit, color="tab:red", ls="--", lw=1,
                           label="spec limit" if sign > 0 else None)  # fmt: skip
        if histograms:
            _histogram(axes[i, 1], result, i, factor, unit, limit)
            axes[i, 1].set_ylabel(f"d{output.name} [{unit}]")
        ax.fill_between(
            phi,
            -factor * result.worst[:, i],
            factor * result.worst[:, i],
            color="tab:blue",
            alpha=0.2,
            label="worst case",
        )
        ax.plot(phi, factor * result.rss[:, i], color="tab:orange", label="RSS (3 sigma)")
        ax.plot(phi, -factor * result.rss[:, i], color="tab:orange")
        if result.uniform:
            for k, run in enumerate(result.uniform):
                pts = factor * run.points[:, i]
                ax.plot(
                    np.full(pts.shape, phi[k]),
                    pts,
                    ".",
                    color="k",
                    ms=1,
                    alpha=0.3,
                    label="Monte Carlo (uniform, exact closure)" if k == 0 else None,
                )
        if result.normal:
            three = factor * np.array([r.three_sigma[i] for r in result.normal])
            ax.plot(phi, three, "x", color="tab:red", ms=4, label="Monte Carlo 3 sigma (normal)")
            ax.plot(phi, -three, "x", color="tab:red", ms=4)
        if result.exact:
            ax.plot(
                phi,
                factor * np.array([w.upper[i] for w in result.exact]),
                "v",
                color="tab:green",
                ms=3,
                label="exact worst case",
            )
            ax.plot(
                phi,
                factor * np.array([w.lower[i] for w in result.exact]),
                "^",
                color="tab:green",
                ms=3,
            )
        ax.set_ylabel(f"d{output.name} [{unit}]")
        ax.grid(True, alpha=0.3)
        _legend(ax, histograms, last=budget is None and i == len(result.outputs) - 1)
    if budget is not None:
        ax = axes[-1, 0]
        if histograms:
            axes[-1, 1].set_visible(False)
        output = result.outputs[result.index(budget.output)]
        factor, unit = scale[output.unit]
        c = factor * budget.clearance
        ax.plot(phi, c, color="k", label="clearances (equilibrium)")
        ax.fill_between(
            phi,
            c - factor * budget.worst,
            c + factor * budget.worst,
            color="tab:blue",
            alpha=0.2,
            label="+ tolerances, worst case",
        )
        ax.plot(phi, c + factor * budget.rss, color="tab:orange", label="+ tolerances, RSS")
        ax.plot(phi, c - factor * budget.rss, color="tab:orange")
        ax.set_ylabel(f"d{budget.output} total [{unit}]")
        ax.grid(True, alpha=0.3)
        _legend(ax, histograms, last=True)
    axes[-1, 0].set_xlabel(f"{result.symbol} [{result.display_unit}]")
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=120, bbox_inches="tight")  # the legends below the panels included
    plt.close(fig)


def _legend(ax: Any, beside: bool, last: bool = False) -> None:
    """The panel's legend: right of it, or below it when a histogram takes that place (below
    the abscissa's label on the ``last`` panel)."""
    if beside:
        below = -0.3 if last else -0.16
        ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, below), ncol=3)
    else:
        ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.01, 0.5))


def _histogram(ax: Any, result: Sweep, index: int, factor: float, unit: str,
               limit: float | None) -> None:  # fmt: skip
    """The kept uniform Monte Carlo deviations of output ``index`` where its worst band is
    largest, against the worst-case and RSS bands and the spec limit (share out of spec over
    every sample there in the title)."""
    k = int(np.argmax(result.worst[:, index]))
    run = result.uniform[k]
    values = factor * run.points[:, index]
    ax.hist(values, bins=40, color="0.4", orientation="horizontal")
    worst, rss = factor * result.worst[k, index], factor * result.rss[k, index]
    for sign in (1.0, -1.0):
        ax.axhline(sign * worst, color="tab:blue", lw=1)
        ax.axhline(sign * rss, color="tab:orange", lw=1)
        if limit is not None:
            ax.axhline(sign * factor * limit, color="tab:red", ls="--", lw=1)
    title = f"at {result.symbol} = {result.display(result.phi[k]):.4g} {result.display_unit}"
    if run.beyond is not None and limit is not None:
        title += f"\n{100 * run.beyond[index] / run.samples:.3g} % out of spec"
    ax.set_title(title, fontsize=8)
    ax.set_xlabel("samples")
    ax.grid(True, alpha=0.3)
