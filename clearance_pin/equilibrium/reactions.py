r"""Joint reactions: the wrench the parent part exerts on the child part through every joint.

A joint's reaction :math:`W_j = (f, m)` [N, N m] is the sum of three parts:

- *contact*: the joint's contact forces (known from the solve), each applied at its contact point;
- *rigid*: the reactions of the components the joint does not let move (rigid components, contact
  points without play), :math:`G_j \mu_j`;
- *drive*: for a driven joint, the drive torque (or force) that locks its own motion,
  :math:`D_j \tau_j`;
- *held*: exact model only, when the load works at the solved pose along a motion the linear model
  leaves free and that motion does not settle nearby (``residuals["held_by_gauge"]``): what holds
  the joint's own free motions where the linear answer put them, as a drive or the least friction
  would; zero otherwise.

The solver eliminates rigid and locked components (null-space reduction), so their multipliers
are recovered afterwards from the statics of every moving body b (world axes, moments about b's
frame origin :math:`o_b`):

.. math::  L_b + \sum_{j:\ \mathrm{child}(j) = b} W_j - \sum_{j:\ \mathrm{parent}(j) = b} W_j = 0

with :math:`L_b` the body's loads. The unknowns :math:`(\mu, \tau)` solve these 6 equations per
body by least squares, minimum norm (forces [N] and moments / L_ref [N]) where the mechanism is
statically indeterminate; the relative residual of that least squares is reported, so an
unbalanced answer is visible. A joint with stiffness transmits its spring's wrench along the
directions that deflect (in series with its play): :math:`D^T W_j = D^T (-K e_j)` holds exactly
(equality constraints of the least squares), so the springs, not the least norm, split a
hyperstatic mechanism's reactions there.

Where the wrenches act:

- small-displacement model: the nominal pose; contact forces and rigid directions in the frame
  of the joint's torsor (``SmallDisplacementMaps.joint_centre``: for a loop joint its child-side
  clearance frame), loads at their nominal points;
- exact model: the solved pose (``Equilibrium.body_placements``). A contact force acts on the
  child's contact point where it is, in the parent-side clearance frame's axes
  (:mod:`.exact`). A rigid direction is the gradient of the exact model's own condition with
  respect to the child's motion :math:`\nu` (right perturbation of the relative placement
  :math:`M = C_a^{-1} C_b`, child-side clearance frame): for a tree joint, whose motion is
  :math:`M = \exp(B t)`, the fixed combinations :math:`A \log_6 M = 0` give
  :math:`G = J_{\log_6}(M)^T A^T`; for a loop joint the conditions of :mod:`.exact`
  (:math:`p_i = 0`, :math:`(R e_x)_{y,z} = 0`, :math:`\mathrm{vee}((R - R^T)/2) = 0`, contact
  points without play :math:`S (p + R r - r) = 0`). Loads are dead loads at the moved points; a
  torque C does the work of a couple of dead loads, :math:`C\cdot\mathrm{vee}((A - A^T)/2)`,
  :math:`A = R_b R_{b0}^T`, so its moment at the solved pose is
  :math:`\tfrac12 (\mathrm{tr}(A) I - A^T) C` (C to first order).
"""

from __future__ import annotations

from collections.abc import Sequence, Set
from dataclasses import dataclass
from types import SimpleNamespace
from typing import TYPE_CHECKING, cast

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from ..errors import ArgumentError, ClearancePinError, NotFoundError
from ..model.clearance import ALPHA, BETA, GAMMA
from ..model.couplings import coupled_joint, driven, passive
from ..model.joints import LoopJoint, TreeJoint
from ..model.stiffness import elastic_at
from ..numerics import Array, null_space
from .load_terms import gather_body_loads
from .poses import ClearanceFrames, clearance_frames
from .small_displacement import tree_joint_basis

if TYPE_CHECKING:  # result.py imports this module
    from ..model.loads import Load
    from ..model.mechanism_parts import ConfigurationParts as Configuration
    from ..model.mechanism_parts import MechanismParts as Mechanism
    from .result import Equilibrium

# a joint's generators of reactions: (part, local wrenches (6, k), placement of their frame)
Generator = tuple[str, Array, pin.SE3]

FRAMES = ("joint", "world")
PARTS = ("rigid", "drive", "held")  # the parts recovered from the statics


@dataclass(frozen=True)
class Reaction:
    """The wrench that the parent part exerts on the child part through one joint.

    For a loop joint the parent is ``frame_a``'s part.

    Attributes:
        joint: joint name.
        frame: ``"joint"``: the axes of the clearance frame the contact forces are given in
            (x = joint axis), moment about its origin, the joint centre (small-displacement
            model: the frame of the joint's torsor at the nominal pose, for a loop joint its
            child side; exact: the parent side at the solved pose); ``"world"``: world axes,
            moment about the world origin.
        force: resultant force [N], (3,).
        moment: resultant moment [N m] about ``point``, (3,).
        point: the point about which the moment is taken, in world coordinates [m], (3,).
        contact: the part carried by the joint's contact forces, (force, moment) (6,) [N, N m],
            same axes and point.
        rigid: the part carried by its rigid directions (rigid components, contact points
            without play), (6,).
        drive: the drive torque (or force) of a driven joint, (6,); zero otherwise.
        held: exact model, the part holding the joint's free motions (module docstring), (6,);
            zero otherwise.
        residual: relative residual of the per-body statics from which the rigid and drive parts
            were recovered (whole mechanism; round-off for a balanced answer), see
            :mod:`clearance_pin.equilibrium.reactions`.
    """

    joint: str
    frame: str
    force: np.ndarray
    moment: np.ndarray
    point: np.ndarray
    contact: np.ndarray
    rigid: np.ndarray
    drive: np.ndarray
    held: np.ndarray
    residual: float

    @property
    def wrench(self) -> np.ndarray:
        """(force, moment) (6,) [N, N m]."""
        return np.concatenate([self.force, self.moment])

    def as_force(self) -> pin.Force:
        """The wrench as a ``pin.Force`` (linear: force [N], angular: moment [N m] about
        :attr:`point`), in :attr:`frame`'s axes: the clearance frame (``"joint"``, Pinocchio's
        ``LOCAL`` of that frame) or the world (``"world"``, Pinocchio's ``WORLD``)."""
        return pin.Force(self.force, self.moment)

    def __array__(self, dtype: npt.DTypeLike | None = None, copy: bool | None = None) -> np.ndarray:
        """``np.asarray(reaction)``: the wrench (force, moment) (6,)."""
        return self.wrench if dtype is None else self.wrench.astype(dtype)


@dataclass(frozen=True)
class JointReactions:
    """Every joint's reaction parts as wrenches at the world origin, world axes (6,) each.

    Attributes:
        contact, rigid, drive, held: joint name -> (force [N], moment about the origin [N m])
            (6,).
        joint_frames: joint name -> world placement (pin.SE3) of the frame of ``frame="joint"``.
        residual: relative residual of the per-body least squares (see the module docstring).
    """

    contact: dict[str, Array]
    rigid: dict[str, Array]
    drive: dict[str, Array]
    held: dict[str, Array]
    joint_frames: dict[str, pin.SE3]
    residual: float

    def reaction(self, joint: str, frame: str = "joint") -> Reaction:
        """The :class:`Reaction` of ``joint`` in ``frame`` (``"joint"`` or ``"world"``)."""
        if joint not in self.contact:
            raise NotFoundError("joint", joint, tuple(self.contact))
        if frame not in FRAMES:
            raise ArgumentError("frame", "'joint' or 'world'", frame)
        parts = [self.contact[joint], self.rigid[joint], self.drive[joint], self.held[joint]]
        point = np.zeros(3)
        if frame == "joint":
            placement = self.joint_frames[joint]
            parts = [placement.actInv(pin.Force(part)).vector for part in parts]
            point = placement.translation.copy()
        contact, rigid, drive, held = parts
        total = contact + rigid + drive + held
        return Reaction(
            joint, frame, total[:3], total[3:], point, contact, rigid, drive, held, self.residual
        )


def joint_reactions(equilibrium: Equilibrium) -> JointReactions:
    """Recover every joint's reaction of ``equilibrium`` (see the module docstring)."""
    if equilibrium.loads is None:
        raise ClearancePinError(
            "this equilibrium does not carry the loads it was solved for (Equilibrium.loads), so "
            "its joint reactions cannot be recovered; solve it with Mechanism.solve"
        )
    mechanism = cast("Mechanism", equilibrium.mechanism)
    model = mechanism.model
    exact = equilibrium.formulation == "exact" and equilibrium.status != "indeterminate"
    nominal = cast("Configuration", equilibrium.configuration)
    placements = tuple(equilibrium.body_placements) if exact else nominal.oMi
    frames = frames_at(mechanism, nominal, placements)
    length = mechanism.length_scale()
    bodies = model.njoints

    loads = _body_wrenches(mechanism, equilibrium.loads, placements, nominal.oMi, exact)
    # the frame of the contact forces and of ``frame="joint"``: exact, the parent side at the
    # solved pose; linear, the frame of the joint's torsor (SmallDisplacementMaps.joint_centre),
    # which is the child side at the nominal pose (a loop joint's journal, block or ball)
    joint_frames = {
        name: frames[name].parent if exact else frames[name].child for name in mechanism.joints
    }
    contact = {name: np.zeros(6) for name in mechanism.joints}
    held_couplings = driven(getattr(mechanism, "couplings", ()), mechanism.joints)
    deadband = {
        c.follower: c for c in held_couplings if mechanism.joints[c.follower].clearance.backlash
    }
    transmitted = {name: np.zeros(6) for name in mechanism.joints}  # leaders' share of it
    for c in equilibrium.contacts:
        if c.moment is not None:
            moment = c.moment
        elif c.position is not None:
            moment = np.cross(c.position, c.force)
        else:  # the solvers give every contact its position
            raise ClearancePinError(f"contact {c.label} has no position: its moment is unknown")
        local = pin.Force(c.force, moment)
        contact[c.joint] += joint_frames[c.joint].act(local).vector
        if c.point == "backlash" and c.joint in deadband:  # a coupling's deadband holds mu_f:
            coupling = deadband[c.joint]  # -m mu_f about its leader's axis (module docstring)
            follower = coupled_joint(mechanism.joints, c.joint)
            mu = float(np.concatenate([c.force, moment])[cast(int, follower.motion_component)])
            leader = coupled_joint(mechanism.joints, coupling.leader)
            transmitted[leader.name] -= (
                coupling.multiplier * mu * _motion_wrench(leader, frames[leader.name])
            )

    columns: list[Array] = []  # generator wrenches at the world origin
    owners: list[tuple[str, str]] = []  # (joint, part) of each
    locals_: list[Array] = []  # and in the joint's own frame
    held = exact and equilibrium.residuals.get("held_by_gauge", 0.0) > 0.0
    # a passive coupling holds both its joints' motions, a driven leader's its follower's unless
    # the follower's deadband does (its stop: a contact, ``transmitted`` above)
    couplings = passive(getattr(mechanism, "couplings", ()), mechanism.joints)
    tied = {name for c in couplings for name in (c.follower, c.leader)}
    rigid_held = tuple(c for c in held_couplings if c.follower not in deadband)
    tied |= {c.follower for c in rigid_held}
    couplings = couplings + rigid_held
    for name, joint in mechanism.joints.items():
        for part, local, placement in _generators(joint, frames[name], exact, held, tied):
            for column in local.T:
                columns.append(placement.act(pin.Force(column)).vector)
                owners.append((name, part))
                locals_.append(column)
    springs = _spring_equations(mechanism, equilibrium, joint_frames, contact, owners, locals_)
    # a passive coupling's reaction: mu about the follower's axis, -m mu about the leader's
    paired = [
        tuple(
            (name, sign * _motion_wrench(coupled_joint(mechanism.joints, name), frames[name]))
            for name, sign in ((c.follower, 1.0), (c.leader, -c.multiplier))
        )
        for c in couplings
    ]

    # body equations at each body's own origin, moments over L_ref: forces and moments compare
    origins = [placements[b].translation for b in range(bodies)]

    def at_body(wrench: np.ndarray, body: int) -> np.ndarray:
        force = wrench[:3]
        return np.concatenate([force, (wrench[3:] - np.cross(origins[body], force)) / length])

    def scatter(wrench: np.ndarray, name: str) -> np.ndarray:
        rows = np.zeros(6 * bodies)
        parent, child = frames[name].parent_body, frames[name].child_body
        rows[6 * child : 6 * child + 6] += at_body(wrench, child)
        rows[6 * parent : 6 * parent + 6] -= at_body(wrench, parent)
        return rows[6:]  # the ground needs no balance

    known = np.zeros(6 * bodies)
    for body, wrench in loads.items():
        known[6 * body : 6 * body + 6] += at_body(wrench, body)
    known = known[6:]
    # the reference is the load (the contact forces' size when nothing is loaded)
    reference = float(np.linalg.norm(known.reshape(-1, 6), axis=1).sum())
    for name, wrench in contact.items():
        known += scatter(wrench, name)
    for name, wrench in transmitted.items():
        if wrench.any():
            known += scatter(wrench, name)
    if reference == 0.0:
        reference = float(np.linalg.norm(known.reshape(-1, 6), axis=1).sum())

    matrix = np.array(
        [scatter(c, name) for c, (name, _) in zip(columns, owners)]
        + [sum(scatter(w, name) for name, w in pair) for pair in paired]
    ).T
    matrix = matrix.reshape(6 * (bodies - 1), len(columns) + len(paired))
    if springs is not None and paired:  # the couplings' columns in no spring's equation
        springs = (np.hstack([springs[0], np.zeros((springs[0].shape[0], len(paired)))]),
                   springs[1])  # fmt: skip
    if matrix.shape[1]:
        sizes = np.linalg.norm(matrix, axis=0)
        sizes[sizes == 0.0] = 1.0
        solution = _least_squares(matrix / sizes, -known, springs, sizes) / sizes
    else:
        solution = np.zeros(0)
    imbalance = (known + matrix @ solution).reshape(-1, 6)
    largest = float(np.linalg.norm(imbalance, axis=1).max(initial=0.0))
    residual = largest / reference if reference > 0.0 else largest

    parts = {part: {name: np.zeros(6) for name in mechanism.joints} for part in PARTS}
    for column, (name, part), value in zip(columns, owners, solution):
        parts[part][name] += value * column
    for pair, value in zip(paired, solution[len(columns) :]):
        for name, wrench in pair:  # what the coupling holds: as a drive would
            parts["drive"][name] += value * wrench
    for name, wrench in transmitted.items():
        parts["drive"][name] += wrench
    return JointReactions(
        contact, parts["rigid"], parts["drive"], parts["held"], joint_frames, float(residual)
    )


def _motion_wrench(joint: TreeJoint, frames: ClearanceFrames) -> Array:
    """A unit torque (force) on a tree joint's child about (along) its axis, at the world
    origin (the clearance frame's x is the joint axis)."""
    wrench: Array = frames.child.act(pin.Force(np.eye(6)[joint.motion_component])).vector
    return wrench


def _spring_equations(
    mechanism: Mechanism,
    equilibrium: Equilibrium,
    joint_frames: dict[str, pin.SE3],
    contact: dict[str, Array],
    owners: list[tuple[str, str]],
    locals_: list[Array],
) -> tuple[Array, Array] | None:
    r"""The equations a joint's stiffness adds, (C (k, columns), d (k,)) or None: along its
    directions that deflect (D, clearance frame) the joint transmits its spring's wrench,
    :math:`D^T (W_{contact} + \sum_c \mu_c g_c) = D^T (-K e)` (the spring is in series with the
    play, e its deflection), which decides the split of a hyperstatic mechanism's rigid
    reactions where the least norm would not."""
    rows: list[Array] = []
    values: list[Array] = []
    for name, joint in mechanism.joints.items():
        deflection = (equilibrium.deflections or {}).get(name)
        if deflection is None:
            continue
        placed = cast("Configuration", equilibrium.configuration).oMi
        directions, stiffnesses = elastic_at(joint, mechanism.model, placed)  # as the maps'
        spring = -directions @ (stiffnesses * (directions.T @ deflection))  # -K e, local
        carried = joint_frames[name].actInv(pin.Force(contact[name])).vector
        row = np.zeros((directions.shape[1], len(owners)))
        for index, (owner, _) in enumerate(owners):
            if owner == name:
                row[:, index] = directions.T @ locals_[index]
        rows.append(row)
        values.append(directions.T @ (spring - carried))
    if not rows:
        return None
    return np.vstack(rows), np.concatenate(values)


def _least_squares(
    matrix: Array, right: Array, springs: tuple[Array, Array] | None, sizes: Array
) -> np.ndarray:
    """The minimum-norm least-squares solution of ``matrix`` u = ``right`` (u: the generators'
    values times ``sizes``), subject to the springs' equations (C, d) on the values when given:
    the particular solution of C, then the least squares over C's null space."""
    if springs is None:
        return np.linalg.lstsq(matrix, right, rcond=None)[0]
    constraint, value = springs
    constraint = constraint / sizes
    particular = np.linalg.lstsq(constraint, value, rcond=None)[0]
    free = null_space(constraint, rtol=1e-12) if constraint.size else np.eye(matrix.shape[1])
    if not free.shape[1]:
        return particular
    rest = np.linalg.lstsq(matrix @ free, right - matrix @ particular, rcond=None)[0]
    return particular + free @ rest


def frames_at(
    mechanism: Mechanism,
    configuration: Configuration,
    placements: Sequence[pin.SE3 | Array],
) -> dict[str, ClearanceFrames]:
    """:func:`~.poses.clearance_frames` of every joint for body placements given as pin.SE3 or
    (3, 4) [R | t] arrays (index = Pinocchio joint id, 0 = ground), before an Equilibrium exists."""
    placed = tuple(
        p if isinstance(p, pin.SE3) else pin.SE3(np.asarray(p)[:, :3], np.asarray(p)[:, 3])
        for p in placements
    )
    return clearance_frames(
        SimpleNamespace(mechanism=mechanism, configuration=configuration, body_placements=placed)
    )


def _body_wrenches(
    mechanism: Mechanism,
    loads: Sequence[Load],
    placements: Sequence[pin.SE3],
    nominal_oMi: Sequence[pin.SE3],
    exact: bool,
) -> dict[int, Array]:
    """Per body, its loads as one wrench (force [N], moment about the world origin [N m]) at the
    pose ``placements``: dead loads at their moved points, and for the exact model the moment
    :math:`\\tfrac12 (\\mathrm{tr}(A) I - A^T) C` of a torque (module docstring)."""
    gathered = gather_body_loads(mechanism, tuple(loads), placements)
    wrenches = {}
    for body, load in gathered.items():
        wrench = load.wrench.copy()
        if exact and np.any(load.torque):
            turn = placements[body].rotation @ nominal_oMi[body].rotation.T
            moment = 0.5 * (np.trace(turn) * np.eye(3) - turn.T) @ load.torque
            wrench[3:] += moment - load.torque
        wrenches[body] = wrench
    return wrenches


def _generators(
    joint: TreeJoint | LoopJoint,
    frames: ClearanceFrames,
    exact: bool,
    held: bool = False,
    tied: Set[str] = frozenset(),
) -> list[Generator]:
    """(part, local wrenches (6, k), placement of the frame they are written in) of a joint's
    rigid directions and drive, and with ``held`` of its own free motions (module docstring)
    but the motion of a joint a coupling ties (``tied``: the coupling holds it, its drive too)."""
    if isinstance(joint, TreeJoint):
        return _tree_generators(joint, frames, exact, held, joint.name in tied)
    return _loop_generators(joint, frames, exact)


def _tree_generators(
    joint: TreeJoint, frames: ClearanceFrames, exact: bool, held: bool = False, tied: bool = False
) -> list[Generator]:
    basis = tree_joint_basis(joint)
    drive = []
    for component in joint.locked_components:
        unit = np.eye(6)[component]
        direction = unit - basis @ (basis.T @ unit)
        drive.append(direction / np.linalg.norm(direction))
    drives = np.array(drive).reshape(-1, 6).T
    rigid = null_space(np.hstack([basis, drives]).T)
    if tied and joint.motion_component in joint.locked_components:
        # its coupling holds its motion (a pair of columns of its own), not a drive of its own
        drives = drives[:, [c != joint.motion_component for c in joint.locked_components]]
    if not exact:
        return [("rigid", rigid, frames.child), ("drive", drives, frames.child)]
    dual = pin.Jlog6(frames.relative).T
    generators = [("rigid", dual @ rigid, frames.child), ("drive", dual @ drives, frames.child)]
    free = [c for c in joint.clearance.free_components if c not in joint.locked_components]
    if tied:
        free = [c for c in free if c != joint.motion_component]
    if held and free:
        generators.append(("held", dual @ np.eye(6)[:, free], frames.child))
    return generators


def _loop_generators(loop: LoopJoint, frames: ClearanceFrames, exact: bool) -> list[Generator]:
    clearance = loop.clearance
    rigid = list(clearance.rigid_components)
    fixed_points = [p for p in clearance.contacts if p.bound == 0.0]
    columns = []
    if not exact:
        columns += [np.eye(6)[c] for c in rigid]
        columns += [row for p in fixed_points for row in p.linear_rows()]
        return [("rigid", np.array(columns).reshape(-1, 6).T, frames.child)]
    rotation = frames.relative.rotation
    rotations = {c for c in rigid if c >= ALPHA}
    for c in rigid:
        if c < ALPHA:
            columns.append(np.concatenate([rotation[c], np.zeros(3)]))  # R^T e_c
    if rotations == {BETA, GAMMA}:
        axis = np.eye(3)[0]
        columns += [np.concatenate([np.zeros(3), np.cross(axis, rotation[k])]) for k in (1, 2)]
    elif rotations:
        turn = 0.5 * (np.trace(rotation) * np.eye(3) - rotation)
        columns += [np.concatenate([np.zeros(3), turn[:, c - ALPHA]]) for c in sorted(rotations)]
    for point in fixed_points:
        r = np.asarray(point.point, dtype=float)
        for c in point.components:
            columns.append(np.concatenate([rotation[c], np.cross(r, rotation[c])]))
    return [("rigid", np.array(columns).reshape(-1, 6).T, frames.child)]


__all__ = ["JointReactions", "Reaction", "frames_at", "joint_reactions"]
