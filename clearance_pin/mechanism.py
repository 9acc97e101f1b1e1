"""A mechanism with joint clearances: the Pinocchio tree, its loop joints, its loads.

Build once, solve many: :meth:`Mechanism.solve` re-uses the built optimiser for every load,
clearance or nominal configuration of the same structure.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterable, Iterator
from concurrent.futures import Executor
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any, TypeVar, Unpack

import numpy as np
import pinocchio as pin
from numpy.typing import ArrayLike

from .arguments import (
    check_case,
    check_clearance_sizes,
    check_load_magnitudes,
    check_solve_many,
)
from .deflection_check import batch_deflections, warn_answer, warn_large_deflections
from .equilibrium.cache import SolveCache
from .equilibrium.formulation import solve_case
from .equilibrium.negligible_play import rigid_negligible_plays
from .equilibrium.options import SolveKeywords, SolveOptions
from .equilibrium.resolver import solve_by_resolver
from .equilibrium.result import Equilibrium
from .errors import (
    ArgumentError,
    ClearancePinError,
    LoadError,
    ModelError,
    NotFoundError,
    StiffnessLeftOutWarning,
)
from .kinematics.loop_frames import eccentricity_problems, loop_joint_frames
from .kinematics.placements import placements_without_data
from .model import plausibility
from .model.clearance import U
from .model.couplings import Coupling, coupled
from .model.dimensions import Dimension
from .model.footprint import DATA_KEPT_UP_TO, check_fits, data_bytes
from .model.frames import frame_id as find_frame
from .model.joints import LoopJoint, TreeJoint
from .model.loads import Gravity, Load, PointForce, Torque, added_gravity
from .model.stiffness import stiff_joints

if TYPE_CHECKING:
    from .equilibrium.batch import EquilibriumBatch
    from .equilibrium.resolver import Resolver

Joint = TypeVar("Joint", TreeJoint, LoopJoint)
LOCK_TOLERANCE = 1e-9  # [rad or m] a configuration's departure from a lock's value, refused beyond


@dataclass(frozen=True)
class Configuration:
    """The mechanism placed at one nominal configuration (Pinocchio numbers, read-only).

    Attributes:
        q: joint configuration (nq,).
        oMi: world placement of every joint frame (copies).
        oMf: world placement of every frame (copies).
        aMc: per loop joint, placement (pin.SE3) of its parent-side clearance frame (the
            housing's zone) in ``frame_a``.
        bMc: per loop joint, placement (pin.SE3) of its child-side clearance frame (the journal,
            block or ball) in ``frame_b``. Both follow the rule of
            :mod:`clearance_pin.kinematics.loop_frames`: the zone sits where the child part is;
            they coincide unless the joint has a nominal eccentricity.
    """

    q: np.ndarray
    oMi: tuple[pin.SE3, ...]
    oMf: tuple[pin.SE3, ...]
    aMc: dict[str, pin.SE3]
    bMc: dict[str, pin.SE3]
    loop_frames: dict[str, tuple[int, int]] = field(default_factory=dict)

    def eccentricity(self, loop: LoopJoint | str) -> pin.SE3:
        """The loop joint's (or the loop joint called ``loop``'s) child clearance frame in its
        parent one at this configuration: identity for an aligned joint, the nominal
        eccentricity (a misaligned housing) else."""
        name = loop if isinstance(loop, str) else loop.name
        if name not in self.aMc:
            raise NotFoundError("loop joint", name, self.aMc, "Configuration.eccentricity")
        frame_a, frame_b = (
            self.loop_frames[name] if isinstance(loop, str) else (loop.frame_a, loop.frame_b)
        )
        oMa, oMb = self.oMf[frame_a], self.oMf[frame_b]
        return (oMa * self.aMc[name]).actInv(oMb * self.bMc[name])


class Mechanism:
    """A mechanism: ``pin.Model`` + joint clearances + loop joints + loads (SI units).

    Use :func:`clearance_pin.load` to read one from a model file. A mechanism is complete when
    it is constructed: suspect values (a clearance in mm, a nominal value outside its limits, a
    tolerance as wide as its size) are warned (``check_values``), and the loops are closed, so an
    impossible assembly raises ModelError here.

    Attributes:
        model: the Pinocchio model of the kinematic tree.
        tree_joints: every joint of the tree with its clearance (ideal when none was given).
        loop_joints: the cut joints closing loops.
        q_nominal: nominal configuration (nq,), loops closed.
        loads: default loads of :meth:`solve`.
        gravity: gravity applied by default (None: off).
        source: where the description came from (file path or ``"<api>"``).
        dimensions: toleranced dimensions (:class:`~clearance_pin.model.dimensions.Dimension`).
        cache: what solves build and keep (:class:`~clearance_pin.equilibrium.cache.SolveCache`).
        nominal_given: (argument) joint id -> nominal value [rad or m] as the user gave it, for the
            limit warnings (default: the values in ``q_nominal``).
    """

    _collision_model: Any  # a pin.GeometryModel, its builder, or None

    def __init__(
        self,
        model: pin.Model,
        tree_joints: tuple[TreeJoint, ...],
        loop_joints: tuple[LoopJoint, ...] = (),
        q_nominal: np.ndarray | None = None,
        loads: tuple[Load, ...] = (),
        gravity: Gravity | None = None,
        source: str = "<api>",
        name: str = "",
        collision_model: Any = None,
        dimensions: tuple[Dimension, ...] = (),
        nominal_given: dict[int, float] | None = None,
        check_values: bool = True,
        couplings: tuple[Coupling, ...] = (),
    ) -> None:
        # a long tree is placed without Pinocchio's data (cubic in nv: 1.7 GB at 300 joints)
        self._without_data = not loop_joints and data_bytes(model.nv) > DATA_KEPT_UP_TO
        check_fits(model, source, with_data=not self._without_data)  # before it is allocated
        self.model = model
        self._set_joints(tuple(tree_joints), tuple(loop_joints), source)
        self.q_nominal = pin.neutral(model) if q_nominal is None else np.array(q_nominal, float)
        self.loads = tuple(loads)
        self.gravity = gravity
        self.source = source
        self.name = name or model.name
        self.collision_model = collision_model
        self.dimensions = tuple(dimensions)
        self.couplings = tuple(couplings)  # followers set by their leaders (model.couplings)
        self._nominal_closed: np.ndarray | None = None
        self.link_frames = {
            f.name: i for i, f in enumerate(model.frames) if f.type == pin.FrameType.BODY
        }
        self.cache = SolveCache(model)
        if check_values:  # unit mistakes warned before the loops are closed (which they may break)
            check_clearance_sizes(self)  # refused, not warned: the solver cannot carry them
        # after that check: a play many times the mechanism would make every other play negligible
        joints = rigid_negligible_plays((*self.tree_joints, *self.loop_joints), source=source)
        self._set_joints(joints[: len(tree_joints)], joints[len(tree_joints) :], source)
        # at the given nominal configuration, before the loops are closed (as it always was);
        # now, while no caller holds this thread's data, which it places
        self.length_scale()
        if check_values:
            given = nominal_given
            if given is None:
                given = plausibility.configuration_values(model, self.q_nominal)
            plausibility.warn_large_clearances(self)
            plausibility.warn_nominal_values(self, given)
            plausibility.warn_wide_tolerances(self, self.dimensions)
        if self.loop_joints:  # closed now: a mechanism is complete, errors come at construction
            self.q_nominal = self.configure().q
            self._nominal_closed = self.q_nominal.copy()

    def _set_joints(
        self, tree_joints: tuple[TreeJoint, ...], loop_joints: tuple[LoopJoint, ...], source: str
    ) -> None:
        """Set the joints (``tree_joints``, ``loop_joints``, ``joints`` by name); names unique."""
        self.tree_joints, self.loop_joints = tree_joints, loop_joints
        self.joints: dict[str, TreeJoint | LoopJoint] = {j.name: j for j in tree_joints}
        self.joints.update({j.name: j for j in loop_joints})
        if len(self.joints) != len(tree_joints) + len(loop_joints):
            raise ModelError(source, "<joints>", "joint names must be unique across tree and loops")
        self.__dict__.pop("_length_scale", None)  # it reads the joints' lengths

    def with_model(self, model: pin.Model) -> Mechanism:
        """The same mechanism on another ``pin.Model`` of the same tree (a manufactured one:
        :func:`clearance_pin.tolerance.dimensions.with_deviations`), its loops closed from this
        mechanism's nominal configuration; its values are not checked again."""
        return self.rebuilt(model, self.tree_joints, self.loop_joints)

    def without_stiffness(self) -> Mechanism:
        """The same mechanism with rigid joints: every joint's stiffness removed, its play,
        backlash and drive kept (``self`` when no joint has stiffness); its values are not
        checked again."""
        if not stiff_joints(self.joints):
            return self

        def rigid(joints: tuple[Joint, ...]) -> tuple[Joint, ...]:
            return tuple(replace(j, clearance=replace(j.clearance, stiffness=None)) for j in joints)

        return self.rebuilt(self.model, rigid(self.tree_joints), rigid(self.loop_joints))

    def rebuilt(
        self,
        model: pin.Model,
        tree_joints: tuple[TreeJoint, ...],
        loop_joints: tuple[LoopJoint, ...],
    ) -> Mechanism:
        """This mechanism with another model or joints: its loads, gravity, dimensions and
        couplings kept, its values not checked again."""
        return Mechanism(
            model,
            tree_joints,
            loop_joints,
            self.q_nominal,
            self.loads,
            self.gravity,
            source=self.source,
            name=self.name,
            dimensions=self.dimensions,
            check_values=False,
            couplings=self.couplings,
        )

    @property
    def data(self) -> pin.Data:
        """This thread's ``pin.Data`` of :attr:`model` (threads of ``solve_many`` each have one)."""
        return self.cache.data

    @property
    def collision_model(self) -> Any:
        """``pin.GeometryModel`` of the URDF's collision geometry, or None without any.

        Built on first use when the mechanism was given a builder (a callable of the model, as
        :class:`~clearance_pin.model.model_file.CollisionGeometry`): meshes are read only when a
        check needs them, and a missing mesh raises a ModelError naming it then.
        """
        if callable(self._collision_model):
            self._collision_model = self._collision_model(self.model)
        return self._collision_model

    @collision_model.setter
    def collision_model(self, geometry: Any) -> None:
        self._collision_model = geometry

    # -- configuration ---------------------------------------------------------------------
    def configure(self, q: np.ndarray | None = None) -> Configuration:
        """Place the mechanism at ``q`` (default: nominal), closing every loop.

        The driven joints keep their values in ``q``; the passive ones are adjusted so that the
        frames of every loop joint coincide (:func:`clearance_pin.kinematics.closure.close_loops`),
        on the assembly branch of the nominal configuration: the driven joints are moved there
        from the nearest configuration already closed (the nominal one or the last one), in
        steps of at most 0.05 rad (or 0.05 of the length scale), closing the loops at each step.
        """
        from .kinematics.closure import close_loops, closure_residual, follow_branch

        given = q is not None
        q = self.q_nominal if q is None else np.asarray(q, dtype=float)
        if q.shape != (self.model.nq,) or not np.all(np.isfinite(q)):
            raise ClearancePinError(
                f"configuration must be {self.model.nq} finite numbers, got shape {q.shape}"
            )
        q = coupled(self.model, self.couplings, q)  # followers from their leaders
        if given:
            self.check_locks(q)
        if self._without_data:  # a long tree: nothing to close
            oMi, oMf = placements_without_data(self.model, q)
            return Configuration(q.copy(), oMi, oMf, {}, {})
        data = self.cache.data  # this thread's
        with self.cache.lock:  # the closed configurations are shared by threads
            pin.framesForwardKinematics(self.model, data, q)
            if self.loop_joints:
                # the closed configuration of every q already closed: an eccentric mechanism
                # (a misaligned housing) keeps a residual, which must not re-close on every call.
                # Keyed by the model and joints, so a copy with other dimensions starts afresh.
                owner = (self.model, self.tree_joints, self.loop_joints)
                cache: tuple[tuple[Any, ...], dict[bytes, np.ndarray]] | None = getattr(
                    self, "_closed_for", None
                )
                if cache is None or any(a is not b for a, b in zip(cache[0], owner)):
                    cache = (owner, {})
                    self._closed_for = cache
                known = cache[1].get(q.tobytes())
                residual, _ = closure_residual(self, data) if known is None else (None, None)
                if known is not None:
                    q = known.copy()
                    self._last_closed = known
                    pin.framesForwardKinematics(self.model, data, q)
                elif residual is not None and (
                    np.max(np.abs(residual), initial=0.0) > 1e-12 * self.length_scale()
                ):
                    requested = q.tobytes()
                    start = self._closed_start(q)
                    q = follow_branch(self, start, q) if start is not None else close_loops(self, q)
                    self._last_closed = q.copy()
                    while len(cache[1]) >= 4096:  # the oldest entries go first
                        cache[1].pop(next(iter(cache[1])))
                    cache[1][requested] = cache[1][q.tobytes()] = self._last_closed
                    pin.framesForwardKinematics(self.model, data, q)
            oMi = tuple(m.copy() for m in data.oMi)
            oMf = tuple(m.copy() for m in data.oMf)
        frames = loop_joint_frames(self, oMf)
        problems = eccentricity_problems(self, oMf) if self.loop_joints else []
        if problems:  # the closure's own test, repeated for configurations it did not touch
            raise ModelError(self.source, "<loop_joint>", problems[0])
        aMc = {name: pair[0] for name, pair in frames.items()}
        bMc = {name: pair[1] for name, pair in frames.items()}
        loops = {loop.name: (loop.frame_a, loop.frame_b) for loop in self.loop_joints}
        return Configuration(q.copy(), oMi, oMf, aMc, bMc, loops)

    def check_locks(self, q: ArrayLike, argument: str = "q") -> None:
        """Refuse a configuration ``q`` (nq,) that gives a locked joint (a ``<lock>``: held where
        it is, at its nominal value) another value than its lock's, to ``LOCK_TOLERANCE``
        [rad or m] (a continuous joint's angle compared modulo a turn).

        Raises:
            ArgumentError: naming ``argument``, the joint, its lock's value and the value given.
        """
        locked = [joint for joint in self.tree_joints if joint.locked]
        if not locked:
            return
        q = coupled(self.model, self.couplings, np.asarray(q, dtype=float))
        for joint in locked:
            held, value = (_joint_value(self.model, joint.joint_id, c) for c in (self.q_nominal, q))
            difference = value - held
            if self.model.joints[joint.joint_id].nq == 2:  # a continuous joint: cos, sin
                difference = (difference + np.pi) % (2.0 * np.pi) - np.pi
            if not abs(difference) <= LOCK_TOLERANCE:
                unit = "m" if joint.motion_component == U else "rad"
                raise ArgumentError(
                    argument,
                    f"{joint.name!r} at its lock's value {held:.12g} {unit} (a locked joint is "
                    "held where it is)",
                    f"{joint.name}={value:.12g} {unit}",
                    "give it its lock's value, or remove its <lock> to move it",
                )

    def _closed_start(self, q: np.ndarray) -> np.ndarray | None:
        """The closed configuration nearest to ``q`` in the driven joints (None before loading)."""
        candidates = [
            c for c in (getattr(self, "_last_closed", None), self._nominal_closed) if c is not None
        ]
        if not candidates:
            return None
        from .kinematics.closure import driven_coordinates

        driven, scales = driven_coordinates(self)
        return min(
            candidates,
            key=lambda c: float(np.max(np.abs(c[driven] - q[driven]) / scales, initial=0.0)),
        )

    def length_scale(self) -> float:
        """Characteristic length [m]: the larger of the largest distance of a joint origin from
        the root at the nominal configuration (tree joints and both frames of every loop joint)
        and the largest journal or block length of a joint with play (1 m when both are 0; an
        ideal joint's length is only a placeholder)."""
        if not hasattr(self, "_length_scale"):
            if self._without_data:
                origins = list(placements_without_data(self.model, self.q_nominal)[0])
            else:
                data = self.cache.data  # this thread's (placed again wherever it is read)
                pin.forwardKinematics(self.model, data, self.q_nominal)
                pin.updateFramePlacements(self.model, data)
                origins = [*data.oMi]
            for loop in self.loop_joints:  # a shaft's further bearings are loop joints
                origins += [data.oMf[loop.frame_a], data.oMf[loop.frame_b]]
            extent = max((float(np.linalg.norm(m.translation)) for m in origins), default=0.0)
            lengths = [
                j.clearance.length for j in self.joints.values() if j.clearance.max_play > 0.0
            ]
            self._length_scale = max([extent, *lengths]) or 1.0
        return self._length_scale

    # -- loads ----------------------------------------------------------------------------
    def resolve_loads(
        self, loads: Iterable[object] | None = None, gravity: bool | Gravity | None = None
    ) -> tuple[Load, ...]:
        """The loads of a solve: ``loads`` (default: the model's) plus the gravity the option
        ``gravity`` adds (:func:`~clearance_pin.model.loads.added_gravity`: one gravity per
        solve)."""
        checked: list[Load] = []
        own = 0
        for load in self.loads if loads is None else loads:
            if isinstance(load, Gravity):
                own += 1
            elif not isinstance(load, (PointForce, Torque)):
                raise LoadError(repr(load), "expected PointForce, Torque or Gravity")
            elif load.link not in self.link_frames:
                raise LoadError(f"on {load.link!r}", self._not_a_link(load.link))
            checked.append(load)
        added = added_gravity(own, gravity, self.gravity)
        return (*checked, added) if added is not None else tuple(checked)

    def _not_a_link(self, name: str) -> str:
        """Why ``name`` cannot carry a load: unknown, or a frame (an MJCF site, a URDF frame
        that is no link) named with the link and the point [m] to write instead."""
        if find_frame(self.model, name) is None:
            return f"unknown link; the links are: {', '.join(sorted(self.link_frames))}"
        link, point = self.link_point(name)
        return (
            f"a frame (an MJCF site or a URDF frame), not a link: a load is applied to a link "
            f"(an MJCF body) at a point in the link's frame; {name!r} is on link {link!r} "
            f"at [{point[0]:.6g} {point[1]:.6g} {point[2]:.6g}] m: write PointForce("
            f"{link!r}, force, point=[{point[0]:.6g}, {point[1]:.6g}, {point[2]:.6g}])"
        )

    def link_point(self, frame: str) -> tuple[str, np.ndarray]:
        """(the link a Pinocchio frame moves with, the frame's origin in that link's frame [m]):
        where a load at the frame is applied (``PointForce(link, force, point=point)``); the
        link the frame hangs from, else the first link moving with it."""
        model = self.model
        frame_id = find_frame(model, frame)
        if frame_id is None:
            raise NotFoundError("frame", frame, [f.name for f in model.frames], self.name)
        placed = model.frames[frame_id]
        links = set(self.link_frames.values())
        link_id = placed.parentFrame if placed.parentFrame in links else None
        if frame_id in links:
            link_id = frame_id
        if link_id is None:
            link_id = next(
                i for i in sorted(links) if model.frames[i].parentJoint == placed.parentJoint
            )
        link = model.frames[link_id]
        return link.name, (link.placement.inverse() * placed.placement).translation

    # -- solving --------------------------------------------------------------------------
    def solve(
        self,
        loads: Iterable[Load] | None = None,
        *,
        q: ArrayLike | None = None,
        **options: Unpack[SolveKeywords],
    ) -> Equilibrium:
        """Quasi-static equilibrium of the parts in their joint clearances.

        Args:
            loads: PointForce / Torque / Gravity loads; default: those of the model file.
            q: nominal configuration (default: the model's); driven joints are held there.
            options: the options of every solve, by keyword (the same in :meth:`solve_many`
                and :meth:`resolver`): ``exact`` (False, True or ``"auto"``), ``gravity``,
                ``tol``, ``backend``, ``accuracy``, ``warm_start``, ``outputs``; see
                :class:`~clearance_pin.equilibrium.options.SolveOptions` for each. The exact
                model is solved by Newton's method from the linear answer, IPOPT (through
                CasADi) only when that does not verify; with ``exact="auto"``, ``.note`` says
                which model answered and why, ``.difference_bound`` holds the estimate.

        Returns:
            :class:`~clearance_pin.equilibrium.result.Equilibrium`.
        """
        if q is None and not options and type(loads) in (list, tuple):
            # a planner's loop: the resolver of these loaded points, from their second solve
            answer = solve_by_resolver(self, loads)  # type: ignore[arg-type]  # a list or tuple
            if answer is not None:
                if answer.deflections:
                    warn_answer(self, answer)
                return answer
        chosen = SolveOptions.of(options)
        configuration = check_case(self, loads, q)
        if configuration is not None:
            self.check_locks(configuration)
        resolved = self.resolve_loads(loads, chosen.gravity)
        check_load_magnitudes(resolved)
        answer = solve_case(self, resolved, configuration, chosen)
        if answer.deflections:  # a spring of the wrong unit: judged after the solve
            warn_answer(self, answer)
        return answer

    def envelope(
        self, output: Any, q: ArrayLike | None = None, exact: bool = False, **options: Any
    ) -> Any:
        """The clearance envelope of ``output`` (a frame, ``"link@[x y z]"`` or ``(link, point)``):
        how far it can move inside the play whatever the load, certified (maxima with lower and
        upper bounds); see :func:`clearance_pin.envelope.envelope` (options: kinds, tol,
        max_directions, certificate)."""
        from .envelope import envelope

        _warn_stiffness_left_out(
            self,
            "the envelope is of the play (with springs the reach depends on the load: the "
            "accuracy map over a load set, accuracy(output, configurations=[q], payloads=[...]), "
            "is its envelope)",
        )
        return envelope(self, output, q=q, exact=exact, **options)

    def accuracy(
        self,
        output: str,
        configurations: ArrayLike,
        payloads: Any = (0.0,),
        gravity: bool | Gravity | None = None,
        payload_point: ArrayLike | None = None,
    ) -> Any:
        """The accuracy map of ``output`` (a Pinocchio frame, the tool) over poses
        ``configurations`` (Q, nq) and ``payloads`` (masses [kg] at the output's origin, or at
        ``payload_point`` (3,) [m] in its frame, or load cases): its displacement (Q, P, 3), its
        reach over the motions the load leaves free (Q, P) and each joint's and source's share;
        see :func:`clearance_pin.accuracy.accuracy_map`."""
        from .accuracy import accuracy_map

        return accuracy_map(self, output, configurations, payloads, gravity, payload_point)

    def identify(
        self,
        measurements: Any,
        point: Any,
        parameters: Any = ("backlash", "drive_stiffness"),
        **options: Any,
    ) -> Any:
        """Each driven joint's backlash and drive stiffness fitted to measured deflections of
        ``point`` (a frame, or ``(frame, [x, y, z])`` [m] in it): a measurement file or
        :class:`~clearance_pin.identification.Measurements`; see
        :func:`clearance_pin.identification.identify` (options: joints, gravity, held_out,
        rotation_weight, seed)."""
        from .identification import identify

        return identify(self, measurements, point, parameters, **options)

    def design_measurements(self, point: Any, count: int, noise: float, **options: Any) -> Any:
        """Where to measure: the ``count`` poses among candidates that determine the drives'
        backlash and stiffness best (D-optimal), with the standard errors expected for a
        measurement ``noise`` [m]; see :func:`clearance_pin.identification.design.design_measurements`."""
        from .identification.design import design_measurements

        return design_measurements(self, point, count, noise, **options)

    def resolver(
        self,
        loads: Iterable[Load] | None = None,
        *,
        q: ArrayLike | None = None,
        **options: Unpack[SolveKeywords],
    ) -> Resolver:
        """A :class:`~clearance_pin.equilibrium.resolver.Resolver`: ``loads`` (default: the
        model's) built once, re-solved with new force and torque vectors,
        ``resolver.solve(values)`` or many at once, ``resolver.solve_many(values)`` (options:
        those of :meth:`solve`)."""
        from .equilibrium.resolver import Resolver

        if q is not None:
            self.check_locks(np.asarray(q, dtype=float))
        return Resolver(self, loads, q, SolveOptions.of(options))

    def solve_many(
        self,
        loads: Iterable[Iterable[Load] | None] | None = None,
        configurations: Iterable[ArrayLike] | None = None,
        *,
        executor: Executor | None = None,
        chunks: int | None = None,
        errors: str = "raise",
        progress: bool | None = None,
        **options: Unpack[SolveKeywords],
    ) -> EquilibriumBatch:
        """Many equilibria, warm-started in sequence; see
        :func:`clearance_pin.equilibrium.batch.solve_many` (options: those of :meth:`solve`
        but ``q``; executor, chunks, errors, progress as there)."""
        from .equilibrium.batch import solve_many, with_refused

        chosen = SolveOptions.of(options)
        # every case checked here, before any is solved: an iterator is read into a list first
        # (the batches solve each case by the core, Mechanism.solve's checks behind them)
        if isinstance(loads, Iterator):
            loads = list(loads)
        if isinstance(configurations, Iterator):
            configurations = list(configurations)
        refused = check_solve_many(
            self, loads, configurations, errors, executor, chunks, chosen.gravity
        )
        if configurations is not None and any(j.locked for j in self.tree_joints):
            configurations = list(configurations)
            for index, pose in enumerate(configurations):
                if pose is not None:
                    self.check_locks(pose, f"configurations[{index}]")
        cases = list(loads) if refused and loads is not None else []
        poses = None if configurations is None or not refused else list(configurations)
        if refused and (poses is None or len(poses) == len(cases)):
            # errors="return": cases whose loads double precision does not carry are not solved
            batch = with_refused(
                self,
                len(cases),
                refused,
                lambda kept: solve_many(
                    self, [cases[i] for i in kept], None if poses is None else [poses[i] for i in kept],
                    chosen, executor=executor, chunks=chunks, errors=errors, progress=progress,
                ),
            )  # fmt: skip
        else:
            batch = solve_many(
                self, loads, configurations, chosen,
                executor=executor, chunks=chunks, errors=errors, progress=progress,
            )  # fmt: skip
        if stiff_joints(self.joints):  # a spring of the wrong unit: once per call
            warn_large_deflections(self, batch_deflections(self, batch), batch=True)
        return batch

    def joint(self, name: str) -> TreeJoint | LoopJoint:
        """The tree or loop joint called ``name``."""
        if name not in self.joints:
            raise ClearancePinError(
                f"unknown joint {name!r}; the joints are: {', '.join(self.joints)}"
            )
        return self.joints[name]

    def __repr__(self) -> str:
        return (
            f"Mechanism({self.name!r}: {len(self.tree_joints)} tree joints, "
            f"{len(self.loop_joints)} loop joints, {len(self.loads)} loads)"
        )


def _joint_value(model: pin.Model, joint_id: int, q: np.ndarray) -> float:
    """A 1-DOF joint's value in ``q`` [rad or m]: a continuous joint's angle from its cos, sin."""
    joint = model.joints[joint_id]
    if joint.nq == 2:
        return float(np.arctan2(q[joint.idx_q + 1], q[joint.idx_q]))
    return float(q[joint.idx_q])


def _warn_stiffness_left_out(mechanism: Mechanism, what: str) -> None:
    """StiffnessLeftOutWarning naming the joints with stiffness, for an analysis of the play."""
    stiff = stiff_joints(mechanism.joints)
    if stiff:
        warnings.warn(
            StiffnessLeftOutWarning(
                f"{mechanism.name}: the stiffness of {', '.join(stiff)} is left out: {what}"
            ),
            stacklevel=3,
        )
