r"""The model of the measured differences: how the measured point moves with each drive's backlash
and compliance (docs/identification.md, section 2).

Under load case :math:`l` at pose :math:`p` the point moves by

.. math::  x_{pl} = o_p + f_{pl} + \sum_j s_j(q_p) \left( \mathrm{sign}(\tau_{jpl})\,
           \frac{b_j}{2} + \tau_{jpl}\, c_j \right), \qquad c_j = 1 / k_j

(:math:`o_p` the pose's unknown offset: the device's placement and the robot's geometric error at
that pose; :math:`f_{pl}` what the rest of the clearance file moves it: the bearings' play and
compliance; :math:`s_j` the point's motion per unit motion of drive :math:`j` [m/rad, and rad/rad
for the rotation]; :math:`\tau_{jpl}` the generalised force of the loads on joint :math:`j`
[N m or N], the arm's own weight included when gravity is on). Linear in
:math:`\theta = (b_j, c_j)` once the signs are known, and they are: the loads' torques set them.

Everything comes from the project's own solver: one ``solve_many`` of the mechanism with its
drives made rigid and without backlash (its bearings' play and compliance kept) gives
:math:`f_{pl}` (the point's displacement) and :math:`\tau_{jpl}` (each drive's torque, minus
what it holds); :math:`s_j` is the point's lever about joint :math:`j`'s axis at the pose
(:func:`~clearance_pin.kinematics.joint_shares.joint_levers`). For a tree the play and the
springs superpose (docs/method.md 2.2.2), so this is exact in the small-displacement model.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from ..errors import ArgumentError, NotFoundError, SolverError, UnsupportedError
from ..kinematics.joint_shares import joint_levers, moved_by
from ..model.frames import frame_id as find_frame
from ..model.frames import parse_point, point_name
from ..model.loads import PointForce

if TYPE_CHECKING:
    from ..model.joints import TreeJoint
    from ..model.mechanism_parts import MechanismParts as Mechanism

KINDS = ("backlash", "drive_stiffness")
ZERO_TORQUE = 1e-9  # a change of torque below this share of the largest torque: no change
B_REF = 1e-4  # [rad or m] the reference's backlash (any value > 0 gives the same model)
SIDE_RTOL = 1e-6  # a turn within this share of B_REF / 2 of its stop: the side is taken up

__all__ = [
    "KINDS",
    "DifferenceModel",
    "MeasuredPoint",
    "Parameter",
    "difference_model",
    "measured_point",
    "with_drives",
]


@dataclass(frozen=True)
class MeasuredPoint:
    """The measured point: a Pinocchio frame and an offset in it.

    Attributes:
        frame: the frame's name.
        offset: the point in the frame [m] (3,).
        frame_id: the frame's index.
        link: the link that carries it (a load there is a ``PointForce`` on it).
        link_point: the point in that link's frame [m] (3,).
    """

    frame: str
    offset: np.ndarray
    frame_id: int
    link: str
    link_point: np.ndarray

    @property
    def label(self) -> str:
        """``FRAME@[x y z]``, as outputs are named everywhere (:mod:`..model.frames`)."""
        return point_name(self.frame, self.offset)


def measured_point(mechanism: Mechanism, point: Any) -> MeasuredPoint:
    """``point``: a frame name, ``"FRAME@[x y z]"`` or ``(frame, xyz)`` (xyz [m] in the frame;
    the same spelling as every output, :mod:`..model.frames`)."""
    if isinstance(point, str):
        parsed = parse_point(point)
        frame, offset = (point.strip(), np.zeros(3)) if parsed is None else parsed
    elif isinstance(point, (tuple, list)) and len(point) == 2 and isinstance(point[0], str):
        frame, offset = point[0], np.asarray(point[1], dtype=float)
    else:
        raise ArgumentError("point", "a frame name, 'FRAME@[x y z]' or (frame, [x, y, z])", point)
    if offset.shape != (3,) or not np.isfinite(offset).all():
        raise ArgumentError("point", "three finite coordinates [m] in the frame", point)
    model = mechanism.model
    index = find_frame(model, frame)
    if index is None:
        raise NotFoundError("frame", frame, [f.name for f in model.frames], "point")
    link, _ = mechanism.link_point(frame)
    link_id = mechanism.link_frames[link]
    # the point in the link's frame: the frame's placement in the link's, applied to the offset
    placed = model.frames[link_id].placement.actInv(model.frames[index].placement)
    link_point = placed.act(offset)
    return MeasuredPoint(frame, offset.copy(), index, link, link_point)


def parameter_unit(kind: str, prismatic: bool) -> str:
    """The unit of a drive parameter: backlash [rad, or m for a sliding drive], stiffness
    [N m/rad, or N/m]."""
    if kind == "backlash":
        return "m" if prismatic else "rad"
    return "N/m" if prismatic else "N m/rad"


@dataclass(frozen=True)
class Parameter:
    """One unknown of the fit.

    Attributes:
        joint: the driven joint.
        kind: ``"backlash"`` (b [rad, or m for a prismatic drive]) or ``"drive_stiffness"``
            (k [N m/rad, or N/m]; fitted as its compliance c = 1/k).
        prior: the clearance file's value (b; k, ``inf`` for a rigid drive).
        prismatic: the drive slides (b [m], k [N/m]).
    """

    joint: str
    kind: str
    prior: float
    prismatic: bool = False

    @property
    def unit(self) -> str:
        return parameter_unit(self.kind, self.prismatic)

    @property
    def prior_column(self) -> float:
        """The prior's value in the fit's unknown: b, or c = 1/k (0 for a rigid drive)."""
        return self.prior if self.kind == "backlash" else 1.0 / self.prior


@dataclass(frozen=True)
class DifferenceModel:
    """The measured point's displacement, linear in the drives' parameters (module docstring).

    Rows i are the measurements (M); d = 3 (position) or 6 (position, then rotation).

    Attributes:
        point: the measured point.
        joints: the drives, in the order of the parameters.
        parameters: (b_j, k_j) of every drive, in that order (2 J).
        fixed: what the bearings' play and compliance move the point, (M, d) [m, rad].
        columns: d x_i / d theta, (M, d, 2 J): b_j's column is s_j sign(tau_j) / 2, c_j's
            s_j tau_j.
        torques: the loads' generalised force on each drive (M, J) [N m or N].
        signs: the side each drive's backlash is taken up on (M, J): -1, 0 (no torque), +1.
        levers: s_j, the point's motion per unit motion of each drive (M, d, J).
        gravity: the arm's own weight was among the loads.
    """

    point: MeasuredPoint
    joints: tuple[str, ...]
    parameters: tuple[Parameter, ...]
    fixed: np.ndarray
    columns: np.ndarray
    torques: np.ndarray
    signs: np.ndarray
    levers: np.ndarray
    gravity: bool

    def prior(self) -> np.ndarray:
        """theta of the clearance file: (b_j, c_j) (2 J,)."""
        return np.array([p.prior_column for p in self.parameters])

    def predict(self, theta: np.ndarray) -> np.ndarray:
        """The point's displacement (M, d) at parameters ``theta`` (2 J,), pose offsets left
        out."""
        predicted: np.ndarray = self.fixed + self.columns @ theta
        return predicted


def driven_chain(mechanism: Mechanism, frame_id: int, joints: Any = None) -> list[TreeJoint]:
    """The driven one-coordinate joints between the ground and the frame (``joints``: their
    names, a subset), in the tree's order; refuses what the linear model does not cover."""
    if mechanism.loop_joints:
        raise UnsupportedError(
            f"{mechanism.name}: identify covers trees (serial arms); this mechanism has loop "
            f"joints ({', '.join(j.name for j in mechanism.loop_joints)})"
        )
    model = mechanism.model
    chain = set()
    body = model.frames[frame_id].parentJoint
    while body:
        chain.add(body)
        body = model.parents[body]
    driven = [
        j
        for j in mechanism.tree_joints
        if j.joint_id in chain and j.driven and j.motion_component is not None
    ]
    if joints is not None:
        names = [str(name) for name in joints]
        known = {j.name for j in driven}
        for name in names:
            if name not in known:
                raise NotFoundError("driven joint", name, sorted(known), "identify(joints=...)")
        driven = [j for j in driven if j.name in names]
    if not driven:
        raise ArgumentError(
            "point", "a point that a driven joint moves", model.frames[frame_id].name
        )
    fitted = {j.name for j in driven}
    for coupling in mechanism.couplings:
        follower = mechanism.joints[coupling.follower]
        if coupling.leader in fitted and getattr(follower, "joint_id", None) in chain:
            raise UnsupportedError(
                f"{mechanism.name}: {coupling.follower} follows {coupling.leader} between the "
                "ground and the measured point; identify does not cover coupled drives"
            )
    return driven


def drive_values(joint: TreeJoint) -> tuple[float, float]:
    """(backlash, drive stiffness; inf for a rigid drive) of a driven joint, SI."""
    k = 0.0
    stiffness = joint.clearance.stiffness
    if stiffness is not None and joint.motion_component is not None:
        k = float(stiffness[joint.motion_component][joint.motion_component])
    return float(joint.clearance.backlash), (k if k > 0.0 else np.inf)


def with_drives(mechanism: Mechanism, values: dict[str, tuple[float, float]]) -> Mechanism:
    """The same mechanism with drive ``name``'s backlash b and drive stiffness k set to
    ``values[name] = (b, k)`` (k = inf: a rigid drive); its values not checked again."""
    joints = []
    for joint in mechanism.tree_joints:
        if joint.name not in values:
            joints.append(joint)
            continue
        b, k = values[joint.name]
        m = joint.motion_component
        assert m is not None
        matrix = np.zeros((6, 6))
        if joint.clearance.stiffness is not None:
            matrix = np.array(joint.clearance.stiffness, dtype=float)
        matrix[m, :] = 0.0
        matrix[:, m] = 0.0
        if np.isfinite(k):
            matrix[m, m] = k
        stiffness = tuple(tuple(float(v) for v in row) for row in matrix) if matrix.any() else None
        clearance = replace(joint.clearance, backlash=float(b), stiffness=stiffness)
        joints.append(replace(joint, clearance=clearance))
    return mechanism.rebuilt(mechanism.model, tuple(joints), mechanism.loop_joints)


def difference_model(
    mechanism: Mechanism,
    point: MeasuredPoint,
    configurations: np.ndarray,
    forces: np.ndarray,
    joints: Any = None,
    gravity: Any = None,
    rotations: bool = False,
) -> DifferenceModel:
    """The model of the point's displacement at each row (module docstring).

    Args:
        mechanism: the robot with its clearance file's values (the priors).
        point: the measured point (:func:`measured_point`).
        configurations: q of each row (M, nq).
        forces: the force at the point of each row (M, 3) [N], world axes.
        joints: the drives to model (default: every driven joint that moves the point).
        gravity: the arm's own weight: None as the model says, True or False.
        rotations: model the point's rotation too (d = 6).

    Raises:
        SolverError: a row the solver could not verify (its line is in the message).
    """
    chain = driven_chain(mechanism, point.frame_id, joints)
    names = tuple(j.name for j in chain)
    parameters = []
    for joint in chain:
        b, k = drive_values(joint)
        slides = joint.motion_component == 0
        parameters += [
            Parameter(joint.name, "backlash", b, slides),
            Parameter(joint.name, "drive_stiffness", k, slides),
        ]
    # the reference: rigid drives with a backlash B_REF (a tree's play, backlash and springs
    # superpose, so its value is immaterial; with it every drive's side is the solver's own)
    reference = with_drives(mechanism, {name: (B_REF, np.inf) for name in names})
    q = np.asarray(configurations, dtype=float)
    forces = np.asarray(forces, dtype=float)
    rows = len(q)
    cases = [[PointForce(point.link, f, point.link_point)] if np.any(f) else [] for f in forces]
    batch = reference.solve_many(cases, configurations=list(q), gravity=gravity, errors="return")
    ok = batch.ok
    if not ok.all():
        first = int(np.flatnonzero(~ok)[0])
        raise SolverError(
            f"measurement {first} (q={np.round(q[first], 6).tolist()}): no verified "
            f"equilibrium of the robot: {batch[first]}",
            "failed",
        )
    translation, rotation = batch.frame_displacements(point.frame)
    held = batch.drive_torques()
    torques = -np.column_stack([held[name] for name in names])  # the loads' generalised force
    turns = np.column_stack(  # each drive's backlash turn (slide), +/- B_REF / 2 or inside
        [batch.torsors(j.name)[:, j.motion_component] for j in chain]
    )
    taken = np.abs(turns) >= (1.0 - SIDE_RTOL) * 0.5 * B_REF
    signs = np.where(taken, np.sign(turns), 0.0)  # inside the backlash: no torque, no side
    # the poses: levers and the frame's axes once per distinct q
    unique, inverse = np.unique(q, axis=0, return_inverse=True)
    inverse = np.asarray(inverse).reshape(-1)
    model = mechanism.model
    data = model.createData()
    frame_axes = np.zeros((len(unique), 3, 3))
    for k, pose in enumerate(unique):
        pin.forwardKinematics(model, data, pose)
        frame_axes[k] = pin.updateFramePlacement(model, data, point.frame_id).rotation
    offset = frame_axes @ point.offset  # (U, 3): frame origin -> point, world axes
    levers_by_joint = joint_levers(model, tuple(chain), point.frame_id, unique)
    d = 6 if rotations else 3
    levers = np.zeros((rows, d, len(chain)))
    for j, joint in enumerate(chain):
        axes, arms = levers_by_joint[joint.name]
        unit = np.zeros((len(unique), 6))
        assert joint.motion_component is not None
        unit[:, joint.motion_component] = 1.0
        moved, turned = moved_by(axes, arms + offset, unit)
        levers[:, :3, j] = moved[inverse]
        if rotations:
            levers[:, 3:, j] = turned[inverse]
    fixed = np.zeros((rows, d))
    fixed[:, :3] = translation + np.cross(rotation, offset[inverse])
    if rotations:
        fixed[:, 3:] = rotation
    fixed -= np.einsum("mdj,mj->md", levers, turns)  # the reference's backlash taken out
    columns = np.zeros((rows, d, 2 * len(chain)))
    columns[:, :, 0::2] = levers * (0.5 * signs)[:, None, :]
    columns[:, :, 1::2] = levers * torques[:, None, :]
    used_gravity = bool(reference.resolve_loads([], gravity))
    return DifferenceModel(
        point, names, tuple(parameters), fixed, columns, torques, signs, levers, used_gravity
    )
