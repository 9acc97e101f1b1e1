"""check_equilibrium: place the parts at the solved pose and let coal measure every clearance."""

from __future__ import annotations

import dataclasses
import time
from typing import TYPE_CHECKING, cast

import numpy as np
import pinocchio as pin

from ..errors import ArgumentError, ClearancePinError
from ..model.joints import LoopJoint, TreeJoint
from .accuracy import Tolerance, coal_accuracy, solver_accuracy
from .geometry import Region, point_shape, shape_cache
from .measure import Probe
from .poses import ClearanceFrames, clearance_frames, solved_mechanism
from .report import CheckReport, JointCheck, PointCheck
from .surfaces import collision_parts, journal_in_bore

if TYPE_CHECKING:
    from ..equilibrium.result import Contact, Equilibrium
    from ..model.mechanism_parts import ConfigurationParts

GJK_TOLERANCE = 1e-12
FACETS = 512
_IDENTITY = np.eye(3)


POSES = ("real", "as_solved")
CHECK_OPTIONS = ("pose", "bores", "journal_radius", "facets", "mesh_faceting", "gjk_tolerance")
"""The keyword options of :func:`check_equilibrium` (tested against its signature)."""


def check_equilibrium(
    equilibrium: Equilibrium,
    *,
    pose: str = "real",
    bores: bool = False,
    journal_radius: float | None = None,
    facets: int = FACETS,
    mesh_faceting: float | None = None,
    gjk_tolerance: float = GJK_TOLERANCE,
) -> CheckReport:
    """Measure a solved pose with coal: every contact point against its clearance region, and
    optionally the parts' surfaces (see :mod:`clearance_pin.check`).

    The real clearance boundaries are met exactly by the exact model only: a small-displacement
    answer's own pose departs from them at second order (the model's error, 1.8 um on the paper's
    case 6.1.6.1b), which is not a wrong answer. So by default (``pose="real"``) a linear answer
    is judged on its exact pose (the exact model solved from it, same loads and configuration),
    and the linear pose's own measure is attached as ``report.departure``, for information; an
    exact answer is measured as it is. ``pose="as_solved"`` measures the given pose whatever its
    formulation (the linear model's second-order departure then fails).

    Args:
        equilibrium: a solved :class:`~clearance_pin.equilibrium.result.Equilibrium`.
        pose: ``"real"`` (default) or ``"as_solved"``, above.
        bores: also measure a journal cylinder in a generated faceted bore for every cylindrical
            and revolute joint (:mod:`.surfaces`).
        journal_radius: radius R of those journals [m] (default 10 radial clearances).
        facets: number N of facets of a generated bore (faceting bound
            (R + c)(1/cos(pi/N) - 1): 2.1e-4 c for R = 10 c, N = 512).
        mesh_faceting: faceting bound [m] of the URDF's collision meshes, when the mechanism has
            collision geometry on both links of a joint; None: only penetration is judged there.
        gjk_tolerance: coal's GJK and EPA tolerances (relative).

    Returns:
        :class:`~clearance_pin.check.report.CheckReport`.

    Raises:
        ClearancePinError: the equilibrium carries no pose, an option is out of range, or coal fails.
    """
    _validate(equilibrium, pose, journal_radius, facets, mesh_faceting, gjk_tolerance)
    options = (bores, journal_radius, facets, mesh_faceting, gjk_tolerance)
    if pose == "as_solved" or equilibrium.formulation != "linear":
        return _measure(equilibrium, *options)
    started = time.perf_counter()
    exact = exact_pose(equilibrium)
    solve_time = time.perf_counter() - started
    report = _measure(exact, *options)
    departure = dataclasses.replace(_measure(equilibrium, *options), information=True)
    return dataclasses.replace(report, departure=departure, exact_solve_time=solve_time)


def exact_pose(linear: Equilibrium) -> Equilibrium:
    """The exact model's answer for the loads and configuration ``linear`` was solved for,
    started from it (what ``Mechanism.solve(exact=True)`` returns for the same case)."""
    from ..equilibrium.formulation import exact_from_linear
    from ..equilibrium.options import TOL

    mechanism = solved_mechanism(linear)
    configuration = cast("ConfigurationParts | None", linear.configuration)
    q = None if configuration is None else np.asarray(configuration.q, dtype=float)
    return exact_from_linear(mechanism, linear.loads or (), q, linear, TOL)


def _measure(
    equilibrium: Equilibrium,
    bores: bool,
    journal_radius: float | None,
    facets: int,
    mesh_faceting: float | None,
    gjk_tolerance: float,
) -> CheckReport:
    """coal's measure of the pose ``equilibrium`` carries (the arguments of
    :func:`check_equilibrium`)."""
    started = time.perf_counter()
    mechanism = solved_mechanism(equilibrium)
    probe = Probe(gjk_tolerance)
    frames = _play_frames(equilibrium, clearance_frames(equilibrium))
    by_joint: dict[str, list[Contact]] = {}
    for contact in equilibrium.contacts:
        by_joint.setdefault(contact.joint, []).append(contact)
    joints: dict[str, JointCheck] = {}
    notes: list[str] = []
    for name, joint in mechanism.joints.items():
        contacts = [c for c in by_joint.get(name, []) if c.point != "backlash"]
        if joint.clearance.backlash:
            notes.append(f"{name}: its drive's backlash (lost motion, no surface), not measured")
        rigid = [p.name for p in joint.clearance.contacts if p.bound == 0.0]
        if rigid and contacts:
            notes.append(
                f"{name}: {', '.join(rigid)} without play (rigid conditions), not measured"
            )
        if not contacts:
            notes.append(f"{name} ({joint.clearance.kind}): no play, nothing to measure")
            continue
        points = tuple(
            _point_reading(equilibrium, joint, contact, frames[name], probe) for contact in contacts
        )
        found: list[PointCheck | None] = []
        if bores:
            found.append(
                journal_in_bore(equilibrium, name, frames[name], probe, facets, journal_radius)
            )
        found.append(collision_parts(equilibrium, name, frames[name], probe, mesh_faceting))
        surfaces = tuple(s for s in found if s is not None)
        if any(not s.judged for s in surfaces):
            notes.append(
                f"{name}: URDF collision meshes of unknown faceting, only penetration judged "
                "(pass mesh_faceting=...)"
            )
        joints[name] = JointCheck(name, joint.clearance.kind, points, surfaces)
    return CheckReport(
        formulation=equilibrium.formulation,
        joints=joints,
        check_time=time.perf_counter() - started,
        coal_time=probe.coal_time,
        build_time=probe.build_time,
        readings=probe.count,
        gjk_tolerance=gjk_tolerance,
        notes=tuple(notes),
    )


def _point_reading(
    equilibrium: Equilibrium,
    joint: TreeJoint | LoopJoint,
    contact: Contact,
    frames: ClearanceFrames,
    probe: Probe,
) -> PointCheck:
    """coal's reading of one contact point: the child's point against its clearance region."""
    point = next(p for p in joint.clearance.contacts if p.name == contact.point)
    if point.bound != contact.clearance:  # measure the clearance the solver used
        point = dataclasses.replace(point, bound=contact.clearance)
    cache = shape_cache(solved_mechanism(equilibrium))
    key = ("functor", joint.name, point)
    if key not in cache:
        import coal

        region = probe.build(Region, point)
        dot = point_shape()
        # the functor keeps raw pointers to both shapes: the cache keeps them alive
        cache[key] = (region, dot, probe.build(coal.ComputeDistance, region.shape, dot))
    region, _, functor = cache[key]
    parent, child = frames.parent, frames.child
    x = child.rotation @ region.nominal + child.translation  # the child's point, world [m]
    oM_region = region.placement(parent.rotation, parent.translation, x)
    signed = probe.distance(functor, oM_region, None, (_IDENTITY, x), contact.label)
    tolerance = Tolerance(
        faceting=0.0,
        solver=solver_accuracy(equilibrium, point.bound, contact.gap, contact.active),
        coal=coal_accuracy(probe.gjk_tolerance, point.bound, float(np.linalg.norm(x))),
    )
    return PointCheck(
        joint.name,
        point.name,
        region.kind,
        point.bound,
        contact.gap,
        -signed,
        contact.active,
        tolerance,
    )


def _validate(
    equilibrium: Equilibrium,
    pose: str,
    journal_radius: float | None,
    facets: int,
    mesh_faceting: float | None,
    gjk_tolerance: float,
) -> None:
    if getattr(equilibrium, "mechanism", None) is None or not equilibrium.body_placements:
        raise ClearancePinError(
            "this equilibrium carries no solved pose (mechanism and body_placements): "
            "check the result of Mechanism.solve"
        )
    if pose not in POSES:
        raise ArgumentError("pose", f"one of {', '.join(map(repr, POSES))}", pose)
    if not isinstance(facets, int) or facets < 3:
        raise ArgumentError("facets", "an integer >= 3", facets)
    for name, value in (("journal_radius", journal_radius), ("mesh_faceting", mesh_faceting)):
        if value is not None and not (np.isfinite(value) and value >= 0.0):
            raise ArgumentError(name, "None or a finite length >= 0 [m]", value)
    if journal_radius is not None and journal_radius <= 0.0:
        raise ArgumentError("journal_radius", "None or a length > 0 [m]", journal_radius)
    if not (0.0 < gjk_tolerance <= 1e-3):
        raise ArgumentError("gjk_tolerance", "a number in (0, 1e-3]", gjk_tolerance)


def _play_frames(
    equilibrium: Equilibrium, frames: dict[str, ClearanceFrames]
) -> dict[str, ClearanceFrames]:
    """``frames`` with each joint's child frame where its play puts it: a joint with stiffness
    moves by its play then its spring (docs/method.md section 2.2.2), and its contact surfaces
    (the journal, the ball, the block) sit on the play's side of the spring, so the check reads
    them at the child frame less the spring's deflection."""
    deflections = equilibrium.deflections or {}
    if not deflections:
        return frames
    out = dict(frames)
    for name, deflection in deflections.items():
        unsprung = pin.exp6(pin.Motion(-np.asarray(deflection, dtype=float)))
        out[name] = dataclasses.replace(frames[name], child=frames[name].child * unsprung)
    return out


__all__ = ["CHECK_OPTIONS", "check_equilibrium", "exact_pose", "GJK_TOLERANCE", "FACETS", "POSES"]
