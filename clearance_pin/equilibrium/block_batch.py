"""``solve_many`` for a tree whose joints are independent blocks (:mod:`.blocks`): every case at once.

Load cases at one configuration (:func:`solve_load_cases`) and trajectories of the driven joints
(:func:`solve_configurations`) share one path: the body wrenches of all cases about the body
origins (:mod:`.load_table`), their gradients from the wrenches about each joint's own centre
(:mod:`.tree_trajectory`: one matrix product at one configuration, the lever arms of every point
along a trajectory), the closed forms of all cases, then the verification
of all cases (:mod:`.block_verify`), each vectorised over the cases with numpy. Verified cases are
kept as arrays: ``torsors(joint)``, ``ok``, ``energy`` and ``statuses`` read them, and an item is
assembled as an :class:`~.result.Equilibrium` only when it is read. Every other case (a load on
an unblocked motion, a group between loaded and unloaded, an answer that does not verify, a load
that cannot be read) is solved alone by :meth:`Mechanism.solve`, in order.
"""

from __future__ import annotations

from dataclasses import fields, replace
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from ..errors import ClearancePinError
from ..numerics import Array, Mask
from .batch import Cases, EquilibriumBatch, name_case
from .batch_answers import StackedAnswers
from .batch_kinematics import body_placements
from .block_verify import SOLVER_STATUS, flat_notes, verify
from .blocks import (
    BlockStructure,
    ClosedForms,
    block_structure,
    closed_forms,
    reduced_unknowns,
)
from .cache import LeastRecentlyUsed
from .formulation import solve_with_options
from .kkt import RESIDUAL_NAMES
from .linear_answer import assemble_linear
from .load_table import LoadTable, LoadVectors, body_wrenches, load_table, repeated
from .method import Method
from .options import SolveOptions
from .outputs import resolve_outputs
from .prepared import PreparedGeometry, prepared_geometry
from .reduction import loaded_problem
from .tree_point import TreePoint
from .tree_trajectory import Objectives, objectives_of, tree_gradients, tree_maps

if TYPE_CHECKING:
    from ..model.mechanism_parts import MechanismParts as Mechanism
    from ..progress import Progress
    from .result import Equilibrium

CHUNK = 1024  # cases per vectorised pass (its arrays stay in the cache)
ANSWERS_KEPT = 64  # assembled items a batch keeps (the others are assembled again when read)


class BlockBatch(EquilibriumBatch):
    """An :class:`~.batch.EquilibriumBatch` whose closed-form cases live in arrays: an item is
    assembled when it is read (``build(i)``), the whole-batch properties read the arrays.

    The batch keeps the last :data:`ANSWERS_KEPT` items it assembled, not every one: an answer
    holds some kB (its configuration, contacts, lazily read parts), so a read trajectory of 1e5
    points would hold hundreds of MB; an item read again after that is assembled again, with the
    same numbers (the arrays and the configuration determine it)."""

    def __init__(
        self,
        items: list[Any],
        closed: Mask,
        energies: Array,
        torsor_maps: dict[str, Array],
        build: Assembler,
    ):
        """``closed``: the cases the closed forms solved; the unknowns x (N, n) are theirs
        (``build.closed.x``) there, NaN elsewhere."""
        x = np.where(closed[:, None], build.closed.x, np.nan)
        super().__init__(items, {"x": x, "batched": closed, "torsor_maps": torsor_maps}, build)
        self._closed = closed
        self._energies = energies
        self._assembler = build
        self._assembled: LeastRecentlyUsed[int, Equilibrium] = LeastRecentlyUsed(ANSWERS_KEPT)

    def __getitem__(self, index: Any) -> Any:
        if isinstance(index, slice):
            return [self[i] for i in range(*index.indices(len(self)))]
        item = self._items[index]  # an IndexError for an index out of range
        if item is None:  # a closed-form case: assembled from the arrays, the latest few kept
            position = int(index) % len(self._items)
            kept = self._assembled.get(position)
            if kept is None:
                kept = self._assembled[position] = self._assembler(position)
            return kept
        return item

    def __reduce__(self) -> tuple[Any, ...]:
        """The arrays and the assembler travel, not items; not the unknowns x (N, n): they are
        the closed forms', formed again where the batch is unpickled (an executor's task
        returns its batch: 1.6 kB per case of a UR5 with them, 1 kB without)."""
        arrays = self._arrays or {}
        return (
            BlockBatch,
            (self._items, self._closed, self._energies, arrays["torsor_maps"], self._assembler),
        )

    def _stacked_answers(self) -> StackedAnswers:
        """The closed-form cases' answers as arrays (:mod:`.batch_answers`), made on first read."""
        answers = self.__dict__.get("_answers")
        if answers is None:
            answers = self.__dict__["_answers"] = self._assembler.stacked(self._closed)
        return cast(StackedAnswers, answers)

    @property
    def energy(self) -> Array:
        """Potential of the loads per case [J] (NaN for errors), (N,)."""
        out = self._energies.copy()
        for i in np.flatnonzero(~self._closed):
            item = self[i]
            out[i] = np.nan if isinstance(item, Exception) else item.energy
        return out

    @property
    def statuses(self) -> list[str]:
        """Solver status per case (the error's class name for errors)."""
        return [
            SOLVER_STATUS
            if self._closed[i]
            else (type(r).__name__ if isinstance(r := self[i], Exception) else r.solver_status)
            for i in range(len(self))
        ]

    @property
    def methods(self) -> list[Method | str]:
        """The engine that answered each case (:class:`~.method.Method`; the error's class name
        for errors)."""
        return [
            Method.CLOSED_FORM
            if self._closed[i]
            else (type(r).__name__ if isinstance(r := self[i], Exception) else r.method)
            for i in range(len(self))
        ]


def _structure(mechanism: Mechanism) -> tuple[PreparedGeometry, BlockStructure] | None:
    if mechanism.loop_joints:
        return None
    prepared = prepared_geometry(mechanism)  # builds the tree's one geometry on first use
    structure = block_structure(prepared.geometry, False)
    return None if structure is None else (prepared, structure)


def solve_load_cases(
    mechanism: Mechanism,
    cases: Cases,
    options: SolveOptions,
    errors: str,
    progress: Progress,
) -> EquilibriumBatch | None:
    """Load cases at the nominal configuration; None when the closed forms do not apply."""
    found = _structure(mechanism)
    if found is None:
        return None
    prepared, structure = found
    table = load_table(mechanism, cases.load_column(), options.gravity)
    objectives = _load_case_objectives(mechanism, prepared, table)
    return _finish(
        mechanism,
        cases,
        options,
        errors,
        progress,
        prepared,
        structure,
        objectives,
        table.valid,
        False,
    )


def _load_case_objectives(
    mechanism: Mechanism, prepared: PreparedGeometry, table: LoadTable
) -> Objectives:
    """The objectives of the load cases of ``table`` at the nominal configuration, formed
    :data:`CHUNK` cases at a time: the intermediate arrays (body wrenches (cases, bodies, 6) and
    their moments) stay small and are re-used, where whole-batch ones (tens of MB for 1e5 cases)
    are fresh memory, whose first touch costs a page fault per 4 kB (a third of the run's time
    here)."""
    origin = prepared.configuration.oMi
    rotations = np.array([m.rotation for m in origin])[None]
    translations = np.array([m.translation for m in origin])[None]
    maps = tree_maps(mechanism, prepared.geometry)
    order = np.argsort(table.case, kind="stable")  # the rows of each case together
    bounds = np.searchsorted(table.case[order], np.arange(0, table.count + CHUNK, CHUNK))
    parts = []
    for k, start in enumerate(range(0, table.count, CHUNK)):
        rows = order[bounds[k] : bounds[k + 1]]
        part = replace(
            table,
            count=min(CHUNK, table.count - start),
            case=table.case[rows] - start,
            body=table.body[rows],
            force=table.force[rows],
            point=table.point[rows],
            torque=table.torque[rows],
            valid=table.valid[start : start + CHUNK],
        )
        wrenches, moments = body_wrenches(part, rotations, translations, prepared.bodies, False)
        # g = W G: one product with the map of this configuration (wrenches about the centres)
        gradients = tree_gradients(maps, rotations, translations, wrenches)
        parts.append(objectives_of(prepared, gradients, wrenches, moments))
    return Objectives(
        *(np.concatenate([getattr(p, f.name) for p in parts]) for f in fields(Objectives))
    )


def solve_configurations(
    mechanism: Mechanism,
    cases: Cases,
    options: SolveOptions,
    errors: str,
    progress: Progress,
) -> EquilibriumBatch | None:
    """A trajectory (one configuration per case, loads shared or paired); None when the closed
    forms do not apply."""
    found = _structure(mechanism)
    if found is None:
        return None
    prepared, structure = found
    given = cases.configurations or [None] * len(cases)
    configurations = [prepared.configuration.q if q is None else q for q in given]
    rotations, translations = body_placements(mechanism, configurations)
    shared = cases.loads is None or (
        not isinstance(cases.loads, LoadVectors) and all(loads is None for loads in cases.loads)
    )
    if shared:  # one load table, repeated (the loads are the same at every point)
        one = load_table(mechanism, [None], options.gravity)
        table = repeated(one, len(cases))
    else:
        table = load_table(mechanism, cases.load_column(), options.gravity)
    wrenches, moments = body_wrenches(table, rotations, translations, prepared.bodies, True)
    maps = tree_maps(mechanism, prepared.geometry)
    gradients = tree_gradients(maps, rotations, translations, wrenches)
    objectives = objectives_of(prepared, gradients, wrenches, moments)

    return _finish(
        mechanism,
        cases,
        options,
        errors,
        progress,
        prepared,
        structure,
        objectives,
        table.valid,
        True,
    )


def solve_blocks(
    mechanism: Mechanism,
    cases: Cases,
    along: bool,
    options: SolveOptions,
    errors: str,
    progress: Progress,
) -> EquilibriumBatch | None:
    """``solve_many``'s cases by closed forms: a trajectory when ``along`` (configurations
    given), else load cases at the nominal configuration; None when the closed forms do not apply
    to this mechanism (loop joints, a prismatic block, ...)."""
    if not cases:
        return None
    solve = solve_configurations if along else solve_load_cases
    return solve(mechanism, cases, options, errors, progress)


def _finish(
    mechanism: Mechanism,
    cases: Cases,
    options: SolveOptions,
    errors: str,
    progress: Progress,
    nominal: PreparedGeometry,
    structure: BlockStructure,
    terms: Objectives,
    valid: Mask,
    along: bool,
) -> EquilibriumBatch:
    """Closed forms and verification of every case; single solves for the rest."""
    closed, y, table, verified, neglected = _closed_and_verified(nominal, structure, terms)
    # the load left on unloaded joints is reported with the share nothing blocks
    terms = replace(terms, shares=np.maximum(terms.shares, neglected))
    done = terms.regular & valid & closed.decided & verified
    progress.update(int(done.sum()))
    items: list[Any] = [None] * len(cases)
    for i in np.flatnonzero(~done).tolist():
        case_loads, q = cases[i]
        try:
            items[i] = solve_with_options(mechanism, case_loads, q, options)
        except ClearancePinError as exc:
            if errors == "raise":
                name_case(exc, i)
                raise
            items[i] = exc
        progress.update()
    energies = np.where(done, np.einsum("ni,ni->n", terms.gradients, closed.x), np.nan)
    torsor_maps = {name: nominal.maps.joint_torsor[name] for name in mechanism.joints}
    build = Assembler(mechanism, options, nominal, structure, terms, closed, y, table, cases, along)
    return BlockBatch(items, done, energies, torsor_maps, build)


class Assembler:
    """The :class:`~.result.Equilibrium` of closed-form case i from the batch's arrays (``along``:
    at its own configuration, a :class:`~.tree_point.TreePoint` of the nominal geometry).

    Pickled without the nominal geometry (maps of the whole tree): it is prepared again from the
    mechanism where the batch is unpickled, by the same computation, so the answers assembled
    there have the same numbers."""

    def __init__(
        self,
        mechanism: Mechanism,
        options: SolveOptions,
        nominal: PreparedGeometry,
        structure: BlockStructure,
        terms: Objectives,
        closed: ClosedForms,
        y: Array,
        table: Array,
        cases: Cases,
        along: bool,
    ):
        self.mechanism, self.options, self.nominal = mechanism, options, nominal
        self.structure, self.terms, self.closed, self.y, self.table = (
            structure,
            terms,
            closed,
            y,
            table,
        )
        self.cases, self.along = cases, along

    def __call__(self, i: int) -> Equilibrium:
        nominal = self.nominal
        if nominal is None:  # unpickled
            nominal = self.nominal = prepared_geometry(self.mechanism)
        case_loads, q = self.cases[i]
        # a point of a trajectory: the nominal geometry moved there (no maps kept per point)
        prepared = (
            cast(PreparedGeometry, TreePoint(nominal, self.mechanism.configure(q)))
            if self.along
            else nominal
        )
        return _item(
            self.mechanism,
            self.options,
            prepared,
            self.structure,
            self.terms,
            self.closed,
            self.y,
            self.table,
            case_loads,
            i,
        )

    def __getstate__(self) -> dict[str, Any]:
        """Without the nominal geometry and the reduced unknowns y (both formed again where
        unpickled, by the same computation), the slab sides as bytes when they are all -1, 0 or
        1 (they are: the side each contact presses)."""
        closed = self.closed
        sides = closed.signs.astype(np.int8)
        if np.array_equal(sides, closed.signs):
            closed = replace(closed, signs=sides)  # type: ignore[arg-type]  # while pickled
        return {**self.__dict__, "nominal": None, "y": None, "closed": closed}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        closed = self.closed
        if closed.signs.dtype != np.float64:
            self.closed = closed = replace(closed, signs=closed.signs.astype(np.float64))
        # y as _closed_and_verified forms it, chunk by chunk (the same products, the same bits)
        self.y = np.concatenate(
            [
                reduced_unknowns(self.structure, closed.x[start : start + CHUNK])
                for start in range(0, max(len(closed.x), 1), CHUNK)
            ]
        )

    def stacked(self, done: Mask) -> StackedAnswers:
        """The answers of the closed-form cases ``done`` as arrays, for the whole-batch readers:
        the body placements of every point of a trajectory (:func:`.batch_kinematics.body_placements`)
        or of the nominal configuration."""
        nominal = self.nominal
        if nominal is None:  # unpickled
            nominal = self.nominal = prepared_geometry(self.mechanism)
        if self.along:
            given = self.cases.configurations or [None] * len(self.cases)
            configurations = [nominal.configuration.q if q is None else q for q in given]
            rotations, translations = body_placements(self.mechanism, configurations)
        else:
            oMi = nominal.configuration.oMi
            rotations = np.array([m.rotation for m in oMi])[None]
            translations = np.array([m.translation for m in oMi])[None]
        return StackedAnswers(
            self.mechanism,
            nominal,
            self.y,
            self.closed.multipliers,
            self.closed.signs,
            self.terms.sigmas,
            done,
            rotations,
            translations,
            self.along,
            self.cases.load_column(),
            self.options.gravity,
        )


def _closed_and_verified(
    nominal: PreparedGeometry, structure: BlockStructure, terms: Objectives
) -> tuple[ClosedForms, Array, Array, Mask, Array]:
    """The closed forms of every case and their verification, in chunks of :data:`CHUNK` cases
    (arrays that stay in the processor's cache): (closed forms, y (N, r), KKT table (N, 4),
    verified (N,), the load neglected on unloaded joints (N,))."""
    parts: list[tuple[ClosedForms, Array, Array, Mask, Array]] = []
    for start in range(0, max(len(terms.sigmas), 1), CHUNK):
        part = slice(start, start + CHUNK)
        closed = closed_forms(structure, terms.gradients[part], terms.sigmas[part])
        y = reduced_unknowns(structure, closed.x)
        check = verify(  # the geometry and its terms are the same at every configuration
            nominal,
            structure,
            terms.objectives[part],
            y,
            closed.x,
            closed.multipliers,
            closed.signs,
            terms.sigmas[part],
            terms.gradients[part],
            terms.load_sizes[part],
            closed.unloaded,
        )
        parts.append((closed, y, check.table, check.verified, check.neglected))
    if len(parts) == 1:
        return parts[0]
    return (
        ClosedForms(
            *(np.concatenate([getattr(p[0], f) for p in parts]) for f in ClosedForms.FIELDS)
        ),
        np.concatenate([p[1] for p in parts]),
        np.concatenate([p[2] for p in parts]),
        np.concatenate([p[3] for p in parts]),
        np.concatenate([p[4] for p in parts]),
    )


def _item(
    mechanism: Mechanism,
    options: SolveOptions,
    prepared: PreparedGeometry,
    structure: BlockStructure,
    terms: Objectives,
    closed: ClosedForms,
    y: Array,
    table: Array,
    case_loads: Any,
    i: int,
) -> Equilibrium:
    """The Equilibrium of closed-form case i, as a single solve assembles its answer."""
    problem = loaded_problem(
        prepared.geometry,
        terms.gradients[i],
        terms.objectives[i],
        float(terms.sigmas[i]),
        float(terms.load_sizes[i]),
        float(terms.shares[i]),
    )
    gravity = options.gravity
    resolved = mechanism.resolve_loads(case_loads, False if gravity is False else gravity)
    outputs = options.outputs
    return assemble_linear(
        prepared,
        problem,
        y[i],
        closed.multipliers[i],
        closed.signs[i],
        "optimal",
        Method.CLOSED_FORM,
        SOLVER_STATUS,
        0,
        True,
        0.0,
        0.0,
        dict(zip(RESIDUAL_NAMES, map(float, table[i]))),
        resolved,
        flat_notes(prepared, structure, closed.unloaded[i]),
        () if outputs is None else resolve_outputs(mechanism, resolved, outputs),
    )


__all__ = ["BlockBatch", "solve_blocks", "solve_configurations", "solve_load_cases"]
