"""Instances of the frozen answer dataclasses without their generated ``__init__``.

A planner re-solves thousands of times; the generated ``__init__`` of a frozen dataclass sets each
field through ``object.__setattr__`` (about 6 us for the 23 fields of an
:class:`~.result.Equilibrium`), filling the instance's ``__dict__`` directly costs a tenth of that.
Only for dataclasses without ``__post_init__``, ``__slots__`` or field converters (checked).
"""

from __future__ import annotations

import dataclasses
from typing import Any

from ..errors import ClearancePinError

_DEFAULTS: dict[type, tuple[dict[str, Any], frozenset[str]]] = {}


class FieldTemplate:
    """The fields of one frozen dataclass filled once (defaults, then ``constants``), copied into
    each new instance (:meth:`new`), whose caller then sets the fields that vary: 1 us for an
    :class:`~.result.Equilibrium` where a keyword dict and a check of its names cost 6. The
    caller sets every field without a default (tested where it is used)."""

    def __init__(self, cls: type, constants: dict[str, Any]):
        known = _DEFAULTS.get(cls)
        if known is None:
            known = _DEFAULTS[cls] = _defaults(cls)
        defaults, _ = known
        unknown = sorted(set(constants) - set(defaults))
        if unknown:
            raise ClearancePinError(f"{cls.__name__}: unknown {unknown}")
        self.cls = cls
        self.fields = {**defaults, **constants}

    def new(self) -> tuple[Any, dict[str, Any]]:
        """(a new instance, its field dict to complete)."""
        instance: Any = object.__new__(self.cls)
        state = instance.__dict__
        state.update(self.fields)
        return instance, state


def _defaults(cls: type) -> tuple[dict[str, Any], frozenset[str]]:
    """(every field's default, MISSING where it has none; the names of those without)."""
    if hasattr(cls, "__post_init__") or "__slots__" in cls.__dict__:
        raise ClearancePinError(f"{cls.__name__} needs its own __init__")
    defaults: dict[str, Any] = {}
    for field in dataclasses.fields(cls):
        if field.default_factory is not dataclasses.MISSING:
            raise ClearancePinError(
                f"{cls.__name__}.{field.name}: a default factory needs __init__"
            )
        defaults[field.name] = field.default
    required = frozenset(n for n, v in defaults.items() if v is dataclasses.MISSING)
    return defaults, required


__all__ = ["FieldTemplate"]
