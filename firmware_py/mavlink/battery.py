"""The simulated battery: a 4S Li-ion pack read through a Blue Robotics Power Sense Module (ArduSub's BATT_MONITOR 4).

There is no battery in the simulated world, so the link simulates the one a
BlueROV2 carries, as ArduPilot's SITL simulates its battery: the pack's
open-circuit voltage follows its state of charge (a 4S Li-ion discharge curve,
4 × 4.2 V full, 4 × 3.0 V empty), sags by the current through its internal
resistance (``SIM_BATT_RES``), and drains by the electrical power of the
thrusters plus a constant hotel load (``SIM_BATT_HOTEL``: computer, camera,
tether interface). Each thruster's power comes from its thrust with the T200
power fit of the paper, P = 0.0011|T|³ + 0.02078|T|² + 0.297|T| (W, T in N:
:func:`bridge.models.thrusters.power_per_dof`, applied per thruster).

What the monitor reports is ArduPilot's: voltage, current, consumed mAh and Wh,
and the remaining capacity counted against ``BATT_CAPACITY`` (the capacity the
user told the vehicle, which need not be the pack's real ``SIM_BATT_CAP_AH``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bridge.models.thrusters import power_per_dof

__all__ = ["CELLS", "BatterySim", "BatteryState", "ocv_per_cell"]

CELLS = 4
_SOC = np.array([0.0, 0.05, 0.10, 0.20, 0.30, 0.40, 0.50, 0.60, 0.70, 0.80, 0.90, 1.00])
_OCV = np.array([3.00, 3.30, 3.45, 3.58, 3.65, 3.71, 3.77, 3.84, 3.91, 3.99, 4.08, 4.20])
"""Open-circuit voltage of one Li-ion cell (V) against its state of charge (a typical 18650 curve)."""


def ocv_per_cell(soc: float) -> float:
    """Open-circuit voltage (V) of one cell at a state of charge in [0, 1]."""
    return float(np.interp(min(1.0, max(0.0, soc)), _SOC, _OCV))


@dataclass(frozen=True)
class BatteryState:
    """What the Power Sense Module reports at one instant."""

    voltage: float          # V at the terminals
    current: float          # A drawn
    consumed_mah: float     # mAh since boot
    consumed_wh: float      # Wh since boot
    remaining_pct: int      # % of BATT_CAPACITY left (0-100), −1 unknown
    power_w: float          # W drawn


class BatterySim:
    """A 4S pack drained by the thrusters' electrical power; :meth:`update` once per link tick.

    Parameters
    ----------
    params : ParameterTable
        SIM_BATT_* describe the pack, BATT_CAPACITY what the monitor counts against.
    """

    def __init__(self, params):
        self.params = params
        self._t: float | None = None
        self.soc = float(params["SIM_BATT_SOC"]) / 100.0
        self.consumed_as = 0.0          # ampere-seconds
        self.consumed_ws = 0.0          # watt-seconds
        self.state = self._state(0.0)

    def _state(self, power_w: float) -> BatteryState:
        p = self.params
        ocv = CELLS * ocv_per_cell(self.soc)
        r = max(0.0, float(p["SIM_BATT_RES"]))
        # P = V·I with V = OCV − R·I  →  R·I² − OCV·I + P = 0, the smaller root
        disc = ocv * ocv - 4.0 * r * power_w
        current = (ocv - math.sqrt(max(0.0, disc))) / (2.0 * r) if r > 0.0 else power_w / max(ocv, 1e-6)
        voltage = max(0.0, ocv - r * current)
        capacity_mah = float(p["BATT_CAPACITY"])
        mah = self.consumed_as / 3.6
        remaining = -1 if capacity_mah <= 0 else int(min(100.0, max(0.0, 100.0 * (1.0 - mah / capacity_mah))))
        return BatteryState(voltage, current, mah, self.consumed_ws / 3600.0, remaining, power_w)

    def power(self, thrust) -> float:
        """Electrical power (W): the thrusters' (from their thrust, N) and the hotel load."""
        t = np.asarray(thrust, dtype=float)
        t = t[np.isfinite(t)]
        return float(np.sum(power_per_dof(t))) + float(self.params["SIM_BATT_HOTEL"])

    def update(self, t: float | None, thrust) -> BatteryState:
        """Drain the pack from the last update to vehicle time ``t`` (s) at the thrust now applied (N)."""
        if t is None or not math.isfinite(t):
            return self.state
        power = self.power(thrust)
        dt = 0.0 if self._t is None else min(max(t - self._t, 0.0), 1.0)   # a clock jump drains nothing
        self._t = t
        state = self._state(power)
        if dt > 0.0:
            self.consumed_as += state.current * dt
            self.consumed_ws += state.voltage * state.current * dt
            cap_as = float(self.params["SIM_BATT_CAP_AH"]) * 3600.0
            self.soc = max(0.0, self.soc - state.current * dt / cap_as)
            state = self._state(power)
        self.state = state
        return state
