"""The batches an executor's chunks return, read as one batch.

With ``executor=``, :func:`.batch.solve_many` sends each chunk of cases to a task that runs
``solve_many`` itself (so a chunk takes the batched engines: closed forms of a tree's blocks,
Newton on stacked arrays, the compiled kernel) and returns its batch; a batch of closed forms
travels as its arrays, not as assembled answers. :class:`ChainedBatch` reads those batches in case
order: its whole-batch readers concatenate theirs, its items are theirs, pointed at the caller's
mechanism.
"""

from __future__ import annotations

import bisect
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from .batch import EquilibriumBatch
from .method import Method


class ChainedBatch(EquilibriumBatch):
    """Batches of consecutive cases (``parts``), read as one :class:`~.batch.EquilibriumBatch`."""

    def __init__(self, parts: list[EquilibriumBatch], mechanism: Any):
        self._parts = parts
        self._starts = list(np.cumsum([0] + [len(part) for part in parts[:-1]]))
        total = sum(len(part) for part in parts)
        super().__init__([None] * total, None, self._item, mechanism)

    def _item(self, index: int) -> Any:
        """Case ``index``: its part's item, pointed at the caller's mechanism."""
        at = bisect.bisect_right(self._starts, index) - 1
        item = self._parts[at][index - self._starts[at]]
        if isinstance(item, Exception):
            return item
        linear = item.linear
        if linear is not None:
            linear = replace(linear, mechanism=self._owner)
        return replace(item, mechanism=self._owner, linear=linear)

    def __reduce__(self) -> tuple[Any, ...]:
        return (ChainedBatch, (self._parts, self._owner))

    def _joined(self, read: Callable[[Any], np.ndarray]) -> np.ndarray:
        return np.concatenate([read(part) for part in self._parts])

    def torsors(self, joint: str) -> np.ndarray:
        return self._joined(lambda part: part.torsors(joint))

    def deflections(self, joint: str) -> np.ndarray:
        return self._joined(lambda part: part.deflections(joint))

    def frame_displacements(self, frame: str) -> tuple[np.ndarray, np.ndarray]:
        pairs = [part.frame_displacements(frame) for part in self._parts]
        return np.concatenate([t for t, _ in pairs]), np.concatenate([r for _, r in pairs])

    def reactions(self, joint: str, frame: str = "joint", part: str | None = None) -> np.ndarray:
        return self._joined(lambda batch: batch.reactions(joint, frame, part))

    def contact_forces(self, joint: str) -> np.ndarray:
        return self._joined(lambda part: part.contact_forces(joint))

    def contact_points(self, joint: str) -> tuple[str, ...]:
        return self._parts[0].contact_points(joint)

    def drive_torques(self) -> dict[str, np.ndarray]:
        tables = [part.drive_torques() for part in self._parts]
        return {name: np.concatenate([table[name] for table in tables]) for name in tables[0]}

    @property
    def ok(self) -> np.ndarray:
        return self._joined(lambda part: part.ok)

    @property
    def energy(self) -> np.ndarray:
        return self._joined(lambda part: part.energy)

    @property
    def statuses(self) -> list[str]:
        return [status for part in self._parts for status in part.statuses]

    @property
    def methods(self) -> list[Method | str]:
        return [method for part in self._parts for method in part.methods]


__all__ = ["ChainedBatch"]
