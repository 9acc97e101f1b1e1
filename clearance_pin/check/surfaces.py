r"""Surface checks: the parts themselves, not their axis points, measured by coal at the solved pose.

Two sources of surfaces:

- **generated bore** (cylindrical and revolute joints, ``check(bores=True)``): a journal cylinder
  of radius :math:`R` (default :data:`JOURNAL_RADIUS_RATIO` clearances) and length :math:`L` on the
  child's clearance frame, in a bore of :math:`N` facets tangent to the circle of radius
  :math:`R + c` on the parent's (:mod:`.geometry`). The bore is long (:data:`~.geometry.BORE_LENGTH`
  journal lengths) and centred, along its axis, on the journal: the model's bore is unbounded
  axially. coal's distance :math:`D_N` satisfies
  :math:`g \le D_N \le g + R(1-\cos\theta) + (R + c)(1/\cos(\pi/N) - 1)` where :math:`g` is the
  model's smallest gap of the two axis ends (:mod:`.accuracy`).
- **URDF parts** (any joint whose two links carry ``<collision>`` geometry): the smallest coal
  distance between the parent link's and the child link's geometries, compared with the model's
  smallest gap of the joint. The parts must be sized to the declared clearances (a journal of the
  model's length in a longer bore, a ball in a socket); primitives are exact, a mesh needs its
  faceting bound (``mesh_faceting`` [m]), otherwise only penetration is judged.

When a part overlaps a mesh, coal's reading is the depth of the deepest part-vs-triangle
penetration, which can be much smaller than the overlap of the solids (a thin facet is pushed out
sideways): a negative surface reading says *that* the parts overlap; the point checks say by how much.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pinocchio as pin

from .accuracy import Tolerance, coal_accuracy, rim_excess, solver_accuracy
from .geometry import (
    BORE_LENGTH,
    bore_mesh,
    cyclic_rotation,
    faceting_bound,
    journal_shape,
    shape_cache,
)
from .measure import Probe
from .poses import ClearanceFrames, joint_links, solved_mechanism
from .report import PointCheck

if TYPE_CHECKING:
    import coal

    from ..equilibrium.result import Contact, Equilibrium

JOURNAL_RADIUS_RATIO = 10.0
"""Default journal radius of a generated bore, in radial clearances."""

_TO_X = pin.SE3(cyclic_rotation(0), np.zeros(3))


def radial_contacts(equilibrium: Equilibrium, joint_name: str) -> list[Contact]:
    """The joint's contacts on two bounded components (the journal's axis ends)."""
    joint = solved_mechanism(equilibrium).joint(joint_name)
    radial = {p.name for p in joint.clearance.contacts if len(p.components) == 2}
    return [c for c in equilibrium.contacts if c.joint == joint_name and c.point in radial]


def journal_in_bore(
    equilibrium: Equilibrium,
    name: str,
    frames: ClearanceFrames,
    probe: Probe,
    facets: int,
    journal_radius: float | None,
) -> PointCheck | None:
    """The generated-bore reading of a cylindrical or revolute joint (None for other kinds)."""
    joint = solved_mechanism(equilibrium).joint(name)
    clearance = joint.clearance
    contacts = radial_contacts(equilibrium, name)
    if clearance.kind not in ("cylindrical", "revolute") or not contacts:
        return None
    c, length = clearance.radial, clearance.length
    radius = JOURNAL_RADIUS_RATIO * c if journal_radius is None else journal_radius
    bore_length = BORE_LENGTH * length
    cache = shape_cache(solved_mechanism(equilibrium))
    bore_key, journal_key = ("bore", radius + c, facets, bore_length), ("journal", radius, length)
    if bore_key not in cache:
        cache[bore_key] = probe.build(bore_mesh, radius + c, facets, bore_length)
    if journal_key not in cache:
        cache[journal_key] = probe.build(journal_shape, radius, length)
    bore, journal = cache[bore_key], cache[journal_key]
    relative = frames.relative
    oM_journal = frames.child * _TO_X
    slide = pin.SE3(np.eye(3), np.array([relative.translation[0], 0.0, 0.0]))
    oM_bore = frames.parent * slide
    distance = probe.distance(bore, oM_bore, journal, oM_journal, f"{name}:surface")
    nearest = min(contacts, key=lambda c: c.gap)
    contact = any(c.active for c in contacts)
    position = float(np.linalg.norm(oM_journal.translation)) + length
    tolerance = Tolerance(
        faceting=faceting_bound(radius + c, facets),
        rim=rim_excess(radius, relative.rotation),
        solver=solver_accuracy(equilibrium, c, nearest.gap, contact),
        coal=coal_accuracy(probe.gjk_tolerance, max(length, radius + c), position, inflated=True),
        one_sided=True,
    )
    return PointCheck(
        name, "surface", f"bore N={facets}", c, nearest.gap, distance, contact, tolerance
    )


def collision_parts(
    equilibrium: Equilibrium,
    name: str,
    frames: ClearanceFrames,
    probe: Probe,
    mesh_faceting: float | None,
) -> PointCheck | None:
    """The URDF-parts reading of a joint (None unless both links carry collision geometry)."""
    import coal

    mechanism = solved_mechanism(equilibrium)
    geometry = mechanism.collision_model
    if geometry is None:
        return None
    contacts = [c for c in equilibrium.contacts if c.joint == name]
    parent_link, child_link = joint_links(mechanism, name)
    parents = [g for g in geometry.geometryObjects if g.parentFrame == parent_link]
    children = [g for g in geometry.geometryObjects if g.parentFrame == child_link]
    if not (parents and children and contacts):
        return None
    placed = equilibrium.body_placements
    distance, position, reach, size, exact = np.inf, 0.0, 0.0, 0.0, True
    for a in parents:
        for b in children:
            oMa = placed[a.parentJoint] * a.placement
            oMb = placed[b.parentJoint] * b.placement
            reading = probe.distance(a.geometry, oMa, b.geometry, oMb, f"{name}:parts")
            distance = min(distance, reading)
            position = max(position, float(np.linalg.norm(oMb.translation)))
            axis_radius, bounding_radius = _radii(b.geometry)
            reach, size = max(reach, axis_radius), max(size, bounding_radius)
            exact = exact and all(isinstance(g.geometry, coal.ShapeBase) for g in (a, b))
    nearest = min(contacts, key=lambda c: c.gap)
    contact = any(c.active for c in contacts)
    clearance = mechanism.joint(name).clearance.max_play
    faceting = 0.0 if exact else (mesh_faceting or 0.0)
    tolerance = Tolerance(
        faceting=faceting,
        rim=rim_excess(reach, frames.relative.rotation),
        solver=solver_accuracy(equilibrium, nearest.clearance, nearest.gap, contact),
        coal=coal_accuracy(
            probe.gjk_tolerance, max(size, clearance), position + size, inflated=True
        ),
    )
    return PointCheck(
        name,
        "parts",
        "parts" + ("" if exact else " (mesh)"),
        nearest.clearance,
        nearest.gap,
        float(distance),
        contact,
        tolerance,
        judged=exact or mesh_faceting is not None,
    )


def _radii(shape: coal.CollisionGeometry) -> tuple[float, float]:
    """(radius about its axis for the rim term, bounding radius) [m] of a child part: a
    cylinder's radius, else the bounding radius about the geometry's origin (conservative)."""
    import coal

    shape.computeLocalAABB()
    bounding = float(np.linalg.norm(shape.aabb_center) + shape.aabb_radius)
    if isinstance(shape, coal.Cylinder):
        return float(shape.radius), bounding
    return bounding, bounding


__all__ = ["JOURNAL_RADIUS_RATIO", "journal_in_bore", "collision_parts", "radial_contacts"]
