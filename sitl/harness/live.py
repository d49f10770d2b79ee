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

from firmware_py.clocks import LockstepPacedClock
from firmware_py.params import ParameterTable
from firmware_py.scheduler import Task

from .run import MissionSetup, build_mission
from .spec import RunSpec

__all__ = ["LiveSim"]


class LiveSim:
    """``with LiveSim(mavlink=["udpout:127.0.0.1:14550"]) as sim: ...`` — the vehicle flies until stopped.

    The vehicle boots disarmed in MANUAL at the mission's station; a ground
    station arms it and picks a mode. ``speedup`` > 1 runs faster than real time.
    """

    def __init__(self, spec: RunSpec | None = None, mavlink: list[str] | tuple[str, ...] = ("udpout:127.0.0.1:14550",),
                 speedup: float = 1.0, params: ParameterTable | None = None, signing_key: bytes | None = None,
                 realtime: bool = False, on_event: Callable[[int, str], None] | None = None):
        from firmware_py.mavlink import MavlinkLink

        self.setup: MissionSetup = build_mission(spec or RunSpec(), params=params, clock=LockstepPacedClock(speedup))
        # (the paced clock anchors the wall clock at the loop's first slot, so the grid starts at 0 then)
        self.firmware = self.setup.firmware
        self.link = MavlinkLink(self.firmware, list(mavlink), signing_key=signing_key)
        rate = self.setup.rate_hz
        self.firmware.add_task(Task("gcs", rate, self.link.update))
        self.firmware.add_task(Task("world", rate, self._step_world))
        self.history: list[list[float]] = []   # t, x, z, θ, τ_X, τ_Z, τ_M per slot (for the summary)
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
        notes = self.firmware.notes             # mode changes, the GCS failsafe: for the log, not sent
        while notes:
            severity, text = notes.popleft()
            if self.on_event is not None:
                self.on_event(severity, text)
        self.setup.hal.step_world()
        s, last = self.setup.plant.state, self.firmware.last
        tau = list(last.control.tau) if last is not None else [0.0, 0.0, 0.0]
        self.history.append([s.t, *s.eta, *tau])
        if self.on_slot is not None and last is not None:
            self.on_slot(s, last)

    def summary(self) -> dict | None:
        """RMSE, max error and mean power per DoF over the whole live run (None if under 2 s)."""
        import numpy as np

        from .metrics import station_keeping_metrics
        h = np.array(self.history)
        if h.shape[0] < 2 * self.setup.rate_hz:
            return None
        return station_keeping_metrics(h[:, 0], h[:, 1:4], self.setup.setpoint, h[:, 4:7])

    def start(self) -> LiveSim:
        self.link.start()
        self._thread = threading.Thread(target=self._run, name="wavekeep-live", daemon=True)
        self._thread.start()
        return self

    def _run(self) -> None:
        if self.realtime:
            try:   # the loop thread only (Linux: pid 0 is the calling thread)
                os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(10))
                self.scheduling = "SCHED_FIFO"
            except (PermissionError, AttributeError, OSError):
                self.scheduling = "normal (SCHED_FIFO not permitted)"
        self.firmware.scheduler.run(stop=self._stop.is_set)

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
        self.link.stop()

    def __enter__(self) -> LiveSim:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()
