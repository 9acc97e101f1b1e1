"""Checks of the arguments of :meth:`Mechanism.solve` and :meth:`Mechanism.solve_many`.

An argument of the wrong kind raises :class:`~clearance_pin.errors.ArgumentError` naming it, what
is expected and what was found, before anything is built or solved (a mistyped backend is not a
numerical failure). A nominal configuration outside the URDF limits is accepted with a
:class:`~clearance_pin.errors.SuspectValueWarning` (:mod:`clearance_pin.model.plausibility`).
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Iterable, Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np

from .equilibrium.cone_solver import BACKENDS
from .errors import ArgumentError
from .model import plausibility
from .model.loads import Gravity, PointForce, Torque

if TYPE_CHECKING:
    from .mechanism import Mechanism

LOAD_TYPES = (PointForce, Torque, Gravity)


def _is_bool(value: object) -> bool:
    return isinstance(value, (bool, np.bool_))


def check_options(
    exact: object,
    gravity: object,
    tol: object,
    backend: object,
    accuracy: object = 1e-9,
    warm_start: object = True,
) -> None:
    """The scalar options of a solve (see :meth:`Mechanism.solve` for their meaning)."""
    if (
        (exact is False or exact is True)
        and gravity is None
        and type(tol) is float
        and type(accuracy) is float
        and 0.0 < tol < math.inf
        and 0.0 < accuracy < math.inf
        and type(backend) is str
        and backend in BACKENDS
        and (warm_start is True or warm_start is False)
    ):
        return  # the common case, decided without the checks below (a planner's re-solve)
    if not (_is_bool(exact) or (isinstance(exact, str) and exact == "auto")):
        raise ArgumentError("exact", "True, False or 'auto'", exact)
    if not (gravity is None or _is_bool(gravity) or isinstance(gravity, Gravity)):
        raise ArgumentError("gravity", "True, False, None or a clearance_pin.Gravity", gravity)
    for name, value in (("tol", tol), ("accuracy", accuracy)):
        if (
            _is_bool(value)
            or not isinstance(value, numbers.Real)
            or not (math.isfinite(value) and float(value) > 0.0)
        ):
            raise ArgumentError(name, "a finite number > 0", value)
    if not (isinstance(backend, str) and backend in BACKENDS):
        raise ArgumentError("backend", f"one of {', '.join(map(repr, BACKENDS))}", backend)
    if not _is_bool(warm_start):
        raise ArgumentError("warm_start", "True or False", warm_start)


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
        # stacklevel 5: the caller of Mechanism.solve (check_solve and this function between)
        values = plausibility.configuration_values(mechanism.model, array)
        plausibility.warn_nominal_values(
            mechanism, values, source=f"{mechanism.source}: {argument}", stacklevel=5
        )
    return array


def check_solve(
    mechanism: Mechanism,
    loads: object,
    exact: object,
    q: object,
    gravity: object,
    tol: object,
    backend: object,
    accuracy: object,
    warm_start: object,
) -> np.ndarray | None:
    """Every argument of :meth:`Mechanism.solve`; returns ``q`` as an array (or None)."""
    check_options(exact, gravity, tol, backend, accuracy, warm_start)
    check_loads(loads)
    return check_configuration(mechanism, q)


def check_solve_many(
    mechanism: Mechanism, loads: object, configurations: object, options: Mapping[str, object]
) -> None:
    """The arguments of :meth:`Mechanism.solve_many`, before any case is solved (so that
    ``errors="return"`` does not turn a mistyped option into one error per case)."""
    check_options(
        options.get("exact", False),
        options.get("gravity"),
        options.get("tol", 1e-12),
        options.get("backend", "auto"),
    )
    errors = options.get("errors", "raise")
    if not (isinstance(errors, str) and errors in ("raise", "return")):
        raise ArgumentError("errors", "'raise' or 'return'", errors)
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
    if configurations is not None:
        if isinstance(configurations, (str, bytes)) or not isinstance(configurations, Iterable):
            raise ArgumentError(
                "configurations", "a list of configurations q, each (nq,)", configurations
            )
        if isinstance(configurations, (Sequence, np.ndarray)):  # not consuming an iterator
            for index, q in enumerate(configurations):
                check_configuration(mechanism, q, f"configurations[{index}]", warn=False)
