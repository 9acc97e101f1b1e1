r"""Everything a small-displacement solve at one nominal configuration needs, computed once.

Build once, solve many: a planner re-solves the same configuration with new loads thousands of
times, so every load-independent product is formed here, and a solve costs a few array products.

- *Load to objective.* The loads act through body wrenches :math:`W_b = (F, p \times F + C)` at
  the world origin, one linear map of their vectors per set of loaded points (:mod:`.load_map`);
  the scaled gradient of the potential is :math:`Z g = -\sum_b Z J_b^T W_b` (:math:`J_b`: body
  twist map), and its reduced part :math:`Q^T Z g` and its part along the unblocked motions
  :math:`K^T Z g` follow from one stacked matrix on the stacked wrenches.
- *Answer.* Joint torsors, body twists and contact images are stacked maps of x; the contact
  forces and the statics residual are vectorised over contacts.
- *Indeterminacy.* The motions along which the optimum is not unique
  (:meth:`PreparedGeometry.flat_directions`) are found at each answer, by one SVD.
"""

from __future__ import annotations

import statistics
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, overload

import numpy as np
import numpy.typing as npt
import pinocchio as pin

from ..errors import LoadError
from ..model.couplings import driven, passive
from ..model.loads import Gravity, PointForce, Torque
from ..numerics import Array, Mask, column_space, null_space
from .cache import LOAD_MAPS_KEPT, LeastRecentlyUsed, SolveCache
from .kkt import UNLOADED
from .lazy import LazySequence
from .load_map import LoadMap, LoadSignature, build_load_map, signature_of
from .load_terms import BodyLoad, gather_body_loads
from .method import Method
from .reduction import (
    ROUND_OFF_WORK,
    UNBOUNDED_FRACTION,
    ReducedGeometry,
    ReducedProblem,
    Signature,
    describe_motion,
    reduce_geometry,
    with_scaled_load,
)
from .small_displacement import SmallDisplacementMaps, build_maps
from .tree_point import body_motions

if TYPE_CHECKING:  # the mechanism module imports this one
    from ..model.loads import Load
    from ..model.mechanism_parts import ConfigurationParts as Configuration
    from ..model.mechanism_parts import MechanismParts as Mechanism


class PreparedGeometry:
    """The reduced geometry of a mechanism at one configuration, ready for many loads.

    Attributes:
        configuration: the closed nominal configuration.
        maps: linear maps at that configuration.
        geometry: the load-independent reduction (:class:`~.reduction.ReducedGeometry`).
        signature: sizes and contact shapes (what a built optimiser depends on).
    """

    def __init__(
        self,
        mechanism: Mechanism,
        configuration: Configuration,
        maps: SmallDisplacementMaps,
        geometry: ReducedGeometry,
    ) -> None:
        self.mechanism = mechanism
        self.configuration = configuration
        self.maps = maps
        self.geometry = geometry
        self.length = mechanism.length_scale()
        self.terms = geometry_terms(mechanism, geometry)  # shared by configurations
        bodies = mechanism.model.njoints
        self.bodies = bodies
        # rows: scaled gradient Z g (n), reduced Q^T Z g (r), along the unblocked motions (f)
        scaled = -geometry.scale[:, None] * np.hstack([maps.body_twist[b].T for b in range(bodies)])
        self._load_rows = np.vstack(
            [scaled, geometry.basis.T @ scaled, geometry.free_scaled.T @ scaled]
        )
        # answer maps
        self._torsor_rows = np.vstack([maps.joint_torsor[name] for name in self.terms.joint_names])
        # per joint with stiffness, x -> its elastic deflection (6, n): its torsor less its play,
        # on its own elastic unknowns (a follower's torsor also reads its leader's motion)
        owner = np.array(maps.variable_joint)
        self.deflection_rows = {
            name: (maps.joint_torsor[name] - maps.play_torsor[name]) * own
            for name in self.terms.joint_names
            if (own := (owner == name) & (maps.stiffness > 0.0)).any()
        }
        self._twist_rows = np.vstack(maps.body_twist)
        self._origins = np.array([m.translation for m in configuration.oMi])
        self._rotations = np.array([m.rotation for m in configuration.oMi])
        # the engines a solve here tries, per (backend, answered before, kernel installed)
        self.plans: dict[tuple[str, bool, bool], tuple[Method, ...]] = {}
        self._load_maps: LeastRecentlyUsed[LoadSignature, LoadMap] = LeastRecentlyUsed(
            LOAD_MAPS_KEPT
        )

    @property
    def signature(self) -> Signature:
        """Sizes and contact shapes: what a built optimiser depends on."""
        return self.terms.signature

    @property
    def size_x(self) -> int:
        """Number of unknowns n."""
        return self.terms.size_x

    @property
    def x_from_y(self) -> np.ndarray:
        """Z Q, (n, r): x = Z Q y."""
        return self.terms.x_from_y

    @property
    def bounds(self) -> np.ndarray:
        """Clearance of every contact [m], (m,)."""
        return self.terms.bounds

    @property
    def joint_names(self) -> tuple[str, ...]:
        """Tree and loop joints, in the order of :meth:`torsor_array`."""
        return self.terms.joint_names

    # -- loads ---------------------------------------------------------------------------------
    def load_map(self, loads: Sequence[object]) -> tuple[LoadMap, LoadSignature, Array] | None:
        """(the :class:`~.load_map.LoadMap` of the signature of ``loads`` at this configuration,
        that signature, the loads' vectors p (3 k,)), the map formed on first use and kept for
        the :data:`~.cache.LOAD_MAPS_KEPT` most recent signatures; None when one of ``loads``
        is not a PointForce, Torque or Gravity."""
        signed = signature_of(loads)
        if signed is None:
            return None
        key, vectors = signed
        built: LoadMap | None = self._load_maps.get(key)
        if built is None:
            built = self._load_maps[key] = build_load_map(
                self.mechanism, loads, self._rotations, self._origins
            )
        return built, key, vectors

    def wrenches(self, loads: Sequence[Load]) -> Array:
        """Body wrenches at the world origin (bodies, 6) [N, N m] of resolved ``loads`` (ground
        row 0): W = A p (:mod:`.load_map`)."""
        mapped = self.load_map(loads)
        if mapped is None:
            other = next(
                load for load in loads if not isinstance(load, (PointForce, Torque, Gravity))
            )
            raise LoadError(repr(other), "expected PointForce, Torque or Gravity")
        built, _, vectors = mapped
        return (built.world @ vectors).reshape(self.bodies, 6)

    def problem(self, loads: Sequence[Load]) -> ReducedProblem:
        """The reduced problem of ``loads`` (raises UnboundedLoadError, see
        :func:`~.reduction.with_scaled_load`)."""
        wrench = self.wrenches(loads)
        stacked = self._load_rows @ wrench.ravel()
        first, second = self.terms.split
        halves = np.sqrt((wrench * wrench).reshape(-1, 2, 3).sum(axis=2))  # |F_b|, |M_b|
        size = float(np.dot(halves.sum(axis=0), self.terms.size_weights))
        return with_scaled_load(
            self.geometry,
            stacked[:first],
            stacked[first:second],
            stacked[second:],
            self.maps,
            self.mechanism.joints,
            self.length,
            size,
        )

    def objectives(self, wrenches: Array) -> tuple[Array, Array, Array, Array, Array, Mask]:
        """The objectives of many loads at once, from their stacked body wrenches (N, 6 bodies).

        Returns:
            (objectives f (N, r), objective scales sigma (N,), x-space gradients g (N, n),
            load sizes (N,) [J] (see :func:`~.reduction.with_scaled_load`), the shares of the
            loads along unblocked motions (N,), regular (N,): False where the load works on an
            unblocked motion or on none; those cases are left to a single solve, which raises or
            reports them).
        """
        stacked = wrenches @ self._load_rows.T
        first, second = self.terms.split
        scaled, reduced, along_free = (
            stacked[:, :first],
            stacked[:, first:second],
            stacked[:, second:],
        )
        per_body = wrenches.reshape(len(wrenches), self.bodies, 2, 3)
        sizes = np.linalg.norm(per_body, axis=3)
        load_sizes = self.terms.play * (
            sizes[:, :, 0].sum(axis=1) + sizes[:, :, 1].sum(axis=1) / max(self.length, 1e-300)
        )
        references = np.maximum(np.linalg.norm(scaled, axis=1), load_sizes)
        free_sizes = (
            np.linalg.norm(along_free, axis=1) if along_free.shape[1] else np.zeros(len(scaled))
        )
        sigmas = np.linalg.norm(reduced, axis=1)
        regular = (free_sizes <= UNBOUNDED_FRACTION * references) & (
            sigmas > ROUND_OFF_WORK * references
        )
        objectives = reduced / np.where(sigmas > 0.0, sigmas, 1.0)[:, None]
        shares = free_sizes / np.where(references > 0.0, references, 1.0)
        gradients = scaled / self.geometry.scale
        return objectives, sigmas, gradients, load_sizes, shares, regular

    # -- answer --------------------------------------------------------------------------------
    def torsor_array(self, x: np.ndarray) -> Array:
        """Torsor (6,) [m, rad] of every joint of ``joint_names`` for the unknowns x, (joints, 6)."""
        torsors: Array = (self._torsor_rows @ x).reshape(-1, 6)  # (NumPy's stubs: Any)
        return torsors

    def body_twists(self, x: np.ndarray) -> Array:
        """Spatial twist (v, omega) at the world origin of every body, (bodies, 6)."""
        twists: Array = (self._twist_rows @ x).reshape(self.bodies, 6)  # (NumPy's stubs: Any)
        return twists

    def body_motions(self, twists: np.ndarray, names: Any) -> dict[str, Any]:
        """Body name -> (translation of its frame origin [m], rotation [rad]), world axes."""
        return body_motions(twists, self._origins, names)

    def joint_centres(self) -> dict[str, pin.SE3]:
        """Joint name -> clearance frame placement oM_c in the world at this configuration."""
        return self.maps.joint_centre

    def contact_state(
        self, x: Array, multipliers: Array, signs: Array, objective_scale: float | Array
    ) -> tuple[Array, Array]:
        r"""Gap of every contact [m], and the contact forces [N] (clearance frame) as rows stacked
        like the contact rows; for one solution (x (n,), multipliers (m,), sigma) or many
        (x (N, n), multipliers (N, m), sigma (N, 1)).

        Forces: a ball or disc pushes back along its image, :math:`f = -2\sigma\lambda_j
        (o_j + S_j x) / c_j^2`; a slab side :math:`f = -\sigma\lambda_j s_j / c_j`.
        """
        image = x @ self.terms.contact_rows.T + self.terms.contact_offsets
        if not image.shape[-1]:
            return image, image
        # a slab has one row, so |s^T x| is the root of its sum of squares too
        gaps = self.bounds - np.sqrt(np.add.reduceat(image * image, self.terms.starts, axis=-1))
        row = self.terms.contact_of_row
        forces = (objective_scale * multipliers[..., row]) * (
            self.terms.norm_force * image + self.terms.slab_force * signs[row]
        )
        return gaps, forces

    @overload
    def statics_residual(
        self,
        gradient: Array,
        forces: Array,
        load_size: float = 0.0,
        springs: Array | None = None,
    ) -> float: ...

    @overload
    def statics_residual(
        self, gradient: Array, forces: Array, load_size: Array, springs: Array | None = None
    ) -> Array: ...

    def statics_residual(
        self,
        gradient: Array,
        forces: Array,
        load_size: float | Array = 0.0,
        springs: Array | None = None,
    ) -> float | Array:
        r"""Relative statics residual :math:`\|P_\perp W (g + K x - \sum_j S_j^T f_j)\| /
        \max(\|W g\|, s)`, for one load (g (n,), forces (k,)) or many ((N, n), (N, k),
        load_size s (N,)); ``springs``: the spring forces K x of the elastic unknowns [N or
        N m] (None: rigid joints).

        :math:`g - \sum_j S_j^T f_j` is what each unknown's direction leaves unbalanced: for a
        translation the force [N], for a rotation the moment [N m] that the loads beyond the joint
        and its contact forces do not balance (the wrench balance of the parts that direction
        moves); W (:attr:`GeometryTerms.statics_weights`) weighs forces by the play scale c and
        moments by c / L, so every joint counts in N whatever its own play (the clearance scales
        Z would weigh a joint of tiny play by that play and hide it); :math:`P_\perp` removes the
        rigid reactions of the loop closure (range of :math:`W E^T`). The reference is the
        larger of :math:`\|W g\|` and ``load_size`` (:math:`c \sum_b |F_b| + |M_b| / L` [J],
        the whole load: a load through a pivot leaves a round-off g that is no imbalance)."""
        weights = self.terms.statics_weights
        unbalanced = gradient - forces @ self.terms.contact_rows
        if springs is not None:
            unbalanced = unbalanced + springs
        weighted = weights * unbalanced
        if self.terms.reactions.shape[1]:
            weighted = weighted - (weighted @ self.terms.reactions) @ self.terms.reactions.T
        reference = np.maximum(np.sqrt(((weights * gradient) ** 2).sum(axis=-1)), load_size)
        residual = np.sqrt((weighted * weighted).sum(axis=-1)) / np.where(
            reference > 0, reference, 1
        )
        return float(residual) if np.ndim(residual) == 0 else residual

    def contact_forces(self, forces: np.ndarray) -> np.ndarray:
        """Stacked force rows -> one (3,) force per contact in its clearance frame, (m, 3)."""
        out = np.zeros(3 * len(self.terms.starts))
        out[self.terms.scatter] = forces
        return out.reshape(-1, 3)

    def flat_directions(
        self, y: Array, multipliers: Array, signs: Array, hessian: np.ndarray | None = None
    ) -> tuple[np.ndarray, Sequence[str]]:
        r"""Directions (r, k) along which the optimum at (y, multipliers) is not unique, with
        their descriptions.

        A contact carrying less than :data:`~.kkt.UNLOADED` (1e-9) of the largest force counts as
        unloaded, the same share below which a load component along an unblocked motion is
        neglected (:data:`~.reduction.UNBOUNDED_FRACTION`). With A the loaded contacts, a
        direction d with :math:`G_A d = 0` (it keeps every contact) and :math:`\nabla^2 L\, d = 0`
        (no curvature of the active cones along it, to 1e-9 of the largest) changes neither the
        potential nor feasibility to second order: the load does not see it (for example the
        axial play of a journal loaded only radially, or a ball's tangential slide when it
        carries 1e-9 of the load). With stiffness, the elastic energy's ``hessian`` H (r, r)
        curves it too (:math:`H d = 0` as well).
        """
        stack = self.geometry.stack
        largest = float(multipliers.max(initial=0.0))
        loaded = np.flatnonzero(multipliers > UNLOADED * largest)
        curvature = stack.hessian(multipliers) if stack.count else np.zeros((stack.size,) * 2)
        gradients = (
            stack.evaluate(y, signs)[1][loaded] if stack.count else np.zeros((0, stack.size))
        )
        rows = np.vstack([gradients, curvature])
        rows = rows / max(1.0, float(np.abs(rows).max(initial=0.0)))
        if hessian is not None:  # on its own scale: a stiff joint's H dwarfs the contact rows
            rows = np.vstack([rows, hessian / max(1.0, float(np.abs(hessian).max()))])
        if rows.size and _surely_full_rank(rows, 1e-9):
            return np.zeros((stack.size, 0)), ()
        flat = null_space(rows, rtol=1e-9) if rows.size else np.eye(stack.size)
        if not flat.shape[1]:
            return flat, ()
        return flat, self.flat_notes(flat)

    def flat_notes(self, flat: np.ndarray) -> Sequence[str]:
        """One sentence per flat direction (columns of ``flat``, (r, k)), written when read."""
        return LazySequence(
            lambda: (
                "bounded but not loaded (the optimum is not unique; minimum-norm point "
                "returned): "
                + "; ".join(
                    describe_motion(
                        self.maps, self.mechanism.joints, self.x_from_y @ flat[:, i], self.length
                    )
                )
                for i in range(flat.shape[1])
            )
        )


@dataclass(frozen=True)
class GeometryTerms:
    """The load- and configuration-independent terms of a reduced geometry, built once per
    geometry (a mechanism without loops has one geometry for all its configurations).

    Attributes:
        signature: sizes and contact shapes (what a built optimiser depends on).
        size_x: number of unknowns n.
        split: (n, n + r): where the stacked load rows change from Z g to Q^T Z g to K^T Z g.
        play: median scale of the unknowns [m or rad], the clearance scale of load sizes.
        size_weights: (play, play / L): the whole load on the clearance scale is
            sum_b |F_b| play + |M_b| play / L [J].
        x_from_y: Z Q, (n, r).
        joint_names: tree then loop joints.
        contact_rows: S_j stacked, (rows, n) [m per unit]; contact_offsets: o_j stacked (rows,) [m].
        bounds: clearance per contact (m,) [m].
        contact_of_row, starts, is_norm: the stack's bookkeeping (:class:`~.kkt.StackedContacts`).
        scatter: stacked force rows -> index in the (m, 3) force array.
        norm_force, slab_force: per row, the factors of :meth:`PreparedGeometry.contact_state`.
        reactions: orthonormal basis (n, k) of the rigid reactions of the closure, range W E^T.
        statics_weights: W (n,): per unknown, the play scale c for a translation, c / L for a
            rotation (:meth:`PreparedGeometry.statics_residual`: forces and moments in N alike).
    """

    signature: Signature
    size_x: int
    split: tuple[int, int]
    play: float
    size_weights: np.ndarray
    x_from_y: np.ndarray
    joint_names: tuple[str, ...]
    contact_rows: np.ndarray
    contact_offsets: np.ndarray
    bounds: np.ndarray
    contact_of_row: np.ndarray
    starts: np.ndarray
    is_norm: np.ndarray
    scatter: np.ndarray
    norm_force: np.ndarray
    slab_force: np.ndarray
    reactions: np.ndarray
    statics_weights: np.ndarray


def geometry_terms(mechanism: Mechanism, geometry: ReducedGeometry) -> GeometryTerms:
    """The :class:`GeometryTerms` of ``geometry``, from the mechanism's cache or built now."""
    cache: SolveCache = mechanism.cache
    cached = cache.geometry_terms.get(id(geometry))
    if cached is not None and cached[0] is geometry:
        return cached[1]
    scale = geometry.scale
    n = scale.size
    stack = geometry.stack
    contacts = geometry.contacts
    signature = (
        geometry.basis.shape[1],
        tuple((c.contact.shape, c.rows.shape[0]) for c in contacts),
    )
    bounds = np.array([c.contact.bound for c in contacts])
    row_bounds = bounds[stack.row_contact]
    row_is_norm = stack.row_is_norm
    play = float(statistics.median(scale.tolist())) if scale.size else 0.0
    length = mechanism.length_scale()
    weights = statics_weights(scale, geometry.translational, length)
    with cache.lock:
        stack.projection_hints = cache.projection_hints.setdefault(signature, set())
    terms = GeometryTerms(
        signature=signature,
        size_x=n,
        split=(n, n + geometry.basis.shape[1]),
        play=play,
        size_weights=np.array([play, play / max(length, 1e-300)]),
        x_from_y=scale[:, None] * geometry.basis,
        joint_names=tuple(mechanism.joints),
        contact_rows=np.vstack([c.rows for c in contacts]) if contacts else np.zeros((0, n)),
        contact_offsets=np.concatenate([c.offset for c in contacts]) if contacts else np.zeros(0),
        bounds=bounds,
        contact_of_row=stack.row_contact,
        starts=stack.starts,
        is_norm=stack.is_norm,
        scatter=np.array(
            [3 * j + k for j, c in enumerate(contacts) for k in c.contact.components], dtype=int
        ),
        norm_force=np.where(row_is_norm, -2.0 / row_bounds**2, 0.0),
        slab_force=np.where(row_is_norm, 0.0, -1.0 / row_bounds),
        # the rank as numpy.linalg.lstsq decides it: eps * max(n, m) of the largest
        reactions=column_space(
            geometry.equalities.T * weights[:, None],
            np.finfo(float).eps * max(geometry.equalities.shape, default=1),
        ),
        statics_weights=weights,
    )
    with cache.lock:
        cache.geometry_terms[id(geometry)] = (geometry, terms)
    return terms


def statics_weights(scale: np.ndarray, translational: Mask | None, length: float) -> Array:
    """W (n,) of :meth:`PreparedGeometry.statics_residual`: per unknown, c for a translation,
    c / L for a rotation (c: the median of the clearance scales ``scale``, the play scale of the
    load size; 1 without unknowns), ``translational`` (n,) bool (None: all translations)."""
    c = float(statistics.median(scale.tolist())) if scale.size else 0.0
    c = c if c > 0.0 else 1.0
    if translational is None:
        translational = np.ones(scale.size, dtype=bool)
    return np.where(translational, c, c / max(length, 1e-300))


def prepared_geometry(mechanism: Mechanism, q: npt.ArrayLike | None = None) -> PreparedGeometry:
    """The mechanism prepared at ``q`` (default: nominal), kept in its cache per configuration:
    closing the loops, the maps and the reduction are done once, so a new load costs a few array
    products."""
    cache: SolveCache = mechanism.cache
    key = None if q is None else np.asarray(q, dtype=float).tobytes()
    prepared = cache.geometry(key)
    if prepared is None:
        with cache.lock:  # one build per configuration, whichever thread asks first
            prepared = cache.geometry(key)
            if prepared is not None:
                return prepared
            configuration = mechanism.configure(q)
            placed = configuration  # a tree's maps read its joint placements only
            if mechanism.loop_joints:
                placed = cache.data
                pin.framesForwardKinematics(mechanism.model, placed, configuration.q)
            maps = build_maps(
                mechanism.model,
                placed,
                mechanism.tree_joints,
                mechanism.loop_joints,
                configuration,
                driven(mechanism.couplings, mechanism.joints),
            )
            prepared = PreparedGeometry(mechanism, configuration, maps, _reduced(mechanism, maps))
            cache.keep_geometry(key, prepared)
    return prepared


def _reduced(mechanism: Mechanism, maps: SmallDisplacementMaps) -> ReducedGeometry:
    """The reduction at the configuration of ``maps``; without loop joints it is the same at every
    configuration (the unknowns are the joints' own torsors and each contact reads its own joint's
    torsor, so no constraint depends on where the parts are), so it is done once."""
    couplings = passive(mechanism.couplings, mechanism.joints)
    if mechanism.loop_joints:
        return reduce_geometry(maps, mechanism.joints, mechanism.length_scale(), couplings)
    cache: SolveCache = mechanism.cache
    if cache.tree_geometry is None:
        cache.tree_geometry = reduce_geometry(
            maps, mechanism.joints, mechanism.length_scale(), couplings
        )
    return cache.tree_geometry


def linear_setup(
    mechanism: Mechanism, loads: Sequence[Load], q: npt.ArrayLike | None
) -> tuple[Configuration, SmallDisplacementMaps, dict[int, BodyLoad], ReducedProblem]:
    """Configuration, maps, per-body loads (with the exact model's terms) and reduced problem."""
    prepared = prepared_geometry(mechanism, q)
    configuration = prepared.configuration
    body_loads = gather_body_loads(mechanism, loads, configuration.oMi)
    return configuration, prepared.maps, body_loads, prepared.problem(loads)


def _surely_full_rank(rows: np.ndarray, rtol: float) -> bool:
    r"""True when every singular value of ``rows`` (k, r) surely exceeds ``rtol`` of the largest,
    decided without an SVD: a Cholesky factor of :math:`R^T R - t I` exists with
    :math:`t = \rho^2 \|R\|_F^2 \ge (\rho\, \sigma_{max})^2`, :math:`\rho = \max(rtol, 10^{-6})`
    (every squared singular value above t). Forming :math:`R^T R` squares the ratios of the
    singular values, so the test resolves no ratio below 1e-6 (1e-12 squared, well above the
    round-off of the product); smaller ones give False: "maybe not", ask the SVD."""
    ratio = max(rtol, 1e-6)
    gram = rows.T @ rows
    shift = ratio * ratio * float(np.trace(gram))
    try:
        np.linalg.cholesky(gram - shift * np.eye(gram.shape[0]))
    except np.linalg.LinAlgError:
        return False
    return True
