r"""Joint stiffness: an elastic deflection in series with a joint's play (issue 23).

A joint's relative motion is its play torsor :math:`p` (bounded by its contacts) plus an elastic
deflection :math:`e` with energy :math:`\tfrac12 e^T K e` (the virtual joint method of Pashkevich
and Klimchik: a link's compliance lumped at its joint). K is a symmetric positive semi-definite
6x6 matrix in the joint's clearance frame (components :math:`(u, v, w, \alpha, \beta, \gamma)`,
x along the joint axis; [N/m] on translations, [N m/rad] on rotations, [N] or [N m/m] across).
A direction K leaves at zero is rigid, as without stiffness.

The attributes of a clearance file build K (always SI, whatever the block's ``unit``):

- ``radial_stiffness`` [N/m]: v and w of a journal or block; u, v and w of a ball;
- ``axial_stiffness`` [N/m]: u of a revolute or planar pin (a cylindrical or prismatic joint
  slides along u);
- ``tilt_stiffness`` [N m/rad]: beta and gamma of a journal, block or planar pin;
- ``drive_stiffness`` [N m/rad, or N/m for a prismatic drive]: the driven joint's own motion
  (a drive's torsional compliance, in series with its backlash);
- ``stiffness``: the full matrix, 36 numbers row by row (the other attributes then add to it);
- ``stiffness_frame``: ``"housing"`` (default) or ``"part"``, the part K is fixed in.

**Frame.** A tree joint's clearance frame is carried by its child (the part): at a configuration
q it has turned with the joint's own motion. K stated in the *housing's* frame (the parent's
side, the clearance frame at the joint's zero motion) is, in the part's frame at q,

.. math:: K_{part}(q) = G^T K\, G, \qquad G = \mathrm{diag}(R(q), R(q)),

:math:`R(q)` the part's rotation relative to the housing in clearance-frame axes (for a revolute
joint the rotation by q about x): a deflection :math:`e` of the part reads :math:`G e` in the
housing's axes, of energy :math:`\tfrac12 (G e)^T K (G e)`. Its deflecting directions are
:math:`G^T D` with the same stiffnesses (:func:`elastic_at`, read by the small-displacement maps
and the reactions; :func:`in_part_frame` gives the exact model's twin :math:`G^T K G`; a tree batch
turns its wrenches by the same G per case, from the cases' placements,
``equilibrium/elastic_batch.py``). ``"part"`` keeps K in the child's frame, turning with it. The
default is the housing: a bearing's stiffness, stated in a datasheet, belongs to the bearing seat
and its housing, which do not turn with the shaft; a K symmetric about the axis (every attribute
but the full matrix: equal radial stiffness in v and w, equal tilt in beta and gamma) is the same
in both frames, so the choice shows only for a full, non-axisymmetric K (a housing stiffer one way
than the other, or a link's compliance lumped at its joint as in the virtual joint method, which
turns with the link: ``"part"``). A loop joint's clearance frame keeps the housing's axes about the
spin (docs/method.md section 2.3), so its K is the housing's; ``"part"`` is refused there.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import replace
from functools import lru_cache

import numpy as np
import pinocchio as pin

from ..errors import ArgumentError
from .clearance import BETA, GAMMA, Clearance, U, V, W
from .joints import LoopJoint, TreeJoint

STIFFNESS_ATTRIBUTES = (
    "radial_stiffness",
    "axial_stiffness",
    "tilt_stiffness",
    "drive_stiffness",
    "stiffness",
)
STIFFNESS_FRAMES = ("housing", "part")
SYMMETRY_RTOL = 1e-9  # of the largest entry: a stiffness matrix must be symmetric to this
ELASTIC_RTOL = 1e-12  # eigenvalues below this share of the largest are rigid directions
JOURNALS = ("cylindrical", "revolute", "prismatic", "planar_revolute")
COMPONENTS: dict[str, dict[str, tuple[int, ...]]] = {
    "radial_stiffness": {
        "spherical": (U, V, W),
        **dict.fromkeys(JOURNALS, (V, W)),
    },
    "axial_stiffness": {"revolute": (U,), "planar_revolute": (U,)},
    "tilt_stiffness": dict.fromkeys(JOURNALS, (BETA, GAMMA)),
}


def stiffness_matrix(
    kind: str,
    values: dict[str, float],
    full: np.ndarray | None = None,
    drive_component: int | None = None,
) -> np.ndarray:
    """K (6, 6) of a joint of clearance ``kind`` from its stiffness attributes ``values``
    (attribute -> value, SI), the full matrix ``full`` (6, 6) and, for ``drive_stiffness``, the
    component its drive moves (``ALPHA`` or ``U``; None: the joint is not driven).

    Raises:
        ArgumentError: an attribute the kind has no component for, a value not finite and > 0,
            or a full matrix not symmetric positive semi-definite; the message names it.
    """
    matrix = np.zeros((6, 6)) if full is None else _checked_full(full)
    for attribute, value in values.items():
        if not (math.isfinite(value) and value > 0.0):
            raise ArgumentError(attribute, "a finite number > 0 (SI)", value)
        if attribute == "drive_stiffness":
            if drive_component is None:
                raise ArgumentError(
                    attribute,
                    'the stiffness of a drive, and this joint is not driven: add driven="true" '
                    "(or remove drive_stiffness)",
                    value,
                )
            components: tuple[int, ...] = (drive_component,)
        else:
            by_kind = COMPONENTS[attribute]
            if kind not in by_kind:
                takers = ", ".join(by_kind)
                raise ArgumentError(
                    attribute,
                    f"a stiffness of a {takers} joint (use stiffness, the full 6x6 matrix, for "
                    "another direction)",
                    value,
                    f"{attribute} does not apply to a {kind} joint",
                )
            components = by_kind[kind]
        for component in components:
            matrix[component, component] += value
    return matrix


def _checked_full(full: np.ndarray) -> np.ndarray:
    matrix = np.asarray(full, dtype=float)
    if matrix.size != 36 or not np.all(np.isfinite(matrix)):
        raise ArgumentError(
            "stiffness", "36 finite numbers (the 6x6 matrix row by row)", f"{matrix.size} numbers"
        )
    matrix = matrix.reshape(6, 6)
    largest = float(np.abs(matrix).max())
    if float(np.abs(matrix - matrix.T).max()) > SYMMETRY_RTOL * largest:
        raise ArgumentError("stiffness", "a symmetric 6x6 matrix", "an unsymmetric one")
    if np.linalg.eigvalsh(0.5 * (matrix + matrix.T))[0] < -ELASTIC_RTOL * largest:
        raise ArgumentError(
            "stiffness",
            "a positive semi-definite matrix (no negative energy)",
            "a negative eigenvalue",
        )
    symmetric: np.ndarray = 0.5 * (matrix + matrix.T)
    return symmetric


def as_entries(matrix: np.ndarray) -> tuple[tuple[float, ...], ...] | None:
    """K as nested tuples (hashable, for a frozen clearance), None when it is zero (rigid)."""
    if not np.any(matrix):
        return None
    return tuple(tuple(float(v) for v in row) for row in matrix)


def stiff_joints(joints: Mapping[str, TreeJoint | LoopJoint]) -> list[str]:
    """The names of the joints (name -> TreeJoint or LoopJoint) that have stiffness."""
    return [name for name, joint in joints.items() if joint.clearance.stiffness]


def elastic(clearance: Clearance) -> tuple[np.ndarray, np.ndarray]:
    """The directions of a joint that deflect elastically: basis (6, m) in its clearance frame
    and their stiffnesses (m,) [N/m or N m/rad]; (6, 0) and (0,) for a rigid joint."""
    if clearance.stiffness is None:
        return np.zeros((6, 0)), np.zeros(0)
    return elastic_directions(clearance.stiffness)


@lru_cache(maxsize=256)
def elastic_directions(entries: tuple[tuple[float, ...], ...]) -> tuple[np.ndarray, np.ndarray]:
    r"""The eigen-directions of K with positive stiffness: basis (6, m) orthonormal and the
    stiffnesses (m,), so that :math:`K = B\,\mathrm{diag}(k)\,B^T` on the directions that deflect
    (coordinate axes kept as they are for a diagonal K)."""
    matrix = np.array(entries, dtype=float)
    largest = float(np.abs(matrix).max())
    if not np.any(matrix - np.diag(np.diag(matrix))):
        diagonal = np.diag(matrix)
        kept = diagonal > ELASTIC_RTOL * largest
        basis, values = np.eye(6)[:, kept], diagonal[kept]
    else:
        eigenvalues, vectors = np.linalg.eigh(matrix)
        kept = eigenvalues > ELASTIC_RTOL * largest
        basis, values = vectors[:, kept], eigenvalues[kept]
    basis.setflags(write=False)
    values.setflags(write=False)
    return basis, values


@lru_cache(maxsize=256)
def axisymmetric(entries: tuple[tuple[float, ...], ...]) -> bool:
    """K is the same turned by any angle about the joint's axis x (to :data:`SYMMETRY_RTOL` of
    its largest entry): a turn by 1 rad leaves it unchanged (a K that commutes with one
    rotation about x not a multiple of pi/2 commutes with all)."""
    matrix = np.array(entries, dtype=float)
    turn = _turn(pin.exp3(np.array([1.0, 0.0, 0.0])))
    largest = float(np.abs(matrix).max())
    return float(np.abs(turn.T @ matrix @ turn - matrix).max()) <= SYMMETRY_RTOL * largest


def part_rotation(model: pin.Model, joint: TreeJoint, oMi: Sequence[pin.SE3]) -> np.ndarray:
    r"""R (3, 3): the rotation of ``joint``'s part relative to its housing at the placements
    ``oMi`` (Pinocchio's, at a configuration q), in clearance-frame axes:
    :math:`R = C^T\, \mathrm{rot}(M_J^{-1}\, {}^oM_p^{-1}\, {}^oM_i)\, C`, :math:`M_J` the
    joint's placement in its parent, C the clearance frame's rotation in the joint frame (a
    revolute joint: the rotation by q about x)."""
    i = joint.joint_id
    own = model.jointPlacements[i].inverse() * oMi[int(model.parents[i])].inverse() * oMi[i]
    rotation: np.ndarray = joint.rotation.T @ own.rotation @ joint.rotation
    return rotation


def elastic_at(
    joint: TreeJoint | LoopJoint, model: pin.Model, oMi: Sequence[pin.SE3]
) -> tuple[np.ndarray, np.ndarray]:
    """The deflecting directions (6, m) of ``joint`` in its clearance frame at the placements
    ``oMi`` and their stiffnesses (m,) (:func:`elastic`): K stated in the housing's frame is
    turned into the part's, :math:`G^T D` (module docstring); the part's K, a K symmetric about
    the axis and a loop joint's K as they are."""
    directions, stiffnesses = elastic(joint.clearance)
    entries = joint.clearance.stiffness
    if (
        entries is None
        or not isinstance(joint, TreeJoint)
        or joint.clearance.stiffness_frame == "part"
        or axisymmetric(entries)
    ):
        return directions, stiffnesses
    turn = _turn(part_rotation(model, joint, oMi))
    turned: np.ndarray = turn.T @ directions
    return turned, stiffnesses


def in_part_frame(clearance: Clearance, rotation: np.ndarray) -> Clearance:
    """``clearance`` with its K (stated in the housing's frame) given in the part's frame of a
    joint turned by ``rotation`` (3, 3) (:func:`part_rotation`): :math:`G^T K G`,
    ``stiffness_frame="part"`` (the exact model's twin: its springs' directions are fixed in the
    part)."""
    assert clearance.stiffness is not None
    turn = _turn(rotation)
    matrix = turn.T @ np.array(clearance.stiffness, dtype=float) @ turn
    return replace(
        clearance, stiffness=as_entries(0.5 * (matrix + matrix.T)), stiffness_frame="part"
    )


def turning(joints: Iterable[TreeJoint | LoopJoint]) -> list[TreeJoint]:
    """The tree joints whose K is stated in the housing's frame and is not symmetric about the
    axis: their K in the part's frame depends on the joint's angle (:func:`elastic_at`)."""
    return [
        joint
        for joint in joints
        if isinstance(joint, TreeJoint)
        and joint.clearance.stiffness is not None
        and joint.clearance.stiffness_frame == "housing"
        and not axisymmetric(joint.clearance.stiffness)
    ]


def turned_stiffness(
    joints: Iterable[TreeJoint | LoopJoint], model: pin.Model, oMi: Sequence[pin.SE3]
) -> list[str]:
    """The names of the :func:`turning` joints that have turned at the placements ``oMi`` (their
    K in the part's frame there differs from the housing's)."""
    return [
        joint.name
        for joint in turning(joints)
        if float(np.abs(part_rotation(model, joint, oMi) - np.eye(3)).max()) > 1e-15
    ]


def _turn(rotation: np.ndarray) -> np.ndarray:
    """G = diag(R, R) (6, 6): a torsor's or wrench's rotation by R, both halves."""
    turn = np.zeros((6, 6))
    turn[:3, :3] = turn[3:, 3:] = rotation
    return turn


__all__ = [
    "STIFFNESS_ATTRIBUTES",
    "STIFFNESS_FRAMES",
    "axisymmetric",
    "elastic_at",
    "in_part_frame",
    "part_rotation",
    "turned_stiffness",
    "turning",
    "as_entries",
    "elastic",
    "elastic_directions",
    "stiff_joints",
    "stiffness_matrix",
]
