"""The MAVLink link against a live vehicle: real UDP/TCP on 127.0.0.1, a real pymavlink ground station, no mocks.

The vehicle is :class:`sitl.live.LiveSim` (plant + firmware + link on the wall
clock, in a background thread). Checks are on behaviour, with generous
deadlines, so that they hold on a loaded two-core machine; rates are measured
on the vehicle's own timestamps (time_boot_ms) where a message carries one.
"""
from __future__ import annotations

import gc
import math
import os
import random
import re
import socket
import subprocess
import sys
import threading
import time

import pytest

os.environ["MAVLINK20"] = "1"
from pymavlink import mavutil  # noqa: E402
from pymavlink.dialects.v20 import ardupilotmega as mavlink  # noqa: E402

from firmware_py.mavlink import CAPABILITIES, MavlinkLink, load_signing_key  # noqa: E402
from firmware_py.modes import MAV_RESULT, Mode  # noqa: E402
from firmware_py.params import load_params  # noqa: E402
from firmware_py.sensors import depth_to_pressure  # noqa: E402
from sitl.live import LiveSim  # noqa: E402

SUB_MODES = {0: "STABILIZE", 2: "ALT_HOLD", 4: "GUIDED", 9: "SURFACE", 16: "POSHOLD", 19: "MANUAL"}
SERVO = mavlink.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW
POS_ONLY = 0b0000_1101_1111_1000        # type_mask: ignore velocity, acceleration, yaw, yaw rate


def free_port(kind=socket.SOCK_DGRAM) -> int:
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class GroundStation:
    """A pymavlink GCS: sends a 1 Hz heartbeat from a thread, reads and matches in the test's thread."""

    def __init__(self, url: str, sysid: int = 255, compid: int = 190, key: bytes | None = None):
        self.conn = mavutil.mavlink_connection(url, source_system=sysid, source_component=compid,
                                               dialect="ardupilotmega")
        if key is not None:
            self.conn.setup_signing(key, sign_outgoing=True)
        self._lock = threading.Lock()
        self._hb_stop = threading.Event()
        self._hb: threading.Thread | None = None
        self.log: list = []

    # ---- sending
    def send(self, msg) -> None:
        with self._lock:
            self.conn.mav.send(msg)

    def send_raw(self, data: bytes) -> None:
        with self._lock:
            self.conn.write(data)

    def heartbeats(self, on: bool) -> None:
        if on and self._hb is None:
            self._hb_stop.clear()
            self._hb = threading.Thread(target=self._beat, daemon=True)
            self._hb.start()
        elif not on and self._hb is not None:
            self._hb_stop.set()
            self._hb.join()
            self._hb = None

    def _beat(self) -> None:
        while not self._hb_stop.is_set():
            self.send(mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID,
                                                        0, 0, 0, 3))
            self._hb_stop.wait(1.0)

    # ---- receiving: every message is kept in ``log`` (arrival time in ._t), so a wait can look back
    def _pump(self, timeout: float) -> None:
        m = self.conn.recv_match(blocking=timeout > 0, timeout=timeout if timeout > 0 else None)
        if m is not None and m.get_type() != "BAD_DATA":
            m._t = time.monotonic()
            self.log.append(m)

    def drain(self) -> int:
        """Read what is waiting; returns the log position from which newer messages will be."""
        while (m := self.conn.recv_match(blocking=False)) is not None:
            if m.get_type() != "BAD_DATA":
                m._t = time.monotonic()
                self.log.append(m)
        return len(self.log)

    mark = drain

    def wait(self, pred, timeout: float = 5.0, since: int | None = None):
        """The first message (from log position ``since``, default: from now) satisfying pred, else None."""
        i = len(self.log) if since is None else since
        end = time.monotonic() + timeout
        while True:
            while i < len(self.log):
                if pred(self.log[i]):
                    return self.log[i]
                i += 1
            left = end - time.monotonic()
            if left <= 0:
                return None
            self._pump(min(left, 0.2))

    def wait_type(self, mtype: str, pred=lambda m: True, timeout: float = 5.0, since: int | None = None):
        return self.wait(lambda m: m.get_type() == mtype and pred(m), timeout, since)

    def collect(self, seconds: float) -> list:
        """Every message received from now for this long."""
        start = self.drain()
        end = time.monotonic() + seconds
        while (left := end - time.monotonic()) > 0:
            self._pump(min(left, 0.2))
        return self.log[start:]

    def heartbeat(self, pred=lambda m: True, timeout: float = 5.0):
        return self.wait_type("HEARTBEAT", lambda m: m.get_srcSystem() == 1 and pred(m), timeout)

    def command(self, command: int, *params: float, target: int = 1, use_int: bool = False, timeout: float = 5.0):
        """Send a COMMAND_LONG (or COMMAND_INT) and return its COMMAND_ACK (None if none came)."""
        p = list(params) + [0.0] * (7 - len(params))
        since = self.mark()
        if use_int:
            self.send(mavlink.MAVLink_command_int_message(target, 1, 0, command, 0, 0, *p[:4], int(p[4]),
                                                          int(p[5]), p[6]))
        else:
            self.send(mavlink.MAVLink_command_long_message(target, 1, command, 0, *p))
        return self.wait_type("COMMAND_ACK", lambda m: m.command == command, timeout, since)

    def param(self, name: str, timeout: float = 5.0):
        since = self.mark()
        self.send(mavlink.MAVLink_param_request_read_message(1, 1, name.encode(), -1))
        return self.wait_type("PARAM_VALUE", lambda m: m.param_id == name, timeout, since)

    def set_param(self, name: str, value: float, timeout: float = 5.0):
        since = self.mark()
        self.send(mavlink.MAVLink_param_set_message(1, 1, name.encode(), value, mavlink.MAV_PARAM_TYPE_REAL32))
        return self.wait_type("PARAM_VALUE", lambda m: m.param_id == name, timeout, since)

    def close(self) -> None:
        self.heartbeats(False)
        self.conn.close()


# --------------------------------------------------------------------------- fixtures

class Vehicle:
    def __init__(self, **kw):
        self.gcs_port, self.in_port = free_port(), free_port()
        self.gs = GroundStation(f"udpin:127.0.0.1:{self.gcs_port}")
        self.sim = LiveSim("W1", "cpd_ff", seed=7, mavlink=[f"udpout:127.0.0.1:{self.gcs_port}",
                                                            f"udpin:127.0.0.1:{self.in_port}"], **kw)
        self.fw, self.link = self.sim.firmware, self.sim.link
        self.defaults = self.fw.params.as_dict()

    def start(self) -> "Vehicle":
        self.sim.start()
        assert self.gs.heartbeat(timeout=10.0) is not None, "no heartbeat from the vehicle"
        end = time.monotonic() + 10.0
        while not self.fw.ekf.converged() and time.monotonic() < end:
            time.sleep(0.05)
        assert self.fw.ekf.converged()
        return self

    def stats(self) -> dict:
        return self.fw.scheduler.stats()

    def restore(self) -> None:
        """Test teardown: disarmed, MANUAL, default parameters, heartbeats on."""
        self.fw.request_arm(False)
        self.fw.request_mode(Mode.MANUAL)
        for name, value in self.defaults.items():
            if self.fw.params[name] != value:
                self.fw.params.set(name, value)
        self.gs.heartbeats(True)

    def stop(self) -> None:
        self.gs.close()
        self.sim.stop()


@pytest.fixture(scope="module")
def v():
    gc.collect()
    vehicle = Vehicle()
    gc.freeze()             # keep full collections (tens of ms with the stack loaded) out of the loop
    vehicle.gs.heartbeats(True)
    try:
        yield vehicle.start()
    finally:
        vehicle.stop()
        gc.unfreeze()


@pytest.fixture(autouse=True)
def _restore(request):
    yield
    if "v" in request.fixturenames:
        request.getfixturevalue("v").restore()


def rate(msgs, stamp) -> float:
    """Messages per second between the first and the last, on the vehicle's clock (stamp in s)."""
    t = [stamp(m) for m in msgs]
    return (len(t) - 1) / (t[-1] - t[0])


# --------------------------------------------------------------------------- identity and telemetry

def test_heartbeat_and_default_streams(v):
    msgs = v.gs.collect(4.2)
    by = {}
    for m in msgs:
        if m.get_srcSystem() == 1:
            by.setdefault(m.get_type(), []).append(m)
    hb = by["HEARTBEAT"]
    assert 3 <= len(hb) <= 6
    gaps = [b._t - a._t for a, b in zip(hb, hb[1:])]
    assert 0.6 < sum(gaps) / len(gaps) < 1.4                 # 1 Hz
    h = hb[-1]
    assert (h.type, h.autopilot, h.base_mode, h.custom_mode, h.system_status, h.mavlink_version) == (
        mavlink.MAV_TYPE_SUBMARINE, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, 81, Mode.MANUAL, mavlink.MAV_STATE_STANDBY, 3)
    assert h.get_srcComponent() == 1 and h.get_msgbuf()[0] == 0xFD      # MAVLink 2
    # ArduSub's default rates (Hz), measured on the vehicle's timestamps
    ms = lambda m: m.time_boot_ms / 1000.0 if hasattr(m, "time_boot_ms") else m._t   # noqa: E731
    for mtype, hz in (("ATTITUDE", 10), ("VFR_HUD", 10), ("GLOBAL_POSITION_INT", 3), ("LOCAL_POSITION_NED", 3),
                      ("SYSTEM_TIME", 3), ("SCALED_PRESSURE2", 2), ("RC_CHANNELS", 2)):
        assert mtype in by, mtype
        assert rate(by[mtype], ms) == pytest.approx(hz, rel=0.25), mtype
    assert rate(by["SERVO_OUTPUT_RAW"], lambda m: m.time_usec / 1e6) == pytest.approx(2, rel=0.25)
    assert 1.4 <= len(by["SYS_STATUS"]) / 4.2 <= 3.0        # no timestamp: count it
    # Contents: the position messages of one tick agree with each other and with the estimate
    lp = by["LOCAL_POSITION_NED"][-1]
    depth = lp.z
    assert depth == pytest.approx(v.fw.last.x_hat[1], abs=1.0) and lp.y == 0.0
    gp = next(m for m in by["GLOBAL_POSITION_INT"] if m.time_boot_ms == lp.time_boot_ms)
    assert gp.alt == pytest.approx(-1000 * depth, abs=2) and gp.relative_alt == gp.alt
    assert gp.vz == pytest.approx(100 * lp.vz, abs=1) and gp.vx == pytest.approx(100 * lp.vx, abs=1)
    assert gp.lat / 1e7 == pytest.approx(v.fw.params["WK_ORIGIN_LAT"] + math.degrees(lp.x / 6378137.0), abs=2e-7)
    assert gp.lon / 1e7 == pytest.approx(v.fw.params["WK_ORIGIN_LON"], abs=1e-6)
    sp = min(by["SCALED_PRESSURE2"], key=lambda m: abs(m.time_boot_ms - lp.time_boot_ms))
    assert sp.press_abs == pytest.approx(depth_to_pressure(depth) / 100.0, abs=25.0)    # measured, 0.25 m
    assert sp.temperature == 1000
    att = by["ATTITUDE"][-1]
    assert att.roll == 0.0 and att.yaw == 0.0 and abs(att.pitch) < 0.5
    assert by["VFR_HUD"][-1].alt == pytest.approx(-depth, abs=1.0)
    servo = by["SERVO_OUTPUT_RAW"][-1]
    assert servo.port == 0 and [getattr(servo, f"servo{i}_raw") for i in range(1, 9)] == [1500] * 8
    ss = by["SYS_STATUS"][-1]
    assert ss.onboard_control_sensors_present & mavlink.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE
    assert ss.onboard_control_sensors_health & mavlink.MAV_SYS_STATUS_AHRS          # EKF converged
    assert not ss.onboard_control_sensors_enabled & mavlink.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS   # disarmed
    named = {m.name: m.value for m in by["NAMED_VALUE_FLOAT"]}
    assert set(named) == {"FF_AGE", "FF_ON", "FF_X", "FF_Z", "FF_M", "TICK_P99", "TICK_MISS"}
    assert 0.0 < named["TICK_P99"] < 50.0 and named["TICK_MISS"] >= 0.0   # control-task compute p99 (ms)
    assert named["FF_AGE"] >= 0.0 and named["FF_ON"] == 0.0        # a forecast, but disarmed: FF off


def test_request_data_stream_and_message_interval(v):
    gs = v.gs
    attitude = lambda s: [m for m in gs.collect(s) if m.get_type() == "ATTITUDE"]   # noqa: E731
    gs.send(mavlink.MAVLink_request_data_stream_message(1, 1, mavlink.MAV_DATA_STREAM_EXTRA1, 2, 1))
    time.sleep(0.3)
    gs.drain()
    slow = attitude(2.1)
    assert 3 <= len(slow) <= 6 and rate(slow, lambda m: m.time_boot_ms / 1e3) == pytest.approx(2, rel=0.3)
    assert v.fw.params["SR0_EXTRA1"] == 2
    # A per-message interval overrides the group: ATTITUDE at 20 Hz
    ack = gs.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_ATTITUDE, 50_000)
    assert ack.result == MAV_RESULT.ACCEPTED
    fast = attitude(1.0)
    assert rate(fast, lambda m: m.time_boot_ms / 1e3) == pytest.approx(20, rel=0.2)
    # GET_MESSAGE_INTERVAL reports it
    gs.drain()
    gs.send(mavlink.MAVLink_command_long_message(1, 1, mavlink.MAV_CMD_GET_MESSAGE_INTERVAL, 0,
                                                 mavlink.MAVLINK_MSG_ID_ATTITUDE, 0, 0, 0, 0, 0, 0))
    mi = gs.wait_type("MESSAGE_INTERVAL")
    assert (mi.message_id, mi.interval_us) == (mavlink.MAVLINK_MSG_ID_ATTITUDE, 50_000)
    # −1 turns a message off, 0 brings back its default
    assert gs.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_VFR_HUD, -1).result == 0
    time.sleep(0.2)
    gs.drain()
    assert not [m for m in gs.collect(0.8) if m.get_type() == "VFR_HUD"]
    assert gs.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_VFR_HUD, 0).result == 0
    assert gs.wait_type("VFR_HUD", timeout=2.0) is not None
    # REQUEST_DATA_STREAM start_stop 0 stops a group (and resets its messages' own intervals)
    gs.send(mavlink.MAVLink_request_data_stream_message(1, 1, mavlink.MAV_DATA_STREAM_EXTRA1, 10, 0))
    time.sleep(0.3)
    assert v.fw.params["SR0_EXTRA1"] == 0
    gs.drain()
    assert not attitude(0.8)
    # An unknown message id is refused with ArduPilot's words
    gs.drain()
    gs.send(mavlink.MAVLink_command_long_message(1, 1, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 0, 12345, 1e5,
                                                 0, 0, 0, 0, 0))
    gs.send(mavlink.MAVLink_request_data_stream_message(1, 1, mavlink.MAV_DATA_STREAM_ALL, 4, 1))
    replies = [m for m in gs.collect(0.6) if m.get_type() in ("COMMAND_ACK", "STATUSTEXT")]
    assert [m.result for m in replies if m.get_type() == "COMMAND_ACK"] == [MAV_RESULT.DENIED]
    assert [m.text for m in replies if m.get_type() == "STATUSTEXT"] == ["No ap_message for mavlink id (12345)"]
    assert all(v.fw.params[g] == 4 for g in ("SR0_RAW_SENS", "SR0_EXTRA1", "SR0_EXTRA3"))


def test_request_message_capabilities_and_timesync(v):
    gs = v.gs
    ack = gs.command(mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION)
    assert ack.result == MAV_RESULT.ACCEPTED and (ack.target_system, ack.target_component) == (255, 190)
    av = gs.wait_type("AUTOPILOT_VERSION")
    assert av.capabilities == CAPABILITIES
    assert av.capabilities & mavlink.MAV_PROTOCOL_CAPABILITY_MAVLINK2
    assert av.capabilities & mavlink.MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT
    assert not av.capabilities & mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_INT
    assert gs.command(mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, 1).result == MAV_RESULT.ACCEPTED
    assert gs.wait_type("AUTOPILOT_VERSION") is not None
    # Any streamed message, once, on request — also while its stream is off
    v.fw.params.set("SR0_EXTRA3", 0)
    assert gs.command(mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_SYSTEM_TIME).result == 0
    st = gs.wait_type("SYSTEM_TIME")
    assert st is not None and abs(st.time_unix_usec / 1e6 - time.time()) < 5
    assert gs.command(mavlink.MAV_CMD_REQUEST_MESSAGE, 9999).result == MAV_RESULT.FAILED
    # TIMESYNC: answered with the vehicle's time, our timestamp echoed; answers are not answered
    gs.drain()
    gs.send(mavlink.MAVLink_timesync_message(0, 123456789))
    ts = gs.wait_type("TIMESYNC", lambda m: m.ts1 == 123456789)
    assert ts is not None and ts.tc1 > 0
    gs.send(mavlink.MAVLink_timesync_message(5, 42))
    assert gs.wait_type("TIMESYNC", lambda m: m.ts1 == 42, timeout=1.0) is None


@pytest.fixture
def fast_heartbeat(v):
    """HEARTBEAT at 5 Hz (SET_MESSAGE_INTERVAL) so that state changes show sooner; back to 1 Hz after."""
    assert v.gs.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_HEARTBEAT, 200_000).result == 0
    yield
    v.gs.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_HEARTBEAT, 0)


def test_unknown_commands_and_wrong_targets(v, fast_heartbeat):
    gs = v.gs
    assert gs.command(31337, 1, 2, 3).result == MAV_RESULT.UNSUPPORTED
    assert gs.command(31337, use_int=True).result == MAV_RESULT.UNSUPPORTED
    # COMMAND_INT carries the same commands
    assert gs.command(mavlink.MAV_CMD_DO_SET_MODE, 1, Mode.STABILIZE, use_int=True).result == 0
    assert gs.heartbeat(lambda m: m.custom_mode == Mode.STABILIZE) is not None
    # Addressed to another system: ignored (no ACK, no effect) and counted
    before = v.link.counters["rx_wrong_target"]
    assert gs.command(mavlink.MAV_CMD_DO_SET_MODE, 1, Mode.MANUAL, target=7, timeout=1.5) is None
    gs.send(mavlink.MAVLink_param_set_message(9, 1, b"WK_FF_GAIN", 0.25, mavlink.MAV_PARAM_TYPE_REAL32))
    gs.send(mavlink.MAVLink_manual_control_message(0, 1000, 0, 500, 0, 0))   # sticks must name the vehicle
    time.sleep(0.5)
    assert v.fw.mode == Mode.STABILIZE and v.fw.params["WK_FF_GAIN"] == 1.0
    assert v.link.counters["rx_wrong_target"] >= before + 3
    # Broadcast (target 0) is accepted where allowed
    assert gs.command(mavlink.MAV_CMD_DO_SET_MODE, 1, Mode.MANUAL, target=0).result == 0


# --------------------------------------------------------------------------- modes and arming

def test_mode_switches_and_unknown_mode(v, fast_heartbeat):
    gs = v.gs
    gs.drain()
    gs.send(mavlink.MAVLink_set_mode_message(1, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, Mode.STABILIZE))
    ack = gs.wait_type("COMMAND_ACK", lambda m: m.command == mavlink.MAVLINK_MSG_ID_SET_MODE)
    assert ack.result == MAV_RESULT.ACCEPTED
    assert gs.heartbeat(lambda m: m.custom_mode == Mode.STABILIZE).base_mode == 81
    since = gs.mark()
    assert gs.command(mavlink.MAV_CMD_DO_SET_MODE, 1, Mode.POSHOLD).result == MAV_RESULT.ACCEPTED
    assert gs.heartbeat(lambda m: m.custom_mode == Mode.POSHOLD).base_mode == 89     # GUIDED_ENABLED
    assert gs.wait_type("STATUSTEXT", lambda m: m.text == "Mode POSHOLD", timeout=2.0, since=since) is not None
    for bad in (Mode.AUTO, 42, Mode.MOTOR_DETECT):
        assert gs.command(mavlink.MAV_CMD_DO_SET_MODE, 1, bad).result == MAV_RESULT.FAILED
    gs.drain()
    gs.send(mavlink.MAVLink_set_mode_message(1, 1, 77))
    assert gs.wait_type("COMMAND_ACK", lambda m: m.command == 11).result == MAV_RESULT.FAILED
    assert gs.heartbeat().custom_mode == Mode.POSHOLD and v.fw.mode == Mode.POSHOLD
    # Without the custom-mode flag ArduPilot's base modes are not supported
    assert gs.command(mavlink.MAV_CMD_DO_SET_MODE, 0, Mode.MANUAL).result == MAV_RESULT.UNSUPPORTED
    assert gs.command(mavlink.MAV_CMD_DO_SET_MODE, 1, Mode.MANUAL).result == MAV_RESULT.ACCEPTED


def test_arming_prearm_failure_then_force_then_success(v, fast_heartbeat):
    gs = v.gs
    assert gs.set_param("WK_EKF_CONV", 1e-4).param_value == pytest.approx(1e-4)   # nothing converges to that
    assert v.fw.params["WK_EKF_CONV"] == 1e-4                                        # the float32 tidied
    since = gs.mark()
    ack = gs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    assert ack.result == MAV_RESULT.FAILED
    assert gs.wait_type("STATUSTEXT", lambda m: m.text.startswith("PreArm"), timeout=2.0, since=since) is not None
    assert not gs.heartbeat().base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED
    assert gs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1, 21196).result == MAV_RESULT.ACCEPTED
    assert gs.heartbeat(lambda m: m.base_mode == 209) is not None
    assert gs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0).result == MAV_RESULT.ACCEPTED
    assert gs.heartbeat(lambda m: m.base_mode == 81) is not None
    gs.set_param("WK_EKF_CONV", 0.3)
    assert gs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == MAV_RESULT.ACCEPTED
    hb = gs.heartbeat(lambda m: m.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
    assert hb.base_mode == 209 and hb.system_status == mavlink.MAV_STATE_ACTIVE
    assert gs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 2).result == MAV_RESULT.UNSUPPORTED
    assert gs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0).result == MAV_RESULT.ACCEPTED


# --------------------------------------------------------------------------- pilot input and outputs

def servos(m) -> list[int]:
    return [getattr(m, f"servo{i}_raw") for i in range(1, 9)]


@pytest.fixture
def fast_servo(v):
    assert v.gs.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, SERVO, 50_000).result == 0
    yield
    v.gs.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, SERVO, 0)


def test_disarmed_neutral_then_manual_control_and_rc_override_move_the_servos(v, fast_servo):
    gs = v.gs
    gs.send(mavlink.MAVLink_manual_control_message(1, 800, 0, 900, 0, 0))
    time.sleep(0.3)
    gs.drain()
    assert all(servos(m) == [1500] * 8 for m in gs.collect(0.5) if m.get_type() == "SERVO_OUTPUT_RAW")
    assert gs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == 0
    # Forward stick in MANUAL: the four horizontal thrusters (1-4) push
    for _ in range(15):
        gs.send(mavlink.MAVLink_manual_control_message(1, 600, 0, 500, 0, 0))
        time.sleep(0.1)
    out = [m for m in gs.collect(0.4) if m.get_type() in ("SERVO_OUTPUT_RAW", "RC_CHANNELS")]
    s = [servos(m) for m in out if m.get_type() == "SERVO_OUTPUT_RAW"][-1]
    assert all(abs(p - 1500) > 50 for p in s[:4]) and all(abs(p - 1500) < 30 for p in s[4:])
    rc = [m for m in out if m.get_type() == "RC_CHANNELS"]
    assert rc and rc[-1].chan5_raw == 1740 and rc[-1].chan3_raw == 1500
    # RC override in ArduSub's channel order: 3 throttle up → the vertical thrusters (5-8)
    for _ in range(15):
        gs.send(mavlink.MAVLink_rc_channels_override_message(1, 1, 1500, 65535, 1800, 65535, 1500, 65535, 0, 0))
        time.sleep(0.1)
    s = servos(gs.wait_type("SERVO_OUTPUT_RAW", since=gs.mark()))
    assert all(abs(p - 1500) > 50 for p in s[4:]) and all(abs(p - 1500) < 30 for p in s[:4])
    assert gs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0).result == 0
    assert gs.wait_type("SERVO_OUTPUT_RAW", lambda m: servos(m) == [1500] * 8, timeout=2.0) is not None


def test_motor_test_armed_only_and_times_out(v, fast_servo):
    gs = v.gs
    motor_test = mavlink.MAV_CMD_DO_MOTOR_TEST
    assert gs.command(motor_test, 1, mavlink.MOTOR_TEST_THROTTLE_PWM, 1700, 1).result == MAV_RESULT.DENIED
    assert gs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == 0
    for _ in range(6):                         # the GCS re-sends at >= 2 Hz
        assert gs.command(motor_test, 3, mavlink.MOTOR_TEST_THROTTLE_PWM, 1700, 1).result == 0
        time.sleep(0.2)
    s = servos(gs.wait_type("SERVO_OUTPUT_RAW", since=gs.mark()))
    assert s[2] == 1700 and s[:2] + s[3:] == [1500] * 7
    # 0.5 s after the last command the motor stops
    assert gs.wait_type("SERVO_OUTPUT_RAW", lambda m: servos(m) == [1500] * 8, timeout=2.0) is not None
    # percent of the ESC range: 75 % → 1700 µs
    assert gs.command(motor_test, 2, mavlink.MOTOR_TEST_THROTTLE_PERCENT, 75, 1).result == 0
    assert gs.wait_type("SERVO_OUTPUT_RAW", lambda m: m.servo2_raw == 1700, timeout=1.0) is not None
    assert gs.command(motor_test, 9, 1, 1700, 1).result == MAV_RESULT.DENIED
    assert gs.command(motor_test, 1, mavlink.MOTOR_TEST_THROTTLE_PILOT, 0, 1).result == MAV_RESULT.FAILED


def test_position_target_only_in_guided(v, fast_heartbeat):
    gs = v.gs
    x0, z0 = v.fw.last.x_hat[:2]
    ignored = v.link.counters["rx_ignored"]
    sp = v.fw.setpoint.copy()
    gs.send(mavlink.MAVLink_set_position_target_local_ned_message(0, 1, 1, mavlink.MAV_FRAME_LOCAL_NED, POS_ONLY,
                                                                  x0 + 1, 0, z0 + 1, 0, 0, 0, 0, 0, 0, 0, 0))
    time.sleep(0.4)
    assert (v.fw.setpoint == sp).all() and v.link.counters["rx_ignored"] == ignored + 1   # MANUAL: ignored
    assert gs.command(mavlink.MAV_CMD_DO_SET_MODE, 1, Mode.GUIDED).result == 0
    assert gs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == 0
    target = (float(x0) + 0.3, float(z0) + 0.4)
    gs.send(mavlink.MAVLink_set_position_target_local_ned_message(0, 1, 1, mavlink.MAV_FRAME_LOCAL_NED, POS_ONLY,
                                                                  target[0], 0, target[1], 0, 0, 0, 0, 0, 0, 0, 0))
    end = time.monotonic() + 3
    while time.monotonic() < end and abs(v.fw.setpoint[1] - target[1]) > 1e-4:
        time.sleep(0.05)
    assert v.fw.setpoint[:2].tolist() == pytest.approx(list(target), abs=1e-4)
    # The vehicle goes there: LOCAL_POSITION_NED (at 10 Hz here) settles near the new target
    gs.send(mavlink.MAVLink_request_data_stream_message(1, 1, mavlink.MAV_DATA_STREAM_POSITION, 10, 1))
    since, end, z = gs.mark(), time.monotonic() + 10, []
    while time.monotonic() < end:
        lp = gs.wait_type("LOCAL_POSITION_NED", timeout=1.0, since=since)
        since = gs.log.index(lp) + 1 if lp is not None else len(gs.log)
        z = (z + [lp.z] if lp is not None else z)[-10:]
        if len(z) == 10 and abs(sum(z) / 10 - target[1]) < 0.1:
            break
    assert len(z) == 10 and abs(sum(z) / 10 - target[1]) < 0.1, z
    # Position-ignore bits are honoured: x ignored, depth moves
    gs.send(mavlink.MAVLink_set_position_target_local_ned_message(0, 1, 1, mavlink.MAV_FRAME_LOCAL_NED,
                                                                  POS_ONLY | 1, 99, 0, 5.2, 0, 0, 0, 0, 0, 0, 0, 0))
    time.sleep(0.4)
    assert v.fw.setpoint[:2].tolist() == pytest.approx([target[0], 5.2], abs=1e-4)
    # Velocity-only targets are not supported, NaN positions are refused: both counted, target kept
    before = v.link.counters["rx_ignored"]
    gs.send(mavlink.MAVLink_set_position_target_local_ned_message(0, 1, 1, mavlink.MAV_FRAME_LOCAL_NED,
                                                                  0b110111000111, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0))
    gs.send(mavlink.MAVLink_set_position_target_local_ned_message(0, 1, 1, mavlink.MAV_FRAME_LOCAL_NED, POS_ONLY,
                                                                  math.nan, 0, 5.0, 0, 0, 0, 0, 0, 0, 0, 0))
    time.sleep(0.4)
    assert v.link.counters["rx_ignored"] == before + 2
    assert v.fw.setpoint[:2].tolist() == pytest.approx([target[0], 5.2], abs=1e-4)


# --------------------------------------------------------------------------- parameters

def test_parameter_protocol(v):
    gs = v.gs
    params = v.fw.params
    gs.drain()
    gs.send(mavlink.MAVLink_param_request_list_message(1, 1))
    got, end = {}, time.monotonic() + 10
    while len(got) < len(params) and time.monotonic() < end:
        m = gs.wait_type("PARAM_VALUE", timeout=1.0)
        if m is not None:
            assert m.param_count == len(params) and m.param_type == mavlink.MAV_PARAM_TYPE_REAL32
            got[m.param_index] = (m.param_id, m.param_value)
    assert sorted(got) == list(range(len(params)))
    assert [got[i][0] for i in range(len(params))] == params.names()
    assert got[params.index_of("SYSID_MYGCS")][1] == 255
    # Read by name and by index
    m = gs.param("WK_PD_KP_X")
    assert m.param_value == pytest.approx(params["WK_PD_KP_X"]) and m.param_index == params.index_of("WK_PD_KP_X")
    gs.drain()
    gs.send(mavlink.MAVLink_param_request_read_message(1, 1, b"", 3))
    m = gs.wait_type("PARAM_VALUE")
    assert (m.param_id, m.param_index) == (params.by_index(3)[0], 3)
    # Set: accepted → the new value comes back
    assert gs.set_param("WK_FF_GAIN", 0.5).param_value == pytest.approx(0.5) and params["WK_FF_GAIN"] == 0.5
    # Out of range, NaN, not an integer: refused, the old value re-sent, and said why
    for bad in (99.0, math.nan, math.inf):
        since = gs.mark()
        assert gs.set_param("WK_FF_GAIN", bad).param_value == pytest.approx(0.5)
        assert gs.wait_type("STATUSTEXT", lambda m: m.text.startswith("WK_FF_GAIN not set"), 2, since) is not None
    assert gs.set_param("FS_GCS_ENABLE", 1.5).param_value == params["FS_GCS_ENABLE"] == 2
    assert params["WK_FF_GAIN"] == 0.5
    # Unknown names are ignored (nothing comes back) and counted
    before = v.link.counters["rx_ignored"]
    assert gs.set_param("NO_SUCH_PARAM", 1.0, timeout=1.0) is None
    assert gs.param("NO_SUCH_PARAM", timeout=0.5) is None
    assert v.link.counters["rx_ignored"] == before + 2


# --------------------------------------------------------------------------- robustness

def frame(msg, seq: int = 0) -> bytes:
    mav = mavlink.MAVLink(None, 255, 190)
    mav.seq = seq
    return bytes(msg.pack(mav))


def test_garbage_truncated_and_hostile_values_are_counted_and_survived(v, fast_heartbeat):
    gs, link = v.gs, v.link
    rng = random.Random(1)
    c0, s0 = dict(link.counters), v.stats()
    raw = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    valid = frame(mavlink.MAVLink_command_long_message(1, 1, mavlink.MAV_CMD_DO_SET_MODE, 0, 1, 16, 0, 0, 0, 0, 0))
    bad_crc = bytearray(valid)
    bad_crc[-1] ^= 0xFF
    unknown_id = bytes([0xFD, 4, 0, 0, 0, 255, 190, 0xDE, 0xBC, 0x0A]) + b"\1\2\3\4" + b"\0\0"
    junk = [rng.randbytes(rng.randint(1, 300)) for _ in range(40)]
    junk += [valid[:k] for k in range(1, len(valid))]               # every truncation of a valid frame
    junk += [bytes(bad_crc), b"\xfd\xff" + rng.randbytes(20), b"\xfe\x05" + bytes(10), unknown_id,
             b"\xfd" * 600, bytes(valid[:-3]) + valid]
    for j in junk:
        raw.sendto(j, ("127.0.0.1", v.in_port))                    # the vehicle's udpin endpoint
        gs.send_raw(j)                                              # and its udpout endpoint
    raw.close()
    # Well-formed messages with hostile values
    nan, inf = math.nan, math.inf
    assert gs.command(mavlink.MAV_CMD_DO_SET_MODE, 1, nan).result == MAV_RESULT.FAILED
    assert gs.command(mavlink.MAV_CMD_DO_SET_MODE, inf, 1e30).result == MAV_RESULT.FAILED
    assert gs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, nan).result == MAV_RESULT.UNSUPPORTED
    assert gs.command(mavlink.MAV_CMD_DO_MOTOR_TEST, inf, 1, nan, -inf).result == MAV_RESULT.FAILED
    assert gs.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 1e30, 1e30).result == MAV_RESULT.DENIED
    assert gs.command(mavlink.MAV_CMD_REQUEST_MESSAGE, -inf).result == MAV_RESULT.FAILED
    assert gs.command(mavlink.MAV_CMD_DO_SET_MODE, 1, 2**40, use_int=True).result == MAV_RESULT.FAILED
    gs.send(mavlink.MAVLink_manual_control_message(1, -32768, 32767, -32768, 32767, 65535))
    gs.send(mavlink.MAVLink_rc_channels_override_message(1, 1, *([65534] * 8)))
    gs.send(mavlink.MAVLink_request_data_stream_message(1, 1, 200, 65535, 1))
    gs.send(mavlink.MAVLink_request_data_stream_message(1, 1, 1, 65535, 7))
    gs.send(mavlink.MAVLink_param_request_read_message(1, 1, b"\xff\xfe\x00", 30000))
    gs.send(mavlink.MAVLink_param_set_message(1, 1, b"\xff\xfe\xfd", inf, 200))
    gs.send(mavlink.MAVLink_mission_request_list_message(1, 1, 0))
    assert gs.wait_type("MISSION_COUNT", lambda m: m.count == 0, timeout=2.0) is not None
    # Still the same vehicle: alive, responsive, on time
    assert gs.command(mavlink.MAV_CMD_DO_SET_MODE, 1, Mode.POSHOLD).result == 0
    assert gs.heartbeat(lambda m: m.custom_mode == Mode.POSHOLD) is not None
    s1, c1 = v.stats(), link.counters
    assert link.alive
    assert c1["rx_bad"] - c0["rx_bad"] >= 2 * 40                   # every junk datagram counted, on both sockets
    assert c1["rx_unsupported"] > c0["rx_unsupported"]
    assert c1["handler_errors"] == c0["handler_errors"] and c1["io_errors"] == c0["io_errors"]
    assert s1["tasks"]["gcs"]["errors"] == 0 and s1["overruns"] - s0["overruns"] <= 3
    assert v.fw.params["SR0_RAW_SENS"] == v.defaults["SR0_RAW_SENS"]      # start_stop 7: ignored


def test_flood_keeps_the_loop_on_time(v):
    """About 3000 messages in one second from a second GCS: the vehicle keeps 20 Hz and its heartbeat."""
    link = v.link
    flood = mavutil.mavlink_connection(f"udpout:127.0.0.1:{v.in_port}", source_system=255, source_component=191,
                                       dialect="ardupilotmega")
    kinds = [mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_GCS, 8, 0, 0, 0, 3),
             mavlink.MAVLink_manual_control_message(1, 0, 0, 500, 0, 0),
             mavlink.MAVLink_command_long_message(1, 1, 31337, 0, 0, 0, 0, 0, 0, 0, 0),
             mavlink.MAVLink_param_request_read_message(1, 1, b"", 5),
             mavlink.MAVLink_timesync_message(0, 1),
             mavlink.MAVLink_system_time_message(0, 0)]
    sent = [0]

    def blast():
        t0 = time.monotonic()
        for burst in range(100):                                   # 100 bursts of 30, one every 10 ms
            for i in range(30):
                flood.mav.send(kinds[(burst + i) % len(kinds)])
                sent[0] += 1
            delay = t0 + (burst + 1) * 0.01 - time.monotonic()
            if delay > 0:
                time.sleep(delay)

    s0, c0 = v.stats(), dict(link.counters)
    t0 = time.monotonic()
    th = threading.Thread(target=blast)
    th.start()
    msgs = v.gs.collect(3.0)
    th.join()
    elapsed = time.monotonic() - t0
    s1, c1 = v.stats(), link.counters
    flood.close()
    assert sent[0] == 3000
    assert c1["rx"] - c0["rx"] >= 1500                     # most of it arrived (UDP may drop some)
    hb = [m._t for m in msgs if m.get_type() == "HEARTBEAT"]
    assert len(hb) >= 2 and max(b - a for a, b in zip([t0] + hb, hb + [time.monotonic()])) < 2.0
    assert s1["ticks"] - s0["ticks"] >= 0.85 * 20 * elapsed                         # 20 Hz kept
    assert s1["overruns"] - s0["overruns"] <= 3
    assert s1["tasks"]["gcs"]["compute"]["p50_us"] < 5000
    assert link.alive and v.gs.command(mavlink.MAV_CMD_REQUEST_MESSAGE, 148).result == 0


# --------------------------------------------------------------------------- failsafe

def test_gcs_failsafe_disarms_after_silence(v, fast_heartbeat):
    gs = v.gs
    assert gs.set_param("FS_GCS_TIMEOUT", 1.0).param_value == 1.0
    assert gs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == 0
    time.sleep(1.6)                                     # heartbeats keep it armed past the timeout
    assert v.fw.armed
    gs.heartbeats(False)
    t0, since = time.monotonic(), gs.mark()
    assert gs.wait_type("STATUSTEXT", lambda m: m.text == "GCS failsafe", timeout=6.0, since=since) is not None
    hb = gs.heartbeat(lambda m: not m.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED, timeout=3.0)
    assert hb is not None and hb.system_status == mavlink.MAV_STATE_CRITICAL
    assert 0.8 < time.monotonic() - t0 < 5.0
    since = gs.mark()
    gs.heartbeats(True)
    assert gs.wait_type("STATUSTEXT", lambda m: m.text == "GCS failsafe cleared", timeout=4.0, since=since) is not None
    assert gs.heartbeat(lambda m: m.system_status == mavlink.MAV_STATE_STANDBY) is not None


# --------------------------------------------------------------------------- endpoints

def test_a_second_endpoint_gets_its_own_replies(v):
    gs2 = GroundStation(f"udpout:127.0.0.1:{v.in_port}", sysid=254, compid=1)
    try:
        gs2.send(mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_GCS, 8, 0, 0, 0, 3))
        assert gs2.heartbeat() is not None                          # udpin replies once spoken to
        v.gs.drain()
        ack = gs2.command(mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION)
        assert ack.result == 0 and ack.target_system == 254
        assert gs2.wait_type("AUTOPILOT_VERSION") is not None
        assert not [m for m in v.gs.collect(0.5) if m.get_type() in ("COMMAND_ACK", "AUTOPILOT_VERSION")]
        # Pilot input from a system that is not SYSID_MYGCS is refused
        before = v.link.counters["rx_ignored"]
        gs2.send(mavlink.MAVLink_manual_control_message(1, 1000, 0, 500, 0, 0))
        time.sleep(0.4)
        assert v.link.counters["rx_ignored"] == before + 1
    finally:
        gs2.close()


def test_tcp_server_endpoint_with_the_loop_driven_by_hand():
    """``tcpin:`` with a pymavlink ``tcp:`` client; the link's task is called as a scheduler would."""
    from sitl.run import build_mission
    m = build_mission("W1", "cpd", params=load_params())
    port = free_port(socket.SOCK_STREAM)
    link = MavlinkLink(m.firmware, [f"tcpin:127.0.0.1:{port}"]).start()
    client = None
    try:
        client = GroundStation(f"tcp:127.0.0.1:{port}")
        stop = threading.Event()

        def fly():
            while not stop.is_set():
                slot = m.firmware.scheduler.next_slot_ns()
                m.firmware.scheduler.run_tick()
                m.hal.step_world()
                link.update(slot)
                time.sleep(0.01)

        th = threading.Thread(target=fly, daemon=True)
        th.start()
        try:
            hb = client.heartbeat(timeout=5.0)
            assert hb is not None and hb.type == mavlink.MAV_TYPE_SUBMARINE
            assert client.command(mavlink.MAV_CMD_DO_SET_MODE, 1, Mode.ALT_HOLD).result == 0
            assert client.heartbeat(lambda h: h.custom_mode == Mode.ALT_HOLD) is not None
        finally:
            stop.set()
            th.join()
    finally:
        if client is not None:
            client.close()
        link.stop()
    assert not link.alive


def test_telemetry_packs_whatever_the_estimate_holds():
    """NaN and huge values in the firmware's state become valid (clipped) messages, never an exception."""
    import dataclasses

    import numpy as np
    from sitl.run import build_mission
    m = build_mission("W1", "cpd", params=load_params())
    fw = m.firmware
    link = MavlinkLink(fw, [f"udpout:127.0.0.1:{free_port()}"])
    try:
        fw.scheduler.run_tick()
        for x_hat in (np.full(6, np.nan), np.full(6, np.inf), np.array([1e12, -1e12, 1e3, 1e9, -1e9, 1e9])):
            fw.last = dataclasses.replace(fw.last, x_hat=x_hat, tau_e_hat=x_hat[:3])
            for mid in list(link._overrides) + [mavlink.MAVLINK_MSG_ID_HEARTBEAT]:
                link._overrides.pop(mid, None)
            link._next_due.clear()
            link._interval.clear()
            link._outbox.clear()
            link.update(fw.scheduler.next_slot_ns())
            types = set()
            mav = mavlink.MAVLink(None, 1, 1)
            for _ep, msg in link._outbox:
                msg.pack(mav)
                types.add(msg.get_type())
            assert link.counters["handler_errors"] == 0, link.last_error
            assert {"HEARTBEAT", "ATTITUDE", "GLOBAL_POSITION_INT", "LOCAL_POSITION_NED", "VFR_HUD",
                    "SERVO_OUTPUT_RAW", "NAMED_VALUE_FLOAT", "SYS_STATUS"} <= types
    finally:
        link.stop()


def test_bad_construction_is_refused():
    from sitl.run import build_mission
    fw = build_mission("W1", "cpd", params=load_params()).firmware
    for bad in ("serial:/dev/ttyS0", "udpout:127.0.0.1", "udpin:host:port", "tcp::5760", "udpout:127.0.0.1:0"):
        with pytest.raises(ValueError):
            MavlinkLink(fw, [bad])
    with pytest.raises(ValueError):
        MavlinkLink(fw, ["udpout:127.0.0.1:14550"], signing_key=b"short")
    port = free_port()
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as busy:
        busy.bind(("127.0.0.1", port))
        with pytest.raises(OSError, match=f"udpin:127.0.0.1:{port}"):
            MavlinkLink(fw, [f"udpin:127.0.0.1:{port}"])


# --------------------------------------------------------------------------- signing

def test_load_signing_key(tmp_path):
    key = bytes(range(32))
    for name, data in (("raw", key), ("hex", key.hex().encode() + b"\n"),
                       ("b64", __import__("base64").b64encode(key) + b"\n")):
        (tmp_path / name).write_bytes(data)
        assert load_signing_key(tmp_path / name) == key
    (tmp_path / "bad").write_text("not a key\n")
    with pytest.raises(ValueError, match="32 raw bytes, 64 hex digits or base64"):
        load_signing_key(tmp_path / "bad")
    with pytest.raises(OSError):
        load_signing_key(tmp_path / "missing")


def test_signing_rejects_unsigned_and_wrongly_signed_commands():
    key = bytes(range(1, 33))
    gcs_port = free_port()
    gs = GroundStation(f"udpin:127.0.0.1:{gcs_port}")
    sim = LiveSim("W1", "cpd", mavlink=[f"udpout:127.0.0.1:{gcs_port}"], signing_key=key).start()
    try:
        assert gs.heartbeat(timeout=10.0) is not None          # signed, but readable without the key
        request = (mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION)
        assert gs.command(*request, timeout=1.5) is None        # unsigned: dropped
        assert sim.link.counters["rx_unsigned"] >= 1
        gs.conn.setup_signing(bytes(32), sign_outgoing=True)   # the wrong key: dropped too
        before = sim.link.counters["rx_unsigned"]
        assert gs.command(*request, timeout=1.5) is None
        assert sim.link.counters["rx_unsigned"] > before
        gs.conn.setup_signing(key, sign_outgoing=True)          # the right key
        ack = gs.command(*request)
        assert ack is not None and ack.result == MAV_RESULT.ACCEPTED
        hb = gs.heartbeat()
        assert hb.get_signed()                                  # the vehicle signs what it sends
        assert sim.link.counters["rx_bad"] == 0
    finally:
        gs.close()
        sim.stop()


# --------------------------------------------------------------------------- MAVProxy acceptance

def _mavproxy_available() -> bool:
    try:
        import MAVProxy  # noqa: F401
    except ImportError:
        return False
    return True


@pytest.mark.skipif(not _mavproxy_available(),
                    reason="MAVProxy not installed (pip install --no-deps MAVProxy pyserial)")
def test_unmodified_mavproxy_flies_the_sub(tmp_path):
    """Headless MAVProxy: sees a Sub with ArduSub's mode names, switches to POSHOLD, arms, lists and sets
    parameters, and sees SERVO_OUTPUT_RAW move."""
    port = free_port()
    sim = LiveSim("W1", "cpd_ff", mavlink=[f"udpout:127.0.0.1:{port}"]).start()
    proc = subprocess.Popen([sys.executable, "-m", "MAVProxy.mavproxy", f"--master=udpin:127.0.0.1:{port}",
                             "--no-state", "--default-modules=param,mode,arm,cmdlong,misc"],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            cwd=tmp_path, env={**os.environ, "PYTHONUNBUFFERED": "1"})
    lines: list[str] = []
    reader = threading.Thread(target=lambda: lines.extend(proc.stdout), daemon=True)
    reader.start()

    def expect(pattern: str, timeout: float = 10.0, since: int = 0) -> re.Match:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            for line in lines[since:]:
                if (m := re.search(pattern, line)) is not None:
                    return m
            time.sleep(0.05)
        raise AssertionError(f"MAVProxy never printed /{pattern}/; it printed:\n" + "".join(lines[-40:]))

    def do(command: str, pattern: str, timeout: float = 10.0) -> re.Match:
        since = len(lines)
        proc.stdin.write(command + "\n")
        proc.stdin.flush()
        return expect(pattern, timeout, since)

    try:
        expect(r"Detected vehicle 1:1")
        expect(rf"Received {len(sim.firmware.params)} parameters", timeout=15.0)     # the whole list
        modes = do("mode", r"Available modes: (.*)")                    # ArduSub's mode names: a Sub
        assert {"MANUAL", "POSHOLD", "ALT_HOLD", "SURFACE", "STABILIZE", "GUIDED"} <= set(re.findall(r"\w+", modes[1]))
        assert do("status HEARTBEAT", r"HEARTBEAT \{type : (\d+)")[1] == str(mavlink.MAV_TYPE_SUBMARINE)
        assert float(do("param show WK_FF_GAIN", r"WK_FF_GAIN\s+([-\d.]+)")[1]) == 1.0
        proc.stdin.write("param set WK_FF_GAIN 0.5\n")
        proc.stdin.flush()
        end = time.monotonic() + 5
        while sim.firmware.params["WK_FF_GAIN"] != 0.5 and time.monotonic() < end:
            time.sleep(0.05)
        assert sim.firmware.params["WK_FF_GAIN"] == 0.5
        assert float(do("param show WK_FF_GAIN", r"WK_FF_GAIN\s+([-\d.]+)")[1]) == 0.5
        before = do("status SERVO_OUTPUT_RAW", r"SERVO_OUTPUT_RAW \{(.*)\}")[1]
        assert re.findall(r"servo[1-8]_raw : (\d+)", before) == ["1500"] * 8
        do("mode POSHOLD", r"POSHOLD>")
        do("arm throttle", r"ARMED")
        assert sim.firmware.mode == Mode.POSHOLD and sim.firmware.armed
        end, moved = time.monotonic() + 10, False
        while not moved and time.monotonic() < end:
            time.sleep(0.5)
            after = do("status SERVO_OUTPUT_RAW", r"SERVO_OUTPUT_RAW \{(.*)\}")[1]
            moved = any(int(p) != 1500 for p in re.findall(r"servo[1-8]_raw : (\d+)", after))
        assert moved, after
    finally:
        proc.kill()
        proc.wait(5)
        sim.stop()
