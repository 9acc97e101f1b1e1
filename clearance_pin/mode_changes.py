r"""Positioning discontinuities along a trajectory: where the contact mode changes, located by
bisection, and how far each output jumps there.

Between two neighbouring poses :math:`q_{i-1}` and :math:`q_i` of a ``solve_many(configurations=)``
batch whose contact modes differ (:func:`~clearance_pin.plot.trajectory.contact_modes`: a contact
touches or leaves, a slab changes face, a drive's backlash stop switches side, or a ball, disc or
journal-end contact's force turns by more than 90 deg: the part flips across its play), the path
:math:`q(s) = (1 - s)\, q_{i-1} + s\, q_i` is bisected on :math:`s \in [0, 1]` until the
interval is below ``tolerance`` of the whole trajectory's driven range; the jump of each output
is its displacement on the far side minus the near side,
:math:`\Delta p = \delta p(s^+) - \delta p(s^-)` [m], and likewise its rotation
:math:`\Delta\theta` [rad] (a contact that flips across a play c moves the parts by up to 2c at
once: a discontinuity of the positioning, not of the model). A drive's backlash stop switches
side where the joint's load torque :math:`\tau_j(q)` changes sign: the joint turns (slides) by
its whole backlash b at once, and an output at the end of the chain jumps by
:math:`\lvert J_j \rvert\, b` in the small-displacement model (:math:`J_j` the output's
Jacobian column of that joint [m/rad or m/m]; tests/test_mode_changes_backlash.py checks both
against Pinocchio's own gravity torques and Jacobians). The bisection solves each middle pose in
the batch's own model (small-displacement or exact).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .equilibrium.result import Equilibrium
from .errors import ArgumentError, ClearancePinError
from .plot.trajectory import (
    BACKLASH_STOP,
    _contact_shapes,
    _pushed,
    _side,
    contact_modes,
    flipped,
)


@dataclass(frozen=True)
class ModeChange:
    """One located change of the contact mode.

    Attributes:
        index: the batch's case i after the change (it lies between cases i - 1 and i).
        fraction: where between them, s in [0, 1] on q(s) = (1 - s) q_{i-1} + s q_i, to within
            ``width``.
        width: the bisected interval, as a fraction of the step from q_{i-1} to q_i.
        configuration: q at the change (nq,) (the middle of the last interval).
        touched, left, flipped: contacts (``joint:point``) that start touching, stop touching,
            or whose force turns by more than 90 deg across the change (slab contacts changing
            face are in ``flipped`` too, but for a drive's backlash stops: ``stops``).
        jumps: output name -> translation jump (3,) [m], world axes, far side minus near side.
        rotation_jumps: output name -> rotation jump (3,) [rad], world axes, likewise.
        near, far: the answers either side of the change, ``width`` apart.
        stops: the drives' backlash stops (``joint:backlash``) that switch side across the
            change: the joint's load torque changes sign there and the joint crosses its whole
            backlash.
    """

    index: int
    fraction: float
    width: float
    configuration: np.ndarray = field(repr=False)
    touched: tuple[str, ...]
    left: tuple[str, ...]
    flipped: tuple[str, ...]
    jumps: dict[str, np.ndarray]
    rotation_jumps: dict[str, np.ndarray] = field(default_factory=dict)
    near: Equilibrium | None = field(default=None, repr=False, compare=False)
    far: Equilibrium | None = field(default=None, repr=False, compare=False)
    stops: tuple[str, ...] = ()

    def largest_jump(self) -> float:
        """The largest output jump [m]."""
        return max((float(np.linalg.norm(j)) for j in self.jumps.values()), default=0.0)

    def largest_rotation_jump(self) -> float:
        """The largest output rotation jump [rad]."""
        return max((float(np.linalg.norm(j)) for j in self.rotation_jumps.values()), default=0.0)


def locate_changes(
    batch: Sequence[Equilibrium | Exception],
    outputs: Sequence[str] | None = None,
    tolerance: float = 1e-6,
) -> tuple[ModeChange, ...]:
    """Every contact-mode change of ``batch`` (the answer of ``solve_many(configurations=...)``)
    located by bisection to ``tolerance`` of the trajectory's driven range, with each output's
    jump (module docstring). ``outputs``: output names of the answers (default: every output of
    the first answer)."""
    if not 0.0 < tolerance < 1.0:
        raise ArgumentError("tolerance", "a fraction of the driven range in (0, 1)", tolerance)
    items = list(batch)
    modes = contact_modes(items)
    answers = [item for item in items if isinstance(item, Equilibrium)]
    mechanism: Any = answers[0].mechanism
    shapes = _contact_shapes(mechanism)
    names = list(answers[0].outputs) if outputs is None else list(outputs)
    configurations: list[np.ndarray | None] = [
        np.asarray(item.configuration.q) if isinstance(item, Equilibrium) else None  # type: ignore[attr-defined]
        for item in items
    ]
    known = [q for q in configurations if q is not None]
    span = float(np.max(np.ptp(np.array(known), axis=0))) if len(known) > 1 else 0.0
    exact = answers[0].formulation == "exact"  # bisected in the batch's own model
    located = []
    for index in modes.changes:
        before = max(k for k in range(index) if configurations[k] is not None)
        near, far = items[before], items[index]
        assert isinstance(near, Equilibrium) and isinstance(far, Equilibrium)
        q0, q1 = configurations[before], configurations[index]
        assert q0 is not None and q1 is not None
        step = float(np.max(np.abs(q1 - q0))) or 1.0
        target = tolerance * (span or step) / step  # the interval's width in s

        def solve(
            s: float, q0: np.ndarray = q0, q1: np.ndarray = q1, loads: Any = near.loads
        ) -> Any:
            return mechanism.solve(
                loads=loads, q=(1.0 - s) * q0 + s * q1, gravity=False, exact=exact
            )

        def in_low_mode(low: Equilibrium, answer: Equilibrium) -> bool:
            return _same_mode(low, answer, shapes)

        low, high, low_answer, high_answer = _bisect(
            solve, (0.0, near), (1.0, far), target, in_low_mode
        )
        if _stops_between(low_answer, high_answer, far, shapes):
            # a stop left free where the load torque is ~0, touching its other side further on:
            # the joint crosses its backlash over this zone; its far edge bisected as well
            def short_of_far(_: Equilibrium, answer: Equilibrium, far: Equilibrium = far) -> bool:
                return not _same_mode(far, answer, shapes)

            _, high, _, high_answer = _bisect(
                solve, (high, high_answer), (1.0, far), target, short_of_far
            )
        touched, left, turned, stops = _differences(low_answer, high_answer, shapes)
        moved = {name: (_moved(low_answer, name), _moved(high_answer, name)) for name in names}
        jumps = {name: far_[0] - near_[0] for name, (near_, far_) in moved.items()}
        turns = {name: far_[1] - near_[1] for name, (near_, far_) in moved.items()}
        located.append(
            ModeChange(
                index,
                0.5 * (low + high),
                high - low,
                (1.0 - 0.5 * (low + high)) * q0 + 0.5 * (low + high) * q1,
                touched,
                left,
                turned,
                jumps,
                turns,
                low_answer,
                high_answer,
                stops,
            )
        )
    return tuple(located)


def _bisect(
    solve: Callable[[float], Equilibrium],
    start: tuple[float, Equilibrium],
    end: tuple[float, Equilibrium],
    target: float,
    on_start_side: Callable[[Equilibrium, Equilibrium], bool],
) -> tuple[float, float, Equilibrium, Equilibrium]:
    """Bisection of s in [start, end] until end - start <= ``target``: the last s (and answer)
    where ``on_start_side(last start-side answer, answer)`` holds and the first where it does
    not. A middle pose whose solve
    does not verify is replaced by the quarter points; when none verifies, the interval stays
    as wide as it is (the change's ``width`` says so)."""
    (low, low_answer), (high, high_answer) = start, end
    while high - low > target:
        answered = None
        for fraction in (0.5, 0.25, 0.75):
            s = low + fraction * (high - low)
            try:
                answered = s, solve(s)
                break
            except ClearancePinError:
                continue
        if answered is None:
            break
        s, answer = answered
        if on_start_side(low_answer, answer):
            low, low_answer = s, answer
        else:
            high, high_answer = s, answer
    return low, high, low_answer, high_answer


def _stops_between(
    near: Equilibrium, middle: Equilibrium, far: Equilibrium, shapes: Shapes
) -> bool:
    """A backlash stop touches in ``near``, is free in ``middle`` and touches its other side in
    ``far``."""
    sides_near, sides_middle = _touching(near, shapes), _touching(middle, shapes)
    sides_far = _touching(far, shapes)
    return any(
        label.endswith(":" + BACKLASH_STOP)
        and label not in sides_middle
        and sides_far.get(label) == -side
        for label, side in sides_near.items()
    )


def _moved(answer: Equilibrium, name: str) -> tuple[np.ndarray, np.ndarray]:
    """The translation [m] and rotation [rad] of an output of the answer, or of a Pinocchio
    frame, world axes."""
    found = answer.outputs.get(name)
    if found is not None:
        return np.asarray(found[0]), np.asarray(found[1])
    displacement = answer.frame_displacement(name)
    return np.asarray(displacement.linear), np.asarray(displacement.angular)


Shapes = dict[str, tuple[str, tuple[int, ...]]]


def _touching(answer: Equilibrium, shapes: Shapes) -> dict[str, float]:
    """Touching contacts with their side (+1 for a ball or disc, the face for a slab or a
    backlash stop: :func:`~clearance_pin.plot.trajectory._side`)."""
    return {c.label: _side(_pushed(c), shapes[c.label]) for c in answer.contacts if c.active}


def _same_mode(a: Equilibrium, b: Equilibrium, shapes: Shapes) -> bool:
    return _touching(a, shapes) == _touching(b, shapes) and not flipped(a, b, shapes)


def _differences(
    a: Equilibrium, b: Equilibrium, shapes: Shapes
) -> tuple[tuple[str, ...], tuple[str, ...], tuple[str, ...], tuple[str, ...]]:
    """The contacts that touch, leave, flip (a slab's face, a force turning) and the backlash
    stops that switch side from ``a`` to ``b``."""
    sides_a, sides_b = _touching(a, shapes), _touching(b, shapes)
    touched = tuple(label for label in sides_b if label not in sides_a)
    left = tuple(label for label in sides_a if label not in sides_b)
    faces = [label for label in sides_b if label in sides_a and sides_a[label] != sides_b[label]]
    stops = tuple(label for label in faces if label.endswith(":" + BACKLASH_STOP))
    others = tuple(label for label in faces if label not in stops)
    return touched, left, others + flipped(a, b, shapes), stops


__all__ = ["ModeChange", "locate_changes"]
