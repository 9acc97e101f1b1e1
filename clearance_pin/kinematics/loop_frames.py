r"""Where a loop joint's clearance zone sits: its two clearance frames at a configuration.

A loop joint joins ``frame_a`` (the housing: bore, guide or socket, on the parent part) and
``frame_b`` (the journal, block or ball, on the child part). The contact points of the clearance
kind (:mod:`clearance_pin.model.clearance`) belong to the child part *where it is*:

- the child-side clearance frame :math:`C_b` has its origin at ``frame_b``'s origin :math:`p_b` and
  the housing's axes :math:`R_c = R_a R_{loop}` (x = the joint axis given in ``frame_a``), tilted
  onto the child's own axis :math:`R_b R_{loop} e_x` where the kind bounds the tilt (journals,
  pins, blocks), and turned with the child entirely where it bounds every rotation;
- the parent-side clearance frame :math:`C_a` has the housing's axes :math:`R_c` and its origin on
  the housing's axis, at the foot of :math:`p_b` when the kind lets the child slide along the axis
  (cylindrical, prismatic: a block slides along its guide, a journal along its bore), at
  :math:`p_a` otherwise.

At a closed, aligned configuration the two frames coincide. What remains of :math:`C_a^{-1} C_b`
is the joint's *nominal eccentricity* (a misaligned housing): admissible when every contact point
of the child lies inside its clearance set at the nominal pose, :math:`\|S_j (p + R r_j - r_j)\|
< c_j`, and zero in every rigid direction. The solvers then write the contact conditions on the
true relative placement, offset included.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from ..model.clearance import ALPHA, BETA, GAMMA, ContactPoint, U
from ..model.joints import LoopJoint, rotation_x_to

if TYPE_CHECKING:
    from ..model.mechanism_parts import MechanismParts as Mechanism

RIGID_TOLERANCE = 1e-9  # [m per m of length scale] a rigid direction may miss by round-off only


def clearance_frames_at(loop: LoopJoint, oMa: pin.SE3, oMb: pin.SE3) -> tuple[pin.SE3, pin.SE3]:
    """World placements (parent side C_a, child side C_b) of a loop joint's clearance frames, for
    the placements ``oMa``, ``oMb`` of its two frames (see the module docstring)."""
    free = set(loop.clearance.free_components)
    housing = oMa.rotation @ loop.rotation
    axis = housing[:, 0]
    offset = oMb.translation - oMa.translation
    origin = oMa.translation + (axis * float(axis @ offset) if U in free else 0.0)
    relative = housing.T @ oMb.rotation @ loop.rotation  # the child's axes in the housing's
    if {ALPHA, BETA, GAMMA} <= free:
        turned = np.eye(3)  # a ball: rotations free, nothing to keep
    elif ALPHA in free:
        turned = rotation_x_to(relative[:, 0])  # a journal or pin: keep the tilt, not the spin
    else:
        turned = relative
    return pin.SE3(housing, origin), pin.SE3(housing @ turned, oMb.translation.copy())


def loop_joint_frames(
    mechanism: Mechanism, oMf: Sequence[pin.SE3]
) -> dict[str, tuple[pin.SE3, pin.SE3]]:
    """Per loop joint, its clearance frames in its own two frames: (aMc, bMc), fixed in
    ``frame_a``'s and ``frame_b``'s parts, from the frame placements ``oMf`` of a configuration.

    A mismatch the loop closure leaves at round-off (below :data:`RIGID_TOLERANCE` of the length
    scale) is no eccentricity: the child frame is then the parent one, so that answers do not
    depend on the last digits of the closure."""
    frames: dict[str, tuple[pin.SE3, pin.SE3]] = {}
    length = max(mechanism.length_scale(), 1.0)
    for loop in mechanism.loop_joints:
        oMa, oMb = oMf[loop.frame_a], oMf[loop.frame_b]
        parent, child = clearance_frames_at(loop, oMa, oMb)
        relative = parent.actInv(child)
        miss = max(
            float(np.abs(relative.translation).max()),
            length * float(np.abs(pin.log3(relative.rotation)).max()),
        )
        if miss <= RIGID_TOLERANCE * length:
            child = parent
        frames[loop.name] = (oMa.actInv(parent), oMb.actInv(child))
    return frames


def nominal_offsets(loop: LoopJoint, relative: pin.SE3) -> dict[str, np.ndarray]:
    r"""Per contact point of ``loop`` with a positive play: its selected displacement components
    :math:`S_j (p + R r_j - r_j)` [m] at the relative placement ``relative`` (C_b in C_a), the
    eccentricity the contact conditions start from."""
    offsets: dict[str, np.ndarray] = {}
    for point in loop.clearance.contacts:
        if point.bound > 0.0:
            offsets[point.name] = _displacement(relative, point)
    return offsets


def eccentricity_problems(mechanism: Mechanism, oMf: Sequence[pin.SE3]) -> list[str]:
    """One message per loop joint whose frames, placed by ``oMf``, miss each other by more than
    an admissible eccentricity: outside the play at a contact point, or in a rigid direction
    (rigid components, contact points without play) by more than round-off. Empty: admissible."""
    problems: list[str] = []
    tolerance = RIGID_TOLERANCE * max(mechanism.length_scale(), 1.0)
    for loop in mechanism.loop_joints:
        parent, child = clearance_frames_at(loop, oMf[loop.frame_a], oMf[loop.frame_b])
        relative = parent.actInv(child)
        clearance = loop.clearance
        for component in clearance.rigid_components:
            miss = _rigid_miss(relative, component)
            if miss > tolerance:
                problems.append(
                    f"loop joint {loop.name!r}: its frames miss each other by {miss:.3e} "
                    f"{'m' if component < ALPHA else 'rad'} in a rigid direction "
                    f"({_COMPONENTS[component]}); an offset is accepted only inside the play"
                )
        for point in clearance.contacts:
            reach = float(np.linalg.norm(_displacement(relative, point)))
            if point.bound == 0.0 and reach > tolerance:
                problems.append(
                    f"loop joint {loop.name!r}: contact point {point.name!r} has no play but its "
                    f"frames miss each other by {reach:.3e} m there"
                )
            elif point.bound > 0.0 and reach >= point.bound:
                problems.append(
                    f"loop joint {loop.name!r}: its frames are offset by {reach:.3e} m at contact "
                    f"point {point.name!r}, not inside the play {point.bound:.3e} m"
                )
    return problems


_COMPONENTS = ("u", "v", "w", "alpha", "beta", "gamma")


def _displacement(relative: pin.SE3, point: ContactPoint) -> np.ndarray:
    r = np.asarray(point.point)
    moved = relative.translation + relative.rotation @ r - r
    selected: np.ndarray = moved[list(point.components)]
    return selected


def _rigid_miss(relative: pin.SE3, component: int) -> float:
    if component < ALPHA:
        return abs(float(relative.translation[component]))
    return abs(float(pin.log3(relative.rotation)[component - ALPHA]))
