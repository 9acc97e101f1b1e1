"""The compiled re-solve: a new load on a built mechanism in two compiled calls (:mod:`.kernel`).

A planner re-solves the same configuration thousands of times. Once a mechanism has been solved,
its next solves go this way: the load's force and torque vectors p map to body wrenches by a
matrix built once per set of loaded points (:func:`load_map`), the compiled kernel forms the
objective, runs the verified active-set Newton step from the previous solution (or polishes the
backend's answer for a cold solve) and computes the answer's arrays; Python builds the answer.
Whatever the kernel does not verify goes the NumPy way (:mod:`.solve`), which handles every case.

Whether the kernel answers is an installation fact, decided once per process and never from
counters, clocks or threads (issue 22): it is used when numba has it compiled on this machine
(``clearance-pin compile``, run by the README's set-up, leaves a record of numba's cache files:
:func:`kernel_installed`), when ``CLEARANCE_PIN_COMPILED=1`` (loaded, compiling if need be, at the
first re-solve) or after :func:`load_kernel`. It then loads at the first re-solve (about half a
second from numba's cache), never at import or on a first solve. ``CLEARANCE_PIN_COMPILED=0``
switches it off. Without it every solve goes the NumPy way, with the same answers.
"""

from __future__ import annotations

import hashlib
import importlib.metadata
import json
import os
import sys
import threading
import time
import warnings
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, NamedTuple, Protocol, TypedDict

import numpy as np
import numpy.typing as npt

from ..errors import KernelUnavailableWarning
from ..model.loads import Gravity, Load
from ..numerics import Array, Index, Mask
from .cone_solver import WARM_MAX_SIZE, Backend, ConeSolution, acceptance
from .frozen import FieldTemplate
from .kkt import ACTIVE_GAP, POLISH_TOL, PROXIMAL, UNLOADED
from .lazy import LazySequence
from .linear_answer import Outcome, linear_equilibrium
from .load_table import uniform_vectors
from .method import Method, backend_method
from .outputs import OutputPoint
from .prepared import PreparedGeometry
from .reduction import ROUND_OFF_WORK, UNBOUNDED_FRACTION, ReducedProblem, loaded_problem
from .residuals import Residuals
from .result import Equilibrium

if TYPE_CHECKING:  # the kernel imports numba: loaded when first used (load_kernel)
    from .kernel import Compiled

# the NumPy path's constants, in the order of kernel.POLISH ... kernel.ROUND_OFF_WORK
TOLERANCES = np.array(
    [POLISH_TOL, PROXIMAL, UNLOADED, ACTIVE_GAP, UNBOUNDED_FRACTION, ROUND_OFF_WORK]
)
# active-set rounds and Newton iterations (kkt.active_set_solve's): compiled, a round costs about
# a microsecond. A re-solve's guess (the previous answer) gets WARM_ROUNDS, then the centred
# start gets ROUNDS plus CENTRE_ROUNDS_PER_CONTACT per contact (it adds contacts one by one and
# walks along the boundary in short steps: with 3 per contact a reviewer's three-bearing shaft
# left 6 of 50 loads to Clarabel, with 8 3 of 50); the polish of a backend's answer gets ROUNDS
ROUNDS, WARM_ROUNDS, CENTRE_ROUNDS_PER_CONTACT, ITERATIONS = 10, 3, 8, 12
POOL = 64  # recent answers the kernel keeps per geometry, the starts of warm solves


class CompiledKernel(Protocol):
    """What the solver reads of the kernel module (:mod:`.kernel`), which is one (mypy checks
    the module against it where :func:`load_kernel` keeps it)."""

    SOLVED: int
    UNDECIDED: int
    UNBOUNDED: int
    NO_WORK: int
    SCALARS: int
    ENERGY: int
    START: int
    solve_cases: Compiled[..., tuple[Array, Array]]
    load_objective: Compiled[..., tuple[int, Array, float, Array, float, float]]


class _Loaded(TypedDict, total=False):
    kernel: CompiledKernel  # the module
    seconds: float  # its load time
    failed: bool  # unavailable in this process
    installed: bool  # numba's cache holds it (the record of _record_path)


_lock = threading.Lock()
_loaded: _Loaded = {}


def load_kernel() -> float:
    """Load the compiled kernel now (numba's import, then its compiled functions from numba's
    on-disk cache, compiling them the first time on a machine) and return the seconds it took;
    a planner calls this at start-up so that no solve later waits for it. Raises ImportError
    when numba is not installed; a no-op when ``CLEARANCE_PIN_COMPILED=0``.

    When numba is installed but cannot load it (its cache not writable on a read-only install,
    where numba raises a RuntimeError; a failed compilation), the solves go the NumPy way: one
    :class:`~clearance_pin.errors.KernelUnavailableWarning` says why, and 0.0 is returned."""
    if os.environ.get("CLEARANCE_PIN_COMPILED") == "0" or "failed" in _loaded:
        return 0.0
    with _lock:
        if _loaded.get("kernel") is None and "failed" not in _loaded:
            started = time.perf_counter()
            try:
                from . import kernel

                kernel.warm_up()
            except ImportError:
                raise
            except Exception as exc:  # numba's own errors: the NumPy path answers
                _loaded["failed"] = True
                reason = " ".join(f"{type(exc).__name__}: {exc}".split())
                warnings.warn(
                    f"the compiled kernel is unavailable ({reason}); the solves go the NumPy "
                    "way, with the same answers (a read-only install: set NUMBA_CACHE_DIR to a "
                    "writable folder)",
                    KernelUnavailableWarning,
                    stacklevel=2,
                )
                return 0.0
            _loaded["kernel"] = kernel
            _loaded["seconds"] = time.perf_counter() - started
            _write_record(kernel)
    if "failed" in _loaded:
        return 0.0
    return float(_loaded["seconds"])


def kernel_load_time() -> float | None:
    """Seconds the kernel took to load (numba import and compile or cache load), None if not
    loaded."""
    value = _loaded.get("seconds")
    return None if value is None else float(value)


def compiled_kernel(engage: int = 0) -> CompiledKernel | None:
    """The kernel module (:mod:`.kernel`) when loaded; with ``engage`` (a re-solve or a batch
    asks for it), loaded now when :func:`kernel_installed`. None otherwise: numba missing, the
    kernel not compiled on this machine, failed to load, or ``CLEARANCE_PIN_COMPILED=0``."""
    if os.environ.get("CLEARANCE_PIN_COMPILED") == "0":
        return None
    module = _loaded.get("kernel")
    if module is not None or not engage or not kernel_installed():
        return module
    try:
        load_kernel()
    except ImportError:  # numba not installed: the NumPy path answers
        _loaded["failed"] = True
        return None
    return _loaded.get("kernel")  # None when it failed to load (load_kernel warned)


def kernel_installed() -> bool:
    """Whether re-solves take the compiled kernel in this process (an installation fact, the
    same for every call): ``CLEARANCE_PIN_COMPILED`` is ``1``, or the kernel is loaded, or
    numba's cache holds it as :func:`load_kernel` recorded it on this machine (the same kernel
    source, Python, numba and ``NUMBA_CACHE_DIR``, every cache index file present); False for
    ``0`` or after a failed load. The record is read once per process."""
    setting = os.environ.get("CLEARANCE_PIN_COMPILED", "auto")
    if setting == "0" or "failed" in _loaded:
        return False
    if setting == "1" or _loaded.get("kernel") is not None:
        return True
    installed = _loaded.get("installed")
    if installed is None:
        installed = _loaded["installed"] = _record_valid()
    return bool(installed)


def _record_path() -> Path | None:
    """The file recording that numba's cache holds this kernel (:func:`_write_record`), in the
    user's cache folder (``XDG_CACHE_HOME`` or ``~/.cache``), named by the kernel's stamp; None
    when the stamp cannot be read (numba not installed)."""
    try:
        numba_version = importlib.metadata.version("numba")
    except importlib.metadata.PackageNotFoundError:
        return None
    source = Path(__file__).with_name("kernel.py").read_bytes()
    stamp = hashlib.sha256(
        b"\0".join([source, numba_version.encode(), sys.version.encode(),
                     os.environ.get("NUMBA_CACHE_DIR", "").encode()])
    ).hexdigest()[:20]  # fmt: skip
    root = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(root) / "clearance_pin" / f"kernel-{stamp}.json"


def _record_valid() -> bool:
    """The record of :func:`_record_path` exists and every numba cache index it lists is there."""
    path = _record_path()
    try:
        if path is None or not path.is_file():
            return False
        files = json.loads(path.read_text())["index_files"]
        return bool(files) and all(os.path.isfile(name) for name in files)
    except (OSError, ValueError, KeyError, TypeError):
        return False


def _write_record(kernel: CompiledKernel) -> None:
    """Record numba's cache index files of the loaded ``kernel`` (:func:`_record_path`), so that
    later processes take the kernel without compiling it; silently nothing where the user's
    cache folder is not writable (those processes go the NumPy way)."""
    path = _record_path()
    if path is None:
        return
    folder = Path(str(kernel.solve_cases.stats.cache_path))
    files = sorted(str(name) for name in folder.glob("kernel.*.nbi"))
    if not files:
        return
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        temporary = path.with_suffix(f".{os.getpid()}.tmp")
        temporary.write_text(json.dumps({"index_files": files}))
        os.replace(temporary, path)
    except OSError:
        return
    _loaded["installed"] = True


# the kernel's layout of a geometry's contacts (matrix, offset, starts, is_norm), of its pool of
# recent answers (f, y, multipliers, sides, (entries, next slot)), of solve_cases' arguments from
# the load map to the guess
Cone = tuple[Array, Array, Index, Mask]
Pool = tuple[Array, Array, Array, Array, Index]
LoadArguments = tuple[Array, Array, Array, int, Array, Array, Array, Index, Mask]


class BoundLoads(NamedTuple):
    """One set of loaded points (kinds, links, points, gravity) on one geometry: the map
    W = A p + w0 from their force and torque vectors p to the body wrenches, and the kernel's
    arguments from A to the guess (:func:`.kernel.solve_cases`), bound once."""

    matrix: Array
    constant: Array
    arguments: LoadArguments


# the residuals in solve_cases' row from column 3 on (kernel.ENERGY's docstring)
_RESIDUAL_COLUMNS = ("unblocked_load", "stationarity", "feasibility", "complementarity",
                     "statics", "max_violation_m", "max_violation_rel", "largest_rotation_rad")  # fmt: skip


class FastTerms:
    """The arrays of one prepared geometry in the kernel's layout (contiguous float64 / int64),
    and the load maps of the sets of loaded points seen so far."""

    def __init__(self, prepared: PreparedGeometry) -> None:
        terms, stack = prepared.terms, prepared.geometry.stack
        self.prepared = prepared
        kernel = compiled_kernel()
        assert kernel is not None  # built only once the kernel is loaded (fast_terms)
        self.kernel = kernel
        self.size = stack.size
        ends = np.append(stack.starts, stack.matrix.shape[0]).astype(np.int64)
        self.cone: Cone = (
            np.ascontiguousarray(stack.matrix, dtype=float),
            np.ascontiguousarray(stack.offset, dtype=float),
            ends,
            np.ascontiguousarray(stack.is_norm, dtype=np.bool_),
        )
        self.load_rows = np.ascontiguousarray(prepared._load_rows)
        self.weights = np.ascontiguousarray(terms.size_weights, dtype=float)
        self.answer = (
            np.ascontiguousarray(terms.x_from_y),
            np.ascontiguousarray(prepared._torsor_rows),
            np.ascontiguousarray(prepared._twist_rows),
            np.ascontiguousarray(terms.contact_rows),
            np.ascontiguousarray(terms.contact_offsets, dtype=float),
            np.ascontiguousarray(terms.bounds, dtype=float),
            np.ascontiguousarray(terms.contact_of_row, dtype=np.int64),
            np.ascontiguousarray(terms.norm_force),
            np.ascontiguousarray(terms.slab_force),
            np.ascontiguousarray(terms.reactions),
            np.ascontiguousarray(prepared.geometry.scale),
            np.ascontiguousarray(terms.statics_weights, dtype=float),
        )
        self.clearance = float(terms.bounds.max(initial=0.0))
        self.accept = acceptance(prepared.geometry.conditioning)
        self.centre_rounds = ROUNDS + CENTRE_ROUNDS_PER_CONTACT * stack.count
        # the columns of solve_cases' rows after its scalars (kernel.solve_cases)
        m, joints, bodies = stack.count, len(terms.joint_names), prepared.bodies
        sizes = (
            ("y", self.size, None),
            ("multipliers", m, None),
            ("signs", m, None),
            ("x", prepared.size_x, None),
            ("torsors", 6 * joints, (joints, 6)),
            ("twists", 6 * bodies, (bodies, 6)),
            ("gaps", m, None),
            ("forces", stack.matrix.shape[0], None),
        )
        self.layout: list[tuple[str, int, int, tuple[int, int] | None]] = []
        at = self.kernel.SCALARS
        for name, size, shape in sizes:
            self.layout.append((name, at, at + size, shape))
            at += size
        self._slices = [(name, slice(start, end), shape) for name, start, end, shape in self.layout]
        # the kernel's pool of recent answers (kernel.solve_cases), updated in place by it
        self.pool: Pool = (
            np.zeros((POOL, self.size)),
            np.zeros((POOL, self.size)),
            np.zeros((POOL, m)),
            np.ones((POOL, m)),
            np.zeros(2, dtype=np.int64),
        )
        # solve_cases' arguments after the guess, for a pooled warm re-solve, bound once
        self._warm_tail = (self.accept, WARM_ROUNDS, self.centre_rounds, ITERATIONS, TOLERANCES,
                           *self.answer, False, True, *self.pool, True)  # fmt: skip
        self._residuals = FieldTemplate(
            Residuals,
            {
                "dual_infeasibility": 0.0,
                "clearance_m": self.clearance,
                "closure_conditioning": prepared.geometry.conditioning,
            },
        )

    def solve(self, cases: Array, load_matrix: Array, load_constant: Array, y: npt.ArrayLike,
              multipliers: npt.ArrayLike, signs: npt.ArrayLike, chain: bool = False,
              allow_flat: bool = True, warm_rounds: int = ROUNDS, centre: bool = True,
              pooled: bool = False, pool: Pool | None = None) -> tuple[Array, Array]:  # fmt: skip
        """kernel.solve_cases on the load cases ``cases`` (N, 3 k) from the guess (y,
        multipliers, slab sides) in ``warm_rounds`` rounds (0: no guess), else from the centre
        (``centre`` False: not): (rows (N, width), flat directions of the last case).
        ``pooled``: each case from the nearest of the recent answers (:attr:`pool`, or
        ``pool``: a :meth:`pool_copy`) instead, the guess while there are none."""
        return self.kernel.solve_cases(
            cases, load_matrix, load_constant, self.load_rows, self.prepared.size_x, self.weights,
            *self.cone, _vector(y), _vector(multipliers), _vector(signs), self.accept,
            warm_rounds, self.centre_rounds if centre else 0, ITERATIONS, TOLERANCES,
            *self.answer, chain, allow_flat, *(self.pool if pool is None else pool), pooled,
        )  # fmt: skip

    def pool_copy(self) -> Pool:
        """A copy of the pool of recent answers, for a chunk of cases solved on another thread
        (the kernel updates a pool in place)."""
        f, y, multipliers, signs, state = self.pool
        return f.copy(), y.copy(), multipliers.copy(), signs.copy(), state.copy()

    def solve_warm(
        self, cases: Array, bound: BoundLoads, warm: ConeSolution
    ) -> tuple[Array, Array]:
        """:meth:`solve` of ``cases`` with the loads ``bound`` (:meth:`load_binding`), each from
        the nearest recent answer, ``warm`` while there are none, in WARM_ROUNDS rounds, then
        from the centre: the re-solve's one compiled call, its other arguments bound once."""
        return self.kernel.solve_cases(
            cases, *bound.arguments, _vector(warm.y), _vector(warm.multipliers),
            _vector(warm.signs), *self._warm_tail,
        )  # fmt: skip

    def forget(self) -> None:
        """Empty the pool of recent answers (a benchmark's runs start equal)."""
        self.pool[4][:] = 0

    def solve_cold(
        self, cases: Array, load_matrix: Array, load_constant: Array
    ) -> tuple[Array, Array]:
        """:meth:`solve` from the centre alone (no guess)."""
        count = self.cone[3].size
        return self.solve(cases, load_matrix, load_constant, np.zeros(self.size), np.zeros(count),
                          np.ones(count), warm_rounds=0)  # fmt: skip

    def parts(self, row: np.ndarray) -> dict[str, np.ndarray]:
        """The arrays of one row of :meth:`solve` (views): y, multipliers, signs, x, torsors
        (joints, 6), twists (bodies, 6), gaps, forces."""
        return {
            name: row[part] if shape is None else row[part].reshape(shape)
            for name, part, shape in self._slices
        }

    def equilibrium(self, row: Array, flat: Array, loads: Sequence[Load], outcome: Outcome,
                    times: tuple[float, float], output_points: tuple[OutputPoint, ...] = (),
                    answer: dict[str, Array] | None = None,
                    residuals: Residuals | None = None) -> Equilibrium:  # fmt: skip
        """The :class:`~.result.Equilibrium` of one row of :meth:`solve` (``answer``,
        ``residuals``: its :meth:`parts` and :meth:`residuals` when already read), its flat
        directions ``flat`` (r, k) described when read; ``outcome`` and ``times`` as
        :func:`.linear_answer.linear_equilibrium`'s."""
        prepared = self.prepared
        answer = self.parts(row) if answer is None else answer
        free_motions = prepared.geometry.free_descriptions
        if flat.shape[1]:  # written when read, after the motions nothing blocks
            notes, free = prepared.flat_notes(flat), free_motions
            free_motions = LazySequence(lambda: (*free, *notes))
        return linear_equilibrium(
            prepared,
            answer["torsors"],
            answer["twists"],
            answer["gaps"],
            answer["forces"],
            answer["multipliers"],
            self.residuals(row) if residuals is None else residuals,
            float(row[self.kernel.ENERGY]),
            outcome,
            times,
            free_motions,
            loads,
            output_points,
            answer["x"],
        )

    def residuals(self, row: np.ndarray) -> Residuals:
        """The measured residuals of one row of :meth:`solve` (from a template of the constant
        fields, :class:`.frozen.FieldTemplate`: a re-solve's few microseconds)."""
        instance, state = self._residuals.new()
        residuals: Residuals = instance  # (FieldTemplate.new: an instance of its class)
        state.update(zip(_RESIDUAL_COLUMNS, row[3 : self.kernel.ENERGY].tolist()))
        return residuals

    def load_map(self, loads: Sequence[object]) -> tuple[Array, Array, Array] | None:
        r"""(p, A, w0): the loads' force and torque vectors stacked (3 k,) [N, N m] and the map
        :math:`W = A p + w_0` to the body wrenches at the world origin (bodies * 6,) (the fixed
        loads, gravity, in :math:`w_0`); None for a load of another kind."""
        bound = self.load_binding(loads)
        return None if bound is None else (bound[0], bound[1].matrix, bound[1].constant)

    def load_binding(self, loads: Sequence[object]) -> tuple[Array, BoundLoads] | None:
        """(p, the :class:`BoundLoads` of the loads' kinds, links, points and gravity), from
        the prepared geometry's :class:`~.load_map.LoadMap` (the gravities' columns times their
        accelerations are w0), kept on the map per gravity vector; None for a load of another
        kind."""
        mapped = self.prepared.load_map(loads)
        if mapped is None:
            return None
        built, _, vectors = mapped
        accelerations = vectors[built.fixed]
        gravity = accelerations.tobytes()
        bound: BoundLoads | None = built.bound.get(gravity)
        if bound is None:
            matrix = np.ascontiguousarray(built.world[:, built.varying])
            constant = np.ascontiguousarray(built.world[:, built.fixed] @ accelerations)
            bound = BoundLoads(matrix, constant, (matrix, constant, *self._load_arguments()))
            built.bound[gravity] = bound
        return np.ascontiguousarray(vectors[built.varying]), bound

    def _load_arguments(self) -> tuple[Array, int, Array, Array, Array, Index, Mask]:
        """solve_cases' arguments between the load map and the guess."""
        return (self.load_rows, self.prepared.size_x, self.weights, *self.cone)

    def load_cases(
        self, cases: Sequence[Sequence[object] | None], appended: tuple[Load, ...] = ()
    ) -> tuple[Array, Array, Array] | None:
        """:meth:`load_map` of many load cases at once, each case's loads followed by the loads
        ``appended`` (gravity): (P (N, 3 k), A, w0) when every case has the first case's loads
        (kinds, links, points, gravity) with other force and torque vectors; None otherwise
        (another set of loaded points, or a case that is not a sequence of loads)."""
        vectors = uniform_vectors(cases)  # (LoadVectors given as they are: no object read)
        if vectors is None or not len(vectors) or any(type(g) is not Gravity for g in appended):
            return None
        if appended and any(type(load) is Gravity for load in vectors.template):
            return None  # the cases' own gravity and an added one: each resolves its loads
        mapped = self.load_map((*vectors.template, *appended))
        if mapped is None:
            return None
        return np.ascontiguousarray(vectors.vectors, dtype=float), mapped[1], mapped[2]


def fast_terms(prepared: PreparedGeometry) -> FastTerms | None:
    """The :class:`FastTerms` of ``prepared`` (built on first use), None when the kernel is not
    installed (:func:`compiled_kernel`), the mechanism has no verified solution yet (a first solve
    goes the NumPy way) or the problem is larger than a dense Newton step pays for."""
    if compiled_kernel(engage=1) is None:  # loaded, or loads now
        return None
    built: FastTerms | None = prepared.__dict__.get("_fast_terms")
    if built is not None:
        return built
    if not prepared.mechanism.cache.warm or prepared.geometry.stack.size > WARM_MAX_SIZE:
        return None
    built = FastTerms(prepared)
    prepared.__dict__["_fast_terms"] = built
    return built


def solve_compiled(
    fast: FastTerms,
    loads: Sequence[Load],
    warm: ConeSolution | None,
    backend_of: Callable[[ReducedProblem], tuple[Backend, bool]],
    started: float,
    output_points: tuple[OutputPoint, ...] = (),
    from_centre: bool = True,
) -> Equilibrium | None:
    """The verified answer by the kernel, or None (the NumPy path then solves this load).

    Args:
        warm: the previous solution of this structure (its contact set is tried first), or None.
        backend_of: ``problem -> (built backend, built now)``: the backend's answer is polished
            when the kernel's own starts do not verify.
        from_centre: the kernel's active-set method from the centred position may answer (False:
            a backend the caller named finds the cold answer).
    """
    kernel = fast.kernel
    mapped = fast.load_binding(loads)
    if mapped is None:
        return None
    params, bound = mapped
    prepared = fast.prepared
    cases = params.reshape(1, -1)
    iterations, build_time = 0, 0.0
    code, status = kernel.UNDECIDED, ""
    if warm is not None and warm.y.shape == (fast.size,) and from_centre:
        solved = fast.solve_warm(cases, bound, warm)
        code = solved[0][0, 0]
    elif warm is not None and warm.y.shape == (fast.size,):
        solved = fast.solve(cases, bound.matrix, bound.constant, warm.y, warm.multipliers,
                            warm.signs, warm_rounds=WARM_ROUNDS, centre=False,
                            pooled=True)  # fmt: skip
        code = solved[0][0, 0]
    elif from_centre:
        solved = fast.solve_cold(cases, bound.matrix, bound.constant)
        code = solved[0][0, 0]
    if code in (kernel.UNBOUNDED, kernel.NO_WORK):
        return None  # the NumPy path raises or answers "indeterminate"
    method = Method.COMPILED
    if code == kernel.SOLVED:
        status = STARTS[solved[0][0, kernel.START]]
    else:
        code, objective, sigma, scaled, load_size, share = kernel.load_objective(
            params, bound.matrix, bound.constant, fast.load_rows, prepared.size_x, fast.size,
            fast.weights, TOLERANCES,
        )  # fmt: skip
        if code != kernel.SOLVED:
            return None
        geometry = prepared.geometry
        problem = loaded_problem(
            geometry, scaled / geometry.scale, objective, sigma, load_size, share
        )
        built, built_now = backend_of(problem)
        y, lam, backend_status, iterations = built.run(problem)
        status = f"{backend_status} (compiled polish)"
        method = backend_method(built.name)
        build_time = (built.build_time if built_now else 0.0) + getattr(built, "setup_time", 0.0)
        solved = fast.solve(cases, bound.matrix, bound.constant, y, lam, geometry.stack.sides(y))
        if solved[0][0, 0] != kernel.SOLVED:
            return None
    rows, flat = solved
    return _verified_answer(fast, rows[0], flat, loads, method, status, iterations, build_time,
                            started, output_points)  # fmt: skip


def resolve_compiled(fast: FastTerms, bound: BoundLoads, vector: Array, warm: ConeSolution,
                     loads_of: Callable[[], Iterable[Load]], started: float,
                     output_points: tuple[OutputPoint, ...]) -> Equilibrium | None:  # fmt: skip
    """A planner's re-solve (:mod:`.resolver`): the loads ``bound`` with the force and torque
    vectors ``vector`` (3 k,) [N, N m], the kernel's pooled warm start then its centred start,
    or None (the caller then solves the loads ``loads_of()`` the general way). ``loads_of``
    builds the load objects of the answer's ``loads``, when read."""
    rows, flat = fast.solve_warm(vector.reshape(1, -1), bound, warm)
    row = rows[0]
    if row[0] != fast.kernel.SOLVED:
        return None
    status = STARTS[row[fast.kernel.START]]
    return _verified_answer(fast, row, flat, LazySequence(loads_of), Method.COMPILED, status, 0,
                            0.0, started, output_points)  # fmt: skip


def _verified_answer(fast: FastTerms, row: Array, flat: Array, loads: Sequence[Load], method: Method,
                     status: str, iterations: int, build_time: float, started: float,
                     output_points: tuple[OutputPoint, ...]) -> Equilibrium | None:  # fmt: skip
    """The Equilibrium of a kernel's SOLVED row when its residuals pass (the answer is kept as
    the next warm start), else None."""
    residuals = fast.residuals(row)
    if not residuals.ok():
        return None
    answer = fast.parts(row)
    prepared = fast.prepared
    prepared.mechanism.cache.warm[prepared.signature] = ConeSolution(
        answer["y"],
        answer["multipliers"],
        answer["signs"],
        status,
        iterations,
        True,
        method=method,
    )
    return fast.equilibrium(
        row,
        flat,
        loads,
        ("optimal", method, status, iterations, True),
        (build_time, time.perf_counter() - started),
        output_points,
        answer,
        residuals,
    )


# solver_status by the start that verified (kernel.FROM_GUESS, FROM_NEIGHBOUR, FROM_CENTRE)
STARTS = {
    0.0: "warm Newton (compiled)",
    1.0: "warm Newton (compiled)",
    2.0: "active set from the centre (compiled)",
}


def _vector(values: npt.ArrayLike) -> Array:
    """A contiguous float64 vector (the kernel's one layout: another would compile again)."""
    return np.ascontiguousarray(values, dtype=np.float64)


def kernel_cache_dir() -> str | None:
    """The folder of numba's on-disk cache the loaded kernel was read from or written to (under
    ``NUMBA_CACHE_DIR`` when set, else the ``__pycache__`` beside :mod:`.kernel`, else numba's
    per-user cache when that is not writable); None when the kernel is not loaded."""
    module = _loaded.get("kernel")
    if module is None:
        return None
    return str(module.solve_cases.stats.cache_path)


def kernel_compiled_now() -> bool:
    """Whether this process compiled the kernel (numba's cache missed it) rather than loading it
    from numba's cache; False when it is not loaded."""
    module = _loaded.get("kernel")
    if module is None:
        return False
    return any(
        sum(function.stats.cache_misses.values()) > 0
        for function in (module.solve_cases, module.load_objective)
    )


__all__ = [
    "BoundLoads",
    "FastTerms",
    "compiled_kernel",
    "fast_terms",
    "kernel_cache_dir",
    "kernel_compiled_now",
    "kernel_load_time",
    "kernel_installed",
    "load_kernel",
    "resolve_compiled",
    "solve_compiled",
]
