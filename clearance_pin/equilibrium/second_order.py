r"""How far the exact answer is from the small-displacement one, at the outputs, without solving it.

Both models share the unknowns x (each tree joint's torsor coordinates). The exact model places
every part by finite motions (:math:`oM_k = oM_p\, {}^pM_{k0}\, C_k \exp(T_k) C_k^{-1}`) and writes
its contact conditions, loop conditions and load work on them; the linear model is that model
linearised at x = 0. At the outputs (:mod:`.outputs`) the exact - linear difference is

.. math::  \Delta_o = D^e_o(x_e) - D^l_o(x_l)
                    = \underbrace{D^e_o(x_l) - D^l_o(x_l)}_{\text{kinematics}}
                      + \underbrace{J^e_o(x_l)\,\delta}_{\text{equilibrium moves}} + O(3),
           \qquad \delta = x_e - x_l,

the first term the second-order kinematics at the linear answer (finite body motions
:math:`\exp(\xi)` against :math:`1 + \xi`: :math:`\tfrac12\omega\times(\omega\times r)` and the
composition of joint rotations along the chain, :math:`\tfrac12[\xi_i, \xi_j]`), amplified by the
lever arm of each output; the second how far the equilibrium itself moves. :math:`\delta` is the
Newton step of the exact KKT system from the linear answer (x_l, its contact forces
:math:`\mu_j` and loop reactions :math:`\nu`), with the linear model's KKT matrix:

.. math::  \begin{bmatrix} H & G^T \\ G & 0 \end{bmatrix}
           \begin{bmatrix} \delta \\ d\mu \end{bmatrix}
           = -\begin{bmatrix} \nabla V^e + \sum_A \mu_j \nabla h^e_j + \nabla e^{T} \nu \\
                              h^e_A \\ e \end{bmatrix}_{x_l},
           \qquad H = \sum_{A} \mu_j \nabla^2 h^l_j,

where the right-hand side holds exactly the terms the linear model drops, evaluated at its
answer: the work of the loads at the displaced points (a dead load turns with the parts it
loads: :math:`\nabla V^e` against :math:`g`), the true contact conditions :math:`h^e_j` of the
active contacts A (curvature of the clearance boundaries, :math:`d = p + R r - r`) and their
normals, and the loop conditions e. Every term of the right-hand side is of second order
(O(|x|^2 / L) in the conditions, O(|x| / L) relative in the loads), so :math:`\delta` is of second
order, and a Newton step from a point at distance O(2) of the solution, with a KKT matrix that
differs from the exact one by O(1) relative (the load's geometric stiffness F/L against the cone
curvature mu/c, and the exact normals), errs by
:math:`O(|\delta|\,(|\delta| / c + |x| / L))`: third order. The estimate

.. math::  \epsilon_o = 2\,\|\Delta_o\| + 10^{-9} \max(c_{max}, \|D^l_o\|)

(factor 2 for the third-order remainder; the additive term is the accuracy to which both answers
are verified, 1e-9 of the play) therefore bounds :math:`\|D^e_o - D^l_o\|` as long as the
remainder is below the estimate: as long as the correction moves no contact by more than a
quarter of its play, no loaded contact releases (:math:`\mu_j + d\mu_j \ge 0`) and no free contact
point is pushed through its boundary, and the linear optimum is unique (a motion inside the
play that the load does not see is left at the minimum-norm point by the linear model, and the
exact model's second-order load terms push it anywhere in the play). When one of those fails,
the active set of the exact model may differ from the linear one and the estimate is reported
unreliable (infinite): ``exact="auto"``
then runs the exact model. Its cost: two passes of numpy forward kinematics with their Jacobians
and one dense KKT solve, no CasADi build.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, cast

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from ..errors import UnsupportedError
from ..model.clearance import ALPHA, BETA, GAMMA, ContactPoint
from ..model.couplings import passive
from ..model.joints import LoopJoint, TreeJoint
from ..numerics import Array
from .load_terms import BodyLoad
from .outputs import OutputPoint
from .poses import clearance_frames
from .prepared import linear_setup
from .small_displacement import tree_joint_basis

if TYPE_CHECKING:  # the mechanism module imports this one
    from ..model.loads import Load
    from ..model.mechanism_parts import ConfigurationParts as Configuration
    from ..model.mechanism_parts import MechanismParts as Mechanism
    from .result import Equilibrium

SAFETY_FACTOR = 2.0
VERIFIED_SHARE = 1e-9  # both answers are verified to this share of the play
RELIABLE_SHARE = 0.25  # a correction moving a contact by more than this share of its play
FLAT_SHARE = 1e-9  # share of the load left along flat motions of the linear optimum


@dataclass(frozen=True)
class DifferenceEstimate:
    """Estimate of the exact - linear difference at the outputs of a linear answer.

    Attributes:
        predicted: output name -> (translation (3,) [m], rotation (3,) [rad]): the second-order
            prediction of exact - linear (world axes).
        bounds: output name -> (translation [m], rotation [rad]): safety-factored bounds on
            the norms of the difference (see module docstring); inf when not reliable.
        reliable: False when the linear contact set may not be the exact one.
        reason: why it is not reliable ("" when it is).
        contact_shift: largest correction of a contact point over its play (dimensionless).
    """

    predicted: dict[str, tuple[Array, Array]]
    bounds: dict[str, tuple[float, float]]
    reliable: bool
    reason: str
    contact_shift: float

    @property
    def translation_m(self) -> float:
        """Largest translation bound over the outputs [m]."""
        return max((b[0] for b in self.bounds.values()), default=0.0)

    @property
    def rotation_rad(self) -> float:
        """Largest rotation bound over the outputs [rad]."""
        return max((b[1] for b in self.bounds.values()), default=0.0)

    def as_dict(self) -> dict[str, Any]:
        """``{"translation_m", "rotation_rad": largest bounds, "outputs": name -> (translation
        bound [m], rotation bound [rad]), "reliable", "reason"}`` (``Equilibrium.difference_bound``).
        """
        return {
            "translation_m": self.translation_m,
            "rotation_rad": self.rotation_rad,
            "outputs": dict(self.bounds),
            "reliable": self.reliable,
            "reason": self.reason,
        }


@dataclass
class _Pose:
    """The duck-typed answer :func:`clearance_frames` reads (mechanism, nominal, placements)."""

    mechanism: object
    configuration: object
    body_placements: tuple[pin.SE3, ...]


@dataclass
class _ContactTerms:
    """One contact at x: selected displacement d (k,) [m] and its x-Jacobian (k, n)."""

    d: np.ndarray
    jacobian: np.ndarray


@dataclass
class _ExactTerms:
    """The exact model evaluated (numpy) at unknowns x."""

    placed: list[pin.SE3]  # per Pinocchio joint
    twists: np.ndarray  # (bodies, 6, n): x-Jacobian of the world spatial twist of every body
    contacts: list[_ContactTerms]  # in the order of the linear answer's contacts
    gradient: np.ndarray  # (n,) gradient of the exact potential [J per unit x]
    equalities: np.ndarray  # (e,) loop conditions
    equality_jacobian: np.ndarray  # (e, n)


def estimate_difference(
    linear: Equilibrium,
    loads: Sequence[Load],
    q: npt.ArrayLike | None,
    points: Sequence[OutputPoint],
) -> DifferenceEstimate:
    """Estimate the exact - linear difference at ``points`` (:class:`~.outputs.OutputPoint`)
    from the linear equilibrium ``linear`` of ``loads`` at ``q`` (see module docstring)."""
    mechanism = cast("Mechanism", linear.mechanism)
    if linear.status == "indeterminate":
        zero = (np.zeros(3), np.zeros(3))  # nothing moves in either model
        bounds: dict[str, tuple[float, float]] = {p.name: (0.0, 0.0) for p in points}
        return DifferenceEstimate({p.name: zero for p in points}, bounds, True, "", 0.0)
    if linear.deflections:
        return _unreliable(points, "no second-order estimate with joint stiffness", 0.0)
    if passive(mechanism.couplings, mechanism.joints):
        return _unreliable(points, "no second-order estimate with a passive coupling", 0.0)
    configuration, _maps, body_loads, problem = linear_setup(mechanism, loads, q)
    x_l = np.concatenate(
        [tree_joint_basis(j).T @ linear.torsors[j.name] for j in mechanism.tree_joints]
    )
    n = x_l.size
    points_of = _contact_points(linear)
    try:
        at_zero = _evaluate(linear, configuration, body_loads, np.zeros(n), points_of)
        at_x = _evaluate(linear, configuration, body_loads, x_l, points_of)
    except UnsupportedError as exc:
        return _unreliable(points, f"no exact form: {exc}", 0.0)

    loaded: list[int] = []
    row_list: list[np.ndarray] = []
    mu_list: list[float] = []
    residual_h: list[float] = []
    hessian = np.zeros((n, n))
    exact_gradient = at_x.gradient.copy()
    linear_gradient = at_zero.gradient.copy()
    linear_gradient_load = at_zero.gradient
    for j, contact in enumerate(linear.contacts):
        point = points_of[j]
        size = contact.force_magnitude
        if not (contact.active and size > 0.0):
            continue
        s0, ex = at_zero.contacts[j].jacobian, at_x.contacts[j]
        d_l = at_zero.contacts[j].d + s0 @ x_l  # d(0): a nominal eccentricity, else 0
        if point.shape == "norm":
            reach = float(np.linalg.norm(d_l))
            normal_l = d_l / reach
            row_l = normal_l @ s0
            row_e = ex.d @ ex.jacobian / np.linalg.norm(ex.d)
            h_e = float(np.linalg.norm(ex.d)) - point.bound
            projector = np.eye(d_l.size) - np.outer(normal_l, normal_l)
            hessian += size * (s0.T @ projector @ s0) / reach
        else:
            pushed = contact.force if contact.moment is None else contact.moment  # a stop's
            side = -np.sign(pushed[point.components[0]])
            row_l, row_e = side * s0[0], side * ex.jacobian[0]
            h_e = float(side * ex.d[0]) - point.bound
        loaded.append(j)
        row_list.append(row_l)
        mu_list.append(size)
        residual_h.append(h_e)
        exact_gradient += size * row_e
        linear_gradient += size * row_l
    rows_l = np.array(row_list).reshape(-1, n)
    mu = np.array(mu_list)
    # loop reactions nu of the linear answer: g + sum mu grad h + E^T nu = 0
    e0 = at_zero.equality_jacobian
    nu = np.linalg.lstsq(e0.T, -linear_gradient, rcond=None)[0] if e0.size else np.zeros(0)
    residual_s = exact_gradient + at_x.equality_jacobian.T @ nu
    gauge = (problem.free_motions / problem.scale[:, None] ** 2).T
    delta, d_mu, unsolved = _correction(
        hessian,
        [rows_l, e0, gauge],
        residual_s,
        [np.array(residual_h), at_x.equalities],
        problem.scale,
        float(np.linalg.norm(problem.scale * linear_gradient_load)),
    )
    shift, reason = _check_contacts(linear, points_of, at_x, delta, loaded, mu, d_mu)
    flat = [m for m in linear.free_motions if m.startswith("bounded but not loaded")]
    if flat:
        reason = (
            "the linear optimum is not unique (a motion inside the play that the load does not "
            "see); the exact model's second-order terms choose a point of it"
        )
    if unsolved > FLAT_SHARE:
        reason = (
            "the linear optimum is not unique along a motion that the exact model's terms load "
            f"({unsolved:.1e} of the load): the exact answer moves along it by up to the play"
        )
    if reason:
        return _unreliable(points, reason, shift)
    predicted: dict[str, tuple[Array, Array]] = {}
    bounds = {}
    largest_play = max((c.clearance for c in linear.contacts), default=0.0)
    length = mechanism.length_scale()
    nominal = configuration.oMi
    for output in points:
        start = nominal[output.body] * output.placement
        moved = at_x.placed[output.body] * output.placement
        twist_l = at_zero.twists[output.body] @ x_l
        linear_t = twist_l[:3] + np.cross(twist_l[3:], start.translation)
        exact_t = moved.translation - start.translation
        exact_r = np.asarray(pin.log3(moved.rotation @ start.rotation.T))
        correction = at_x.twists[output.body] @ delta
        translation = (
            exact_t - linear_t + correction[:3] + np.cross(correction[3:], moved.translation)
        )
        rotation = exact_r - twist_l[3:] + correction[3:]
        predicted[output.name] = (translation, rotation)
        floor_t = VERIFIED_SHARE * max(largest_play, float(np.linalg.norm(linear_t)))
        floor_r = VERIFIED_SHARE * max(float(np.linalg.norm(twist_l[3:])), largest_play / length)
        bounds[output.name] = (
            SAFETY_FACTOR * float(np.linalg.norm(translation)) + floor_t,
            SAFETY_FACTOR * float(np.linalg.norm(rotation)) + floor_r,
        )
    return DifferenceEstimate(predicted, bounds, True, "", shift)


def _unreliable(points: Sequence[OutputPoint], reason: str, shift: float) -> DifferenceEstimate:
    inf = (np.inf, np.inf)
    nan = (np.full(3, np.nan), np.full(3, np.nan))
    return DifferenceEstimate(
        {p.name: nan for p in points}, {p.name: inf for p in points}, False, reason, shift
    )


def _correction(
    hessian: Array,
    blocks: list[Array],
    residual_s: Array,
    residuals_c: list[Array],
    scale: Array,
    load_size: float,
) -> tuple[Array, Array, float]:
    """Solve the KKT system of the module docstring in the scaled unknowns z = x / scale, rows
    of G normalised (their right-hand sides with them).

    Returns:
        (delta (n,), d_mu (loaded,), the share of the right-hand side the system cannot take:
        above round-off when the linear optimum is flat along a motion that the dropped terms
        load).
    """
    rows = np.vstack(blocks)
    rhs = np.concatenate([*residuals_c, np.zeros(blocks[-1].shape[0])])
    rows_z = rows * scale
    norms = np.linalg.norm(rows_z, axis=1)
    norms[norms == 0.0] = 1.0
    rows_z, rhs = rows_z / norms[:, None], rhs / norms
    h_z = hessian * np.outer(scale, scale)
    n, m = scale.size, rows.shape[0]
    kkt = np.block([[h_z, rows_z.T], [rows_z, np.zeros((m, m))]])
    right = -np.concatenate([scale * residual_s, rhs])
    solution = np.linalg.lstsq(kkt, right, rcond=None)[0]
    left = kkt @ solution - right
    # stationarity left over against the load's work on the clearance scale; conditions left over
    # in plays (the scaled unknowns are clearance-sized)
    unsolved = max(
        float(np.linalg.norm(left[:n])) / max(load_size, 1e-300), float(np.linalg.norm(left[n:]))
    )
    loaded = blocks[0].shape[0]
    return scale * solution[:n], solution[n : n + loaded] / norms[:loaded], unsolved


def _check_contacts(
    linear: Equilibrium,
    points_of: list[ContactPoint],
    at_x: _ExactTerms,
    delta: Array,
    loaded: list[int],
    mu: Array,
    d_mu: Array,
) -> tuple[float, str]:
    """Largest contact shift over its play, and why the linear contact set may not hold."""
    shift, loaded_set = 0.0, set(loaded)
    for j, contact in enumerate(linear.contacts):
        point, terms = points_of[j], at_x.contacts[j]
        step = terms.jacobian @ delta
        shift = max(shift, float(np.linalg.norm(step)) / point.bound)
        if j in loaded_set:
            continue
        moved = terms.d + step
        reach = float(np.linalg.norm(moved) if point.shape == "norm" else abs(moved[0]))
        if reach > point.bound * (1.0 + VERIFIED_SHARE):
            return shift, f"the correction pushes the free contact {contact.label} into its bound"
    if shift > RELIABLE_SHARE:
        return shift, f"the correction moves a contact by {shift:.2g} of its play"
    released = [linear.contacts[j].label for j, m, dm in zip(loaded, mu, d_mu) if m + dm < 0.0]
    if released:
        return shift, f"the correction releases the contact {released[0]}"
    return shift, ""


def _contact_points(linear: Equilibrium) -> list[ContactPoint]:
    """The clearance ContactPoint of every contact of the answer, in its order."""
    joints = cast("Mechanism", linear.mechanism).joints
    return [
        next(p for p in joints[c.joint].clearance.contacts if p.name == c.point)
        for c in linear.contacts
    ]


def _evaluate(
    linear: Equilibrium,
    configuration: Configuration,
    body_loads: dict[int, BodyLoad],
    x: Array,
    points_of: list[ContactPoint],
) -> _ExactTerms:
    """The exact model at x, in numpy: placements, twist Jacobians, contacts, potential gradient
    and loop conditions (the same equations as :mod:`.exact`, differentiated by hand)."""
    mechanism = cast("Mechanism", linear.mechanism)
    model = mechanism.model
    nominal = configuration.oMi
    n = x.size
    placed = [pin.SE3.Identity()] * model.njoints
    twists = np.zeros((model.njoints, 6, n))
    by_id: dict[int, tuple[TreeJoint, np.ndarray, int]] = {}
    offset = 0
    for joint in mechanism.tree_joints:
        basis = tree_joint_basis(joint)
        by_id[joint.joint_id] = (joint, basis, offset)
        offset += basis.shape[1]
    for i in range(1, model.njoints):
        joint, basis, start = by_id[i]
        parent = model.parents[i]
        torsor = basis @ x[start : start + basis.shape[1]]
        frame = pin.SE3(joint.rotation, np.zeros(3))
        moved = frame * pin.exp6(pin.Motion(torsor))
        placed[i] = placed[parent] * nominal[parent].actInv(nominal[i]) * moved * frame.inverse()
        twists[i] = twists[parent]
        oMc = placed[i] * frame
        twists[i][:, start : start + basis.shape[1]] += (
            oMc.action @ pin.Jexp6(pin.Motion(torsor)) @ basis
        )
    frames = clearance_frames(_Pose(mechanism, configuration, tuple(placed)))
    relative_jacobian: dict[str, Array] = {}
    for name, f in frames.items():
        relative_jacobian[name] = f.child.inverse().action @ (
            twists[f.child_body] - twists[f.parent_body]
        )
    contacts: list[_ContactTerms] = []
    for contact, point in zip(linear.contacts, points_of):
        relative = frames[contact.joint].relative
        contacts.append(_contact_terms(relative, relative_jacobian[contact.joint], point))
    gradient = np.zeros(n)
    for body, load in body_loads.items():
        R, t = placed[body].rotation, placed[body].translation
        M = R @ nominal[body].rotation.T
        G = load.moment_matrix
        moment = (
            np.cross(t, load.force)
            + _vee(G @ R.T - R @ G.T)
            + 0.5 * (np.trace(M) * np.eye(3) - M).T @ load.torque
        )
        gradient -= twists[body].T @ np.concatenate([load.force, moment])
    values: list[float] = []
    rows: list[Array] = []
    for loop in mechanism.loop_joints:
        v, r = _loop_conditions(loop, frames[loop.name].relative, relative_jacobian[loop.name])
        values.extend(v)
        rows.extend(r)
    return _ExactTerms(
        placed,
        twists,
        contacts,
        gradient,
        np.array(values),
        np.array(rows).reshape(-1, n),
    )


def _contact_terms(relative: pin.SE3, jacobian: np.ndarray, point: ContactPoint) -> _ContactTerms:
    r""":math:`d = p + R r - r` of a contact point and its x-Jacobian
    :math:`R\,[I, -[r]_\times]\, J_\eta` (selected components)."""
    R, p = relative.rotation, relative.translation
    selected = list(point.components)
    if point.lever:  # a drive's backlash stop: lever x the rotation vector (first order in it)
        turned = point.lever * jacobian[3:]
        return _ContactTerms(point.displacement(R, p), turned[selected])
    r = np.asarray(point.point, dtype=float)
    d = p + R @ r - r
    full = R @ np.hstack([np.eye(3), -pin.skew(r)]) @ jacobian
    return _ContactTerms(d[selected], full[selected])


def _loop_conditions(
    loop: LoopJoint, relative: pin.SE3, jacobian: np.ndarray
) -> tuple[list[float], list[Array]]:
    """The rigid conditions of a loop joint (as :func:`.exact._loop_equalities`) and their rows."""
    R, p = relative.rotation, relative.translation
    values: list[float] = []
    rows: list[Array] = []
    rigid = loop.clearance.rigid_components
    rotations = {c for c in rigid if c >= ALPHA}
    translation_rows = np.hstack([R, np.zeros((3, 3))]) @ jacobian
    for component in rigid:
        if component < ALPHA:
            values.append(p[component])
            rows.append(translation_rows[component])
    if rotations == {BETA, GAMMA}:
        axis_rows = np.hstack([np.zeros((3, 3)), -R @ pin.skew(np.eye(3)[0])]) @ jacobian
        values.extend([-R[2, 0], R[1, 0]])
        rows.extend([-axis_rows[2], axis_rows[1]])
    elif rotations == {ALPHA, BETA, GAMMA}:
        values.extend(_vee(0.5 * (R - R.T)))
        turn = np.hstack([np.zeros((3, 3)), 0.5 * (np.trace(R) * np.eye(3) - R.T)]) @ jacobian
        rows.extend(turn)
    elif rotations:
        raise UnsupportedError(f"loop joint {loop.name!r}: rigid rotations {sorted(rotations)}")
    for point in loop.clearance.contacts:
        if point.bound == 0.0:
            terms = _contact_terms(relative, jacobian, point)
            values.extend(terms.d)
            rows.extend(terms.jacobian)
    return values, rows


def _vee(skew: np.ndarray) -> np.ndarray:
    return np.array([skew[2, 1], skew[0, 2], skew[1, 0]])


def boundary_errors(equilibrium: Equilibrium) -> dict[str, float]:
    """Per contact ``joint:point``: distance [m] of the true contact point from where the model
    puts it (on the boundary for contacts; inside it for free points)."""
    relative = {name: f.relative for name, f in clearance_frames(equilibrium).items()}
    errors: dict[str, float] = {}
    for contact, point in zip(equilibrium.contacts, _contact_points(equilibrium)):
        placement = relative[contact.joint]
        d = point.displacement(placement.rotation, placement.translation)
        reach = float(np.linalg.norm(d)) if point.shape == "norm" else abs(float(d[0]))
        if contact.active:
            errors[contact.label] = abs(reach - point.bound)
        else:
            errors[contact.label] = max(reach - point.bound, 0.0)
    return errors
