"""Loads applied to a mechanism: forces at points, torques, gravity.

All in SI and in world axes at the nominal configuration. A load acts on a *link* (a URDF link,
i.e. a Pinocchio BODY frame); its point is given in that link's frame.

The potential of the loads (docs/method.md section 2, [Y]):

.. math::  \\mathcal{V} = -\\sum (F \\cdot U_P + C \\cdot \\Theta)

with :math:`U_P` the displacement of the point of application and :math:`\\Theta` the rotation of
the loaded part.
"""

from __future__ import annotations

import functools
import inspect
import math
from dataclasses import dataclass
from typing import Any, TypeVar

import numpy as np
from numpy.typing import ArrayLike

from ..errors import ArgumentError, LoadError


def _vector3(load: str, link: str | None, name: str, value: object) -> np.ndarray:
    """``value`` as a read-only float array (3,), or a LoadError naming the ``load`` on ``link``
    (a planner builds loads in its loop: the checks are scalar Python, about 0.5 us; the label
    is written only for an error)."""
    try:
        array = np.array(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise LoadError(_label(load, link), f"{name} must be 3 numbers, got {value!r}") from exc
    if array.shape != (3,):
        array = array.reshape(-1)
        if array.shape != (3,):
            raise LoadError(_label(load, link), f"{name} must have 3 components, got {array.size}")
    x, y, z = array.tolist()
    if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(z)):
        raise LoadError(_label(load, link), f"{name} must be finite, got {array.tolist()}")
    array.setflags(write=False)
    return array


def _label(load: str, link: str | None) -> str:
    return load if link is None else f"{load} on {link!r}"


_ORIGIN_ARGUMENT = (0.0, 0.0, 0.0)  # PointForce's default point, as given
_ORIGIN = np.zeros(3)
_ORIGIN.setflags(write=False)  # shared by every force at its link's origin: read-only


_Load = TypeVar("_Load")


def _checked_arguments(cls: type[_Load]) -> type[_Load]:
    """Make the dataclass's ``__init__`` raise :class:`ArgumentError` naming the valid arguments
    (instead of Python's TypeError) for a missing, extra or unknown one, e.g. ``Torque(value=...)``."""
    init = cls.__init__
    signature = inspect.signature(init)
    valid = [name for name in signature.parameters if name != "self"]

    @functools.wraps(init)
    def checked(self: object, *args: Any, **kwargs: Any) -> None:
        try:
            init(self, *args, **kwargs)
            return
        except TypeError as raised:
            error = raised  # the arguments are looked at only when the call fails
        try:
            signature.bind(self, *args, **kwargs)
        except TypeError as exc:
            expected = f"the arguments {', '.join(valid)}"
            unknown = {k: v for k, v in kwargs.items() if k not in valid}
            if unknown:
                name = next(iter(unknown))
                raise ArgumentError(
                    f"{cls.__name__}({name}=...)", expected, unknown, "unknown keyword"
                ) from None
            raise ArgumentError(
                f"{cls.__name__}(...)", expected, (args, kwargs), str(exc)
            ) from None
        raise error

    cls.__init__ = checked  # type: ignore[method-assign]  # the class's own, wrapped
    return cls


def _check_link(kind: str, link: object) -> None:
    if not isinstance(link, str) or not link:
        raise ArgumentError(f"{kind}(link)", "a link name (a non-empty str)", link)


@_checked_arguments
@dataclass(frozen=True, init=False)
class PointForce:
    """A force [N] (world axes) applied at ``point`` [m] of ``link`` (in the link frame)."""

    link: str
    force: np.ndarray
    point: np.ndarray = _ORIGIN_ARGUMENT  # type: ignore[assignment]  # read as the origin

    def __init__(self, link: str, force: ArrayLike, point: ArrayLike = _ORIGIN_ARGUMENT) -> None:
        # the fields written directly (a frozen dataclass's own __init__ and __post_init__ cost
        # a microsecond more per load, in a planner's loop)
        if type(link) is not str or not link:
            _check_link("PointForce", link)
        fields = self.__dict__
        fields["link"] = link
        fields["force"] = _vector3("force", link, "force", force)
        fields["point"] = (
            _ORIGIN if point is _ORIGIN_ARGUMENT else _vector3("force", link, "point", point)
        )


@_checked_arguments
@dataclass(frozen=True, init=False)
class Torque:
    """A torque [N m] (world axes) applied to ``link``."""

    link: str
    torque: np.ndarray

    def __init__(self, link: str, torque: ArrayLike) -> None:
        if type(link) is not str or not link:
            _check_link("Torque", link)
        fields = self.__dict__
        fields["link"] = link
        fields["torque"] = _vector3("torque", link, "torque", torque)


_STANDARD_GRAVITY = (0.0, 0.0, -9.81)


@_checked_arguments
@dataclass(frozen=True, init=False)
class Gravity:
    """Gravity acting on every body's URDF inertial: acceleration [m/s^2] in world axes."""

    acceleration: np.ndarray

    def __init__(self, acceleration: ArrayLike = _STANDARD_GRAVITY) -> None:
        self.__dict__["acceleration"] = _vector3("gravity", None, "acceleration", acceleration)


Load = PointForce | Torque | Gravity


def added_gravity(
    own: int, option: bool | Gravity | None, model_gravity: Gravity | None
) -> Gravity | None:
    """The gravity a solve adds to its loads, of which ``own`` are Gravity loads: one gravity
    per solve. ``option`` (a solve's ``gravity=``): True the model's (standard gravity when the
    model has none), a Gravity that one, False none, None the model's setting
    (``model_gravity``). A Gravity among the loads stands in for the model's setting; given
    with True or a Gravity too, or twice among the loads, it is refused: the two would add up,
    a second weight no mechanism has.

    Raises:
        ArgumentError: naming ``gravity`` (or ``loads``) and the conflict.
    """
    if own > 1:
        raise ArgumentError("loads", "at most one Gravity", f"{own} Gravity loads")
    if option is False:
        return None
    if own:
        if option is None:
            return None
        raise ArgumentError(
            "gravity",
            "no gravity option when the loads hold a Gravity (one gravity per solve: leave "
            "gravity= out, or the Gravity out of the loads)",
            option,
        )
    if option is True:
        return model_gravity or Gravity()
    return model_gravity if option is None else option


def with_vector(load: PointForce | Torque, vector: np.ndarray) -> PointForce | Torque:
    """``load`` with its force (PointForce) or torque (Torque) replaced by ``vector`` [N, N m],
    a float array (3,) that the caller has checked is finite (a planner's re-solve: the checks
    and argument binding of the constructor cost microseconds each time)."""
    value = np.array(vector, dtype=float)
    value.setflags(write=False)
    copy = object.__new__(type(load))
    copy.__dict__.update(load.__dict__)
    copy.__dict__["force" if isinstance(load, PointForce) else "torque"] = value
    return copy
