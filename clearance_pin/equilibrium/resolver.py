"""Re-solves of one set of loads with new values: a planner's loop, built once.

``mechanism.resolver(loads)`` checks the arguments once, resolves the loads (gravity included),
the output points and the prepared geometry; ``resolver.solve(values)`` takes the new force and
torque vectors of those loads, in their order, as one array (k, 3) or (3 k,) [N, N m] (the way a
prebuilt optimiser takes a new cost vector) and returns the verified
:class:`~.result.Equilibrium`, the same answer as ``mechanism.solve`` of those loads. Once the
compiled kernel is engaged (:mod:`.fast_path`), a re-solve is one compiled call on arguments
bound when first used, and the load objects of the answer's ``loads`` are built when read: the
checks, look-ups and load objects of ``mechanism.solve`` are skipped (about a third of a warm
``solve``'s time on the paper's shafts: 56 against 82 us on 6.2.1, medians of solves
interleaved with other work).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from ..arguments import (
    SMALLEST_LOAD,
    check_case,
    check_configurations,
    check_errors,
    check_load_magnitudes,
)
from ..deflection_check import batch_deflections, warn_answer, warn_large_deflections
from ..errors import ArgumentError, ClearancePinError, SolverError
from ..model.loads import PointForce, Torque, with_vector
from ..model.stiffness import stiff_joints
from ..numerics import LARGEST_MAGNITUDE
from .blocks import block_structure
from .cone_solver import clarabel_available
from .fast_path import BoundLoads, FastTerms, fast_terms, kernel_installed
from .formulation import solve_case
from .load_map import signature_of
from .load_table import LoadVectors
from .method import Method
from .options import DEFAULT_OPTIONS, SolveOptions
from .outputs import resolve_outputs
from .plan import plan_linear
from .prepared import prepared_geometry
from .result import Equilibrium
from .solve import resolve_linear, solve_linear


class Resolver:
    """One mechanism, one set of loads whose force and torque vectors change; the options of
    :meth:`Mechanism.solve` (``exact=True`` or ``"auto"``: each re-solve goes
    ``Mechanism.solve``'s way from the resolved loads).

    Attributes:
        loads: the resolved loads (gravity last when on); ``solve`` replaces the vectors of the
            PointForce and Torque ones, in this order.
        size: how many numbers ``solve`` takes (3 per PointForce or Torque).
    """

    def __init__(
        self,
        mechanism: Any,
        loads: Any = None,
        q: Any = None,
        options: SolveOptions = DEFAULT_OPTIONS,
    ) -> None:
        """``options`` checked by the caller (:meth:`Mechanism.resolver`)."""
        self._q = check_case(mechanism, loads, q)
        self.options = options
        backend, warm_start = options.backend, options.warm_start
        exact, outputs = options.exact, options.outputs
        self.mechanism = mechanism
        self.loads = mechanism.resolve_loads(loads, options.gravity)
        self._varying = [
            i for i, load in enumerate(self.loads) if isinstance(load, (PointForce, Torque))
        ]
        if not self._varying:
            raise ArgumentError(
                "loads", "at least one PointForce or Torque (solve() changes their vectors)", loads
            )
        self.size = 3 * len(self._varying)
        # above this, a value may make a force's moment about its link origin exceed what
        # check_load_magnitudes allows: that check (building the load objects) names it then
        farthest = max((_farthest_point(self.loads[i]) for i in self._varying), default=0.0)
        self._largest_value = LARGEST_MAGNITUDE / max(1.0, farthest)
        self._points = resolve_outputs(mechanism, self.loads, outputs)
        self._prepared = prepared_geometry(mechanism, self._q)  # kept: valid while we hold it
        # the plan's structure of these loads (:func:`.plan.plan_linear`), read once
        self._plan = functools.partial(
            plan_linear,
            independent_blocks=backend == "auto"
            and block_structure(self._prepared.geometry, bool(mechanism.loop_joints)) is not None,
            size=self._prepared.geometry.stack.size,
            contacts=self._prepared.geometry.stack.count,
            backend=backend,
            clarabel=clarabel_available(),
        )
        # the compiled re-solve with the kernel's own starts: a warm small-displacement solve
        self._compiled = warm_start and not exact and backend == "auto"
        self._bound: tuple[FastTerms, BoundLoads] | None = None  # once the kernel is engaged

    def solve(self, values: Any) -> Equilibrium:
        """The equilibrium with the force and torque vectors ``values`` ((k, 3) or (3 k,) [N,
        N m], in the order of :attr:`loads`); raises like :meth:`Mechanism.solve`."""
        vector = _finite_vector(values, self.size)
        if vector is None:
            raise ArgumentError(
                "values",
                f"finite real numbers shaped ({self.size // 3}, 3) or ({self.size},): the loads' "
                "force and torque vectors [N, N m], a row each, in the order of resolver.loads",
                values,
                _why_not(values, self.size),
            )
        largest = float(np.abs(vector).max())
        if largest > self._largest_value or 0.0 < largest < SMALLEST_LOAD:
            check_load_magnitudes(self._loads_with(vector), "values")
        answer = self._solve(vector, functools.partial(self._loads_with, vector))
        if answer.deflections:  # a spring of the wrong unit (Mechanism.solve's own lane warns)
            warn_answer(self.mechanism, answer)
        return answer

    def solve_loads(
        self, loads: Sequence[PointForce | Torque], vector: np.ndarray | None = None
    ) -> Equilibrium:
        """The equilibrium of ``loads``, load objects at the resolver's loaded points (kinds,
        links and points in the order of :attr:`loads`, built and checked by their
        constructors), as :meth:`solve` of their vectors (``vector`` (3 k,) when the caller has
        stacked them); the answer's ``loads`` are these objects (then gravity, when resolved).
        :meth:`Mechanism.solve` of default options comes here (:func:`solve_by_resolver`)."""
        if vector is None:
            vector = np.concatenate(
                [load.force if isinstance(load, PointForce) else load.torque for load in loads]
            )
        largest = float(np.abs(vector).max())
        resolved = (*loads, *self.loads[len(loads) :])
        if largest > self._largest_value or 0.0 < largest < SMALLEST_LOAD:
            check_load_magnitudes(resolved)
        return self._solve(vector, lambda: resolved)

    def _solve(self, vector: np.ndarray, loads_of: Callable[[], tuple[Any, ...]]) -> Equilibrium:
        """The equilibrium of the loads ``loads_of()`` (built when read), whose force and torque
        vectors are ``vector`` (3 k,), checked."""
        mechanism, options = self.mechanism, self.options
        # once bound, the plan's answer for these loads is known (it reads the structure and
        # the installation, neither of which changes): the kernel first
        if self._bound is not None or (
            self._compiled
            and Method.COMPILED
            in self._plan(solved_before=bool(mechanism.cache.warm), kernel=kernel_installed())
        ):
            answer = self._resolve_compiled(vector, loads_of)
            if answer is not None:
                return answer
        try:
            if options.exact:  # the exact model, from the resolved loads
                return solve_case(mechanism, loads_of(), self._q, options)
            return solve_linear(
                mechanism,
                loads_of(),
                self._q,
                options.tol,
                options.backend,
                options.warm_start,
                self._points,
                self._prepared,
            )
        except (np.linalg.LinAlgError, OverflowError, FloatingPointError, ValueError) as exc:
            if isinstance(exc, ClearancePinError):
                raise
            raise SolverError(
                f"numerical failure in {mechanism.name!r} ({type(exc).__name__}: {exc})",
                "numerical error",
            ) from None

    def solve_many(
        self,
        values: Any,
        configurations: Any = None,
        *,
        errors: str = "raise",
        progress: bool | None = None,
        **options: Any,
    ) -> Any:
        """Many re-solves in one call, from arrays: the force and torque vectors ``values``
        (N, k, 3) or (N, 3 k) [N, N m] (row n: case n's vectors, as :meth:`solve` takes one),
        no load object built; with ``configurations`` (Q, nq), every pose under every load case,
        a payload x pose grid of Q N cases, case ``i * N + n`` pose i under load case n.

        Returns the :class:`~.batch.EquilibriumBatch` of ``Mechanism.solve_many`` (its
        whole-batch readers give arrays: ``frame_displacements``, ``reactions``,
        ``contact_forces``, ``drive_torques``), the same answers as ``solve_many`` of the load
        objects; ``errors`` and ``progress`` as there (with ``errors="return"`` a row with an
        infinite or NaN entry, or beyond what double precision carries, is its cases' error:
        the others are solved, and the batch is read item by item). Without ``configurations`` every case is
        at the resolver's configuration (its ``q``).
        """
        from .batch import solve_many, with_refused

        if options:  # the resolver's own: given once, to mechanism.resolver(...)
            name = next(iter(options))
            raise ArgumentError(
                name, "no solve option here: the resolver's options are given to "
                "mechanism.resolver(loads, ...)", options[name], "unknown argument",
            )  # fmt: skip
        check_errors(errors)
        vectors, refused = self._vectors(values, errors == "raise")
        poses = None  # every case at the resolver's own configuration
        if configurations is not None:
            poses = self._poses(configurations)
            cases = len(vectors)
            vectors = np.tile(vectors, (len(poses), 1))
            poses = [q for q in poses for _ in range(cases)]
            refused = {i * cases + n: error for i in range(len(poses) // cases)
                       for n, error in refused.items()}  # fmt: skip
        elif self._q is not None:
            poses = [self._q] * len(vectors)

        def solved(kept: list[int] | None = None) -> Any:
            return solve_many(
                self.mechanism,
                LoadVectors(self.loads, vectors if kept is None else vectors[kept]),
                poses if poses is None or kept is None else [poses[i] for i in kept],
                replace(self.options, gravity=False),  # resolved: the loads carry it
                errors=errors,
                progress=progress,
            )

        # errors="return": the rows refused take their cases' places
        batch = with_refused(self.mechanism, len(vectors), refused, solved) if refused else solved()
        if stiff_joints(self.mechanism.joints):  # a spring of the wrong unit: once per call
            warn_large_deflections(
                self.mechanism, batch_deflections(self.mechanism, batch), batch=True
            )
        return batch

    def _vectors(
        self, values: Any, refuse: bool
    ) -> tuple[np.ndarray, dict[int, ClearancePinError]]:
        """``values`` as a float array (N, 3 k), checked: finite real numbers, magnitudes
        within double precision (:func:`~clearance_pin.arguments.check_load_magnitudes`, in
        bulk; the first case beyond the limits named); and, unless ``refuse`` (then the first
        is raised), the error of each row that is not, by row (``errors="return"``)."""
        expected = (
            f"finite real numbers shaped (N, {self.size // 3}, 3) or (N, {self.size}): per case "
            "the loads' force and torque vectors [N, N m], in the order of resolver.loads"
        )
        try:
            raw = np.asarray(values)
        except (TypeError, ValueError):  # ragged lists
            raise ArgumentError("values", expected, values) from None
        shaped = raw.ndim in (2, 3) and raw.shape[1:] in ((self.size // 3, 3), (self.size,))
        if raw.dtype.kind not in "fiu" or not shaped or len(raw) == 0:
            raise ArgumentError("values", expected, values)
        vectors = raw.astype(float).reshape(len(raw), self.size)
        refused: dict[int, ClearancePinError] = {}
        finite = np.isfinite(vectors).all(axis=1)
        for row in np.flatnonzero(~finite).tolist():
            error = ArgumentError(
                f"values[{row}]", expected, vectors[row], "an infinite or NaN entry"
            )
            if refuse:
                raise error
            refused[row] = error
        with np.errstate(invalid="ignore"):  # NaN rows: refused above
            largest = np.abs(vectors).max(axis=1)
        beyond = (largest > self._largest_value) | ((largest > 0.0) & (largest < SMALLEST_LOAD))
        for row in np.flatnonzero(beyond & finite).tolist():
            try:
                check_load_magnitudes(self._loads_with(vectors[row]), f"values[{row}]")
            except ClearancePinError as error:
                if refuse:
                    raise
                refused[row] = error
        return vectors, refused

    def _poses(self, configurations: Any) -> list[np.ndarray]:
        """``configurations`` as a list of checked configurations q (nq,) (None: the
        resolver's own), one warning for those outside the joints' limits."""
        poses = check_configurations(self.mechanism, configurations)
        if not poses:
            raise ArgumentError("configurations", "at least one configuration", configurations)
        own = self.mechanism.q_nominal if self._q is None else self._q
        checked = [np.asarray(own if q is None else q, dtype=float) for q in poses]
        if any(joint.locked for joint in self.mechanism.tree_joints):
            for index, q in enumerate(checked):
                self.mechanism.check_locks(q, f"configurations[{index}]")
        return checked

    def _resolve_compiled(
        self, vector: np.ndarray, loads_of: Callable[[], tuple[Any, ...]]
    ) -> Equilibrium | None:
        """The compiled re-solve (:func:`.solve.resolve_linear`), None when the kernel is not
        engaged or does not verify this load."""
        if self._bound is None:
            fast = fast_terms(self._prepared)
            if fast is None:
                return None
            binding = fast.load_binding(self.loads)
            if binding is None:
                self._compiled = False  # loads the kernel does not take: always the NumPy way
                return None
            self._bound = (fast, binding[1])
        fast, bound = self._bound
        return resolve_linear(self.mechanism, fast, bound, vector, loads_of, self._points)

    def _loads_with(self, vector: np.ndarray) -> tuple[Any, ...]:
        """:attr:`loads` with the force and torque vectors ``vector`` (3 k,)."""
        loads = list(self.loads)
        for k, index in enumerate(self._varying):
            loads[index] = with_vector(loads[index], vector[3 * k : 3 * k + 3])
        return tuple(loads)


def _finite_vector(values: Any, size: int) -> np.ndarray | None:
    """``values`` as a new float vector (size,) (a copy: the answer's loads are built from it
    when read), None unless they are real numbers (integers or floats: not booleans, strings or
    complex numbers) shaped (size / 3, 3) or (size,), all finite."""
    try:
        raw = np.asarray(values)
    except (TypeError, ValueError):  # ragged lists
        return None
    if raw.dtype.kind not in "fiu" or raw.shape not in ((size,), (size // 3, 3)):
        return None
    vector = raw.astype(float).ravel()  # astype copies
    # a finite sum proves every entry finite (an inf or NaN entry makes it inf or NaN); else
    # (or an overflow of huge entries) each entry is tested
    if not math.isfinite(sum(vector.tolist())) and not np.isfinite(vector).all():
        return None
    return vector


def solve_by_resolver(mechanism: Any, loads: Sequence[object]) -> Equilibrium | None:
    """:meth:`Mechanism.solve` of ``loads`` (a list or tuple) with the default options at the
    nominal configuration, by the :class:`Resolver` of their loaded points (kinds, links,
    points), which the mechanism keeps from the second solve of those points on
    (``cache.resolvers``, the :data:`~.cache.RESOLVERS_KEPT` most recent): a planner's loop that
    builds its loads gets the resolver's re-solve without asking for it. None when a load is
    not a PointForce or Torque, on the first solve of those points, or when they cannot make a
    resolver (the general path then answers, or raises naming the problem)."""
    signed = signature_of(loads)
    if signed is None or (None, None) in signed[0]:  # not a load, or a gravity among them
        return None
    key, vector = signed  # (forces and torques only: their stacked vectors)
    kept = mechanism.cache.resolvers
    resolver = kept.get(key, _UNSEEN)
    if resolver is _UNSEEN or resolver is None:
        if resolver is _UNSEEN:  # first seen: the general path; a resolver if seen again
            kept[key] = None
            return None
        try:
            resolver = Resolver(mechanism, loads)
        except ClearancePinError:
            kept[key] = _REFUSED  # the general path raises, naming the problem
            return None
        kept[key] = resolver
    if not isinstance(resolver, Resolver):  # refused
        return None
    return resolver.solve_loads(loads, vector)  # type: ignore[arg-type]  # PointForce, Torque


_UNSEEN, _REFUSED = object(), object()


def _why_not(values: Any, size: int) -> str | None:
    """What :func:`_finite_vector` refused in ``values``: its shape, its kind, or an infinite
    or NaN entry (an error's note)."""
    try:
        raw = np.asarray(values)
    except (TypeError, ValueError):
        return "ragged rows"
    if raw.shape not in ((size,), (size // 3, 3)):
        return f"shape {raw.shape}"
    if raw.dtype.kind not in "fiu":
        return f"entries of kind {raw.dtype}"
    return "an infinite or NaN entry"


__all__ = ["Resolver", "solve_by_resolver"]


def _farthest_point(load: Any) -> float:
    """The largest coordinate [m] of a PointForce's point (0 for a Torque)."""
    return float(np.abs(load.point).max()) if isinstance(load, PointForce) else 0.0
