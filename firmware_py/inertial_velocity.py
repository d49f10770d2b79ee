"""Body velocity from the IMU and the position fixes alone: no vehicle model, no forecast.

A third-order complementary filter per NED axis, as ArduPilot's inertial navigation
(AP_InertialNav) blends its accelerometers with GPS and the barometer: position,
velocity and an accelerometer bias, driven by the measured acceleration and pulled
to each fix through gains 3ω, 3ω², ω³ (three poles at ω = 1/``WK_FF_SKILL_VTC``).

The accelerometer's specific force f = [f_x, f_z] (body FRD) and the AHRS pitch θ
give the NED acceleration (:func:`~firmware_py.sensors.specific_force` inverted):

    ẍ = cos θ f_x + sin θ f_z,    z̈ = −sin θ f_x + cos θ f_z + g.

The fixes are the horizontal position x and the depth, whenever a frame carries
them. The feed-forward's skill (:mod:`firmware_py.feedforward`) needs a velocity the
forecast has not touched: the estimator predicts with the forecast, so its velocity
follows a wrong forecast as well as a right one.
"""
from __future__ import annotations

import math

import numpy as np

from .sensors import SensorFrame

__all__ = ["InertialVelocity"]


class InertialVelocity:
    """x and z (NED, m), their rates (m/s) and the accelerometer biases (m/s²), from IMU and fixes.

    ``h`` is the tick (s), ``tc`` the filter's time constant (s), ``g`` gravity (m/s²).
    """

    def __init__(self, h: float, tc: float, g: float):
        self.h, self.tc, self.g = h, tc, g
        self.reset()

    def reset(self) -> None:
        """Forget the state: the next frames with both fixes start it again."""
        self.pos = np.full(2, math.nan)      # [x, z] NED (m)
        self.vel = np.zeros(2)               # [ẋ, ż] (m/s)
        self.bias = np.zeros(2)              # NED acceleration bias (m/s²)
        self._since_fix = np.zeros(2)        # s since each axis' last fix
        self._acc: np.ndarray | None = None  # the last tick's NED acceleration (m/s²)

    @property
    def ready(self) -> bool:
        return bool(np.all(np.isfinite(self.pos)))

    def update(self, frame: SensorFrame) -> np.ndarray | None:
        """Propagate one tick with this frame's IMU, correct with its fixes; body [u, w] (m/s) or None."""
        fix = np.array([frame.x, frame.depth])
        imu = (frame.acc_x, frame.acc_z, frame.pitch)
        if not all(math.isfinite(v) for v in imu):
            self.reset()
            return None
        f_x, f_z, th = imu
        c, s = math.cos(th), math.sin(th)
        if not self.ready:
            self.pos = np.where(np.isfinite(fix), fix, self.pos)
            return None
        acc = np.array([c * f_x + s * f_z, -s * f_x + c * f_z + self.g]) - self.bias
        prev = acc if self._acc is None else self._acc
        self._acc = acc
        h = self.h
        # the acceleration taken linear over the tick (trapezoid): the readings are samples, not means
        self.pos += self.vel * h + (2.0 * prev + acc) * (h * h / 6.0)
        self.vel += 0.5 * (prev + acc) * h
        self._since_fix += h
        w = 1.0 / self.tc
        for i in (0, 1):
            if math.isfinite(fix[i]):
                dt = self._since_fix[i]
                e = fix[i] - self.pos[i]
                self.pos[i] += min(1.0, 3.0 * w * dt) * e
                self.vel[i] += 3.0 * w * w * dt * e
                self.bias[i] -= w ** 3 * dt * e
                self._since_fix[i] = 0.0
        # NED rates → body: u = cos θ ẋ − sin θ ż, w = sin θ ẋ + cos θ ż
        return np.array([c * self.vel[0] - s * self.vel[1], s * self.vel[0] + c * self.vel[1]])
