"""CasADi kinematics of Pinocchio models (the PyPI ``pin`` wheels lack ``pinocchio.casadi``).

Shared math and conventions (all Pinocchio's):

* Placement ``M = (R, p)``, ``R`` in SO(3) (3x3), ``p`` in metres (3x1); it maps child-frame
  coordinates to the parent frame: ``x_parent = R x_child + p``. Composition
  ``A * B = (R_a R_b, R_a p_b + p_a)``, inverse ``(R^T, -R^T p)``.
* Twist ``xi = (v, omega)``, linear part first [m], angular part last [rad].
  ``exp(xi) = (R, p)`` with ``R = I + A [w]x + B [w]x^2``, ``p = (I + B [w]x + C [w]x^2) v``,
  ``A = sin t / t``, ``B = (1 - cos t) / t^2``, ``C = (t - sin t) / t^3``, ``t = |omega|``;
  below ``t^2 < 1e-3`` the coefficients are Taylor series in ``t^2`` (to ``t^6``), so values,
  gradients and Hessians are finite at ``omega = 0``.
* Smooth rotation measure: ``vee((R - R^T) / 2) = sin(t) * axis``.
* Forward kinematics: ``oMi[0] = I``;
  ``oMi[i] = oMi[parent(i)] * jointPlacement[i] * M_i(q_i) * delta_i`` (``delta_i`` an optional
  extra relative placement, default identity); ``oMf = oMi[frame.parentJoint] * frame.placement``.
* Configuration layout as Pinocchio: quaternions ``(x, y, z, w)``, continuous joints
  ``(cos, sin)``, planar ``(x, y, cos, sin)``; ``CasadiKinematics.integrate`` mirrors
  ``pin.integrate`` (``q (+) v``, ``v`` in the joint's local tangent space).
"""

import importlib

_LAZY = {
    **{
        name: "casadi_kinematics"
        for name in (
            "SUPPORTED_JOINTS",
            "CasadiKinematics",
            "JointSpec",
            "casadi_function",
            "joint_integrate",
            "joint_transform",
            "stack_placements",
        )
    },
    **{
        name: "lie_casadi"
        for name in (
            "Placement",
            "act",
            "as_placement",
            "as_sx",
            "axis_angle_rotation",
            "compose",
            "identity",
            "inverse",
            "quat_exp3",
            "quat_multiply",
            "quat_to_rotation",
            "rotation_vee_antisym",
            "se2_exp",
            "se3_exp",
            "skew",
            "so3_exp",
            "vee",
        )
    },
}


def __getattr__(name: str) -> object:
    """Import the CasADi modules on first use: Pinocchio-only callers (loop closure) skip CasADi."""
    if name in _LAZY:
        value = getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
        globals()[name] = value  # once imported, a plain attribute (the API reference reads it)
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = [
    "SUPPORTED_JOINTS",
    "CasadiKinematics",
    "JointSpec",
    "Placement",
    "act",
    "as_placement",
    "as_sx",
    "axis_angle_rotation",
    "casadi_function",
    "compose",
    "identity",
    "inverse",
    "joint_integrate",
    "joint_transform",
    "quat_exp3",
    "quat_multiply",
    "quat_to_rotation",
    "rotation_vee_antisym",
    "se2_exp",
    "se3_exp",
    "skew",
    "so3_exp",
    "stack_placements",
    "vee",
]
