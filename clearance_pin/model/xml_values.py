"""Numbers and vectors read from XML attributes, with the error a user can act on.

Every reader of the model file (joints, loads, dimensions) reads its values here, so a bad value
gets the same message wherever it is: a :class:`~clearance_pin.errors.ModelError` naming the
file, the element, the attribute, the text found and what was expected.

Lengths may be written in another unit than the metre (a clearance file's ``unit="mm"``): the
reader passes its power of ten, ``exponent`` (-3 for mm), and the value is converted here, at
the edge, in decimal arithmetic, so ``0.01`` mm gives the same float as ``1e-05`` m written in
metres (a float multiplication by 1e-3 would not always).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from decimal import Decimal, InvalidOperation

import numpy as np
from numpy.typing import ArrayLike

from ..errors import ModelError

# length units of a clearance file or block: power of ten of the metre
UNITS: dict[str, int] = {
    "m": 0,
    "mm": -3,
    "um": -6,
    "\N{MICRO SIGN}m": -6,
    "\N{GREEK SMALL LETTER MU}m": -6,
}


class LabelledElement(ET.Element):
    """An element with the name its messages give it, when it did not come from XML (an entry
    ``[joints.elbow]`` of a TOML clearance file, ``clearances['elbow']`` of a Python dict).

    Attributes:
        label: how messages name the element.
    """

    label: str = ""


def labelled(tag: str, attributes: dict[str, str], label: str) -> LabelledElement:
    """A :class:`LabelledElement` ``<tag attributes...>`` named ``label`` in messages."""
    element = LabelledElement(tag, attributes)
    element.label = label
    return element


def label_of(element: ET.Element) -> str | None:
    """The label a :class:`LabelledElement` carries (None for an element read from XML)."""
    return element.label if isinstance(element, LabelledElement) and element.label else None


def scaled(text: str, exponent: int) -> float:
    """The float nearest to ``text x 10**exponent`` (decimal arithmetic; ``text`` a number)."""
    value = float(text)
    if exponent == 0 or not math.isfinite(value):
        return value
    try:
        return float(Decimal(text.strip()).scaleb(exponent))
    except (InvalidOperation, ValueError):  # a form float reads and Decimal does not
        return value * 10.0**exponent


def number(
    source: str,
    label: str,
    element: ET.Element,
    attribute: str,
    nonnegative: bool = False,
    unit: str = "",
    exponent: int = 0,
) -> float:
    """The finite number of ``attribute`` (>= 0 with ``nonnegative``) times ``10**exponent``
    (a length in the file's unit converted to metres); ``unit`` is named in the message ([m],
    [rad]) when given."""
    text = element.get(attribute)
    suffix = f" [{unit}]" if unit else ""
    try:
        value = float(text)  # type: ignore[arg-type]  # None raises TypeError, reported below
    except (TypeError, ValueError):
        raise ModelError(source, label, f"{attribute}={text!r} is not a number{suffix}") from None
    expected = "a finite number >= 0" if nonnegative else "finite"
    if not math.isfinite(value) or (nonnegative and value < 0.0):
        raise ModelError(source, label, f"{attribute}={text!r} must be {expected}{suffix}")
    return scaled(text, exponent) if exponent else value  # type: ignore[arg-type]  # a number


def vector(
    source: str,
    label: str,
    text: str | None,
    attribute: str,
    default: ArrayLike | None = None,
    allow_zero: bool = False,
    exponent: int = 0,
) -> np.ndarray:
    """The 3 finite numbers of an attribute's ``text`` (``default`` when it is absent; a zero
    vector refused unless ``allow_zero``), times ``10**exponent`` (a position in the file's
    unit converted to metres; ``default`` is in metres)."""
    if text is None:
        if default is None:
            raise ModelError(source, label, f"needs {attribute} (3 numbers)")
        return np.array(default, dtype=float)
    words = text.split()
    try:
        value = np.array([float(v) for v in words], dtype=float)
    except ValueError:
        raise ModelError(source, label, f"{attribute}={text!r} is not 3 numbers") from None
    if value.shape != (3,) or not np.all(np.isfinite(value)):
        raise ModelError(source, label, f"{attribute}={text!r} must be 3 finite numbers")
    if not allow_zero and np.linalg.norm(value) == 0.0:
        raise ModelError(source, label, f"{attribute} has zero length")
    if exponent:
        value = np.array([scaled(v, exponent) for v in words], dtype=float)
    return value


__all__ = ["UNITS", "LabelledElement", "label_of", "labelled", "number", "scaled", "vector"]
