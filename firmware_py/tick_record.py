"""What one control tick saw and did (:class:`TickRecord`, flattened by :func:`tick_row` into the tick log's
:data:`~firmware_py.logger.tick_columns.TICK_COLUMNS`), and what it hands the next tick's estimator prediction
(:class:`Prediction`)."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from bridge.models.body6 import Flow6
from bridge.models.vehicle import BodyFlow

from .control.cascaded_pd import ControlOutput, SolveInfo
from .hal.sensors import SensorFrame
from .lateral_plane import LateralRecord
from .motors.mixer import MixerOutput

__all__ = ["Prediction", "TickRecord", "tick_row"]


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
    ff_weight: np.ndarray = field(default_factory=lambda: np.ones(3))   # FF monitor's weights [X, Z, M]
    d_hat: np.ndarray = field(default_factory=lambda: np.zeros(3))      # EKF's disturbance estimate [X, Z, M]
    nis: tuple[float, int] = (0.0, 0)                                    # EKF's joint NIS this tick and its dof
    target_offset: np.ndarray = field(default_factory=lambda: np.zeros(3))   # saturation preview's [x, z, θ] (m, rad)
    ff_skill: np.ndarray = field(default_factory=lambda: np.ones(3))    # forecast's skill per axis [X, Z, M]
    solve: SolveInfo = field(default_factory=SolveInfo)                 # the controller's solver this tick
    lateral: LateralRecord | None = None                                 # the lateral plane, when estimated


_NO_LATERAL = [math.nan] * 14


def tick_row(r: TickRecord) -> list[float]:
    """A :class:`TickRecord` as a flat row in :data:`TICK_COLUMNS` order."""
    lat = r.lateral
    return [*r.x_hat, *r.sigma[:3], *r.setpoint, *r.control.tau, *r.control.tau_ff, *r.tau_e_hat, *r.mix.pwm,
            float(r.ff_active), *r.ff_weight, float(r.control.saturated), *r.sigma[3:6], *r.d_hat,
            *r.control.tau_dob, float(r.nis[0]), float(r.nis[1]), *r.target_offset[:2], *r.ff_skill,
            float(r.solve.status), float(r.solve.iterations), r.solve.solve_ms,
            *(_NO_LATERAL if lat is None else [*lat.x_hat, *lat.target, *lat.tau, *lat.tau_ff])]


@dataclass(frozen=True)
class Prediction:
    """What a tick hands the next tick's estimator prediction: the wrench the mixer expected the
    thrusters to give at the period's three RK4 stages (N, N, N m), and the forecast's flow at the
    body over the period (None without a forecast), taken at tick time ``t`` (s)."""

    tau_stages: np.ndarray
    flow: BodyFlow | None
    t: float
    tau6_stages: np.ndarray | None = None    # (3, 6): the same wrench in six DoF, when the lateral plane is held
    flow6: Flow6 | None = None               # the forecast's flow at the six-DoF strips, likewise
