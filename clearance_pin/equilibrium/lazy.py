"""Containers computed on first access, for the parts of an answer a caller rarely reads.

A planner re-solves thousands of times and reads a few numbers of each answer; every body's motion,
world placements, contact lists and descriptions of free motions are computed only when read, and
pickled computed (answers travel to other processes).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from typing import NoReturn, TypeVar, overload

import pinocchio as pin

from ..numerics import Array

K = TypeVar("K")
V = TypeVar("V")
T = TypeVar("T")


def _computed() -> NoReturn:
    raise AssertionError("computed once")  # pragma: no cover (the value is kept)


class LazyMapping(Mapping[K, V]):
    """A read-only mapping computed by ``compute()`` on first access (for answers a caller
    rarely reads, such as every body's motion after each of thousands of re-solves)."""

    def __init__(self, compute: Callable[[], dict[K, V]]) -> None:
        self._compute = compute
        self._value: dict[K, V] | None = None

    def _get(self) -> dict[K, V]:
        if self._value is None:
            self._value = self._compute()
            self._compute = _computed  # what it read (a whole geometry, maybe) is let go
        return self._value

    def __getitem__(self, key: K) -> V:
        return self._get()[key]

    def __iter__(self) -> Iterator[K]:
        return iter(self._get())

    def __len__(self) -> int:
        return len(self._get())

    def __repr__(self) -> str:
        return repr(self._get())

    def __reduce__(self) -> tuple[type[dict[K, V]], tuple[dict[K, V]]]:
        return (dict, (self._get(),))  # pickled computed: results travel to other processes


class LazySequence(Sequence[T]):
    """A read-only sequence computed by ``compute()`` on first access (world placements of every
    body, descriptions of free motions: answers a planner re-solving thousands of times rarely
    reads)."""

    def __init__(self, compute: Callable[[], Iterable[T]]) -> None:
        self._compute = compute
        self._value: tuple[T, ...] | None = None

    def _get(self) -> tuple[T, ...]:
        if self._value is None:
            self._value = tuple(self._compute())
            self._compute = _computed  # what it read is let go
        return self._value

    def __len__(self) -> int:
        return len(self._get())

    @overload
    def __getitem__(self, index: int) -> T: ...

    @overload
    def __getitem__(self, index: slice) -> tuple[T, ...]: ...

    def __getitem__(self, index: int | slice) -> T | tuple[T, ...]:
        return self._get()[index]

    def __eq__(self, other: object) -> bool:
        return tuple(self) == tuple(other) if isinstance(other, Sequence) else NotImplemented

    def __hash__(self) -> int:
        return hash(self._get())

    def __add__(self, other: Iterable[T]) -> LazySequence[T]:
        return LazySequence(lambda: (*self, *other))

    def __reduce__(self) -> tuple[type[tuple[T, ...]], tuple[tuple[T, ...]]]:
        return (tuple, (self._get(),))  # pickled computed: results travel to other processes

    def __repr__(self) -> str:
        return repr(self._get())


def placements(twists: Array, nominal: Sequence[pin.SE3]) -> LazySequence[pin.SE3]:
    r"""World placements of every body at a linear solution, :math:`\exp(\xi_b)\, oM_{b0}`,
    computed on first access."""
    return LazySequence(
        lambda: (
            nominal[0],
            *(pin.exp6(pin.Motion(twists[i])) * nominal[i] for i in range(1, len(nominal))),
        )
    )


__all__ = ["LazyMapping", "LazySequence", "placements"]
