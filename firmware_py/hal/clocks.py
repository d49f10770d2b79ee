"""Clocks for the firmware's scheduler: wall time, simulated time, and lockstep time paced on the wall.

* :class:`WallClock` — ``time.monotonic_ns``; sleeps to about 1 ms before a
  deadline and then spins (start error p99 ≈ 0.7 ms on an idle machine, see
  ``docs/platform-notes.md``).
* :class:`SimClock` — simulated time that moves only when told (lockstep runs).
* :class:`LockstepPacedClock` — lockstep time that also waits for the wall
  clock at a given speed-up (``--speedup``), counting the slots it was late for.

All times are integer nanoseconds.
"""
from __future__ import annotations

import math
import time
from typing import Protocol, runtime_checkable

import numpy as np

__all__ = ["Clock", "LockstepPacedClock", "RingBuffer", "SimClock", "WallClock"]


class RingBuffer:
    """Fixed-size ring of int64 samples (ns); preallocated so a tick allocates nothing."""

    __slots__ = ("buf", "i", "n")

    def __init__(self, size: int):
        self.buf = np.zeros(size, dtype=np.int64)
        self.i = 0
        self.n = 0

    def push(self, v: int) -> None:
        self.buf[self.i] = v
        self.i += 1
        if self.i == self.buf.size:
            self.i = 0
        if self.n < self.buf.size:
            self.n += 1

    def percentiles_us(self) -> dict:
        if self.n == 0:
            return {"p50_us": None, "p99_us": None, "max_us": None, "mean_us": None, "n": 0}
        d = self.buf[: self.n]
        p50, p99 = np.percentile(d, (50.0, 99.0))
        return {"p50_us": float(p50) / 1e3, "p99_us": float(p99) / 1e3,
                "max_us": float(d.max()) / 1e3, "mean_us": float(d.mean()) / 1e3, "n": int(self.n)}


@runtime_checkable
class Clock(Protocol):
    """Source of monotonic time and of waiting, injected into :class:`Scheduler`."""

    def now_ns(self) -> int:
        """Monotonic time (integer ns)."""
        ...

    def sleep_until(self, t_ns: int) -> None:
        """Return at, or just after, the monotonic time ``t_ns`` (ns); at once if it has passed."""
        ...


class WallClock:
    """Real time from ``time.monotonic_ns`` (system-wide, comparable across processes).

    Parameters
    ----------
    spin_ns : int
        How long before a deadline (ns) :meth:`sleep_until` stops sleeping and
        busy-waits. OS sleeps overshoot by up to about a millisecond; the spin
        absorbs that, at the cost of up to ``spin_ns`` of CPU per wait.
    """

    simulated = False

    def __init__(self, spin_ns: int = 1_000_000):
        if spin_ns < 0:
            raise ValueError(f"spin_ns must be >= 0, got {spin_ns}")
        self.spin_ns = int(spin_ns)

    def now_ns(self) -> int:
        """Monotonic time (ns)."""
        return time.monotonic_ns()

    def sleep_until(self, t_ns: int) -> None:
        """Sleep until ``spin_ns`` before ``t_ns`` (ns), then spin until ``t_ns``."""
        remaining = t_ns - time.monotonic_ns()
        if remaining > self.spin_ns:
            time.sleep((remaining - self.spin_ns) * 1e-9)
        while time.monotonic_ns() < t_ns:
            pass


class SimClock:
    """Simulated (lockstep) time: deterministic, never sleeps.

    Parameters
    ----------
    start_ns : int
        Initial time (ns).

    Notes
    -----
    Time only moves through :meth:`sleep_until` and :meth:`advance`, so it does
    not advance while a task computes; :class:`Scheduler` therefore measures
    compute time with ``time.perf_counter_ns`` under a ``SimClock``.
    """

    simulated = True

    def __init__(self, start_ns: int = 0):
        self._now = int(start_ns)

    def now_ns(self) -> int:
        """Current simulated time (ns)."""
        return self._now

    def sleep_until(self, t_ns: int) -> None:
        """Jump to ``t_ns`` (ns) if it is in the future; time never goes backwards."""
        if t_ns > self._now:
            self._now = int(t_ns)

    def advance_to(self, t_ns: int) -> None:
        """Move time forward to ``t_ns`` (ns) if it is in the future."""
        self.sleep_until(t_ns)

    def advance(self, dt_ns: int) -> None:
        """Move time forward by ``dt_ns`` (ns, >= 0)."""
        if dt_ns < 0:
            raise ValueError(f"SimClock cannot go backwards (dt_ns={dt_ns})")
        self._now += int(dt_ns)


class LockstepPacedClock(SimClock):
    """Simulated (lockstep) time, paced against the wall clock at ``speedup`` × real time.

    For SITL runs that should go at (a multiple of) real time: time is the
    simulation's, moved only by :meth:`sleep_until` and :meth:`advance_to`, so a
    slow tick is never skipped (the plant advanced exactly one step per tick,
    and must stay in lockstep) — the run simply falls behind the wall clock, as
    ArduPilot's SITL does. :meth:`sleep_until` waits for the slot's wall-clock
    deadline (sleep, then spin the last ``spin_ns``); deadlines already past on
    arrival are counted in :attr:`late` with the worst lag in
    :attr:`max_lag_ns`. The wall-clock origin is set by the first
    :meth:`sleep_until`.
    """

    def __init__(self, speedup: float = 1.0, start_ns: int = 0, spin_ns: int = 1_000_000):
        if not (speedup > 0 and math.isfinite(speedup)):
            raise ValueError(f"speedup must be positive and finite, got {speedup}")
        super().__init__(start_ns)
        self.speedup = float(speedup)
        self.spin_ns = int(spin_ns)
        self._start = int(start_ns)
        self._wall0: int | None = None
        self.late = 0
        self.max_lag_ns = 0
        self.wake_error = RingBuffer(4096)   # wall-clock start error of each slot (ns): the loop's start jitter

    def sleep_until(self, t_ns: int) -> None:
        if self._wall0 is None:
            # The first slot anchors the wall clock: it starts now, by definition on time
            self._wall0 = time.monotonic_ns() - int((t_ns - self._start) / self.speedup)
            super().sleep_until(t_ns)
            return
        deadline = self._wall0 + int((t_ns - self._start) / self.speedup)
        lag = time.monotonic_ns() - deadline
        if lag > 0:
            self.late += 1
            self.max_lag_ns = max(self.max_lag_ns, lag)
        else:
            remaining = -lag
            if remaining > self.spin_ns:
                time.sleep((remaining - self.spin_ns) * 1e-9)
            while time.monotonic_ns() < deadline:
                pass
        self.wake_error.push(time.monotonic_ns() - deadline)
        super().sleep_until(t_ns)

    def advance_to(self, t_ns: int) -> None:
        """Move simulated time forward to ``t_ns`` without waiting (the plant's reply)."""
        super().sleep_until(t_ns)
