"""A minimal progress bar on standard error, shown only when standard error is a terminal."""

from __future__ import annotations

import sys
import time


class Progress:
    """Counts work done and redraws one line at most ten times a second.

    Args:
        total: number of items.
        label: text before the bar.
        enabled: None: only when stderr is a terminal; True/False to force.
    """

    def __init__(self, total: int, label: str = "", enabled: bool | None = None) -> None:
        self.total = max(int(total), 1)
        self.label = label
        self.enabled = sys.stderr.isatty() if enabled is None else enabled
        self.done = 0
        self._started = time.perf_counter()
        self._drawn = 0.0

    def update(self, count: int = 1) -> None:
        """Record ``count`` more items done."""
        self.done += count
        now = time.perf_counter()
        if self.enabled and (now - self._drawn > 0.1 or self.done >= self.total):
            self._drawn = now
            fraction = min(self.done / self.total, 1.0)
            bar = "#" * int(30 * fraction)
            rate = self.done / max(now - self._started, 1e-9)
            sys.stderr.write(f"\r{self.label} [{bar:<30}] {self.done}/{self.total} {rate:,.0f}/s")
            sys.stderr.flush()

    def close(self) -> None:
        """End the line."""
        if self.enabled:
            sys.stderr.write("\n")
            sys.stderr.flush()
