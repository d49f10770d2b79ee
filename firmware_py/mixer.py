"""Motor mixer: body wrench → eight thruster thrusts → PWM (paper Eq. 13).

* Allocation by the Moore–Penrose pseudo-inverse of the 3×8 matrix derived from
  the thruster layout, within ±``WK_THR_MAX`` per thruster, with attitude
  first: the pitch moment is allocated, then heave, then surge, each scaled
  down only as far as the thrust the previous ones left requires. Clipping
  each thruster alone would let a saturated heave demand (the vertical
  thrusters serve both) wipe out the pitch moment; ArduSub's Motors6DOF
  likewise gives roll/pitch/yaw priority over throttle.
* Motor-lag compensation: the motors follow their command with a first-order
  lag t_m, so over one period h the thrust moves a fraction 1 − e^{−h/t_m} of
  the way. The command that makes each motor *reach* its demand f_d by the end
  of the period is f_cmd = (f_d − e^{−h/t_m} f̂) / (1 − e^{−h/t_m}), where f̂ is the
  firmware's model of the motor's present thrust.
  The boost can exceed a thruster's range; clipping each thruster alone would
  again lose the pitch moment, so with ``WK_MOT_LIM`` 1 the command's wrench
  B f_cmd is re-allocated pitch first within ±``WK_THR_MAX`` (the rc companion:
  an autopilot's sticks reach no further, ``docs/companion.md``).
* Thrust → PWM through the inverse T200 curve (nominal), rounded to whole µs
  as an ESC takes them, 1100–1900 µs.

The mixer also reports the thrust it expects over the coming period (at t,
t + h/2, t + h) so the estimator's prediction uses the same motor model.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bridge.models.thrusters import T200Curve, ThrusterLayout
from bridge.models.vehicle import motor_lag_stages

from .params import ParameterTable

__all__ = ["MixerOutput", "MotorMixer"]


@dataclass(frozen=True)
class MixerOutput:
    pwm: np.ndarray            # (8,) int µs
    thrust_demand: np.ndarray  # (8,) N, after allocation and clipping
    thrust_cmd: np.ndarray     # (8,) N, the steady-state thrust of the PWM sent
    tau_stages: np.ndarray     # (3, 3) expected thruster wrench at t, t + h/2, t + h


class MotorMixer:
    def __init__(self, layout: ThrusterLayout, curve: T200Curve, params: ParameterTable, h: float):
        self.layout = layout
        self.curve = curve
        self.params = params
        self.h = float(h)
        self.B = layout.allocation_matrix()
        self.B_pinv = np.linalg.pinv(self.B)
        self._pinv_cols = tuple(self.B_pinv[:, axis].tolist() for axis in range(3))   # floats for allocate()
        self.f_hat = np.zeros(layout.n)
        self._stage_offsets = np.array([0.0, 0.5 * self.h, self.h])

    def reset(self) -> None:
        self.f_hat = np.zeros(self.layout.n)

    def output(self, pwm: np.ndarray, f_d: np.ndarray | None = None) -> MixerOutput:
        """Send these PWM values (µs); keeps the firmware's motor model in step."""
        if f_d is None:
            f_d = self.curve.thrust(pwm)
        f_sent = self.curve.thrust(pwm)
        stages = motor_lag_stages(f_sent, self.f_hat, self.params["WK_MOT_TC"], self._stage_offsets)
        self.f_hat = stages[-1]
        return MixerOutput(pwm, f_d, f_sent, stages @ self.B.T)

    def mix(self, tau: np.ndarray) -> MixerOutput:
        """Allocate the body wrench τ = [X, Z, M] and return the PWM to send."""
        p = self.params
        f_d = self.allocate(tau, p["WK_THR_MAX"])
        if p["WK_MOT_COMP"]:
            a = math.exp(-self.h / p["WK_MOT_TC"])
            f_cmd = (f_d - a * self.f_hat) / (1.0 - a)
            if p["WK_MOT_LIM"]:
                # The compensated command re-allocated pitch first: its boost never clips pitch away
                f_cmd = self.allocate(self.B @ f_cmd, p["WK_THR_MAX"])
        else:
            f_cmd = f_d
        # Below WK_THR_MIN a thruster is sent neutral: the curve is flat at the dead band's edge,
        # so a residual of a few mN would otherwise hold it at 1472/1528 µs indefinitely.
        f_cmd = np.where(np.abs(f_cmd) < p["WK_THR_MIN"], 0.0, f_cmd)
        pwm = np.rint(self.curve.pwm(f_cmd)).astype(np.int64)
        return self.output(pwm, f_d)

    _PRIORITY = (2, 1, 0)  # pitch, heave, surge

    def allocate(self, tau: np.ndarray, f_max: float) -> np.ndarray:
        """Thrusts (N) for the wrench τ, pitch first, every thruster within ±f_max."""
        f = [0.0] * self.layout.n
        # In floats (eight thrusters, three axes): the same IEEE operations as the array form, a tenth of the time
        for axis in self._PRIORITY:
            ta = float(tau[axis])
            g = [b * ta for b in self._pinv_cols[axis]]
            # Largest s in [0, 1] with |f + s g| ≤ f_max for every thruster
            room = math.inf
            for fi, gi in zip(f, g, strict=True):
                if gi > 0:
                    room = min(room, (f_max - fi) / gi)
                elif gi < 0:
                    room = min(room, (-f_max - fi) / gi)
            scale = min(1.0, max(0.0, room))
            f = [fi + scale * gi for fi, gi in zip(f, g, strict=True)]
        return np.array(f)

    def neutral(self) -> MixerOutput:
        """Every thruster at the neutral pulse (disarmed, failsafe)."""
        pwm = np.full(self.layout.n, int(round(self.curve.pwm_neutral)), dtype=np.int64)
        return self.output(pwm, np.zeros(self.layout.n))
