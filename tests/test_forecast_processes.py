"""Issue acceptance with real processes: kill the forecast service mid-mission, then restart it.

Plant (JSON SITL + buoy on zenoh), forecast service (oracle, 2 s horizon) and
firmware run as processes at real time; the test is the ground station.
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

import pytest

os.environ["MAVLINK20"] = "1"
from pymavlink import mavutil

from sitl.harness.ports import free_port

pytestmark = pytest.mark.processes   # starts the plant, firmware and forecast as processes


def start(args, log: Path) -> subprocess.Popen:
    env = dict(os.environ, PYTHONUNBUFFERED="1", OPENBLAS_NUM_THREADS="1")
    return subprocess.Popen([sys.executable, "-m", "sitl.harness.cli", *args], stdout=open(log, "w"),
                            stderr=subprocess.STDOUT, env=env, start_new_session=True)


def wait_line(log: Path, text: str, timeout: float = 60.0) -> None:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if log.exists() and text in log.read_text():
            return
        time.sleep(0.05)
    raise AssertionError(f"{log.name}: no {text!r} within {timeout} s:\n{log.read_text() if log.exists() else ''}")


@pytest.fixture
def world(tmp_path):
    zport, pport, gport = free_port(socket.SOCK_STREAM), free_port(), free_port()
    net = tmp_path / "network.yaml"
    net.write_text(json.dumps({"site": "acc", "zenoh": {
        "mode": "peer", "service_listen": [f"tcp/127.0.0.1:{zport}"], "connect": [f"tcp/127.0.0.1:{zport}"],
        "multicast_scouting": False, "gossip_scouting": True, "scouting_delay_ms": 0}}))
    forecast_args = ["forecast", "--case", "W1", "--mode", "oracle", "--horizon", "2", "--rate", "4",
                     "--network", str(net)]
    procs = {"forecast": start(forecast_args, tmp_path / "forecast.log")}
    wait_line(tmp_path / "forecast.log", "ready")
    procs["plant"] = start(["plant", "--case", "W1", "--port", str(pport), "--buoy-network", str(net)],
                           tmp_path / "plant.log")
    wait_line(tmp_path / "plant.log", "ready")
    procs["firmware"] = start(["firmware", "--hal", f"sitl:127.0.0.1:{pport}", "--mavlink",
                               f"udpout:127.0.0.1:{gport}", "--speedup", "1", "--network", str(net),
                               # a ground station without a joystick that arms at once: no pilot-input failsafe
                               # (as ArduSub's, it would disarm 3 s after boot)
                               "--set", "FS_GCS_ENABLE=0", "--set", "FS_PILOT_INPUT=0"], tmp_path / "firmware.log")
    wait_line(tmp_path / "firmware.log", "ready")
    gcs = mavutil.mavlink_connection(f"udpin:127.0.0.1:{gport}", source_system=255, dialect="ardupilotmega")
    try:
        yield procs, gcs, forecast_args, tmp_path
    finally:
        gcs.close()
        for p in procs.values():
            if p.poll() is None:
                p.send_signal(signal.SIGTERM)
                try:
                    p.wait(10)
                except subprocess.TimeoutExpired:
                    p.kill()


def watch(gcs, until, timeout: float, state: dict):
    """Read the vehicle's messages into ``state`` until ``until(state)``; returns the elapsed time."""
    t0 = time.monotonic()
    while time.monotonic() - t0 < timeout:
        m = gcs.recv_match(blocking=True, timeout=0.1)
        if m is None:
            continue
        kind = m.get_type()
        if kind == "NAMED_VALUE_FLOAT":
            state[m.name.rstrip("\x00")] = m.value
        elif kind == "STATUSTEXT":
            state.setdefault("text", []).append(m.text.rstrip("\x00"))
        elif kind == "LOCAL_POSITION_NED":
            state["max_dev"] = max(state.get("max_dev", 0.0), abs(m.x), abs(m.z - 5.0))
        if until(state):
            return time.monotonic() - t0
    raise AssertionError(f"condition not met within {timeout} s; state {state}")


def command(gcs, cmd, *p):
    gcs.mav.command_long_send(1, 1, cmd, 0, *(list(p) + [0] * (7 - len(p))))
    end = time.monotonic() + 10
    while time.monotonic() < end:
        m = gcs.recv_match(type="COMMAND_ACK", blocking=True, timeout=0.2)
        if m is not None and m.command == cmd:
            return m.result
    raise AssertionError(f"no ack for {cmd}")


def test_killing_and_restarting_the_forecast_service(world):
    procs, gcs, forecast_args, tmp = world
    assert gcs.wait_heartbeat(timeout=20) is not None
    state: dict = {}
    watch(gcs, lambda s: s.get("FF_AGE", -1) >= 0, 30, state)           # a valid forecast aboard
    assert command(gcs, mavutil.mavlink.MAV_CMD_DO_SET_MODE, 1, 16) == 0  # POSHOLD
    assert command(gcs, mavutil.mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1) == 0
    watch(gcs, lambda s: s.get("FF_ON") == 1.0, 10, state)
    time.sleep(2.0)
    # Kill the service: the vehicle reports it, and FF goes off once the last forecast
    # (valid 2 s past the newest buoy time it had seen) expires — well within 2 + 1 s.
    procs["forecast"].send_signal(signal.SIGKILL)
    procs["forecast"].wait(10)
    off_after = watch(gcs, lambda s: s.get("FF_ON") == 0.0, 15, state)
    print(f"FF off {off_after:.2f} s after the kill")
    assert off_after < 2.0 + 1.0 + 0.5     # horizon + the 1 s + telemetry at 2 Hz
    assert any("Forecast service lost" in t for t in state.get("text", []))
    assert any("feed-forward off" in t for t in state.get("text", []))
    # C-PD keeps station meanwhile
    state["max_dev"] = 0.0
    time.sleep(3.0)
    watch(gcs, lambda s: "max_dev" in s, 5, state)
    assert state["max_dev"] < 1.5
    # Restart: FF back on by itself
    procs["forecast"] = start(forecast_args, tmp / "forecast2.log")
    wait_line(tmp / "forecast2.log", "ready")
    watch(gcs, lambda s: s.get("FF_ON") == 1.0, 20, state)
    assert any("Forecast service up" in t for t in state.get("text", []))
    assert all(p.poll() is None for name, p in procs.items())
