"""The Wavekeep firmware: the 20 Hz station-keeping control task and what it is made of.

    read sensors (HAL) → EKF predict/update → C-PD (+ FF from the forecast) →
    allocation, motor-lag compensation, PWM (mixer) → write PWM (HAL)

ArduPilot's split: the scheduler runs the task on an absolute time grid; the
estimator, controller and mixer are separate modules; every tunable is in the
parameter table. The feed-forward is the negated wave load predicted by the
same model the plant uses (:func:`~firmware_py.physics.vehicle.hydrodynamic_load`)
with nominal parameters and the forecast's flow at the estimated pose and
velocity; the same predicted flow drives the estimator's prediction.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from .control import ControlOutput, StationKeepingController
from .estimator import PlanarEKF
from .forecast import ForecastHandoff
from .hal import HAL
from .mixer import MixerOutput, MotorMixer
from .params import ParameterTable
from .physics.thrusters import T200Curve, ThrusterLayout
from .physics.vehicle import BodyFlow, VehicleParams, body_flow, hydrodynamic_load, strip_nodes
from .scheduler import Scheduler, Task
from .sensors import SensorFrame

__all__ = ["TickRecord", "Firmware"]


@dataclass(frozen=True)
class TickRecord:
    """What one control tick saw and did (for logs and telemetry)."""

    t: float
    frame: SensorFrame
    x_hat: np.ndarray
    sigma: np.ndarray
    setpoint: np.ndarray
    control: ControlOutput
    mix: MixerOutput
    tau_e_hat: np.ndarray      # predicted wave load at the end of the period (zeros without a forecast)
    ff_active: bool
    forecast_seq: int


class Firmware:
    """The vehicle's control software, bound to a HAL."""

    def __init__(self, hal: HAL, params: ParameterTable, vehicle: VehicleParams, layout: ThrusterLayout,
                 curve: T200Curve, setpoint, loop_rate_hz: float = 20.0, strips: int = 3,
                 forecast: ForecastHandoff | None = None, on_tick: Callable[[TickRecord], None] | None = None):
        self.hal = hal
        self.params = params
        self.vehicle = vehicle
        self.h = 1.0 / loop_rate_hz
        self.strips = strip_nodes(vehicle.length, strips)
        self.setpoint = np.asarray(setpoint, dtype=float)
        self.forecast = forecast if forecast is not None else ForecastHandoff()
        self.ekf = PlanarEKF(vehicle, params, self.h)
        self.controller = StationKeepingController(params, vehicle)
        self.mixer = MotorMixer(layout, curve, params, self.h)
        self.on_tick = on_tick
        self.last: TickRecord | None = None
        self._pending: tuple | None = None
        self._stage_offsets = np.array([0.0, 0.5 * self.h, self.h])
        self.scheduler = Scheduler(hal.clock, loop_rate_hz, [Task("control", loop_rate_hz, self.control_task)])

    def predicted_flow(self, t: float) -> tuple[BodyFlow | None, int]:
        """The forecast's flow at the strips, at the estimated pose, at t, t + h/2, t + h — or None."""
        if not self.params["WK_FF_ENABLE"] or not self.ekf.initialised:
            return None, -1
        active = self.forecast.current(t)
        if active is None:
            return None, -1
        return body_flow(active.components, self.ekf.x[:3], t + self._stage_offsets, self.strips), active.forecast.seq

    def control_task(self, slot_ns: int) -> None:
        t = slot_ns * 1e-9
        frame = self.hal.read_sensors()
        if self._pending is not None:
            self.ekf.predict(*self._pending)
        self.ekf.update(frame)
        if not self.ekf.initialised:
            mix = self.mixer.neutral()
            self.hal.write_pwm(mix.pwm)
            return
        flow, seq = self.predicted_flow(t)
        ff_active = flow is not None
        if ff_active:
            # τ̂_E on the vehicle holding station (ν = 0) at the end of the period, when the mixer
            # has the motors at their demand. The load's dependence on the vehicle's own motion is
            # left to the feedback: through the quadratic drag it would turn velocity-estimate
            # noise into feed-forward noise (≈ 300 N per m/s in W2).
            tau_e_hat = np.array(hydrodynamic_load(self.vehicle, 0.0, 0.0, 0.0, flow.stage(2)))
        else:
            tau_e_hat = np.zeros(3)
        control = self.controller.update(self.ekf.x, self.setpoint, -tau_e_hat if ff_active else None, self.h)
        mix = self.mixer.mix(control.tau)
        self.hal.write_pwm(mix.pwm)
        self._pending = (mix.tau_stages, flow)
        self.last = TickRecord(t, frame, self.ekf.x.copy(), self.ekf.sigma(), self.setpoint.copy(), control, mix,
                               tau_e_hat, ff_active, seq)
        if self.on_tick is not None:
            self.on_tick(self.last)
