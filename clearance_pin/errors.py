"""Exceptions of clearance_pin.

Every error the library raises on purpose derives from :class:`ClearancePinError` and carries its
data as attributes, so that callers (scripts, planners, tests) can act on them without parsing text.
Errors of Pinocchio, CasADi or coal are caught at the library's edge and re-raised as one of these.
Every warning it gives derives from :class:`ClearancePinWarning` (itself a ``UserWarning``), so that
``warnings.simplefilter("error", ClearancePinWarning)`` turns them all into errors.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any, Self


class ClearancePinError(Exception):
    """Base class of every error raised by clearance_pin."""


class ModelError(ClearancePinError, ValueError):
    """A model description is invalid.

    Attributes:
        source: file path (or ``"<api>"`` when built from Python).
        element: the offending element, e.g. ``"<clearance joint='I2'>"``.
        problem: what is wrong, with the expected and the found value.
    """

    def __init__(self, source: str, element: str, problem: str) -> None:
        self.source = source
        self.element = element
        self.problem = problem
        super().__init__(f"{source}: {element}: {problem}")

    def __reduce__(self) -> tuple[type[Self], tuple[Any, ...]]:
        return (type(self), (self.source, self.element, self.problem))


class ArgumentError(ClearancePinError, ValueError):
    """An argument of a library call has the wrong kind or value.

    Attributes:
        argument: the argument, e.g. ``"gravity"`` or ``"configurations[3]"``.
        expected: what it must be, e.g. ``"True, False, None or a clearance_pin.Gravity"``.
        found: the value given.
        note: what is wrong with it, when its repr does not say (e.g. its shape), or None.
    """

    def __init__(
        self, argument: str, expected: str, found: object, note: str | None = None
    ) -> None:
        self.argument = argument
        self.expected = expected
        self.found = found
        self.note = note
        detail = f" ({note})" if note else ""
        super().__init__(f"{argument}: expected {expected}, found {_short_repr(found)}{detail}")

    def __reduce__(self) -> tuple[type[Self], tuple[Any, ...]]:
        return (type(self), (self.argument, self.expected, self.found, self.note))


def _short_repr(value: object, limit: int = 80) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


class MeasurementError(ClearancePinError, ValueError):
    """A measurement file (``clearance-pin identify --measurements``) is invalid.

    Attributes:
        source: the file (or ``"<api>"`` for arrays given in Python).
        row: its line number (1 = the header), or None for the file as a whole.
        column: the column's name, or None for the row as a whole.
        problem: what is wrong, with the value found and the value expected.
    """

    def __init__(self, source: str, row: int | None, column: str | None, problem: str) -> None:
        self.source = source
        self.row = row
        self.column = column
        self.problem = problem
        where = [f"line {row}"] if row is not None else []
        where += [f"column {column!r}"] if column is not None else []
        place = f"{', '.join(where)}: " if where else ""
        super().__init__(f"{source}: {place}{problem}")

    def __reduce__(self) -> tuple[type[Self], tuple[Any, ...]]:
        return (type(self), (self.source, self.row, self.column, self.problem))


class CaseIndexError(ClearancePinError, IndexError):
    """A case index beyond a batch (also an ``IndexError``: a batch is a sequence, iterated
    until its first index out of range)."""


class NotFoundError(ClearancePinError, KeyError):
    """A name that is looked up does not exist (a joint, frame, link, output, dimension...).

    Also a ``KeyError``, so that ``except KeyError`` around a look-up keeps working.

    Attributes:
        kind: what was looked up, e.g. ``"joint"``, ``"frame"``, ``"output"``, ``"dimension"``.
        name: the name given.
        valid: the valid names (a tuple, in the order they are listed).
        where: where the look-up was made (the model file, the argument, the output spec), or
            None.
        hint: what else would be accepted, when the valid names do not say it all, or None.
    """

    def __init__(
        self,
        kind: str,
        name: object,
        valid: Iterable[object],
        where: str | None = None,
        hint: str | None = None,
    ) -> None:
        self.kind = kind
        self.name = name
        # each name once (a URDF's link and joint of one name are two frames of that name)
        self.valid = tuple(dict.fromkeys(valid))
        self.where = where
        self.hint = hint
        listed = ", ".join(map(str, self.valid)) if self.valid else "(none)"
        prefix = f"{where}: " if where else ""
        detail = f"; {hint}" if hint else ""
        super().__init__(
            f"{prefix}unknown {kind} {_short_repr(name)}; the {_plural(kind)} are: {listed}{detail}"
        )

    def __str__(self) -> str:  # KeyError's own str() would quote the message
        return str(self.args[0])

    def __reduce__(self) -> tuple[type[Self], tuple[Any, ...]]:
        return (type(self), (self.kind, self.name, self.valid, self.where, self.hint))


def _plural(kind: str) -> str:
    return kind if kind.endswith("s") else kind + "s"


class LoadError(ClearancePinError, ValueError):
    """A load is invalid (unknown link, non-finite value, wrong shape)."""

    def __init__(self, load: str, problem: str) -> None:
        self.load = load
        self.problem = problem
        super().__init__(f"load {load}: {problem}")

    def __reduce__(self) -> tuple[type[Self], tuple[Any, ...]]:
        return (type(self), (self.load, self.problem))


def motions_listed_once(motions: Iterable[str]) -> str:
    """The joint components that motions move, each named once, in the order of their first
    mention. A motion is described as ``joint 'a' alpha (spin ...); joint 'b' u (...); and 3
    smaller components (under 20 % of the largest)`` (or given as the list of those parts); the
    free motions of one mechanism share their joints (nine motions of six joints named the same
    components nine times, in 4188 characters), so their components are merged and the smaller
    ones said once."""
    named: dict[str, None] = {}
    smaller: dict[str, None] = {}
    for motion in motions:
        for part in motion.split("; "):
            if part.startswith("and ") and "smaller component" in part:
                smaller.setdefault(part)
            else:
                named.setdefault(part)
    parts = list(named)
    if len(smaller) == 1:
        parts.extend(smaller)
    elif smaller:
        parts.append("and smaller components (under 20 % of the largest)")
    return "; ".join(parts)


class UnboundedLoadError(ClearancePinError):
    """The load drives a motion that nothing blocks: no equilibrium exists.

    Attributes:
        motions: human-readable descriptions of the unblocked motion(s), largest first.
        fraction: share of the (scaled) load that works along the unblocked motion, in [0, 1].
        where: where the load works along them, when not in the linear model (the exact
            model's solved pose), or None.
    """

    def __init__(self, motions: list[str], fraction: float, where: str | None = None) -> None:
        self.motions = motions
        self.fraction = fraction
        self.where = where
        listed = motions_listed_once(motions)
        at = f", {where}" if where else ""
        super().__init__(
            "no equilibrium: the load has a component along a motion that no clearance or joint "
            f"blocks ({fraction:.3g} of the load{at}): {listed}. Lock (drive) that joint, add "
            "the missing joint, or remove that load component."
        )

    def __reduce__(self) -> tuple[type[Self], tuple[Any, ...]]:
        return (type(self), (self.motions, self.fraction, self.where))


class SingularPositionError(UnboundedLoadError):
    """The mechanism is at a singular position of its loop closure (a toggle or dead centre):
    the load works along a motion that the parts block only at second order, which the
    small-displacement model cannot see, so it has no equilibrium there. A subclass of
    :class:`UnboundedLoadError` (same attributes), named for what it is: not a missing joint.
    """

    def __init__(self, motions: list[str], fraction: float, where: str | None = None) -> None:
        self.motions = motions
        self.fraction = fraction
        self.where = where
        listed = motions_listed_once(motions)
        ClearancePinError.__init__(
            self,
            "singular position: the loop closure is singular at this configuration (a toggle or "
            "dead-centre position), and the load works along a motion that the parts block only "
            f"at second order ({fraction:.3g} of the load): {listed}. The small-displacement "
            "model cannot see that: move the driven joints away from it (q) and solve there with "
            "exact=True (near it the small-displacement answer loses digits as 1 / closure "
            "conditioning).",
        )


class SolverError(ClearancePinError):
    """The optimiser failed, or its answer failed our own checks.

    Attributes:
        status: the solver's status string.
        residuals: dict (a copy) of the residuals we measured (feasibility [m], stationarity, ...).
        answer: the unverified answer (the :class:`~clearance_pin.Equilibrium` that failed
            verification), to inspect or use at one's own risk; None when there is none.
    """

    def __init__(
        self,
        message: str,
        status: str,
        residuals: Mapping[str, float] | None = None,
        answer: Any = None,
    ) -> None:
        self.message = message
        self.status = status
        self.residuals = dict(residuals or {})
        self.answer = answer
        detail = ", ".join(f"{k}={v:.3g}" for k, v in self.residuals.items())
        super().__init__(f"{message} (status: {status}{'; ' + detail if detail else ''})")

    def __reduce__(self) -> tuple[type[Self], tuple[Any, ...]]:
        return (type(self), (self.message, self.status, self.residuals, self.answer))


class NearSingularError(SolverError):
    """No verified small-displacement answer near a singular position of the loop closure (a
    toggle or dead centre): there the linear model would turn joints by more than it can
    represent (rotations << 1 rad) and its contact forces grow as 1 / conditioning, so its
    optimum is neither reachable to the verification tolerances nor meaningful.
    ``Mechanism.solve(exact=True)`` answers there (the exact model then starts from the nominal
    position). A subclass of :class:`SolverError` (same attributes)."""


class UnsupportedError(ClearancePinError, NotImplementedError):
    """A feature combination that clearance_pin does not handle (named in the message)."""


class ClearancePinWarning(UserWarning):
    """Base class of every warning given by clearance_pin."""


class SuspectValueWarning(ClearancePinWarning):
    """A value that is valid but unlikely to be meant, most often a unit mistake (a clearance in
    mm, an angle in degrees, a tolerance as wide as its size): the element and the numbers are in
    the message. The thresholds are in :mod:`clearance_pin.model.plausibility`."""


class ConditioningWarning(ClearancePinWarning):
    """The loop closure is nearly singular (a toggle or dead-centre position): the
    small-displacement answer loses accuracy roughly as 1 / conditioning."""


class HeldMotionWarning(ClearancePinWarning):
    """The exact model's answer holds a motion the small-displacement model leaves free (a
    shaft's spin, a slide; held where the linear answer puts it, as whatever drives it would)
    with more of the load than the model's second-order size (the largest play over the part
    size): the answer then depends on what holds that motion, not only on the contacts. The
    motions, the force or torque holding each and its share of the load are in the message
    (docs/method.md section 4)."""


class StiffnessLeftOutWarning(ClearancePinWarning):
    """An analysis of the play alone (the envelope, the accuracy map) on a mechanism whose joints
    have stiffness: their elastic deflection is not in its figures (the joints are named)."""


class KernelUnavailableWarning(ClearancePinWarning):
    """The compiled kernel (numba) could not be loaded, most often because numba's cache is not
    writable (a read-only install: set ``NUMBA_CACHE_DIR`` to a writable folder): the solves go
    the NumPy way, slower per re-solve, with the same answers. Given once per process."""
