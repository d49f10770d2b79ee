"""The vehicle's MAVLink link: ArduSub's ground-station protocol, served without ever blocking the control task.

Threading model
---------------
* One daemon **I/O thread** (:meth:`MavlinkLink.start`) owns every socket. It
  waits in ``select`` (short timeouts), reads all endpoints, parses MAVLink
  (pymavlink's parser, robust mode), counts and drops what is bad, unsigned,
  unsupported or addressed to another system, and appends the rest to a
  bounded **inbox** (``deque(maxlen)``; overflow drops the oldest and is
  counted). It also packs and writes everything in the **outbox** — per
  endpoint, with that endpoint's sequence numbers and signing state.
* :meth:`MavlinkLink.update` runs in the firmware's scheduler (a 20 Hz task,
  after the control task). It handles at most ``max_per_update`` inbox
  messages within a time budget, turns them into firmware calls
  (:meth:`~firmware_py.firmware.Firmware.request_mode`, ``request_arm``,
  ``set_target``, ``pilot_input``, ``motor_test``, ``gcs_heartbeat``, the
  parameter table), and queues replies and due telemetry as message objects in
  the outbox. It never touches a socket, so it never blocks; packing (the
  costly part of sending) happens in the I/O thread.

Each counter in :attr:`MavlinkLink.counters` is written by one thread only.

What goes on the wire, and where it differs from ArduSub, is in ``docs/mavlink.md``.
"""
from __future__ import annotations

import os

os.environ["MAVLINK20"] = "1"   # for any mavutil in this process (NOTES: pymavlink); the link itself
                                # packs and parses with the MAVLink 2 dialect module directly

import base64
import binascii
import errno
import math
import select
import socket
import threading
import time
from collections import OrderedDict, deque
from pathlib import Path
from typing import Callable

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from .modes import AUTO_AXES, GUIDED_GROUP, MAV_RESULT, MAV_SEVERITY, Mode
from .sensors import depth_to_pressure

__all__ = ["MavlinkLink", "load_signing_key", "STREAM_GROUPS", "DATA_STREAM_PARAMS", "FLIGHT_SW_VERSION",
           "CAPABILITIES", "SIGNING_EPOCH_S"]

# --------------------------------------------------------------------------- wire constants

COMPONENT_ID = 1                      # MAV_COMP_ID_AUTOPILOT1
FORCE_ARM_MAGIC = 21196.0             # COMPONENT_ARM_DISARM param2 that skips the pre-arm checks
SIGNING_EPOCH_S = 1420070400          # MAVLink 2 signing timestamps count 10 µs from 2015-01-01
WAVEKEEP_VERSION = (0, 1, 0)
FLIGHT_SW_VERSION = ((WAVEKEEP_VERSION[0] << 24) | (WAVEKEEP_VERSION[1] << 16) | (WAVEKEEP_VERSION[2] << 8)
                     | mavlink.FIRMWARE_VERSION_TYPE_DEV)
CAPABILITIES = (mavlink.MAV_PROTOCOL_CAPABILITY_MAVLINK2 | mavlink.MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT
                | mavlink.MAV_PROTOCOL_CAPABILITY_COMMAND_INT
                | mavlink.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED)
"""What AUTOPILOT_VERSION claims: only what this link implements (no missions, no FTP)."""

BASE_MODE_ALWAYS = (mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | mavlink.MAV_MODE_FLAG_STABILIZE_ENABLED
                    | mavlink.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED)

ID = {name: getattr(mavlink, f"MAVLINK_MSG_ID_{name}") for name in (
    "HEARTBEAT", "SYS_STATUS", "SYSTEM_TIME", "ATTITUDE", "LOCAL_POSITION_NED", "GLOBAL_POSITION_INT",
    "SERVO_OUTPUT_RAW", "RC_CHANNELS", "VFR_HUD", "SCALED_PRESSURE2", "NAMED_VALUE_FLOAT", "AUTOPILOT_VERSION",
    "SET_MODE", "PARAM_REQUEST_READ", "PARAM_REQUEST_LIST", "PARAM_SET", "REQUEST_DATA_STREAM", "MANUAL_CONTROL",
    "RC_CHANNELS_OVERRIDE", "COMMAND_LONG", "COMMAND_INT", "SET_POSITION_TARGET_LOCAL_NED", "TIMESYNC",
    "MISSION_REQUEST_LIST", "MISSION_COUNT", "MISSION_CLEAR_ALL", "AUTOPILOT_VERSION_REQUEST", "RADIO_STATUS",
    "RADIO")}

STREAM_GROUPS: dict[str, tuple[int, ...]] = {
    "SR0_RAW_SENS": (ID["SCALED_PRESSURE2"],),
    "SR0_EXT_STAT": (ID["SYS_STATUS"], ID["NAMED_VALUE_FLOAT"]),
    "SR0_RC_CHAN": (ID["SERVO_OUTPUT_RAW"], ID["RC_CHANNELS"]),
    "SR0_POSITION": (ID["GLOBAL_POSITION_INT"], ID["LOCAL_POSITION_NED"]),
    "SR0_EXTRA1": (ID["ATTITUDE"],),
    "SR0_EXTRA2": (ID["VFR_HUD"],),
    "SR0_EXTRA3": (ID["SYSTEM_TIME"],),
}
"""Stream-rate parameter (Hz) → the messages it paces (ArduPilot's SR0_* groups)."""

MSG_GROUP = {mid: group for group, ids in STREAM_GROUPS.items() for mid in ids}
HEARTBEAT_INTERVAL_NS = 1_000_000_000
STREAMED = (ID["HEARTBEAT"],) + tuple(MSG_GROUP)

DATA_STREAM_PARAMS = {
    mavlink.MAV_DATA_STREAM_RAW_SENSORS: "SR0_RAW_SENS",
    mavlink.MAV_DATA_STREAM_EXTENDED_STATUS: "SR0_EXT_STAT",
    mavlink.MAV_DATA_STREAM_RC_CHANNELS: "SR0_RC_CHAN",
    mavlink.MAV_DATA_STREAM_POSITION: "SR0_POSITION",
    mavlink.MAV_DATA_STREAM_EXTRA1: "SR0_EXTRA1",
    mavlink.MAV_DATA_STREAM_EXTRA2: "SR0_EXTRA2",
    mavlink.MAV_DATA_STREAM_EXTRA3: "SR0_EXTRA3",
}
"""REQUEST_DATA_STREAM's req_stream_id → the SR0_ parameter it sets (MAV_DATA_STREAM_ALL sets them all)."""

# MAV_SYS_STATUS_SENSOR bits this vehicle has
_S = mavlink
SENSORS_PRESENT = (_S.MAV_SYS_STATUS_SENSOR_3D_GYRO | _S.MAV_SYS_STATUS_SENSOR_3D_ACCEL
                   | _S.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE | _S.MAV_SYS_STATUS_SENSOR_VISION_POSITION
                   | _S.MAV_SYS_STATUS_SENSOR_ANGULAR_RATE_CONTROL | _S.MAV_SYS_STATUS_SENSOR_ATTITUDE_STABILIZATION
                   | _S.MAV_SYS_STATUS_SENSOR_Z_ALTITUDE_CONTROL | _S.MAV_SYS_STATUS_SENSOR_XY_POSITION_CONTROL
                   | _S.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS | _S.MAV_SYS_STATUS_AHRS)
_SENSOR_BITS = (_S.MAV_SYS_STATUS_SENSOR_3D_GYRO | _S.MAV_SYS_STATUS_SENSOR_3D_ACCEL
                | _S.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE)
_CONTROL_BITS = (_S.MAV_SYS_STATUS_SENSOR_ATTITUDE_STABILIZATION | _S.MAV_SYS_STATUS_SENSOR_Z_ALTITUDE_CONTROL
                 | _S.MAV_SYS_STATUS_SENSOR_XY_POSITION_CONTROL | _S.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS)

WATER_TEMPERATURE_CDEG = 1000        # SCALED_PRESSURE2.temperature: nominal 10 °C (no temperature sensor)
EARTH_RADIUS_M = 6378137.0
UINT16_MAX = 65535
INT16_MAX = 32767
RC_NEUTRAL = 1500
RC_RANGE = 400                        # µs from neutral to full stick (1100–1900)
MOTOR_TEST_TIMEOUT_S = 0.5            # ArduSub stops a motor test 0.5 s after the last command
PARAM_TYPE = mavlink.MAV_PARAM_TYPE_REAL32


def _clip_int(v, lo: int, hi: int, default: int = 0) -> int:
    """int(v) clipped to [lo, hi]; ``default`` for NaN, inf or non-numbers (values from the firmware)."""
    try:
        f = float(v)
    except (TypeError, ValueError):
        return default
    if not math.isfinite(f):
        return default
    return int(min(hi, max(lo, round(f))))


def _finite(*values) -> bool:
    return all(isinstance(v, (int, float)) and math.isfinite(v) for v in values)


def _tidy_float32(value: float) -> float:
    """A float32 from the wire as the decimal the sender most likely meant (0.1f → 0.1), so range
    bounds such as 1e-4 are not missed by float32 rounding."""
    if not math.isfinite(value):
        return value
    return float(f"{value:.7g}")


def load_signing_key(path: str | Path) -> bytes:
    """A 32-byte MAVLink 2 signing key from a file: 32 raw bytes, 64 hex digits, or base64 of 32 bytes.

    Surrounding whitespace is ignored in the text forms. Raises ``ValueError``
    saying what was found otherwise (and ``OSError`` if the file cannot be read).
    """
    path = Path(path)
    data = path.read_bytes()
    if len(data) == 32:
        return data
    text = data.strip()
    if len(text) == 64:
        try:
            return bytes.fromhex(text.decode("ascii"))
        except (UnicodeDecodeError, ValueError):
            pass
    try:
        key = base64.b64decode(text, validate=True)
        if len(key) == 32:
            return key
    except (binascii.Error, ValueError):
        pass
    raise ValueError(f"{path}: not a MAVLink 2 signing key: expected 32 raw bytes, 64 hex digits or base64 of "
                     f"32 bytes; the file holds {len(data)} bytes")


# --------------------------------------------------------------------------- transports

class _Endpoint:
    """One endpoint in pymavlink's syntax: ``udpout:``, ``udpin:``, ``tcp:`` (client) or ``tcpin:`` (server).

    Owned by the I/O thread after :meth:`MavlinkLink.start`. UDP datagrams are
    parsed one at a time (a truncated frame cannot eat the next datagram);
    TCP is a byte stream. ``udpin`` and ``tcpin`` reply to the peers they have
    heard from; ``tcp`` reconnects every second while the server is away.
    """

    KINDS = ("udpout", "udpin", "tcp", "tcpin")
    MAX_PEERS = 8
    MAX_PENDING = 256 * 1024           # bytes queued on a slow TCP peer before messages are dropped

    def __init__(self, url: str, index: int):
        kind, sep, rest = url.partition(":")
        host, sep2, port = rest.rpartition(":")
        if kind not in self.KINDS or not sep or not sep2 or not host:
            raise ValueError(f"MAVLink endpoint {url!r}: expected udpout:HOST:PORT, udpin:HOST:PORT, "
                             f"tcp:HOST:PORT or tcpin:HOST:PORT")
        try:
            port_n = int(port)
        except ValueError:
            raise ValueError(f"MAVLink endpoint {url!r}: port {port!r} is not a number") from None
        if not 0 <= port_n <= 65535 or (kind in ("udpout", "tcp") and port_n == 0):
            raise ValueError(f"MAVLink endpoint {url!r}: port out of range")
        self.url, self.kind, self.host, self.port, self.index = url, kind, host, port_n, index
        self.mav: mavlink.MAVLink | None = None
        self.sock: socket.socket | None = None       # UDP socket, TCP client socket, or the tcpin listener
        self.client: socket.socket | None = None     # tcpin: the accepted connection
        self.peers: OrderedDict = OrderedDict()       # udpin: address → last heard (monotonic s)
        self.dest = None
        self.pending = bytearray()
        self.next_retry = 0.0
        self.error: str | None = None

    # ---- opening and closing
    def open(self) -> None:
        """Open the socket (raises OSError, e.g. a port in use); a ``tcp`` client only tries once."""
        if self.kind in ("udpout", "udpin"):
            infos = socket.getaddrinfo(self.host, self.port, socket.AF_INET, socket.SOCK_DGRAM)
            addr = infos[0][4]
            s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            if self.kind == "udpin":
                s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
                s.bind(addr)
            else:
                self.dest = addr
            s.setblocking(False)
            self.sock = s
        elif self.kind == "tcpin":
            s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
            s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            s.bind((self.host, self.port))
            s.listen(1)
            s.setblocking(False)
            self.sock = s
        else:
            self.try_connect()

    def try_connect(self) -> bool:
        """tcp client: one connection attempt (≤ 0.5 s); False and a retry in 1 s if it fails."""
        self.next_retry = time.monotonic() + 1.0
        try:
            s = socket.create_connection((self.host, self.port), timeout=0.5)
        except OSError as exc:
            self.error = repr(exc)
            return False
        s.setblocking(False)
        s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.sock = s
        self.pending.clear()
        self.error = None
        return True

    def stream(self) -> socket.socket | None:
        """The connected TCP socket, if any."""
        return self.client if self.kind == "tcpin" else (self.sock if self.kind == "tcp" else None)

    def drop_stream(self) -> None:
        s = self.stream()
        if s is not None:
            try:
                s.close()
            except OSError:
                pass
        if self.kind == "tcpin":
            self.client = None
        elif self.kind == "tcp":
            self.sock = None
            self.next_retry = time.monotonic() + 1.0
        self.pending.clear()

    def close(self) -> None:
        for s in (self.client, self.sock):
            if s is not None:
                try:
                    s.close()
                except OSError:
                    pass
        self.client = self.sock = None

    def read_sockets(self) -> list[socket.socket]:
        return [s for s in (self.sock, self.client) if s is not None]

    def can_send(self) -> bool:
        if self.kind == "udpout":
            return self.sock is not None
        if self.kind == "udpin":
            return self.sock is not None and bool(self.peers)
        return self.stream() is not None


# --------------------------------------------------------------------------- the link

class MavlinkLink:
    """ArduSub-compatible MAVLink link of the Wavekeep firmware (see the module docstring).

    Parameters
    ----------
    firmware : Firmware
        The vehicle (:class:`firmware_py.firmware.Firmware`).
    endpoints : list of str
        pymavlink-style endpoints, several at once: ``udpout:HOST:PORT`` (send
        to a GCS), ``udpin:HOST:PORT`` (listen; reply to whoever spoke),
        ``tcp:HOST:PORT`` (connect to a server), ``tcpin:HOST:PORT`` (serve one client).
    signing_key : bytes, optional
        32-byte MAVLink 2 signing key: outgoing messages are signed; incoming
        ones must be signed with it (RADIO_STATUS excepted) or are dropped and
        counted in ``rx_unsigned``.
    scheduler : Scheduler, optional
        Whose statistics SYS_STATUS reports (default: the firmware's, looked up each time).
    inbox_size, max_per_update, budget_s :
        Inbox bound; at most this many messages, and about this much time, per :meth:`update`.
    """

    PARAMS_PER_UPDATE = 20
    EVENTS_PER_UPDATE = 16

    def __init__(self, firmware, endpoints: list[str] | None = None, signing_key: bytes | None = None, *,
                 scheduler=None, inbox_size: int = 1000, outbox_size: int = 2000, max_per_update: int = 200,
                 budget_s: float = 0.004):
        self.fw = firmware
        self.endpoints = [_Endpoint(url, i) for i, url in enumerate(
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
        self.counters: dict[str, int] = dict.fromkeys((
            "rx", "rx_bad", "rx_wrong_target", "rx_unsupported", "rx_unsigned", "rx_ignored", "inbox_dropped",
            "tx", "tx_dropped", "tx_errors", "outbox_dropped", "handler_errors", "io_errors"), 0)
        self.last_error: str | None = None
        self._inbox: deque = deque(maxlen=int(inbox_size))
        self._outbox: deque = deque(maxlen=int(outbox_size))
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._wake_r, self._wake_w = socket.socketpair()
        self._wake_r.setblocking(False)
        self._wake_w.setblocking(False)
        # update-thread state
        self._now_ns = 0
        self._overrides: dict[int, int] = {}          # msg id → interval ns, or -1: disabled
        self._next_due: dict[int, int] = {}
        self._interval: dict[int, int | None] = {}
        self._param_cursor: dict[int, int] = {}       # endpoint → next index of a PARAM_REQUEST_LIST
        self._rc = [RC_NEUTRAL] * 8                   # last RC override / stick state, ArduSub channel order
        self._sched_stats: dict | None = None         # refreshed by the I/O thread
        self._after: list = []                        # messages a command asked for, sent after its ACK
        self._handlers: dict[int, Callable] = {
            ID["HEARTBEAT"]: self._on_heartbeat,
            ID["SET_MODE"]: self._on_set_mode,
            ID["PARAM_REQUEST_LIST"]: self._on_param_request_list,
            ID["PARAM_REQUEST_READ"]: self._on_param_request_read,
            ID["PARAM_SET"]: self._on_param_set,
            ID["REQUEST_DATA_STREAM"]: self._on_request_data_stream,
            ID["MANUAL_CONTROL"]: self._on_manual_control,
            ID["RC_CHANNELS_OVERRIDE"]: self._on_rc_override,
            ID["COMMAND_LONG"]: self._on_command_long,
            ID["COMMAND_INT"]: self._on_command_int,
            ID["SET_POSITION_TARGET_LOCAL_NED"]: self._on_position_target,
            ID["TIMESYNC"]: self._on_timesync,
            ID["MISSION_REQUEST_LIST"]: self._on_mission_request_list,
            ID["MISSION_COUNT"]: self._on_mission_upload,
            ID["MISSION_CLEAR_ALL"]: self._on_mission_clear_all,
            ID["AUTOPILOT_VERSION_REQUEST"]: self._on_autopilot_version_request,
        }
        self._commands: dict[int, Callable] = {
            mavlink.MAV_CMD_DO_SET_MODE: self._cmd_set_mode,
            mavlink.MAV_CMD_COMPONENT_ARM_DISARM: self._cmd_arm,
            mavlink.MAV_CMD_DO_MOTOR_TEST: self._cmd_motor_test,
            mavlink.MAV_CMD_SET_MESSAGE_INTERVAL: self._cmd_set_message_interval,
            mavlink.MAV_CMD_GET_MESSAGE_INTERVAL: self._cmd_get_message_interval,
            mavlink.MAV_CMD_REQUEST_MESSAGE: self._cmd_request_message,
            mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES: self._cmd_autopilot_capabilities,
            mavlink.MAV_CMD_NAV_LOITER_UNLIM: lambda *_: self.fw.request_mode(Mode.POSHOLD),
            mavlink.MAV_CMD_NAV_LAND: lambda *_: self.fw.request_mode(Mode.SURFACE),
            mavlink.MAV_CMD_DO_SEND_BANNER: self._cmd_banner,
        }
        self._builders: dict[int, Callable] = {
            ID["HEARTBEAT"]: self._heartbeat,
            ID["SYS_STATUS"]: self._sys_status,
            ID["NAMED_VALUE_FLOAT"]: self._named_values,
            ID["SCALED_PRESSURE2"]: self._scaled_pressure2,
            ID["SERVO_OUTPUT_RAW"]: self._servo_output_raw,
            ID["RC_CHANNELS"]: self._rc_channels,
            ID["GLOBAL_POSITION_INT"]: self._global_position_int,
            ID["LOCAL_POSITION_NED"]: self._local_position_ned,
            ID["ATTITUDE"]: self._attitude,
            ID["VFR_HUD"]: self._vfr_hud,
            ID["SYSTEM_TIME"]: self._system_time,
            ID["AUTOPILOT_VERSION"]: self._autopilot_version,
        }
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
        return int(self.fw.params["SYSID_THISMAV"])

    def start(self) -> "MavlinkLink":
        """Start the I/O thread (once)."""
        if self._thread is not None:
            raise RuntimeError("MavlinkLink already started")
        self._thread = threading.Thread(target=self._io_loop, name="wavekeep-mavlink", daemon=True)
        self._thread.start()
        return self

    def stop(self, timeout: float = 2.0) -> None:
        """Stop the I/O thread (after it sends what is queued) and close every socket. Idempotent."""
        self._stop.set()
        self._wake()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout)
        for ep in self.endpoints:
            ep.close()
        for s in (self._wake_r, self._wake_w):
            try:
                s.close()
            except OSError:
                pass

    @property
    def alive(self) -> bool:
        """True while the I/O thread runs."""
        return self._thread is not None and self._thread.is_alive()

    def update(self, slot_ns: int) -> None:
        """The 20 Hz task: handle received messages, queue replies and due telemetry. Never raises."""
        try:
            self._update(int(slot_ns))
        except Exception as exc:   # the link must never take the vehicle's tick down
            self.counters["handler_errors"] += 1
            self.last_error = repr(exc)

    # ------------------------------------------------------------------ update (scheduler thread)
    def restart_streams(self, now_ns: int) -> None:
        """Start every stream's schedule afresh at ``now_ns`` (after the firmware's clock was rebased)."""
        for mid in list(self._next_due):
            self._next_due[mid] = int(now_ns)
        self._now_ns = int(now_ns)

    def _update(self, slot_ns: int) -> None:
        self._now_ns = slot_ns
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
        self._send_events()
        self._send_param_batches()
        self._send_streams(slot_ns)
        if self._outbox:
            self._wake()

    def _queue(self, msg, ep: int | None = None) -> None:
        """Queue a message for one endpoint, or all (None)."""
        if len(self._outbox) == self._outbox.maxlen:
            self.counters["outbox_dropped"] += 1
        self._outbox.append((ep, msg))

    def _wake(self) -> None:
        try:
            self._wake_w.send(b"\0")
        except OSError:   # full (already awake) or closed
            pass

    def _send_events(self) -> None:
        events = self.fw.events
        for _ in range(self.EVENTS_PER_UPDATE):
            try:
                severity, text = events.popleft()
            except IndexError:
                return
            self._statustext(severity, text)

    def _statustext(self, severity: int, text: str, ep: int | None = None) -> None:
        self._queue(mavlink.MAVLink_statustext_message(_clip_int(severity, 0, 7, MAV_SEVERITY.INFO),
                                                       str(text).encode("ascii", "replace")[:50]), ep)

    # ---- telemetry streams
    def _stream_interval(self, mid: int) -> int | None:
        """ns between two sends of a streamed message, or None when it is off."""
        ov = self._overrides.get(mid)
        if ov is not None:
            return None if ov < 0 else ov
        group = MSG_GROUP.get(mid)
        if group is None:
            return HEARTBEAT_INTERVAL_NS
        rate = self.fw.params[group]
        return int(1e9 / rate) if rate > 0 else None

    def _send_streams(self, now: int) -> None:
        for mid in STREAMED:
            interval = self._stream_interval(mid)
            if interval != self._interval.get(mid):
                self._interval[mid] = interval
                self._next_due[mid] = now
            if interval is None or now < self._next_due[mid]:
                continue
            due = self._next_due[mid] + interval
            self._next_due[mid] = due if due > now else now + interval
            try:
                msgs = self._builders[mid]()
            except Exception as exc:       # one bad value must not silence the other streams
                self.counters["handler_errors"] += 1
                self.last_error = f"stream {mid}: {exc!r}"
                continue
            for msg in msgs:
                self._queue(msg)

    def _time_boot_ms(self) -> int:
        r = self.fw.last
        t = r.t if r is not None else self._now_ns * 1e-9
        return _clip_int(t * 1000.0, 0, 2**63) & 0xFFFFFFFF

    def _heartbeat(self) -> list:
        fw = self.fw
        base = BASE_MODE_ALWAYS
        if fw.mode in GUIDED_GROUP:
            base |= mavlink.MAV_MODE_FLAG_GUIDED_ENABLED
        if fw.armed:
            base |= mavlink.MAV_MODE_FLAG_SAFETY_ARMED
        return [mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_SUBMARINE, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA,
                                                  base, int(fw.mode), int(fw.system_status()), 3)]

    def _sys_status(self) -> list:
        fw = self.fw
        if fw.last is None:
            return []
        enabled = SENSORS_PRESENT & ~_CONTROL_BITS
        surge, heave, pitch = AUTO_AXES.get(fw.mode, (False, False, False))
        if pitch:
            enabled |= _S.MAV_SYS_STATUS_SENSOR_ATTITUDE_STABILIZATION
        if heave:
            enabled |= _S.MAV_SYS_STATUS_SENSOR_Z_ALTITUDE_CONTROL
        if surge:
            enabled |= _S.MAV_SYS_STATUS_SENSOR_XY_POSITION_CONTROL
        if fw.armed:
            enabled |= _S.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS
        health = SENSORS_PRESENT
        if not fw.sensors_healthy:
            health &= ~_SENSOR_BITS
        if not fw.ekf.converged():
            health &= ~(_S.MAV_SYS_STATUS_AHRS | _S.MAV_SYS_STATUS_SENSOR_VISION_POSITION)
        c = self.counters
        st = self._sched_stats or {}
        load = 0
        tasks = st.get("tasks") or {}
        if tasks and st.get("period_ns"):      # the firmware's own tasks: a SITL world's step is not its load
            busy_us = sum((t["compute"].get("mean_us") or 0.0) * t["rate_hz"] / st["loop_rate_hz"]
                          for name, t in tasks.items() if name != "world")
            load = _clip_int(1000.0 * busy_us / (st["period_ns"] / 1e3), 0, 1000)
        received = c["rx"] + c["rx_bad"]
        drop = _clip_int(10000.0 * (c["rx_bad"] + c["inbox_dropped"]) / received, 0, 10000) if received else 0
        u16 = lambda v: _clip_int(v, 0, UINT16_MAX)   # noqa: E731
        return [mavlink.MAVLink_sys_status_message(
            SENSORS_PRESENT, enabled, health, load, UINT16_MAX, -1, -1, drop, u16(c["rx_bad"]),
            u16(c["inbox_dropped"]), u16(c["rx_unsigned"]), u16(st.get("overruns", 0)),
            u16(st.get("skipped_slots", 0)))]

    def _named_values(self) -> list:
        r = self.fw.last
        if r is None:
            return []
        age = -1.0
        try:
            active = self.fw.forecast.current(r.t)
            if active is not None and self.fw.params["WK_FF_ENABLE"]:
                age = r.t - active.forecast.time_base
        except Exception:   # a forecast that cannot be evaluated reads as none
            age = -1.0
        ms = self._time_boot_ms()
        tau = r.tau_e_hat
        values = ((b"FF_AGE", age), (b"FF_ON", 1.0 if r.ff_active else 0.0),
                  (b"FF_X", tau[0]), (b"FF_Z", tau[1]), (b"FF_M", tau[2])) + self._loop_values()
        return [mavlink.MAVLink_named_value_float_message(ms, name, float(v)) for name, v in values]

    def _loop_values(self) -> tuple:
        """The control loop's performance, as ArduPilot reports its loop timing: the control task's
        compute p99 (ms), the missed deadlines (overruns, plus slots a paced SITL run fell behind)."""
        st = self._sched_stats or {}
        control = (st.get("tasks") or {}).get("control") or {}
        p99 = (control.get("compute") or {}).get("p99_us")
        late = getattr(getattr(self.fw.hal, "clock", None), "late", 0)
        return ((b"TICK_P99", (p99 or 0.0) / 1e3), (b"TICK_MISS", float(st.get("overruns", 0) + late)))

    def _depth_estimate(self) -> tuple[float, float, float, float, float, float]:
        """x, depth, θ, and NED velocities vx, vz and pitch rate q, from the estimate of the last tick."""
        x, z, th, u, w, q = (float(v) for v in self.fw.last.x_hat[:6])
        c, s = (math.cos(th), math.sin(th)) if math.isfinite(th) else (math.nan, math.nan)
        return x, z, th, u * c + w * s, -u * s + w * c, q

    def _scaled_pressure2(self) -> list:
        r = self.fw.last
        if r is None:
            return []
        depth = r.frame.depth if math.isfinite(r.frame.depth) else float(r.x_hat[1])
        if not math.isfinite(depth):
            return []
        return [mavlink.MAVLink_scaled_pressure2_message(self._time_boot_ms(), depth_to_pressure(depth) / 100.0,
                                                         0.0, WATER_TEMPERATURE_CDEG)]

    def _servo_output_raw(self) -> list:
        r = self.fw.last
        if r is None:
            return []
        pwm = [_clip_int(v, 0, UINT16_MAX) for v in list(r.mix.pwm)[:8]]
        pwm += [0] * (8 - len(pwm))
        return [mavlink.MAVLink_servo_output_raw_message(_clip_int(r.t * 1e6, 0, 2**63) & 0xFFFFFFFF, 0, *pwm)]

    def _rc_channels(self) -> list:
        if self.fw.last is None:
            return []
        return [mavlink.MAVLink_rc_channels_message(self._time_boot_ms(), 8, *self._rc, *([UINT16_MAX] * 10), 255)]

    def _global_position_int(self) -> list:
        if self.fw.last is None:
            return []
        x, z, _th, vx, vz, _q = self._depth_estimate()
        p = self.fw.params
        lat = p["WK_ORIGIN_LAT"] + math.degrees(x / EARTH_RADIUS_M) if math.isfinite(x) else p["WK_ORIGIN_LAT"]
        alt_mm = _clip_int(-z * 1000.0, -2**31, 2**31 - 1)
        return [mavlink.MAVLink_global_position_int_message(
            self._time_boot_ms(), _clip_int(lat * 1e7, -900000000, 900000000),
            _clip_int(p["WK_ORIGIN_LON"] * 1e7, -1800000000, 1800000000), alt_mm, alt_mm,
            _clip_int(vx * 100.0, -32768, INT16_MAX), 0, _clip_int(vz * 100.0, -32768, INT16_MAX), 0)]

    def _local_position_ned(self) -> list:
        if self.fw.last is None:
            return []
        x, z, _th, vx, vz, _q = self._depth_estimate()
        return [mavlink.MAVLink_local_position_ned_message(self._time_boot_ms(), x, 0.0, z, vx, 0.0, vz)]

    def _attitude(self) -> list:
        if self.fw.last is None:
            return []
        _x, _z, th, _vx, _vz, q = self._depth_estimate()
        return [mavlink.MAVLink_attitude_message(self._time_boot_ms(), 0.0, th, 0.0, 0.0, q, 0.0)]

    def _vfr_hud(self) -> list:
        r = self.fw.last
        if r is None:
            return []
        _x, z, _th, vx, vz, _q = self._depth_estimate()
        heave = float(r.mix.tau_stages[-1][1])               # N, FRD: + is down
        tau_max = self.fw.params["WK_TAU_MAX_Z"]
        throttle = _clip_int(50.0 - 50.0 * heave / tau_max, 0, 100, 50)
        speed = abs(vx) if math.isfinite(vx) else 0.0
        return [mavlink.MAVLink_vfr_hud_message(speed, speed, 0, throttle, -z, -vz)]

    def _system_time(self) -> list:
        return [mavlink.MAVLink_system_time_message(int(time.time() * 1e6), self._time_boot_ms())]

    def _autopilot_version(self) -> list:
        return [mavlink.MAVLink_autopilot_version_message(
            CAPABILITIES, FLIGHT_SW_VERSION, 0, 0, 0, [0] * 8, [0] * 8, [0] * 8, 0, 0, self.sysid)]

    # ---- parameters
    def _param_value(self, index: int):
        name, value = self.fw.params.by_index(index)
        return mavlink.MAVLink_param_value_message(name.encode("ascii"), float(value), PARAM_TYPE,
                                                   len(self.fw.params), index)

    def _send_param_batches(self) -> None:
        if not self._param_cursor:
            return
        count = len(self.fw.params)
        for ep, i in list(self._param_cursor.items()):
            end = min(count, i + self.PARAMS_PER_UPDATE)
            for j in range(i, end):
                self._queue(self._param_value(j), ep)
            if end >= count:
                del self._param_cursor[ep]
            else:
                self._param_cursor[ep] = end

    # ------------------------------------------------------------------ message handlers (scheduler thread)
    def _from_gcs(self, msg) -> bool:
        return msg.get_srcSystem() == int(self.fw.params["SYSID_MYGCS"])

    def _ignored(self) -> None:
        self.counters["rx_ignored"] += 1

    def _on_heartbeat(self, ep: int, msg) -> None:
        if self._from_gcs(msg):
            self.fw.gcs_heartbeat()

    def _ack(self, ep: int, msg, command: int, result: int) -> None:
        self._queue(mavlink.MAVLink_command_ack_message(
            _clip_int(command, 0, UINT16_MAX), int(result), 0, 0, msg.get_srcSystem(), msg.get_srcComponent()), ep)

    def _set_mode(self, base_mode: float, custom_mode: float) -> int:
        if not _finite(base_mode, custom_mode):
            return MAV_RESULT.FAILED
        if not int(base_mode) & mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            return MAV_RESULT.UNSUPPORTED
        if custom_mode != int(custom_mode) or not 0 <= custom_mode < 2**32:
            return MAV_RESULT.FAILED
        return self.fw.request_mode(int(custom_mode))

    def _on_set_mode(self, ep: int, msg) -> None:
        # ArduPilot acks SET_MODE with a COMMAND_ACK whose command is the message id (11)
        self._ack(ep, msg, ID["SET_MODE"], self._set_mode(msg.base_mode, msg.custom_mode))

    def _on_param_request_list(self, ep: int, msg) -> None:
        self._statustext(MAV_SEVERITY.INFO, "Wavekeep V%d.%d.%d (ArduSub-compatible)" % WAVEKEEP_VERSION, ep)
        self._param_cursor[ep] = 0

    def _on_param_request_read(self, ep: int, msg) -> None:
        params = self.fw.params
        if msg.param_index >= 0:
            if msg.param_index >= len(params):
                return self._ignored()
            index = msg.param_index
        else:
            name = msg.param_id
            if name not in params:
                return self._ignored()
            index = params.index_of(name)
        self._queue(self._param_value(index), ep)

    def _on_param_set(self, ep: int, msg) -> None:
        params = self.fw.params
        name = msg.param_id
        if name not in params:
            return self._ignored()
        value = _tidy_float32(msg.param_value)
        why = params.set(name, value)
        if why:
            self.fw.say(MAV_SEVERITY.WARNING, f"{name} not set: {why}")
        # Every GCS learns the value in force (the new one, or the old one after a refusal)
        self._queue(self._param_value(params.index_of(name)))

    def _on_request_data_stream(self, ep: int, msg) -> None:
        if msg.start_stop == 0:
            rate = 0.0
        elif msg.start_stop == 1:
            rate = float(msg.req_message_rate)
        else:
            return self._ignored()
        if msg.req_stream_id == mavlink.MAV_DATA_STREAM_ALL:
            groups = list(STREAM_GROUPS)
        elif msg.req_stream_id in DATA_STREAM_PARAMS:
            groups = [DATA_STREAM_PARAMS[msg.req_stream_id]]
        else:
            return self._ignored()
        params = self.fw.params
        for group in groups:
            d = params.definition(group)
            params.set(group, min(d.hi, max(d.lo, rate)))
            for mid in STREAM_GROUPS[group]:      # a stream request resets its messages' own intervals
                self._overrides.pop(mid, None)

    def _stick(self, value: float) -> int:
        return _clip_int(RC_NEUTRAL + RC_RANGE * value, RC_NEUTRAL - RC_RANGE, RC_NEUTRAL + RC_RANGE, RC_NEUTRAL)

    def _on_manual_control(self, ep: int, msg) -> None:
        if not self._from_gcs(msg):        # ArduSub takes sticks from its own GCS only
            return self._ignored()
        x = 0.0 if msg.x == INT16_MAX else msg.x / 1000.0
        up = 0.0 if msg.z == INT16_MAX else (msg.z - 500) / 500.0
        pitch = (self._rc[0] - RC_NEUTRAL) / RC_RANGE
        if getattr(msg, "enabled_extensions", 0) & 1 and msg.s != INT16_MAX:   # the pitch-only axis
            pitch = msg.s / 1000.0
        x, up, pitch = (min(1.0, max(-1.0, v)) for v in (x, up, pitch))
        self._rc[0], self._rc[2], self._rc[4] = self._stick(pitch), self._stick(up), self._stick(x)
        self.fw.pilot_input(x, up, pitch)
        self.fw.gcs_heartbeat()            # ArduSub: pilot input counts as the GCS being there

    def _on_rc_override(self, ep: int, msg) -> None:
        if not self._from_gcs(msg):
            return self._ignored()
        raw = [msg.chan1_raw, msg.chan2_raw, msg.chan3_raw, msg.chan4_raw, msg.chan5_raw, msg.chan6_raw,
               msg.chan7_raw, msg.chan8_raw]
        for i, v in enumerate(raw):
            if v == UINT16_MAX:             # "ignore this field": keep the last value
                continue
            self._rc[i] = RC_NEUTRAL if v == 0 else min(RC_NEUTRAL + RC_RANGE, max(RC_NEUTRAL - RC_RANGE, v))
        norm = lambda ch: (self._rc[ch] - RC_NEUTRAL) / RC_RANGE   # noqa: E731
        self.fw.pilot_input(norm(4), norm(2), norm(0))              # 5 forward, 3 throttle, 1 pitch
        self.fw.gcs_heartbeat()

    def _on_position_target(self, ep: int, msg) -> None:
        fw = self.fw
        if fw.mode != Mode.GUIDED:          # ArduSub ignores targets outside GUIDED
            return self._ignored()
        mask = msg.type_mask
        x = None if mask & mavlink.POSITION_TARGET_TYPEMASK_X_IGNORE else float(msg.x)
        depth = None if mask & mavlink.POSITION_TARGET_TYPEMASK_Z_IGNORE else float(msg.z)
        if msg.coordinate_frame == mavlink.MAV_FRAME_LOCAL_OFFSET_NED and fw.last is not None:
            x = None if x is None else x + float(fw.last.x_hat[0])
            depth = None if depth is None else depth + float(fw.last.x_hat[1])
        elif msg.coordinate_frame != mavlink.MAV_FRAME_LOCAL_NED:
            return self._ignored()
        if x is None and depth is None:     # velocity / acceleration / yaw only: not supported
            return self._ignored()
        if fw.set_target(x, depth, None) != MAV_RESULT.ACCEPTED:
            self._ignored()

    def _on_timesync(self, ep: int, msg) -> None:
        if msg.tc1 != 0:                    # an answer to somebody's request, not a request
            return
        self._queue(mavlink.MAVLink_timesync_message(max(1, self._now_ns), msg.ts1), ep)

    def _on_mission_request_list(self, ep: int, msg) -> None:
        self._queue(mavlink.MAVLink_mission_count_message(msg.get_srcSystem(), msg.get_srcComponent(), 0,
                                                          msg.mission_type), ep)

    def _on_mission_upload(self, ep: int, msg) -> None:
        self._queue(mavlink.MAVLink_mission_ack_message(msg.get_srcSystem(), msg.get_srcComponent(),
                                                        mavlink.MAV_MISSION_UNSUPPORTED, msg.mission_type), ep)

    def _on_mission_clear_all(self, ep: int, msg) -> None:
        self._queue(mavlink.MAVLink_mission_ack_message(msg.get_srcSystem(), msg.get_srcComponent(),
                                                        mavlink.MAV_MISSION_ACCEPTED, msg.mission_type), ep)

    def _on_autopilot_version_request(self, ep: int, msg) -> None:
        for m in self._autopilot_version():
            self._queue(m, ep)

    # ---- commands
    def _on_command_long(self, ep: int, msg) -> None:
        self._command(ep, msg, (msg.param1, msg.param2, msg.param3, msg.param4, msg.param5, msg.param6,
                                msg.param7))

    def _on_command_int(self, ep: int, msg) -> None:
        self._command(ep, msg, (msg.param1, msg.param2, msg.param3, msg.param4, float(msg.x), float(msg.y),
                                msg.z))

    def _command(self, ep: int, msg, p: tuple) -> None:
        handler = self._commands.get(msg.command)
        if handler is None:
            result = MAV_RESULT.UNSUPPORTED
        else:
            try:
                result = handler(ep, msg, p)
            except Exception as exc:
                self.counters["handler_errors"] += 1
                self.last_error = f"command {msg.command}: {exc!r}"
                result = MAV_RESULT.FAILED
        # The ACK goes first; what a command asked for (queued as _after) follows it
        self._ack(ep, msg, msg.command, int(result))
        for m in self._after:
            self._queue(m, ep)
        self._after = []

    def _cmd_set_mode(self, ep, msg, p) -> int:
        return self._set_mode(p[0], p[1])

    def _cmd_arm(self, ep, msg, p) -> int:
        if p[0] == 1.0:
            result, _why = self.fw.request_arm(True, force=p[1] == FORCE_ARM_MAGIC)
            return result
        if p[0] == 0.0:
            return self.fw.request_arm(False)[0]
        return MAV_RESULT.UNSUPPORTED

    def _cmd_motor_test(self, ep, msg, p) -> int:
        motor, kind, value, timeout = p[:4]
        if not _finite(motor, kind, value, timeout) or motor != int(motor):
            return MAV_RESULT.FAILED
        if kind == mavlink.MOTOR_TEST_THROTTLE_PWM:
            pwm = int(round(value))
        elif kind == mavlink.MOTOR_TEST_THROTTLE_PERCENT:    # 0–100 % of the ESC range 1100–1900 (ArduSub)
            pwm = int(round(RC_NEUTRAL - RC_RANGE + 2 * RC_RANGE * min(100.0, max(0.0, value)) / 100.0))
        else:
            return MAV_RESULT.FAILED
        timeout = timeout if 0.0 < timeout < MOTOR_TEST_TIMEOUT_S else MOTOR_TEST_TIMEOUT_S
        if not -2**31 <= motor < 2**31:
            return MAV_RESULT.FAILED
        return self.fw.motor_test(int(motor), pwm, timeout)

    def _cmd_set_message_interval(self, ep, msg, p) -> int:
        mid, interval_us = p[0], p[1]
        if not _finite(mid, interval_us) or mid != int(mid):
            return MAV_RESULT.FAILED
        mid = int(mid)
        if mid not in self._builders or mid == ID["AUTOPILOT_VERSION"]:
            self._statustext(MAV_SEVERITY.INFO, f"No ap_message for mavlink id ({mid})", ep)
            return MAV_RESULT.DENIED
        if interval_us == -1:
            self._overrides[mid] = -1
        elif interval_us == 0:
            self._overrides.pop(mid, None)
        elif interval_us > 0:
            self._overrides[mid] = int(min(interval_us, 60e6) * 1000)
        else:
            return MAV_RESULT.FAILED
        return MAV_RESULT.ACCEPTED

    def _cmd_get_message_interval(self, ep, msg, p) -> int:
        if not _finite(p[0]) or p[0] != int(p[0]):
            return MAV_RESULT.FAILED
        mid = int(p[0])
        if mid in STREAMED:
            interval = self._stream_interval(mid)
            us = -1 if interval is None else _clip_int(interval / 1000, 1, 2**31 - 1)
        else:
            us = 0
        self._after.append(mavlink.MAVLink_message_interval_message(_clip_int(mid, 0, UINT16_MAX), us))
        return MAV_RESULT.ACCEPTED

    def _cmd_request_message(self, ep, msg, p) -> int:
        if not _finite(p[0]) or p[0] != int(p[0]):
            return MAV_RESULT.FAILED
        builder = self._builders.get(int(p[0]))
        if builder is None:
            return MAV_RESULT.FAILED
        out = builder()
        if not out:
            return MAV_RESULT.TEMPORARILY_REJECTED     # nothing to report before the first tick
        self._after.extend(out)
        return MAV_RESULT.ACCEPTED

    def _cmd_autopilot_capabilities(self, ep, msg, p) -> int:
        if p[0] != 1.0:
            return MAV_RESULT.FAILED
        self._after.extend(self._autopilot_version())
        return MAV_RESULT.ACCEPTED

    def _cmd_banner(self, ep, msg, p) -> int:
        self._statustext(MAV_SEVERITY.INFO, "Wavekeep V%d.%d.%d (ArduSub-compatible)" % WAVEKEEP_VERSION, ep)
        return MAV_RESULT.ACCEPTED

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

    @staticmethod
    def _reset_parser(mav: mavlink.MAVLink) -> None:
        mav.buf = bytearray()
        mav.buf_index = 0
        mav.expected_length = mavlink.HEADER_LEN_V1 + 2
        mav.have_prefix_error = False

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
        try:
            self._flush_outbox()
        except Exception:
            pass

    def _housekeeping(self, now: float) -> None:
        for ep in self.endpoints:
            if ep.kind == "tcp" and ep.sock is None and now >= ep.next_retry:
                if ep.try_connect():
                    self._reset_parser(ep.mav)
        try:
            self._sched_stats = self.scheduler.stats()
        except Exception:
            pass

    def _io_once(self) -> None:
        owner: dict[socket.socket, _Endpoint] = {}
        for ep in self.endpoints:
            for s in ep.read_sockets():
                owner[s] = ep
        writers = [s for ep in self.endpoints if ep.pending and (s := ep.stream()) is not None]
        try:
            readable, writable, _ = select.select([self._wake_r, *owner], writers, [], 0.1)
        except (OSError, ValueError):      # a socket closed under us: try again next time round
            time.sleep(0.005)
            return
        for s in readable:
            if s is self._wake_r:
                try:
                    while self._wake_r.recv(4096):
                        pass
                except OSError:
                    pass
            else:
                self._read(owner[s], s)
        for s in writable:
            for ep in self.endpoints:
                if ep.stream() is s:
                    self._write_stream(ep, b"")
        self._flush_outbox()

    def _read(self, ep: _Endpoint, s: socket.socket) -> None:
        if ep.kind in ("udpout", "udpin"):
            for _ in range(256):
                try:
                    data, addr = s.recvfrom(65536)
                except (BlockingIOError, InterruptedError):
                    return
                except OSError as exc:      # e.g. ECONNREFUSED from an earlier send: not fatal
                    if exc.errno not in (errno.ECONNREFUSED, errno.ECONNRESET):
                        self.counters["io_errors"] += 1
                    continue
                if ep.kind == "udpin":
                    ep.peers[addr] = time.monotonic()
                    ep.peers.move_to_end(addr)
                    while len(ep.peers) > ep.MAX_PEERS:
                        ep.peers.popitem(last=False)
                self._feed(ep, data, datagram=True)
            return
        if ep.kind == "tcpin" and s is ep.sock:
            try:
                conn, _addr = s.accept()
            except OSError:
                return
            ep.drop_stream()                # the newest client wins (a GCS that reconnects)
            conn.setblocking(False)
            conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            ep.client = conn
            self._reset_parser(ep.mav)
            return
        for _ in range(64):
            try:
                data = s.recv(65536)
            except (BlockingIOError, InterruptedError):
                return
            except OSError:
                ep.drop_stream()
                return
            if not data:                    # EOF
                ep.drop_stream()
                self._reset_parser(ep.mav)
                return
            self._feed(ep, data, datagram=False)

    def _feed(self, ep: _Endpoint, data: bytes, datagram: bool) -> None:
        mav = ep.mav
        c = self.counters
        try:
            msgs = mav.parse_buffer(data) or ()
        except Exception:
            c["rx_bad"] += 1
            self._reset_parser(mav)
            return
        for m in msgs:
            self._classify(ep.index, m)
        if datagram and mav.buf_len() > 0:  # a datagram that ends inside a frame: truncated
            c["rx_bad"] += 1
            self._reset_parser(mav)

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
        c = self.counters
        sysid = self.sysid
        eps = self.endpoints
        for ep in eps:
            ep.mav.srcSystem = sysid
        while outbox:
            try:
                target, msg = outbox.popleft()
            except IndexError:
                return
            for ep in (eps if target is None else (eps[target],)):
                if not ep.can_send():
                    continue
                mav = ep.mav
                try:
                    buf = msg.pack(mav)
                except Exception as exc:
                    c["tx_errors"] += 1
                    self.last_error = f"pack {msg.get_type()}: {exc!r}"
                    continue
                mav.seq = (mav.seq + 1) % 256
                if self._send(ep, buf):
                    c["tx"] += 1

    def _send(self, ep: _Endpoint, buf: bytes) -> bool:
        if ep.kind == "udpout":
            try:
                ep.sock.sendto(buf, ep.dest)
                return True
            except OSError:
                self.counters["tx_errors"] += 1
                return False
        if ep.kind == "udpin":
            ok = False
            for addr in list(ep.peers):
                try:
                    ep.sock.sendto(buf, addr)
                    ok = True
                except OSError:
                    self.counters["tx_errors"] += 1
            return ok
        return self._write_stream(ep, buf)

    def _write_stream(self, ep: _Endpoint, buf: bytes) -> bool:
        s = ep.stream()
        if s is None:
            return False
        if len(ep.pending) + len(buf) > ep.MAX_PENDING:
            self.counters["tx_dropped"] += 1
            return False
        ep.pending += buf
        try:
            n = s.send(ep.pending)
        except (BlockingIOError, InterruptedError):
            return True
        except OSError:
            ep.drop_stream()
            return False
        del ep.pending[:n]
        return True
