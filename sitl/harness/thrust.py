"""``wavekeep thrust``: a small bench-test client that streams thrust demands to the vehicle over MAVLink.

It behaves as a ground station (sysid 255): sends its heartbeat at 1 Hz,
optionally switches the vehicle to MANUAL and arms it, then streams, at 20 Hz,
MANUAL_CONTROL (x forward, z throttle 500-neutral) and RC_CHANNELS_OVERRIDE
(channel 1 pitch, 3 throttle, 5 forward; ArduSub's order) — the way ArduSub
takes pilot input. Demands are surge, heave (up positive) and pitch (nose up
positive), each either normalised to [−1, 1] or in N / N m (``--units si``,
scaled by the vehicle's own ``WK_TAU_MAX_*`` read over the parameter protocol).

Sources: a CSV with columns ``t, surge, heave, pitch`` (header optional; values
held between rows) or a named pattern (zero, step, square, sine, sweep).
At the end it sends neutral sticks and, if it armed the vehicle, disarms it.
"""
from __future__ import annotations

import os
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bridge.csvio import read_numeric_csv

__all__ = ["ThrustProfile", "csv_profile", "pattern_profile", "stick_messages", "stream_thrust"]

PATTERNS = ("zero", "step", "square", "sine", "sweep")
AXES = ("surge", "heave", "pitch")


@dataclass(frozen=True)
class ThrustProfile:
    """Demands (K, 3) [surge, heave up, pitch up] at times t (K,), held from one row to the next."""

    t: np.ndarray
    demand: np.ndarray

    def at(self, t: float) -> np.ndarray:
        i = int(np.searchsorted(self.t, t, side="right")) - 1
        return self.demand[max(i, 0)]

    @property
    def duration(self) -> float:
        return float(self.t[-1])


def pattern_profile(pattern: str, axis: str, amplitude: float, duration: float, period: float = 4.0,
                    rate: float = 20.0) -> ThrustProfile:
    """A named test pattern on one axis: zero, step (on after 1 s), square and sine (``period`` s),
    sweep (a sine from 0.1 to 1 Hz)."""
    if pattern not in PATTERNS:
        raise ValueError(f"pattern must be one of {PATTERNS}, got {pattern!r}")
    if axis not in AXES:
        raise ValueError(f"axis must be one of {AXES}, got {axis!r}")
    t = np.arange(0.0, duration + 1e-9, 1.0 / rate)
    if pattern == "zero":
        v = np.zeros_like(t)
    elif pattern == "step":
        v = np.where(t >= 1.0, amplitude, 0.0)
    elif pattern == "square":
        v = amplitude * np.sign(np.sin(2 * np.pi * t / period) + 1e-12)
    elif pattern == "sine":
        v = amplitude * np.sin(2 * np.pi * t / period)
    else:
        f = 0.1 + 0.9 * t / max(duration, 1e-9)
        v = amplitude * np.sin(2 * np.pi * np.cumsum(f) / rate)
    demand = np.zeros((t.size, 3))
    demand[:, AXES.index(axis)] = v
    return ThrustProfile(t, demand)


def csv_profile(path: str | Path) -> ThrustProfile:
    """Read ``t, surge, heave, pitch`` rows (time increasing); a header line is allowed."""
    a = read_numeric_csv(path, ("t", "surge", "heave", "pitch"))
    if np.any(np.diff(a[:, 0]) < 0):
        raise ValueError(f"{path}: time must not decrease")
    return ThrustProfile(a[:, 0] - a[0, 0], a[:, 1:])


def stick_messages(mav, target: int, surge: float, up: float, pitch: float) -> list:
    """MANUAL_CONTROL and RC_CHANNELS_OVERRIDE for normalised demands (clipped to [−1, 1])."""
    s, u, p = (min(1.0, max(-1.0, v)) for v in (surge, up, pitch))
    pwm = lambda v: int(round(1500 + 400 * v))  # noqa: E731
    rc = [pwm(p), 1500, pwm(u), 1500, pwm(s), 1500, 0, 0]          # 1 pitch, 2 roll, 3 throttle, 4 yaw, 5 fwd, 6 lat
    return [
        mav.manual_control_encode(target, int(round(1000 * s)), 0, int(round(500 + 500 * u)), 0, 0),
        mav.rc_channels_override_encode(target, 1, *rc),
    ]


def _read_tau_max(conn, target: int, timeout: float = 5.0) -> np.ndarray:
    names = [f"WK_TAU_MAX_{a}" for a in "XZP"]
    values: dict[str, float] = {}
    deadline = time.monotonic() + timeout
    while len(values) < 3 and time.monotonic() < deadline:
        for n in names:
            if n not in values:
                conn.mav.param_request_read_send(target, 1, n.encode(), -1)
        end = time.monotonic() + 0.5
        while time.monotonic() < end:
            m = conn.recv_match(type="PARAM_VALUE", blocking=True, timeout=0.1)
            if m is not None and m.param_id in names:
                values[m.param_id] = m.param_value
    if len(values) < 3:
        raise TimeoutError("the vehicle did not report WK_TAU_MAX_X/Z/P")
    return np.array([values[n] for n in names])


def _command(conn, target: int, command: int, *params: float, timeout: float = 3.0) -> int:
    p = list(params) + [0.0] * (7 - len(params))
    conn.mav.command_long_send(target, 1, command, 0, *p)
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        m = conn.recv_match(type="COMMAND_ACK", blocking=True, timeout=0.2)
        if m is not None and m.command == command:
            return int(m.result)
    raise TimeoutError(f"no COMMAND_ACK for command {command}")


def stream_thrust(endpoint: str, profile: ThrustProfile, units: str = "normalised", arm: bool = False,
                  rate: float = 20.0, wait_heartbeat: float = 10.0, log=print) -> dict:
    """Stream the profile to the vehicle at ``rate`` Hz on an absolute time grid; returns counts."""
    os.environ["MAVLINK20"] = "1"
    from pymavlink import mavutil

    conn = mavutil.mavlink_connection(endpoint, source_system=255, source_component=190, dialect="ardupilotmega")
    try:
        hb = conn.wait_heartbeat(timeout=wait_heartbeat)
        if hb is None:
            raise TimeoutError(f"no vehicle heartbeat on {endpoint} within {wait_heartbeat:g} s")
        target = conn.target_system
        log(f"vehicle {target}: type {hb.type}, mode {hb.custom_mode}, base_mode {hb.base_mode}")
        scale = _read_tau_max(conn, target) if units == "si" else np.ones(3)
        armed_here = False
        if arm:
            r = _command(conn, target, mavutil.mavlink.MAV_CMD_DO_SET_MODE, 1, 19)   # MANUAL
            if r != 0:
                raise RuntimeError(f"vehicle refused MANUAL (MAV_RESULT {r})")
            r = _command(conn, target, mavutil.mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
            if r != 0:
                raise RuntimeError(f"vehicle refused to arm (MAV_RESULT {r})")
            armed_here = True
            log(f"vehicle {target}: MANUAL, armed")
        period = 1.0 / rate
        t0 = time.monotonic()
        sent, k, next_hb = 0, 0, t0
        while True:
            t = k * period
            if t > profile.duration:
                break
            now = time.monotonic()
            if now >= next_hb:
                conn.mav.heartbeat_send(mavutil.mavlink.MAV_TYPE_GCS, mavutil.mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
                next_hb += 1.0
            demand = profile.at(t) / scale
            for msg in stick_messages(conn.mav, target, *demand):
                conn.mav.send(msg)
                sent += 1
            while conn.recv_msg() is not None:   # keep the socket drained
                pass
            k += 1
            delay = t0 + k * period - time.monotonic()
            if delay > 0:
                time.sleep(delay)
        for msg in stick_messages(conn.mav, target, 0.0, 0.0, 0.0):
            conn.mav.send(msg)
        if armed_here:
            r = _command(conn, target, mavutil.mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0)
            log(f"vehicle {target}: " + ("disarmed" if r == 0 else f"refused to disarm (MAV_RESULT {r})"))
        return {"ticks": k, "messages": sent, "duration_s": time.monotonic() - t0}
    finally:
        conn.close()
