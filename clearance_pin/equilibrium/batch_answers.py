r"""The answers of a batch solved on stacked arrays, read for every case at once.

``solve_many`` keeps the cases it solved on stacked arrays (closed forms of a tree's blocks,
batched Newton) as arrays: reduced unknowns y, multipliers, slab sides and the scale sigma of
each case. An item is assembled as an :class:`~.result.Equilibrium` only when read
(:func:`.linear_answer.assemble_linear`); the whole-batch readers of
:class:`~.batch.EquilibriumBatch` form the same quantities from the arrays, every case at once,
with the formulas of the item (small-displacement model):

- unknowns :math:`x = Z Q y`;
- contact forces (clearance frame): :meth:`.prepared.PreparedGeometry.contact_state` per row,
  the touching contacts split by least norm where they are statically indeterminate
  (:func:`.linear_answer.split_force_rows`, asked only for the cases whose touching contacts are
  not surely independent);
- body twists (v, omega) at the world origin: the prepared maps at one configuration, or along a
  trajectory of a tree :math:`\xi_i = \xi_{\lambda(i)} + \mathrm{Ad}(oM_i C_k) B_k t_k`
  (:mod:`.tree_point`);
- the displacement of a frame f of body b: :math:`(v_b + \omega_b \times p_f, \omega_b)`;
- the joint reactions (:mod:`.batch_reactions`).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ..numerics import Array, Mask
from .linear_answer import ACTIVE_RELATIVE_GAP, split_force_rows
from .small_displacement import tree_joint_basis

if TYPE_CHECKING:
    from ..model.mechanism_parts import MechanismParts as Mechanism
    from .prepared import PreparedGeometry


@dataclass
class StackedAnswers:
    """The linear answers of the cases of a batch solved on stacked arrays.

    Attributes:
        mechanism: the solved mechanism.
        prepared: its prepared geometry at the nominal configuration (a tree: the one geometry of
            every configuration, :mod:`.tree_point`).
        y: reduced unknowns (N, r) (rows of the cases not solved here: anything, masked).
        multipliers: (N, m); signs: slab sides (N, m); sigmas: the objective scale sigma (N,) [J].
        stacked: (N,) the case's answer is in these arrays.
        rotations, translations: body placements (K, bodies, 3, 3), (K, bodies, 3) [m], K = 1
            (every case at the nominal configuration) or N (a trajectory of a tree).
        along: the cases are points of a trajectory (one configuration each; a tree).
        load_column: every case's loads (None: the model's); gravity: the solve's option.
        given: the arrays an engine already formed, as the items read them (the compiled
            kernel's rows): name (``"x"``, ``"gaps"``, ``"force_rows"``, ``"twists"``) ->
            (N, ...); the others are formed here.
    """

    mechanism: Mechanism
    prepared: PreparedGeometry
    y: Array
    multipliers: Array
    signs: Array
    sigmas: Array
    stacked: Mask
    rotations: Array
    translations: Array
    along: bool
    load_column: Any
    gravity: Any
    given: dict[str, Array] = field(default_factory=dict)

    @property
    def x(self) -> Array:
        """Unknowns x (N, n) [m, rad], :math:`x = Z Q y` as the item forms them."""
        cached: Array | None = self.__dict__.get("_x", self.given.get("x"))
        if cached is None:
            cached = self.__dict__["_x"] = self.y @ self.prepared.x_from_y.T
        return cached


def contact_forces(answers: StackedAnswers) -> Array:
    """Force of the parent on the child at every contact point, clearance frame, (N, m, 3) [N],
    as :attr:`.result.Equilibrium.contacts` gives them (module docstring)."""
    cached: Array | None = answers.__dict__.get("_contact_forces")
    if cached is not None:
        return cached
    prepared, x = answers.prepared, answers.x
    terms = prepared.terms
    count = len(x)
    if not len(terms.starts):
        return np.zeros((count, 0, 3))
    if "force_rows" in answers.given:
        gaps, rows = answers.given["gaps"], answers.given["force_rows"].copy()
    else:
        image = x @ terms.contact_rows.T + terms.contact_offsets
        gaps = prepared.bounds - np.sqrt(np.add.reduceat(image * image, terms.starts, axis=-1))
        row = terms.contact_of_row
        # PreparedGeometry.contact_state, with one set of slab sides per case
        rows = (answers.sigmas[:, None] * answers.multipliers[:, row]) * (
            terms.norm_force * image + terms.slab_force * answers.signs[:, row]
        )
    bounds = prepared.bounds
    active = (gaps <= ACTIVE_RELATIVE_GAP * bounds) | (
        (answers.multipliers > 0.0) & (gaps <= 1e-6 * bounds)
    )
    for i in _maybe_dependent(prepared, x, rows, active & answers.stacked[:, None]).tolist():
        rows[i] = split_force_rows(prepared, x[i], rows[i], active[i])
    out = np.zeros((count, 3 * len(terms.starts)))
    out[:, terms.scatter] = rows
    forces = out.reshape(count, -1, 3)
    answers.__dict__["_contact_forces"] = forces
    return forces


def _maybe_dependent(prepared: PreparedGeometry, x: Array, rows: Array, active: Mask) -> Array:
    r"""The cases whose touching contacts may be statically indeterminate: the ones
    :func:`.contact_split.least_norm_split` may change, asked one by one. A case is left out
    when it has fewer than two touching contacts, or when the Gram matrix :math:`G^T G` of its
    unit-force columns (formed as :func:`.linear_answer.split_force_rows` forms them) has its
    least eigenvalue above twice the shift :math:`10^{-12} \mathrm{tr}(G^T G)` by which
    ``_surely_independent`` tests it: that Cholesky factor then exists, the split is unique and
    the forces are kept."""
    terms = prepared.terms
    asked: list[Array] = []
    several = np.flatnonzero(active.sum(axis=1) >= 2)
    if not several.size:
        return np.zeros(0, dtype=np.intp)
    patterns, inverse = np.unique(active[several], axis=0, return_inverse=True)
    reduced_all = terms.contact_rows @ terms.x_from_y  # S Z Q: on the reduced unknowns
    for p, pattern in enumerate(patterns):
        members = several[inverse.ravel() == p]
        chosen = np.flatnonzero(pattern[terms.contact_of_row])
        owner = terms.contact_of_row[chosen]
        starts = np.flatnonzero(np.r_[True, owner[1:] != owner[:-1]])
        counts = np.diff(np.r_[starts, chosen.size])
        image = x[members] @ terms.contact_rows[chosen].T + terms.contact_offsets[chosen]
        sizes = np.sqrt(np.add.reduceat(image * image, starts, axis=1))
        directions = np.where(
            terms.is_norm[owner],
            -image / np.repeat(np.where(sizes > 0.0, sizes, 1.0), counts, axis=1),
            -np.sign(image),
        )
        columns = np.add.reduceat(
            reduced_all[chosen][None] * directions[:, :, None], starts, axis=1
        )  # (cases, a, r): G^T
        if columns.shape[1] > columns.shape[2]:
            asked.append(members)
            continue
        gram = columns @ columns.transpose(0, 2, 1)
        shift = 1e-12 * np.trace(gram, axis1=1, axis2=2)
        lowest = np.linalg.eigvalsh(gram)[:, 0]
        loaded = np.any(rows[members][:, chosen] != 0.0, axis=1)
        asked.append(members[loaded & ~(lowest > 2.0 * shift)])
    return np.concatenate(asked)


def body_twists(answers: StackedAnswers) -> Array:
    """Spatial twist (v, omega) at the world origin of every body, (N, bodies, 6) [m, rad]."""
    cached: Array | None = answers.__dict__.get("_twists")
    if cached is not None:
        return cached
    x, prepared = answers.x, answers.prepared
    if "twists" in answers.given:
        twists = answers.given["twists"]
    elif not answers.along:  # the prepared maps of the one configuration, as the item reads them
        twists = np.array([prepared.body_twists(row) for row in x]).reshape(len(x), -1, 6)
    else:
        twists = tree_body_twists(answers.mechanism, answers.rotations, answers.translations, x)
    answers.__dict__["_twists"] = twists
    return twists


def tree_body_twists(
    mechanism: Mechanism, rotations: Array, translations: Array, x: Array
) -> Array:
    r"""Body twists (N, bodies, 6) of a tree at N configurations (body placements (N, bodies,
    3, 3), (N, bodies, 3) [m]) from the unknowns x (N, n): each joint's torsor
    :math:`B_k t_k` composed along the tree (:func:`torsor_twists`)."""
    torsors = {}
    start = 0
    for joint in mechanism.tree_joints:
        basis = tree_joint_basis(joint)
        torsors[joint.name] = x[:, start : start + basis.shape[1]] @ basis.T
        start += basis.shape[1]
    return torsor_twists(mechanism, rotations, translations, torsors)


def torsor_twists(
    mechanism: Mechanism, rotations: Array, translations: Array, torsors: Mapping[str, Array]
) -> Array:
    r"""Body twists (N, bodies, 6) at the world origin of a tree whose joints' torsors are
    ``torsors`` (name -> (N, 6) [m, rad], clearance frames): :math:`\xi_i = \xi_{\lambda(i)} +
    \mathrm{Ad}(oM_i C_k)\, \tau_k`, with :math:`\mathrm{Ad}(R, p)(v, \omega) = (R v + p \times
    R \omega, R \omega)` (as :meth:`.tree_point.TreePoint.body_twists` forms them one by one);
    body placements (K, bodies, 3, 3), (K, bodies, 3) [m], K = N (a trajectory) or 1."""
    model = mechanism.model
    count = len(next(iter(torsors.values()))) if torsors else len(rotations)
    twists = np.zeros((count, model.njoints, 6))
    by_id = {joint.joint_id: joint for joint in mechanism.tree_joints}
    for i in range(1, model.njoints):  # a parent before its children
        joint = by_id[i]
        local = torsors[joint.name]  # (N, 6), clearance frame
        turn = rotations[:, i] @ joint.rotation  # R_i C_k (K, 3, 3)
        omega = (turn @ local[:, 3:, None])[..., 0]
        v = (turn @ local[:, :3, None])[..., 0] + np.cross(translations[:, i], omega)
        twists[:, i, :3] = twists[:, model.parents[i], :3] + v
        twists[:, i, 3:] = twists[:, model.parents[i], 3:] + omega
    return twists


def frame_displacements(answers: StackedAnswers, frame_id: int) -> tuple[Array, Array]:
    r"""World displacement of frame ``frame_id`` in every case: translations (N, 3) [m] of its
    origin, :math:`v_b + \omega_b \times p_f`, and rotations :math:`\omega_b` (N, 3) [rad]
    (:meth:`.result.Equilibrium.frame_displacement`, small-displacement model)."""
    model = answers.mechanism.model
    frame = model.frames[frame_id]
    body = frame.parentJoint
    twists = body_twists(answers)[:, body]
    rotation = answers.rotations[:, body]
    origin = rotation @ frame.placement.translation + answers.translations[:, body]  # oMf
    translation = twists[:, :3] + np.cross(twists[:, 3:], origin)
    return translation, twists[:, 3:].copy()


__all__ = [
    "StackedAnswers",
    "body_twists",
    "contact_forces",
    "frame_displacements",
    "torsor_twists",
    "tree_body_twists",
]
