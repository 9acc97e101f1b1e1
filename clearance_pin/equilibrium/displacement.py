r"""A frame's displacement as a Pinocchio ``pin.Motion`` in a named reference frame.

The solved displacement of a frame f is its origin's translation :math:`t` [m] and its rotation
:math:`\theta` [rad] (a rotation vector), world axes: Pinocchio's ``LOCAL_WORLD_ALIGNED``
convention. The other conventions follow as for a twist (first order in the rotation):

- ``pin.LOCAL``: the frame's own axes at the nominal pose, :math:`(R_0^T t, R_0^T \theta)`;
- ``pin.WORLD``: world axes, the translation of the point at the world origin carried by the
  frame's body, :math:`(t - \theta \times p_0, \theta)` (:math:`p_0`: the frame's nominal origin).
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np
import pinocchio as pin

from ..errors import ArgumentError

REFERENCE_FRAMES = (pin.LOCAL, pin.WORLD, pin.LOCAL_WORLD_ALIGNED)


class Displacement(pin.Motion):  # type: ignore[misc]  # pinocchio has no type information
    """A ``pin.Motion`` (``linear`` [m], ``angular`` [rad]) that also unpacks as the pair
    ``translation, rotation = displacement`` (copies) and indexes as one (``[0]``, ``[1]``)."""

    def __iter__(self) -> Iterator[np.ndarray]:
        return iter((self.linear.copy(), self.angular.copy()))

    def __getitem__(self, index: int) -> np.ndarray:
        pair: tuple[np.ndarray, np.ndarray] = (self.linear.copy(), self.angular.copy())
        return pair[index]

    def __len__(self) -> int:
        return 2


def displacement_in(
    translation: np.ndarray, rotation: np.ndarray, nominal: pin.SE3, reference_frame: Any
) -> Displacement:
    """The :class:`Displacement` of a frame whose nominal world placement is ``nominal``, from
    its origin's translation (3,) [m] and rotation vector (3,) [rad] in world axes, expressed in
    ``reference_frame`` (module docstring)."""
    if reference_frame == pin.LOCAL_WORLD_ALIGNED:
        return Displacement(translation, rotation)
    if reference_frame == pin.LOCAL:
        axes = nominal.rotation.T
        return Displacement(axes @ translation, axes @ rotation)
    if reference_frame == pin.WORLD:
        return Displacement(translation - np.cross(rotation, nominal.translation), rotation)
    raise ArgumentError(
        "reference_frame", "pin.LOCAL, pin.WORLD or pin.LOCAL_WORLD_ALIGNED", reference_frame
    )


__all__ = ["REFERENCE_FRAMES", "Displacement", "displacement_in"]
