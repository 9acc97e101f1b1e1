"""The answer of a solve: an :class:`Equilibrium` that carries its own status and residuals.

Conventions: SI units; a joint torsor is (u, v, w, alpha, beta, gamma) [m, rad] of the child part
relative to the parent at the joint centre, in the joint's clearance frame (x = joint axis).
A contact force [N] is the force the parent part exerts on the child at a contact point, in the
joint's (parent-side) clearance frame axes; ``Contact.position`` is that point in the same frame and
``Contact.world_position`` in the world. Small-displacement model: at the nominal pose (the child's
contact point at its nominal place); exact model: at the solved pose (the child's contact point
where it is, in the parent-side clearance frame where it is).
A joint reaction (:meth:`Equilibrium.reaction`, :class:`~.reactions.Reaction`) is the wrench [N, N m]
the parent part exerts on the child through the joint: clearance-frame axes and moment about the
joint centre (``frame="joint"``), or world axes and moment about the world origin
(``frame="world"``); contact forces + rigid directions + drive. A body twist is at the world
origin, world axes; loads are given in world axes.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Literal, cast

import numpy as np
import pinocchio as pin

from ..errors import ArgumentError, NotFoundError
from ..kinematics.joint_shares import joint_levers, moved_by
from ..kinematics.loop_frames import RIGID_TOLERANCE
from ..model.couplings import chain_multipliers
from ..model.frames import frame_id as find_frame
from .displacement import Displacement, displacement_in
from .method import Method
from .outputs import OutputPoint, output_displacements, resolve_outputs
from .reactions import Reaction, joint_reactions
from .report import report
from .residuals import Residuals

if TYPE_CHECKING:  # the mechanism module imports this one
    from ..check.report import CheckReport
    from ..model.loads import Load
    from ..model.mechanism_parts import ConfigurationParts as Configuration
    from ..model.mechanism_parts import MechanismParts as Mechanism

Formulation = Literal["linear", "exact"]
Status = Literal["optimal", "indeterminate"]


@dataclass(frozen=True)
class Contact:
    """One contact point of one joint at the equilibrium.

    Attributes:
        joint: joint name.
        point: contact point name within the joint (``ball``, ``end-``, ``end+``, ``axial``, ...).
        gap: remaining play at that point [m] (0 in contact, > 0 free).
        clearance: the clearance that bounds the point [m].
        force: force of the parent on the child at that point [N], clearance frame, (3,).
        active: the point touches (gap within tolerance of zero and a force may act).
        position: where the force acts [m], (3,): the child's contact point in the same
            clearance frame as ``force``; small-displacement model: its nominal place, exact
            model: where it is at the solved pose.
        world_position: the same point in world coordinates [m], (3,) (nominal pose for the
            small-displacement model, solved pose for the exact one).
        moment: a drive's backlash stop (``point == "backlash"`` of a revolute joint): the moment
            [N m] the parent exerts on the child about the joint axis, same frame, (3,); its
            ``force`` is zero. None for a point contact.
    """

    joint: str
    point: str
    gap: float
    clearance: float
    force: np.ndarray
    active: bool
    position: np.ndarray | None = None
    world_position: np.ndarray | None = None
    moment: np.ndarray | None = None

    @property
    def label(self) -> str:
        """``joint:point``."""
        return f"{self.joint}:{self.point}"

    @property
    def force_magnitude(self) -> float:
        """|force| [N]."""
        return float(np.linalg.norm(self.force))


@dataclass(frozen=True)
class Equilibrium:
    """Quasi-static equilibrium of a mechanism in its joint clearances (immutable).

    Attributes:
        formulation: ``"linear"`` (small displacements, [Y]) or ``"exact"`` (finite rigid motions).
        torsors: joint name -> torsor (6,) [m, rad], clearance frame at the joint centre.
        body_motions: body (Pinocchio joint) name -> (translation of its frame origin [m],
            rotation vector [rad]), world axes.
        contacts: every contact point with its gap and force (active ones carry the load).
        energy: potential of the loads at the equilibrium [J].
        status: ``"optimal"``, or ``"indeterminate"`` (no load on any admissible motion).
        method: the engine that answered (:class:`~.method.Method`): closed form, compiled
            Newton, Clarabel, IPOPT, ...; the same call takes the same engine in every process
            (:mod:`.plan`).
        solver_status: the optimiser's own status text.
        iterations: optimiser iterations.
        residuals: the residuals measured by the library (:class:`~.residuals.Residuals`:
            KKT, statics, penetration, and per formulation closure conditioning or closure).
        free_motions: motions that no contact sees, left at zero (minimum-norm optimum).
        build_time, solve_time: [s]; build_time is 0 when a built problem was re-used.
        polished: the active-set Newton polish was accepted.
        difference: when both formulations ran, exact - linear where users look, at the
            outputs (:attr:`outputs`): ``{"translation_m", "rotation_rad"}``: the largest norm
            over the outputs [m, rad]; ``"outputs"``: name -> (translation (3,) [m], rotation
            (3,) [rad]), world axes; ``"torsor_translation_m"``, ``"torsor_rotation_rad"``: the
            largest difference of a joint torsor component [m, rad].
        difference_bound: ``exact="auto"``: the estimate of that difference at every output,
            from the linear answer alone (:mod:`.second_order`): ``{"translation_m",
            "rotation_rad", "outputs": name -> (bound [m], bound [rad]), "reliable", "reason"}``.
        output_points: the points whose displacement :attr:`outputs` reports
            (:class:`~.outputs.OutputPoint`; empty: the leaf links).
        linear: the small-displacement equilibrium that seeded an exact solve, if any.
        body_placements: world placement (pin.SE3) of every Pinocchio joint frame at the solved
            pose, index = joint id (0 = ground). Exact: the finite motion; linear: the rigid
            motion exp(xi_b) oM_b0 of each body's small twist.
        mechanism: the solved :class:`~clearance_pin.mechanism.Mechanism`.
        configuration: its nominal :class:`~clearance_pin.mechanism.Configuration`.
        body_twists: linear formulation: the spatial twist (v, omega) at the world origin of every
            body, shape (njoints, 6) [m, rad].
        note: how the formulation was chosen (``exact="auto"``).
        deflections: joint name -> the elastic deflection (6,) [m, rad] its stiffness adds to its
            play, clearance frame (joints with stiffness only; None without any;
            :meth:`deflection`).
        loads: the loads the equilibrium was solved for (gravity included), None when unknown;
            :meth:`reaction` needs them.
    """

    formulation: Formulation
    torsors: Mapping[str, np.ndarray]
    body_motions: Mapping[str, tuple[np.ndarray, np.ndarray]]
    contacts: Sequence[Contact]
    energy: float
    status: Status
    method: Method
    solver_status: str
    iterations: int
    residuals: Residuals
    free_motions: Sequence[str]
    build_time: float
    solve_time: float
    polished: bool = False
    difference: dict[str, Any] | None = None
    linear: Equilibrium | None = None
    body_placements: Sequence[pin.SE3] = ()
    mechanism: object = field(default=None, repr=False, compare=False)
    configuration: object = field(default=None, repr=False, compare=False)
    body_twists: np.ndarray | None = field(default=None, repr=False, compare=False)
    note: str = ""
    loads: tuple[Load, ...] | None = field(default=None, repr=False)
    output_points: tuple[OutputPoint, ...] = field(default=(), repr=False)
    difference_bound: dict[str, Any] | None = None
    deflections: Mapping[str, np.ndarray] | None = field(default=None, repr=False)

    @property
    def ok(self) -> bool:
        """Residuals within tolerance (:meth:`.residuals.Residuals.ok`): every contact inside its
        play (to 1e-9 of that play), the loop closure held (exact model), the contact forces
        balancing the load (statics; exact model: no more than 1e-8 of it held by the gauge),
        and no contact pulling (dual feasibility)."""
        return self.residuals.ok()

    def torsor(self, joint: str) -> np.ndarray:
        """Torsor (u, v, w, alpha, beta, gamma) [m, rad] of ``joint`` in its clearance frame."""
        if joint not in self.torsors:
            raise NotFoundError("joint", joint, tuple(self.torsors))
        return self.torsors[joint].copy()

    def deflection(self, joint: str) -> np.ndarray:
        """The elastic deflection (u, v, w, alpha, beta, gamma) [m, rad] of ``joint`` in its
        clearance frame: the part of :meth:`torsor` its stiffness gives (zero for a rigid joint);
        ``torsor(joint) - deflection(joint)`` is its play."""
        if joint not in self.torsors:
            raise NotFoundError("joint", joint, tuple(self.torsors))
        deflection = (self.deflections or {}).get(joint)
        return np.zeros(6) if deflection is None else deflection.copy()

    def frame_placement(self, frame: str) -> pin.SE3:
        """World placement of a Pinocchio frame at the solved pose (linear: its body moved by the
        rigid motion exp(xi_b) of its small twist; exact: the finite motion)."""
        frame_id, body = self._frame(frame)
        model = cast("Mechanism", self.mechanism).model
        return self.body_placements[body] * model.frames[frame_id].placement

    def frame_displacement(
        self, frame: str, reference_frame: pin.ReferenceFrame = pin.LOCAL_WORLD_ALIGNED
    ) -> Displacement:
        """Displacement of a Pinocchio frame from its nominal pose, a ``pin.Motion`` (linear [m],
        angular [rad]) in ``reference_frame`` (:mod:`.displacement`: ``pin.LOCAL_WORLD_ALIGNED``,
        the default, is the translation of the frame's origin and the rotation vector, world
        axes; ``pin.LOCAL``: the frame's nominal axes; ``pin.WORLD``: the point at the world
        origin). It also unpacks as ``translation, rotation``.

        Linear formulation: :math:`(v_b + \\omega_b \\times p_f, \\omega_b)` from the body twist;
        exact: the finite displacement, rotation as a rotation vector (log3).
        """
        frame_id, body = self._frame(frame)
        model = cast("Mechanism", self.mechanism).model
        nominal = cast("Configuration", self.configuration).oMf[frame_id]
        if self.body_twists is not None:
            twist = self.body_twists[body]
            translation = twist[:3] + np.cross(twist[3:], nominal.translation)
            rotation = twist[3:].copy()
        else:
            moved = self.body_placements[body] * model.frames[frame_id].placement
            translation = moved.translation - nominal.translation
            rotation = np.asarray(pin.log3(moved.rotation @ nominal.rotation.T))
        return displacement_in(translation, rotation, nominal, reference_frame)

    def contributions(self, frame: str) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """What each joint's play moves a Pinocchio frame: joint name -> (translation (3,) [m],
        rotation (3,) [rad]), world axes, largest first (:mod:`..kinematics.joint_shares`:
        :math:`R_j v_j + (R_j \\omega_j) \\times (p - c_j)`, the joints between the ground and
        the frame). The shares sum to the small-displacement model's :meth:`frame_displacement`
        (to first order in the rotations for an exact answer); joints that do not move the frame
        are left out."""
        frame_id, _ = self._frame(frame)
        mechanism = cast("Mechanism", self.mechanism)
        q = cast("Configuration", self.configuration).q
        levers = joint_levers(mechanism.model, mechanism.tree_joints, frame_id, q[None])
        shares = {}
        for name, (axes, arms) in levers.items():
            moved, turned = moved_by(axes, arms, self.torsors[name][None])
            if np.any(moved) or np.any(turned):
                shares[name] = (moved[0], turned[0])
        return dict(sorted(shares.items(), key=lambda item: -float(np.linalg.norm(item[1][0]))))

    def _frame(self, frame: str) -> tuple[int, int]:
        """(frame id, its parent joint) of a Pinocchio frame name; NotFoundError naming the
        frames otherwise."""
        mechanism = cast("Mechanism", self.mechanism)
        model = mechanism.model
        frame_id = find_frame(model, frame)
        if frame_id is None:
            raise NotFoundError("frame", frame, [f.name for f in model.frames], mechanism.name)
        return frame_id, int(model.frames[frame_id].parentJoint)

    @property
    def outputs(self) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        r"""World displacement of every output: name -> (translation (3,) [m] of the frame's
        origin or of the load point, rotation (3,) [rad]), world axes. Outputs: the loaded points
        (``link@[x y z]``, link frame) and the frames asked for in ``solve(outputs=...)``
        (default: the leaf links). Linear: :math:`(v + \omega \times p, \omega)`; exact: the
        finite displacement, rotation as log3 (:mod:`.outputs`)."""
        points = self.output_points or resolve_outputs(self.mechanism, self.loads or ())
        return output_displacements(self, points)

    def reaction(self, joint: str, frame: str = "joint") -> Reaction:
        """The wrench the parent part exerts on the child part through ``joint`` (for a loop
        joint the parent is ``frame_a``'s part): contact forces + rigid directions + drive torque.

        Args:
            joint: joint name (tree or loop).
            frame: ``"joint"``: clearance-frame axes, moment about the joint centre (nominal pose
                for the small-displacement model, parent side at the solved pose for the exact
                one); ``"world"``: world axes, moment about the world origin.

        Returns:
            :class:`~clearance_pin.equilibrium.reactions.Reaction` (force [N], moment [N m],
            its parts and the residual of the per-body statics they were recovered from).
        """
        reactions = self.__dict__.get("_reactions")
        if reactions is None:  # computed once per answer (a cache, not part of its value)
            reactions = joint_reactions(self)
            self.__dict__["_reactions"] = reactions
        return reactions.reaction(joint, frame)

    def drive_torque(self, joint: str) -> float:
        """The torque [N m] (force [N] for a prismatic drive) that ``joint``'s drive exerts on the
        child about (along) the joint axis: the drive part of its reaction, or with backlash what
        its stop holds; 0 for a joint that is not driven. It balances the loads: minus their
        generalised force on the joint (:math:`g(q) - J^T F` for a serial arm, g the weight's).
        A coupling's follower's is the torque the coupling holds (:meth:`motor_torques` gives it
        to the leader)."""
        reaction = self.reaction(joint)
        mechanism = cast("Mechanism", self.mechanism)
        component = 0 if getattr(mechanism.joints[joint], "motion_component", None) == 0 else 3
        held = float(reaction.drive[component])
        for c in self.contacts:
            if c.joint == joint and c.point == "backlash":
                stop = np.concatenate([c.force, np.zeros(3) if c.moment is None else c.moment])
                held += float(stop[component])
        return held

    def motor_torques(self) -> dict[str, float]:
        r"""Per motor (a driven joint that is no coupling's follower): the torque [N m] (force
        [N]) it exerts, its own :meth:`drive_torque` plus, for a coupling's leader, m times each
        follower's, through chains of any depth the product of the multipliers (virtual work of
        the coupling :math:`q_f = m q_l + o`: :math:`\tau_l\, \delta q_l + \tau_f\, m\,
        \delta q_l`; :func:`~clearance_pin.model.couplings.chain_multipliers`). With backlash it
        is what the motor's stop holds."""
        mechanism = cast("Mechanism", self.mechanism)
        couplings = getattr(mechanism, "couplings", ())
        followers = {c.follower for c in couplings}
        motors = {
            j.name: self.drive_torque(j.name)
            for j in mechanism.tree_joints
            if j.driven and j.name not in followers
        }
        for follower, (motor, factor) in chain_multipliers(couplings, mechanism.joints).items():
            if motor in motors:
                motors[motor] += factor * self.drive_torque(follower)
        return motors

    @property
    def eccentricities(self) -> dict[str, tuple[np.ndarray, np.ndarray]]:
        """Loop joints with a nominal eccentricity (a misaligned housing inside its play): name ->
        (translation (3,) [m], rotation vector (3,) [rad]) of the child's clearance frame in the
        parent's at the nominal configuration, parent clearance-frame axes
        (:meth:`~clearance_pin.mechanism.Configuration.eccentricity`); aligned joints are left out.
        The joint's torsor is its motion from that eccentric place."""
        found = {}
        mechanism = cast("Mechanism", self.mechanism)
        configuration = cast("Configuration", self.configuration)
        for loop in getattr(mechanism, "loop_joints", ()):
            offset = configuration.eccentricity(loop)
            translation, rotation = offset.translation.copy(), pin.log3(offset.rotation)
            length = max(mechanism.length_scale(), 1.0)
            size = max(float(np.abs(translation).max()), length * float(np.abs(rotation).max()))
            if size > RIGID_TOLERANCE * length:  # beyond the closure's round-off
                found[loop.name] = (translation, rotation)
        return found

    @property
    def active_contacts(self) -> tuple[Contact, ...]:
        """The contacts that carry load."""
        return tuple(c for c in self.contacts if c.active)

    def check(self, **options: Any) -> CheckReport:
        """Measure the solved pose with coal (see :mod:`clearance_pin.check`): ``options`` of
        :func:`~clearance_pin.check.check_equilibrium` (``pose``, ``bores``, ``journal_radius``,
        ``facets``, ``mesh_faceting``, ``gjk_tolerance``; a small-displacement answer is judged
        on its exact pose unless ``pose="as_solved"``)."""
        from ..check import CHECK_OPTIONS, check_equilibrium

        for name, value in options.items():
            if name not in CHECK_OPTIONS:
                raise ArgumentError(
                    name, f"one of the options {', '.join(CHECK_OPTIONS)}", value,
                    "unknown option of check()",
                )  # fmt: skip
        return check_equilibrium(self, **options)

    def to_dict(self, length: float = 1.0, unit: str = "m") -> dict[str, Any]:
        """JSON-ready dict; lengths multiplied by ``length`` (1e3 for mm), angles in rad."""
        return {
            "formulation": self.formulation,
            "status": self.status,
            "ok": self.ok,
            "length_unit": unit,
            "torsors": {
                name: _scaled_torsor(t, length).tolist() for name, t in self.torsors.items()
            },
            "contacts": [
                {
                    "joint": c.joint,
                    "point": c.point,
                    "active": c.active,
                    "gap": c.gap * length,
                    "force_N": c.force.tolist(),
                    "position": _scaled_point(c.position, length),
                    "world_position": _scaled_point(c.world_position, length),
                    **({} if c.moment is None else {"moment_N_m": c.moment.tolist()}),
                }
                for c in self.contacts
            ],
            "energy_J": self.energy,
            "free_motions": list(self.free_motions),
            "method": self.method.value,
            "solver_status": self.solver_status,
            "iterations": self.iterations,
            "residuals": self.residuals.to_dict(),
            "polished": self.polished,
            "build_time_s": self.build_time,
            "solve_time_s": self.solve_time,
            "outputs": {
                name: {"translation": (t * length).tolist(), "rotation_rad": r.tolist()}
                for name, (t, r) in self.outputs.items()
            },
            "difference_exact_linear": _difference_dict(self.difference, length),
            "difference_bound": _difference_dict(self.difference_bound, length),
            "eccentricities": {
                name: {"translation": (t * length).tolist(), "rotation_rad": r.tolist()}
                for name, (t, r) in self.eccentricities.items()
            },
            "note": self.note,
        }

    def table(self) -> str:
        """The engineer's text report (:func:`.report.report`): outputs, bearing loads, contacts
        with their world positions, torsors, residuals; every frame named, columns kept."""
        return report(self)


def _difference_dict(difference: dict[str, Any] | None, length: float) -> dict[str, Any] | None:
    """``difference`` / ``difference_bound`` JSON-ready: lengths times ``length``, arrays as
    lists, per output ``{"translation", "rotation_rad"}``."""
    if difference is None:
        return None
    out: dict[str, Any] = {}
    for key, value in difference.items():
        if key == "outputs":
            out[key] = {
                name: {
                    "translation": _finite(np.asarray(t, dtype=float) * length),
                    "rotation_rad": _finite(np.asarray(r, dtype=float)),
                }
                for name, (t, r) in value.items()
            }
        elif key.endswith("_m"):
            out[key.removesuffix("_m")] = _finite(np.asarray(float(value) * length))
        elif key.endswith("_rad"):
            out[key] = _finite(np.asarray(float(value)))
        else:
            out[key] = value
    return out


def _finite(values: np.ndarray) -> float | list[Any] | None:
    """A number or list for JSON; None for an unknown (infinite or NaN) estimate."""
    if not np.all(np.isfinite(values)):
        return None
    listed: float | list[Any] = values.tolist()  # a number for a 0-d array
    return listed


def _scaled_point(point: np.ndarray | None, length: float) -> list[float] | None:
    return None if point is None else (np.asarray(point) * length).tolist()


def _scaled_torsor(torsor: np.ndarray, length: float) -> np.ndarray:
    out = np.array(torsor, dtype=float)
    out[:3] *= length
    return out
