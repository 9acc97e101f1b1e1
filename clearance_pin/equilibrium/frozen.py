"""Instances of the frozen answer dataclasses without their generated ``__init__``.

A planner re-solves thousands of times; the generated ``__init__`` of a frozen dataclass sets each
field through ``object.__setattr__`` (about 6 us for the 23 fields of an
:class:`~.result.Equilibrium`), filling the instance's ``__dict__`` directly costs a tenth of that.
Only for dataclasses without ``__post_init__``, ``__slots__`` or field converters (checked).
"""

from __future__ import annotations

import dataclasses
from typing import Any, TypeVar

from ..errors import ClearancePinError

T = TypeVar("T")
_DEFAULTS: dict[type, tuple[dict[str, Any], frozenset[str]]] = {}


def frozen_instance(cls: type[T], values: dict[str, Any]) -> T:
    """``cls(**values)``, the fields not in ``values`` at their defaults; a missing field without
    a default or an unknown name raises ClearancePinError (a programming error, as the generated
    ``__init__``'s TypeError)."""
    known = _DEFAULTS.get(cls)
    if known is None:
        known = _DEFAULTS[cls] = _defaults(cls)
    defaults, required = known
    if not required <= values.keys() <= defaults.keys():
        unknown = sorted(set(values) - set(defaults))
        raise ClearancePinError(
            f"{cls.__name__}: unknown {unknown}, missing {sorted(required - set(values))}"
        )
    instance = object.__new__(cls)
    state = instance.__dict__
    state.update(defaults)
    state.update(values)
    return instance


def _defaults(cls: type) -> tuple[dict[str, Any], frozenset[str]]:
    """(every field's default, MISSING where it has none; the names of those without)."""
    if hasattr(cls, "__post_init__") or "__slots__" in cls.__dict__:
        raise ClearancePinError(f"{cls.__name__} needs its own __init__")
    defaults: dict[str, Any] = {}
    for field in dataclasses.fields(cls):  # type: ignore[arg-type]
        if field.default_factory is not dataclasses.MISSING:
            raise ClearancePinError(
                f"{cls.__name__}.{field.name}: a default factory needs __init__"
            )
        defaults[field.name] = field.default
    required = frozenset(n for n, v in defaults.items() if v is dataclasses.MISSING)
    return defaults, required


__all__ = ["frozen_instance"]
