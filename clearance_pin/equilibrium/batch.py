"""Many equilibria of one mechanism: load cases, trajectories of the driven joints, executors.

Cases are solved in order, so each one is warm-started from its neighbour (the active-set Newton
step of :mod:`.kkt` from the previous contact set) and the built problem is re-used. With an
``executor`` (any ``concurrent.futures.Executor``: threads, processes, or Dask through
``distributed.Client(...).get_executor()``), the cases are cut into contiguous chunks, one task
each, so warm starts still chain inside a chunk.
"""

from __future__ import annotations

import functools
import itertools
import os
import threading
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from concurrent.futures import Executor, ThreadPoolExecutor
from typing import TYPE_CHECKING, Any, overload

import numpy as np

from ..arguments import check_errors
from ..errors import ArgumentError, CaseIndexError, ClearancePinError, NotFoundError
from ..model.couplings import coupled, leader_springs
from ..model.frames import frame_id as find_frame
from ..model.stiffness import stiff_joints
from ..numerics import Array, Mask
from ..progress import Progress
from .batch_answers import StackedAnswers, contact_forces, frame_displacements
from .batch_newton import batched_newton, stacked_evaluation
from .batch_reactions import PARTS, stacked_reactions, subtree_statics_hold, whole_tree_reaction
from .cone_solver import ConeSolution, acceptance
from .fast_path import WARM_ROUNDS, FastTerms, fast_terms
from .formulation import solve_with_options
from .kkt import RESIDUAL_NAMES, UNLOADED, StackedContacts
from .linear_answer import Outcome, assemble_linear
from .load_table import uniform_vectors
from .method import Method
from .options import DEFAULT_OPTIONS, SolveOptions
from .outputs import resolve_outputs
from .prepared import PreparedGeometry, prepared_geometry
from .reactions import FRAMES
from .reduction import loaded_problem
from .residuals import verified as measured_ok
from .result import Equilibrium
from .solve import linear_plan

BATCH_MINIMUM = 16
BATCH_MAX_SIZE = 48  # reduced unknowns beyond which cases are solved one by one (warm-started)
REGROUP_ROUNDS = 4  # batched Newton rounds, each seeded by a single solve of a contact set
PROBE = 16  # cases that show whether a batched round pays before the rest of it runs
#: a probe of PROBE cases pays when it verifies this many: a batched round of 16 costs about
#: what one or two single solves do (0.5-0.7 ms against 0.55-0.9 ms per warm single solve on the
#: bundled loop mechanisms, NumPy way), so the structure of the answers decides, not a clock
PROBE_PAYS = 2
# a compiled batch runs on threads in chunks of at least THREAD_CASES cases (a thread's start
# and hand-over cost about what 10 cases do), at most THREAD_CHUNKS of them
THREAD_CASES, THREAD_CHUNKS = 64, 2


if TYPE_CHECKING:
    from ..model.mechanism_parts import MechanismParts as Mechanism

Item = Equilibrium | Exception
"""A case's answer, or its error (``errors="return"``)."""
Pending = Item | Callable[[], Item] | None
"""A case as a batch keeps it: its answer, what assembles it, or None (``build(index)``)."""
Arrays = dict[str, Any]
"""A batch's whole-batch arrays: ``x`` (N, n), ``batched`` (N,), ``torsor_maps`` (joint ->
(6, n)) and ``stacked`` (the :class:`.batch_answers.StackedAnswers`, or what builds them)."""
FromArrays = Callable[[StackedAnswers], tuple[Array, Mask]]


class EquilibriumBatch(Sequence[Item]):
    """The results of :func:`solve_many`: a sequence of equilibria, with whole-batch arrays.

    Items are :class:`~clearance_pin.equilibrium.result.Equilibrium` objects (or the error of a
    case, with ``errors="return"``), assembled on first access when the batch was solved on
    stacked arrays (an item given as a callable, or None with ``build(index)``). ``torsors(joint)``,
    ``ok``, ``energy`` and ``statuses`` read the whole batch without assembling each item.
    """

    def __init__(
        self,
        items: list[Any],  # of Pending
        arrays: Arrays | None = None,
        build: Callable[[int], Item] | None = None,
        mechanism: Any = None,
    ) -> None:
        """``mechanism``: the mechanism solved, which the readers name joints and points of
        when no case has an answer (else read from the answers)."""
        self._items = items
        self._arrays = arrays
        self._build = build
        self._owner = mechanism

    def __len__(self) -> int:
        return len(self._items)

    @overload
    def __getitem__(self, index: int) -> Item: ...

    @overload
    def __getitem__(self, index: slice) -> list[Item]: ...

    def __getitem__(self, index: int | slice) -> Item | list[Item]:
        if isinstance(index, slice):
            return [self[i] for i in range(*index.indices(len(self)))]
        if not -len(self._items) <= index < len(self._items):
            raise CaseIndexError(f"case {index} of a batch of {len(self._items)} cases")
        pending: Pending = self._items[index]
        if pending is None:
            assert self._build is not None  # None items come with what builds them
            item = self._build(index % len(self._items))
        elif callable(pending):
            item = pending()
        else:
            return pending
        self._items[index] = item
        return item

    def __reduce__(self) -> tuple[type[EquilibriumBatch], tuple[Any, ...]]:
        """Pickled with every item assembled (what assembles one is a closure, which does not
        travel) and the whole-batch arrays: a Dask or process task may return a batch."""
        arrays = self._arrays
        if arrays is not None and "stacked" in arrays:  # the items carry the answers
            arrays = {key: value for key, value in arrays.items() if key != "stacked"}
        return (EquilibriumBatch, ([self[i] for i in range(len(self))], arrays, None, self._owner))

    def torsors(self, joint: str) -> np.ndarray:
        """Torsor of ``joint`` for every case, (N, 6) [m, rad] (NaN for failed cases)."""
        if self._arrays is not None and joint in self._arrays["torsor_maps"]:
            values: Array = self._arrays["x"] @ self._arrays["torsor_maps"][joint].T
            alone = np.flatnonzero(~self._arrays["batched"])  # the cases solved one by one
            values[alone] = self._one_by_one(joint, alone)
            return values
        self._check_joint(joint)  # (no answer may name it)
        return self._one_by_one(joint, range(len(self)))

    def deflections(self, joint: str) -> np.ndarray:
        """Elastic deflection of ``joint`` for every case, (N, 6) [m, rad], clearance frame
        (:meth:`.result.Equilibrium.deflection`: zero for a rigid joint; NaN for failed cases);
        ``torsors(joint) - deflections(joint)`` is its play."""
        self._check_joint(joint)
        rows = []
        for i in range(len(self)):
            item = self[i]
            rows.append(
                np.full(6, np.nan) if isinstance(item, Exception) else item.deflection(joint)
            )
        return np.array(rows).reshape(-1, 6)

    def _one_by_one(self, joint: str, indices: Iterable[int]) -> Array:
        """Torsors of ``joint`` read from the items ``indices`` (NaN for errors), (k, 6)."""
        rows = []
        for i in indices:
            item = self[i]
            rows.append(np.full(6, np.nan) if isinstance(item, Exception) else item.torsor(joint))
        return np.array(rows).reshape(-1, 6)

    def _stacked_answers(self) -> StackedAnswers | None:
        """The answers of the cases solved on stacked arrays (:mod:`.batch_answers`), None when
        the batch has none (every item a single solve, or assembled before pickling)."""
        source = (self._arrays or {}).get("stacked")
        if callable(source):
            source = self._arrays["stacked"] = source()  # type: ignore[index]
        return source

    def _read(
        self,
        shape: tuple[int, ...],
        from_arrays: FromArrays,
        from_item: Callable[[Equilibrium], Any],
    ) -> Array:
        """A whole-batch array (N, *shape): ``from_arrays(answers)`` (its rows, and the mask of
        the rows it gives) for the cases solved on stacked arrays, ``from_item(item)`` for the
        cases solved one by one, NaN for errors."""
        out = np.full((len(self), *shape), np.nan)
        rest: Sequence[int] = range(len(self))
        answers = self._stacked_answers()
        if answers is not None:
            values, given = from_arrays(answers)
            out[given] = values[given]
            rest = np.flatnonzero(~given).tolist()
        for i in rest:
            item = self[i]
            if not isinstance(item, Exception):
                out[i] = from_item(item)
        return out

    def frame_displacements(self, frame: str) -> tuple[np.ndarray, np.ndarray]:
        """World displacement of a Pinocchio frame in every case: translations (N, 3) [m] of its
        origin and rotations (N, 3) [rad], world axes (NaN for failed cases); see
        :meth:`~clearance_pin.equilibrium.result.Equilibrium.frame_displacement` (small
        displacements: :math:`(v_b + \\omega_b \\times p_f, \\omega_b)`)."""
        mechanism = self._mechanism()
        frame_id = find_frame(mechanism.model, frame) if mechanism is not None else None
        if mechanism is not None and frame_id is None:
            names = [f.name for f in mechanism.model.frames]
            raise NotFoundError("frame", frame, names, mechanism.name)

        def from_arrays(answers: StackedAnswers) -> tuple[Array, Mask]:
            assert frame_id is not None  # stacked answers carry their mechanism
            return np.hstack(frame_displacements(answers, frame_id)), answers.stacked

        both = self._read((6,), from_arrays, lambda item: np.hstack(item.frame_displacement(frame)))
        return both[:, :3], both[:, 3:]

    def reactions(self, joint: str, frame: str = "joint", part: str | None = None) -> np.ndarray:
        """The wrench the parent part exerts on the child through ``joint`` in every case,
        (force, moment) (N, 6) [N, N m] (NaN for failed cases), as
        :meth:`~clearance_pin.equilibrium.result.Equilibrium.reaction` gives it
        (``np.asarray(item.reaction(joint, frame))``): ``frame="joint"``, clearance-frame axes
        and moment about the joint centre; ``"world"``, world axes and moment about the world
        origin. ``part``: None for the whole reaction, or one of its parts ``"contact"``,
        ``"rigid"``, ``"drive"``, ``"held"`` (:class:`~.reactions.Reaction`)."""
        if part is not None and part not in PARTS:
            raise ArgumentError("part", f"None or one of {', '.join(PARTS)}", part)
        self._check_joint(joint)

        def from_arrays(answers: StackedAnswers) -> tuple[Array, Mask]:
            whole = None if part is not None else whole_tree_reaction(answers, joint, frame)
            if whole is not None:  # a tree's: the statics of the subtree, no split needed
                return whole, answers.stacked & np.all(np.isfinite(whole), axis=1)
            reactions = stacked_reactions(answers)
            values = reactions.reaction(joint, frame, part)
            return values, answers.stacked & np.all(np.isfinite(values), axis=1)

        def from_item(item: Equilibrium) -> Any:
            reaction = item.reaction(joint, frame)
            return reaction.wrench if part is None else getattr(reaction, part)

        if frame not in FRAMES:
            raise ArgumentError("frame", "'joint' or 'world'", frame)
        return self._read((6,), from_arrays, from_item)

    def contact_forces(self, joint: str) -> np.ndarray:
        """Force of the parent on the child at each contact point of ``joint`` in every case,
        (N, k, 3) [N], the joint's clearance frame, the points in the order of
        :attr:`~clearance_pin.equilibrium.result.Equilibrium.contacts` (their names:
        :meth:`contact_points`); NaN for failed cases."""
        self._check_joint(joint)
        names = self.contact_points(joint)

        def from_arrays(answers: StackedAnswers) -> tuple[Array, Mask]:
            chosen = [
                k for k, c in enumerate(answers.prepared.geometry.contacts) if c.joint == joint
            ]
            return contact_forces(answers)[:, chosen], answers.stacked

        def from_item(item: Equilibrium) -> Array:
            return np.array([c.force for c in item.contacts if c.joint == joint]).reshape(-1, 3)

        return self._read((len(names), 3), from_arrays, from_item)

    def contact_points(self, joint: str) -> tuple[str, ...]:
        """The names of ``joint``'s contact points (``Contact.point``), in the order of
        :meth:`contact_forces`."""
        self._check_joint(joint)
        answers = self._stacked_answers()
        if answers is not None:
            contacts = answers.prepared.geometry.contacts
            return tuple(c.contact.name for c in contacts if c.joint == joint)
        for item in self:
            if not isinstance(item, Exception):
                return tuple(c.point for c in item.contacts if c.joint == joint)
        if self._owner is None:
            return ()
        contacts = prepared_geometry(self._owner).geometry.contacts  # no answer: the model's
        return tuple(c.contact.name for c in contacts if c.joint == joint)

    def drive_torques(self) -> dict[str, np.ndarray]:
        """Driven joint name -> its drive torque about the joint axis [N m] in every case (N,)
        (the drive force [N] of a driven prismatic joint): the ``drive`` part of
        :meth:`reactions` in the joint's clearance frame (x = joint axis), component 3 (0 for a
        prismatic joint), and with backlash what its stop holds (the ``contact`` part's
        component: the journal's contacts, on its axis, have none), as
        :meth:`.result.Equilibrium.drive_torque` and the bearing-load table report it; NaN for
        failed cases."""
        mechanism = self._mechanism()
        if mechanism is None:
            return {}
        out = {}
        for name, joint in mechanism.joints.items():
            backlash = bool(joint.clearance.backlash)
            if getattr(joint, "locked_components", ()) or backlash:
                component = 0 if getattr(joint, "motion_component", None) == 0 else 3
                held = self.reactions(name, "joint", "drive")[:, component]
                if backlash:
                    held = held + self.reactions(name, "joint", "contact")[:, component]
                out[name] = held
        return out

    def _mechanism(self) -> Any:
        answers = self._stacked_answers()
        if answers is not None:
            return answers.mechanism
        for item in self:
            if not isinstance(item, Exception):
                return item.mechanism
        return self._owner

    def _check_joint(self, joint: str) -> None:
        mechanism = self._mechanism()
        if mechanism is not None and joint not in mechanism.joints:
            raise NotFoundError("joint", joint, tuple(mechanism.joints), mechanism.name)

    @property
    def ok(self) -> np.ndarray:
        """Per case: a verified equilibrium (False for errors), (N,)."""
        if self._arrays is not None:
            flags: Mask = self._arrays["batched"].copy()
            for i in np.flatnonzero(~flags).tolist():
                item = self[i]
                flags[i] = not isinstance(item, Exception) and item.ok
            return flags
        return np.array([not isinstance(r, Exception) and r.ok for r in self])

    @property
    def energy(self) -> np.ndarray:
        """Potential of the loads per case [J] (NaN for errors), (N,)."""
        return np.array([np.nan if isinstance(r, Exception) else r.energy for r in self])

    @property
    def statuses(self) -> list[str]:
        """Solver status per case (the error's class name for errors)."""
        return [type(r).__name__ if isinstance(r, Exception) else r.solver_status for r in self]

    @property
    def methods(self) -> list[Method | str]:
        """The engine that answered each case (:class:`~.method.Method`; the error's class name
        for errors)."""
        return [type(r).__name__ if isinstance(r, Exception) else r.method for r in self]


Case = tuple[Any, Any]
"""A case: its loads (None: the model's) and its configuration (None: the nominal one)."""


class Cases(Sequence[Case]):
    """The cases of :func:`solve_many` as two columns, read as (loads, configuration) pairs.

    Attributes:
        loads: the load cases (None: the model's loads in every case).
        configurations: the configurations as float arrays (None: the nominal one in every case).

    The columns are kept as given: pairing 1e5 cases up front would allocate 1e5 tuples and wake
    the garbage collector over every load object of the batch (a tenth of a second).
    """

    def __init__(
        self, loads: Sequence[Any] | None, configurations: Sequence[Any] | None, count: int
    ) -> None:
        self.loads, self.configurations, self._count = loads, configurations, count

    def __len__(self) -> int:
        return self._count

    @overload
    def __getitem__(self, index: int) -> Case: ...

    @overload
    def __getitem__(self, index: slice) -> Cases: ...

    def __getitem__(self, index: int | slice) -> Case | Cases:
        if isinstance(index, slice):
            return Cases(
                None if self.loads is None else self.loads[index],
                None if self.configurations is None else self.configurations[index],
                len(range(*index.indices(self._count))),
            )
        # a column's own indexing raises the IndexError of an index out of range
        return (
            None if self.loads is None else self.loads[index],
            None if self.configurations is None else self.configurations[index],
        )

    def __iter__(self) -> Iterator[Case]:
        none = itertools.repeat(None, self._count)
        loads = none if self.loads is None else self.loads
        configurations = none if self.configurations is None else self.configurations
        return zip(loads, configurations)

    def load_column(self) -> Sequence[Any]:
        """Every case's loads (None: the model's)."""
        return [None] * self._count if self.loads is None else self.loads


def _cases(mechanism: Mechanism, loads: Any, configurations: Any) -> Cases:
    if loads is not None and not isinstance(loads, Sequence):
        loads = list(loads)
    if configurations is not None:  # followers from their leaders (model.couplings)
        configurations = [
            coupled(mechanism.model, mechanism.couplings, np.asarray(q, dtype=float))
            for q in configurations
        ]
    if loads is None and configurations is None:
        raise ClearancePinError("solve_many needs load cases, configurations, or both")
    if loads is not None and configurations is not None and len(loads) != len(configurations):
        raise ArgumentError(
            "configurations",
            f"one configuration per load case ({len(loads)}): solve_many pairs them",
            f"{len(configurations)} configurations",
        )
    count = len(loads) if loads is not None else len(configurations)
    return Cases(loads, configurations, count)


def _solve_chunk(
    mechanism: Mechanism,
    cases: Iterable[Case],
    options: SolveOptions,
    errors: str,
    progress: Progress | None = None,
    start: int = 0,
) -> list[Item]:
    """Solve cases in order (each warm-started from the previous one); ``start``: the index of
    the first in the whole batch (an error raised names its case)."""
    results: list[Item] = []  # answers, or the errors of their cases
    for k, (case_loads, q) in enumerate(cases):
        try:
            results.append(solve_with_options(mechanism, case_loads, q, options))
        except ClearancePinError as exc:
            if errors == "raise":
                name_case(exc, start + k)
                raise
            results.append(exc)
        if progress is not None:
            progress.update()
    return results


def with_refused(
    mechanism: Mechanism,
    count: int,
    refused: Mapping[int, Exception],
    solve_kept: Callable[[list[int]], Sequence[Item]],
) -> EquilibriumBatch:
    """A batch of ``count`` cases whose cases ``refused`` (case -> its error, ``errors="return"``:
    a load beyond what double precision carries, a NaN value) are not solved: ``solve_kept`` of
    the other cases (their indices, in order) answers them, each error takes its case's place.
    Its readers read item by item."""
    kept = [index for index in range(count) if index not in refused]
    solved = solve_kept(kept) if kept else []
    place = {case: position for position, case in enumerate(kept)}
    return EquilibriumBatch(
        [
            refused[index] if index in refused else functools.partial(_item, solved, place[index])
            for index in range(count)
        ],
        mechanism=mechanism,
    )


def _item(batch: Sequence[Item], index: int) -> Item:
    return batch[index]


def name_case(error: ClearancePinError, index: int) -> None:
    """Add to ``error`` a note naming the case of :func:`solve_many` it comes from (shown under
    the message in a traceback; ``error.__notes__``)."""
    error.add_note(f"solve_many: in case {index} (counting from 0)")


def solve_many(
    mechanism: Mechanism,
    loads: Any = None,
    configurations: Any = None,
    options: SolveOptions = DEFAULT_OPTIONS,
    *,
    executor: Executor | None = None,
    chunks: int | None = None,
    errors: str = "raise",
    progress: bool | None = None,
) -> EquilibriumBatch:
    """Solve many load cases and/or nominal configurations of one mechanism (the core of
    :meth:`Mechanism.solve_many` and ``resolver.solve_many``, which check the arguments).

    Args:
        mechanism: the :class:`~clearance_pin.mechanism.Mechanism`.
        loads: sequence of load cases (each a sequence of PointForce/Torque/Gravity, or
            :class:`~.load_table.LoadVectors`), or None for the model's loads in every case.
        configurations: sequence of nominal configurations q (nq,) (a trajectory of the driven
            joints; passive joints are closed for each), or None for the nominal one. When both
            are given they are paired case by case.
        options: the :class:`~.options.SolveOptions` of every case (every option of a single
            solve works here; ``warm_start=False`` solves each case from the nominal position,
            not warm-started from its neighbour).
        executor: run chunks of cases as tasks of this executor (default: in this process).
        chunks: number of chunks with an executor (default: 4 per worker, at least 1 case each).
        errors: ``"raise"`` (the first error stops, a note on it names its case) or ``"return"``
            (the error takes the case's place).
        progress: progress bar on stderr (None: when stderr is a terminal and more than 100 cases).

    Returns:
        :class:`EquilibriumBatch`: a sequence of
        :class:`~clearance_pin.equilibrium.result.Equilibrium` (or errors, with
        ``errors="return"``), in case order, with whole-batch arrays (``torsors(joint)``, ``ok``).
    """
    check_errors(errors)
    cases = _cases(mechanism, loads, configurations)
    exact, backend = options.exact, options.backend
    if (
        not exact
        and not mechanism.loop_joints
        and (stiff := stiff_joints(mechanism.joints))
        and all(subtree_statics_hold(mechanism, joint) for joint in stiff)
        and not leader_springs(mechanism.couplings, mechanism.joints)  # as solve.py
    ):
        from .elastic_batch import solve_superposed  # a tree's springs: its rigid twin's batch

        return solve_superposed(mechanism, cases, options, errors, progress, executor, chunks)
    if options.outputs is not None:  # an unknown frame refused now, not in every case
        resolve_outputs(mechanism, (), options.outputs)
    show = progress if progress is not None else (None if len(cases) > 100 else False)
    bar = Progress(len(cases), "solving load cases", show, unit="case")
    if executor is None and not exact and backend == "auto":
        from .block_batch import solve_blocks  # closed forms of a tree's independent joints

        blocks = solve_blocks(mechanism, cases, configurations is not None, options, errors, bar)
        if blocks is not None:
            bar.close()
            return blocks
    if executor is None:
        if (
            configurations is None
            and not exact
            and options.warm_start
            and len(cases) >= BATCH_MINIMUM
        ):
            batch = _solve_loads_batched(mechanism, cases, options, errors, bar)
            bar.close()
            return batch
        results = _solve_chunk(mechanism, cases, options, errors, bar)
        bar.close()
        return EquilibriumBatch(results, mechanism=mechanism)
    workers = getattr(executor, "_max_workers", None) or 2
    count = chunks or min(len(cases), 4 * workers)
    if cases.loads is not None:  # cases of one layout travel as an array, not as objects
        vectors = uniform_vectors(cases.loads)
        if vectors is not None:
            cases = Cases(vectors, cases.configurations, len(cases))
    bounds = np.linspace(0, len(cases), count + 1).astype(int)
    futures = [
        executor.submit(_solve_part, mechanism, cases[a:b], options, errors, int(a))
        for a, b in itertools.pairwise(bounds)
        if b > a
    ]
    parts = []
    for future in futures:
        part = future.result()
        parts.append(part)
        bar.update(len(part))
    bar.close()
    from .chained_batch import ChainedBatch

    return ChainedBatch(parts, mechanism)


def _solve_part(
    mechanism: Mechanism, cases: Cases, options: SolveOptions, errors: str, start: int
) -> EquilibriumBatch:
    """An executor's task: :func:`solve_many` of one chunk of cases (its batched engines, in the
    task's process), its batch; an error raised names its case in the whole batch (``start``:
    the chunk's first)."""
    try:
        return solve_many(
            mechanism, cases.loads, cases.configurations, options, errors=errors, progress=False
        )
    except ClearancePinError as error:
        notes = getattr(error, "__notes__", [])
        local = [note for note in notes if note.startswith("solve_many: in case ")]
        for note in local:
            notes.remove(note)
            index = int(note.removeprefix("solve_many: in case ").split()[0])
            name_case(error, start + index)
        raise


def _solve_loads_batched(
    mechanism: Mechanism, cases: Cases, options: SolveOptions, errors: str, bar: Progress
) -> EquilibriumBatch:
    """Load cases at one configuration: one prepared geometry, the objectives of all cases from one
    matrix product, Newton on stacked arrays per contact set, then single solves for the rest.

    The first case is solved alone; its contact set seeds a batched Newton over all cases. Cases
    that fail the verification are regrouped: the first of them is solved alone and seeds the
    next batched round (at most :data:`REGROUP_ROUNDS`), and what is left is solved one by one.
    """
    first = _solve_chunk(mechanism, cases[:1], options, errors)[0]
    if isinstance(first, Exception) or first.status != "optimal":
        return EquilibriumBatch(
            _solve_chunk(mechanism, cases, options, errors, bar), mechanism=mechanism
        )
    prepared = prepared_geometry(mechanism)
    geometry = prepared.geometry
    plan = linear_plan(mechanism, prepared, options.backend)
    fast = fast_terms(prepared) if Method.COMPILED in plan else None
    if fast is not None:
        compiled = _solve_compiled_batch(mechanism, prepared, fast, first, cases, options, errors)
        if compiled is not None:
            bar.update(len(cases))
            return compiled
    if geometry.basis.shape[1] > BATCH_MAX_SIZE:
        # stacked dense KKT systems cost O(N r^3) memory traffic for little gain at this size
        rest = _solve_chunk(mechanism, cases[1:], options, errors, bar, start=1)
        return EquilibriumBatch([first, *rest], mechanism=mechanism)
    try:
        wrenches = np.array(
            [
                prepared.wrenches(mechanism.resolve_loads(case_loads, options.gravity)).ravel()
                for case_loads, _ in cases
            ]
        )
    except ClearancePinError:
        return EquilibriumBatch(
            _solve_chunk(mechanism, cases, options, errors, bar), mechanism=mechanism
        )
    objectives, sigmas, gradients, load_sizes, shares, regular = prepared.objectives(wrenches)
    items: list[Any] = [None] * len(cases)  # of Pending
    items[0] = first
    pending = np.flatnonzero(regular)
    pending = pending[pending > 0]
    seed = mechanism.cache.warm.get(prepared.signature)
    x_all = np.full((len(cases), prepared.size_x), np.nan)
    batched = np.zeros(len(cases), dtype=bool)
    # the answers of the batched cases, for the whole-batch readers (.batch_answers)
    y_all = np.full((len(cases), geometry.basis.shape[1]), np.nan)
    multipliers_all = np.full((len(cases), len(prepared.bounds)), np.nan)
    signs_all = np.ones_like(multipliers_all)

    def batched_round(group: np.ndarray) -> np.ndarray:
        """Batched Newton from ``seed`` on the cases ``group``: the verified ones kept (their
        answers assembled when read), their mask returned."""
        y, multipliers, verified, table = batched_newton(
            geometry.stack,
            objectives[group],
            seed.y,
            seed.multipliers,
            seed.signs,
            accept=acceptance(geometry.conditioning),
        )
        verified = _unique(geometry.stack, seed, y, multipliers, verified)
        x = y @ prepared.x_from_y.T
        # the same independent checks as a single solve: statics in x, penetration
        gaps, forces = prepared.contact_state(x, multipliers, seed.signs, sigmas[group][:, None])
        statics = prepared.statics_residual(gradients[group], forces, load_sizes[group])
        violation = np.maximum(-gaps / prepared.bounds, 0.0).max(axis=1, initial=0.0)
        verified &= measured_ok(statics, violation)
        for k in np.flatnonzero(verified):
            i = group[k]
            items[i] = _lazy_item(
                prepared,
                (gradients[i], objectives[i], sigmas[i], load_sizes[i], shares[i]),
                y[k],
                multipliers[k],
                seed.signs,
                table[k],
                mechanism.resolve_loads(cases[i][0], options.gravity),
                options.outputs,
            )
        x_all[group[verified]] = x[verified]
        batched[group[verified]] = True
        y_all[group[verified]] = y[verified]
        multipliers_all[group[verified]] = multipliers[verified]
        signs_all[group[verified]] = seed.signs
        bar.update(int(verified.sum()))
        return verified

    for _ in range(REGROUP_ROUNDS):
        if seed is None or pending.size == 0:
            break
        # never much slower than a loop of single solves: a probe of the group shows whether
        # the seed's contact set is shared widely enough for the batch to pay (loads so diverse
        # that few share it are solved one by one); decided by what it verifies (PROBE_PAYS),
        # never by a clock: the route of a call depends on its cases, not on the machine
        done = batched_round(pending[:PROBE])
        pays = int(done.sum()) >= PROBE_PAYS
        left = [pending[:PROBE][~done]]
        if pays and pending.size > PROBE:
            left.append(pending[PROBE:][~batched_round(pending[PROBE:])])
        elif pending.size > PROBE:
            left.append(pending[PROBE:])
        pending = np.concatenate(left)
        if pending.size == 0 or not pays:
            break
        # the next group: seeded by a single solve of the first case left
        i = pending[0]
        items[i] = _solve_chunk(mechanism, [cases[i]], options, errors, start=i)[0]
        bar.update()
        pending = pending[1:]
        solved = items[i]
        seed = (
            mechanism.cache.warm.get(prepared.signature)
            if not isinstance(solved, Exception)
            else None
        )
    for i in range(len(cases)):
        if items[i] is None:
            items[i] = _solve_chunk(mechanism, [cases[i]], options, errors, start=i)[0]
            bar.update()
    torsor_maps = {name: prepared.maps.joint_torsor[name] for name in mechanism.joints}
    oMi = prepared.configuration.oMi

    def stacked() -> StackedAnswers:
        return StackedAnswers(
            mechanism,
            prepared,
            y_all,
            multipliers_all,
            signs_all,
            sigmas,
            batched,
            np.array([m.rotation for m in oMi])[None],
            np.array([m.translation for m in oMi])[None],
            False,
            cases.load_column(),
            options.gravity,
        )

    arrays = {"x": x_all, "batched": batched, "torsor_maps": torsor_maps, "stacked": stacked}
    return EquilibriumBatch(items, arrays, mechanism=mechanism)


def _solve_compiled_batch(
    mechanism: Mechanism,
    prepared: PreparedGeometry,
    fast: FastTerms,
    first: Item,
    cases: Cases,
    options: SolveOptions,
    errors: str,
) -> EquilibriumBatch | None:
    """Load cases at one configuration in one compiled call (:func:`.kernel.solve_cases`), each
    warm-started from the previous case's answer, verified like a single solve; the cases it
    does not verify are solved alone. None when the cases' loads do not share one set of loaded
    points (the NumPy batch then runs)."""
    seed = mechanism.cache.warm.get(prepared.signature)
    if seed is None:
        return None
    try:  # the loads every case shares after its own (gravity); the first case resolved them
        appended = mechanism.resolve_loads((), options.gravity)
    except ClearancePinError:
        return None
    column = cases.load_column()  # cases: the Cases of solve_many
    mapped = fast.load_cases(column[1:], appended)
    if mapped is None:
        return None  # cases of other loaded points (or refused loads): the NumPy batch
    rows = _compiled_rows(fast, *mapped, seed)
    x_column = next(start for name, start, _, _ in fast.layout if name == "x")
    x_all = np.full((len(cases), prepared.size_x), np.nan)
    statics, violation = rows[:, 7], rows[:, 9]
    good = (rows[:, 0] == fast.kernel.SOLVED) & measured_ok(statics, violation)
    x_all[1:][good] = rows[good, x_column : x_column + prepared.size_x]
    batched = np.concatenate([[False], good])
    items: list[Any] = [first]  # None: a verified case, assembled when read (_compiled_item)
    for k, verified in enumerate(good.tolist(), start=1):
        items.append(
            None if verified else _solve_chunk(mechanism, [cases[k]], options, errors, start=k)[0]
        )
    torsor_maps = {name: prepared.maps.joint_torsor[name] for name in mechanism.joints}
    arrays = {
        "x": x_all,
        "batched": batched,
        "torsor_maps": torsor_maps,
        "stacked": lambda: _compiled_answers(mechanism, fast, rows, batched, cases, options),
    }
    return EquilibriumBatch(
        items,
        arrays,
        lambda i: _compiled_item(fast, rows[i - 1], (*column[i], *appended), options.outputs),
        mechanism,
    )


def _compiled_answers(
    mechanism: Mechanism,
    fast: FastTerms,
    rows: Array,
    batched: Mask,
    cases: Cases,
    options: SolveOptions,
) -> StackedAnswers:
    """The answers of a compiled batch as arrays (:mod:`.batch_answers`): the kernel's rows of
    the cases 1... read as its items read them (:meth:`.fast_path.FastTerms.parts`: unknowns,
    gaps, force rows, body twists); case 0 was solved alone."""
    prepared = fast.prepared
    parts = [fast.parts(row) for row in rows]

    def column(name: str) -> np.ndarray:
        values = np.array([part[name] for part in parts]).reshape(len(rows), -1)
        out = np.full((len(rows) + 1, values.shape[1]), np.nan)
        out[1:] = values
        return out

    oMi = prepared.configuration.oMi
    given = {name: column(name) for name in ("x", "gaps", "forces", "twists")}
    given["force_rows"] = given.pop("forces")
    given["twists"] = given["twists"].reshape(len(rows) + 1, -1, 6)
    multipliers = column("multipliers")
    return StackedAnswers(
        mechanism,
        prepared,
        column("y"),
        multipliers,
        column("signs"),
        np.full(len(rows) + 1, np.nan),
        batched,
        np.array([m.rotation for m in oMi])[None],
        np.array([m.translation for m in oMi])[None],
        False,
        cases.load_column(),
        options.gravity,
        given,
    )


def _compiled_rows(
    fast: FastTerms, params: Array, load_matrix: Array, load_constant: Array, seed: ConeSolution
) -> Array:
    """The kernel's rows of the load cases ``params`` (N, 3 k), each warm-started from the
    nearest recent answer, in chunks of at least :data:`THREAD_CASES` cases (at most
    :data:`THREAD_CHUNKS`) solved on threads at once when the machine has the cores (the kernel
    releases the GIL). The chunks depend on N alone, so the answers do not depend on the
    machine; each chunk starts from ``seed`` and a copy of the pool (the first chunk: the pool
    itself, which keeps its answers)."""
    count = min(THREAD_CHUNKS, len(params) // THREAD_CASES)

    def chunk(part: slice, pool: Any = None) -> Array:
        rows: Array = fast.solve(params[part], load_matrix, load_constant, seed.y, seed.multipliers,
                          seed.signs, chain=True, warm_rounds=WARM_ROUNDS, pooled=True,
                          pool=pool)[0]  # fmt: skip
        return rows

    if count < 2:
        return chunk(slice(None))
    edges = np.linspace(0, len(params), count + 1).astype(int).tolist()
    parts = [slice(a, b) for a, b in itertools.pairwise(edges)]
    pools = [None, *(fast.pool_copy() for _ in parts[1:])]
    threads = _helper_threads()
    if threads is None:  # one core: the same chunks in turn
        return np.concatenate([chunk(part, pool) for part, pool in zip(parts, pools)])
    others = [threads.submit(chunk, part, pool) for part, pool in zip(parts[1:], pools[1:])]
    first = chunk(parts[0])  # on this thread meanwhile
    return np.concatenate([first, *(future.result() for future in others)])


_helpers: list[ThreadPoolExecutor] = []  # the helper threads' executor, made on first use
_helpers_lock = threading.Lock()


def _helper_threads() -> ThreadPoolExecutor | None:
    """THREAD_CHUNKS - 1 helper threads, kept for the process (starting threads for each
    batch would cost about what 10 cases do); None on a machine of one core."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    if (cores or 1) < 2:
        return None
    with _helpers_lock:
        if not _helpers:
            _helpers.append(ThreadPoolExecutor(THREAD_CHUNKS - 1, "clearance_pin-batch"))
    return _helpers[0]


def _compiled_item(
    fast: FastTerms, row: Array, loads: tuple[Any, ...], outputs: Sequence[str] | None = None
) -> Equilibrium:
    """The Equilibrium of one case of a compiled batch, its ``row`` of the kernel's answer (its
    flat directions, if any, found and described now); ``outputs`` as :meth:`Mechanism.solve`'s."""
    answer = fast.parts(row)
    flat, _ = fast.prepared.flat_directions(answer["y"], answer["multipliers"], answer["signs"])
    outcome: Outcome = ("optimal", Method.COMPILED, "batched Newton (compiled)", 0, True)
    points = () if outputs is None else resolve_outputs(fast.prepared.mechanism, loads, outputs)
    answered: Equilibrium = fast.equilibrium(row, flat, loads, outcome, (0.0, 0.0), points, answer)
    return answered


def _unique(
    stack: StackedContacts, seed: ConeSolution, y: Array, multipliers: Array, verified: Mask
) -> Mask:
    """Cases whose optimum is unique (no direction that keeps the loaded contacts and sees no
    curvature, as :meth:`~.prepared.PreparedGeometry.flat_directions` decides for a single
    solve) and whose loaded contacts are the seed's; the others are left to single solves, which
    move them to the minimum-norm point."""
    loaded_seed = seed.multipliers > UNLOADED * seed.multipliers.max(initial=0.0)
    largest = multipliers.max(axis=1, initial=0.0)
    loaded = multipliers > UNLOADED * largest[:, None]
    verified = verified & np.all(loaded == loaded_seed, axis=1)
    gradients = stacked_evaluation(stack, y, seed.signs)[1] * loaded[:, :, None]
    row_weights = np.where(stack.row_is_norm, 2.0 * multipliers[:, stack.row_contact], 0.0)
    hessians = np.matmul(stack.matrix.T[None] * row_weights[:, None, :], stack.matrix)
    rows = np.concatenate([gradients, hessians], axis=1)
    rows /= np.maximum(1.0, np.abs(rows).max(axis=(1, 2)))[:, None, None]
    singular = np.linalg.svd(rows, compute_uv=False)
    unique: Mask = verified & (singular[:, -1] > 1e-9 * singular[:, 0])
    return unique


def _lazy_item(
    prepared: PreparedGeometry,
    load: tuple[Any, ...],
    y: Array,
    multipliers: Array,
    signs: Array,
    table: Array,
    loads: tuple[Any, ...],
    outputs: Sequence[str] | None = None,
) -> Callable[[], Equilibrium]:
    """The Equilibrium of one batched case, assembled when first read (``loads``: the case's
    resolved loads, kept for the joint reactions; ``outputs`` as :meth:`Mechanism.solve`'s)."""

    def build() -> Equilibrium:
        return assemble_linear(
            prepared,
            loaded_problem(prepared.geometry, *load),
            y,
            multipliers,
            signs,
            "optimal",
            Method.NEWTON,
            "batched Newton",
            0,
            True,
            0.0,
            0.0,
            dict(zip(RESIDUAL_NAMES, map(float, table))),
            loads,
            (),
            () if outputs is None else resolve_outputs(prepared.mechanism, loads, outputs),
        )

    return build
