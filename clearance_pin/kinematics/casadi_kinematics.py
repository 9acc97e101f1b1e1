"""Forward kinematics of a ``pin.Model`` as CasADi ``SX`` expressions.

The PyPI ``pin`` wheels ship without ``pinocchio.casadi``, so this module rebuilds the
forward kinematics from the model's numbers (joint placements, axes, frame placements
are embedded as constants). Conventions are Pinocchio's (see :mod:`.lie_casadi`):

* ``oMi[0] = I`` (universe) and, for joint ``i`` with parent ``lambda(i)``,
  ``oMi[i] = oMi[lambda(i)] * jointPlacement[i] * M_i(q_i) * delta_i``
  (``delta_i`` an optional extra relative placement, identity by default);
* ``oMf = oMi[frame.parentJoint] * frame.placement``;
* lengths in metres, angles in radians, quaternions stored ``(x, y, z, w)``.

Joint transforms ``M_i(q_i)`` supported (``joint.shortname()``):

* ``JointModelR{X,Y,Z}``, ``JointModelRevoluteUnaligned`` (axis ``a``):
  ``R = cos(q) I + sin(q) [a]x + (1 - cos q) a a^T``;
* ``JointModelRUB{X,Y,Z}``, ``JointModelRevoluteUnboundedUnaligned``, ``q = (c, s)``:
  same with ``(cos q, sin q)`` replaced by ``(c, s)`` (not normalised, as Pinocchio);
* ``JointModelP{X,Y,Z}``, ``JointModelPrismaticUnaligned``: ``p = q a``;
* ``JointModelFreeFlyer``, ``q = (x, y, z, qx, qy, qz, qw)``: ``p = (x, y, z)``,
  ``R = quat_to_rotation(qx, qy, qz, qw)``;
* ``JointModelSpherical``, ``q = (qx, qy, qz, qw)``: ``R = quat_to_rotation(q)``;
* ``JointModelPlanar``, ``q = (x, y, c, s)``: ``p = (x, y, 0)``, ``R = rot_z(c, s)``.

Any other joint type raises :class:`clearance_pin.errors.ModelError` (a ``ValueError``)
at construction, naming the joint and its type.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import casadi as ca
import numpy as np
import pinocchio as pin

from ..errors import ArgumentError, ModelError
from .lie_casadi import (
    Placement,
    PlacementLike,
    SXLike,
    as_placement,
    as_sx,
    axis_angle_rotation,
    compose,
    identity,
    quat_exp3,
    quat_multiply,
    quat_to_rotation,
    se2_exp,
    se3_exp,
)

_AXIS_INDEX = {"X": 0, "Y": 1, "Z": 2}
_REVOLUTE = {f"JointModelR{k}" for k in _AXIS_INDEX}
_REVOLUTE_UNBOUNDED = {f"JointModelRUB{k}" for k in _AXIS_INDEX}
_PRISMATIC = {f"JointModelP{k}" for k in _AXIS_INDEX}
_UNALIGNED = {
    "JointModelRevoluteUnaligned",
    "JointModelRevoluteUnboundedUnaligned",
    "JointModelPrismaticUnaligned",
}
_QUATERNION = {"JointModelFreeFlyer", "JointModelSpherical"}
SUPPORTED_JOINTS = frozenset(
    _REVOLUTE | _REVOLUTE_UNBOUNDED | _PRISMATIC | _UNALIGNED | _QUATERNION | {"JointModelPlanar"}
)


@dataclass(frozen=True)
class JointSpec:
    """Numbers of one joint of a ``pin.Model`` needed to build its kinematics."""

    index: int
    name: str
    kind: str  # joint.shortname()
    parent: int
    idx_q: int
    nq: int
    idx_v: int
    nv: int
    placement: tuple[np.ndarray, np.ndarray]  # jointPlacement (R, p) in the parent joint frame
    axis: np.ndarray  # unit axis in the joint frame (zeros for multi-dof joints)


def _joint_axis(model: pin.Model, index: int, kind: str) -> np.ndarray:
    """Unit axis of a one-dof joint, in its own frame.

    Aligned joints: read from the name. Unaligned: ``joint.extract().axis`` when pin
    exposes it (Revolute/PrismaticUnaligned), else (RevoluteUnboundedUnaligned, which
    has no ``axis`` binding in pin 4.1) the motion subspace ``S`` of ``joint.calc``.
    """
    if kind in _REVOLUTE | _REVOLUTE_UNBOUNDED | _PRISMATIC:
        aligned = np.zeros(3)
        aligned[_AXIS_INDEX[kind[-1]]] = 1.0
        return aligned
    if kind not in _UNALIGNED:
        return np.zeros(3)
    joint = model.joints[index]
    axis: np.ndarray | None = getattr(joint.extract(), "axis", None)
    if axis is None:
        jdata = joint.createData()
        joint.calc(jdata, pin.neutral(model))
        S = np.asarray(jdata.S, dtype=float).reshape(6, -1)[:, 0]
        axis = S[:3] if kind == "JointModelPrismaticUnaligned" else S[3:]
    return np.array(axis, dtype=float).reshape(3)


def _unsupported(index: int, name: str, kind: str) -> ModelError:
    return ModelError(
        "<api>",
        f"<joint '{name}' (index {index})>",
        f"unsupported joint type {kind} for CasADi kinematics; supported: "
        f"{', '.join(sorted(SUPPORTED_JOINTS))}",
    )


def _joint_specs(model: pin.Model) -> list[JointSpec]:
    specs = []
    for i in range(1, model.njoints):
        joint = model.joints[i]
        kind = joint.shortname()
        if kind not in SUPPORTED_JOINTS:
            raise _unsupported(i, model.names[i], kind)
        M = model.jointPlacements[i]
        specs.append(
            JointSpec(
                index=i,
                name=model.names[i],
                kind=kind,
                parent=int(model.parents[i]),
                idx_q=joint.idx_q,
                nq=joint.nq,
                idx_v=joint.idx_v,
                nv=joint.nv,
                placement=(np.array(M.rotation), np.array(M.translation)),
                axis=_joint_axis(model, i, kind),
            )
        )
    return specs


def _rot_about_basis(k: int, c: ca.SX, s: ca.SX) -> ca.SX:
    """Rotation about basis axis ``e_k`` given its cosine ``c`` and sine ``s``."""
    R = ca.SX.eye(3)
    i, j = (k + 1) % 3, (k + 2) % 3
    R[i, i], R[i, j], R[j, i], R[j, j] = c, -s, s, c
    return R


def joint_transform(spec: JointSpec, qj: ca.SX) -> Placement:
    """``M_i(q_i)``: placement of joint ``i``'s child frame in its reference frame.

    ``qj`` is the joint's own configuration slice (SX ``nq x 1``).
    """
    kind = spec.kind
    zero = ca.SX.zeros(3, 1)
    if kind in _REVOLUTE:
        return _rot_about_basis(_AXIS_INDEX[kind[-1]], ca.cos(qj[0]), ca.sin(qj[0])), zero
    if kind in _REVOLUTE_UNBOUNDED:
        return _rot_about_basis(_AXIS_INDEX[kind[-1]], qj[0], qj[1]), zero
    if kind == "JointModelRevoluteUnaligned":
        return axis_angle_rotation(spec.axis, ca.cos(qj[0]), ca.sin(qj[0])), zero
    if kind == "JointModelRevoluteUnboundedUnaligned":
        return axis_angle_rotation(spec.axis, qj[0], qj[1]), zero
    if kind in _PRISMATIC or kind == "JointModelPrismaticUnaligned":
        return ca.SX.eye(3), qj[0] * as_sx(spec.axis, (3, 1))
    if kind == "JointModelFreeFlyer":
        return quat_to_rotation(qj[3:7]), qj[0:3]
    if kind == "JointModelSpherical":
        return quat_to_rotation(qj), zero
    if kind == "JointModelPlanar":
        return _rot_about_basis(2, qj[2], qj[3]), ca.vertcat(qj[0], qj[1], 0)
    raise _unsupported(spec.index, spec.name, kind)


def _first_order_normalize(x: ca.SX) -> ca.SX:
    """Pinocchio's ``firstOrderNormalize``: ``x * (3 - |x|^2) / 2``."""
    return x * (3 - ca.dot(x, x)) / 2


def joint_integrate(spec: JointSpec, qj: ca.SX, vj: ca.SX) -> ca.SX:
    """Mirror of ``pin.integrate`` for one joint: ``q_j (+) v_j`` (SX ``nq x 1``).

    Vector-space joints: ``q + v``. ``RUB*`` (SO(2) as (c, s)): rotate by ``v`` then
    first-order normalise. Spherical: ``quat * exp3(v)`` then first-order normalise.
    FreeFlyer: ``M(q) * exp6(v)``, quaternion sign chosen so that ``dot(out, quat) >= 0``,
    then first-order normalise. Planar: ``M(q) * exp_SE2(v)``.
    """
    kind = spec.kind
    if spec.nq == spec.nv:
        return qj + vj
    if kind in _REVOLUTE_UNBOUNDED or kind == "JointModelRevoluteUnboundedUnaligned":
        c, s = ca.cos(vj[0]), ca.sin(vj[0])
        out = ca.vertcat(c * qj[0] - s * qj[1], s * qj[0] + c * qj[1])
        return _first_order_normalize(out)
    if kind == "JointModelSpherical":
        return _first_order_normalize(quat_multiply(qj, quat_exp3(vj)))
    if kind == "JointModelFreeFlyer":
        quat = qj[3:7]
        _, p_exp = se3_exp(vj)
        pos = quat_to_rotation(quat) @ p_exp + qj[0:3]
        res = quat_multiply(quat, quat_exp3(vj[3:6]))
        res = ca.if_else(ca.dot(res, quat) < 0, -res, res)
        return ca.vertcat(pos, _first_order_normalize(res))
    if kind == "JointModelPlanar":
        R0 = ca.vertcat(ca.horzcat(qj[2], -qj[3]), ca.horzcat(qj[3], qj[2]))
        R, t = se2_exp(vj)
        return ca.vertcat(R0 @ t + qj[0:2], R0 @ R[:, 0])
    raise _unsupported(spec.index, spec.name, kind)


class CasadiKinematics:
    """Forward kinematics of a ``pin.Model`` as CasADi SX expressions.

    Example::

        kin = CasadiKinematics(model)
        q = ca.SX.sym("q", model.nq)
        oMi = kin.joint_placements(q)
        R, p = kin.frame_placement(oMi, model.getFrameId("tool"))
    """

    def __init__(self, model: pin.Model) -> None:
        self.model = model
        self.nq: int = model.nq
        self.nv: int = model.nv
        self.njoints: int = model.njoints
        self.joints: list[JointSpec] = _joint_specs(model)
        self.frames: list[tuple[int, tuple[np.ndarray, np.ndarray]]] = [
            (
                int(f.parentJoint),
                (np.array(f.placement.rotation), np.array(f.placement.translation)),
            )
            for f in model.frames
        ]

    def joint_placements(
        self, q: SXLike, deltas: Mapping[int, PlacementLike] | None = None
    ) -> list[Placement]:
        """``oMi`` (world placement of every joint frame), indices ``0..njoints-1``.

        ``q``: configuration (SX or numpy, size ``nq``). ``deltas``: optional
        ``{joint_index: (R, p) or pin.SE3}``, right-multiplied onto joint ``i``'s frame:
        ``oMi = oM_parent * jointPlacement_i * M_i(q_i) * delta_i``. Index 0 (universe)
        is always the identity and cannot take a delta.
        """
        q = as_sx(q, (self.nq, 1))
        deltas = dict(deltas or {})
        for k in deltas:
            if not isinstance(k, (int, np.integer)) or not 1 <= k < self.njoints:
                raise ArgumentError(
                    f"deltas[{k!r}]", f"a key that is a joint index in 1..{self.njoints - 1}", k
                )
        oMi: list[Placement] = [identity()]
        for spec in self.joints:
            qj = q[spec.idx_q : spec.idx_q + spec.nq]
            M = compose(oMi[spec.parent], spec.placement)
            M = compose(M, joint_transform(spec, qj))
            if spec.index in deltas:
                M = compose(M, as_placement(deltas[spec.index]))
            oMi.append(M)
        return oMi

    def frame_placement(self, joint_placements: Sequence[Placement], frame_id: int) -> Placement:
        """``oMf = oMi[frame.parentJoint] * frame.placement`` for one frame."""
        if not 0 <= frame_id < len(self.frames):
            raise ArgumentError("frame_id", f"a frame index in 0..{len(self.frames) - 1}", frame_id)
        parent, placement = self.frames[frame_id]
        return compose(joint_placements[parent], placement)

    def frame_placements(self, joint_placements: Sequence[Placement]) -> list[Placement]:
        """``oMf`` for every frame of the model, in ``model.frames`` order."""
        return [self.frame_placement(joint_placements, f) for f in range(len(self.frames))]

    def integrate(self, q: SXLike, v: SXLike) -> ca.SX:
        """Mirror of ``pin.integrate(model, q, v)`` (SX ``nq x 1``), see :func:`joint_integrate`."""
        q = as_sx(q, (self.nq, 1))
        v = as_sx(v, (self.nv, 1))
        out = [q[k] for k in range(self.nq)]
        for spec in self.joints:
            qj = q[spec.idx_q : spec.idx_q + spec.nq]
            vj = v[spec.idx_v : spec.idx_v + spec.nv]
            res = joint_integrate(spec, qj, vj)
            for k in range(spec.nq):
                out[spec.idx_q + k] = res[k]
        return ca.vertcat(*out)


def stack_placements(placements: Sequence[Placement]) -> ca.SX:
    """``[R_0 p_0 R_1 p_1 ...]``, an SX ``3 x 4n`` matrix."""
    return ca.horzcat(*[ca.horzcat(R, p) for R, p in placements])


def casadi_function(model: pin.Model) -> ca.Function:
    """``casadi.Function`` ``q -> (oMi, oMf)``, each a ``3 x 4n`` stack ``[R_k p_k ...]``
    over joints (``n = njoints``) and frames (``n = nframes``)."""
    kin = CasadiKinematics(model)
    q = ca.SX.sym("q", model.nq)
    oMi = kin.joint_placements(q)
    oMf = kin.frame_placements(oMi)
    return ca.Function(
        "forward_kinematics",
        [q],
        [stack_placements(oMi), stack_placements(oMf)],
        ["q"],
        ["oMi", "oMf"],
    )
