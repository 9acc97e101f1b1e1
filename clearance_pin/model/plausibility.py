"""Values that are valid but unlikely to be meant: warnings against unit mistakes.

A clearance typed in millimetres, an angle in degrees or a tolerance as wide as its size is a valid
number, and the solver answers it confidently. These checks compare each value with a size of the
mechanism it belongs to and give a :class:`~clearance_pin.errors.SuspectValueWarning` (a
:class:`~clearance_pin.errors.ClearancePinWarning`) naming the element and the numbers:

- a joint's clearance (its largest play) above :data:`CLEARANCE_FRACTION` of its part's size,
  the largest of the journal or block length and the distances between the joint centres of
  either part it joins (measured in the body frames, so at any configuration). A part whose size
  is unknown (a lone joint at the origin) is not checked;
- a nominal joint value outside the URDF ``<limit lower upper>`` of a revolute or prismatic joint
  (a ``<limit>`` with ``lower == upper``, the URDF defaults, gives no range and is not checked),
  and a revolute value of more than :data:`TURN` (one turn: degrees, most likely);
- a toleranced length whose half tolerance exceeds :data:`TOLERANCE_FRACTION` of its nominal size
  (of the mechanism's length scale when the nominal value is 0, an offset), and an angle whose
  half tolerance exceeds :data:`ANGLE_TOLERANCE` [rad]: beyond these the first-order propagation
  of Flores [F] is no longer small, and a unit mistake is the likely cause.
"""

from __future__ import annotations

import itertools
import math
import warnings
from collections.abc import Iterable, Mapping, Sequence
from typing import Protocol

import numpy as np
import pinocchio as pin

from ..errors import ModelError, SuspectValueWarning
from ..numerics import LARGEST_MAGNITUDE
from .clearance import ALPHA, Clearance
from .dimensions import Dimension
from .joints import MOTION_COMPONENT_BY_PIN_JOINT, LoopJoint, TreeJoint

CLEARANCE_FRACTION = 0.05  # of the part's size; real plays are 1e-4 .. 1e-2 of it
ROUND_OFF_SIZE = 1e-9  # of the length scale: distances below it are round-off, not a size
TOLERANCE_FRACTION = 0.10  # half tolerance over nominal size; ISO IT18 is about 3 % at 500 mm
ANGLE_TOLERANCE = 0.1  # [rad] half tolerance of an angle (5.7 deg)
TURN = 2.0 * math.pi  # [rad]
LIMIT_SLACK = 1e-9  # [rad or m] round-off allowed on the URDF limits


class Checked(Protocol):
    """What these checks read of a :class:`~clearance_pin.mechanism.Mechanism` (the model layer
    does not import it)."""

    @property
    def model(self) -> pin.Model: ...
    @property
    def source(self) -> str: ...
    @property
    def loop_joints(self) -> Sequence[LoopJoint]: ...
    @property
    def joints(self) -> Mapping[str, TreeJoint | LoopJoint]: ...
    def length_scale(self) -> float: ...


def _warn(message: str, stacklevel: int) -> None:
    """``stacklevel`` as the public function's: 1 is that function, 2 its caller."""
    warnings.warn(SuspectValueWarning(message), stacklevel=stacklevel + 1)


def joint_centres(mechanism: Checked, body: int) -> list[np.ndarray]:
    """Joint centres [m] on one body, in its joint frame: its own tree joint's origin, the origins
    of the tree joints it carries and the frames of the loop joints that end on it."""
    model = mechanism.model
    centres = [np.zeros(3)] if body > 0 else []
    for child in range(1, model.njoints):
        if model.parents[child] == body:
            centres.append(np.array(model.jointPlacements[child].translation))
    for loop in mechanism.loop_joints:
        for frame_id in (loop.frame_a, loop.frame_b):
            frame = model.frames[frame_id]
            if frame.parentJoint == body:
                centres.append(np.array(frame.placement.translation))
    return centres


def part_size(mechanism: Checked, joint: TreeJoint | LoopJoint) -> float:
    """Size [m] against which a joint's clearance is judged: the largest of its length and the
    distances between the joint centres of either part it joins (0 when none is known)."""
    model = mechanism.model
    if hasattr(joint, "joint_id"):
        bodies = (model.parents[joint.joint_id], joint.joint_id)
    else:
        bodies = (model.frames[joint.frame_a].parentJoint, model.frames[joint.frame_b].parentJoint)
    size = joint.clearance.length
    for body in bodies:
        centres = joint_centres(mechanism, body)
        for a, b in itertools.combinations(centres, 2):
            size = max(size, float(np.linalg.norm(a - b)))
    # joint centres that meet (the cross of a universal joint written as two revolutes) differ
    # by round-off only: that is no size
    return size if size > ROUND_OFF_SIZE * mechanism.length_scale() else 0.0


def warn_large_clearances(mechanism: Checked, stacklevel: int = 2) -> None:
    """Warn for every joint whose largest play exceeds CLEARANCE_FRACTION of its part's size."""
    for joint in mechanism.joints.values():
        play = joint.clearance.max_play
        size = part_size(mechanism, joint)
        if play > 0.0 and size > 0.0 and play > CLEARANCE_FRACTION * size:
            _warn(
                f"{mechanism.source}: joint {joint.name!r}: clearance {play:.6g} m is "
                f"{100 * play / size:.3g} % of its part's size {size:.6g} m (journal length or "
                f"distance between joint centres; warned above {100 * CLEARANCE_FRACTION:g} %; the "
                f"largest play: {_largest_play(joint.clearance)}). "
                "Clearances are in metres: 50 um is 5e-05.",
                stacklevel,
            )


def _largest_play(clearance: Clearance) -> str:
    """The attribute(s) of the block that give a clearance its largest play."""
    if clearance.max_play == clearance.axial:
        return "axial_clearance"
    if clearance.play_z is not None and clearance.max_play == clearance.play_z:
        return "play_z"
    return "radial_clearance or diametral_clearance / 2"


def check_magnitudes(source: str, model: pin.Model) -> None:
    """Refuse a model whose joint or frame origins lie beyond :data:`LARGEST_MAGNITUDE` [m]
    (1e150: every product of two lengths must stay within double precision), naming the first
    such joint or frame; before any length of it is measured."""
    places = [(f"<joint name='{model.names[j]}'>", model.jointPlacements[j].translation)
              for j in range(1, model.njoints)]  # fmt: skip
    places += [(f"<link name='{f.name}'>", f.placement.translation) for f in model.frames]
    for label, origin in places:
        largest = float(np.max(np.abs(origin), initial=0.0))
        if not largest <= LARGEST_MAGNITUDE:
            raise ModelError(
                source,
                label,
                f"its origin {largest:.3g} m away is beyond what double precision carries "
                f"(at most {LARGEST_MAGNITUDE:.0e} m: every product of two lengths must stay "
                "finite)",
            )


def limits_of(model: pin.Model, joint_id: int) -> tuple[float, float] | None:
    """URDF position limits (lower, upper) of a 1-DOF joint with nq = 1, None without a range."""
    joint = model.joints[joint_id]
    if joint.nq != 1:
        return None
    lower = float(model.lowerPositionLimit[joint.idx_q])
    upper = float(model.upperPositionLimit[joint.idx_q])
    if not (math.isfinite(lower) and math.isfinite(upper)) or lower >= upper:
        return None
    return lower, upper


def nominal_problem(model: pin.Model, joint_id: int, value: float) -> str | None:
    """What is suspect about a nominal value [rad or m] of a 1-DOF joint, or None."""
    revolute = MOTION_COMPONENT_BY_PIN_JOINT.get(model.joints[joint_id].shortname()) == ALPHA
    unit = "rad" if revolute else "m"
    limits = limits_of(model, joint_id)
    if limits is not None and not (limits[0] - LIMIT_SLACK <= value <= limits[1] + LIMIT_SLACK):
        problem = (
            f"nominal value {value:.6g} {unit} is outside the joint's limits (URDF <limit>, "
            f"MJCF range) [{limits[0]:.6g}, {limits[1]:.6g}] {unit}"
        )
    elif revolute and abs(value) > TURN:
        problem = f"nominal value {value:.6g} rad is more than a turn"
    else:
        return None
    if revolute and abs(value) > TURN:  # a value within a turn is no degree typed as radians
        problem += f"; q is in radians ({value:.6g} deg would be {math.radians(value):.6g} rad)"
    elif revolute:
        problem += "; q is in radians"
    else:
        problem += "; q of a prismatic joint is a length, in metres (in a file: in its unit)"
    return problem


def warn_configurations(mechanism: Checked, q: np.ndarray, stacklevel: int = 2) -> None:
    """One warning for many configurations ``q`` (Q, nq) [rad, m]: the first joint with a value
    outside its limits or beyond a turn (:func:`nominal_problem`, asked of the whole column at
    once), how many configurations do so, and the first of them."""
    model = mechanism.model
    for joint_id in range(1, model.njoints):
        joint = model.joints[joint_id]
        if joint.nq != 1:
            continue
        values = q[:, joint.idx_q]
        beyond = np.zeros(len(q), dtype=bool)
        limits = limits_of(model, joint_id)
        if limits is not None:
            beyond |= (values < limits[0] - LIMIT_SLACK) | (values > limits[1] + LIMIT_SLACK)
        if MOTION_COMPONENT_BY_PIN_JOINT.get(joint.shortname()) == ALPHA:
            beyond |= np.abs(values) > TURN
        if beyond.any():
            first = int(np.flatnonzero(beyond)[0])
            problem = nominal_problem(model, joint_id, float(values[first]))
            follows = [c for c in getattr(mechanism, "couplings", ()) if
                       c.follower == model.names[joint_id]]  # fmt: skip
            if follows:  # not the user's value: the coupling's, from its leader's
                c = follows[0]
                problem = (
                    f"{problem}; it follows {c.leader!r} through its <mimic> "
                    f"({c.multiplier:g} x q + {c.offset:g}): the leader's value puts it there"
                )
            _warn(
                f"{mechanism.source}: configurations: {int(beyond.sum())} of {len(q)} put joint "
                f"{model.names[joint_id]!r} outside its limits or beyond a turn; the first, "
                f"configurations[{first}]: {problem}",
                stacklevel + 1,
            )
            return


def configuration_values(model: pin.Model, q: np.ndarray) -> dict[int, float]:
    """The value [rad or m] of every joint with nq = 1 in a configuration ``q`` (nq,)."""
    return {
        joint_id: float(q[model.joints[joint_id].idx_q])
        for joint_id in range(1, model.njoints)
        if model.joints[joint_id].nq == 1
    }


def warn_nominal_values(
    mechanism: Checked,
    values: Mapping[int, float],
    source: str | None = None,
    stacklevel: int = 2,
) -> None:
    """Warn for every nominal value outside its joint's URDF limits, or beyond a turn.

    Args:
        values: joint id -> value [rad or m] of 1-DOF joints (an unbounded revolute included,
            by its angle).
        source: prefix of the message (default: the mechanism's source).
    """
    model = mechanism.model
    for joint_id, value in values.items():
        problem = nominal_problem(model, joint_id, value)
        if problem:
            _warn(
                f"{source or mechanism.source}: joint {model.names[joint_id]!r}: {problem}",
                stacklevel,
            )


def warn_wide_tolerances(
    mechanism: Checked, dimensions: Iterable[Dimension], stacklevel: int = 2
) -> None:
    """Warn for every dimension whose half tolerance is not small against its size."""
    for dimension in dimensions:
        half = dimension.half_tolerance
        if dimension.kind == "angle":
            if half > ANGLE_TOLERANCE:
                _warn(
                    f"{mechanism.source}: dimension {dimension.name!r}: half tolerance "
                    f"{half:.6g} rad is more than {ANGLE_TOLERANCE:g} rad; angles are in radians",
                    stacklevel,
                )
            continue
        size = abs(dimension.nominal)
        basis = "its nominal size"
        if size == 0.0:
            size, basis = mechanism.length_scale(), "the mechanism's length scale (an offset)"
        if half > TOLERANCE_FRACTION * size:
            _warn(
                f"{mechanism.source}: dimension {dimension.name!r}: tolerance +/- {half:.6g} m is "
                f"{100 * half / size:.3g} % of {basis} {size:.6g} m (warned above "
                f"{100 * TOLERANCE_FRACTION:g} %); tolerances are in metres: +/- 50 um is 5e-05",
                stacklevel,
            )
