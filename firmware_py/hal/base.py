"""The hardware abstraction layer: what the firmware needs from the vehicle.

``read_sensors()`` → :class:`~firmware_py.hal.sensors.SensorFrame`,
``write_pwm(pwm)`` with eight thruster pulse widths (µs, ArduSub motor order),
and ``clock`` (a :class:`~firmware_py.hal.scheduler.Clock`).

:class:`InProcessSITLHAL` calls straight into a simulated plant in the same
process for fast batch runs; it is duck-typed (any object with ``state.t``,
``state.eta``, ``state.nu`` and ``step(pwm, dt)``), so the firmware never imports
the simulator. The networked backend (ArduPilot JSON SITL over UDP) is a
drop-in replacement.
"""
from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Protocol

import numpy as np

from bridge.models.thrusters import NEUTRAL_PWM_US

from ..params.table import ParameterTable
from .clocks import Clock, SimClock
from .sensors import SensorFrame, SimulatedSensors, specific_force

__all__ = ["HAL", "PWM_CHANNELS", "InProcessSITLHAL", "PlantLike"]

PWM_CHANNELS = 8


class HAL(ABC):
    clock: Clock

    @abstractmethod
    def read_sensors(self) -> SensorFrame:
        """The newest sensor readings (non-blocking beyond the current tick)."""

    @abstractmethod
    def write_pwm(self, pwm: np.ndarray) -> None:
        """Output eight thruster pulse widths (µs)."""


class PlantStateLike(Protocol):
    t: float              # s
    eta: np.ndarray       # [x, z, θ]
    nu: np.ndarray        # [u, w, q]


class PlantLike(Protocol):
    @property
    def state(self) -> PlantStateLike: ...

    def step(self, pwm, dt: float) -> object: ...


class InProcessSITLHAL(HAL):
    """Lockstep in-process SITL.

    ``write_pwm`` latches the command; the harness then calls :meth:`step_world`,
    which holds it for one period and advances the plant, as the JSON SITL
    physics server does on each servo packet. Keeping the plant out of the
    control task keeps the task's measured compute time the firmware's own.
    The clock is a :class:`SimClock` that the scheduler moves from slot to
    slot; the plant's time and the clock agree at every slot.
    """

    def __init__(self, plant: PlantLike, params: ParameterTable, period_s: float, sensor_seed: int,
                 clock: Clock | None = None):
        self.plant = plant
        self.period_s = float(period_s)
        self.clock = clock if clock is not None else SimClock(start_ns=int(round(plant.state.t * 1e9)))
        self.sensors = SimulatedSensors(params, sensor_seed)
        self.last_pwm = np.full(PWM_CHANNELS, NEUTRAL_PWM_US, dtype=np.int64)

    def read_sensors(self) -> SensorFrame:
        s = self.plant.state
        nu_dot = getattr(self.plant, "nu_dot", None)     # the plant's body acceleration, if it keeps one
        g = getattr(getattr(self.plant, "vehicle", None), "g", None)
        accel = None if nu_dot is None or g is None else specific_force(s.eta, s.nu, nu_dot, g)
        # A plant that models the depth sensor's dynamic pressure says what the sensor reads (m); one that moves
        # in six DoF gives the lateral channels their truth
        lateral_of = getattr(self.plant, "lateral_state", None)
        lateral = lateral_of() if lateral_of is not None else None
        if lateral is not None:      # the accelerometer of a vehicle that moves in six DoF: what JSON SITL sends
            f = self.plant.specific_force6()  # type: ignore[attr-defined]
            accel = np.array([f[0], f[2]])
        return self.sensors.read(s.t, s.eta, s.nu, accel, getattr(self.plant, "pressure_depth", None), lateral)

    def write_pwm(self, pwm: np.ndarray) -> None:
        self.last_pwm = np.array(pwm, dtype=np.int64)

    def step_world(self) -> None:
        """Advance the plant one period under the latched PWM."""
        self.plant.step(self.last_pwm.astype(float), self.period_s)
