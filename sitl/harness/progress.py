"""The one progress helper of the harness: a tqdm bar on a terminal, periodic log lines to stderr otherwise.

``with ProgressBar(total, "W3 C-PD+FF exact", unit="tick") as bar: bar.update(done)`` — ``done`` is
the absolute count. On a terminal it draws a tqdm bar; when stderr is not a terminal (a log
file, CI, a pipe) it writes one line every ``interval`` seconds (done/total, %, elapsed, ETA)
and one at the end. Leaving the block by an exception (Ctrl-C, an error) closes the bar where
it stands: a stopped run never shows 100 %. Missions, the launcher, ``openloop`` and
campaigns (:class:`~sitl.harness.campaign.CampaignProgress`) all use it.
"""
from __future__ import annotations

import sys
import time
from collections.abc import Callable
from typing import Any, TextIO

__all__ = ["ProgressBar"]


def _isatty(stream: Any) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


class ProgressBar:
    """See the module docstring. ``enabled``: None = on (bar or log lines), False = silent."""

    def __init__(self, total: float, label: str = "", stream: TextIO | None = None, enabled: bool | None = None,
                 unit: str = "", interval: float = 10.0, initial: float = 0.0,
                 line: Callable[[], str] | None = None):
        self.total = max(float(total), 1e-12)
        self.label, self.unit, self.interval = label, unit, float(interval)
        self.stream = stream or sys.stderr
        self.enabled = enabled is not False
        self.done = float(initial)
        self._line = line
        self._t0 = self._last = time.monotonic()
        self._bar: Any = None
        if self.enabled and _isatty(self.stream):
            from tqdm import tqdm
            self._bar = tqdm(total=total, initial=initial, desc=label, unit=unit or "it", file=self.stream,
                             dynamic_ncols=True, mininterval=0.2, leave=True)

    @property
    def is_bar(self) -> bool:
        """Drawing a terminal bar (True) or writing log lines (False)?"""
        return self._bar is not None

    def line(self) -> str:
        """The log line: label, done/total, %, elapsed and ETA."""
        if self._line is not None:
            return self._line()
        el = time.monotonic() - self._t0
        frac = min(self.done / self.total, 1.0)
        eta = f"{el * (1 - frac) / frac:.0f} s" if frac > 0 else "?"
        unit = f" {self.unit}" if self.unit else ""
        return (f"{self.label}: {self.done:g}/{self.total:g}{unit} ({100 * frac:.0f} %), "
                f"elapsed {el:.0f} s, ETA {eta}")

    def update(self, done: float) -> None:
        """Set the absolute progress to ``done``."""
        step, self.done = done - self.done, float(done)
        if not self.enabled:
            return
        if self._bar is not None:
            self._bar.update(step)
            return
        now = time.monotonic()
        if now - self._last >= self.interval:
            self._last = now
            print(self.line(), file=self.stream, flush=True)

    def set_postfix(self, **kw: Any) -> None:
        if self._bar is not None:
            self._bar.set_postfix(refresh=False, **kw)

    def close(self, completed: bool = True) -> None:
        """End the bar; in log mode write the last line if it finished (never a false 100 %)."""
        if self._bar is not None:
            self._bar.close()
            self._bar = None
        elif self.enabled and completed and self.done >= self.total:
            print(self.line(), file=self.stream, flush=True)
        self.enabled = False

    def __enter__(self) -> ProgressBar:
        return self

    def __exit__(self, exc_type, *exc) -> None:
        self.close(completed=exc_type is None)
