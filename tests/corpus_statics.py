"""Independent checks for the corpus of mechanisms written from the docs (tests/test_corpus_*.py).

Written from docs/model-format.md and the public API only, sharing no code with the solver:

- ``statics_residual``: per-body statics of a linear (small-displacement) equilibrium at the
  nominal pose. Every body must be balanced by its external loads, the contact forces the answer
  reports (force of the parent on the child at the contact point, clearance frame) and the
  reactions of the directions its joints hold without play (rigid components of the kind, the
  drive of a driven joint). Those reactions are not reported yet (issue 10 finding 5), so their
  magnitudes are fitted by least squares; the residual is what no reaction can balance.
- ``reaction_residual``: the same balance from ``Equilibrium.reaction`` alone, when it exists.
- ``clearance_frame``: the world placement of a joint's clearance frame from a plain Pinocchio
  forward kinematics.

Contact points, from the table of clearance kinds in docs/model-format.md (clearance frame, x =
joint axis): ``end-`` / ``end+`` at x = -/+ L/2 on the axis, ``axial``, ``ball`` and ``pin`` at
the joint centre, prismatic ``corner(sx sy sz).y|z`` at the block's corners x = +/- L/2, y = +/- width/2,
z = +/- height/2.
"""

from __future__ import annotations

import re

import numpy as np
import pinocchio as pin

from clearance_pin import Gravity, PointForce, Torque

U, V, W, ALPHA, BETA, GAMMA = range(6)

# components held without play, by clearance kind (docs/model-format.md, "Clearance kinds")
RIGID_BY_KIND = {
    "spherical": (),
    "cylindrical": (),
    "revolute": (),
    "planar_revolute": (U, BETA, GAMMA),
    "rigid": (U, V, W, ALPHA, BETA, GAMMA),
    "free": (),
}
OWN_MOTION = {"revolute": ALPHA, "planar_revolute": ALPHA, "prismatic": U, "cylindrical": None}


def held_components(joint) -> tuple[int, ...]:
    """Torsor components [index] that the joint holds by a reaction rather than a contact."""
    clearance = joint.clearance
    held = set(RIGID_BY_KIND.get(clearance.kind, ()))
    if clearance.kind == "prismatic" and not (clearance.width or clearance.height):
        pass  # roll free (docs: width = height = 0)
    elif clearance.kind == "prismatic":
        held.add(ALPHA)
    if clearance.kind == "revolute" and clearance.radial == 0.0:
        held.update((V, W, BETA, GAMMA))
    if clearance.kind == "revolute" and not clearance.axial:
        held.add(U)
    if getattr(joint, "driven", False) and OWN_MOTION.get(clearance.kind) is not None:
        held.add(OWN_MOTION[clearance.kind])
    return tuple(sorted(held))


def contact_point(joint, point_name: str) -> np.ndarray:
    """Position [m] of a contact point in the clearance frame, from the docs' table."""
    clearance = joint.clearance
    half = 0.5 * (clearance.length or 0.0)
    if point_name == "end-":
        return np.array([-half, 0.0, 0.0])
    if point_name == "end+":
        return np.array([half, 0.0, 0.0])
    if point_name in ("axial", "ball", "pin"):
        return np.zeros(3)
    corner = re.fullmatch(r"corner\(([+-]{3})\)\.[yz]", point_name)
    if corner:
        signs = [1.0 if sign == "+" else -1.0 for sign in corner.group(1)]
        sizes = [half, 0.5 * (clearance.width or 0.0), 0.5 * (clearance.height or 0.0)]
        return np.array([s * h for s, h in zip(signs, sizes)])
    raise KeyError(f"unknown contact point {point_name!r} of joint {joint.name!r}")


def placements(mechanism, q) -> tuple[list, list]:
    """World placements of the joints (oMi) and frames (oMf) at q, by a plain Pinocchio FK."""
    data = mechanism.model.createData()
    pin.framesForwardKinematics(mechanism.model, data, np.asarray(q, dtype=float))
    return [m.copy() for m in data.oMi], [m.copy() for m in data.oMf]


def joint_bodies(mechanism, joint, oMi, oMf) -> tuple[int, int, pin.SE3]:
    """(parent body, child body, world placement of the clearance frame) of a tree or loop joint.
    Tree joint: the child's joint frame (joint centre) rotated by the clearance axes; loop joint:
    ``frame_a`` rotated by the clearance axes (docs: ``axis`` is given in ``frame_a``)."""
    model = mechanism.model
    if hasattr(joint, "frame_a"):
        parent = model.frames[joint.frame_a].parentJoint
        child = model.frames[joint.frame_b].parentJoint
        return parent, child, oMf[joint.frame_a] * pin.SE3(joint.rotation, np.zeros(3))
    child = joint.joint_id
    return model.parents[child], child, oMi[child] * pin.SE3(joint.rotation, np.zeros(3))


def clearance_frame(mechanism, q, name: str) -> pin.SE3:
    """World placement of joint ``name``'s clearance frame at configuration q."""
    oMi, oMf = placements(mechanism, q)
    return joint_bodies(mechanism, mechanism.joint(name), oMi, oMf)[2]


def wrench_at_origin(force, point) -> np.ndarray:
    """(F, p x F) [N, N m]: a force F acting at the world point p, as a wrench at the origin."""
    force = np.asarray(force, dtype=float)
    return np.concatenate([force, np.cross(np.asarray(point, dtype=float), force)])


def external_wrenches(mechanism, loads, oMi, oMf) -> np.ndarray:
    """Wrench at the world origin of the external loads on each body, (njoints, 6) [N, N m]."""
    model = mechanism.model
    out = np.zeros((model.njoints, 6))
    for load in loads:
        if isinstance(load, Gravity):
            for b in range(1, model.njoints):
                inertia = model.inertias[b]
                weight = inertia.mass * np.asarray(load.acceleration, dtype=float)
                out[b] += wrench_at_origin(weight, oMi[b].act(inertia.lever))
            continue
        frame = model.getFrameId(load.link)
        body = model.frames[frame].parentJoint
        if isinstance(load, PointForce):
            out[body] += wrench_at_origin(load.force, oMf[frame].act(np.asarray(load.point)))
        elif isinstance(load, Torque):
            out[body, 3:] += np.asarray(load.torque, dtype=float)
        else:
            raise TypeError(load)
    return out


def all_joints(mechanism) -> list:
    return [*mechanism.tree_joints, *mechanism.loop_joints]


def statics_residual(equilibrium, loads, q=None) -> float:
    """Largest per-body imbalance of a linear equilibrium, relative to the largest load wrench.

    For every body b: sum of external wrenches + sum over joints of (+ on the child, - on the
    parent) [contact forces at their points + fitted reactions of the held components] = 0, all
    as wrenches at the world origin at the nominal pose (small-displacement statics).
    """
    mechanism = equilibrium.mechanism
    q = equilibrium.configuration.q if q is None else q
    oMi, oMf = placements(mechanism, q)
    nb = mechanism.model.njoints
    balance = external_wrenches(mechanism, loads, oMi, oMf)
    scale = float(np.abs(balance[1:]).max()) or 1.0
    contacts = {c.label: c for c in equilibrium.contacts}
    unknown_columns = []
    for joint in all_joints(mechanism):
        parent, child, oMc = joint_bodies(mechanism, joint, oMi, oMf)
        for point in joint.clearance.contacts:
            if point.bound == 0.0:  # a point held without play: its force is a reaction
                for k in point.components:
                    unit = wrench_at_origin(oMc.rotation[:, k], oMc.act(np.asarray(point.point)))
                    column = np.zeros((nb, 6))
                    column[child] += unit
                    column[parent] -= unit
                    unknown_columns.append(column[1:].ravel())
                continue
            contact = contacts[f"{joint.name}:{point.name}"]
            wrench = wrench_at_origin(
                oMc.rotation @ np.asarray(contact.force),
                oMc.act(contact_point(joint, point.name)),
            )
            balance[child] += wrench
            balance[parent] -= wrench
        for k in held_components(joint):
            axis = oMc.rotation[:, k % 3]
            unit = (
                wrench_at_origin(axis, oMc.translation)
                if k < 3
                else np.concatenate([np.zeros(3), axis])
            )
            column = np.zeros((nb, 6))
            column[child] += unit
            column[parent] -= unit
            unknown_columns.append(column[1:].ravel())
    rhs = balance[1:].ravel()  # the ground (body 0) takes whatever is left
    if unknown_columns:
        matrix = np.array(unknown_columns).T
        reactions = np.linalg.lstsq(matrix, -rhs, rcond=None)[0]
        rhs = rhs + matrix @ reactions
    return float(np.abs(rhs).max() / scale)


def reaction_residual(equilibrium, loads, q=None) -> float:
    """Per-body imbalance from ``Equilibrium.reaction(joint, frame="world")`` alone (issue 10
    finding 5), relative to the largest load wrench; the reaction is the wrench of the parent on
    the child, world axes, moment about the world origin. Exact answers are balanced at their
    solved pose (the loads' points follow their bodies)."""
    mechanism = equilibrium.mechanism
    q = equilibrium.configuration.q if q is None else q
    oMi, oMf = placements(mechanism, q)
    if equilibrium.formulation == "exact":  # statics at the solved pose
        model = mechanism.model
        oMi = [equilibrium.body_placements[i] for i in range(model.njoints)]
        oMf = [oMi[frame.parentJoint] * frame.placement for frame in model.frames]
    balance = external_wrenches(mechanism, loads, oMi, oMf)
    scale = float(np.abs(balance[1:]).max()) or 1.0
    for joint in all_joints(mechanism):
        parent, child, _ = joint_bodies(mechanism, joint, oMi, oMf)
        reaction = equilibrium.reaction(joint.name, frame="world")
        wrench = (
            np.concatenate([np.ravel(part) for part in reaction])
            if isinstance(reaction, tuple)
            else np.ravel(reaction)
        )
        balance[child] += wrench
        balance[parent] -= wrench
    return float(np.abs(balance[1:]).max() / scale)


def distance_to_line(point, origin, direction) -> float:
    """Distance [m] of a point from the line through origin along the unit direction."""
    offset = np.asarray(point) - np.asarray(origin)
    return float(np.linalg.norm(offset - direction * (direction @ offset)))
