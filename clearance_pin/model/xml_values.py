"""Numbers and vectors read from XML attributes, with the error a user can act on.

Every reader of the model file (joints, loads, dimensions) reads its values here, so a bad value
gets the same message wherever it is: a :class:`~clearance_pin.errors.ModelError` naming the
file, the element, the attribute, the text found and what was expected.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
from numpy.typing import ArrayLike

from ..errors import ModelError


def number(
    source: str,
    label: str,
    element: ET.Element,
    attribute: str,
    nonnegative: bool = False,
    unit: str = "",
) -> float:
    """The finite number of ``attribute`` (>= 0 with ``nonnegative``); ``unit`` is named in the
    message ([m], [rad]) when given."""
    text = element.get(attribute)
    suffix = f" [{unit}]" if unit else ""
    try:
        value = float(text)  # type: ignore[arg-type]  # None raises TypeError, reported below
    except (TypeError, ValueError):
        raise ModelError(source, label, f"{attribute}={text!r} is not a number{suffix}") from None
    expected = "a finite number >= 0" if nonnegative else "finite"
    if not math.isfinite(value) or (nonnegative and value < 0.0):
        raise ModelError(source, label, f"{attribute}={text!r} must be {expected}{suffix}")
    return value


def vector(
    source: str,
    label: str,
    text: str | None,
    attribute: str,
    default: ArrayLike | None = None,
    allow_zero: bool = False,
) -> np.ndarray:
    """The 3 finite numbers of an attribute's ``text`` (``default`` when it is absent; a zero
    vector refused unless ``allow_zero``)."""
    if text is None:
        if default is None:
            raise ModelError(source, label, f"needs {attribute} (3 numbers)")
        return np.array(default, dtype=float)
    try:
        value = np.array([float(v) for v in text.split()], dtype=float)
    except ValueError:
        raise ModelError(source, label, f"{attribute}={text!r} is not 3 numbers") from None
    if value.shape != (3,) or not np.all(np.isfinite(value)):
        raise ModelError(source, label, f"{attribute}={text!r} must be 3 finite numbers")
    if not allow_zero and np.linalg.norm(value) == 0.0:
        raise ModelError(source, label, f"{attribute} has zero length")
    return value


__all__ = ["number", "vector"]
