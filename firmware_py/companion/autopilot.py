"""The companion's MAVLink connection to the autopilot: telemetry in, commands out, one thread.

Everything runs in the companion's scheduler thread: :meth:`AutopilotLink.pump`
reads what has arrived (waiting at most ``timeout`` for the first datagram) and
keeps the newest of each message the HAL needs, stamped with the autopilot's
clock (``time_boot_ms``) and the local arrival time (``time.monotonic``).

The companion speaks as the ground station's system (``MAV_GCS_SYSID``, 255 by
default — ArduSub takes RC_CHANNELS_OVERRIDE from that system only) with its
own component id (191, MAV_COMP_ID_ONBOARD_COMPUTER).
"""
from __future__ import annotations

import math
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil

mavlink = mavutil.mavlink

__all__ = ["SUB_MODES", "AutopilotLink", "Sample", "VehicleIdentityError"]

SUB_MODES = {0: "STABILIZE", 1: "ACRO", 2: "ALT_HOLD", 3: "AUTO", 4: "GUIDED", 7: "CIRCLE", 9: "SURFACE",
             16: "POSHOLD", 19: "MANUAL", 20: "MOTOR_DETECT", 21: "SURFTRAK"}
MANUAL = 19
LOCKSTEP_MARKER = b"LOCKSTEP"


class VehicleIdentityError(RuntimeError):
    """The autopilot is not the Sub this companion was built for (sysid, type, autopilot, frame)."""


@dataclass
class Sample:
    """The newest value of one telemetry message: its fields, the autopilot's time (ms), local arrival (s)."""

    values: tuple[float, ...] = ()
    t_ms: int = -1
    arrived: float = -math.inf
    count: int = 0


@dataclass
class VehicleState:
    armed: bool = False
    mode: int | None = None
    heartbeat_at: float = -math.inf
    samples: dict[str, Sample] = field(default_factory=dict)
    marker_ms: int = -1              # newest lockstep marker (SITL stand-in only)
    marker_at: float = -math.inf
    offset_ns: int | None = None     # autopilot clock − local monotonic clock (TIMESYNC)
    rtt_ns: int | None = None


class AutopilotLink:
    """A pymavlink connection to the autopilot ``target_system`` (component 1)."""

    def __init__(self, url: str, target_system: int = 1, source_system: int = 255, source_component: int = 191):
        self.url = url
        self.target = int(target_system)
        self.conn = mavutil.mavlink_connection(url, source_system=source_system, source_component=source_component,
                                               dialect="ardupilotmega")
        self.mav = self.conn.mav
        self.state = VehicleState()
        self.on_mode_change: Callable[[bool, int | None], None] | None = None
        self.params: dict[str, float] = {}
        self.acks: dict[int, int] = {}
        self.text: list[str] = []
        self.version: int | None = None
        self.counters = {"rx": 0, "tx_override": 0, "timesync": 0, "other_system": 0}

    # ------------------------------------------------------------------ receiving
    def pump(self, timeout: float = 0.0) -> int:
        """Handle every message that has arrived; wait up to ``timeout`` s for the first. Returns how many."""
        n = 0
        m = self.conn.recv_msg()
        if m is None and timeout > 0:
            self.conn.select(timeout)
            m = self.conn.recv_msg()
        while m is not None:
            self._handle(m)
            n += 1
            m = self.conn.recv_msg()
        return n

    def _handle(self, m) -> None:
        kind = m.get_type()
        if kind == "BAD_DATA":
            return
        if m.get_srcSystem() != self.target or m.get_srcComponent() != 1:
            self.counters["other_system"] += 1
            return
        self.counters["rx"] += 1
        now = time.monotonic()
        st = self.state
        if kind in ("ATTITUDE", "SCALED_PRESSURE2", "LOCAL_POSITION_NED", "VFR_HUD", "RAW_IMU"):
            s = st.samples.setdefault(kind, Sample())
            s.values = _fields(m, kind)
            s.t_ms, s.arrived, s.count = int(getattr(m, "time_boot_ms", -1)), now, s.count + 1
        elif kind == "HEARTBEAT":
            self._heartbeat(m, now)
        elif kind == "NAMED_VALUE_INT" and _name(m.name) == LOCKSTEP_MARKER:
            st.marker_ms, st.marker_at = max(st.marker_ms, int(m.time_boot_ms)), now
        elif kind == "TIMESYNC" and m.tc1 != 0:
            now_ns = time.monotonic_ns()
            st.rtt_ns = now_ns - int(m.ts1)
            st.offset_ns = int(m.tc1) - (int(m.ts1) + now_ns) // 2
            self.counters["timesync"] += 1
        elif kind == "PARAM_VALUE":
            self.params[_name(m.param_id).decode()] = float(m.param_value)
        elif kind == "COMMAND_ACK":
            self.acks[int(m.command)] = int(m.result)
        elif kind == "AUTOPILOT_VERSION":
            self.version = int(m.flight_sw_version)
        elif kind == "STATUSTEXT":
            self.text.append(_name(m.text).decode(errors="replace"))
            del self.text[:-50]

    def _heartbeat(self, m, now: float) -> None:
        st = self.state
        armed = bool(m.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
        mode = int(m.custom_mode)
        changed = (armed, mode) != (st.armed, st.mode)
        st.armed, st.mode, st.heartbeat_at = armed, mode, now
        st.samples.setdefault("HEARTBEAT", Sample()).values = (float(m.type), float(m.autopilot))
        if changed and self.on_mode_change is not None:
            self.on_mode_change(armed, mode)

    def fresh(self, kind: str, max_age_s: float) -> Sample | None:
        """The newest sample of ``kind`` if it arrived within ``max_age_s`` (local time), else None."""
        s = self.state.samples.get(kind)
        return s if s is not None and time.monotonic() - s.arrived <= max_age_s else None

    # ------------------------------------------------------------------ sending
    def heartbeat(self) -> None:
        self.mav.heartbeat_send(mavlink.MAV_TYPE_ONBOARD_CONTROLLER, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)

    def statustext(self, severity: int, text: str) -> None:
        self.mav.statustext_send(severity, text.encode("ascii", "replace")[:50])

    def rc_override(self, channels: list[int]) -> None:
        """RC_CHANNELS_OVERRIDE with 18 channel values (µs; see the protocol's ignore/release values)."""
        self.mav.rc_channels_override_send(self.target, 1, *channels[:18])
        self.counters["tx_override"] += 1

    def set_param(self, name: str, value: float) -> None:
        """PARAM_SET (no wait: the PARAM_VALUE echo lands in :attr:`params`)."""
        self.mav.param_set_send(self.target, 1, name.encode(), float(value), mavlink.MAV_PARAM_TYPE_REAL32)

    def lockstep_answer(self, ms: int) -> None:
        self.mav.named_value_int_send(ms, LOCKSTEP_MARKER, ms)

    def timesync(self) -> None:
        self.mav.timesync_send(0, time.monotonic_ns())

    def command(self, cmd: int, *params: float) -> None:
        p = [float(v) for v in params] + [0.0] * (7 - len(params))
        self.acks.pop(cmd, None)
        self.mav.command_long_send(self.target, 1, cmd, 0, *p)

    def command_wait(self, cmd: int, *params: float, timeout: float = 3.0) -> int | None:
        """Send a COMMAND_LONG and wait for its ACK (re-sent each second); the MAV_RESULT or None."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            self.command(cmd, *params)
            step_end = min(end, time.monotonic() + 1.0)
            while time.monotonic() < step_end:
                self.pump(0.02)
                if cmd in self.acks:
                    return self.acks[cmd]
        return None

    def set_message_interval(self, msg_id: int, hz: float) -> int | None:
        return self.command_wait(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, 1e6 / hz)

    def read_param(self, name: str, timeout: float = 3.0) -> float | None:
        """PARAM_REQUEST_READ (re-sent each 0.5 s) until the PARAM_VALUE comes; None if it never does."""
        self.params.pop(name, None)
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            self.mav.param_request_read_send(self.target, 1, name.encode(), -1)
            step_end = min(end, time.monotonic() + 0.5)
            while time.monotonic() < step_end:
                self.pump(0.02)
                if name in self.params:
                    return self.params[name]
        return None

    def close(self) -> None:
        self.conn.close()

    # ------------------------------------------------------------------ start-up
    def wait_vehicle(self, timeout: float = 10.0) -> None:
        """Wait for the target's heartbeat; refuse anything but ArduSub on a Sub (VehicleIdentityError)."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            self.heartbeat()
            self.pump(0.2)
            hb = self.state.samples.get("HEARTBEAT")
            if hb is not None:
                vtype, autopilot = hb.values
                if int(vtype) != mavlink.MAV_TYPE_SUBMARINE:
                    raise VehicleIdentityError(f"system {self.target} is MAV_TYPE {int(vtype)}, not a "
                                               f"submarine ({mavlink.MAV_TYPE_SUBMARINE})")
                if int(autopilot) != mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA:
                    raise VehicleIdentityError(f"system {self.target}'s autopilot is {int(autopilot)}, not ArduPilot")
                return
        other = f" (heard {self.counters['other_system']} messages from other systems)" \
            if self.counters["other_system"] else ""
        raise VehicleIdentityError(f"no Sub heartbeat from system {self.target} in {timeout:g} s{other}")


def _name(v) -> bytes:
    return (v.encode() if isinstance(v, str) else bytes(v)).rstrip(b"\0")


def _fields(m, kind: str) -> tuple[float, ...]:
    if kind == "ATTITUDE":
        return (float(m.pitch), float(m.pitchspeed))
    if kind == "SCALED_PRESSURE2":
        return (float(m.press_abs),)
    if kind == "LOCAL_POSITION_NED":
        return (float(m.x), float(m.z), float(m.vx), float(m.vz))
    if kind == "RAW_IMU":           # the accelerometer's specific force, mG, body FRD (ArduPilot scales it so)
        return (float(m.xacc), float(m.yacc), float(m.zacc))
    return (float(m.alt),)        # VFR_HUD
