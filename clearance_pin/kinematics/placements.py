r"""World placements of every joint and frame without a ``pin.Data`` (for long trees).

Pinocchio's data holds second-order derivative tensors of size :math:`n_v^3`
(:mod:`clearance_pin.model.footprint`): 1.7 GB for a chain of 300 joints, of which the solve of a
mechanism without loops reads only the placements. They follow joint by joint from each joint's
own small data, as Pinocchio's forward kinematics forms them:

.. math::  {}^oM_i = {}^oM_{\lambda(i)}\, ({}^{\lambda(i)}M_i\, M_J(q_i)), \qquad
           {}^oM_f = {}^oM_{parent(f)}\, {}^{parent(f)}M_f

(the same products, so the same numbers as ``pin.framesForwardKinematics``).
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin


def placements_without_data(
    model: pin.Model, q: np.ndarray
) -> tuple[tuple[pin.SE3, ...], tuple[pin.SE3, ...]]:
    """(oMi, oMf) at ``q`` (nq,): the world placement (pin.SE3) of every joint frame (0: the
    ground) and of every frame of ``model``."""
    oMi = [pin.SE3.Identity()]
    for i in range(1, model.njoints):
        joint = model.joints[i]
        motion = joint.createData()
        joint.calc(motion, q)
        oMi.append(oMi[model.parents[i]] * (model.jointPlacements[i] * motion.M))
    oMf = tuple(oMi[frame.parentJoint] * frame.placement for frame in model.frames)
    return tuple(oMi), oMf


__all__ = ["placements_without_data"]
