r"""Deviations of the toleranced dimensions of a mechanism (:mod:`clearance_pin.model.dimensions`):
which parts a dimension moves, and the model or mechanism with given deviations.

A deviation ``dd`` of a dimension is the rigid motion ``D(dd)`` of the subtree below its joint, in
the anchor joint's frame (``Dimension.displacement``), left-multiplied onto every joint placement
and frame placement that hangs on the anchor directly (the deeper ones follow through the forward
kinematics).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from ..errors import ArgumentError
from ..model.dimensions import Dimension

if TYPE_CHECKING:
    from ..mechanism import Mechanism

__all__ = ["affected_frames", "apply_deviations", "directly_moved", "with_deviations"]


# --------------------------------------------------------------------------------------------
# The subtree of a dimension, and exact deviations
# --------------------------------------------------------------------------------------------


def _ancestor_frames(model: pin.Model, frame_id: int) -> set[int]:
    """The frame and all frames above it (through ``parentFrame``, up to the universe)."""
    chain = {frame_id}
    while frame_id != 0:
        frame_id = model.frames[frame_id].parentFrame
        chain.add(frame_id)
    return chain


def affected_frames(model: pin.Model, dimension: Dimension) -> np.ndarray:
    """Which frames a deviation of ``dimension`` moves: bool mask, shape (nframes,)."""
    return np.array(
        [dimension.frame_id in _ancestor_frames(model, i) for i in range(len(model.frames))]
    )


def directly_moved(model: pin.Model, dimension: Dimension) -> tuple[list[int], list[int]]:
    """Joints and frames hanging on ``J`` directly whose placement a deviation changes."""
    mask = affected_frames(model, dimension)
    joints = [
        j
        for j in range(1, model.njoints)
        if model.parents[j] == dimension.parent_joint_id
        and model.existFrame(model.names[j], pin.FrameType.JOINT)
        and mask[model.getFrameId(model.names[j], pin.FrameType.JOINT)]
    ]
    frames = [
        i
        for i, f in enumerate(model.frames)
        if mask[i] and f.parentJoint == dimension.parent_joint_id
    ]
    return joints, frames


def apply_deviations(
    model: pin.Model, dimensions: tuple[Dimension, ...], deviations: np.ndarray
) -> pin.Model:
    """A copy of ``model`` carrying the dimension deviations exactly (finite, not linearised).

    Every joint and frame placement of a dimension's subtree that hangs on its parent joint is
    left-multiplied by :meth:`Dimension.displacement`; several dimensions compose in order.

    Args:
        model: the nominal model (not modified).
        dimensions: the toleranced dimensions.
        deviations: ``dd`` [m or rad], shape ``(n_dim,)``.

    Returns:
        The perturbed model.
    """
    deviations = np.asarray(deviations, dtype=float)
    if deviations.shape != (len(dimensions),):
        raise ArgumentError(
            "deviations",
            f"one deviation per dimension [m or rad], shape ({len(dimensions)},)",
            deviations,
            f"shape {deviations.shape}",
        )
    perturbed = model.copy()
    for dimension, dd in zip(dimensions, deviations):
        motion = dimension.displacement(float(dd))
        joints, frames = directly_moved(model, dimension)
        for j in joints:
            perturbed.jointPlacements[j] = motion * perturbed.jointPlacements[j]
        for i in frames:
            frame = perturbed.frames[i]
            frame.placement = motion * frame.placement
            perturbed.frames[i] = frame
    return perturbed


def with_deviations(mechanism: Mechanism, deviations: np.ndarray) -> Mechanism:
    """The manufactured mechanism: a new :class:`~clearance_pin.mechanism.Mechanism` whose model
    carries ``deviations`` (see :func:`apply_deviations`) and whose loops are closed from the
    nominal configuration; everything else (joints, loads, dimensions) is the mechanism's."""
    return mechanism.with_model(
        apply_deviations(mechanism.model, tuple(mechanism.dimensions), deviations)
    )
