r"""Monte Carlo and exact worst case of the tolerance stack-up, with the exact loop closure.

The linear bands of [F] (P. Flores, "A methodology for quantifying the kinematic position errors
due to manufacturing and assembly tolerances", Strojniski vestnik - J. Mech. Eng. (2011)) rest
on ``dq = S dd``. Here each sample of the dimensions ``d + dd`` is a manufactured mechanism whose
loops are closed *exactly* (``Phi(q, d + dd) = 0``), and the outputs are read from it:

- :func:`monte_carlo`: ``dd_j ~ U(-T_j/2, T_j/2)`` (every sample inside the worst-case box) or
  ``dd_j ~ N(0, (T_j/6)^2)`` (process spread ``6 sigma = T``, whose output ``3 sigma`` the RSS
  band predicts), summary statistics per output;
- :func:`exact_worst_case`: the true extremes of each output over the tolerance box
  ``|dd_j| <= T_j/2``, by optimisation (vertex enumeration, then projected Newton).

The closure is solved for many samples at once (:class:`BatchClosure`): a Newton method on the
same residual as :mod:`clearance_pin.kinematics.closure` (constrained components of each loop's
relative placement ``cM_b`` in its clearance frame), built generically from the ``pin.Model``:

.. math::

    oM_i = oM_{\lambda(i)} \, D(dd) \, {}^{\lambda(i)}M_i \, M_i(q_i^0) \exp(S_i \delta_i), \qquad
    \delta \leftarrow \delta - (J^T W^2 J)^{-1} J^T W^2 r(\delta)

with ``delta`` the passive joints' increments (started at the linear prediction ``S_q dd``),
``J`` the exact derivative of the residual, ``W`` = 1 on translation rows and the mechanism's
length scale on rotation rows.

Vectorisation: every 3-vector and 3x3 matrix entry is a Python float (the same for all samples:
constants, the exact zeros of planar mechanisms) or a per-sample value, so the arithmetic folds
what does not vary. The kinematics of one configuration is traced once in this algebra into a
tape of NumPy ufunc calls (dead values dropped, registers reused), which is then replayed on
blocks of samples with ``out=`` buffers: about 200 array operations per Newton iteration and
output evaluation for the slider-crank, some 0.4 us per sample.
"""

from __future__ import annotations

import contextlib
import itertools
import os
import time
from collections import deque
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Literal

import numpy as np
import pinocchio as pin

from ..errors import ClearancePinError, SolverError, UnsupportedError
from ..model.clearance import ALPHA
from ..progress import Progress
from .dimensions import Dimension, directly_moved
from .sensitivity import Output, Sensitivities, sensitivities
from .statistics import monte_carlo_inputs

__all__ = ["BatchClosure", "MonteCarloResult", "WorstCase", "exact_worst_case", "monte_carlo"]

_SNAP = 1e-14  # constant matrix entries below this are exact zeros (rpy round-off)

# --------------------------------------------------------------------------------------------
# Entry-wise algebra: an entry is a float (same for every sample), an array (N,) or a traced
# value (_Var); 3-vectors are 3-tuples, 3x3 matrices 9-tuples (row-major), placements (R, t)
# --------------------------------------------------------------------------------------------


def _mul(a, b):
    if isinstance(a, float):
        if a == 0.0:
            return 0.0
        if a == 1.0:
            return b
    if isinstance(b, float):
        if b == 0.0:
            return 0.0
        if b == 1.0:
            return a
    return a * b


def _add(a, b):
    if isinstance(a, float) and a == 0.0:
        return b
    if isinstance(b, float) and b == 0.0:
        return a
    return a + b


def _neg(a):
    return -a if not (isinstance(a, float) and a == 0.0) else 0.0


def _sub(a, b):
    if isinstance(b, float) and b == 0.0:
        return a
    if isinstance(a, float) and a == 0.0:
        return -b
    return a - b


def _dot(a, b):
    return _add(_add(_mul(a[0], b[0]), _mul(a[1], b[1])), _mul(a[2], b[2]))


def _mat_vec(m, v):
    """``M v``; m: 9 entries, row-major."""
    return tuple(_dot(m[3 * i : 3 * i + 3], v) for i in range(3))


def _mat_t_vec(m, v):
    """``M^T v``."""
    return tuple(_dot((m[i], m[3 + i], m[6 + i]), v) for i in range(3))


def _mat_mul(a, b):
    cols = [(b[j], b[3 + j], b[6 + j]) for j in range(3)]
    return tuple(_dot(a[3 * i : 3 * i + 3], cols[j]) for i in range(3) for j in range(3))


def _transpose(m):
    return (m[0], m[3], m[6], m[1], m[4], m[7], m[2], m[5], m[8])


def _vadd(a, b):
    return tuple(_add(x, y) for x, y in zip(a, b))


def _vsub(a, b):
    return tuple(_sub(x, y) for x, y in zip(a, b))


def _vscale(a, s):
    return tuple(_mul(x, s) for x in a)


def _cross(a, b):
    return (
        _sub(_mul(a[1], b[2]), _mul(a[2], b[1])),
        _sub(_mul(a[2], b[0]), _mul(a[0], b[2])),
        _sub(_mul(a[0], b[1]), _mul(a[1], b[0])),
    )


def _compose(a, b):
    """Placement product ``a * b``; a placement is (R: 9 entries, t: 3 entries)."""
    return _mat_mul(a[0], b[0]), _vadd(_mat_vec(a[0], b[1]), a[1])


def _rotation(axis, c, s):
    """Rodrigues ``cos I + sin [a]x + (1 - cos) a a^T`` for a unit axis of floats."""
    x, y, z = axis
    k = _sub(1.0, c)
    return (
        _add(c, _mul(k, x * x)),
        _sub(_mul(k, x * y), _mul(s, z)),
        _add(_mul(k, x * z), _mul(s, y)),
        _add(_mul(k, x * y), _mul(s, z)),
        _add(c, _mul(k, y * y)),
        _sub(_mul(k, y * z), _mul(s, x)),
        _sub(_mul(k, x * z), _mul(s, y)),
        _add(_mul(k, y * z), _mul(s, x)),
        _add(c, _mul(k, z * z)),
    )


def _constant_placement(placement: pin.SE3):
    snap = lambda v: 0.0 if abs(v) < _SNAP else float(v)  # noqa: E731
    return (
        tuple(snap(v) for v in placement.rotation.reshape(-1)),
        tuple(snap(v) for v in placement.translation),
    )


def _log3(m):
    """Rotation vector of a rotation (entries), for angles below pi, and the angle."""
    v = (0.5 * _sub(m[7], m[5]), 0.5 * _sub(m[2], m[6]), 0.5 * _sub(m[3], m[1]))
    if all(isinstance(x, float) and x == 0.0 for x in v):
        return (0.0, 0.0, 0.0), 0.0
    s = np.sqrt(_dot(v, v))
    c = 0.5 * (m[0] + m[4] + m[8] - 1.0)
    theta = np.arctan2(s, c)
    big = s > 1e-7
    safe = _where(big, s, 1.0)
    factor = _where(big, theta / safe, 1.0 + theta * theta / 6.0)
    return _vscale(v, factor), theta


def _jl_inverse(phi, theta, w):
    r"""``J_l^{-1}(phi) w = w - phi x w / 2 + beta phi x (phi x w)`` (left Jacobian of SO(3))."""
    if isinstance(theta, float) and theta == 0.0:
        return w
    t2 = theta * theta
    big = np.abs(theta) > 1e-4
    safe = _where(big, theta, 1.0)
    beta = _where(
        big,
        1.0 / (safe * safe) - (1.0 + np.cos(theta)) / (2.0 * safe * np.sin(safe)),
        1.0 / 12.0 + t2 / 720.0,
    )
    pw = _cross(phi, w)
    return _vadd(_vsub(w, _vscale(pw, 0.5)), _vscale(_cross(phi, pw), beta))


def _where(condition, a, b):
    """``a`` where ``condition`` else ``b``; both branches finite (a blend, so it traces)."""
    if isinstance(condition, (bool, np.bool_)):
        return a if condition else b
    if isinstance(condition, np.ndarray):
        return np.where(condition, a, b)
    return _add(_mul(condition, a), _mul(_sub(1.0, condition), b))


# --------------------------------------------------------------------------------------------
# Tape: the entry algebra traced once per configuration, replayed on arrays
# --------------------------------------------------------------------------------------------


class _Var:
    """A traced entry: a value of the tape (one array over the samples at replay)."""

    __slots__ = ("id", "tape")

    def __init__(self, tape: _Tape, index: int):
        self.tape, self.id = tape, index

    def __array_ufunc__(self, ufunc, method, *inputs, **kwargs):
        if method != "__call__" or kwargs or ufunc.nout != 1:
            return NotImplemented
        return self.tape.record(ufunc, inputs)

    def __add__(self, other):
        return np.add(self, other)

    def __radd__(self, other):
        return np.add(other, self)

    def __sub__(self, other):
        return np.subtract(self, other)

    def __rsub__(self, other):
        return np.subtract(other, self)

    def __mul__(self, other):
        return np.multiply(self, other)

    def __rmul__(self, other):
        return np.multiply(other, self)

    def __truediv__(self, other):
        return np.true_divide(self, other)

    def __rtruediv__(self, other):
        return np.true_divide(other, self)

    def __neg__(self):
        return np.negative(self)

    def __gt__(self, other):
        return np.greater(self, other)


class _Tape:
    """Records the array operations of the entry algebra (constants fold at trace time)."""

    def __init__(self):
        self.code: list[tuple] = []  # (ufunc, output value, args: value ids (int) or floats)
        self.count = 0

    def variables(self, n: int) -> list[_Var]:
        out = [_Var(self, self.count + i) for i in range(n)]
        self.count += n
        return out

    def record(self, ufunc, inputs) -> _Var:
        args = []
        for x in inputs:
            if isinstance(x, _Var):
                if x.tape is not self:
                    raise ValueError("operands from two tapes")
                args.append(x.id)
            else:
                args.append(float(x))
        out = _Var(self, self.count)
        self.count += 1
        self.code.append((ufunc, out.id, tuple(args)))
        return out

    def compile(self, inputs: list[_Var], results: list) -> _Program:
        """Keep what the results need, and give every value a register (reused when dead)."""
        needed = {r.id for r in results if isinstance(r, _Var)}
        kept = []
        for ufunc, out, args in reversed(self.code):
            if out in needed:
                kept.append((ufunc, out, args))
                needed.update(a for a in args if isinstance(a, int))
        kept.reverse()
        last_use = {}
        for i, (_, _, args) in enumerate(kept):
            for a in args:
                if isinstance(a, int):
                    last_use[a] = i
        for r in results:
            if isinstance(r, _Var):
                last_use[r.id] = len(kept)
        register = {v.id: k for k, v in enumerate(inputs)}
        free: list[int] = []
        size = len(inputs)
        code = []
        for i, (ufunc, out, args) in enumerate(kept):
            operands = tuple(("r", register[a]) if isinstance(a, int) else ("c", a) for a in args)
            for a in args:  # an operand dying here may hold the output (elementwise ufuncs)
                if (
                    isinstance(a, int)
                    and last_use.get(a) == i
                    and register[a] >= len(inputs)
                    and register[a] not in free
                ):
                    free.append(register[a])
            if free:
                register[out] = free.pop()
            else:
                register[out] = size
                size += 1
            if last_use.get(out, -1) < i:  # computed but unused
                free.append(register[out])
            code.append((ufunc, register[out], operands))
        outputs = [
            ("r", register[r.id]) if isinstance(r, _Var) else ("c", float(r)) for r in results
        ]
        return _Program(code, size, len(inputs), outputs)


@dataclass(frozen=True)
class _Program:
    """A compiled tape: ``run`` evaluates it on arrays of samples."""

    code: list
    size: int
    n_inputs: int
    outputs: list

    def run(self, inputs: list[np.ndarray]) -> list:
        """Results (arrays, or floats for constant results) for input arrays of one length."""
        n = len(inputs[0]) if inputs else 1
        registers = list(inputs) + [np.empty(n) for _ in range(self.size - self.n_inputs)]
        for ufunc, out, operands in self.code:
            ufunc(*[registers[v] if kind == "r" else v for kind, v in operands], out=registers[out])
        return [registers[v].copy() if kind == "r" else v for kind, v in self.outputs]


def _as_array(x, n: int) -> np.ndarray:
    return np.broadcast_to(np.asarray(x, dtype=float), (n,))


# --------------------------------------------------------------------------------------------
# Batched exact closure
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Item:
    """A joint or frame placement in its parent joint, with the dimensions that move it."""

    parent: int
    placement: tuple
    dims: tuple  # ((k, kind, axis, point), ...) in file order


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
        mechanism,
        outputs,
        q: np.ndarray | None = None,
        dimensions: tuple[Dimension, ...] | None = None,
        tol: float | None = None,
        max_iterations: int = 12,
        linear: Sensitivities | None = None,
    ):
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

        moved_joints: dict[int, list] = {}
        moved_frames: dict[int, list] = {}
        for k, dim in enumerate(self.dimensions):
            joints, frames = directly_moved(model, dim)
            entry = (k, dim.kind, tuple(dim.axis_in_parent_joint), tuple(dim.point_in_parent_joint))
            for j in joints:
                moved_joints.setdefault(j, []).append(entry)
            for f in frames:
                moved_frames.setdefault(f, []).append(entry)

        self.passive = list(self.linear.passive_indices)
        column_of_joint = {}
        for j in range(1, model.njoints):
            if model.joints[j].nv == 1 and model.joints[j].idx_v in self.passive:
                column_of_joint[j] = self.passive.index(model.joints[j].idx_v)

        frames = {o.index for o in self.outputs if o.kind != "joint"}
        for loop in mechanism.loop_joints:
            frames.update((loop.frame_a, loop.frame_b))
        needed = set()
        for f in frames:
            needed.update(int(j) for j in model.supports[model.frames[f].parentJoint] if j > 0)
        self.joints: dict[int, tuple] = {}
        for j in sorted(needed):
            placement = _constant_placement(model.jointPlacements[j])
            motion = _constant_placement(model.jointPlacements[j].inverse() * data.liMi[j])
            spec = None
            if j in column_of_joint:
                s = pin.getJointJacobian(model, data, j, pin.LOCAL)[:, model.joints[j].idx_v]
                if np.allclose(s[:3], 0.0) and abs(np.linalg.norm(s[3:]) - 1) < 1e-12:
                    spec = (column_of_joint[j], "revolute", tuple(float(v) for v in s[3:]))
                elif np.allclose(s[3:], 0.0) and abs(np.linalg.norm(s[:3]) - 1) < 1e-12:
                    spec = (column_of_joint[j], "prismatic", tuple(float(v) for v in s[:3]))
                else:
                    raise UnsupportedError(
                        f"passive joint {model.names[j]!r}: only revolute and "
                        "prismatic passive joints are supported by the batch "
                        "closure"
                    )
            item = _Item(int(model.parents[j]), placement, tuple(moved_joints.get(j, ())))
            self.joints[j] = (item, motion, spec)
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
        self.loops = []
        for loop in mechanism.loop_joints:
            free = set(loop.clearance.free_components)
            rows = [c for c in range(6) if c not in free]
            rotation = _constant_placement(pin.SE3(loop.rotation, np.zeros(3)))[0]
            self.loops.append((loop.frame_a, loop.frame_b, rows, ALPHA in free, rotation))
        # nominal frame rotations (orientation outputs are rotation vectors of R R_0^T)
        self._frame_reference = {f: _transpose(_constant_placement(data.oMf[f])[0]) for f in frames}
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
        delta = tape.variables(len(self.passive))
        oMi, oMf = self._forward(dd, delta)
        values, states = self._residual(oMf)
        self._rows = len(values)
        self._evaluate = tape.compile(dd + delta, values + self._outputs(oMf, delta))
        self._step = None
        if self.passive and self.loops:
            increment = _newton_step(self._jacobian(oMi, states), values, len(self.passive))
            self._step = tape.compile(
                dd + delta, values + [_add(d, x) for d, x in zip(delta, increment)]
            )

    # -- kinematics ---------------------------------------------------------------------
    @staticmethod
    def _moved(item: _Item, dd: list):
        rotation, translation = item.placement
        for k, kind, axis, point in item.dims:
            if kind == "length":
                translation = _vadd(translation, tuple(_mul(a, dd[k]) for a in axis))
            else:
                e = _rotation(axis, np.cos(dd[k]), np.sin(dd[k]))
                rotation = _mat_mul(e, rotation)
                translation = _vadd(_mat_vec(e, _vsub(translation, point)), point)
        return rotation, translation

    def _forward(self, dd: list, delta: list):
        """World placements of the needed joints and frames, for deviations ``dd`` and passive
        increments ``delta`` (entries, one per dimension / passive joint)."""
        identity = ((1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0), (0.0, 0.0, 0.0))
        oMi = {0: identity}
        for j, (item, motion, spec) in self.joints.items():
            placement = _compose(_compose(oMi[item.parent], self._moved(item, dd)), motion)
            if spec is not None:
                column, kind, axis = spec
                d = delta[column]
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
        return oMi, oMf

    def _columns(self, oMi):
        """World axis and origin of every passive joint: (column, kind, w, p)."""
        columns = []
        for j, (_, _, spec) in self.joints.items():
            if spec is not None:
                column, kind, axis = spec
                columns.append((j, column, kind, _mat_vec(oMi[j][0], axis), oMi[j][1]))
        return columns

    def _residual(self, oMf):
        """Weighted residual rows of every loop, and the loop geometry for :meth:`_jacobian`."""
        values, states = [], []
        for frame_a, frame_b, rows, axis_mode, rotation in self.loops:
            ra, pc = oMf[frame_a]
            rb, pb = oMf[frame_b]
            rc = _mat_mul(ra, rotation)
            rel_r = _mat_mul(_transpose(rc), _mat_mul(rb, rotation))
            rel_t = _mat_t_vec(rc, _vsub(pb, pc))
            if axis_mode:  # as closure.py: only the axis must line up, the spin is free
                m = (rel_r[0], rel_r[3], rel_r[6])
                rot, theta = (0.0, _neg(np.arctan2(m[2], m[0])), np.arctan2(m[1], m[0])), m
            else:
                rot, theta = _log3(rel_r)
            error = (*rel_t, *rot)
            weights = [1.0 if c < ALPHA else self.length for c in rows]
            values.extend(_mul(error[c], w) for c, w in zip(rows, weights))
            states.append((frame_a, frame_b, rows, axis_mode, weights, rc, pc, pb, rot, theta))
        return values, states

    def _jacobian(self, oMi, states):
        r"""Exact derivatives of the residual rows by the passive increments, row by row.

        For a passive joint with world axis ``w`` through ``p``: point velocity
        ``w x (x - p)`` (revolute) or ``w`` (prismatic); then
        ``d t_rel = R_c^T (v_b - v_c - omega_a x (p_b - p_c))``, ``w_rel = R_c^T (omega_b -
        omega_a)`` and ``d log(R_rel) = J_l^{-1} w_rel`` (or the derivative of the axis angles).
        """
        zero = (0.0, 0.0, 0.0)
        columns = self._columns(oMi)
        derivatives = []
        for frame_a, frame_b, rows, axis_mode, weights, rc, pc, pb, rot, theta in states:
            per_column = {}
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
                if axis_mode:
                    m = theta
                    dm = _cross(wr, m)
                    d1 = _neg(
                        _sub(_mul(m[0], dm[2]), _mul(m[2], dm[0])) / (m[0] * m[0] + m[2] * m[2])
                    )
                    d2 = _sub(_mul(m[0], dm[1]), _mul(m[1], dm[0])) / (m[0] * m[0] + m[1] * m[1])
                    drot = (0.0, d1, d2)
                else:
                    drot = _jl_inverse(rot, theta, wr)
                derror = (*dt, *drot)
                per_column[column] = [_mul(derror[c], w) for c, w in zip(rows, weights)]
            for r in range(len(rows)):
                derivatives.append(
                    [per_column[c][r] if c in per_column else 0.0 for c in range(len(self.passive))]
                )
        return derivatives

    def _outputs(self, oMf, delta: list) -> list:
        values = []
        for output in self.outputs:
            if output.kind == "joint":
                idx_v = self.mechanism.model.joints[output.index].idx_v
                values.append(delta[self.passive.index(idx_v)] if idx_v in self.passive else 0.0)
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
        delta = dd @ self.linear.passive.T if self.passive else np.zeros((n, 0))
        delta = [np.ascontiguousarray(delta[:, k]) for k in range(delta.shape[1])]
        iterations = 0
        while True:
            if self._step is not None:
                delta = [_as_array(d, n) for d in self._step.run(columns + delta)[rows:]]
                iterations += 1
            result = self._evaluate.run(columns + delta)
            largest = max((float(np.max(np.abs(v))) for v in result[:rows]), default=0.0)
            if largest <= self.tol:
                return (
                    np.column_stack([_as_array(v, n) for v in result[rows:]])
                    if len(result) > rows
                    else np.zeros((n, 0))
                )
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
            raise ClearancePinError(
                f"deviations must have shape (N, {len(self.dimensions)}), got {dd.shape}"
            )
        out = np.empty((dd.shape[0], len(self.outputs)))
        for start in range(0, dd.shape[0], chunk):
            out[start : start + chunk] = self._close(dd[start : start + chunk]) - self._reference
        return out


def _newton_step(derivatives, values, n_passive: int) -> list:
    """Gauss-Newton increment ``-(J^T J)^{-1} J^T r`` per sample (entries), by Cholesky."""
    a = [[0.0] * n_passive for _ in range(n_passive)]
    g = [0.0] * n_passive
    for row, value in zip(derivatives, values):
        for i in range(n_passive):
            if isinstance(row[i], float) and row[i] == 0.0:
                continue
            g[i] = _add(g[i], _mul(row[i], value))
            for j in range(i + 1):
                a[i][j] = _add(a[i][j], _mul(row[i], row[j]))
    lower = [[0.0] * n_passive for _ in range(n_passive)]
    for i in range(n_passive):
        for j in range(i + 1):
            s = a[i][j]
            for k in range(j):
                s = _sub(s, _mul(lower[i][k], lower[j][k]))
            if i == j:
                lower[i][i] = np.sqrt(np.maximum(s, 1e-300))
            else:
                lower[i][j] = s / lower[j][j]
    y = [0.0] * n_passive
    for i in range(n_passive):
        s = _neg(g[i])
        for k in range(i):
            s = _sub(s, _mul(lower[i][k], y[k]))
        y[i] = s / lower[i][i]
    x = [0.0] * n_passive
    for i in reversed(range(n_passive)):
        s = y[i]
        for k in range(i + 1, n_passive):
            s = _sub(s, _mul(lower[k][i], x[k]))
        x[i] = s / lower[i][i]
    return x


# --------------------------------------------------------------------------------------------
# Monte Carlo
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class MonteCarloResult:
    """Statistics of the exact output deviations over the samples, per output.

    Attributes:
        outputs: the outputs.
        distribution: ``"uniform"`` or ``"normal"``.
        samples: number of samples.
        mean, std, minimum, maximum: per output [m or rad], shape (n_out,); ``std`` with ``n - 1``.
        points: a random subset of the deviations, shape (k, n_out), for plots.
        seconds: wall time.
    """

    outputs: tuple[Output, ...]
    distribution: str
    samples: int
    mean: np.ndarray
    std: np.ndarray
    minimum: np.ndarray
    maximum: np.ndarray
    points: np.ndarray
    seconds: float

    @property
    def three_sigma(self) -> np.ndarray:
        """``3 s`` per output [m or rad]: compare with the RSS band (normal inputs)."""
        return 3.0 * self.std

    @property
    def max_abs(self) -> np.ndarray:
        """Largest ``|deviation|`` per output: inside the worst case band (uniform inputs)."""
        return np.maximum(np.abs(self.minimum), np.abs(self.maximum))


def monte_carlo(
    mechanism,
    outputs,
    q: np.ndarray | None = None,
    samples: int = 100_000,
    distribution: Literal["uniform", "normal"] = "uniform",
    seed: int = 0,
    chunk: int = 1 << 16,
    keep: int = 2000,
    progress: bool | None = None,
    closure: BatchClosure | None = None,
    workers: int | None = None,
) -> MonteCarloResult:
    """Monte Carlo of the outputs with the loops closed exactly for every sample [F].

    Args:
        mechanism: :class:`~clearance_pin.mechanism.Mechanism` with dimensions.
        outputs: output specs or :class:`Output` objects (ignored if ``closure`` is given).
        q: configuration (default nominal); ignored if ``closure`` is given.
        samples: number of manufactured mechanisms.
        distribution: ``"uniform"`` (``U(-T/2, T/2)``) or ``"normal"`` (``sigma = T/6``).
        seed: seed of ``numpy.random.default_rng``; the results depend only on the seed and
            ``chunk`` (not on ``workers``).
        chunk: samples drawn per block.
        keep: how many deviations to keep for plots.
        progress: progress bar on stderr (None: only on a terminal and for long runs).
        closure: a prebuilt :class:`BatchClosure` of the configuration.
        workers: threads closing blocks in parallel (NumPy releases the GIL in its loops);
            default ``min(4, cpu_count)``; the draws stay sequential.

    Returns:
        :class:`MonteCarloResult`.
    """
    started = time.perf_counter()
    closure = closure or BatchClosure(mechanism, outputs, q)
    if isinstance(samples, bool) or int(samples) != samples or samples < 2:
        raise ClearancePinError(f"samples must be an integer >= 2, got {samples!r}")
    rng = np.random.default_rng(seed)
    half = np.array([d.half_tolerance for d in closure.dimensions])
    stats = _Moments(len(closure.outputs), keep)
    bar = Progress(
        samples,
        "Monte Carlo",
        enabled=progress if progress is not None else (None if samples >= 1_000_000 else False),
    )
    workers = min(4, os.cpu_count() or 1) if workers is None else max(1, int(workers))
    counts = [min(chunk, samples - start) for start in range(0, samples, chunk)]
    with ThreadPoolExecutor(workers) if workers > 1 else contextlib.nullcontext() as pool:
        pending: deque = deque()
        for count in counts:
            dd = monte_carlo_inputs(rng, half, count, distribution)
            if pool is None:
                stats.add(closure.solve(dd))
                bar.update(count)
                continue
            pending.append((count, pool.submit(closure.solve, dd)))
            while len(pending) > 2 * workers:
                done, future = pending.popleft()
                stats.add(future.result())
                bar.update(done)
        while pending:
            done, future = pending.popleft()
            stats.add(future.result())
            bar.update(done)
    bar.close()
    return MonteCarloResult(
        closure.outputs,
        distribution,
        samples,
        stats.mean(),
        stats.std(),
        stats.low,
        stats.high,
        np.vstack(stats.kept) if stats.kept else np.zeros((0, len(closure.outputs))),
        time.perf_counter() - started,
    )


class _Moments:
    """Running mean, variance (shifted sums), extremes and the first ``keep`` samples."""

    def __init__(self, n_out: int, keep: int):
        self.count, self.keep = 0, keep
        self.total, self.total_sq = np.zeros(n_out), np.zeros(n_out)
        self.low, self.high = np.full(n_out, np.inf), np.full(n_out, -np.inf)
        self.shift: np.ndarray | None = None
        self.kept: list[np.ndarray] = []

    def add(self, y: np.ndarray) -> None:
        if self.shift is None:
            self.shift = y.mean(axis=0)
        centred = y - self.shift
        self.total += centred.sum(axis=0)
        self.total_sq += np.sum(centred * centred, axis=0)
        self.low, self.high = (
            np.minimum(self.low, y.min(axis=0)),
            np.maximum(self.high, y.max(axis=0)),
        )
        room = self.keep - sum(len(k) for k in self.kept)
        if room > 0:
            self.kept.append(y[:room])
        self.count += len(y)

    def mean(self) -> np.ndarray:
        return self.shift + self.total / self.count

    def std(self) -> np.ndarray:
        centred_mean = self.total / self.count
        variance = (self.total_sq - self.count * centred_mean**2) / (self.count - 1)
        return np.sqrt(np.maximum(variance, 0.0))


# --------------------------------------------------------------------------------------------
# Exact worst case over the tolerance box
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class WorstCase:
    """True extremes of the output deviations over the tolerance box ``|dd_j| <= T_j/2``.

    Attributes:
        outputs: the outputs.
        lower, upper: smallest and largest deviation per output [m or rad], shape (n_out,).
        argmin, argmax: the deviations ``dd`` [m or rad] reaching them, shape (n_out, n_dim).
        linear: the first-order worst-case half band per output (for comparison).
        projected_gradient: optimality check, the largest projected gradient component times
            the half tolerance [output units] at the answers (0 at a vertex optimum).
    """

    outputs: tuple[Output, ...]
    lower: np.ndarray
    upper: np.ndarray
    argmin: np.ndarray
    argmax: np.ndarray
    linear: np.ndarray
    projected_gradient: np.ndarray

    @property
    def half_band(self) -> np.ndarray:
        """``max(|lower|, |upper|)`` per output: the exact worst-case half band."""
        return np.maximum(np.abs(self.lower), np.abs(self.upper))


def exact_worst_case(
    mechanism,
    outputs,
    q: np.ndarray | None = None,
    closure: BatchClosure | None = None,
    max_vertices: int = 4096,
    max_iterations: int = 50,
) -> WorstCase:
    """Exact (nonlinear) extremes of every output over the tolerance box, by optimisation.

    For each output and sign: the best vertex of the box (all ``2^n`` vertices when
    ``2^n <= max_vertices``, else the linear worst-case vertex and its one-coordinate flips),
    then a projected Newton ascent with finite-difference derivatives of the exact closure
    (free coordinates: Newton step on the concave part, gradient step otherwise; backtracking
    on the true value) until the projected gradient vanishes.

    Returns:
        :class:`WorstCase`.
    """
    closure = closure or BatchClosure(mechanism, outputs, q)
    half = np.array([d.half_tolerance for d in closure.dimensions])
    n_out, n_dim = len(closure.outputs), len(half)
    lower, upper = np.zeros(n_out), np.zeros(n_out)
    argmin, argmax = np.zeros((n_out, n_dim)), np.zeros((n_out, n_dim))
    kkt = np.zeros(n_out)
    vertices = _vertices(half, closure.linear.matrix, max_vertices)
    values = closure.solve(vertices) if len(vertices) else np.zeros((0, n_out))
    for i in range(n_out):
        for sign in (1.0, -1.0):

            def f(x, i=i, sign=sign):
                return sign * closure.solve(np.atleast_2d(x))[:, i]

            start = vertices[int(np.argmax(sign * values[:, i]))]
            x, value, pg = _projected_newton(f, start, half, max_iterations)
            if sign > 0:
                upper[i], argmax[i] = value, x
            else:
                lower[i], argmin[i] = -value, x
            kkt[i] = max(kkt[i], pg)
    return WorstCase(
        closure.outputs, lower, upper, argmin, argmax, closure.linear.worst_case(), kkt
    )


def _vertices(half: np.ndarray, matrix: np.ndarray, max_vertices: int) -> np.ndarray:
    n = len(half)
    if 2**n <= max_vertices:
        signs = np.array(list(itertools.product((-1.0, 1.0), repeat=n)))
        return signs * half
    starts = []
    for row in matrix:
        for sign in (1.0, -1.0):
            base = np.where(sign * row >= 0, 1.0, -1.0)
            starts.append(base)
            for j in range(n):
                flipped = base.copy()
                flipped[j] = -flipped[j]
                starts.append(flipped)
    return np.unique(np.array(starts), axis=0) * half


def _projected_newton(f, x: np.ndarray, half: np.ndarray, max_iterations: int):
    """Maximise ``f`` over ``|x_j| <= half_j`` from ``x``; returns (x, f(x), projected gradient)."""
    n = len(x)
    scale = np.where(half > 0, half, 1.0)
    active = half > 0
    h = 1e-3 * scale
    value = float(f(x)[0])
    pg = 0.0
    for _ in range(max_iterations):
        g, hessian = _derivatives(f, x, h)
        g_scaled = g * scale
        at_hi = x >= half - 1e-12 * scale
        at_lo = x <= -half + 1e-12 * scale
        free = active & ~((at_hi & (g > 0)) | (at_lo & (g < 0)))
        pg = float(np.max(np.abs(g_scaled[free]), initial=0.0))
        if not free.any():
            break
        step = np.zeros(n)
        hff = hessian[np.ix_(free, free)]
        try:
            chol = np.linalg.cholesky(-hff)
            step[free] = np.linalg.solve(chol.T, np.linalg.solve(chol, g[free]))
        except np.linalg.LinAlgError:
            step[free] = (
                g[free] * scale[free] ** 2 / max(np.linalg.norm(g_scaled[free]), 1e-300) * 2
            )
        trials = np.array([np.clip(x + t * step, -half, half) for t in 0.5 ** np.arange(30)])
        trial_values = f(trials)
        best = int(np.argmax(trial_values))
        gain = float(trial_values[best]) - value
        if gain <= 1e-15 * max(abs(value), 1e-300) or gain <= 0.0:
            break
        x, value = trials[best], float(trial_values[best])
    return x, value, pg


def _derivatives(f, x: np.ndarray, h: np.ndarray):
    """Central finite-difference gradient and Hessian of ``f`` at ``x`` (one batched call)."""
    n = len(x)
    points = [x]
    for i in range(n):
        for si in (1.0, -1.0):
            e = np.zeros(n)
            e[i] = si * h[i]
            points.append(x + e)
    pairs = [(i, j) for i in range(n) for j in range(i)]
    for i, j in pairs:
        for si, sj in ((1, 1), (1, -1), (-1, 1), (-1, -1)):
            e = np.zeros(n)
            e[i], e[j] = si * h[i], sj * h[j]
            points.append(x + e)
    y = f(np.array(points))
    g = np.array([(y[1 + 2 * i] - y[2 + 2 * i]) / (2 * h[i]) for i in range(n)])
    hessian = np.zeros((n, n))
    for i in range(n):
        hessian[i, i] = (y[1 + 2 * i] - 2 * y[0] + y[2 + 2 * i]) / (h[i] ** 2)
    base = 1 + 2 * n
    for p, (i, j) in enumerate(pairs):
        pp, pm, mp, mm = y[base + 4 * p : base + 4 * p + 4]
        hessian[i, j] = hessian[j, i] = (pp - pm - mp + mm) / (4 * h[i] * h[j])
    return g, hessian
