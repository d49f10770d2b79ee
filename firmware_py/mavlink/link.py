"""The vehicle's MAVLink link: ArduSub's ground-station protocol, served without ever blocking the control task.

Threading model
---------------
* One daemon **I/O thread** (:meth:`MavlinkLink.start`) owns every socket
  (:mod:`.transports`). It waits in ``select`` (short timeouts), reads all
  endpoints, parses MAVLink (pymavlink's parser, robust mode), counts and drops
  what is bad, unsigned, unsupported or addressed to another system, and
  appends the rest to a bounded **inbox** (``deque(maxlen)``; overflow drops
  the oldest and is counted). It also packs and writes everything in the
  **outbox** — per endpoint, with that endpoint's sequence numbers and signing state.
* :meth:`MavlinkLink.update` runs in the firmware's scheduler (a 20 Hz task,
  after the control task). It takes one telemetry snapshot
  (:meth:`~firmware_py.firmware.Firmware.telemetry_snapshot`), handles at most
  ``max_per_update`` inbox messages within a time budget (:mod:`.commands`,
  :mod:`.param_protocol`), and queues replies and due telemetry
  (:mod:`.telemetry`) as message objects in the outbox. It never touches a
  socket, so it never blocks; packing (the costly part of sending) happens in
  the I/O thread.

Each counter in :attr:`MavlinkLink.counters` is written by one thread only.
What goes on the wire, and where it differs from ArduSub, is in ``docs/mavlink.md``.
"""
from __future__ import annotations

import contextlib
import math
import select
import socket
import threading
import time
from collections import deque
from collections.abc import Callable

from ..modes import MAV_SEVERITY
from ..telemetry_snapshot import TelemetrySnapshot
from .battery import BatterySim
from .commands import Dispatcher
from .ftp import FtpResponder
from .identity import custom_version
from .lockstep import CompanionLockstep
from .missions import MissionProtocol
from .param_protocol import ParamProtocol
from .pilot import Joystick
from .streams import Streams
from .telemetry import BUILDERS, EARTH_RADIUS_M, Builder, LinkState
from .telemetry_extra import EXTRA_BUILDERS
from .transports import Transport, make_transport
from .vehicle_commands import VehicleCommands
from .vibration import VibrationMonitor
from .wire import COMPONENT_ID, ID, SIGNING_EPOCH_S, UINT16_MAX, clip_int, mavlink

__all__ = ["MavlinkLink"]

COUNTERS = ("rx", "rx_bad", "rx_wrong_target", "rx_unsupported", "rx_unsigned", "rx_ignored", "inbox_dropped",
            "tx", "tx_dropped", "tx_errors", "outbox_dropped", "handler_errors", "io_errors")


class MavlinkLink:
    """ArduSub-compatible MAVLink link of the Wavekeep firmware (see the module docstring).

    Parameters
    ----------
    firmware : Firmware
        The vehicle (:class:`firmware_py.firmware.Firmware`).
    endpoints : list of str, optional
        pymavlink-style endpoints, several at once: ``udpout:HOST:PORT``, ``udpin:HOST:PORT``,
        ``tcp:HOST:PORT``, ``tcpin:HOST:PORT`` (:mod:`.transports`). Default: ``udpout:127.0.0.1:14550``.
    signing_key : bytes, optional
        32-byte MAVLink 2 signing key: outgoing messages are signed; incoming
        ones must be signed with it (RADIO_STATUS excepted) or are dropped and
        counted in ``rx_unsigned``.
    scheduler : Scheduler, optional
        Whose statistics SYS_STATUS reports (default: the firmware's, looked up each time).
    inbox_size, outbox_size : int
        Queue bounds (messages).
    max_per_update : int
        At most this many inbox messages per :meth:`update`.
    budget_s : float
        About this much time (s) per :meth:`update` for inbox messages.
    """

    EVENTS_PER_UPDATE = 16

    def __init__(self, firmware, endpoints: list[str] | None = None, signing_key: bytes | None = None, *,
                 scheduler=None, inbox_size: int = 1000, outbox_size: int = 2000, max_per_update: int = 200,
                 budget_s: float = 0.004, lockstep: bool = False):
        self.fw = firmware
        self.counters: dict[str, int] = dict.fromkeys(COUNTERS, 0)
        self.endpoints: list[Transport] = [make_transport(url, i, self.counters) for i, url in enumerate(
            ["udpout:127.0.0.1:14550"] if endpoints is None else list(endpoints))]
        if not self.endpoints:
            raise ValueError("MavlinkLink needs at least one endpoint")
        if signing_key is not None:
            signing_key = bytes(signing_key)
            if len(signing_key) != 32:
                raise ValueError(f"a MAVLink 2 signing key is 32 bytes, got {len(signing_key)}")
        self.signing_key = signing_key
        self._scheduler = scheduler
        self.max_per_update = int(max_per_update)
        self.budget_ns = int(budget_s * 1e9)
        self.last_error: str | None = None
        self._inbox: deque = deque(maxlen=int(inbox_size))
        self._outbox: deque = deque(maxlen=int(outbox_size))
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._wake_r, self._wake_w = socket.socketpair()
        self._wake_r.setblocking(False)
        self._wake_w.setblocking(False)
        # update-thread state
        self.state = LinkState(sysid=self.sysid, counters=self.counters)
        self.snapshot: TelemetrySnapshot | None = None
        self.streams = Streams(firmware.params)
        self.after: list = []                         # messages a command asked for, sent after its ACK
        self._ready = False                           # "ArduPilot Ready" said
        self._armed = False
        self.builders: dict[int, Builder] = {**BUILDERS, **EXTRA_BUILDERS}
        self.battery = BatterySim(firmware.params)
        self.state.vibration = VibrationMonitor()
        self.joystick = Joystick(self)
        self.vehicle_commands = VehicleCommands(self, self.joystick)
        self.dispatcher = Dispatcher(self, self.joystick)
        self.dispatcher.commands.update(self.vehicle_commands.commands)
        self.param_protocol = ParamProtocol(self)
        self.missions = MissionProtocol(self)
        self.ftp = FtpResponder(self)
        self._handlers: dict[int, Callable] = {**self.dispatcher.messages, **self.param_protocol.messages,
                                               **self.missions.messages, **self.ftp.messages}
        self.lockstep = CompanionLockstep(self) if lockstep else None   # SITL: wait for a companion each tick
        custom_version()                  # asks git once, now: never inside the 20 Hz tick
        self._open_endpoints()

    def _open_endpoints(self) -> None:
        for ep in self.endpoints:
            ep.mav = self._new_mav(ep.index)
        opened = []
        try:
            for ep in self.endpoints:
                try:
                    ep.open()
                except OSError as exc:
                    raise OSError(f"MAVLink endpoint {ep.url}: {exc}") from exc
                opened.append(ep)
        except BaseException:
            for ep in opened:
                ep.close()
            self._wake_r.close()
            self._wake_w.close()
            raise

    # ------------------------------------------------------------------ public
    @property
    def scheduler(self):
        return self._scheduler if self._scheduler is not None else self.fw.scheduler

    @property
    def sysid(self) -> int:
        """This vehicle's MAVLink system id (MAV_SYSID)."""
        return int(self.fw.params["MAV_SYSID"])

    def start(self) -> MavlinkLink:
        """Start the I/O thread (once)."""
        if self._thread is not None:
            raise RuntimeError("MavlinkLink already started")
        self._thread = threading.Thread(target=self._io_loop, name="wavekeep-mavlink", daemon=True)
        self._thread.start()
        return self

    def stop(self, timeout: float = 2.0) -> None:
        """Stop the I/O thread (after it sends what is queued) and close every socket. Idempotent."""
        self._stop.set()
        self.wake()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout)
        for ep in self.endpoints:
            ep.close()
        for s in (self._wake_r, self._wake_w):
            with contextlib.suppress(OSError):
                s.close()

    @property
    def alive(self) -> bool:
        """True while the I/O thread runs."""
        return self._thread is not None and self._thread.is_alive()

    def update(self, slot_ns: int) -> None:
        """The 20 Hz task: handle received messages, queue replies and due telemetry. Never raises.

        Parameters
        ----------
        slot_ns : int
            The scheduler slot this call belongs to (firmware clock, ns).
        """
        try:
            self._update(int(slot_ns))
        except Exception as exc:   # the link must never take the vehicle's tick down
            self.counters["handler_errors"] += 1
            self.last_error = repr(exc)

    def restart_streams(self, now_ns: int) -> None:
        """Start every stream's schedule afresh at ``now_ns`` (after the firmware's clock was rebased)."""
        self.streams.restart(now_ns)
        self.state.now_ns = int(now_ns)

    # ------------------------------------------------------------------ for the handlers (scheduler thread)
    def queue(self, msg, ep: int | None = None) -> None:
        """Queue a message for one endpoint, or all (None)."""
        if len(self._outbox) == self._outbox.maxlen:
            self.counters["outbox_dropped"] += 1
        self._outbox.append((ep, msg))

    def ack(self, ep: int, msg, command: int, result: int) -> None:
        """COMMAND_ACK of ``command`` to the sender of ``msg``."""
        self.queue(mavlink.MAVLink_command_ack_message(
            clip_int(command, 0, UINT16_MAX), int(result), 0, 0, msg.get_srcSystem(), msg.get_srcComponent()), ep)

    def statustext(self, severity: int, text: str, ep: int | None = None) -> None:
        """A STATUSTEXT (≤ 50 ASCII characters) to one endpoint or all."""
        self.queue(mavlink.MAVLink_statustext_message(clip_int(severity, 0, 7, MAV_SEVERITY.INFO),
                                                      str(text).encode("ascii", "replace")[:50]), ep)

    def ignored(self) -> None:
        """Count a message that was handled but refused."""
        self.counters["rx_ignored"] += 1

    def build(self, mid: int) -> list:
        """The message(s) with id ``mid`` as they would be streamed now (empty: nothing to report yet)."""
        snap = self.snapshot if self.snapshot is not None else self.fw.telemetry_snapshot()
        return self.builders[mid](snap, self.state)

    def set_interval(self, mid: int, interval_ns: int | None) -> None:
        """A message's own interval (ns), −1 to turn it off, None to go back to its group's rate."""
        self.streams.set_interval(mid, interval_ns)

    def stream_interval(self, mid: int) -> int | None:
        """ns between two sends of a streamed message, or None when it is off."""
        return self.streams.interval(mid)

    # ------------------------------------------------------------------ update
    def _update(self, slot_ns: int) -> None:
        self.state.now_ns = slot_ns
        self.state.sysid = self.sysid
        self.snapshot = snap = self.fw.telemetry_snapshot()
        self._vehicle_state(snap)
        self._drain()
        self._send_events()
        self.param_protocol.send_batches()
        self.missions.update()
        self.state.mission_seq, self.state.mission_total = self.missions.current, self.missions.count
        self._send_streams(slot_ns)
        if self.lockstep is not None and self.lockstep.after_streams(snap.t):
            self._drain()                  # the companion's commands for the next control tick
            self._send_events()
        if self._outbox:
            self.wake()

    def _drain(self) -> None:
        """Handle inbox messages, at most ``max_per_update`` and about ``budget_s``."""
        inbox, handlers = self._inbox, self._handlers
        deadline = time.perf_counter_ns() + self.budget_ns
        n = 0
        while inbox and n < self.max_per_update:
            if n & 15 == 15 and time.perf_counter_ns() > deadline:
                break
            ep, msg = inbox.popleft()
            n += 1
            try:
                handlers[msg.get_msgId()](ep, msg)
            except Exception as exc:
                self.counters["handler_errors"] += 1
                self.last_error = f"{msg.get_type()}: {exc!r}"
            if self.fw.events:
                self._send_events()

    def _vehicle_state(self, snap: TelemetrySnapshot) -> None:
        """What the link tracks from tick to tick: battery, vibration, clock epoch, pilot input, depth samples,
        the boot's "ArduPilot Ready" and home on arming."""
        st = self.state
        if snap.has_tick and not self._ready:
            self._ready = True
            self.statustext(MAV_SEVERITY.INFO, "ArduPilot Ready")     # ArduSub's word that it has booted
        if snap.armed and not self._armed:
            self._home_on_arming(snap)
        self._armed = snap.armed
        if snap.t is not None:
            if st.epoch_us is None:
                st.epoch_us = int(time.time() * 1e6 - snap.t * 1e6)
            if st.vibration is not None:
                st.vibration.update(snap)
            if math.isfinite(snap.measured_x):
                st.fix = (snap.t, snap.measured_x)
            self.vehicle_commands.sample(snap.measured_depth)
        st.battery = self.battery.update(snap.t, snap.thrust if snap.armed else ())
        st.ekf_sd_bad = float(self.fw.params["WK_EKF_SD_BAD"])
        self.joystick.update(snap.t)

    def _home_on_arming(self, snap: TelemetrySnapshot) -> None:
        """As ArduSub: arming moves home to where the vehicle is (with a position estimate), and GPS_GLOBAL_ORIGIN
        and HOME_POSITION go to every ground station."""
        if snap.has_tick and snap.ekf_converged and all(map(math.isfinite, snap.x_hat[:2])):
            self.state.home = (snap.origin_lat + math.degrees(snap.x_hat[0] / EARTH_RADIUS_M), snap.origin_lon,
                               -snap.x_hat[1])
        for mid in (ID["GPS_GLOBAL_ORIGIN"], ID["HOME_POSITION"]):
            for m in self.build(mid):
                self.queue(m)

    def wake(self) -> None:
        with contextlib.suppress(OSError):   # full (already awake) or closed
            self._wake_w.send(b"\0")

    def _send_events(self) -> None:
        events = self.fw.events
        for _ in range(self.EVENTS_PER_UPDATE):
            try:
                severity, text = events.popleft()
            except IndexError:
                return
            self.statustext(severity, text)

    def _send_streams(self, now: int) -> None:
        if self.streams.timesync_due(now):          # ArduPilot asks its ground stations to time-sync every 10 s
            self.queue(mavlink.MAVLink_timesync_message(0, max(1, now)))
        for mid in self.streams.due(now):
            try:
                msgs = self.build(mid)
            except Exception as exc:       # one bad value must not silence the other streams
                self.counters["handler_errors"] += 1
                self.last_error = f"stream {mid}: {exc!r}"
                continue
            for msg in msgs:
                self.queue(msg)

    # ------------------------------------------------------------------ I/O thread
    def _new_mav(self, index: int) -> mavlink.MAVLink:
        mav = mavlink.MAVLink(None, srcSystem=self.sysid, srcComponent=COMPONENT_ID)
        mav.robust_parsing = True
        if self.signing_key is not None:
            allowed = (ID["RADIO_STATUS"], ID["RADIO"])
            s = mav.signing
            s.secret_key = self.signing_key
            s.sign_outgoing = True
            s.allow_unsigned_callback = lambda _mav, msg_id: msg_id in allowed
            s.link_id = index & 0xFF
            s.timestamp = int((max(time.time(), SIGNING_EPOCH_S) - SIGNING_EPOCH_S) * 100_000)
        return mav

    def _io_loop(self) -> None:
        next_housekeeping = 0.0
        while not self._stop.is_set():
            try:
                now = time.monotonic()
                if now >= next_housekeeping:
                    next_housekeeping = now + 1.0
                    self._housekeeping(now)
                self._io_once()
            except Exception as exc:   # the link stays up whatever arrives
                self.counters["io_errors"] += 1
                self.last_error = f"io: {exc!r}"
                time.sleep(0.01)
        with contextlib.suppress(Exception):
            self._flush_outbox()

    def _housekeeping(self, now: float) -> None:
        for ep in self.endpoints:
            ep.housekeeping(now)
        with contextlib.suppress(Exception):
            self.state.sched_stats = self.scheduler.stats()

    def _io_once(self) -> None:
        readers: dict[socket.socket, Transport] = {}
        writers: dict[socket.socket, Transport] = {}
        for ep in self.endpoints:
            for s in ep.read_sockets():
                readers[s] = ep
            for s in ep.write_sockets():
                writers[s] = ep
        try:
            readable, writable, _ = select.select([self._wake_r, *readers], list(writers), [], 0.1)
        except (OSError, ValueError):      # a socket closed under us: try again next time round
            time.sleep(0.005)
            return
        for s in readable:
            if s is self._wake_r:
                # one read takes every wake-up byte queued (one per update at most); a rest, if ever,
                # wakes the next select at once. Reading on to EAGAIN cost a syscall and an exception.
                with contextlib.suppress(OSError):
                    self._wake_r.recv(4096)
            else:
                readers[s].on_readable(s, self._feed)
        for s in writable:
            writers[s].on_writable(s)
        self._flush_outbox()

    def _feed(self, ep: Transport, data: bytes) -> None:
        mav = ep.mav
        assert mav is not None   # set when the transport was opened
        try:
            msgs = mav.parse_buffer(data) or ()
        except Exception:
            self.counters["rx_bad"] += 1
            ep.reset_parser()
            return
        for m in msgs:
            self._classify(ep.index, m)
        if ep.datagram and mav.buf_len() > 0:  # a datagram that ends inside a frame: truncated
            self.counters["rx_bad"] += 1
            ep.reset_parser()

    def _classify(self, ep: int, m) -> None:
        c = self.counters
        mid = m.get_msgId()
        if mid == mavlink.MAVLINK_MSG_ID_BAD_DATA:
            if self.signing_key is not None and getattr(m, "reason", "") == "Invalid signature":
                c["rx_unsigned"] += 1
            else:
                c["rx_bad"] += 1
            return
        c["rx"] += 1
        if mid == ID["NAMED_VALUE_INT"] and self.lockstep is not None and self.lockstep.is_marker(m):
            return
        if mid not in self._handlers:
            c["rx_unsupported"] += 1
            return
        sysid = self.sysid
        if mid == ID["MANUAL_CONTROL"]:
            if m.target != sysid:           # ArduSub: sticks must name this vehicle
                c["rx_wrong_target"] += 1
                return
        else:
            ts = getattr(m, "target_system", 0)
            tc = getattr(m, "target_component", 0)
            if ts not in (0, sysid) or tc not in (0, COMPONENT_ID):
                c["rx_wrong_target"] += 1
                return
        if len(self._inbox) == self._inbox.maxlen:
            c["inbox_dropped"] += 1
        self._inbox.append((ep, m))

    def _flush_outbox(self) -> None:
        outbox = self._outbox
        if not outbox:
            return
        sysid = self.sysid
        eps = self.endpoints
        for ep in eps:
            if ep.mav is not None:
                ep.mav.srcSystem = sysid
        while outbox:
            try:
                target, msg = outbox.popleft()
            except IndexError:
                return
            for ep in (eps if target is None else (eps[target],)):
                if ep.can_send():
                    self._send(ep, msg)

    def _send(self, ep: Transport, msg) -> None:
        mav = ep.mav
        assert mav is not None   # set when the transport was opened
        try:
            buf = msg.pack(mav)
        except Exception as exc:
            self.counters["tx_errors"] += 1
            self.last_error = f"pack {msg.get_type()}: {exc!r}"
            return
        mav.seq = (mav.seq + 1) % 256
        if ep.send(buf):
            self.counters["tx"] += 1
