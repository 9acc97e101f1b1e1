"""The one load front end (issue 22): every engine reads its body wrenches from one linear map
per set of loaded points, W = A p (equilibrium/load_map.py), formed from unit loads by the one
reading of loads (load_table) and its wrench formula (body_wrenches).

The reference here is computed without the library's load code: Pinocchio's own placements
(``framesForwardKinematics``) and the textbook wrench of a force at a world point, of a torque
and of a body's weight at its centre of mass, about the world origin.
"""

from __future__ import annotations

import numpy as np
import pinocchio as pin
from conftest import MODELS

import clearance_pin as cp
from clearance_pin.equilibrium.prepared import prepared_geometry


def _reference(arm, q, loads):
    """Body wrenches (bodies, 6) about the world origin [N, N m] from Pinocchio's placements."""
    model = arm.model
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    out = np.zeros((model.njoints, 6))
    for load in loads:
        if isinstance(load, cp.Gravity):
            for body in range(1, model.njoints):
                inertia = model.inertias[body]
                weight = inertia.mass * load.acceleration
                centre = data.oMi[body].act(inertia.lever)
                out[body] += np.concatenate([weight, np.cross(centre, weight)])
            continue
        frame = model.getFrameId(load.link, pin.BODY)
        body = model.frames[frame].parentJoint
        if body == 0:
            continue
        if isinstance(load, cp.PointForce):
            point = data.oMf[frame].act(load.point)
            out[body] += np.concatenate([load.force, np.cross(point, load.force)])
        else:
            out[body, 3:] += load.torque
    return out


def test_wrenches_equal_pinocchio_statics_of_the_same_loads():
    """prepared.wrenches (W = A p) of a force at an off-origin point, a torque and a tilted
    gravity equals the reference to 1e-13 of the largest, at three configurations; a second
    set of vectors of the same loaded points reuses the map (one map for the signature)."""
    arm = cp.load(MODELS / "arm_6r.urdf")
    rng = np.random.default_rng(4)
    links = list(arm.link_frames)
    for q in (arm.q_nominal, arm.q_nominal + 0.3, arm.q_nominal - rng.uniform(0, 1, arm.model.nq)):
        prepared = prepared_geometry(arm, q)
        point = rng.normal(size=3) * 0.1
        for _ in range(3):
            loads = (
                cp.PointForce("tool", rng.normal(size=3) * 40, point),
                cp.Torque(links[3], rng.normal(size=3) * 5),
                cp.Gravity(np.array([0.0, 0.0, -9.81]) + rng.normal(size=3)),
            )
            expected = _reference(arm, prepared.configuration.q, loads)
            got = prepared.wrenches(loads)
            assert np.allclose(got, expected, rtol=0, atol=1e-13 * np.abs(expected).max())
        assert len(prepared._load_maps) == 1  # private: the one map of this signature


def test_a_subclass_of_a_load_is_read_as_its_load():
    """A user's subclass of PointForce is read as a PointForce by every engine (the load map's
    signature, the batch's table, the resolver's lane): the same torsors as the plain load."""

    class ToolForce(cp.PointForce):
        pass

    arm = cp.load(MODELS / "arm_6r.urdf")
    plain = arm.solve([cp.PointForce("tool", [0.0, 10.0, -50.0], [0.0, 0.02, 0.0])])
    for _ in range(3):  # the third through the resolver of these loaded points
        given = arm.solve([ToolForce("tool", [0.0, 10.0, -50.0], [0.0, 0.02, 0.0])])
    batch = arm.solve_many([[ToolForce("tool", [0.0, 10.0, -50.0], [0.0, 0.02, 0.0])]] * 3)
    for joint in arm.joints:
        assert np.allclose(given.torsor(joint), plain.torsor(joint), rtol=1e-12, atol=1e-18)
        assert np.allclose(batch.torsors(joint), plain.torsor(joint), rtol=1e-12, atol=1e-18)
