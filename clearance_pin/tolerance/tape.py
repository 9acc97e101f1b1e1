r"""Traced entry-wise array algebra for batched kinematics (used by :mod:`.batch_closure`).

Every 3-vector and 3x3 matrix entry is a Python float (the same for all samples: constants, the
exact zeros of planar mechanisms) or a per-sample value, so the arithmetic folds what does not
vary. The kinematics of one configuration is traced once in this algebra into a tape of NumPy
ufunc calls (dead values dropped, registers reused), which is then replayed on blocks of samples
with ``out=`` buffers: about 200 array operations per Newton iteration and output evaluation for
the slider-crank, some 0.4 us per sample.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, TypeAlias

import numpy as np
import pinocchio as pin

from ..errors import ArgumentError

_SNAP = 1e-14  # constant matrix entries below this are exact zeros (rpy round-off)

# --------------------------------------------------------------------------------------------
# Entry-wise algebra: an entry is a float (same for every sample), an array (N,) or a traced
# value (_Var); 3-vectors are 3-tuples, 3x3 matrices 9-tuples (row-major), placements (R, t)
# --------------------------------------------------------------------------------------------

#: one entry: a float (the same for every sample), an array (N,) or a traced value
Entry: TypeAlias = "float | np.ndarray | _Var"
#: a 3-vector (3 entries) or a 3x3 matrix (9 entries, row-major)
Entries: TypeAlias = "tuple[Entry, ...]"
#: a placement (R, t)
Placement: TypeAlias = "tuple[Entries, Entries]"


def _apply(ufunc: np.ufunc, *operands: Entry) -> Entry:
    """``ufunc(*operands)`` on entries: numpy hands it to :meth:`_Var.__array_ufunc__` when an
    operand is traced (numpy's stubs type that dispatch for one-operand ufuncs only)."""
    value: Entry = ufunc(*operands)
    return value


def _mul(a: Entry, b: Entry) -> Entry:
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


def _add(a: Entry, b: Entry) -> Entry:
    if isinstance(a, float) and a == 0.0:
        return b
    if isinstance(b, float) and b == 0.0:
        return a
    return a + b


def _neg(a: Entry) -> Entry:
    return -a if not (isinstance(a, float) and a == 0.0) else 0.0


def _sub(a: Entry, b: Entry) -> Entry:
    if isinstance(b, float) and b == 0.0:
        return a
    if isinstance(a, float) and a == 0.0:
        return -b
    return a - b


def _dot(a: Entries, b: Entries) -> Entry:
    return _add(_add(_mul(a[0], b[0]), _mul(a[1], b[1])), _mul(a[2], b[2]))


def _mat_vec(m: Entries, v: Entries) -> Entries:
    """``M v``; m: 9 entries, row-major."""
    return tuple(_dot(m[3 * i : 3 * i + 3], v) for i in range(3))


def _mat_t_vec(m: Entries, v: Entries) -> Entries:
    """``M^T v``."""
    return tuple(_dot((m[i], m[3 + i], m[6 + i]), v) for i in range(3))


def _mat_mul(a: Entries, b: Entries) -> Entries:
    cols = [(b[j], b[3 + j], b[6 + j]) for j in range(3)]
    return tuple(_dot(a[3 * i : 3 * i + 3], cols[j]) for i in range(3) for j in range(3))


def _transpose(m: Entries) -> Entries:
    return (m[0], m[3], m[6], m[1], m[4], m[7], m[2], m[5], m[8])


def _vadd(a: Entries, b: Entries) -> Entries:
    return tuple(_add(x, y) for x, y in zip(a, b))


def _vsub(a: Entries, b: Entries) -> Entries:
    return tuple(_sub(x, y) for x, y in zip(a, b))


def _vscale(a: Entries, s: Entry) -> Entries:
    return tuple(_mul(x, s) for x in a)


def _cross(a: Entries, b: Entries) -> Entries:
    return (
        _sub(_mul(a[1], b[2]), _mul(a[2], b[1])),
        _sub(_mul(a[2], b[0]), _mul(a[0], b[2])),
        _sub(_mul(a[0], b[1]), _mul(a[1], b[0])),
    )


def _compose(a: Placement, b: Placement) -> Placement:
    """Placement product ``a * b``; a placement is (R: 9 entries, t: 3 entries)."""
    return _mat_mul(a[0], b[0]), _vadd(_mat_vec(a[0], b[1]), a[1])


def _rotation(axis: Sequence[float], c: Entry, s: Entry) -> Entries:
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


def _constant_placement(placement: pin.SE3) -> tuple[tuple[float, ...], tuple[float, ...]]:
    def snap(v: float) -> float:
        return 0.0 if abs(v) < _SNAP else float(v)

    return (
        tuple(snap(v) for v in placement.rotation.reshape(-1)),
        tuple(snap(v) for v in placement.translation),
    )


def _log3(m: Entries) -> tuple[Entries, Entry]:
    """Rotation vector of a rotation (entries), for angles below pi, and the angle."""
    v = (0.5 * _sub(m[7], m[5]), 0.5 * _sub(m[2], m[6]), 0.5 * _sub(m[3], m[1]))
    if all(isinstance(x, float) and x == 0.0 for x in v):
        return (0.0, 0.0, 0.0), 0.0
    s = np.sqrt(_dot(v, v))
    c = 0.5 * (m[0] + m[4] + m[8] - 1.0)
    theta = _apply(np.arctan2, s, c)
    big = s > 1e-7
    safe = _where(big, s, 1.0)
    factor = _where(big, theta / safe, 1.0 + theta * theta / 6.0)
    return _vscale(v, factor), theta


def _jl_inverse(phi: Entries, theta: Entry, w: Entries) -> Entries:
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


def _where(condition: bool | np.bool_ | Entry, a: Entry, b: Entry) -> Entry:
    """``a`` where ``condition`` else ``b``; both branches finite (a blend, so it traces)."""
    if isinstance(condition, (bool, np.bool_)):
        return a if condition else b
    if isinstance(condition, np.ndarray):
        chosen: np.ndarray = np.where(condition, np.asarray(a), np.asarray(b))
        return chosen
    return _add(_mul(condition, a), _mul(_sub(1.0, condition), b))


# --------------------------------------------------------------------------------------------
# Tape: the entry algebra traced once per configuration, replayed on arrays
# --------------------------------------------------------------------------------------------


class _Var:
    """A traced entry: a value of the tape (one array over the samples at replay)."""

    __slots__ = ("id", "tape")
    tape: _Tape
    id: int

    def __init__(self, tape: _Tape, index: int) -> None:
        self.tape, self.id = tape, index

    def __array_ufunc__(
        self, ufunc: np.ufunc, method: str, *inputs: Any, **kwargs: Any
    ) -> object:  # a traced value, or NotImplemented
        if method != "__call__" or kwargs or ufunc.nout != 1:
            return NotImplemented
        return self.tape.record(ufunc, inputs)

    def __add__(self, other: Entry) -> _Var:
        return _traced(np.add, self, other)

    def __radd__(self, other: Entry) -> _Var:
        return _traced(np.add, other, self)

    def __sub__(self, other: Entry) -> _Var:
        return _traced(np.subtract, self, other)

    def __rsub__(self, other: Entry) -> _Var:
        return _traced(np.subtract, other, self)

    def __mul__(self, other: Entry) -> _Var:
        return _traced(np.multiply, self, other)

    def __rmul__(self, other: Entry) -> _Var:
        return _traced(np.multiply, other, self)

    def __truediv__(self, other: Entry) -> _Var:
        return _traced(np.true_divide, self, other)

    def __rtruediv__(self, other: Entry) -> _Var:
        return _traced(np.true_divide, other, self)

    def __neg__(self) -> _Var:
        return _traced(np.negative, self)

    def __gt__(self, other: Entry) -> _Var:
        return _traced(np.greater, self, other)


def _traced(ufunc: np.ufunc, *operands: Entry) -> _Var:
    """``ufunc(*operands)`` with a traced operand: a traced value (see :func:`_apply`)."""
    value: _Var = ufunc(*operands)
    return value


class _Tape:
    """Records the array operations of the entry algebra (constants fold at trace time)."""

    def __init__(self) -> None:
        self.code: list[
            tuple[np.ufunc, int, tuple[int | float, ...]]
        ] = []  # (ufunc, output value, args: value ids (int) or floats)
        self.count = 0

    def variables(self, n: int) -> list[_Var]:
        out = [_Var(self, self.count + i) for i in range(n)]
        self.count += n
        return out

    def record(self, ufunc: np.ufunc, inputs: Sequence[Entry]) -> _Var:
        args: list[int | float] = []
        for x in inputs:
            if isinstance(x, _Var):
                if x.tape is not self:
                    raise ArgumentError(
                        "operand", "a value recorded on this tape", x, "it is from another tape"
                    )
                args.append(x.id)
            else:
                args.append(float(x))
        out = _Var(self, self.count)
        self.count += 1
        self.code.append((ufunc, out.id, tuple(args)))
        return out

    def compile(self, inputs: list[_Var], results: Sequence[Entry]) -> _Program:
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


#: an operand of a compiled tape: ("r", register index) or ("c", constant float)
Operand: TypeAlias = tuple[str, Any]
#: one step of a compiled tape: (ufunc, output register, operands)
Instruction: TypeAlias = tuple[np.ufunc, int, tuple[Operand, ...]]


@dataclass(frozen=True)
class _Program:
    """A compiled tape: ``run`` evaluates it on arrays of samples."""

    code: list[Instruction]
    size: int
    n_inputs: int
    outputs: list[Operand]

    def run(self, inputs: list[np.ndarray]) -> list[np.ndarray | float]:
        """Results (arrays, or floats for constant results) for input arrays of one length."""
        n = len(inputs[0]) if inputs else 1
        registers = list(inputs) + [np.empty(n) for _ in range(self.size - self.n_inputs)]
        for ufunc, out, operands in self.code:
            ufunc(*[registers[v] if kind == "r" else v for kind, v in operands], out=registers[out])
        return [registers[v].copy() if kind == "r" else v for kind, v in self.outputs]


def _as_array(x: np.ndarray | float, n: int) -> np.ndarray:
    array: np.ndarray = np.broadcast_to(np.asarray(x, dtype=float), (n,))
    return array


# --------------------------------------------------------------------------------------------
# Batched exact closure
# --------------------------------------------------------------------------------------------


#: a dimension moving a placement: (its index k, kind, axis, point) in the parent joint frame
Moved: TypeAlias = tuple[int, str, tuple[float, ...], tuple[float, ...]]


@dataclass(frozen=True)
class _Item:
    """A joint or frame placement in its parent joint, with the dimensions that move it."""

    parent: int
    placement: tuple[tuple[float, ...], tuple[float, ...]]
    dims: tuple[Moved, ...]  # in file order
