"""The companion inside the extension: one flight session at a time in its own thread, steered by the page.

:class:`CompanionService` runs ``firmware_py.companion``'s machinery as ``wavekeep companion`` does
(:func:`~firmware_py.companion.app.check_vehicle`, then :func:`~firmware_py.companion.app.run` with the
scheduler in this thread) and adds two things through ``run``'s ``attach`` hook, both in the scheduler's own
thread: the page's requests (engage, release) are taken at the start of a tick, and the commander engages
only in a tick the page allowed (``Commander.permit_required``). Everything else that keeps the pilot safe is
the commander's own (docs/companion.md, Safety rules): it never arms or changes mode, releases at once on a
disarm or mode change, on stale telemetry, on a stall and on an estimate that is no longer finite; after any
release the companion stays released until the pilot engages again from the page.

A session ends when its link fails (no heartbeat, a refused vehicle: the page says which, and it tries again
every ``retry_s``), when the settings change (it starts again with them) or when the extension stops.
"""
from __future__ import annotations

import math
import queue
import sys
import threading
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from firmware_py.companion.app import build_parser, check_vehicle, run
from firmware_py.companion.autopilot import MANUAL, SUB_MODES, AutopilotLink, VehicleIdentityError
from firmware_py.hal.scheduler import Task

from .settings import Settings, SettingsError, SettingsStore, gain_presets

__all__ = ["CompanionService", "ServiceOptions"]

KEEP_RECORDS = 1200
"""Per-command records (latency, channels) the commander keeps while the extension runs: the newest minute at
20 Hz. The plain companion keeps a whole flight for its log; the extension runs for days."""
ANSWER_TIMEOUT_S = 2.0
"""s the page waits for the control task to answer an engage or release."""
TICKING_S = 1.0
"""s without a control tick after which the page counts the loop as not running."""


@dataclass(frozen=True)
class ServiceOptions:
    """How the extension reaches the vehicle; the entry point's options (``python -m blueos.main -h``).

    data : the bind-mounted folder (settings, logs, the zenoh config written from the settings).
    mavlink : the companion's MAVLink endpoint (pymavlink URL) on BlueOS's router.
    target_system : ArduSub's system id (BlueOS passes ``MAV_SYSTEM_ID``).
    gcs_sysid : the companion's system id: ArduSub's ``MAV_GCS_SYSID`` (it takes overrides from that one only).
    stale_s : wall s without ATTITUDE before the companion releases.
    identity_timeout_s : s to wait for ArduSub's heartbeat before the page says there is no vehicle.
    retry_s : s between two attempts at a link that failed.
    """

    data: Path
    mavlink: str = "udpout:host.docker.internal:14771"
    target_system: int = 1
    gcs_sysid: int = 255
    stale_s: float = 0.5
    identity_timeout_s: float = 5.0
    retry_s: float = 2.0


@dataclass
class _Request:
    """An engage or release from the page, answered by the control task (or by the page when it does not run)."""

    what: str
    done: threading.Event = field(default_factory=threading.Event)
    ok: bool = False
    message: str = ""

    def answer(self, ok: bool, message: str) -> None:
        self.ok, self.message = ok, message
        self.done.set()


class CompanionService:
    """The flight sessions (a thread) and what the page reads and asks of them (any thread)."""

    def __init__(self, options: ServiceOptions, store: SettingsStore, log: Callable[[str], None] = print):
        self.options, self.store, self.log = options, store, log
        self.settings, self.settings_error = store.load()
        if self.settings_error:
            log(f"wavekeep blueos: {self.settings_error}")
        self.phase, self.detail = "starting", ""
        self.endpoint = "not registered (the router endpoint is set by hand)"
        self.fw: Any = None
        self.commander: Any = None
        self.link: AutopilotLink | None = None
        self._stop = threading.Event()          # the extension stops
        self._session_stop = threading.Event()  # the current session stops
        self._restart = threading.Event()       # ... to start again at once with new settings
        self._requests: queue.Queue[_Request] = queue.Queue()
        self._pending: _Request | None = None
        self._last_tick = -math.inf
        self.ticks = 0                          # control ticks of this process (every session)
        self.forecast_seen = (0, -math.inf)    # (offers counted, wall s of the newest)
        self._thread: threading.Thread | None = None
        self.before_session: Callable[[], None] | None = None

    # ------------------------------------------------------------------ lifecycle
    def start(self) -> CompanionService:
        self._thread = threading.Thread(target=self._supervise, name="companion", daemon=True)
        self._thread.start()
        return self

    def stop(self, timeout: float = 15.0) -> None:
        """Stop the session (the companion releases on its way out) and the thread."""
        self._stop.set()
        self._session_stop.set()
        if self._thread is not None:
            self._thread.join(timeout)

    def _supervise(self) -> None:
        while not self._stop.is_set():
            self._session_stop.clear()
            try:
                if self.before_session is not None:
                    self.before_session()
                self._session(self.settings)
            except Exception as exc:       # a session that failed is reported and started again, never fatal
                self.phase, self.detail = "error", f"{type(exc).__name__}: {exc}"
                self.log(f"wavekeep blueos: session failed: {self.detail}")
                traceback.print_exc(file=sys.stderr)
            self.fw = self.commander = None
            if self._restart.is_set():
                self._restart.clear()
                continue
            self._stop.wait(self.options.retry_s)

    def _session(self, settings: Settings) -> None:
        args = build_parser().parse_args(self.companion_argv(settings))
        self.phase, self.detail = "connecting", f"waiting for ArduSub's heartbeat on {args.autopilot}"
        link = AutopilotLink(args.autopilot, args.target_system, args.sysid, args.compid)
        self.link = link
        try:
            try:
                check_vehicle(link, args.method, args.identity_timeout)
            except VehicleIdentityError as exc:
                refused = "no Sub heartbeat" not in str(exc)
                self.phase, self.detail = ("refused" if refused else "no vehicle"), str(exc)
                if refused:
                    link.statustext(3, "WK: companion refused this vehicle")
                return
            self.phase, self.detail = "starting", "vehicle accepted: starting the control task"
            try:
                run(args, link, self._session_stop, attach=self._attach)
            except Exception as exc:         # (e.g. the forecast link cannot open): the pilot's GCS hears it
                link.statustext(3, f"WK: companion stopped: {type(exc).__name__}")
                raise
        finally:
            self.link = None
            link.close()

    def companion_argv(self, settings: Settings) -> list[str]:
        """``wavekeep companion``'s options for these settings (the zenoh config written into the data folder)."""
        o = self.options
        network = self._write_network(settings)
        argv = ["--autopilot", o.mavlink, "--method", settings.method, "--target-system", str(o.target_system),
                "--sysid", str(o.gcs_sysid), "--stale", f"{o.stale_s:g}", "--identity-timeout",
                f"{o.identity_timeout_s:g}", "--network", str(network),
                "--set", f"WK_CTRL_LAW={1 if settings.law == 'mpc' else 0}"]
        if settings.needs_forecast:
            argv += ["--forecast", "zenoh"]
        for name, value in gain_presets()[settings.gains].items():
            argv += ["--set", f"{name}={value!r}"]
        return argv

    def _write_network(self, settings: Settings) -> Path:
        """The companion's zenoh config (``configs/network.yaml``'s schema): a client of the forecast endpoint."""
        path = Path(self.options.data) / "network.yaml"
        path.parent.mkdir(parents=True, exist_ok=True)
        doc = {"site": settings.site, "zenoh": {"mode": "client", "connect": [settings.forecast_endpoint],
                                                "multicast_scouting": False, "gossip_scouting": False}}
        path.write_text("# written by the extension from its settings; edit them on its page\n"
                        + yaml.safe_dump(doc, sort_keys=False))
        return path

    # ------------------------------------------------------------------ the control task's side
    def _attach(self, fw, commander) -> list[Task]:
        """``run``'s hook: the page's task, run each tick before the commander's gate."""
        commander.permit_required = True
        commander.log = self.log
        self.fw, self.commander = fw, commander
        self.phase, self.detail = "running", ""
        return [Task("page", fw.loop_rate_hz, self._tick)]

    def _tick(self, _slot_ns: int = 0) -> None:
        c = self.commander
        self._last_tick = time.monotonic()
        self.ticks += 1
        c.permitted = False                      # a permit lasts one gate
        if self._pending is not None:            # last tick's engage: did the gate engage?
            req, self._pending = self._pending, None
            req.answer(c.engaged, "engaged" if c.engaged else "not engaged: the companion did not engage")
        while True:
            try:
                req = self._requests.get_nowait()
            except queue.Empty:
                break
            self._handle(req)
        offered = self.fw.forecast.offered
        if offered != self.forecast_seen[0]:
            self.forecast_seen = (offered, time.monotonic())
        for records in (c.latency_s, c.answered_ms, c.sent, c.events):
            if len(records) > 2 * KEEP_RECORDS:
                del records[:-KEEP_RECORDS]

    def _handle(self, req: _Request) -> None:
        c = self.commander
        if req.what == "release":
            if c.engaged:
                c.release("released from the page")
                req.answer(True, "released")
            else:
                req.answer(True, "not engaged")
            return
        if c.engaged:
            req.answer(True, "already engaged")
            return
        why = self.why_not_engage()
        if why:
            c.say(4, f"WK: not engaged: {why}")
            req.answer(False, f"not engaged: {why}")
        else:
            c.permitted = True
            self._pending = req

    def why_not_engage(self) -> str | None:
        """Why the companion may not engage now (None: it may). Read in the control task's thread."""
        fw, c, link = self.fw, self.commander, self.link
        if link is None or link.fresh("ATTITUDE", self.options.stale_s) is None:
            return "no telemetry from the vehicle"
        st = link.state
        if not st.armed:
            return "the vehicle is disarmed: arm it in MANUAL"
        if st.mode != MANUAL:
            return f"the vehicle is in {SUB_MODES.get(st.mode or 0, st.mode)}: select MANUAL"
        if not c.selected:
            return "arm in MANUAL (or select MANUAL) after the companion started"
        if self.settings.needs_forecast and (fw.last is None or fw.forecast.current(fw.last.t) is None):
            return "no valid wave forecast"
        if not fw.ekf.initialised:
            return "the estimate is not ready yet"
        return None

    # ------------------------------------------------------------------ the page's side
    def request(self, what: str) -> tuple[bool, str]:
        """Engage or release, answered by the control task; (done, what happened)."""
        if what not in ("engage", "release"):
            raise ValueError(f"request {what!r}: engage or release")
        if self.commander is None or time.monotonic() - self._last_tick > TICKING_S:
            if what == "release":
                return True, "not engaged"
            return False, f"not engaged: {self.status_line()}"
        req = _Request(what)
        self._requests.put(req)
        if not req.done.wait(ANSWER_TIMEOUT_S):
            return False, "the control task did not answer"
        return req.ok, req.message

    def apply(self, doc: Any) -> Settings:
        """New settings from the page: validated, refused while engaged, saved, then a new session flies them."""
        new = Settings.from_dict(doc)
        if self.commander is not None and self.commander.engaged:
            raise SettingsError("release the companion before changing its settings")
        self.store.save(new)
        self.settings, self.settings_error = new, None
        self.log(f"wavekeep blueos: settings saved: {new.as_dict()}")
        self._restart.set()
        self._session_stop.set()
        return new

    def status_line(self) -> str:
        """The link's state in a few words (the page's headline when not flying)."""
        fw, c = self.fw, self.commander
        if self.phase == "running" and fw is not None and self.settings.needs_forecast and fw.forecast.newest() is None:
            return "waiting for the wave forecast: not engaging"
        if self.phase == "running" and c is not None:
            return "engaged: holding station" if c.engaged else "ready: arm in MANUAL, then Engage"
        return f"{self.phase}: {self.detail}" if self.detail else self.phase
