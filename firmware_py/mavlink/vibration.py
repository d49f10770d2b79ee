"""ArduPilot's vibration levels, from the estimate's body acceleration (RAW_IMU's accelerometer, VIBRATION)."""
from __future__ import annotations

import math

from ..telemetry_snapshot import TelemetrySnapshot

__all__ = ["G_MSS", "VibrationMonitor"]

G_MSS = 9.80665


class VibrationMonitor:
    """ArduPilot's vibration levels: √(low-pass of (a − low-pass(a))²) of the body acceleration (m/s²).

    The acceleration is the estimate's body-velocity change between ticks, plus gravity
    resolved in the body frame (what an accelerometer measures).
    """

    def __init__(self, floor_hz: float = 5.0, level_hz: float = 2.0):
        self._floor_hz, self._level_hz = floor_hz, level_hz
        self._last: tuple[float, float, float] | None = None
        self._floor = [0.0, 0.0]
        self._sq = [0.0, 0.0]
        self.accel = (0.0, 0.0, -G_MSS)

    def update(self, snap: TelemetrySnapshot) -> tuple[float, float, float]:
        """Feed one tick's estimate; returns the vibration levels (x, y, z), m/s²."""
        if not snap.has_tick or len(snap.x_hat) < 6 or not all(map(math.isfinite, snap.x_hat[2:5])):
            return self.levels()
        t, th, u, w = float(snap.t or 0.0), snap.x_hat[2], snap.x_hat[3], snap.x_hat[4]
        last, self._last = self._last, (t, u, w)
        if last is None or not t > last[0]:
            return self.levels()
        dt = t - last[0]
        ax = (u - last[1]) / dt + G_MSS * math.sin(th)
        az = (w - last[2]) / dt - G_MSS * math.cos(th)
        self.accel = (ax, 0.0, az)
        a_floor = 1.0 - math.exp(-2 * math.pi * self._floor_hz * dt)
        a_level = 1.0 - math.exp(-2 * math.pi * self._level_hz * dt)
        for i, a in enumerate((ax, az)):
            self._floor[i] += a_floor * (a - self._floor[i])
            self._sq[i] += a_level * ((a - self._floor[i]) ** 2 - self._sq[i])
        return self.levels()

    def levels(self) -> tuple[float, float, float]:
        return math.sqrt(max(self._sq[0], 0.0)), 0.0, math.sqrt(max(self._sq[1], 0.0))
