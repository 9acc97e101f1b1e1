r"""The exact loop closure for many toleranced samples at once (Flores [F] Monte Carlo).

A Newton method on the same residual as :mod:`clearance_pin.kinematics.closure` (constrained
components of each loop's relative placement ``cM_b`` in its clearance frame), built generically
from the ``pin.Model``:

.. math::

    oM_i = oM_{\lambda(i)} \, D(dd) \, {}^{\lambda(i)}M_i \, M_i(q_i^0) \exp(S_i \delta_i), \qquad
    \delta \leftarrow \delta - (J^T W^2 J)^{-1} J^T W^2 r(\delta)

with ``delta`` the passive joints' increments (started at the linear prediction ``S_q dd``),
``J`` the exact derivative of the residual, ``W`` = 1 on translation rows and the mechanism's
length scale on rotation rows. The kinematics is traced once per configuration
(:mod:`.tape`) and replayed on blocks of samples.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import TYPE_CHECKING, TypeAlias

import numpy as np
import pinocchio as pin

from ..errors import ArgumentError, SolverError
from ..kinematics.closure import (
    PassiveMotion,
    _weights,
    closure_jacobian,
    closure_residual,
    idle_motion_count,
    passive_basis,
    passive_motions,
)
from ..model.clearance import ALPHA
from ..model.dimensions import Dimension
from .dimensions import directly_moved
from .sensitivity import Output, Sensitivities, sensitivities
from .tape import (
    Entries,
    Entry,
    Moved,
    Placement,
    _add,
    _apply,
    _as_array,
    _compose,
    _constant_placement,
    _cross,
    _Item,
    _jl_inverse,
    _log3,
    _mat_mul,
    _mat_t_vec,
    _mat_vec,
    _mul,
    _neg,
    _Program,
    _rotation,
    _sub,
    _Tape,
    _transpose,
    _vadd,
    _Var,  # noqa: F401  (the Entry alias names it: read by the API reference here)
    _vsub,
)

if TYPE_CHECKING:
    from ..mechanism import Mechanism

__all__ = ["BatchClosure"]

#: a passive motion of a joint: (its column of S_q, "revolute" or "prismatic", axis)
Spec: TypeAlias = tuple[int, str, tuple[float, ...]]
#: a passive motion where it acts: (joint, column, kind, world axis w, world origin p)
Geometry: TypeAlias = tuple[int, int, str, Entries, Entries]
#: a loop joint of the residual, for the Jacobian: (frame_a, frame_b, rows, axis_mode, weights,
#: R_c, p_c, p_b, rotation error, its angle (or the moved axis in axis_mode))
LoopState: TypeAlias = tuple[
    int, int, list[int], bool, list[float], Entries, Entries, Entries, Entries, "Entry | Entries"
]


class BatchClosure:
    """Exact loop closure of one configuration for many dimension deviations at once.

    Build once per configuration, then :meth:`solve` any number of samples.

    Args:
        mechanism: :class:`~clearance_pin.mechanism.Mechanism`.
        outputs: :class:`~clearance_pin.tolerance.sensitivity.Output` objects or spec strings.
        q: configuration (nq,), driven joints at their values (default: nominal); closed first.
        dimensions: default ``mechanism.dimensions``.
        tol: closure tolerance on the length-scaled residual [m].
        max_iterations: Newton iterations per sample.
    """

    def __init__(
        self,
        mechanism: Mechanism,
        outputs: Iterable[Output | str],
        q: np.ndarray | None = None,
        dimensions: tuple[Dimension, ...] | None = None,
        tol: float | None = None,
        max_iterations: int = 12,
        linear: Sensitivities | None = None,
    ) -> None:
        model = mechanism.model
        self.mechanism = mechanism
        self.linear = (
            linear if linear is not None else sensitivities(mechanism, outputs, q, dimensions)
        )
        self.outputs = self.linear.outputs
        self.dimensions = self.linear.dimensions
        self.q = self.linear.q
        self.length = mechanism.length_scale()
        self.tol = 1e-12 * self.length if tol is None else float(tol)
        self.max_iterations = int(max_iterations)
        data = model.createData()
        pin.framesForwardKinematics(model, data, self.q)
        pin.computeJointJacobians(model, data, self.q)

        moved_joints: dict[int, list[Moved]] = {}
        moved_frames: dict[int, list[Moved]] = {}
        for k, dim in enumerate(self.dimensions):
            joints, moved = directly_moved(model, dim)
            entry = (k, dim.kind, tuple(dim.axis_in_parent_joint), tuple(dim.point_in_parent_joint))
            for j in joints:
                moved_joints.setdefault(j, []).append(entry)
            for f in moved:
                moved_frames.setdefault(f, []).append(entry)

        # the passive motions (columns of the sensitivities' S_q): a 1-DOF joint's own motion,
        # a ball joint's three rotations, ... applied one after the other in the joint frame
        motions = passive_motions(mechanism)
        self.passive = list(range(len(motions)))
        specs_of_joint: dict[int, list[Spec]] = {}
        for column, motion in enumerate(motions):
            specs_of_joint.setdefault(motion.joint_id, []).append(
                (column, motion.kind, motion.axis)
            )
        self._column_of_velocity = {
            model.joints[m.joint_id].idx_v: c
            for c, m in enumerate(motions)
            if model.joints[m.joint_id].nv == 1
        }
        self._reduction = _idle_free_basis(mechanism, data, motions)

        frames = {o.index for o in self.outputs if o.kind != "joint"}
        for loop in mechanism.loop_joints:
            frames.update((loop.frame_a, loop.frame_b))
        needed: set[int] = set()
        for f in frames:
            needed.update(int(j) for j in model.supports[model.frames[f].parentJoint] if j > 0)
        self.joints: dict[int, tuple[_Item, Placement, tuple[Spec, ...]]] = {}
        for j in sorted(needed):
            placement = _constant_placement(model.jointPlacements[j])
            at_q = _constant_placement(model.jointPlacements[j].inverse() * data.liMi[j])
            spec = tuple(specs_of_joint.get(j, ()))
            item = _Item(int(model.parents[j]), placement, tuple(moved_joints.get(j, ())))
            self.joints[j] = (item, at_q, spec)
        self.frames = {
            f: _Item(
                int(model.frames[f].parentJoint),
                _constant_placement(model.frames[f].placement),
                tuple(moved_frames.get(f, ())),
            )
            for f in frames
        }
        self.supports = {
            f: {int(j) for j in model.supports[model.frames[f].parentJoint]} for f in frames
        }
        self.loops: list[tuple[int, int, list[int], bool, Entries]] = []
        for loop in mechanism.loop_joints:
            free = set(loop.clearance.free_components)
            rows = [c for c in range(6) if c not in free]
            rotation = _constant_placement(pin.SE3(loop.rotation, np.zeros(3)))[0]
            self.loops.append((loop.frame_a, loop.frame_b, rows, ALPHA in free, rotation))
        # nominal frame rotations (orientation outputs are rotation vectors of R R_0^T)
        self._frame_reference: dict[int, Entries] = {
            f: _transpose(_constant_placement(data.oMf[f])[0]) for f in frames
        }
        self._trace()
        # the nominal outputs of the batch kinematics itself (its round-off cancels)
        self._reference = np.zeros(len(self.outputs))
        self._reference = self.solve(np.zeros((1, len(self.dimensions))))[0]

    def _trace(self) -> None:
        """Trace the kinematics once with symbolic entries; compile the two programs.

        ``_evaluate``: (dd, delta) -> residual rows, outputs; ``_step``: (dd, delta) ->
        residual rows, delta + Newton increment."""
        tape = _Tape()
        dd = tape.variables(len(self.dimensions))
        reduced = self._reduction
        z = tape.variables(len(self.passive) if reduced is None else reduced.shape[1])
        delta: Sequence[Entry] = z if reduced is None else [_combination(row, z) for row in reduced]
        geometry, oMf = self._forward(dd, delta)
        values, states = self._residual(oMf)
        self._rows = len(values)
        self._evaluate = tape.compile(dd + z, values + self._outputs(oMf, delta))
        self._step: _Program | None = None
        if z and self.loops:
            derivatives = self._jacobian(geometry, states)
            if reduced is not None:  # by the reduced unknowns: J C
                derivatives = [
                    [_combination(column, row) for column in reduced.T] for row in derivatives
                ]
            increment = _newton_step(derivatives, values, len(z))
            self._step = tape.compile(dd + z, values + [_add(d, x) for d, x in zip(z, increment)])

    # -- kinematics ---------------------------------------------------------------------
    @staticmethod
    def _moved(item: _Item, dd: Sequence[Entry]) -> Placement:
        rotation: Entries = item.placement[0]
        translation: Entries = item.placement[1]
        for k, kind, axis, point in item.dims:
            if kind == "length":
                translation = _vadd(translation, tuple(_mul(a, dd[k]) for a in axis))
            else:
                e = _rotation(axis, np.cos(dd[k]), np.sin(dd[k]))
                rotation = _mat_mul(e, rotation)
                translation = _vadd(_mat_vec(e, _vsub(translation, point)), point)
        return rotation, translation

    def _forward(
        self, dd: Sequence[Entry], delta: Sequence[Entry]
    ) -> tuple[list[Geometry], dict[int, Placement]]:
        """World placements of the needed frames for deviations ``dd`` and passive increments
        ``delta`` (entries, one per dimension / passive motion), and the world axis and origin
        of every passive motion where it acts: [(joint, column, kind, w, p)]. A joint's motions
        act one after the other in its frame (a ball joint: three rotations)."""
        identity: Placement = ((1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0), (0.0, 0.0, 0.0))
        oMi = {0: identity}
        geometry: list[Geometry] = []
        for j, (item, motion, specs) in self.joints.items():
            placement = _compose(_compose(oMi[item.parent], self._moved(item, dd)), motion)
            for column, kind, axis in specs:
                d = delta[column]
                geometry.append((j, column, kind, _mat_vec(placement[0], axis), placement[1]))
                if kind == "revolute":
                    placement = _compose(
                        placement, (_rotation(axis, np.cos(d), np.sin(d)), (0.0, 0.0, 0.0))
                    )
                else:
                    placement = _compose(placement, (identity[0], tuple(_mul(a, d) for a in axis)))
            oMi[j] = placement
        oMf = {
            f: _compose(oMi[item.parent], self._moved(item, dd)) for f, item in self.frames.items()
        }
        return geometry, oMf

    def _residual(self, oMf: Mapping[int, Placement]) -> tuple[list[Entry], list[LoopState]]:
        """Weighted residual rows of every loop, and the loop geometry for :meth:`_jacobian`."""
        values: list[Entry] = []
        states: list[LoopState] = []
        for frame_a, frame_b, rows, axis_mode, rotation in self.loops:
            ra, pc = oMf[frame_a]
            rb, pb = oMf[frame_b]
            rc = _mat_mul(ra, rotation)
            rel_r = _mat_mul(_transpose(rc), _mat_mul(rb, rotation))
            rel_t = _mat_t_vec(rc, _vsub(pb, pc))
            rot: Entries
            theta: Entry | Entries
            if axis_mode:  # as closure.py: only the axis must line up, the spin is free
                m = (rel_r[0], rel_r[3], rel_r[6])
                rot = (0.0, _neg(_apply(np.arctan2, m[2], m[0])), _apply(np.arctan2, m[1], m[0]))
                theta = m
            else:
                rot, theta = _log3(rel_r)
            error = (*rel_t, *rot)
            weights = [1.0 if c < ALPHA else self.length for c in rows]
            values.extend(_mul(error[c], w) for c, w in zip(rows, weights))
            states.append((frame_a, frame_b, rows, axis_mode, weights, rc, pc, pb, rot, theta))
        return values, states

    def _jacobian(self, geometry: list[Geometry], states: list[LoopState]) -> list[list[Entry]]:
        r"""Exact derivatives of the residual rows by the passive increments, row by row.

        For a passive joint with world axis ``w`` through ``p``: point velocity
        ``w x (x - p)`` (revolute) or ``w`` (prismatic); then
        ``d t_rel = R_c^T (v_b - v_c - omega_a x (p_b - p_c))``, ``w_rel = R_c^T (omega_b -
        omega_a)`` and ``d log(R_rel) = J_l^{-1} w_rel`` (or the derivative of the axis angles).
        """
        zero: Entries = (0.0, 0.0, 0.0)
        columns = geometry
        derivatives: list[list[Entry]] = []
        for frame_a, frame_b, rows, axis_mode, weights, rc, pc, pb, rot, theta in states:
            per_column: dict[int, list[Entry]] = {}
            for j, column, kind, w, p in columns:
                in_a, in_b = j in self.supports[frame_a], j in self.supports[frame_b]
                if not (in_a or in_b):
                    continue
                if kind == "revolute":
                    vb = _cross(w, _vsub(pb, p)) if in_b else zero
                    vc = _cross(w, _vsub(pc, p)) if in_a else zero
                    wa, wb = (w if in_a else zero), (w if in_b else zero)
                else:
                    vb, vc, wa, wb = (w if in_b else zero), (w if in_a else zero), zero, zero
                dt = _mat_t_vec(rc, _vsub(_vsub(vb, vc), _cross(wa, _vsub(pb, pc))))
                wr = _mat_t_vec(rc, _vsub(wb, wa))
                drot: Entries
                if axis_mode:
                    m = theta
                    assert isinstance(m, tuple)  # the moved axis (see _residual)
                    dm = _cross(wr, m)
                    d1 = _neg(
                        _sub(_mul(m[0], dm[2]), _mul(m[2], dm[0])) / (m[0] * m[0] + m[2] * m[2])
                    )
                    d2 = _sub(_mul(m[0], dm[1]), _mul(m[1], dm[0])) / (m[0] * m[0] + m[1] * m[1])
                    drot = (0.0, d1, d2)
                else:
                    assert not isinstance(theta, tuple)  # the angle (see _residual)
                    drot = _jl_inverse(rot, theta, wr)
                derror = (*dt, *drot)
                per_column[column] = [_mul(derror[c], w) for c, w in zip(rows, weights)]
            for r in range(len(rows)):
                derivatives.append(
                    [per_column[c][r] if c in per_column else 0.0 for c in range(len(self.passive))]
                )
        return derivatives

    def _outputs(self, oMf: Mapping[int, Placement], delta: Sequence[Entry]) -> list[Entry]:
        values: list[Entry] = []
        for output in self.outputs:
            if output.kind == "joint":
                idx_v = self.mechanism.model.joints[output.index].idx_v
                column = self._column_of_velocity.get(idx_v)
                values.append(delta[column] if column is not None else 0.0)
            elif output.kind == "position":
                values.append(oMf[output.index][1][output.component])
            else:  # world rotation vector of R R_0^T, R_0 the nominal rotation
                rotation = _mat_mul(oMf[output.index][0], self._frame_reference[output.index])
                values.append(_log3(rotation)[0][output.component])
        return values

    def _close(self, dd: np.ndarray) -> np.ndarray:
        """Newton on the passive increments, then the outputs (n, n_out), not yet referenced."""
        n, rows = dd.shape[0], self._rows
        columns = [np.ascontiguousarray(dd[:, k]) for k in range(dd.shape[1])]
        guess = dd @ self.linear.passive.T if self.passive else np.zeros((n, 0))
        if self._reduction is not None:  # S_q has no idle part: its reduced coordinates
            guess = guess @ self._reduction
        delta = [np.ascontiguousarray(guess[:, k]) for k in range(guess.shape[1])]
        iterations = 0
        while True:
            if self._step is not None:
                delta = [_as_array(d, n) for d in self._step.run(columns + delta)[rows:]]
                iterations += 1
            result = self._evaluate.run(columns + delta)
            largest = max((float(np.max(np.abs(v))) for v in result[:rows]), default=0.0)
            if largest <= self.tol:
                closed: np.ndarray = (
                    np.column_stack([_as_array(v, n) for v in result[rows:]])
                    if len(result) > rows
                    else np.zeros((n, 0))
                )
                return closed
            if iterations >= self.max_iterations or not np.isfinite(largest):
                raise SolverError(
                    "the exact loop closure did not converge for some samples "
                    "(tolerances too large for this configuration?)",
                    "max_iter",
                    {"closure_residual_m": largest},
                )

    def solve(self, deviations: np.ndarray, chunk: int = 1 << 14) -> np.ndarray:
        """Exact output deviations for dimension deviations, shape (N, n_out) [m or rad].

        Args:
            deviations: ``dd`` [m or rad], shape (N, n_dim).
            chunk: samples per vectorised block (memory / cache trade-off).

        Raises:
            SolverError: the Newton closure did not converge (deviations too large).
        """
        dd = np.asarray(deviations, dtype=float)
        if dd.ndim != 2 or dd.shape[1] != len(self.dimensions):
            raise ArgumentError(
                "deviations",
                f"an array of shape (N, {len(self.dimensions)}) [m or rad]",
                deviations,
                f"shape {dd.shape}",
            )
        out = np.empty((dd.shape[0], len(self.outputs)))
        for start in range(0, dd.shape[0], chunk):
            out[start : start + chunk] = self._close(dd[start : start + chunk]) - self._reference
        return out


def _newton_step(
    derivatives: Sequence[Sequence[Entry]], values: Sequence[Entry], n_passive: int
) -> list[Entry]:
    """Gauss-Newton increment ``-(J^T J)^{-1} J^T r`` per sample (entries), by Cholesky."""
    a: list[list[Entry]] = [[0.0] * n_passive for _ in range(n_passive)]
    g: list[Entry] = [0.0] * n_passive
    for row, value in zip(derivatives, values):
        for i in range(n_passive):
            if isinstance(row[i], float) and row[i] == 0.0:
                continue
            g[i] = _add(g[i], _mul(row[i], value))
            for j in range(i + 1):
                a[i][j] = _add(a[i][j], _mul(row[i], row[j]))
    lower: list[list[Entry]] = [[0.0] * n_passive for _ in range(n_passive)]
    for i in range(n_passive):
        for j in range(i + 1):
            s: Entry = a[i][j]
            for k in range(j):
                s = _sub(s, _mul(lower[i][k], lower[j][k]))
            if i == j:
                lower[i][i] = np.sqrt(_apply(np.maximum, s, 1e-300))
            else:
                lower[i][j] = s / lower[j][j]
    y: list[Entry] = [0.0] * n_passive
    for i in range(n_passive):
        s = _neg(g[i])
        for k in range(i):
            s = _sub(s, _mul(lower[i][k], y[k]))
        y[i] = s / lower[i][i]
    x: list[Entry] = [0.0] * n_passive
    for i in reversed(range(n_passive)):
        s = y[i]
        for k in range(i + 1, n_passive):
            s = _sub(s, _mul(lower[k][i], x[k]))
        x[i] = s / lower[i][i]
    return x


def _combination(coefficients: Iterable[float], entries: Iterable[Entry]) -> Entry:
    """``sum_k c_k e_k`` of float coefficients and entries (zeros fold)."""
    total: Entry = 0.0
    for c, e in zip(coefficients, entries):
        if abs(float(c)) > 1e-15:
            total = _add(total, _mul(float(c), e))
    return total


def _idle_free_basis(
    mechanism: Mechanism, data: pin.Data, motions: Sequence[PassiveMotion]
) -> np.ndarray | None:
    """An orthonormal basis C (n_passive, n_kept) of the passive motions orthogonal to the idle
    ones (null space of the closure Jacobian at this configuration; a rod between two ball
    joints spins freely), or None without idle motions. The batched Newton solves for the
    coordinates z of ``delta = C z``: the idle motions stay where the sensitivities put them
    (nowhere), and the normal equations are regular."""
    if not motions or not mechanism.loop_joints:
        return None
    idle = idle_motion_count(mechanism)
    if not idle:
        return None
    length = mechanism.length_scale()
    _, selections = closure_residual(mechanism, data)
    weights = np.concatenate([_weights(rows, length) for _, rows, _ in selections])
    jacobian = closure_jacobian(mechanism, data, selections, passive_basis(mechanism, motions))
    vt = np.linalg.svd(weights[:, None] * jacobian, full_matrices=True)[2]
    basis: np.ndarray = vt[: len(motions) - idle].T
    basis[np.abs(basis) < 1e-15] = 0.0
    return basis
