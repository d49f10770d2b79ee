"""Fixed-rate task scheduler in the style of ArduPilot's ``AP_Scheduler``, with an injectable clock.

Timing model
------------
* **Absolute grid.** The base loop runs on slots at ``t0 + k·period`` (integer
  nanoseconds, ``period = round(1e9 / loop_rate_hz)``; ``t0`` is the clock time
  at the first :meth:`Scheduler.run_tick`, or the value given to
  :meth:`Scheduler.start`). The loop always waits for an absolute deadline,
  never ``sleep(period)``, so timing errors do not accumulate: there is no drift.
* **Tasks.** Each task's rate must divide the loop rate exactly; a task of rate
  ``r`` runs every ``loop_rate / r`` slots, on the slots where
  ``k % period_ticks == 0``. ``k`` counts skipped slots too, so every task stays
  phase-locked to the grid at its exact rate. The tasks due in a slot run when
  the slot starts, in list order, and each is called with the slot's scheduled
  time ``t0 + k·period`` (ns), not the time it actually started.
* **Overruns.** If, after a slot's tasks have run, the clock is already past
  the start of the next slot, the tick is an *overrun*: it is counted for the
  loop and for every task of that slot whose run ended after the next slot
  started. Every slot whose start time has already passed is then *skipped*
  (counted in ``skipped_slots``; a task due in a skipped slot misses that run)
  and the next run happens at the next future slot of the same grid. The loop
  never bursts to catch up and never shifts its phase. Example: a 120 ms run on
  a 50 ms grid skips two slots and the next run starts 150 ms after the late one.
* **Gaps between calls.** If the caller itself comes back more than a period
  late (a stall between :meth:`Scheduler.run_tick` calls, or a ``t0`` in the
  past), the slots that have completely passed are skipped the same way; this
  is counted in ``skipped_slots`` but is not an overrun.
* **Faults.** A task raising an ``Exception`` does not stop the scheduler (the
  vehicle must keep flying): the error is counted per task and its ``repr`` kept,
  and the remaining tasks run. ``BaseException`` (``KeyboardInterrupt``,
  ``SystemExit``) still propagates, and so does a Ctrl-C wrapped in an
  ``Exception`` (a compiled call interrupted mid-way raises a SystemError from it).
* **Measurements.** Per task, over a ring buffer of the last ``window`` runs:
  compute time (end − start of the call) and start jitter (actual start −
  scheduled slot time), both reported in µs as p50 / p99 / max / mean. Start
  jitter and overrun checks use the scheduler's clock. Compute time uses the
  scheduler's clock too, except under :class:`SimClock`, where simulated time
  stands still while a task computes: there it is measured with
  ``time.perf_counter_ns`` (real CPU-side duration), so start jitter is 0 under
  a plain :class:`SimClock` while compute times stay meaningful.

The clocks are in :mod:`firmware_py.hal.clocks`. Real-time notes (measured, see
``docs/platform-notes.md``): ``gc.collect(); gc.freeze()`` after start-up keeps
a full collection (≈ 56 ms with the stack loaded) out of the loop; SCHED_FIFO,
where permitted, is the caller's business.
"""
from __future__ import annotations

import gc
import math
import sys
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

from .clocks import Clock, RingBuffer

__all__ = ["GIL_SWITCH_INTERVAL_S", "Scheduler", "Task", "TaskStats", "interrupt_in", "settle_for_loop",
           "shorten_gil_switch"]

GIL_SWITCH_INTERVAL_S = 0.0005
"""How long (s) another Python thread may keep the interpreter before the loop's thread gets it back. CPython's
default is 5 ms: a link thread parsing a flood of hostile datagrams then started the 20 Hz loop up to 5 ms late."""


def shorten_gil_switch() -> None:
    """A loop paced on the wall clock: :data:`GIL_SWITCH_INTERVAL_S` for the whole process (threads' results are
    the same; only who runs when changes)."""
    sys.setswitchinterval(GIL_SWITCH_INTERVAL_S)


def settle_for_loop(realtime: bool) -> None:
    """Just before a process's loop starts: a full collection and ``gc.freeze()`` (one would cost more than a
    tick), and on the wall clock (``realtime``) the short interpreter switch of :func:`shorten_gil_switch`."""
    gc.collect()
    gc.freeze()
    if realtime:
        shorten_gil_switch()


def interrupt_in(exc: BaseException) -> KeyboardInterrupt | None:
    """The Ctrl-C an exception carries as its cause or context, or None: a KeyboardInterrupt that lands inside a
    compiled call (numba boxing a kernel's result) comes back as a SystemError "returned a result with an exception
    set" raised from it."""
    seen: set[int] = set()
    e: BaseException | None = exc
    while e is not None and id(e) not in seen:
        if isinstance(e, KeyboardInterrupt):
            return e
        seen.add(id(e))
        e = e.__cause__ or e.__context__
    return None


def _reraise_interrupt(exc: BaseException) -> None:
    """A task's exception that carries a Ctrl-C stops the run as a Ctrl-C, not as a task's fault."""
    interrupt = interrupt_in(exc)
    if interrupt is not None:
        raise interrupt


@dataclass
class Task:
    """A periodic job.

    Attributes
    ----------
    name : str
        Unique name (the key in :meth:`Scheduler.stats`).
    rate_hz : float
        Run rate (Hz); must divide the scheduler's loop rate exactly.
    fn : Callable[[int], None]
        Called with the scheduled time of its slot (ns, on the absolute grid).
    """

    name: str
    rate_hz: float
    fn: Callable[[int], None]


@dataclass
class TaskStats:
    """Counters and timing rings of one task.

    Attributes
    ----------
    window : int
        Number of most recent runs kept for the percentiles.
    runs : int
        Calls made, including those that raised.
    overruns : int
        Runs that ended after the next base-loop slot had started (made the loop late).
    skipped_slots : int
        Runs missed because their slot was skipped after an overrun or a stall.
    errors : int
        Runs that raised an ``Exception``.
    last_error : str or None
        ``repr`` of the last exception raised.
    """

    window: int = 4096
    runs: int = 0
    overruns: int = 0
    skipped_slots: int = 0
    errors: int = 0
    last_error: str | None = None
    _compute: RingBuffer = field(init=False, repr=False, compare=False)
    _jitter: RingBuffer = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if self.window < 1:
            raise ValueError(f"window must be >= 1, got {self.window}")
        self._compute = RingBuffer(self.window)
        self._jitter = RingBuffer(self.window)

    def compute_percentiles_us(self) -> dict:
        """Compute time of the last ``window`` runs (µs).

        Returns
        -------
        dict
            ``{"p50_us", "p99_us", "max_us", "mean_us", "n"}``; the values are
            ``None`` before the first run. Measured on the scheduler's clock,
            or with ``time.perf_counter_ns`` under :class:`SimClock`.
        """
        return self._compute.percentiles_us()

    def start_jitter_percentiles_us(self) -> dict:
        """Start jitter (actual start − scheduled slot time) of the last ``window`` runs (µs).

        Same keys as :meth:`compute_percentiles_us`; always measured on the
        scheduler's clock (0 under a plain :class:`SimClock`). It includes the
        compute time of the tasks run before this one in the same slot.
        """
        return self._jitter.percentiles_us()


def _multiples_in(every: int, a: int, b: int) -> int:
    """Number of multiples of ``every`` in the integer range [a, b)."""
    return -(-b // every) + (-a // every)


class Scheduler:
    """Run tasks at fixed rates on an absolute time grid (see the module docstring).

    Parameters
    ----------
    clock : Clock
        Time source: :class:`WallClock` on the vehicle, :class:`SimClock` in lockstep SITL and tests.
    loop_rate_hz : float
        Base loop rate (Hz). The period is ``round(1e9 / loop_rate_hz)`` ns.
    tasks : list of Task
        Run in this order within a slot. Each ``loop_rate_hz / rate_hz`` must be
        an integer >= 1 (within 1e-9), and names must be unique.
    window : int
        Runs kept per task for the compute-time and jitter percentiles.

    Raises
    ------
    ValueError
        On a non-positive rate, a task rate that does not divide the loop rate,
        or a duplicate task name.
    """

    def __init__(self, clock: Clock, loop_rate_hz: float, tasks: list[Task], window: int = 4096):
        if not (math.isfinite(loop_rate_hz) and loop_rate_hz > 0):
            raise ValueError(f"loop rate must be a positive finite number of Hz, got {loop_rate_hz!r}")
        self._clock = clock
        self._loop_rate_hz = float(loop_rate_hz)
        self._period_ns = round(1e9 / loop_rate_hz)
        if self._period_ns < 1:
            raise ValueError(f"loop rate {loop_rate_hz} Hz is too high for a 1 ns grid")
        # Simulated time stands still while a task computes: time compute on the real clock.
        self._sim_compute = bool(getattr(clock, "simulated", False))
        self._tasks = list(tasks)
        self._stats: dict[str, TaskStats] = {}
        self._entries: list[tuple[Callable[[int], None], int, TaskStats]] = []
        for task in self._tasks:
            if task.name in self._stats:
                raise ValueError(f"duplicate task name {task.name!r}")
            rate = task.rate_hz
            if not (isinstance(rate, (int, float)) and math.isfinite(rate) and rate > 0):
                raise ValueError(f"task {task.name!r}: rate must be a positive finite number of Hz, "
                                 f"got {rate!r}")
            ratio = loop_rate_hz / rate
            every = round(ratio)
            if every < 1 or abs(ratio - every) > 1e-9:
                raise ValueError(f"task {task.name!r}: rate {rate} Hz does not divide the loop rate "
                                 f"{loop_rate_hz} Hz (loop/task = {ratio:.6g}, must be an integer >= 1)")
            stats = TaskStats(window=window)
            self._stats[task.name] = stats
            self._entries.append((task.fn, every, stats))
        self._t0: int | None = None
        self._tick = 0
        self._overruns = 0
        self._skipped = 0

    # --- properties -----------------------------------------------------------------

    @property
    def tick(self) -> int:
        """Slots consumed so far, executed or skipped (the next slot's index)."""
        return self._tick

    @property
    def period_ns(self) -> int:
        """Base-loop period (ns)."""
        return self._period_ns

    @property
    def loop_rate_hz(self) -> float:
        """Base-loop rate (Hz)."""
        return self._loop_rate_hz

    def _origin(self) -> int:
        """The grid origin (ns), fixing it now if the grid has not started."""
        if self._t0 is None:
            self.start()
        assert self._t0 is not None
        return self._t0

    @property
    def t0_ns(self) -> int | None:
        """Grid origin (ns), or ``None`` before the grid is fixed."""
        return self._t0

    @property
    def overruns(self) -> int:
        """Ticks whose tasks ended after the next slot had started."""
        return self._overruns

    @property
    def skipped_slots(self) -> int:
        """Slots skipped (after overruns or stalls between calls)."""
        return self._skipped

    @property
    def task_stats(self) -> Mapping[str, TaskStats]:
        """Live per-task statistics, by task name."""
        return self._stats

    # --- running --------------------------------------------------------------------

    def start(self, t0_ns: int | None = None) -> None:
        """Fix the grid origin at ``t0_ns`` (ns; default: now). May be called once, before any tick."""
        if self._t0 is not None:
            raise RuntimeError("scheduler already started")
        self._t0 = self._clock.now_ns() if t0_ns is None else int(t0_ns)

    def _stale_target(self, now: int) -> int:
        """Index of the slot the next tick will use, skipping slots that have completely passed."""
        k = self._tick
        t0 = self._origin()
        if now > t0 + (k + 1) * self._period_ns:
            # first slot starting at or after now: ceil((now - t0) / period)
            return -((t0 - now) // self._period_ns)
        return k

    def _skip_to(self, j: int) -> None:
        """Consume slots [tick, j) without running them."""
        k = self._tick
        if j <= k:
            return
        self._skipped += j - k
        for _fn, every, st in self._entries:
            st.skipped_slots += _multiples_in(every, k, j)
        self._tick = j

    def next_slot_ns(self) -> int:
        """Scheduled time (ns) of the slot the next :meth:`run_tick` will execute.

        Before the grid is fixed this is the current time (the first tick runs at once).
        """
        if self._t0 is None:
            return self._clock.now_ns()
        return self._t0 + self._stale_target(self._clock.now_ns()) * self._period_ns

    def run_tick(self) -> bool:
        """Wait for the next slot, run the tasks due in it and account for overruns.

        Returns
        -------
        bool
            True if this tick overran (its tasks ended after the next slot started).
        """
        clock = self._clock
        t0 = self._origin()
        period = self._period_ns
        self._skip_to(self._stale_target(clock.now_ns()))
        k = self._tick
        t_slot = t0 + k * period
        t_next = t_slot + period
        clock.sleep_until(t_slot)

        sim = self._sim_compute
        for fn, every, st in self._entries:
            if k % every:
                continue
            start = clock.now_ns()
            c0 = time.perf_counter_ns() if sim else 0
            try:
                fn(t_slot)
            except Exception as exc:  # keep flying: count it and run the other tasks
                _reraise_interrupt(exc)
                st.errors += 1
                st.last_error = repr(exc)
            end = clock.now_ns()
            st._compute.push(time.perf_counter_ns() - c0 if sim else end - start)
            st._jitter.push(start - t_slot)
            st.runs += 1
            if end > t_next:
                st.overruns += 1

        self._tick = k + 1
        now = clock.now_ns()
        if now > t_next:
            self._overruns += 1
            # Drop every slot that has already started: no catch-up burst, same grid.
            self._skip_to(-((t0 - now) // period))
            return True
        return False

    def run(self, n_ticks: int | None = None, until_ns: int | None = None,
            stop: Callable[[], bool] | None = None) -> None:
        """Run ticks until a limit is reached (forever if none is given).

        Parameters
        ----------
        n_ticks : int, optional
            Return once this many more slots have been consumed (skipped slots
            count, so the run spans ``n_ticks`` periods of the grid). Returns
            right after the last slot's tasks.
        until_ns : int, optional
            Run every slot that starts before ``until_ns`` (ns), then wait until
            ``until_ns`` and return, so a lockstep clock ends exactly there.
        stop : Callable[[], bool], optional
            Checked before each slot; return at once when it returns True.
        """
        if n_ticks is not None and n_ticks < 0:
            raise ValueError(f"n_ticks must be >= 0, got {n_ticks}")
        if self._t0 is None:
            self.start()
        target = None if n_ticks is None else self._tick + n_ticks
        while True:
            if target is not None and self._tick >= target:
                return
            if until_ns is not None and self.next_slot_ns() >= until_ns:
                self._clock.sleep_until(until_ns)
                return
            if stop is not None and stop():
                return
            self.run_tick()

    # --- reporting ------------------------------------------------------------------

    def stats(self) -> dict:
        """JSON-serialisable summary.

        Returns
        -------
        dict
            ``{"loop_rate_hz", "period_ns", "ticks", "overruns", "skipped_slots",
            "tasks": {name: {"rate_hz", "runs", "overruns", "skipped_slots",
            "errors", "last_error", "compute": {...}, "start_jitter": {...}}}}``,
            where ``compute`` and ``start_jitter`` hold ``p50_us``, ``p99_us``,
            ``max_us``, ``mean_us`` (µs) and ``n``.
        """
        tasks = {}
        for task in self._tasks:
            st = self._stats[task.name]
            tasks[task.name] = {
                "rate_hz": float(task.rate_hz),
                "runs": st.runs,
                "overruns": st.overruns,
                "skipped_slots": st.skipped_slots,
                "errors": st.errors,
                "last_error": st.last_error,
                "compute": st.compute_percentiles_us(),
                "start_jitter": st.start_jitter_percentiles_us(),
            }
        return {
            "loop_rate_hz": self._loop_rate_hz,
            "period_ns": self._period_ns,
            "ticks": self._tick,
            "overruns": self._overruns,
            "skipped_slots": self._skipped,
            "tasks": tasks,
        }
