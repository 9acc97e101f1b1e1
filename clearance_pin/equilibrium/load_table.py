r"""The one reading of loads: one row per load term on a body, and the body wrenches of all cases.

The loads of N cases (each a list of :class:`~clearance_pin.model.loads.PointForce`,
``Torque`` and ``Gravity``, resolved as :meth:`Mechanism.resolve_loads` resolves them) become rows
(case, body, F [N], point p in the body frame [m], C [N m]), world axes; gravity is one row per
body with mass (:math:`F = m a`, p its centre of mass). With the body rotations :math:`R_b` of
each case (one configuration for all, or one per case) the wrench of each body about its own
origin :math:`t_b` (world axes) is

.. math::  W_b = \Big(\sum F,\ \sum (R_b p) \times F + C\Big) \qquad [N,\ N\,m],

summed per case and body by one weighted count per component: the lever arms are the points'
offsets :math:`R_b p` from the body origin, never their world positions, so that the moments
about the joint centres (:mod:`.tree_trajectory`) are formed without the round-off of a moment
about the world origin; the moments about the world origin,
:math:`\sum (R_b p + t_b) \times F + C`, come beside them. Every engine reads its loads through
here: a batch through its table, one solve through the linear map of its loads' signature formed
from unit loads (:mod:`.load_map`), the exact model through its table's per-body sums
(:func:`.load_terms.gather_body_loads`). A case whose loads cannot be read (an unknown link, not
a load) is marked invalid and left to a single solve, which raises or reports its error
(:func:`check_links`).
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass, replace
from itertools import compress
from typing import TYPE_CHECKING, overload

import numpy as np

from ..errors import LoadError
from ..model.loads import Gravity, PointForce, Torque, added_gravity, with_vector
from ..numerics import Array, Index, Mask

if TYPE_CHECKING:
    from ..model.mechanism_parts import MechanismParts as Mechanism


@dataclass(frozen=True)
class LoadTable:
    """The load terms of N cases.

    Attributes:
        count: number of cases N.
        case: per row, its case, (L,).
        body: per row, its body (Pinocchio joint index >= 1), (L,).
        force: per row, F (L, 3) [N], world axes.
        point: per row, p (L, 3) [m], body frame.
        torque: per row, C (L, 3) [N m], world axes.
        valid: per case, all its loads were read, (N,).
        gravity: the acceleration (3,) [m/s^2] of the gravity every case has (the model's or the
            solve's option), None without; its terms are formed once per configuration.
        weighed: the bodies with mass, (B_m,); masses (B_m,) [kg]; levers: their centres of mass
            in the body frames (B_m, 3) [m].
    """

    count: int
    case: Index
    body: Index
    force: Array
    point: Array
    torque: Array
    valid: Mask
    gravity: Array | None
    weighed: Index
    masses: Array
    levers: Array


KIND = {PointForce: 0, Torque: 1, Gravity: 2}  # any other object: 3, not a load


class LoadVectors(Sequence[tuple[object, ...]]):
    """N load cases that share one set of loads (kinds, links, points) and differ by the force
    and torque vectors: ``template`` (resolved loads, checked) and ``vectors`` (N, 3 k) [N, N m],
    row n the vectors of case n's PointForce and Torque loads in the template's order (3 numbers
    each). A case reads as the tuple of its loads, built when read; the batch engines read the
    vectors themselves (:func:`load_table`, :meth:`.fast_path.FastTerms.load_cases`), so that
    1e5 cases from a planner's arrays build no load object."""

    def __init__(self, template: Sequence[object], vectors: Array) -> None:
        self.template = tuple(template)
        self.varying = tuple(
            k for k, load in enumerate(self.template) if type(load) in (PointForce, Torque)
        )
        self.vectors = vectors

    def __len__(self) -> int:
        return len(self.vectors)

    @overload
    def __getitem__(self, index: int) -> tuple[object, ...]: ...

    @overload
    def __getitem__(self, index: slice) -> LoadVectors: ...

    def __getitem__(self, index: int | slice) -> tuple[object, ...] | LoadVectors:
        if isinstance(index, slice):
            return LoadVectors(self.template, self.vectors[index])
        row = self.vectors[index]  # an index out of range raises here
        loads = list(self.template)
        for k, position in enumerate(self.varying):
            loads[position] = with_vector(loads[position], row[3 * k : 3 * k + 3])  # type: ignore[arg-type]
        return tuple(loads)


def uniform_vectors(cases: Sequence[object]) -> LoadVectors | None:
    """``cases`` as :class:`LoadVectors` when every case is a list or tuple of the first case's
    loads (kinds, links, points, gravities) with other force and torque vectors; None
    otherwise (another set of loaded points, the model's loads (None), not a load). Already
    LoadVectors: themselves."""
    if isinstance(cases, LoadVectors):
        return cases
    if not cases or type(cases[0]) not in (tuple, list):
        return None
    first: Sequence[object] = cases[0]  # type: ignore[assignment]  # a list or tuple
    # per position of the first case: (kind, link, the point or gravity it must equal)
    layout = [
        (type(load), getattr(load, "link", None),
         load.point.tobytes() if type(load) is PointForce else
         load.acceleration.tobytes() if type(load) is Gravity else None)
        for load in first
    ]  # fmt: skip
    if any(kind not in KIND for kind, _, _ in layout):
        return None
    size = len(layout)
    vectors = []
    for loads in cases:
        if type(loads) not in (tuple, list) or len(loads) != size:  # type: ignore[arg-type]
            return None
        for load, (kind, link, known) in zip(loads, layout):  # type: ignore[call-overload]
            if type(load) is not kind:
                return None
            if kind is PointForce:
                if load.link != link or load.point.tobytes() != known:
                    return None
                vectors.append(load.force)
            elif kind is Torque:
                if load.link != link:
                    return None
                vectors.append(load.torque)
            elif load.acceleration.tobytes() != known:
                return None
    width = 3 * sum(kind in (PointForce, Torque) for kind, _, _ in layout)
    array = _rows(vectors).reshape(len(cases), width) if width else np.zeros((len(cases), 0))
    return LoadVectors(first, array)


def load_table(
    mechanism: Mechanism,
    cases: Sequence[Sequence[object] | None] | LoadVectors,
    gravity: object,
) -> LoadTable:
    """The load terms of ``cases`` (None: the model's loads) with ``gravity`` (an option of
    :meth:`Mechanism.solve`)."""
    if isinstance(cases, LoadVectors):
        return _vector_table(mechanism, cases, gravity)
    model, links = mechanism.model, mechanism.link_frames
    frames = model.frames
    names = list(links)
    slot_of = {name: k for k, name in enumerate(names)}  # the link's row below
    link_body = np.array([frames[links[name]].parentJoint for name in names], dtype=np.intp)
    link_rotation = np.array([frames[links[name]].placement.rotation for name in names])
    link_origin = np.array([frames[links[name]].placement.translation for name in names])
    default = tuple(mechanism.loads)
    lists = [
        default if case is None else case if isinstance(case, (list, tuple)) else [*case]
        for case in cases
    ]
    owner = np.repeat(np.arange(len(lists), dtype=np.intp), [len(items) for items in lists])
    loads: list[object] = list(itertools.chain.from_iterable(lists))
    kind = np.array([KIND.get(type(load), 3) for load in loads], dtype=np.intp)
    valid = np.ones(len(cases), dtype=bool)
    valid[owner[kind == 3]] = False
    on_link = np.flatnonzero(kind < 2)  # forces and torques: on a link
    located = loads if on_link.size == len(loads) else list(compress(loads, (kind < 2).tolist()))
    slot = np.array([slot_of.get(load.link, -1) for load in located], dtype=np.intp)  # type: ignore[attr-defined]
    valid[owner[on_link[slot < 0]]] = False  # an unknown link: the single solve raises
    body = np.where(slot >= 0, link_body[slot], 0)
    keep = body > 0  # a load on the ground does no work
    is_force = kind[on_link] == 0
    rows = keep & is_force
    forces = located if rows.all() else list(compress(located, rows.tolist()))
    force = _rows([load.force for load in forces])  # type: ignore[attr-defined]
    point = _rows([load.point for load in forces])  # type: ignore[attr-defined]
    in_body = np.empty_like(point)  # the point in its body's frame: one product per link
    link_of = slot[rows]
    for link in np.unique(link_of).tolist():
        chosen = link_of == link
        in_body[chosen] = point[chosen] @ link_rotation[link].T + link_origin[link]
    turning = keep & ~is_force
    torque = _rows([load.torque for load in compress(located, turning.tolist())])  # type: ignore[attr-defined]
    heavy = [b for b in range(1, model.njoints) if model.inertias[b].mass > 0.0]
    weighed = np.array(heavy, dtype=np.intp)
    masses = np.array([model.inertias[b].mass for b in heavy])
    levers = np.array([np.array(model.inertias[b].lever) for b in heavy]).reshape(-1, 3)
    # a Gravity among a case's loads: one row per body with mass
    pulled = np.flatnonzero(kind == 2)
    acceleration = np.array(
        [load.acceleration for load in compress(loads, (kind == 2).tolist())]  # type: ignore[attr-defined]
    ).reshape(-1, 3)
    weight = (acceleration[:, None, :] * masses[None, :, None]).reshape(-1, 3)
    added = added_gravity(0, gravity, mechanism.gravity)  # type: ignore[arg-type]  # checked
    # a case with its own Gravity: its single solve decides (it stands in for the model's, or
    # is refused beside a gravity option); with two, refused there too
    own = np.bincount(owner[kind == 2], minlength=len(cases))
    valid[(own > 1) | ((own > 0) & (added is not None))] = False
    n_force, n_torque, n_weight = len(force), len(torque), len(weight)
    return LoadTable(
        count=len(cases),
        case=np.concatenate(
            [
                owner[on_link[rows]],
                np.repeat(owner[pulled], weighed.size),
                owner[on_link[turning]],
            ]
        ),
        body=np.concatenate([body[rows], np.tile(weighed, pulled.size), body[turning]]),
        force=np.concatenate([force, weight, np.zeros((n_torque, 3))]),
        point=np.concatenate([in_body, np.tile(levers, (pulled.size, 1)), np.zeros((n_torque, 3))]),
        torque=np.concatenate([np.zeros((n_force + n_weight, 3)), torque]),
        valid=valid,
        gravity=None if added is None else np.array(added.acceleration, dtype=float),
        weighed=weighed,
        masses=masses,
        levers=levers,
    )


def _vector_table(mechanism: Mechanism, cases: LoadVectors, gravity: object) -> LoadTable:
    """:func:`load_table` of cases given as vectors: the rows of each load of the template
    (one case: 0 or 1 row, or a body's weight rows for a Gravity), repeated for every case,
    the force or torque columns of a varying load replaced by its vectors."""
    count = len(cases)
    fixed = [load for k, load in enumerate(cases.template) if k not in cases.varying]
    parts = [repeated(load_table(mechanism, [fixed], False), count)]
    for k, position in enumerate(cases.varying):
        one = load_table(mechanism, [[cases.template[position]]], False)
        rows = repeated(one, count)
        if one.body.size:  # a load on the ground has no row: it does no work
            vectors = cases.vectors[:, 3 * k : 3 * k + 3]
            is_force = type(cases.template[position]) is PointForce
            rows = replace(
                rows,
                force=vectors if is_force else rows.force,
                torque=rows.torque if is_force else vectors,
            )
        parts.append(rows)
    # the gravity option (none when the template holds a Gravity: it stands in for the model's,
    # or is refused beside an option) and the bodies' masses
    own = sum(type(load) is Gravity for load in cases.template)
    added = added_gravity(own, gravity, mechanism.gravity)  # type: ignore[arg-type]  # checked
    shared = load_table(mechanism, [()], False if added is None else added)
    return replace(
        shared,
        count=count,
        case=np.concatenate([part.case for part in parts]),
        body=np.concatenate([part.body for part in parts]),
        force=np.concatenate([part.force for part in parts]),
        point=np.concatenate([part.point for part in parts]),
        torque=np.concatenate([part.torque for part in parts]),
        valid=np.ones(count, dtype=bool),
    )


def repeated(one: LoadTable, count: int) -> LoadTable:
    """The rows of a one-case table ``one`` for ``count`` cases, case by case (the loads the
    same in every case)."""
    size = one.body.size
    return replace(
        one,
        count=count,
        case=np.repeat(np.arange(count, dtype=np.intp), size),
        body=np.tile(one.body, count),
        force=np.tile(one.force, (count, 1)),
        point=np.tile(one.point, (count, 1)),
        torque=np.tile(one.torque, (count, 1)),
        valid=np.repeat(one.valid, count),
    )


def _rows(vectors: list[Array]) -> Array:
    """3-vectors (float arrays, as the loads keep them) stacked as rows (L, 3), through one
    buffer (a third of numpy.array's time on 1e5 small arrays)."""
    data = b"".join([vector.tobytes() for vector in vectors])
    if len(data) != 24 * len(vectors):  # not float64 3-vectors: the general conversion
        return np.array(vectors, dtype=float).reshape(-1, 3)
    return np.frombuffer(data).reshape(-1, 3).copy()


def body_wrenches(
    table: LoadTable, rotations: Array, translations: Array, bodies: int, per_case: bool
) -> tuple[Array, Array]:
    r"""Body wrenches about the body origins, world axes, of every case, (N, bodies, 6)
    [N, N m] (ground row 0): :math:`(\sum F, \sum (R_b p) \times F + C)` (module docstring);
    and their moments about the world origin, :math:`\sum (R_b p + t_b) \times F + C`
    (N, bodies, 3) [N m], the sizes of the loads as a single solve measures them
    (:meth:`.prepared.PreparedGeometry.objectives`).

    Args:
        rotations, translations: body placements (K, bodies, 3, 3) and (K, bodies, 3) [m], with
            K = N (``per_case``: a trajectory) or 1 (one configuration for every case).
    """
    if per_case:
        rotation = rotations[table.case, table.body]
        lever = (rotation @ table.point[:, :, None])[:, :, 0]
        origin = translations[table.case, table.body]
    else:  # one configuration: one (L_b, 3) product per loaded body
        lever = np.empty_like(table.point)
        for body in np.unique(table.body).tolist():
            rows = table.body == body
            lever[rows] = table.point[rows] @ rotations[0, body].T
        origin = translations[0, table.body]
    moment = np.cross(lever, table.force) + table.torque
    world = np.cross(lever + origin, table.force) + table.torque
    slots = table.case * bodies + table.body
    size = table.count * bodies
    out = np.empty((table.count, bodies, 6))
    about = np.empty((table.count, bodies, 3))
    for k in range(3):
        out[:, :, k] = np.bincount(slots, table.force[:, k], size).reshape(table.count, bodies)
        out[:, :, 3 + k] = np.bincount(slots, moment[:, k], size).reshape(table.count, bodies)
        about[:, :, k] = np.bincount(slots, world[:, k], size).reshape(table.count, bodies)
    if table.gravity is not None and table.weighed.size:
        # the shared gravity, once per configuration: (m a, (R c) x m a), c the centre of mass
        centres = (rotations[:, table.weighed] @ table.levers[:, :, None])[..., 0]
        weight = table.masses[:, None] * table.gravity
        shared = np.zeros((rotations.shape[0], bodies, 6))
        shared[:, table.weighed, :3] = weight
        shared[:, table.weighed, 3:] = np.cross(centres, weight)
        out += shared  # (1 or N, bodies, 6): broadcast over the cases at one configuration
        moved = np.zeros((rotations.shape[0], bodies, 3))
        moved[:, table.weighed] = np.cross(centres + translations[:, table.weighed], weight)
        about += moved
    return out, about


def check_links(mechanism: Mechanism, loads: Sequence[object]) -> None:
    """A LoadError naming the first force or torque on a link the model does not have (a
    batch's table marks that case invalid instead, for its single solve to raise this)."""
    links = mechanism.link_frames
    for load in loads:
        link = getattr(load, "link", None)
        if link is not None and link not in links:
            known = ", ".join(sorted(links))
            raise LoadError(f"on {link!r}", f"unknown link; the model's links are: {known}")


__all__ = [
    "LoadTable",
    "LoadVectors",
    "body_wrenches",
    "check_links",
    "load_table",
    "repeated",
    "uniform_vectors",
]
