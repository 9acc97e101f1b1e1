"""Progress of long work on standard error, through tqdm: an estimate of the time left, the rate,
a label a user reads ("solving load cases", not a function's name); a notebook gets its widget
(``tqdm.auto``). Shown only when standard error is a terminal (or a notebook), unless forced;
tqdm is imported only when a bar is shown."""

from __future__ import annotations

import sys
from typing import Any


class Progress:
    """Counts work done; tqdm redraws at most ten times a second.

    Args:
        total: number of items.
        label: what is being done, as a user reads it.
        enabled: None: only when stderr is a terminal; True/False to force.
        unit: what one item is (``"case"``, ``"position"``, ``"sample"``).
    """

    def __init__(
        self, total: int, label: str = "", enabled: bool | None = None, unit: str = "it"
    ) -> None:
        self.total = max(int(total), 1)
        self.label = label
        self.enabled = _interactive() if enabled is None else enabled
        self.done = 0
        self._bar: Any = None
        if self.enabled:
            from tqdm.auto import tqdm

            self._bar = tqdm(
                total=self.total, desc=label, unit=unit, file=sys.stderr, mininterval=0.1,
                dynamic_ncols=True, leave=True,
            )  # fmt: skip

    def update(self, count: int = 1) -> None:
        """Record ``count`` more items done."""
        self.done += count
        if self._bar is not None:
            self._bar.update(count)

    def close(self) -> None:
        """End the bar (its last line stays, with the time taken)."""
        if self._bar is not None:
            self._bar.close()
            self._bar = None


def _interactive() -> bool:
    """Standard error is a terminal, or this runs in a Jupyter kernel."""
    if sys.stderr.isatty():
        return True
    return "ipykernel" in sys.modules


__all__ = ["Progress"]
