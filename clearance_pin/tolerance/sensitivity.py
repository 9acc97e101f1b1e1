r"""First-order sensitivities of a mechanism's outputs to its toleranced dimensions [F].

P. Flores, "A methodology for quantifying the kinematic position errors due to manufacturing
and assembly tolerances", Strojniski vestnik - J. Mech. Eng. (2011) [F], differentiates the
constraint equations ``Phi(q, d) = 0`` with the driving coordinates fixed:

.. math::

    \Phi_q \, dq + \Phi_d \, dd = 0 \quad\Rightarrow\quad dq = S_q \, dd, \qquad
    S_q = -\Phi_q^{-1} \Phi_d

Here ``Phi`` is the loop closure of :mod:`clearance_pin.kinematics.closure`: the components
that each loop joint constrains of the relative placement of its two frames, in its clearance
frame ``c``, and ``q`` the passive joints. Both Jacobians come from Pinocchio's spatial frame
Jacobians (``pin.WORLD``) at the closed nominal configuration:

.. math::

    \Phi_q = \big[\mathrm{Ad}(oM_c)^{-1} (J_b - J_a)\big]_{rows,\,passive}, \qquad
    \Phi_d = \big[\mathrm{Ad}(oM_c)^{-1} (D_b - D_a)\big]_{rows}

A dimension acts as a *virtual joint* at its joint origin: its spatial column (world, at the
world origin) is ``xi = Ad(oM_J) (u, 0)`` for a length along ``u`` (a prismatic joint) and
``xi = Ad(oM_J) (c x a, a)`` for an angle about ``a`` through the origin ``c`` (a revolute
joint), ``J`` the parent joint; ``D_x`` holds ``xi`` in the columns of the dimensions whose
subtree carries frame ``x`` (:func:`~clearance_pin.tolerance.dimensions.affected_frames`).
``Phi_q`` may have more rows than columns (a planar loop closed in 3-D): ``S_q`` is then the
least-squares solution, and a dimension that the passive joints cannot follow (an
out-of-plane length in an overconstrained loop) is refused.

Outputs (spec strings of :func:`parse_output`): a frame's world position coordinate
``slider.x`` [m], a small rotation of a frame about a world axis ``rod.rz`` [rad] (for a
planar motion about z, the change of the frame's angle), or a 1-DOF joint coordinate
``pin_A`` [rad or m]; ``x4=slider.x`` names it. Their sensitivities:

.. math::

    \frac{d p_f}{dd} = \big[v - p_f \times \omega\big], \quad
    \frac{d \theta_f}{dd} = \omega, \qquad (v, \omega) = J_f \, dq + D_f \, dd
"""

from __future__ import annotations

import re
import warnings
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Literal

import numpy as np
import pinocchio as pin

from ..errors import (
    ArgumentError,
    ClearancePinError,
    ConditioningWarning,
    ModelError,
    NotFoundError,
)
from ..kinematics.closure import (
    closure_jacobian,
    closure_residual,
    idle_motion_count,
    passive_basis,
    passive_velocity_indices,
)
from ..model.clearance import ALPHA
from ..model.dimensions import Dimension
from ..model.frames import frame_id
from .dimensions import affected_frames
from .statistics import rss_band, worst_case_band

if TYPE_CHECKING:
    from ..mechanism import Mechanism

__all__ = [
    "Output",
    "Sensitivities",
    "determined_outputs",
    "dimension_columns",
    "loop_passive_indices",
    "output_deviations",
    "output_values",
    "parse_output",
    "sensitivities",
]

COMPONENTS = {"x": 0, "y": 1, "z": 2, "rx": 0, "ry": 1, "rz": 2}
#: relative residual above which a dimension counts as not absorbable by the passive joints
CONSISTENCY_TOL = 1e-8
#: smallest/largest singular value of the scaled Phi_q under which the position is singular
SINGULAR_TOL = 1e-10


@dataclass(frozen=True)
class Output:
    """One output of a tolerance analysis.

    Attributes:
        name: label in tables and JSON (``"x4"``).
        kind: ``"position"`` [m], ``"orientation"`` [rad] or ``"joint"`` [rad or m].
        target: frame name (position, orientation) or joint name (joint).
        index: frame id or joint id in the Pinocchio model.
        component: 0, 1, 2 for x, y, z (position, orientation); 0 for a joint.
        linear: a joint output whose coordinate is a length (a prismatic joint) [m].
    """

    name: str
    kind: Literal["position", "orientation", "joint"]
    target: str
    index: int
    component: int = 0
    linear: bool = False

    @property
    def unit(self) -> str:
        """``"m"`` (a position, a prismatic joint's coordinate) or ``"rad"``."""
        return "m" if self.kind == "position" or self.linear else "rad"


def parse_output(model: pin.Model, spec: str) -> Output:
    """Read an output spec: ``[NAME=]FRAME.{x,y,z,rx,ry,rz}`` or ``[NAME=]JOINT``.

    Examples: ``"x4=slider.x"`` (world x of the frame ``slider``), ``"theta3=rod.rz"``,
    ``"pin_A"`` (the coordinate of a 1-DOF joint).

    Raises:
        NotFoundError: unknown frame or joint, or a component other than x, y, z, rx, ry, rz
            (the message lists the frames and the joints).
        ArgumentError: a joint with more than one degree of freedom.
    """
    name, _, target = spec.rpartition("=")
    target = target.strip()
    match = re.fullmatch(r"(.+)\.(x|y|z|rx|ry|rz)", target)
    if match and model.existFrame(match.group(1)):
        frame, axis = match.groups()
        kind: Literal["position", "orientation"] = (
            "orientation" if axis.startswith("r") else "position"
        )
        index = frame_id(model, frame)
        assert index is not None  # the frame exists
        return Output(name.strip() or target, kind, frame, index, COMPONENTS[axis])
    if model.existJointName(target) and model.getJointId(target) > 0:
        joint_id = model.getJointId(target)
        if model.joints[joint_id].nv != 1:
            raise ArgumentError(
                f"output {spec!r}",
                "a FRAME.x|y|z|rx|ry|rz or a 1-DOF joint (only their coordinates are outputs)",
                target,
                f"joint {target!r} has {model.joints[joint_id].nv} degrees of freedom",
            )
        prismatic = model.joints[joint_id].shortname().startswith("JointModelP")
        return Output(name.strip() or target, "joint", target, joint_id, 0, prismatic)
    raise _unknown_output(model, spec, target, match)


def _unknown_output(
    model: pin.Model, spec: str, target: str, match: re.Match[str] | None
) -> NotFoundError:
    """The error for an output spec that names no frame and no joint: the frame if the spec
    reads FRAME.component, else the joint, listing the frames and the joints."""
    frames = sorted({f.name for f in model.frames if f.type == pin.FrameType.BODY})
    joints = list(model.names[1:])
    where = f"output {spec!r}"
    form = "an output is FRAME.x|y|z|rx|ry|rz or a 1-DOF joint name"
    if match:
        return NotFoundError(
            "frame", match.group(1), frames, where, f"{form}; the joints are: {', '.join(joints)}"
        )
    return NotFoundError(
        "joint", target, joints, where, f"{form}; the frames are: {', '.join(frames)}"
    )


@dataclass(frozen=True)
class Sensitivities:
    """Sensitivities of the outputs at one closed configuration.

    Attributes:
        q: the closed configuration (nq,).
        outputs: the outputs (rows of ``matrix``).
        dimensions: the dimensions (columns).
        values: nominal output values, shape (n_out,) [m or rad] (orientation: the world
            rotation-vector component, the frame angle for a planar motion).
        matrix: ``S`` [output/dimension], shape (n_out, n_dim).
        passive: ``S_q`` [rad/m or -] of the passive motions
            (:func:`~clearance_pin.kinematics.closure.passive_motions`: every free component of
            the tree joints in loops, spherical ones included), shape (n_passive, n_dim).
        passive_indices: velocity indices of the 1-DOF passive joints in loops.
        conditioning: smallest / largest singular value of the (length-scaled) ``Phi_q``, 1 for
            an open chain; near 0 at a singular position.
    """

    q: np.ndarray
    outputs: tuple[Output, ...]
    dimensions: tuple[Dimension, ...]
    values: np.ndarray
    matrix: np.ndarray
    passive: np.ndarray
    passive_indices: tuple[int, ...]
    conditioning: float
    half_tolerances: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        object.__setattr__(
            self, "half_tolerances", np.array([d.half_tolerance for d in self.dimensions])
        )

    def worst_case(self) -> np.ndarray:
        """Worst-case half bands ``sum_j |S_ij| T_j/2`` [output units], shape (n_out,)."""
        return np.asarray(worst_case_band(self.matrix, self.half_tolerances)).reshape(-1)

    def rss(self) -> np.ndarray:
        """RSS half bands ``sqrt(sum_j (S_ij T_j/2)^2)`` [output units], shape (n_out,)."""
        return np.asarray(rss_band(self.matrix, self.half_tolerances)).reshape(-1)

    def row(self, name: str) -> np.ndarray:
        """The sensitivities of the output called ``name``, shape (n_dim,)."""
        for i, output in enumerate(self.outputs):
            if output.name == name:
                row: np.ndarray = self.matrix[i]
                return row
        raise NotFoundError("output", name, [o.name for o in self.outputs], "Sensitivities.row")


def dimension_columns(
    model: pin.Model,
    data: pin.Data,
    dimensions: tuple[Dimension, ...],
    frame_id: int,
    masks: list[np.ndarray] | None = None,
) -> np.ndarray:
    """Spatial Jacobian columns (world, at the world origin) of the virtual joints, shape (6, n_dim).

    Zero for the dimensions whose subtree does not carry ``frame_id``. Needs the forward
    kinematics in ``data`` (``data.oMi``); ``masks`` are the dimensions'
    :func:`~clearance_pin.tolerance.dimensions.affected_frames`, computed if not given.
    """
    if masks is None:
        masks = [affected_frames(model, d) for d in dimensions]
    columns = np.zeros((6, len(dimensions)))
    for k, dimension in enumerate(dimensions):
        if not masks[k][frame_id]:
            continue
        oMJ = data.oMi[dimension.parent_joint_id]
        axis = oMJ.rotation @ np.asarray(dimension.axis_in_parent_joint)
        if dimension.kind == "length":
            columns[:3, k] = axis
        else:
            point = oMJ.act(np.asarray(dimension.point_in_parent_joint))
            columns[:3, k] = np.cross(point, axis)
            columns[3:, k] = axis
    return columns


def sensitivities(
    mechanism: Mechanism,
    outputs: Iterable[Output | str],
    q: np.ndarray | None = None,
    dimensions: tuple[Dimension, ...] | None = None,
    closed: bool = False,
) -> Sensitivities:
    """Sensitivities ``S = dy/dd`` of the outputs at a configuration [F].

    Args:
        mechanism: :class:`~clearance_pin.mechanism.Mechanism`.
        outputs: :class:`Output` objects or spec strings (:func:`parse_output`).
        q: configuration (nq,), driven joints at their values (default: the nominal one); the
            loops are closed first unless ``closed``.
        dimensions: default: ``mechanism.dimensions``.
        closed: ``q`` already closes the loops (skip :meth:`Mechanism.configure`).

    Returns:
        :class:`Sensitivities`.

    Raises:
        ClearancePinError: no dimensions; a singular position (``Phi_q`` rank-deficient).
        ModelError: a dimension that the passive joints cannot follow (overconstrained loop).
    """
    model = mechanism.model
    dimensions = tuple(mechanism.dimensions if dimensions is None else dimensions)
    if not dimensions:
        raise ClearancePinError(
            f"{mechanism.source}: no toleranced dimension; add <dimension> "
            "elements to the <clearance_pin> block"
        )
    parsed = tuple(o if isinstance(o, Output) else parse_output(model, o) for o in outputs)
    if not closed:
        q = mechanism.configure(q).q
    q = np.asarray(q, dtype=float)
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    pin.computeJointJacobians(model, data, q)
    basis = passive_basis(mechanism)
    masks = [affected_frames(model, d) for d in dimensions]
    s_passive, conditioning, idle = _passive_sensitivities(
        mechanism, data, dimensions, basis, masks
    )
    dq = basis @ s_passive
    _refuse_idle_outputs(model, data, parsed, basis @ idle)
    matrix = (
        np.vstack([_output_row(model, data, dimensions, o, dq, masks) for o in parsed])
        if parsed
        else np.zeros((0, len(dimensions)))
    )
    return Sensitivities(
        q.copy(),
        parsed,
        dimensions,
        output_values(model, data, q, parsed),
        matrix,
        s_passive,
        tuple(loop_passive_indices(mechanism)),
        conditioning,
    )


def loop_passive_indices(mechanism: Mechanism) -> list[int]:
    """Velocity indices of the passive joints that carry a loop frame (the unknowns ``q``).

    A passive joint outside every loop (a free-hanging link) is not determined by the closure;
    it keeps its value (``dq = 0``)."""
    model = mechanism.model
    supporting: set[int] = set()
    for loop in mechanism.loop_joints:
        for frame in (loop.frame_a, loop.frame_b):
            supporting.update(model.supports[model.frames[frame].parentJoint])
    in_loops = {model.joints[j].idx_v for j in supporting if j > 0}
    return [v for v in passive_velocity_indices(mechanism) if v in in_loops]


def _passive_sensitivities(
    mechanism: Mechanism,
    data: pin.Data,
    dimensions: tuple[Dimension, ...],
    basis: np.ndarray,
    masks: list[np.ndarray],
) -> tuple[np.ndarray, float, np.ndarray]:
    """``S_q = -Phi_q^+ Phi_d`` (least squares on length-scaled rows, minimum norm), the
    conditioning, and the idle passive motions (null space of ``Phi_q``: a rod between two ball
    joints spins freely), shape (n_passive, n_idle)."""
    model = mechanism.model
    n_passive = basis.shape[1]
    if not mechanism.loop_joints:
        return np.zeros((0, len(dimensions))), 1.0, np.zeros((0, 0))
    length = mechanism.length_scale()
    _, selections = closure_residual(mechanism, data)
    phi_q: list[np.ndarray] = []
    phi_d: list[np.ndarray] = []
    weights: list[list[float]] = []
    for loop, rows, oMc in selections:
        to_c = oMc.inverse().action
        j_ab = pin.getFrameJacobian(model, data, loop.frame_b, pin.WORLD) - pin.getFrameJacobian(
            model, data, loop.frame_a, pin.WORLD
        )
        d_ab = dimension_columns(model, data, dimensions, loop.frame_b, masks) - dimension_columns(
            model, data, dimensions, loop.frame_a, masks
        )
        phi_q.append((to_c @ j_ab)[rows] @ basis)
        phi_d.append((to_c @ d_ab)[rows])
        weights.append([1.0 if c < ALPHA else length for c in rows])
    w = np.concatenate(weights)[:, None]
    a, b = w * np.vstack(phi_q), w * np.vstack(phi_d)
    # idle motions are structural (counted at the nominal configuration); a rank lost beyond
    # them is a singular position
    idle_count = idle_motion_count(mechanism) if n_passive else 0
    expected = n_passive - idle_count
    if a.size:
        _, singular, vt = np.linalg.svd(a, full_matrices=True)
        idle = vt[expected:].T
    else:
        singular, idle = np.zeros(0), np.zeros((n_passive, 0))
    kept = singular[:expected]
    conditioning = float(kept[-1] / kept[0]) if kept.size and kept[0] > 0 else 0.0
    if expected and (kept.size < expected or conditioning < SINGULAR_TOL):
        raise ClearancePinError(
            f"{mechanism.source}: singular position (conditioning "
            f"{conditioning:.2e} of the loop closure): the sensitivities are "
            "unbounded here"
        )
    if conditioning < 1e-6:
        warnings.warn(
            f"loop closure conditioning {conditioning:.1e}: near a singular position, "
            "the first-order sensitivities lose accuracy",
            ConditioningWarning,
            stacklevel=3,
        )
    if idle.shape[1]:  # minimum norm: no part along the idle motions
        a = a @ (np.eye(n_passive) - idle @ idle.T)
    s = np.linalg.lstsq(a, -b, rcond=None)[0] if a.shape[1] else np.zeros((0, b.shape[1]))
    misfit = np.linalg.norm(a @ s + b, axis=0)
    scale = np.maximum(np.linalg.norm(b, axis=0), 1e-300)
    for k, dimension in enumerate(dimensions):
        if misfit[k] > CONSISTENCY_TOL * scale[k]:
            raise ModelError(
                mechanism.source,
                f"<dimension name='{dimension.name}'>",
                "the passive joints cannot follow this dimension (the loop is "
                "overconstrained in its direction, e.g. an out-of-plane length of a "
                f"planar loop; {misfit[k] / scale[k]:.1e} of its effect is left): "
                "only the joints' play could absorb it; remove it or change direction",
            )
    return s, conditioning, idle


def _refuse_idle_outputs(
    model: pin.Model, data: pin.Data, outputs: Iterable[Output], idle: np.ndarray
) -> None:
    """An output that an idle motion moves (the orientation of a rod spinning freely between
    two ball joints) is not determined by the loop closure: refuse it by name."""
    for output in outputs:
        if _moved_by_idle(model, data, output, idle):
            raise ClearancePinError(
                f"output {output.name!r} moves with an idle motion of the mechanism (a part "
                "that turns freely, such as a rod between two ball joints): the loop closure "
                "does not determine it; choose a frame on a part the loops hold"
            )


def _moved_by_idle(model: pin.Model, data: pin.Data, output: Output, idle: np.ndarray) -> bool:
    """Does an idle motion (columns of ``idle``, velocity space (nv, n_idle)) move the output?"""
    if not idle.size:
        return False
    if output.kind == "joint":
        moved = np.abs(idle[model.joints[output.index].idx_v])
    else:
        twist = pin.getFrameJacobian(model, data, output.index, pin.WORLD) @ idle
        point = data.oMf[output.index].translation
        velocity = twist[:3] - np.cross(point, twist[3:].T).T
        moving = twist[3:] if output.kind == "orientation" else velocity
        moved = np.abs(moving[output.component])
    return bool(np.max(moved, initial=0.0) > 1e-9 * max(1.0, float(np.max(np.abs(idle)))))


def determined_outputs(
    mechanism: Mechanism, outputs: Iterable[Output | str], q: np.ndarray | None = None
) -> tuple[Output, ...]:
    """The outputs that the loop closure determines at ``q`` (default nominal): those no idle
    motion moves (a rod between two ball joints spins freely; its orientation is not one)."""
    model = mechanism.model
    parsed = tuple(o if isinstance(o, Output) else parse_output(model, o) for o in outputs)
    if not mechanism.loop_joints or not idle_motion_count(mechanism):
        return parsed
    q = mechanism.configure(q).q
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    pin.computeJointJacobians(model, data, q)
    basis = passive_basis(mechanism)
    _, selections = closure_residual(mechanism, data)
    length = mechanism.length_scale()
    weights = np.concatenate(
        [[1.0 if c < ALPHA else length for c in rows] for _, rows, _ in selections]
    )
    jacobian = weights[:, None] * closure_jacobian(mechanism, data, selections, basis)
    vt = np.linalg.svd(jacobian, full_matrices=True)[2]
    idle = basis @ vt[basis.shape[1] - idle_motion_count(mechanism) :].T
    return tuple(o for o in parsed if not _moved_by_idle(model, data, o, idle))


def _output_row(
    model: pin.Model,
    data: pin.Data,
    dimensions: tuple[Dimension, ...],
    output: Output,
    dq: np.ndarray,
    masks: list[np.ndarray],
) -> np.ndarray:
    row: np.ndarray
    if output.kind == "joint":
        row = dq[model.joints[output.index].idx_v].copy()
        return row
    twist = pin.getFrameJacobian(model, data, output.index, pin.WORLD) @ dq + dimension_columns(
        model, data, dimensions, output.index, masks
    )
    if output.kind == "orientation":
        row = twist[3 + output.component]
        return row
    point = data.oMf[output.index].translation
    linear = twist[:3] - np.cross(point, twist[3:].T).T  # velocity of the frame origin
    row = linear[output.component]
    return row


def _joint_value(model: pin.Model, q: np.ndarray, joint_id: int) -> float:
    joint = model.joints[joint_id]
    if joint.nq == 2:  # unbounded revolute, (cos, sin)
        return float(np.arctan2(q[joint.idx_q + 1], q[joint.idx_q]))
    return float(q[joint.idx_q])


def output_values(
    model: pin.Model, data: pin.Data, q: np.ndarray, outputs: Iterable[Output]
) -> np.ndarray:
    """Output values [m or rad] at ``q`` (needs ``framesForwardKinematics`` in ``data``).

    Orientation outputs are components of the world rotation vector ``log3(oR_f)``."""
    values: list[float] = []
    for output in outputs:
        if output.kind == "joint":
            values.append(_joint_value(model, q, output.index))
        elif output.kind == "position":
            values.append(float(data.oMf[output.index].translation[output.component]))
        else:
            values.append(float(pin.log3(data.oMf[output.index].rotation)[output.component]))
    return np.array(values)


def output_deviations(
    model0: pin.Model, q0: np.ndarray, model1: pin.Model, q1: np.ndarray, outputs: Iterable[Output]
) -> np.ndarray:
    """Exact output deviations from (model0, q0) to (model1, q1) [m or rad], shape (n_out,).

    Positions: difference of world coordinates; orientations: the world rotation vector
    ``log3(oR_f1 oR_f0^T)``; joints: ``pin.difference`` of the coordinate."""
    d0, d1 = model0.createData(), model1.createData()
    pin.framesForwardKinematics(model0, d0, q0)
    pin.framesForwardKinematics(model1, d1, q1)
    dv = pin.difference(model0, q0, q1)
    values: list[float] = []
    for output in outputs:
        if output.kind == "joint":
            values.append(float(dv[model0.joints[output.index].idx_v]))
        elif output.kind == "position":
            values.append(
                float(
                    d1.oMf[output.index].translation[output.component]
                    - d0.oMf[output.index].translation[output.component]
                )
            )
        else:
            rotation = d1.oMf[output.index].rotation @ d0.oMf[output.index].rotation.T
            values.append(float(pin.log3(rotation)[output.component]))
    return np.array(values)
