"""The real ArduSub SITL in Wavekeep's world, for the tests that need the binary (``WAVEKEEP_ARDUSUB``).

:class:`SubRig` is one boot shared by a test module: the plant in this process
(:class:`sitl.physics_server.PhysicsServer` in a thread, so a test reads the
truth whenever it likes) as ``wavekeep sim --autopilot`` serves ArduSub
(surface start, six DoF, its own physics rate, still water), the binary
(:class:`sitl.harness.ardusub.ArduSubProcess`, its ``--speedup``) with MAVLink
to a pymavlink ground station (:class:`mavlink_gcs.GroundStation`) and a
second link for a companion, and ``wavekeep companion`` on demand. Waits are
on the vehicle's clock (``time_boot_ms``), with wall deadlines generous enough
for a loaded two-core machine. Tests skip, with the reason, without the binary.
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

os.environ["MAVLINK20"] = "1"
from ardusub_pair import ENV, ardusub_binary
from mavlink_gcs import GroundStation
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sitl.harness.ardusub import ArduSubProcess, load_ardusub_config
from sitl.harness.ports import free_port
from sitl.physics_server import PhysicsServer
from sitl.plant import Plant
from sitl.sea import Sea

__all__ = ["ENV", "SubRig", "ardusub_binary", "motor_axes"]

CLI = [sys.executable, "-m", "sitl.harness.cli"]
GUIDED, ALT_HOLD, MANUAL = 4, 2, 19
STALE_S = 2.0
"""The companion's ``--stale`` (s of wall time) here: on a loaded two-core machine the companion, ArduSub and
this process (the plant) starve each other for half a second now and then; 0.5 s (the default) then releases."""
STILL_S = 1e6
"""The sea starts this late: the rig's water is still (the tests check behaviour, not wave response)."""



def motor_axes(pwm) -> dict[str, float]:
    """Vectored-6DOF outputs (µs, motors 1-8) as the axis commands ArduSub's factors make them (µs about
    1500): yaw, lateral and forward from the horizontal four, roll, pitch and throttle from the vertical."""
    m = np.asarray(pwm, dtype=float) - 1500.0
    return {"yaw": (m[0] - m[1] - m[2] + m[3]) / 4, "lateral": (m[0] - m[1] + m[2] - m[3]) / 4,
            "forward": (-m[0] - m[1] + m[2] + m[3]) / 4, "roll": (m[4] - m[5] + m[6] - m[7]) / 4,
            "pitch": (-m[4] - m[5] + m[6] + m[7]) / 4, "throttle": -(m[4] + m[5] + m[6] + m[7]) / 4}


def servo_pwm(m) -> list[int]:
    return [getattr(m, f"servo{i}_raw") for i in range(1, 9)]


class SubRig:
    """Plant (in this process) + the ArduSub binary + a ground station; ``companion()`` adds the companion."""

    def __init__(self, tmp: Path, binary: str, speedup: float = 8.0, start: str = "surface", six_dof: bool = True,
                 case: str = "W1", sea_start: float = STILL_S):
        self.tmp = tmp
        cfg = load_ardusub_config()
        sea = Sea.load(case)
        self.server = PhysicsServer(lambda: Plant.from_configs(sea, start=start, sea_start=sea_start,
                                                                dof="six" if six_dof else "planar"),
                                    port=0, physics_rate_hz=cfg["physics_rate_hz"]).start()
        self.gcs_port, self.companion_port = free_port(), free_port()
        self.gcs = GroundStation(f"udpin:127.0.0.1:{self.gcs_port}")
        self.ardusub = ArduSubProcess(Path(binary), cfg, tmp / "ardusub", self.server.port, self.gcs_port,
                                      self.companion_port, speedup=speedup)
        self.companion_proc: subprocess.Popen | None = None
        assert self.gcs.heartbeat(timeout=60) is not None, self.ardusub.tail()
        self.gcs.heartbeats(True)
        for name, value in cfg["params"].items():
            self.gcs.set_param(name, value)
        self.stream(mavlink.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW, 50)
        self.stream(mavlink.MAVLINK_MSG_ID_SYSTEM_TIME, 20)
        self.stream(mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, 20)
        self.stream(mavlink.MAVLINK_MSG_ID_SCALED_PRESSURE2, 20)
        self.stream(mavlink.MAVLINK_MSG_ID_HEARTBEAT, 20)

    # ------------------------------------------------------------------ the vehicle
    def stream(self, msg_id: int, hz: float) -> None:
        self.gcs.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, msg_id, 1e6 / hz)

    @property
    def truth(self):
        return self.server.snapshot()

    def now(self) -> float:
        """The vehicle's clock (s): the newest SYSTEM_TIME."""
        m = self.gcs.wait_type("SYSTEM_TIME", timeout=10)
        assert m is not None, "no SYSTEM_TIME"
        return m.time_boot_ms / 1000.0

    def run_for(self, seconds: float) -> list:
        """Every message received while the vehicle's clock advances ``seconds``."""
        since = self.gcs.mark()
        end = self.now() + seconds
        deadline = time.monotonic() + seconds * 5 + 60
        while self.now() < end:
            assert time.monotonic() < deadline, "the vehicle's clock stalled"
        return self.gcs.log[since:]

    def mode(self, mode: int, timeout: float = 120.0) -> None:
        """DO_SET_MODE until accepted (GUIDED: once ArduSub's EKF has a position)."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            ack = self.gcs.command(mavlink.MAV_CMD_DO_SET_MODE, 1, mode, timeout=2)
            if ack is not None and ack.result == 0:
                return
            time.sleep(0.3)
        raise AssertionError(f"mode {mode} not accepted")

    def arm(self, on: bool = True) -> None:
        ack = self.gcs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1 if on else 0)
        assert ack is not None and ack.result == 0, ack

    def goto_station(self, depth: float = 5.0) -> None:
        for _ in range(3):
            self.gcs.send(mavlink.MAVLink_set_position_target_local_ned_message(
                0, 1, 1, mavlink.MAV_FRAME_LOCAL_NED, 0b0000_1111_1111_1000, 0.0, 0.0, depth, 0, 0, 0, 0, 0, 0, 0, 0))

    def wait_truth(self, pred, seconds: float) -> bool:
        """Run the vehicle's clock up to ``seconds`` until ``pred(truth)``."""
        end = self.now() + seconds
        while self.now() < end:
            if pred(self.truth):
                return True
        return pred(self.truth)

    def outputs(self, msgs) -> np.ndarray:
        """(time s, pwm 1-8) of the SERVO_OUTPUT_RAW among ``msgs``."""
        rows = [[m.time_usec * 1e-6, *servo_pwm(m)] for m in msgs if m.get_type() == "SERVO_OUTPUT_RAW"]
        return np.array(rows).reshape(-1, 9)

    # ------------------------------------------------------------------ the companion
    def companion(self, method: str = "servo", *args: str) -> subprocess.Popen:
        log = self.tmp / "companion.log"
        f = open(log, "w")  # noqa: SIM115 — closed with the process
        self.companion_proc = subprocess.Popen(
            [*CLI, "companion", "--autopilot", f"udpin:127.0.0.1:{self.companion_port}", "--method", method,
             "--log", str(self.tmp / "companion_ticks.csv"), "--stale", str(STALE_S), *args], stdout=f,
            stderr=subprocess.STDOUT,
            env=dict(os.environ, PYTHONUNBUFFERED="1"), start_new_session=True)
        end = time.monotonic() + 60
        while "ready" not in log.read_text():
            assert self.companion_proc.poll() is None and time.monotonic() < end, log.read_text()
            time.sleep(0.05)
        return self.companion_proc

    def companion_log(self) -> str:
        return (self.tmp / "companion.log").read_text()

    def wait_log(self, text: str, seconds: float) -> bool:
        """Run the vehicle's clock up to ``seconds`` until the companion's log holds ``text``."""
        end = self.now() + seconds
        while text not in self.companion_log():
            if self.now() > end:
                return False
        return True

    def wait_count(self, text: str, times: int, seconds: float) -> bool:
        """Run the vehicle's clock up to ``seconds`` until the companion's log holds ``text`` ``times`` times."""
        end = self.now() + seconds
        while self.companion_log().count(text) < times:
            if self.now() > end:
                return False
        return True

    def close(self) -> None:
        if self.companion_proc is not None and self.companion_proc.poll() is None:
            os.killpg(self.companion_proc.pid, signal.SIGCONT)
            self.companion_proc.send_signal(signal.SIGTERM)
            try:
                self.companion_proc.wait(10)
            except subprocess.TimeoutExpired:
                os.killpg(self.companion_proc.pid, signal.SIGKILL)
        self.ardusub.stop()
        self.gcs.close()
        self.server.stop()


def depth_of(m) -> float:
    """ArduSub's depth (m, positive down) in GLOBAL_POSITION_INT (relative_alt, mm above home)."""
    return -m.relative_alt / 1000.0


def sp2_depth(m, rho_g: float = 1025.0 * 9.80665) -> float:
    return (m.press_abs * 100.0 - 101325.0) / rho_g


