"""What the firmware reports to a ground station, taken once per GCS tick: a frozen, typed snapshot.

The MAVLink link builds every telemetry message from a :class:`TelemetrySnapshot`
(:meth:`firmware_py.firmware.Firmware.telemetry_snapshot`) and never reaches into
the estimator or the HAL itself, so the vehicle's internals can change without
touching the link. All values are plain Python numbers; non-finite values are
passed through (the message builders clip them).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["TelemetrySnapshot"]


@dataclass(frozen=True)
class TelemetrySnapshot:
    """The vehicle's state as the ground station sees it, at one instant.

    Attributes
    ----------
    t : float or None
        Vehicle time of the last control tick (s); None before the first tick.
    mode : int
        Flight mode (ArduSub custom_mode number).
    armed : bool
        Motors armed.
    system_status : int
        MAV_STATE (BOOT, STANDBY, ACTIVE, CRITICAL).
    sensors_healthy : bool
        The last sensor frame was healthy and finite.
    ekf_converged : bool
        The estimator's position 1-sigma is below WK_EKF_CONV.
    failsafe : bool
        A GCS or EKF failsafe is active.
    x_hat : tuple of float
        Estimate [x (m, north), z (m, depth), θ (rad, pitch), u (m/s), w (m/s), q (rad/s)] of the
        last tick, body-frame velocities; empty before the first tick.
    measured_depth : float
        The pressure sensor's depth at the last tick (m; NaN if none).
    pwm : tuple of float
        Thruster outputs of the last tick (µs), motor order.
    heave_force : float
        Commanded heave force at the end of the last period (N, FRD: + is down).
    tau_e_hat : tuple of float
        Predicted wave load [X (N), Z (N), M (N m)] of the last tick.
    ff_active : bool
        Feed-forward applied at the last tick.
    forecast_age : float
        Age of the forecast in use (s); −1 without one.
    late_slots : int
        Slots a paced SITL clock fell behind (0 on a real clock).
    origin_lat, origin_lon : float
        Latitude and longitude of the local NED origin (deg).
    tau_max_z : float
        Heave effort at full throttle (N).
    prearm_ok : bool
        The pre-arm checks ARMING_CHECK selects pass (:meth:`~firmware_py.firmware.Firmware.prearm_failure`).
    thrust : tuple of float
        Steady-state thrust of each thruster's PWM at the last tick (N), motor order; empty before it.
    sigma : tuple of float
        The estimate's 1-sigma of [x, z, θ] at the last tick; empty before it.
    setpoint : tuple of float
        The target [x (m), depth (m), θ (rad)] the controller held at the last tick; empty before it.
    measured_x : float
        The position fix's x at the last tick (m, north; NaN if none came that tick).
    lateral : tuple of float
        The lateral-directional estimate [y (m, east), φ (rad, roll), ψ (rad, heading), v (m/s), p, r (rad/s)]
        of the last tick; empty when the vehicle is not estimated in six DoF (a planar world).
    """

    t: float | None
    mode: int
    armed: bool
    system_status: int
    sensors_healthy: bool
    ekf_converged: bool
    failsafe: bool
    x_hat: tuple[float, ...]
    measured_depth: float
    pwm: tuple[float, ...]
    heave_force: float
    tau_e_hat: tuple[float, ...]
    ff_active: bool
    forecast_age: float
    late_slots: int
    origin_lat: float
    origin_lon: float
    tau_max_z: float
    prearm_ok: bool = False
    thrust: tuple[float, ...] = ()
    sigma: tuple[float, ...] = ()
    setpoint: tuple[float, ...] = ()
    measured_x: float = math.nan
    lateral: tuple[float, ...] = ()

    @property
    def has_tick(self) -> bool:
        """True once the control task has run (there is an estimate and an output to report)."""
        return self.t is not None

    @classmethod
    def from_firmware(cls, fw) -> TelemetrySnapshot:
        """Take the snapshot of a :class:`~firmware_py.firmware.Firmware` (called from its scheduler thread)."""
        r = fw.last
        p = fw.params
        age = -1.0
        if r is not None and p["WK_FF_ENABLE"]:
            try:
                active = fw.forecast.current(r.t)
                if active is not None:
                    age = float(r.t - active.forecast.time_base)
            except Exception:   # a forecast that cannot be evaluated reads as none
                age = -1.0
        late = getattr(getattr(fw.hal, "clock", None), "late", 0)
        converged = bool(fw.ekf.converged())
        common: dict[str, Any] = dict(mode=int(fw.mode), armed=bool(fw.armed), system_status=int(fw.system_status()),
                      sensors_healthy=bool(fw.sensors_healthy), ekf_converged=converged,
                      failsafe=bool(fw.failsafe_gcs or fw.failsafe_ekf), forecast_age=age,
                      late_slots=int(late or 0), origin_lat=float(p["WK_ORIGIN_LAT"]),
                      origin_lon=float(p["WK_ORIGIN_LON"]), tau_max_z=float(p["WK_TAU_MAX_Z"]),
                      prearm_ok=fw.prearm_failure(converged) is None)
        if r is None:
            return cls(t=None, x_hat=(), measured_depth=math.nan, pwm=(), heave_force=0.0, tau_e_hat=(0.0,) * 3,
                       ff_active=False, **common)
        return cls(t=float(r.t), x_hat=_floats(r.x_hat[:6]), measured_depth=float(r.frame.depth),
                   measured_x=float(r.frame.x),
                   pwm=_floats(r.mix.pwm), heave_force=float(r.mix.tau_stages[-1][1]),
                   tau_e_hat=_floats(r.tau_e_hat[:3]), ff_active=bool(r.ff_active),
                   thrust=_floats(r.mix.thrust_cmd), sigma=_floats(r.sigma[:3]), setpoint=_floats(r.setpoint[:3]),
                   lateral=() if r.lateral is None else _floats(r.lateral.x_hat), **common)


def _floats(values) -> tuple[float, ...]:
    """``tuple(float(v) for v in values)`` in one call (the snapshot is taken every tick)."""
    return tuple(np.asarray(values, dtype=float).tolist())
