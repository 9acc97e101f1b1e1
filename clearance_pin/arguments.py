"""Checks of the arguments of :meth:`Mechanism.solve` and :meth:`Mechanism.solve_many`.

An argument of the wrong kind raises :class:`~clearance_pin.errors.ArgumentError` naming it, what
is expected and what was found, before anything is built or solved (a mistyped backend is not a
numerical failure). A nominal configuration outside the URDF limits is accepted with a
:class:`~clearance_pin.errors.SuspectValueWarning` (:mod:`clearance_pin.model.plausibility`).

Magnitudes are refused where double precision cannot carry them: a load (force [N], torque
[N m], moment of a force about its link's origin [N m], gravity [m/s^2]) or a point [m] is
squared on the way (norms, the cone programme's constraints), and squares leave the normal range
of doubles beyond about 1e154 and below about 1e-154 (2.2e-308 is the smallest normal double).
:data:`LARGEST_MAGNITUDE` and :data:`SMALLEST_LOAD` keep a margin of four decades; below the
latter a load was solved as no load (no contact) before, without a word.
"""

from __future__ import annotations

import math
import numbers
import os
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .errors import ArgumentError, LoadError, ModelError
from .model import plausibility
from .model.loads import Gravity, PointForce, Torque, added_gravity
from .numerics import LARGEST_MAGNITUDE

if TYPE_CHECKING:
    from .model.mechanism_parts import MechanismParts as Mechanism

LOAD_TYPES = (PointForce, Torque, Gravity)

#: the smallest load [N, N m, m/s^2] taken, unless it is exactly zero (module docstring)
SMALLEST_LOAD = 1e-150
#: a joint's play is refused above this many times the mechanism's size (check_clearance_sizes)
LARGEST_PLAY = 10.0
#: ``tolerance --positions``: at most this many positions (about 10 ms each on a slider-crank
#: with the default 10000 Monte Carlo samples: 100 s)
MOST_POSITIONS = 10_000
#: ``tolerance --samples``: at most this many Monte Carlo samples per position and law (a
#: million take about a second and some hundred MB on a slider-crank)
MOST_SAMPLES = 1_000_000
#: ``accuracy --poses``: at most this many random poses (about 0.4 ms each on the 6R arm with
#: one payload: some 7 minutes; beyond, the pose arrays alone outgrow memory: 1e11 poses asked
#: NumPy for 4.37 TiB)
MOST_POSES = 1_000_000


def is_bool(value: object) -> bool:
    return isinstance(value, (bool, np.bool_))


def check_loads(loads: object, argument: str = "loads") -> None:
    """``loads`` is None or a list (any iterable) of loads, not a single load nor a text."""
    if loads is None or type(loads) in (list, tuple):
        return
    if isinstance(loads, LOAD_TYPES):
        raise ArgumentError(
            argument,
            f"a list of PointForce, Torque or Gravity (write {argument}=[load] for one load)",
            loads,
        )
    if isinstance(loads, (str, bytes, dict)) or not isinstance(loads, Iterable):
        raise ArgumentError(argument, "a list of PointForce, Torque or Gravity", loads)


def check_configuration(
    mechanism: Mechanism, q: object, argument: str = "q", warn: bool = True
) -> np.ndarray | None:
    """``q`` as a float array (nq,), or None; warns when a value is outside the URDF limits.

    Raises:
        ArgumentError: ``q`` holds text, has the wrong shape or a non-finite value.
    """
    if q is None:
        return None
    nq = mechanism.model.nq
    expected = f"{nq} finite numbers [rad, m] (a Pinocchio configuration, shape ({nq},))"
    try:
        array = np.asarray(q)
    except (TypeError, ValueError):
        raise ArgumentError(argument, expected, q, "not an array of numbers") from None
    if array.dtype.kind not in "iuf":  # text ("60"), bools, objects, ragged lists
        note = "text, not numbers" if array.dtype.kind in "US" else f"array of {array.dtype}"
        raise ArgumentError(argument, expected, q, note)
    array = array.astype(float)
    if array.shape != (nq,):
        raise ArgumentError(argument, expected, q, f"shape {array.shape}")
    if not np.all(np.isfinite(array)):
        raise ArgumentError(argument, expected, q, "not finite")
    if warn:
        # stacklevel 5: the caller of Mechanism.solve (check_case and this function between)
        values = plausibility.configuration_values(mechanism.model, array)
        plausibility.warn_nominal_values(
            mechanism, values, source=f"{mechanism.source}: {argument}", stacklevel=5
        )
    return array


def check_case(mechanism: Mechanism, loads: object, q: object) -> np.ndarray | None:
    """The loads and configuration of a solve (its options are checked by
    :meth:`~clearance_pin.equilibrium.options.SolveOptions.of`); returns ``q`` as an array (or
    None)."""
    check_loads(loads)
    return check_configuration(mechanism, q)


def check_load_magnitudes(loads: Iterable[object], argument: str = "loads") -> None:
    """The loads' magnitudes are within what double precision carries (module docstring):
    every force, torque, moment about the link origin |p x F| and gravity at most
    :data:`LARGEST_MAGNITUDE`, every point coordinate too, and the largest of them, unless all
    are zero, at least :data:`SMALLEST_LOAD` (the equilibrium pose does not depend on the loads'
    common scale: multiplying them all by one factor gives the same pose).

    Raises:
        LoadError: naming the load and its magnitude.
    """
    largest, largest_load, largest_unit = 0.0, None, ""
    for load in loads:  # the labels are written only for an error (this runs on every solve)
        if isinstance(load, PointForce):
            point = _largest(load.point)
            if point > LARGEST_MAGNITUDE:
                raise LoadError(_load_label(load, argument), _too_large("point", point, "m"))
            force = _largest(load.force)
            magnitude, unit = force, "N"
            if force * point > force:  # a point farther than 1 m: its moment is the larger
                magnitude, unit = force * point, "N m (the moment |p x F| about the link origin)"
        elif isinstance(load, Torque):
            magnitude, unit = _largest(load.torque), "N m"
        elif isinstance(load, Gravity):
            magnitude, unit = _largest(load.acceleration), "m/s^2"
        else:
            continue  # not a load: refused, naming it, by Mechanism.resolve_loads
        if magnitude > LARGEST_MAGNITUDE:
            raise LoadError(_load_label(load, argument), _too_large("magnitude", magnitude, unit))
        if magnitude > largest:
            largest, largest_load, largest_unit = magnitude, load, unit
    if 0.0 < largest < SMALLEST_LOAD:
        raise LoadError(
            _load_label(largest_load, argument),
            f"the largest load is {largest:.3g} {largest_unit}, below the smallest taken, "
            f"{SMALLEST_LOAD:.0e} (double precision loses its square); the settled pose does not depend "
            "on the loads' common scale: multiply them all by one factor",
        )


def _load_label(load: object, argument: str) -> str:
    """How an error names a load: "force on 'link'", "torque on 'link'" or "gravity", with
    " in <argument>" unless the argument is ``loads``."""
    where = "" if argument == "loads" else f" in {argument}"
    if isinstance(load, PointForce):
        return f"force on {load.link!r}{where}"
    if isinstance(load, Torque):
        return f"torque on {load.link!r}{where}"
    return f"gravity{where}"


def _check_case_magnitudes(
    cases: Sequence[object], refuse: bool, added: Gravity | None
) -> dict[int, LoadError]:
    """:func:`check_load_magnitudes` of every load case that is a list or tuple, in bulk: the
    largest |component| of all forces, torques, points and gravities, and of each case, found by
    a few array reductions (about 0.2 us per load against 2 us one by one); only when one of them
    is beyond the limits is each case checked by itself, to name the load. ``added``: the
    gravity the solve adds to a case without its own (its weight counts among the loads, as in
    a single solve). ``refuse``: the first such error raised, else returned with the others per
    case (``errors="return"``)."""
    listed = [(index, case) for index, case in enumerate(cases) if type(case) in (list, tuple)]
    vectors: list[np.ndarray] = []
    owners: list[int] = []  # per vector, its case; -1 for a point (not a load's magnitude)
    weighed = np.zeros(len(cases), dtype=bool)  # the cases with their own gravity
    for index, case in listed:
        for load in case:  # type: ignore[attr-defined]  # a list or tuple
            if isinstance(load, PointForce):
                vectors += (load.force, load.point)
                owners += (index, -1)
            elif isinstance(load, Torque):
                vectors.append(load.torque)
                owners.append(index)
            elif isinstance(load, Gravity):
                vectors.append(load.acceleration)
                owners.append(index)
                weighed[index] = True
    if not vectors:
        return {}
    largest = np.abs(np.array(vectors)).max(axis=1)
    owner = np.array(owners)
    per_case = np.zeros(len(cases))
    np.maximum.at(per_case, owner[owner >= 0], largest[owner >= 0])
    if added is not None:
        per_case[~weighed] = np.maximum(per_case[~weighed], np.abs(added.acceleration).max())
    smallest_case = per_case[per_case > 0.0].min(initial=np.inf)
    # a point beyond 1 m multiplies its force's magnitude: the product of the largest point and
    # the largest force bounds every moment
    # (compared with the square root: the square of a value beyond it overflows)
    if largest.max() <= math.sqrt(LARGEST_MAGNITUDE) and smallest_case >= SMALLEST_LOAD:
        return {}
    refused = {}
    for index, case in listed:
        loads: tuple[object, ...] = tuple(case)  # type: ignore[arg-type]  # a list or tuple
        with_gravity = loads if weighed[index] or added is None else (*loads, added)
        try:
            check_load_magnitudes(with_gravity, f"loads[{index}]")
        except LoadError as error:
            if refuse:
                raise
            refused[index] = error
    return refused


def _largest(vector: np.ndarray) -> float:
    """The largest absolute component of a 3-vector (a Python max: about 0.5 us, a third of
    NumPy's on 3 values; this runs on every solve)."""
    return float(max(map(abs, vector.tolist())))


def _too_large(what: str, value: float, unit: str) -> str:
    return (
        f"{what} {value:.3g} {unit} is beyond the largest taken, {LARGEST_MAGNITUDE:.0e} "
        "(its square overflows double precision)"
    )


def check_point(argument: str, point: np.ndarray, given: object) -> None:
    """A point [m] (an output point, a load's point) within :data:`LARGEST_MAGNITUDE`."""
    largest = float(np.max(np.abs(point), initial=0.0))
    if largest > LARGEST_MAGNITUDE:
        raise ArgumentError(
            argument,
            f"a point of 3 finite numbers [m] within {LARGEST_MAGNITUDE:.0e} m",
            given,
            "its square overflows double precision",
        )


def check_count(argument: str, value: object, lowest: int, highest: int | None = None) -> int:
    """An integer option in ``[lowest, highest]`` (``--positions``, ``--samples``, ``chunks``)."""
    if (
        is_bool(value)
        or not isinstance(value, numbers.Integral)
        or int(value) < lowest
        or (highest is not None and int(value) > highest)
    ):
        expected = f"an integer >= {lowest}"
        if highest is not None:
            expected = f"an integer from {lowest} to {highest}"
        raise ArgumentError(argument, expected, value)
    return int(value)


def check_seed(argument: str, value: object) -> int:
    """A random seed: an integer >= 0 (NumPy's SeedSequence refuses negative ones)."""
    if is_bool(value) or not isinstance(value, numbers.Integral) or int(value) < 0:
        raise ArgumentError(argument, "an integer >= 0", value)
    return int(value)


def check_errors(errors: object) -> None:
    """``errors`` of a batch: ``"raise"`` or ``"return"``."""
    if not (isinstance(errors, str) and errors in ("raise", "return")):
        raise ArgumentError("errors", "'raise' or 'return'", errors)


def check_executor(executor: object) -> None:
    """``executor`` is None or a ``concurrent.futures.Executor`` (anything with ``submit``, as
    Dask's ``client.get_executor()``)."""
    if executor is not None and not callable(getattr(executor, "submit", None)):
        raise ArgumentError(
            "executor",
            "None or a concurrent.futures.Executor (an object with a submit method)",
            executor,
        )


def check_solve_many(
    mechanism: Mechanism,
    loads: object,
    configurations: object,
    errors: object,
    executor: object,
    chunks: object,
    gravity: bool | Gravity | None = None,
) -> dict[int, LoadError]:
    """The arguments of :meth:`Mechanism.solve_many` but its solve options (checked by
    :meth:`~clearance_pin.equilibrium.options.SolveOptions.of`; ``gravity`` its checked
    option), before any case is solved (so that ``errors="return"`` does not turn a mistyped
    argument into one error per case).

    Returns:
        with ``errors="return"``, the LoadError of each case whose load magnitudes are beyond
        what double precision carries (:func:`check_load_magnitudes`), by case: those cases
        are not solved, their errors take their places (with ``"raise"`` the first is raised).
    """
    check_errors(errors)
    refused: dict[int, LoadError] = {}
    check_executor(executor)
    if chunks is not None:
        check_count("chunks", chunks, 1)
    if loads is not None:
        if isinstance(loads, (*LOAD_TYPES, str, bytes, dict)) or not isinstance(loads, Iterable):
            raise ArgumentError("loads", "a list of load cases (each a list of loads)", loads)
        if isinstance(loads, Sequence):  # not consuming an iterator
            plain = (list, tuple, type(None))  # a case of these needs no closer look
            for index, case in enumerate(loads):
                if type(case) in plain:
                    continue
                if isinstance(case, LOAD_TYPES):
                    raise ArgumentError(
                        f"loads[{index}]",
                        "a load case: a list of PointForce, Torque or Gravity (solve_many takes "
                        "a list of cases; one case is [[load, ...]])",
                        case,
                    )
                check_loads(case, f"loads[{index}]")
            own = added_gravity(0, gravity, mechanism.gravity)  # a case without its own
            refused = _check_case_magnitudes(loads, errors == "raise", own)
    if loads is None:
        check_load_magnitudes((*mechanism.loads, mechanism.gravity), "the model's loads")
    if configurations is not None:
        check_configurations(mechanism, configurations)
    return refused


def check_configurations(mechanism: Mechanism, configurations: object) -> list[np.ndarray | None]:
    """A list of configurations (Q, nq) [rad, m] of :meth:`Mechanism.solve_many` or
    ``resolver.solve_many``, each checked (:func:`check_configuration`; None: the nominal one);
    one configuration (nq,) given alone is refused naming the shape expected. Values outside
    the joints' limits or beyond a turn give one :class:`~clearance_pin.errors.SuspectValueWarning`
    for the whole list: how many configurations, the first one and its joint."""
    nq = mechanism.model.nq
    expected = f"a list of configurations q, shape (Q, {nq})"
    if isinstance(configurations, (str, bytes)) or not isinstance(configurations, Iterable):
        raise ArgumentError("configurations", expected, configurations)
    if not isinstance(configurations, (Sequence, np.ndarray)):  # an iterator: read once
        configurations = list(configurations)
    shape = np.shape(configurations) if _numeric(configurations) else None
    if shape is not None and len(shape) == 1:
        raise ArgumentError(
            "configurations", expected, configurations,
            f"shape {shape}: one configuration; write [q] for one",
        )  # fmt: skip
    checked = [
        check_configuration(mechanism, q, f"configurations[{index}]", warn=False)
        for index, q in enumerate(configurations)
    ]
    given = [q for q in checked if q is not None]
    if given:
        plausibility.warn_configurations(mechanism, np.asarray(given), stacklevel=4)
    return checked


def _numeric(values: object) -> bool:
    try:
        return np.asarray(values).dtype.kind in "iuf"
    except (TypeError, ValueError):  # ragged
        return False


def check_clearance_sizes(mechanism: Mechanism) -> None:
    """Every joint's plays (radial, axial, play_z [m]) are at most :data:`LARGEST_PLAY` times
    the whole mechanism (:meth:`Mechanism.length_scale`), and its lengths (journal, block width
    and height [m]) within :data:`LARGEST_MAGNITUDE`.

    A play above 5 % of its part is warned (:mod:`clearance_pin.model.plausibility`); one many
    times the whole mechanism is refused: the small-displacement model means nothing there, and
    the solver's scaling by the plays breaks down (pin_A of the 0.137 m slider-crank with a 10 m
    play, the others 50 um, was reported as an unblocked motion; 3 m still solved; 1e308 m was an
    IndexError).

    Raises:
        ModelError: naming the joint's element, the value and the bound.
    """
    for joint in mechanism.joints.values():
        clearance = joint.clearance
        tag = "joint" if hasattr(joint, "joint_id") else "loop_joint"
        element = f"<{tag} name='{joint.name}'>"
        for name in ("length", "width", "height"):
            value = float(getattr(clearance, name))
            if value > LARGEST_MAGNITUDE:
                raise ModelError(mechanism.source, element, _too_large(name, value, "m"))
        play = float(clearance.max_play)
        if play > 0.0 and play > LARGEST_PLAY * mechanism.length_scale():
            raise ModelError(
                mechanism.source,
                element,
                f"clearance {play:.6g} m is more than {LARGEST_PLAY:g} times the whole mechanism "
                f"({mechanism.length_scale():.6g} m: its farthest joint from the root or its "
                "longest journal); clearances are in metres: 50 um is 5e-05",
            )


#: the file types a plot is written in (matplotlib's, by the file name's extension)
PLOT_FORMATS = ("png", "pdf", "svg", "svgz", "eps", "ps", "jpg", "jpeg", "tif", "tiff", "webp")


def check_not_an_input(option: str, path: Path, inputs: Mapping[str, Path | None]) -> None:
    """A file to write that is none of the command's input files (``envelope m.urdf --json
    m.urdf`` overwrote the model): their resolved paths compared, and the files themselves
    when both exist (a hard or symbolic link to the model). ``inputs``: what each input is
    (``"the model file"``) -> its path, or None when not given."""
    for what, given in inputs.items():
        if given is None:
            continue
        same = path.resolve() == given.resolve()
        if not same and path.exists() and given.exists():
            try:
                same = os.path.samefile(path, given)
            except OSError:
                same = False
        if same:
            raise ArgumentError(
                option,
                "a file other than the inputs",
                str(path),
                f"it is {what}: it would be overwritten",
            )


def check_output_file(option: str, path: Path, formats: Sequence[str] = ()) -> None:
    """A file to write (``--plot``, ``--json``): in an existing folder, not a folder itself, and
    of one of ``formats`` by its extension when they are given; checked before any work."""
    folder = path.parent
    if not folder.is_dir():
        raise ArgumentError(
            option, "a file in an existing folder", str(path), f"no folder {folder}"
        )
    if path.is_dir():
        raise ArgumentError(option, "a file to write", str(path), "a folder")
    if formats and path.suffix.lower().lstrip(".") not in formats:
        raise ArgumentError(
            option,
            f"a file name ending in one of .{', .'.join(formats)}",
            str(path),
            "unknown file type",
        )
