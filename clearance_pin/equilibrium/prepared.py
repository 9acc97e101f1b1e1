r"""Everything a small-displacement solve at one nominal configuration needs, computed once.

Build once, solve many: a planner re-solves the same configuration with new loads thousands of
times, so every load-independent product is formed here, and a solve costs a few array products.

- *Load to objective.* The loads gather into body wrenches :math:`W_b = (F, p \times F + C)` at the
  world origin (:mod:`.load_terms`); the scaled gradient of the potential is
  :math:`Z g = -\sum_b Z J_b^T W_b` (:math:`J_b`: body twist map), and its reduced part
  :math:`Q^T Z g` and its part along the unblocked motions :math:`K^T Z g` follow from one
  stacked matrix on the stacked wrenches.
- *Answer.* Joint torsors, body twists and contact images are stacked maps of x; the contact
  forces and the statics residual are vectorised over contacts.
- *Indeterminacy.* The motions along which the optimum is not unique
  (:meth:`PreparedGeometry.flat_directions`) are found at each answer, by one SVD.
"""

from __future__ import annotations

import statistics
from collections.abc import Mapping, Sequence

import numpy as np
import pinocchio as pin

from ..errors import LoadError
from ..model.loads import Gravity, PointForce, Torque
from ..numerics import cross
from .kkt import UNLOADED
from .reduction import (
    ROUND_OFF_WORK,
    UNBOUNDED_FRACTION,
    ReducedGeometry,
    describe_motion,
    with_scaled_load,
)
from .small_displacement import SmallDisplacementMaps, null_space


class PreparedGeometry:
    """The reduced geometry of a mechanism at one configuration, ready for many loads.

    Attributes:
        configuration: the closed nominal configuration.
        maps: linear maps at that configuration.
        geometry: the load-independent reduction (:class:`~.reduction.ReducedGeometry`).
        signature: sizes and contact shapes (what a built optimiser depends on).
    """

    def __init__(self, mechanism, configuration, maps: SmallDisplacementMaps, geometry):
        geometry: ReducedGeometry
        self.mechanism = mechanism
        self.configuration = configuration
        self.maps = maps
        self.geometry = geometry
        self.length = mechanism.length_scale()
        self.__dict__.update(_geometry_terms(mechanism, geometry))  # shared by configurations
        bodies = mechanism.model.njoints
        self.bodies = bodies
        # rows: scaled gradient Z g (n), reduced Q^T Z g (r), along the unblocked motions (f)
        scaled = -geometry.scale[:, None] * np.hstack([maps.body_twist[b].T for b in range(bodies)])
        self._load_rows = np.vstack(
            [scaled, geometry.basis.T @ scaled, geometry.free_scaled.T @ scaled]
        )
        self._frames: dict[str, tuple] = {}  # link -> (body, R, t), filled on first use
        self._gravity: np.ndarray | None = None
        # answer maps
        self._torsor_rows = np.vstack([maps.joint_torsor[name] for name in self.joint_names])
        self._twist_rows = np.vstack(maps.body_twist)
        self._origins = np.array([m.translation for m in configuration.oMi])

    # -- loads ---------------------------------------------------------------------------------
    def _frame(self, link: str) -> tuple:
        """(body, R, t): the body carrying ``link`` and the link frame's world placement."""
        entry = self._frames.get(link)
        if entry is None:
            frame_id = self.mechanism.link_frames.get(link)
            if frame_id is None:
                known = ", ".join(sorted(self.mechanism.link_frames))
                raise LoadError(f"on {link!r}", f"unknown link; the model's links are: {known}")
            placement = self.configuration.oMf[frame_id]
            body = self.mechanism.model.frames[frame_id].parentJoint
            entry = (body, placement.rotation.copy(), placement.translation.copy())
            self._frames[link] = entry
        return entry

    def _gravity_map(self) -> np.ndarray:
        """W_b = (m a, c_b x m a) = Gm_b a per body (c_b: world centre of mass), (6 bodies, 3)."""
        if self._gravity is None:
            model = self.mechanism.model
            gravity = np.zeros((self.bodies, 6, 3))
            for body in range(1, self.bodies):
                inertia = model.inertias[body]
                if inertia.mass > 0.0:
                    centre = self.configuration.oMi[body].act(inertia.lever)
                    gravity[body, :3] = inertia.mass * np.eye(3)
                    gravity[body, 3:] = inertia.mass * pin.skew(centre)
            self._gravity = gravity.reshape(6 * self.bodies, 3)
        return self._gravity

    def wrenches(self, loads) -> np.ndarray:
        """Body wrenches at the world origin (bodies, 6) [N, N m] of ``loads`` (ground excluded)."""
        wrench = np.zeros((self.bodies, 6))
        for load in loads:
            if isinstance(load, Gravity):
                wrench += (self._gravity_map() @ load.acceleration).reshape(self.bodies, 6)
                continue
            body, rotation, translation = self._frame(load.link)
            if isinstance(load, PointForce):
                point = rotation @ load.point + translation
                wrench[body, :3] += load.force
                wrench[body, 3:] += cross(point, load.force)
            elif isinstance(load, Torque):
                wrench[body, 3:] += load.torque
        wrench[0] = 0.0  # a load on the fixed ground does no work
        return wrench

    def problem(self, loads):
        """The reduced problem of ``loads`` (raises UnboundedLoadError, see
        :func:`~.reduction.with_scaled_load`)."""
        wrench = self.wrenches(loads)
        stacked = self._load_rows @ wrench.ravel()
        first, second = self._split
        halves = np.sqrt((wrench * wrench).reshape(-1, 2, 3).sum(axis=2))  # |F_b|, |M_b|
        size = float(np.dot(halves.sum(axis=0), self._size_weights))
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

    def objectives(self, wrenches: np.ndarray):
        """The objectives of many loads at once, from their stacked body wrenches (N, 6 bodies).

        Returns:
            (objectives f (N, r), objective scales sigma (N,), x-space gradients g (N, n),
            load sizes (N,) [J] (see :func:`~.reduction.with_scaled_load`), regular (N,): False
            where the load works on an unblocked motion or on none; those cases are left to a
            single solve, which raises or reports them).
        """
        stacked = wrenches @ self._load_rows.T
        first, second = self._split
        scaled, reduced, along_free = (
            stacked[:, :first],
            stacked[:, first:second],
            stacked[:, second:],
        )
        per_body = wrenches.reshape(len(wrenches), self.bodies, 2, 3)
        sizes = np.linalg.norm(per_body, axis=3)
        load_sizes = self.play * (
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
        return objectives, sigmas, scaled / self.geometry.scale, load_sizes, regular

    # -- answer --------------------------------------------------------------------------------
    def torsor_array(self, x: np.ndarray) -> np.ndarray:
        """Torsor (6,) [m, rad] of every joint of ``joint_names`` for the unknowns x, (joints, 6)."""
        return (self._torsor_rows @ x).reshape(-1, 6)

    def body_twists(self, x: np.ndarray) -> np.ndarray:
        """Spatial twist (v, omega) at the world origin of every body, (bodies, 6)."""
        return (self._twist_rows @ x).reshape(self.bodies, 6)

    def body_motions(self, twists: np.ndarray, names) -> dict:
        """Body name -> (translation of its frame origin [m], rotation [rad]), world axes."""
        w, p = twists[:, 3:], self._origins
        moved = twists[:, :3] + np.stack(
            (
                w[:, 1] * p[:, 2] - w[:, 2] * p[:, 1],
                w[:, 2] * p[:, 0] - w[:, 0] * p[:, 2],
                w[:, 0] * p[:, 1] - w[:, 1] * p[:, 0],
            ),
            axis=1,
        )
        return {names[i]: (moved[i], twists[i, 3:]) for i in range(1, self.bodies)}

    def contact_state(self, x: np.ndarray, multipliers, signs, objective_scale):
        r"""Gap of every contact [m], and the contact forces [N] (clearance frame) as rows stacked
        like the contact rows; for one solution (x (n,), multipliers (m,), sigma) or many
        (x (N, n), multipliers (N, m), sigma (N, 1)).

        Forces: a ball or disc pushes back along its image, :math:`f = -2\sigma\lambda_j
        (o_j + S_j x) / c_j^2`; a slab side :math:`f = -\sigma\lambda_j s_j / c_j`.
        """
        image = x @ self._contact_rows.T + self._contact_offsets
        if not image.shape[-1]:
            return image, image
        # a slab has one row, so |s^T x| is the root of its sum of squares too
        gaps = self.bounds - np.sqrt(np.add.reduceat(image * image, self._starts, axis=-1))
        row = self._contact_of_row
        forces = (objective_scale * multipliers[..., row]) * (
            self._norm_force * image + self._slab_force * signs[row]
        )
        return gaps, forces

    def statics_residual(self, gradient: np.ndarray, forces: np.ndarray, load_size=0.0):
        r"""Relative virtual-work residual :math:`\|P_\perp Z (g - \sum_j S_j^T f_j)\| / \|Z g\|`,
        :math:`P_\perp` removing the rigid reactions of the loop closure (range of :math:`Z E^T`);
        for one load (g (n,), forces (k,)) or many ((N, n), (N, k), load_size (N,)).

        The reference is the larger of :math:`\|Z g\|` and ``load_size`` (the whole load on the
        clearance scale): a load through a pivot leaves a round-off g that is no imbalance."""
        scale = self.geometry.scale
        scaled = scale * (gradient - forces @ self._contact_rows)
        if self._reactions.shape[1]:
            scaled = scaled - (scaled @ self._reactions) @ self._reactions.T
        reference = np.maximum(np.sqrt(((scale * gradient) ** 2).sum(axis=-1)), load_size)
        residual = np.sqrt((scaled * scaled).sum(axis=-1)) / np.where(reference > 0, reference, 1)
        return float(residual) if np.ndim(residual) == 0 else residual

    def contact_forces(self, forces: np.ndarray) -> np.ndarray:
        """Stacked force rows -> one (3,) force per contact in its clearance frame, (m, 3)."""
        out = np.zeros(3 * len(self._starts))
        out[self._scatter] = forces
        return out.reshape(-1, 3)

    def flat_directions(self, y, multipliers, signs) -> tuple[np.ndarray, LazySequence]:
        r"""Directions (r, k) along which the optimum at (y, multipliers) is not unique, with
        their descriptions.

        A contact carrying less than :data:`~.kkt.UNLOADED` (1e-9) of the largest force counts as
        unloaded, the same share below which a load component along an unblocked motion is
        neglected (:data:`~.reduction.UNBOUNDED_FRACTION`). With A the loaded contacts, a
        direction d with :math:`G_A d = 0` (it keeps every contact) and :math:`\nabla^2 L\, d = 0`
        (no curvature of the active cones along it, to 1e-9 of the largest) changes neither the
        potential nor feasibility to second order: the load does not see it (for example the
        axial play of a journal loaded only radially, or a ball's tangential slide when it
        carries 1e-9 of the load).
        """
        stack = self.geometry.stack
        largest = float(multipliers.max(initial=0.0))
        loaded = np.flatnonzero(multipliers > UNLOADED * largest)
        _, gradients = stack.evaluate(y, signs)
        rows = np.vstack([gradients[loaded], stack.hessian(multipliers)])
        scale = max(1.0, float(np.abs(rows).max(initial=0.0)))
        flat = null_space(rows / scale, rtol=1e-9) if rows.size else np.eye(stack.size)
        if not flat.shape[1]:
            return flat, ()
        descriptions = LazySequence(
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
        return flat, descriptions


def _geometry_terms(mechanism, geometry) -> dict:
    """The load- and configuration-independent terms of a reduced geometry, built once per
    geometry (a mechanism without loops has one geometry for all its configurations)."""
    key = ("geometry terms", id(geometry))
    cached = mechanism._solve_state.get(key)
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
    stack.projection_hints = mechanism._solve_state.setdefault(
        ("projection hints", signature), set()
    )
    terms = {
        "signature": signature,
        "size_x": n,
        "_split": (n, n + geometry.basis.shape[1]),
        "play": play,
        # the whole load on the clearance scale: sum_b |F_b| c + |M_b| c / L (c: median scale)
        "_size_weights": np.array([play, play / max(length, 1e-300)]),
        "x_from_y": scale[:, None] * geometry.basis,
        "joint_names": tuple(mechanism.joints),
        "_contact_rows": np.vstack([c.rows for c in contacts]) if contacts else np.zeros((0, n)),
        "_contact_offsets": np.concatenate([c.offset for c in contacts]) if contacts else np.zeros(0),
        "bounds": bounds,
        "_contact_of_row": stack.row_contact,
        "_starts": stack.starts,
        "_is_norm": stack.is_norm,
        "_scatter": np.array(
            [3 * j + k for j, c in enumerate(contacts) for k in c.contact.components], dtype=int
        ),
        "_norm_force": np.where(row_is_norm, -2.0 / row_bounds**2, 0.0),
        "_slab_force": np.where(row_is_norm, 0.0, -1.0 / row_bounds),
        "_reactions": _column_basis(geometry.equalities.T * scale[:, None]),
    }
    mechanism._solve_state[key] = (geometry, terms)
    return terms


class LazyMapping(Mapping):
    """A read-only mapping computed by ``compute()`` on first access (for answers a caller
    rarely reads, such as every body's motion after each of thousands of re-solves)."""

    def __init__(self, compute):
        self._compute = compute
        self._value: dict | None = None

    def _get(self) -> dict:
        if self._value is None:
            self._value = self._compute()
        return self._value

    def __getitem__(self, key):
        return self._get()[key]

    def __iter__(self):
        return iter(self._get())

    def __len__(self) -> int:
        return len(self._get())

    def __repr__(self) -> str:
        return repr(self._get())

    def __reduce__(self):
        return (dict, (self._get(),))  # pickled computed: results travel to other processes


class LazySequence(Sequence):
    """A read-only sequence computed by ``compute()`` on first access (world placements of every
    body, descriptions of free motions: answers a planner re-solving thousands of times rarely
    reads)."""

    def __init__(self, compute):
        self._compute = compute
        self._value: tuple | None = None

    def _get(self) -> tuple:
        if self._value is None:
            self._value = tuple(self._compute())
        return self._value

    def __len__(self) -> int:
        return len(self._get())

    def __getitem__(self, index):
        return self._get()[index]

    def __eq__(self, other) -> bool:
        return tuple(self) == tuple(other) if isinstance(other, Sequence) else NotImplemented

    def __hash__(self) -> int:
        return hash(self._get())

    def __add__(self, other):
        return LazySequence(lambda: (*self, *other))

    def __reduce__(self):
        return (tuple, (self._get(),))  # pickled computed: results travel to other processes

    def __repr__(self) -> str:
        return repr(self._get())


def placements(twists: np.ndarray, nominal: tuple) -> LazySequence:
    r"""World placements of every body at a linear solution, :math:`\exp(\xi_b)\, oM_{b0}`,
    computed on first access."""
    return LazySequence(
        lambda: (
            nominal[0],
            *(pin.exp6(pin.Motion(twists[i])) * nominal[i] for i in range(1, len(nominal))),
        )
    )


def _column_basis(matrix: np.ndarray) -> np.ndarray:
    """Orthonormal basis of the column space of ``matrix`` (n, m), rank as numpy.linalg.lstsq
    decides it (singular values above eps * max(n, m) of the largest)."""
    if matrix.size == 0:
        return np.zeros((matrix.shape[0], 0))
    u, s, _ = np.linalg.svd(matrix, full_matrices=False)
    if s.size == 0 or s[0] == 0.0:
        return np.zeros((matrix.shape[0], 0))
    rank = int(np.sum(s > np.finfo(float).eps * max(matrix.shape) * s[0]))
    return u[:, :rank].copy()
