"""The companion's HAL: sensors from the autopilot's telemetry, thruster commands as RC overrides.

:class:`MAVLinkAutopilotHAL` gives the Wavekeep control task what a HAL gives it:

* **pitch, pitch rate** — ATTITUDE (pitch, pitchspeed): the autopilot's AHRS;
* **depth** — SCALED_PRESSURE2 (the Bar30): (p − p_surface) / (ρ g), as ArduSub
  computes it; without it, LOCAL_POSITION_NED's z (ArduSub's EKF depth);
* **x** — LOCAL_POSITION_NED, a fix only when a new one has arrived since the
  last tick. ArduSub has a horizontal position only when a DVL/USBL feeds its
  EKF; without one the message does not come (or repeats), the companion's EKF
  predicts x from its model alone, position-holding modes are refused and the
  companion holds depth and pitch (ALT_HOLD behaviour) rather than surge;
* **specific force** [f_x, f_z] — RAW_IMU's accelerometer (mG, body FRD, gravity
  included), a new sample only: the aided estimator's inertial channel (``WK_EKF_MODE`` 1);
* ``write_pwm`` — :class:`~firmware_py.companion.commander.Commander.output`.

Readings are stamped with the autopilot's clock (``time_boot_ms``). Two clocks
drive the scheduler: :class:`LockstepMarkerClock` (SITL stand-in: time is the
autopilot's, and a tick starts when the autopilot marks its tick's telemetry
complete), :class:`TelemetryClock` (a real vehicle, the default: a tick starts when
the autopilot's ATTITUDE for it arrives, so the command answers the freshest
telemetry whatever the phase between the two loops) and :class:`AutopilotClock`
(the local monotonic clock + the TIMESYNC offset, i.e. the autopilot's boot
clock, in real time at an arbitrary phase to its telemetry).
"""
from __future__ import annotations

import math
import time
from collections.abc import Callable

import numpy as np

from ..hal.base import HAL
from ..hal.sensors import ATM_PA, G0, RHO_SEAWATER, SensorFrame
from .autopilot import AutopilotLink
from .commander import Commander

__all__ = ["AutopilotClock", "LockstepMarkerClock", "MAVLinkAutopilotHAL", "TelemetryClock", "attitude_stamp"]


class TelemetryClock:
    """The autopilot's time as its telemetry stamps it: a slot starts when the message that stamps it arrives.

    ``stamp_ms()`` is the newest stamp (ms on the autopilot's clock, −1 before the first). A slot at
    t is due once a stamp reaches t − ``early_ns``: a stream at the loop rate whose stamps jitter by a
    few ms about the grid then starts each slot with its own message, never one period late.
    Deterministic under lockstep; never runs ahead of the autopilot.
    """

    simulated = True

    def __init__(self, link: AutopilotLink, watchdog: Callable[[], None], stop: Callable[[], bool],
                 stamp_ms: Callable[[], int], early_ns: int = 0):
        self.link, self.watchdog, self.stop = link, watchdog, stop
        self.stamp_ms, self.early_ns = stamp_ms, int(early_ns)
        self._now = 0

    def now_ns(self) -> int:
        return self._now

    def sleep_until(self, t_ns: int) -> None:
        while self.stamp_ms() * 1_000_000 < t_ns - self.early_ns and not self.stop():
            self.link.pump(0.05)
            self.watchdog()
        self._now = max(self._now, self.stamp_ms() * 1_000_000, int(t_ns) if self.stop() else 0)


class LockstepMarkerClock(TelemetryClock):
    """SITL stand-in: time moved by its LOCKSTEP markers (each tick's telemetry complete), exactly on the grid."""

    def __init__(self, link: AutopilotLink, watchdog: Callable[[], None], stop: Callable[[], bool]):
        super().__init__(link, watchdog, stop, lambda: link.state.marker_ms)


def attitude_stamp(link: AutopilotLink) -> Callable[[], int]:
    """The newest ATTITUDE's ``time_boot_ms`` (−1 before the first): what a :class:`TelemetryClock` ticks on."""
    def stamp() -> int:
        s = link.state.samples.get("ATTITUDE")
        return -1 if s is None else s.t_ms
    return stamp


class AutopilotClock:
    """Real time on the autopilot's boot clock: local monotonic + the TIMESYNC offset (fixed at start)."""

    simulated = False

    def __init__(self, link: AutopilotLink, watchdog: Callable[[], None], offset_ns: int):
        self.link, self.watchdog, self.offset_ns = link, watchdog, int(offset_ns)

    def now_ns(self) -> int:
        return time.monotonic_ns() + self.offset_ns

    def sleep_until(self, t_ns: int) -> None:
        while True:
            left = (t_ns - self.offset_ns - time.monotonic_ns()) * 1e-9
            if left <= 0:
                return
            self.link.pump(min(left, 0.01))
            self.watchdog()


class MAVLinkAutopilotHAL(HAL):
    """Sensors from ATTITUDE / SCALED_PRESSURE2 / LOCAL_POSITION_NED / RAW_IMU; PWM out through the commander."""

    def __init__(self, link: AutopilotLink, commander: Commander, clock, stale_s: float = 0.5,
                 surface_pa: float = ATM_PA, rho: float = RHO_SEAWATER):
        self.link, self.commander, self.clock = link, commander, clock
        self.stale_s = float(stale_s)
        self.surface_pa, self.rho = float(surface_pa), float(rho)
        self._pos_count = 0
        self._sp2_count = 0
        self._sp2_value = math.nan
        self._imu_count = 0

    def depth(self) -> float:
        """A new depth reading, or NaN when there is none this tick. ArduSub reads its barometer at 10 Hz and
        repeats the last reading in a faster SCALED_PRESSURE2 stream: a repeated value is no new measurement
        (fused twice, its noise would count as half what it is)."""
        sp2 = self.link.fresh("SCALED_PRESSURE2", self.stale_s)
        if sp2 is not None:
            new = sp2.count != self._sp2_count and sp2.values[0] != self._sp2_value
            self._sp2_count, self._sp2_value = sp2.count, sp2.values[0]
            return (sp2.values[0] * 100.0 - self.surface_pa) / (self.rho * G0) if new else math.nan
        lp = self.link.fresh("LOCAL_POSITION_NED", self.stale_s)
        return lp.values[1] if lp is not None else math.nan

    def read_sensors(self) -> SensorFrame:
        t = self.clock.now_ns() * 1e-9
        att = self.link.fresh("ATTITUDE", self.stale_s)
        x = math.nan
        lp = self.link.fresh("LOCAL_POSITION_NED", self.stale_s)
        if lp is not None and lp.count != self._pos_count:
            self._pos_count = lp.count
            x = lp.values[0]
        depth = self.depth()
        if att is None:
            return SensorFrame(t, math.nan, math.nan, math.nan, math.nan, healthy=False)
        # healthy while a depth source streams (a tick between two 10 Hz readings has none of its own)
        source = self.link.fresh("SCALED_PRESSURE2", self.stale_s) or self.link.fresh("LOCAL_POSITION_NED",
                                                                                        self.stale_s)
        acc_x, acc_z = self.specific_force()
        return SensorFrame(t, x, depth, att.values[0], att.values[1], acc_x=acc_x, acc_z=acc_z,
                           healthy=source is not None)

    def specific_force(self) -> tuple[float, float]:
        """The autopilot's accelerometer [f_x, f_z] (m/s², body FRD, ≈ [0, −g] at rest) from its newest RAW_IMU,
        a new sample only (NaN otherwise: a repeated sample is no new measurement); the aided estimator's
        (``WK_EKF_MODE`` 1) inertial channel."""
        imu = self.link.fresh("RAW_IMU", self.stale_s)
        if imu is None or imu.count == self._imu_count:
            return math.nan, math.nan
        self._imu_count = imu.count
        return imu.values[0] * G0 / 1000.0, imu.values[2] * G0 / 1000.0

    def write_pwm(self, pwm: np.ndarray) -> None:
        self.commander.output(pwm)
