"""Companion mode with real processes: the plant, the firmware as a stand-in ArduSub, ``wavekeep companion``.

Safety: a pilot's mode change hands control back within one tick; a killed
companion's overrides expire (RC_OVERRIDE_TIME) and the vehicle holds neutral;
stale telemetry releases them; a vehicle that is not a Sub is refused. And the
lockstep run is deterministic (same seed, same result).
"""
from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil

from sitl.faultrelay import FaultRelay, Faults
from sitl.harness.companion_launch import launch_companion, stand_in_args
from sitl.harness.launcher import SimOptions
from sitl.harness.ports import free_port
from sitl.harness.spec import RunSpec

pytestmark = pytest.mark.processes
CLI = [sys.executable, "-m", "sitl.harness.cli"]
mavlink = mavutil.mavlink


def _start(argv, log: Path, wait_ready=True) -> subprocess.Popen:
    f = open(log, "w")  # noqa: SIM115 — closed with the process
    p = subprocess.Popen(argv, stdout=f, stderr=subprocess.STDOUT, env=dict(os.environ, PYTHONUNBUFFERED="1"),
                         start_new_session=True)
    end = time.monotonic() + 60
    while wait_ready and "ready" not in log.read_text():
        assert p.poll() is None and time.monotonic() < end, log.read_text()
        time.sleep(0.05)
    return p


class Rig:
    """Plant + stand-in ArduSub (real time) + companion, with a GCS (the pilot) and an optional relay."""

    def __init__(self, tmp: Path, method: str, relay: bool = False):
        self.tmp, self.procs = tmp, []
        plant, gcs, comp = free_port(), free_port(), free_port()
        self.procs.append(_start([*CLI, "plant", "--case", "W1", "--port", str(plant)], tmp / "plant.log"))
        self.relay = FaultRelay(("127.0.0.1", comp)).start() if relay else None
        vehicle_port = self.relay.port if self.relay else comp
        args = [a for a in stand_in_args(method) if a != "--companion-lockstep"]
        self.procs.append(_start([*CLI, "firmware", "--hal", f"sitl:127.0.0.1:{plant}", "--speedup", "1",
                                  "--mavlink", f"udpout:127.0.0.1:{gcs}", "--mavlink",
                                  f"udpout:127.0.0.1:{vehicle_port}", *args], tmp / "ardusub.log"))
        self.gcs = mavutil.mavlink_connection(f"udpin:127.0.0.1:{gcs}", source_system=255, source_component=190,
                                              dialect="ardupilotmega")
        self.companion = _start([*CLI, "companion", "--autopilot", f"udpin:127.0.0.1:{comp}", "--method", method,
                                 "--log", str(tmp / "companion.csv")], tmp / "companion.log")
        self.procs.append(self.companion)
        self.wait(lambda m: m.get_type() == "HEARTBEAT" and m.get_srcSystem() == 1, 20)
        self.gcs.mav.command_long_send(1, 1, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 0, 65, 50_000, 0, 0, 0, 0, 0)
        self.gcs.mav.command_long_send(1, 1, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 0, 36, 50_000, 0, 0, 0, 0, 0)

    def wait(self, until, timeout: float):
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            m = self.gcs.recv_match(blocking=True, timeout=0.1)
            if m is not None and until(m):
                return m
        raise AssertionError("timed out")

    def command(self, cmd, *p):
        self.gcs.mav.command_long_send(1, 1, cmd, 0, *(list(p) + [0] * (7 - len(p))))
        return self.wait(lambda m: m.get_type() == "COMMAND_ACK" and m.command == cmd, 5).result

    def engage(self) -> None:
        assert self.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1) == 0
        self.wait_log("WK: engaged", 10)

    def log(self) -> str:
        return (self.tmp / "companion.log").read_text()

    def wait_log(self, text: str, timeout: float) -> None:
        end = time.monotonic() + timeout
        while text not in self.log():
            assert time.monotonic() < end, self.log()
            self.drain()
            time.sleep(0.02)
        self.drain()

    def drain(self) -> None:
        """Read everything queued: what comes next is fresh."""
        while self.gcs.recv_match(blocking=False) is not None:
            pass

    def samples(self, kind: str, seconds: float) -> list:
        out, end = [], time.monotonic() + seconds
        while time.monotonic() < end:
            m = self.gcs.recv_match(blocking=True, timeout=0.1)
            if m is not None and m.get_type() == kind:
                out.append(m)
        return out

    def close(self) -> None:
        for p in reversed(self.procs):
            if p.poll() is None:
                p.send_signal(signal.SIGTERM)
                try:
                    p.wait(10)
                except subprocess.TimeoutExpired:
                    os.killpg(p.pid, signal.SIGKILL)
        if self.relay:
            self.relay.stop()
        self.gcs.close()


@pytest.fixture
def rig(tmp_path, request):
    r = Rig(tmp_path, *request.param)
    yield r
    r.close()


def _sticks(m) -> tuple[int, int, int]:
    return m.chan1_raw, m.chan3_raw, m.chan5_raw


@pytest.mark.parametrize("rig", [("rc",)], indirect=True)
def test_pilot_mode_change_hands_control_back_within_one_tick(rig):
    rig.engage()
    assert any(_sticks(m) != (1500, 1500, 1500) for m in rig.samples("RC_CHANNELS", 1.0))   # it is flying
    assert rig.command(mavlink.MAV_CMD_DO_SET_MODE, 1, 0) == 0                                # pilot: STABILIZE
    hb = rig.wait(lambda m: m.get_type() == "HEARTBEAT" and m.get_srcSystem() == 1 and m.custom_mode == 0, 2)
    assert hb is not None
    rig.drain()
    after = rig.samples("RC_CHANNELS", 1.0)
    # The release follows the first 20 Hz heartbeat in STABILIZE: no command after the next tick
    assert after and all(_sticks(m) == (1500, 1500, 1500) for m in after[2:]), [_sticks(m) for m in after]
    rig.wait_log("released overrides (pilot selected STABILIZE)", 2)
    time.sleep(0.5)
    assert "engaged" not in rig.log().split("released overrides")[-1]     # and it does not take over again


@pytest.mark.parametrize("rig", [("servo",)], indirect=True)
def test_killed_companion_overrides_expire_and_the_vehicle_holds_neutral(rig):
    rig.engage()
    # the outputs become pass-through at the stand-in's next whole second (ArduSub re-assigns them at 1 Hz)
    assert any(set(m.servo1_raw for m in rig.samples("SERVO_OUTPUT_RAW", 2.0)) - {1500})
    rig.companion.send_signal(signal.SIGKILL)          # no chance to release
    # timed on the vehicle's clock (SERVO_OUTPUT_RAW.time_usec), so a loaded machine does not stretch it
    t_kill = rig.wait(lambda m: m.get_type() == "SERVO_OUTPUT_RAW", 2).time_usec
    wall_end = time.monotonic() + 20.0
    while True:
        m = rig.wait(lambda m: m.get_type() == "SERVO_OUTPUT_RAW", 2)
        pwm = [getattr(m, f"servo{i}_raw") for i in range(1, 9)]
        if pwm == [1500] * 8:
            break
        assert (m.time_usec - t_kill) * 1e-6 < 3.0 + 0.5, pwm      # RC_OVERRIDE_TIME (3 s) + a margin
        assert time.monotonic() < wall_end, "no neutral output within 20 s of wall time"
    assert all([getattr(m, f"servo{i}_raw") for i in range(1, 9)] == [1500] * 8
               for m in rig.samples("SERVO_OUTPUT_RAW", 1.0))


@pytest.mark.parametrize("rig", [("rc", True)], indirect=True)
def test_stale_telemetry_releases_the_overrides(rig):
    rig.engage()
    rig.relay.faults["up"] = Faults(drop=1.0)          # the vehicle's telemetry to the companion: lost for 2 s
    time.sleep(2.0)
    rig.relay.faults["up"] = Faults()
    rig.wait_log("released overrides (stale telemetry, ATTITUDE", 2)
    tail = rig.samples("RC_CHANNELS", 1.0)
    assert tail and all(_sticks(m) == (1500, 1500, 1500) for m in tail), [_sticks(m) for m in tail]


def test_companion_refuses_a_vehicle_that_is_not_a_sub(tmp_path):
    port = free_port()
    p = _start([*CLI, "companion", "--autopilot", f"udpin:127.0.0.1:{port}", "--identity-timeout", "5"],
               tmp_path / "c.log", wait_ready=False)
    quad = mavutil.mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=1, source_component=1,
                                      dialect="ardupilotmega")
    try:
        end = time.monotonic() + 20
        while p.poll() is None and time.monotonic() < end:
            quad.mav.heartbeat_send(mavlink.MAV_TYPE_QUADROTOR, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, 81, 0, 3)
            time.sleep(0.1)
        assert p.wait(5) == 3
        assert "refused" in (tmp_path / "c.log").read_text() and "not a submarine" in (tmp_path / "c.log").read_text()
    finally:
        quad.close()
        if p.poll() is None:
            p.kill()


def test_companion_lockstep_run_is_deterministic(tmp_path):
    def run(name):
        opt = SimOptions(RunSpec(case="W1", controller="cpd", duration=6.0), out=str(tmp_path / name),
                         plant_port=free_port(), gcs_port=free_port(), zenoh_port=free_port(socket.SOCK_STREAM))
        r = launch_companion(opt, "rc", free_port())
        return r, np.loadtxt(tmp_path / name / "timeseries.csv", delimiter=",", skiprows=1)
    (a, ta), (b, tb) = run("a"), run("b")
    assert np.array_equal(ta, tb, equal_nan=True)   # (no forecast: forecast_eta is NaN)
    assert a["rmse"] == b["rmse"]
    assert a["companion"]["telemetry_to_command_ms"]["n"] > 100
    assert json.loads((tmp_path / "a" / "results.json").read_text())["rmse"]["heave"] < 0.2


def test_the_companion_flies_the_mpc_on_the_forecast(tmp_path):
    """Companion mode with the preview MPC (WK_CTRL_LAW 1, implied by the controller) and its forecast over zenoh:
    every tick solved by the MPC, none flown as the fallback, and the station held."""
    opt = SimOptions(RunSpec(case="W1", controller="mpc", duration=8.0), out=str(tmp_path / "mpc"),
                     plant_port=free_port(), gcs_port=free_port(), zenoh_port=free_port(socket.SOCK_STREAM))
    r = launch_companion(opt, "rc", free_port())
    solver = r["solver"]
    assert solver["law"] == "mpc"
    assert solver["ticks"] > 100 and solver["solved"] == solver["ticks"]
    assert solver["fallback_share"] == 0.0
    assert r["rmse"]["surge"] < 0.1 and r["rmse"]["heave"] < 0.1
