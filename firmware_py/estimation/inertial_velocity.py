"""Body velocity from the IMU and the position fixes alone: no vehicle model, no forecast.

A third-order complementary filter per NED axis, as ArduPilot's inertial navigation
(AP_InertialNav) blends its accelerometers with GPS and the barometer: position,
velocity and an accelerometer bias, driven by the measured acceleration and pulled
to each fix through gains 3ω, 3ω², ω³ (three poles at ω = 1/``WK_FF_SKILL_VTC``).

The accelerometer's specific force f = [f_x, f_z] (body FRD) and the AHRS pitch θ
give the NED acceleration (:func:`~firmware_py.hal.sensors.specific_force` inverted):

    ẍ = cos θ f_x + sin θ f_z,    z̈ = −sin θ f_x + cos θ f_z + g.

The fixes are the horizontal position x and the depth, whenever a frame carries
them. The feed-forward's skill (:mod:`firmware_py.control.feedforward`) needs a velocity the
forecast has not touched: the estimator predicts with the forecast, so its velocity
follows a wrong forecast as well as a right one.
"""
from __future__ import annotations

import math

import numpy as np

from ..hal.sensors import SensorFrame

__all__ = ["InertialVelocity"]


class InertialVelocity:
    """x and z (NED, m), their rates (m/s) and the accelerometer biases (m/s²), from IMU and fixes.

    ``h`` is the tick (s), ``tc`` the filter's time constant (s), ``g`` gravity (m/s²). The two axes
    are kept as plain floats: a tick is a dozen scalar operations per axis, which cost less as Python
    floats than as two-element arrays (the arithmetic, and so the bits, are the same).
    """

    def __init__(self, h: float, tc: float, g: float):
        self.h, self.tc, self.g = h, tc, g
        self.reset()

    def reset(self) -> None:
        """Forget the state: the next frames with both fixes start it again."""
        self._pos = [math.nan, math.nan]      # [x, z] NED (m)
        self._vel = [0.0, 0.0]                # [ẋ, ż] (m/s)
        self._bias = [0.0, 0.0]               # NED acceleration bias (m/s²)
        self._since_fix = [0.0, 0.0]          # s since each axis' last fix
        self._acc: tuple[float, float] | None = None   # the last tick's NED acceleration (m/s²)

    @property
    def pos(self) -> np.ndarray:
        """[x, z] NED (m)."""
        return np.array(self._pos)

    @property
    def vel(self) -> np.ndarray:
        """[ẋ, ż] NED (m/s)."""
        return np.array(self._vel)

    @property
    def bias(self) -> np.ndarray:
        """The accelerometer's bias in NED [x, z] (m/s²)."""
        return np.array(self._bias)

    @property
    def ready(self) -> bool:
        return math.isfinite(self._pos[0]) and math.isfinite(self._pos[1])

    def update(self, frame: SensorFrame) -> np.ndarray | None:
        """Propagate one tick with this frame's IMU, correct with its fixes; body [u, w] (m/s) or None."""
        fix = (float(frame.x), float(frame.depth))
        f_x, f_z, th = float(frame.acc_x), float(frame.acc_z), float(frame.pitch)
        if not (math.isfinite(f_x) and math.isfinite(f_z) and math.isfinite(th)):
            self.reset()
            return None
        c, s = math.cos(th), math.sin(th)
        pos, vel, bias, since = self._pos, self._vel, self._bias, self._since_fix
        if not self.ready:
            self._pos = [f if math.isfinite(f) else x for f, x in zip(fix, pos, strict=True)]
            return None
        acc = (c * f_x + s * f_z - bias[0], -s * f_x + c * f_z + self.g - bias[1])
        prev = acc if self._acc is None else self._acc
        self._acc = acc
        h = self.h
        w = 1.0 / self.tc
        for i in (0, 1):
            # the acceleration taken linear over the tick (trapezoid): the readings are samples, not means
            pos[i] += vel[i] * h + (2.0 * prev[i] + acc[i]) * (h * h / 6.0)
            vel[i] += 0.5 * (prev[i] + acc[i]) * h
            since[i] += h
            if math.isfinite(fix[i]):
                dt = since[i]
                e = fix[i] - pos[i]
                pos[i] += min(1.0, 3.0 * w * dt) * e
                vel[i] += 3.0 * w * w * dt * e
                bias[i] -= w ** 3 * dt * e
                since[i] = 0.0
        # NED rates → body: u = cos θ ẋ − sin θ ż, w = sin θ ẋ + cos θ ż
        return np.array([c * vel[0] - s * vel[1], s * vel[0] + c * vel[1]])
