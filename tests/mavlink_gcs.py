"""Test helpers for the MAVLink link: a real pymavlink ground station and a live vehicle on 127.0.0.1.

The vehicle is :class:`sitl.harness.live.LiveSim` (plant + firmware + link on the wall
clock, in a background thread). Checks are on behaviour, with generous
deadlines, so that they hold on a loaded two-core machine; rates are measured
on the vehicle's own timestamps (time_boot_ms) where a message carries one.
Test modules import the fixtures ``v``, ``_restore``, ``fast_heartbeat`` and
``fast_servo`` from here: each module gets its own vehicle.
"""
from __future__ import annotations

import gc
import os
import shutil
import threading
import time
from pathlib import Path

import pytest

os.environ["MAVLINK20"] = "1"
from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from firmware_py.modes import Mode
from sitl.harness.live import LiveSim
from sitl.harness.ports import free_port
from sitl.harness.spec import RunSpec

SUB_MODES = {0: "STABILIZE", 2: "ALT_HOLD", 4: "GUIDED", 9: "SURFACE", 16: "POSHOLD", 19: "MANUAL"}
SERVO = mavlink.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW
POS_ONLY = 0b0000_1101_1111_1000        # type_mask: ignore velocity, acceleration, yaw, yaw rate




class GroundStation:
    """A pymavlink GCS: sends a 1 Hz heartbeat from a thread, reads and matches in the test's thread."""

    def __init__(self, url: str, sysid: int = 255, compid: int = 190, key: bytes | None = None,
                 hb_period: float = 1.0):
        self.hb_period = hb_period      # s of wall time between heartbeats (shorter for a vehicle run faster)
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
            self._hb_stop.wait(self.hb_period)

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
        # A ground station without a joystick: ArduSub's pilot-input failsafe (FS_PILOT_INPUT 2) would trip
        # once at boot and keep the heartbeat CRITICAL until sticks came; the tests that fly it turn it on.
        spec = RunSpec("W1", "cpd_ff", seed=7, overrides={"FS_PILOT_INPUT": 0})
        self.sim = LiveSim(spec, mavlink=[f"udpout:127.0.0.1:{self.gcs_port}", f"udpin:127.0.0.1:{self.in_port}"],
                           **kw)
        self.fw, self.link = self.sim.firmware, self.sim.link
        self.defaults = self.fw.params.as_dict()

    def start(self) -> Vehicle:
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
        self.link.state.home = None             # home where the vehicle booted (arming moves it)
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


@pytest.fixture
def fast_heartbeat(v):
    """HEARTBEAT at 5 Hz (SET_MESSAGE_INTERVAL) so that state changes show sooner; back to 1 Hz after."""
    assert v.gs.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_HEARTBEAT, 200_000).result == 0
    yield
    v.gs.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_HEARTBEAT, 0)

def servos(m) -> list[int]:
    return [getattr(m, f"servo{i}_raw") for i in range(1, 9)]


@pytest.fixture
def fast_servo(v):
    assert v.gs.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, SERVO, 50_000).result == 0
    yield
    v.gs.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, SERVO, 0)

def frame(msg, seq: int = 0) -> bytes:
    mav = mavlink.MAVLink(None, 255, 190)
    mav.seq = seq
    return bytes(msg.pack(mav))


def mavproxy_available() -> bool:
    """Is MAVProxy installed (the Makefile's test extra installs it headless)?"""
    try:
        import MAVProxy  # noqa: F401
    except ImportError:
        return False
    return True


def mavsdk_server() -> str | None:
    """The ``mavsdk_server`` binary MAVSDK-Python (mavsdk<4) ships, or one on PATH; None without MAVSDK."""
    try:
        import mavsdk
    except ImportError:
        return None
    path = Path(mavsdk.__file__).parent / "bin" / "mavsdk_server"
    return str(path) if path.exists() else shutil.which("mavsdk_server")


def dronekit_installed() -> bool:
    """Does dronekit (dronekit2) import here?"""
    try:
        import dronekit  # noqa: F401
    except Exception:
        return False
    return True
