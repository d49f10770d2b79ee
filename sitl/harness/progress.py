"""A dependency-free progress bar for long runs (stderr; silent when stderr is not a terminal)."""
from __future__ import annotations

import sys
import time


class ProgressBar:
    """``with ProgressBar(total, "W3 cpd_ff") as bar: bar.update(k)`` — redraws at most 10 times a second."""

    def __init__(self, total: float, label: str = "", stream=None, enabled: bool | None = None, width: int = 30):
        self.total = max(float(total), 1e-12)
        self.label = label
        self.stream = stream or sys.stderr
        self.enabled = self.stream.isatty() if enabled is None else enabled
        self.width = width
        self._last = 0.0
        self._start = time.perf_counter()

    def update(self, done: float) -> None:
        if not self.enabled:
            return
        now = time.perf_counter()
        if now - self._last < 0.1 and done < self.total:
            return
        self._last = now
        frac = min(max(done / self.total, 0.0), 1.0)
        fill = int(round(frac * self.width))
        elapsed = now - self._start
        self.stream.write(f"\r{self.label} [{'#' * fill}{'.' * (self.width - fill)}] {100 * frac:5.1f}% "
                          f"{elapsed:5.1f}s")
        self.stream.flush()

    def __enter__(self) -> ProgressBar:
        return self

    def __exit__(self, *exc) -> None:
        if self.enabled:
            self.update(self.total)
            self.stream.write("\n")
            self.stream.flush()
