"""A live vehicle in one process: the world and the firmware on a (scaled) wall clock, with its MAVLink link.

For flying Wavekeep from a ground station now, and for the link's tests. The
firmware's scheduler runs the control task, the GCS link's update and the
world's step each slot, in a background thread, on :class:`LockstepPacedClock` (real
time at ``speedup`` 1). The multi-process launcher (``wavekeep sim``) puts the
world and the firmware in separate processes instead.
"""
from __future__ import annotations

import os
import threading
from collections.abc import Callable

from firmware_py.hal.clocks import LockstepPacedClock
from firmware_py.hal.scheduler import Task, shorten_gil_switch
from firmware_py.modes import AUTO_AXES, MODE_NAMES
from firmware_py.params.table import ParameterTable

from .run import MissionSetup, build_mission
from .spec import RunSpec

__all__ = ["HISTORY_COLUMNS", "LiveSim", "live_summary"]

HISTORY_COLUMNS = ("t", "x", "z", "theta", "sp_x", "sp_z", "sp_theta", "tau_X", "tau_Z", "tau_M", "held", "armed",
                   "mode", "ff_active")
"""One row per slot of a live flight: truth after the slot, the target, the thrusters' actual wrench [X, Z, M]
(N, N m), whether the controller held station (armed, every axis automatic), armed, the mode, FF active."""

MIN_HELD_S = 2.0
"""Shortest time held on station (s) for which errors and power are reported."""


class LiveSim:
    """``with LiveSim(mavlink=["udpout:127.0.0.1:14550"]) as sim: ...`` — the vehicle flies until stopped.

    The vehicle boots disarmed in MANUAL at the mission's station; a ground
    station arms it and picks a mode. ``speedup`` > 1 runs faster than real time.
    """

    def __init__(self, spec: RunSpec | None = None, mavlink: list[str] | tuple[str, ...] = ("udpout:127.0.0.1:14550",),
                 speedup: float = 1.0, params: ParameterTable | None = None, signing_key: bytes | None = None,
                 realtime: bool = False, on_event: Callable[[int, str], None] | None = None,
                 duration: float | None = None):
        from firmware_py.mavlink import MavlinkLink

        self.setup: MissionSetup = build_mission(spec or RunSpec(), params=params, clock=LockstepPacedClock(speedup))
        # (the paced clock anchors the wall clock at the loop's first slot, so the grid starts at 0 then)
        self.firmware = self.setup.firmware
        self.link = MavlinkLink(self.firmware, list(mavlink), signing_key=signing_key)
        rate = self.setup.rate_hz
        self.firmware.add_task(Task("gcs", rate, self.link.update))
        self.firmware.add_task(Task("world", rate, self._step_world))
        self.history: list[list[float]] = []   # per slot: HISTORY_COLUMNS (for the summary)
        self.n_ticks = None if duration is None else int(round(duration * rate))
        self.done = threading.Event()          # set when the loop has stopped (n_ticks flown, or stop())
        self.on_slot: Callable[[object, object], None] | None = None   # (plant state, tick record): the view's
        self.on_event = on_event
        if on_event is not None:   # the firmware's STATUSTEXT events (arming, failsafes...) as the link sends them
            send = self.link.statustext

            def tapped(severity: int, text: str, ep: int | None = None) -> None:
                on_event(severity, text)
                send(severity, text, ep)
            self.link.statustext = tapped  # type: ignore[method-assign]
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.realtime = realtime
        self.scheduling = "normal"

    def _step_world(self, _slot) -> None:
        fw = self.firmware
        while fw.notes:                          # mode changes, the GCS failsafe: for the log, not sent
            severity, text = fw.notes.popleft()
            if self.on_event is not None:
                self.on_event(severity, text)
        held = fw.armed and all(AUTO_AXES.get(fw.mode, (False, False, False)))   # the controller holds every axis
        ff = fw.last is not None and fw.last.ff_active
        self.setup.hal.step_world()
        s, tau = self.setup.plant.state, self.setup.plant.tau     # the thrusters' actual load over the slot
        self.history.append([s.t, *s.eta, *fw.setpoint, *tau.tolist(), float(held), float(fw.armed),
                             float(fw.mode), float(ff)])
        last = fw.last
        if self.on_slot is not None and last is not None:
            self.on_slot(s, last)

    def summary(self, label: str = "") -> dict:
        """What the flight was (:func:`live_summary`)."""
        return live_summary(self.history, self.setup.rate_hz, label)

    def start(self) -> LiveSim:
        self.link.start()
        self._thread = threading.Thread(target=self._run, name="wavekeep-live", daemon=True)
        self._thread.start()
        return self

    def _run(self) -> None:
        shorten_gil_switch()       # paced on the wall clock: the link's thread must not hold the loop up
        if self.realtime:
            try:   # the loop thread only (Linux: pid 0 is the calling thread)
                os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(10))
                self.scheduling = "SCHED_FIFO"
            except (PermissionError, AttributeError, OSError):
                self.scheduling = "normal (SCHED_FIFO not permitted)"
        try:
            self.firmware.scheduler.run(stop=self._finished)
        finally:
            self.done.set()

    def _finished(self) -> bool:
        return self._stop.is_set() or (self.n_ticks is not None and len(self.history) >= self.n_ticks)

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
        self.link.stop()

    def __enter__(self) -> LiveSim:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()


def live_summary(history: list[list[float]], rate_hz: float, label: str = "") -> dict:
    """What a live flight was: seconds per mode (disarmed apart) and, over the slots the controller held station
    (armed in GUIDED or POSHOLD), RMSE and max error against the target flown and the mean power of the
    thrusters' actual wrench. ``metrics`` is None when it held station for under :data:`MIN_HELD_S`; ``label``
    is ``label`` with the modes held in and, for a feed-forward flight, how much of that time FF was active."""
    import numpy as np

    from .metrics import station_keeping_metrics
    c = {name: i for i, name in enumerate(HISTORY_COLUMNS)}
    h = np.array(history, dtype=float).reshape(-1, len(HISTORY_COLUMNS))
    dt = 1.0 / rate_hz
    times: dict[str, float] = {}
    for row in h:
        name = MODE_NAMES.get(int(row[c["mode"]]), str(int(row[c["mode"]]))) if row[c["armed"]] else "disarmed"
        times[name] = times.get(name, 0.0) + dt
    held = h[h[:, c["held"]] > 0]
    out: dict = {"flown_s": len(h) * dt, "time_s": times, "held_s": len(held) * dt, "metrics": None, "label": label}
    if len(held) * dt < MIN_HELD_S:
        return out
    modes = sorted({MODE_NAMES.get(int(m), str(int(m))) for m in held[:, c["mode"]]})
    ff = float(np.mean(held[:, c["ff_active"]]))
    qualifier = f", FF active {100 * ff:.0f} % of it" if "+FF" in label else ""
    out["label"] = f"{label} in {'/'.join(modes)}{qualifier}"
    out["metrics"] = station_keeping_metrics(held[:, c["t"]], held[:, c["x"]:c["theta"] + 1],
                                             held[:, c["sp_x"]:c["sp_theta"] + 1], held[:, c["tau_X"]:c["tau_M"] + 1])
    return out
