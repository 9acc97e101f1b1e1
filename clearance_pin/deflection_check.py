r"""Springs that deflect implausibly far: a warning after the solve (issue 33 item 5).

A stiffness typed in the wrong unit (``drive_stiffness = 40`` meant as 40 kN m/rad, typed as
N m/rad) is a valid number, and the solver answers it confidently: the joint turns 0.875 rad
under 35 N m and the tool moves by metres. The play cannot show it (no play is that large), so
the answer is judged after the solve, like a large backlash at load time
(:class:`~clearance_pin.errors.SuspectValueWarning`):

- a rotation of a joint's spring :math:`\lVert (e_\alpha, e_\beta, e_\gamma) \rVert` above
  :data:`ROTATION_LIMIT` = 0.1 rad: beyond it the small-displacement model's linearisation is
  off by about :math:`\theta^2/2` = 0.5 % and a real bearing, gear train or link has long
  failed (a robot's drive deflects by 1e-4 to 1e-3 rad at its rated torque);
- a translation :math:`\lVert (e_u, e_v, e_w) \rVert` above :data:`LENGTH_FRACTION` = 5 % of the
  joint's part's size (the journal length or the distances between the joint centres of either
  part it joins, :func:`~clearance_pin.model.plausibility.part_size`; the mechanism's length
  scale when it has none), the fraction that judges a clearance too: a bearing deflects by
  micrometres, a link's compliance lumped at its joint by a fraction of a millimetre.

Both rules are absolute, not relative to the joint's play (a stiff joint with no play at all
deflects by its load over its stiffness, legitimately "infinitely" more than its play). Single
solves and batches warn once per call, naming the joint, its largest deflection and, in a batch,
the case.
"""

from __future__ import annotations

import math
import warnings
import weakref
from collections.abc import Iterable
from typing import Any

import numpy as np

from .errors import SuspectValueWarning
from .model.plausibility import part_size

ROTATION_LIMIT = 0.1  # [rad] a spring's rotation beyond which its stiffness is suspect
LENGTH_FRACTION = 0.05  # of the part's size: a spring's translation beyond it is suspect


def largest_deflections(
    mechanism: Any, deflections: Iterable[tuple[str, np.ndarray]]
) -> list[tuple[float, str, str, int]]:
    """The springs that deflect beyond the limits (module docstring): per joint and kind, (its
    share of the limit, the joint, a description of the deflection, the case), largest first.

    Args:
        mechanism: the mechanism solved (its joints and sizes).
        deflections: (joint, deflections (N, 6) [m, rad] in its clearance frame) per joint with
            stiffness; NaN rows (failed cases) are skipped.
    """
    found = []
    for name, given in deflections:
        rows = np.atleast_2d(np.asarray(given, dtype=float))
        if not rows.size:
            continue
        size = _sizes(mechanism)[name]
        turns = np.linalg.norm(rows[:, 3:], axis=1)
        moves = np.linalg.norm(rows[:, :3], axis=1)
        for values, limit, what in (
            (turns, ROTATION_LIMIT, "rad (warned above {limit:g} rad)"),
            (moves, LENGTH_FRACTION * size, "m ({share:.3g} % of its part's size {size:.6g} m; "
                                            "warned above {percent:g} %)"),
        ):  # fmt: skip
            if not np.any(values > limit):  # NaN rows compare False
                continue
            case = int(np.nanargmax(values))
            value = float(values[case])
            text = f"{value:.6g} " + what.format(
                limit=ROTATION_LIMIT,
                share=100.0 * value / size,
                size=size,
                percent=100.0 * LENGTH_FRACTION,
            )
            found.append((value / limit, name, text, case))
    found.sort(key=lambda item: -item[0])
    return found


_SIZES: weakref.WeakKeyDictionary[Any, dict[str, float]] = weakref.WeakKeyDictionary()


def _sizes(mechanism: Any) -> dict[str, float]:
    """Per joint with stiffness, its part's size [m] (the length scale when it has none), read
    once per mechanism (a re-solve's check is then a few norms)."""
    sizes = _SIZES.get(mechanism)
    if sizes is None:
        scale = float(mechanism.length_scale())
        sizes = _SIZES[mechanism] = {
            name: part_size(mechanism, joint) or scale
            for name, joint in mechanism.joints.items()
            if joint.clearance.stiffness is not None
        }
    return sizes


def warn_large_deflections(
    mechanism: Any,
    deflections: Iterable[tuple[str, np.ndarray]],
    batch: bool = False,
    stacklevel: int = 2,
) -> None:
    """One :class:`~clearance_pin.errors.SuspectValueWarning` for the springs of ``deflections``
    (see :func:`largest_deflections`) that deflect beyond the limits, naming the largest (and
    how many more); ``batch``: name the case too. ``stacklevel`` as the caller's (2: its
    caller)."""
    found = largest_deflections(mechanism, deflections)
    if not found:
        return
    _, name, text, case = found[0]
    where = f" in case {case}" if batch else ""
    others = len({joint for _, joint, _, _ in found} - {name})
    more = f"; {others} more joint{'s' if others != 1 else ''} too" if others else ""
    warnings.warn(
        SuspectValueWarning(
            f"{mechanism.source}: joint {name!r}: its spring deflects by {text}{where}{more}. "
            "Stiffnesses are SI, whatever the file's unit: N/m and N m/rad (a drive of "
            "40 kN m/rad is drive_stiffness=4e4)."
        ),
        stacklevel=stacklevel + 1,
    )


def warn_answer(mechanism: Any, answer: Any, stacklevel: int = 2) -> None:
    """:func:`warn_large_deflections` of one answer (an Equilibrium): its springs judged at
    once, the message built only when one is beyond the limits (a re-solve's check is then a
    few norms)."""
    found = answer.deflections
    if not found:
        return
    sizes = _sizes(mechanism)
    for name, value in found.items():
        u, v, w, a, b, c = value.tolist()
        if math.hypot(a, b, c) > ROTATION_LIMIT or math.hypot(u, v, w) > (
            LENGTH_FRACTION * sizes[name]
        ):
            rows = [(joint, deflection[None, :]) for joint, deflection in found.items()]
            warn_large_deflections(mechanism, rows, stacklevel=stacklevel + 1)
            return


def batch_deflections(mechanism: Any, batch: Any) -> list[tuple[str, np.ndarray]]:
    """(joint, its deflections (N, 6)) of every joint with stiffness of ``mechanism`` in
    ``batch`` (an EquilibriumBatch)."""
    return [
        (joint.name, batch.deflections(joint.name))
        for joint in mechanism.joints.values()
        if joint.clearance.stiffness is not None
    ]


__all__ = [
    "LENGTH_FRACTION",
    "ROTATION_LIMIT",
    "batch_deflections",
    "largest_deflections",
    "warn_answer",
    "warn_large_deflections",
]
