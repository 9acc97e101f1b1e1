"""Statics checked without the solver: the reported contact forces balance the load on the shaft.

For the shaft cases of section 6 every clearance frame is parallel to the world axes (joint axis
along x), I1 is the tree joint (ground -> shaft) and I2 a loop joint from a ground frame to a
shaft frame, so every contact force is the force of the ground on the shaft, in world axes. Its
point is the joint centre (ball) or the joint centre -/+ L/2 along x (journal ends). Summing
force and moment over contacts and loads must give zero.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
import pytest
from conftest import CASES, build_case

SHAFT_CASES = sorted(CASES)


def contact_points(case: dict) -> dict[str, np.ndarray]:
    """World position [m] of every contact point of a shaft case, by ``joint:point`` label."""
    points = {}
    for joint in case["joint"]:
        centre = np.asarray(joint["center_m"], dtype=float)
        assert tuple(joint.get("axis", (1.0, 0.0, 0.0))) == (1.0, 0.0, 0.0)
        if joint["kind"] == "spherical":
            points[f"{joint['name']}:ball"] = centre
        else:
            half = np.array([joint["length_m"] / 2, 0.0, 0.0])
            points[f"{joint['name']}:end-"] = centre - half
            points[f"{joint['name']}:end+"] = centre + half
    return points


def wrench_sum(case: dict, contacts, point_of=None) -> tuple[np.ndarray, np.ndarray]:
    """Net force [N] and moment about the world origin [N m] on the shaft: contacts + load."""
    points = contact_points(case)
    load = case["load"]
    force = np.asarray(load["force_N"], dtype=float)
    moment = np.cross(np.asarray(load["point_m"], dtype=float), force) + np.asarray(
        load["torque_Nm"], dtype=float
    )
    total_force = force.copy()
    for contact in contacts:
        where = points[contact.label] if point_of is None else point_of(contact)
        total_force += contact.force
        moment = moment + np.cross(where, contact.force)
    return total_force, moment


def load_size(case: dict) -> tuple[float, float]:
    """|F| [N] and a moment size [N m] to judge residuals against."""
    load = case["load"]
    force = np.linalg.norm(load["force_N"])
    reach = max(np.linalg.norm(j["center_m"]) + j.get("length_m", 0.0) for j in case["joint"])
    moment = np.linalg.norm(load["torque_Nm"]) + force * max(reach, np.linalg.norm(load["point_m"]))
    return max(force, np.linalg.norm(load["torque_Nm"]) / reach), moment


@pytest.mark.parametrize("case_id", SHAFT_CASES)
def test_contact_forces_balance_the_load(case_id):
    """Small-displacement model: sum of contact forces + applied force = 0 and sum of their
    moments (nominal contact points) + applied moment = 0, to 1e-10 of the load."""
    case = CASES[case_id]
    result = build_case(case).solve()
    force, moment = wrench_sum(case, result.contacts)
    force_size, moment_size = load_size(case)
    assert np.linalg.norm(force) <= 1e-10 * force_size, force
    assert np.linalg.norm(moment) <= 1e-10 * moment_size, moment
    assert result.residuals["statics"] < 1e-9


@pytest.mark.parametrize("case_id", SHAFT_CASES)
def test_contact_forces_push_along_the_outward_normal(case_id):
    """A contact force pushes the shaft back into its play: it is opposite to the displacement
    of its contact point (its bounded components), and zero at a point with a gap."""
    case = CASES[case_id]
    result = build_case(case).solve()
    for contact in result.contacts:
        joint, point = contact.label.split(":")
        torsor = result.torsor(joint)
        r = {"ball": 0.0, "end-": -1.0, "end+": 1.0}[point] * next(
            j.get("length_m", 0.0) / 2 for j in case["joint"] if j["name"] == joint
        )
        displacement = torsor[:3] + np.cross(torsor[3:], [r, 0.0, 0.0])
        if point != "ball":
            displacement[0] = 0.0  # a journal end is bounded across the axis only
        if contact.force_magnitude == 0.0:
            continue
        assert contact.active
        cosine = (
            contact.force @ displacement / (contact.force_magnitude * np.linalg.norm(displacement))
        )
        assert cosine == pytest.approx(-1.0, abs=1e-12)
        assert np.linalg.norm(displacement) == pytest.approx(contact.clearance, rel=1e-12)


@pytest.mark.parametrize(
    "case_id", [c for c in SHAFT_CASES if not any(CASES[c]["load"]["torque_Nm"])]
)
def test_exact_contact_forces_balance_the_load_on_the_moved_shaft(case_id):
    """Exact model: the contact forces act at the contact points of the *moved* shaft and the
    load at the moved load point; force and moment still sum to zero (to 1e-8 of the load, the
    optimiser's tolerance). Cases with a torque are left out (the exact potential of a dead couple
    is C . vee((R - R^T)/2), not C . Theta)."""
    case = CASES[case_id]
    result = build_case(case).solve(exact=True)
    centres = {j["name"]: np.asarray(j["center_m"], dtype=float) for j in case["joint"]}
    lengths = {j["name"]: j.get("length_m", 0.0) for j in case["joint"]}

    def moved_point(contact):
        # the child point r (clearance frame = world axes) at the relative placement exp6(T)
        placement = pin.exp6(pin.Motion(result.torsor(contact.joint)))
        r = {"ball": 0.0, "end-": -0.5, "end+": 0.5}[contact.point] * lengths[contact.joint]
        return centres[contact.joint] + placement.act(np.array([r, 0.0, 0.0]))

    shaft = result.body_placements[1]
    # the shaft frame has world axes and its origin at the centre of I1
    local = np.asarray(case["load"]["point_m"], dtype=float) - centres["I1"]
    load_point = shaft.act(local)
    force = np.asarray(case["load"]["force_N"], dtype=float)
    total_force = force + sum(c.force for c in result.contacts)
    total_moment = np.cross(load_point, force) + sum(
        np.cross(moved_point(c), c.force) for c in result.contacts
    )
    force_size, moment_size = load_size(case)
    assert np.linalg.norm(total_force) <= 1e-8 * force_size
    assert np.linalg.norm(total_moment) <= 1e-8 * moment_size
    assert result.residuals["statics"] < 1e-9
