"""Sensor frames and the simulated sensors of the SITL HAL.

As in ArduPilot's SITL, the simulator reports the true state and the
firmware's HAL turns it into sensor readings with noise (``SIM_*``
parameters), so the noise is the same whichever transport carries the state.

Sensors (paper §IV: sensor noise on, EKF in the loop; the paper gives no values):

* horizontal position fix x (m), at ``SIM_POS_RATE`` Hz — an acoustic
  positioning system (USBL class);
* depth (m) from a Bar30-like pressure sensor, every tick; reported also as
  absolute pressure (Pa) for telemetry. The wave's dynamic pressure is not
  modelled: the plant's state carries no pressure field;
* pitch (rad) and pitch rate (rad/s) from the IMU/AHRS, every tick.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .params import ParameterTable

__all__ = ["ATM_PA", "RHO_SEAWATER", "SensorFrame", "SimulatedSensors", "depth_to_pressure"]

ATM_PA = 101325.0          # Pa at the surface
RHO_SEAWATER = 1025.0      # kg/m³
G0 = 9.80665               # m/s², as pressure-to-depth conversions use


def depth_to_pressure(depth_m: float) -> float:
    """Absolute pressure (Pa) at a depth (m) in sea water."""
    return ATM_PA + RHO_SEAWATER * G0 * depth_m


@dataclass(frozen=True)
class SensorFrame:
    """One tick's sensor readings. A reading not available this tick is NaN."""

    t: float            # s, vehicle clock
    x: float            # m, NED north (position fix)
    depth: float        # m
    pitch: float        # rad
    pitch_rate: float   # rad/s
    healthy: bool = True

    def as_vector(self) -> np.ndarray:
        """[x, depth, θ, q] in the estimator's measurement order."""
        return np.array([self.x, self.depth, self.pitch, self.pitch_rate])


class SimulatedSensors:
    """Truth → noisy readings, seeded for reproducibility."""

    def __init__(self, params: ParameterTable, seed: int):
        self.params = params
        self.rng = np.random.default_rng(seed)
        self._last_fix_slot = -1

    def read(self, t: float, eta, nu) -> SensorFrame:
        """Sample the sensors at time t (s) for truth η = [x, z, θ], ν = [u, w, q]."""
        p = self.params
        # Draw every channel every tick so the noise sequence is independent of rates.
        n = self.rng.standard_normal(4)
        slot = math.floor(t * p["SIM_POS_RATE"] + 1e-9)
        fix = slot != self._last_fix_slot
        self._last_fix_slot = slot
        return SensorFrame(
            t=t,
            x=float(eta[0] + p["SIM_POS_RND"] * n[0]) if fix else math.nan,
            depth=float(eta[1] + p["SIM_DEPTH_RND"] * n[1]),
            pitch=float(eta[2] + p["SIM_PITCH_RND"] * n[2]),
            pitch_rate=float(nu[2] + p["SIM_GYRO_RND"] * n[3]),
        )
