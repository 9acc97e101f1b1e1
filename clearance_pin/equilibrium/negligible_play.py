"""Plays too small to resolve beside the others are the joint without play in that direction.

A play below :data:`NEGLIGIBLE_PLAY` (1e-9) of the mechanism's largest play moves its joint by
less than the round-off of the other joints' motions: the solve cannot tell it from zero (its
unknowns, scaled by their play, sit 1e9 below the others), and physically the part is held there
as by a joint without play (a 1e-14 m play beside 3e-4 m plays is below an atom). The limit of the
answer as that play goes to zero is the answer with the joint rigid in those directions: its
contact point then carries any force, as a ball in a socket without play does. So such a play is
set to zero (a ``SuspectValueWarning`` names the joint, the play and the largest play), and every
part of the library (the reduction, the reactions, the exact model) sees the same rigid joint.
"""

from __future__ import annotations

import warnings
from dataclasses import replace
from typing import Any

from ..errors import SuspectValueWarning

NEGLIGIBLE_PLAY = 1e-9  # of the mechanism's largest play
PLAY_FIELDS = ("radial", "axial", "play_z")  # the Clearance fields that bound contacts [m]


def rigid_negligible_plays(
    joints: tuple[Any, ...], largest: float | None = None, source: str = ""
) -> tuple[Any, ...]:
    """``joints`` (TreeJoint or LoopJoint) with every play below 1e-9 of ``largest`` (default:
    the largest play of ``joints``) set to zero, warned about; the joints themselves when none
    is."""
    if largest is None:
        largest = max((j.clearance.max_play for j in joints), default=0.0)
    threshold = NEGLIGIBLE_PLAY * largest
    out = []
    for joint in joints:
        clearance = joint.clearance
        negligible = {
            name: value
            for name in PLAY_FIELDS
            if (value := getattr(clearance, name)) is not None and 0.0 < value < threshold
        }
        if negligible:
            given = ", ".join(f"{name} {value:.3g} m" for name, value in negligible.items())
            warnings.warn(
                SuspectValueWarning(
                    f"{source + ': ' if source else ''}joint {joint.name!r}: play {given} is "
                    f"below {NEGLIGIBLE_PLAY:g} of the largest play ({largest:.3g} m), too small "
                    "to resolve beside it: treated as no play (rigid) in that direction"
                ),
                stacklevel=4,
            )
            rigid = replace(clearance, **dict.fromkeys(negligible, 0.0))
            out.append(replace(joint, clearance=rigid))
        else:
            out.append(joint)
    return tuple(out)


__all__ = ["NEGLIGIBLE_PLAY", "rigid_negligible_plays"]
