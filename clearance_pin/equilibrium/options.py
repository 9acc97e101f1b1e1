"""The options of a solve: one frozen object, built and checked once by every entry point
(:meth:`~clearance_pin.mechanism.Mechanism.solve`, ``solve_many``, ``resolver``) and read by the
engines, so that every option works in every entry point.

An option of the wrong kind raises :class:`~clearance_pin.errors.ArgumentError` naming it, what
is expected and what was found; an unknown one names the options there are.
"""

from __future__ import annotations

import contextlib
import math
import numbers
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, fields
from typing import TypedDict

from ..arguments import is_bool as _is_bool
from ..errors import ArgumentError, ClearancePinError
from ..model.loads import Gravity
from .cone_solver import BACKENDS

TOL = 1e-12
"""The optimiser's default tolerance (dimensionless, on clearance-scaled unknowns)."""

ACCURACY = 1e-9
"""``exact="auto"``'s default accuracy [m]: the exact model runs when the estimated
exact - linear difference at an output may exceed it."""


class SolveKeywords(TypedDict, total=False):
    """The options as keywords (``mechanism.solve(loads, **options)``): see :class:`SolveOptions`."""

    exact: bool | str
    gravity: bool | Gravity | Sequence[float] | None
    tol: float
    backend: str
    accuracy: float
    warm_start: bool
    outputs: Sequence[str] | None


@dataclass(frozen=True, slots=True)
class SolveOptions:
    """The options of a solve.

    Attributes:
        exact: False: the small-displacement model [Y]; True: also the exact finite-displacement
            model (warm-started from the linear one), the linear answer in ``.linear``;
            ``"auto"``: the exact model only when the estimated exact - linear difference at an
            output (translation [m], or rotation times the mechanism's length scale) may exceed
            ``accuracy`` [m], or cannot be estimated.
        gravity: True, a :class:`~clearance_pin.model.loads.Gravity` or an acceleration (3
            numbers [m/s^2]) to add gravity, False to add none, None for the model's setting
            (:func:`~clearance_pin.model.loads.added_gravity`: a Gravity among the loads
            stands in for the model's; with True, a Gravity or an acceleration too, refused).
        tol: the optimiser's tolerance (dimensionless, on clearance-scaled unknowns).
        backend: ``"auto"`` (Clarabel when installed, else IPOPT), ``"clarabel"`` or
            ``"ipopt"`` for the small-displacement cone programme; the answer is polished and
            verified the same way whichever finds it.
        accuracy: ``exact="auto"``'s threshold [m].
        warm_start: the compiled kernel (when installed) starts from the recent answers of the
            same structure (False: from the centred position; the other engines always start
            from the nominal position); batches warm-start each case from its neighbour.
        outputs: Pinocchio frame names whose world displacement is reported in ``.outputs``
            (and compared in ``.difference``), after the loaded points; None: the leaf links.
    """

    exact: bool | str = False
    gravity: bool | Gravity | None = None
    tol: float = TOL
    backend: str = "auto"
    accuracy: float = ACCURACY
    warm_start: bool = True
    outputs: tuple[str, ...] | None = None

    @classmethod
    def of(cls, options: Mapping[str, object]) -> SolveOptions:
        """The checked options from keywords ``options`` (the defaults for those not given)."""
        if not options:
            return DEFAULT_OPTIONS
        unknown = [name for name in options if name not in NAMES]
        if unknown:
            note = "unknown option"
            if unknown[0] == "q":  # solve's configuration, given to a batch
                note += "; many configurations go to solve_many(configurations=[q, ...])"
            raise ArgumentError(
                unknown[0], f"one of the options {', '.join(NAMES)}", options[unknown[0]], note
            )
        chosen = {**_DEFAULT_VALUES, **options}
        for name in ("exact", "gravity", "warm_start"):  # NumPy's booleans as Python's
            if _is_bool(chosen[name]):
                chosen[name] = bool(chosen[name])
        gravity = chosen["gravity"]
        if not (gravity is None or _is_bool(gravity) or isinstance(gravity, Gravity)):
            with contextlib.suppress(ClearancePinError):  # else refused below, by name
                chosen["gravity"] = Gravity(gravity)  # type: ignore[arg-type]  # 3 numbers
        outputs = chosen["outputs"]
        if isinstance(outputs, Iterable) and not isinstance(outputs, (str, bytes, Mapping)):
            chosen["outputs"] = tuple(outputs)  # an iterator read once, its names checked
        check_options(**chosen)
        return cls(**chosen)  # type: ignore[arg-type]  # each checked above


NAMES = tuple(field.name for field in fields(SolveOptions))
_DEFAULT_VALUES: dict[str, object] = {field.name: field.default for field in fields(SolveOptions)}
DEFAULT_OPTIONS = SolveOptions()


def check_options(
    exact: object,
    gravity: object,
    tol: object,
    backend: object,
    accuracy: object,
    warm_start: object,
    outputs: object,
) -> None:
    """Each option of a solve is of its kind (see :class:`SolveOptions`)."""
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
        and outputs is None
    ):
        return  # the common case, decided without the checks below (a planner's re-solve)
    if not (_is_bool(exact) or (isinstance(exact, str) and exact == "auto")):
        raise ArgumentError("exact", "True, False or 'auto'", exact)
    if not (gravity is None or _is_bool(gravity) or isinstance(gravity, Gravity)):
        raise ArgumentError(
            "gravity",
            "True, False, None, a clearance_pin.Gravity or an acceleration (3 numbers) [m/s^2]",
            gravity,
        )
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
    check_outputs(outputs)


def check_outputs(outputs: object) -> None:
    """``outputs`` is None or a list (any iterable) of Pinocchio frame names; the names
    themselves are looked up by :func:`~clearance_pin.equilibrium.outputs.resolve_outputs`."""
    if outputs is None or (
        isinstance(outputs, (list, tuple)) and all(type(n) is str for n in outputs)
    ):
        return
    expected = "None or a list of Pinocchio frame names (write outputs=[name] for one)"
    if isinstance(outputs, (str, bytes, Mapping)) or not isinstance(outputs, Iterable):
        raise ArgumentError("outputs", expected, outputs)
    if isinstance(outputs, Sequence):  # not consuming an iterator
        for index, name in enumerate(outputs):
            if not isinstance(name, str):
                raise ArgumentError(f"outputs[{index}]", "a Pinocchio frame name", name)


__all__ = [
    "ACCURACY",
    "DEFAULT_OPTIONS",
    "NAMES",
    "SolveKeywords",
    "SolveOptions",
    "TOL",
    "check_options",
    "check_outputs",
]
