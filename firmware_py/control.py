"""Station-keeping controller: cascaded PD (C-PD) with wave feed-forward — paper Eq. 12.

Structure, after the authors' implementation (docs/reference.md §7):

* the position error e = R(θ)ᵀ (η_r − η̂) is taken in the body frame for surge
  and heave (pitch error as is);
* outer loop: velocity demand ν_d = sat(K_p e + K_d ė, ν_max), ė the error's
  rate over the last period;
* inner loop: normalised effort u = K_pv (ν_d − ν̂);
* hydrostatic compensation (``WK_G_COMP``): u += τ_g / τ_max with the nominal
  net-buoyancy force at the estimated pitch and the restoring moment at the
  setpoint pitch, so the vehicle's 2 N of buoyancy and a non-zero pitch
  setpoint leave no steady-state error, while the natural pitch stiffness
  about the setpoint is kept (the paper's C-PD has no integral term and none
  of this; ArduSub integrates instead);
* feed-forward (C-PD+FF): u += g_ff · τ_FF / τ_max with τ_FF = −τ̂_E, the
  predicted wave load negated (the paper prints the inertia term with the
  wrong sign; docs/architecture.md);
* disturbance observer (``WK_DOB_ENABLE``, the ``cpd_dob`` and ``cpd_ff_dob``
  controllers): u += τ_DOB / τ_max with τ_DOB = −g_dob · d̂, the aided EKF's
  estimate of the disturbance wrench the model does not predict, limited to
  ``WK_DOB_LIM_*`` · τ_max (docs/estimator.md);
* τ = τ_max · sat(u, 1).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bridge.models.vehicle import VehicleParams, ned_to_body, restoring_forces

from .params import ParameterTable

__all__ = ["ControlOutput", "StationKeepingController"]

_GAIN_FAMILIES = ("WK_PD_KP", "WK_PD_KD", "WK_VEL_MAX", "WK_VEL_KP", "WK_TAU_MAX")


@dataclass(frozen=True)
class ControlOutput:
    """Body-frame wrenches [X (N), Z (N), M (N m)]."""

    tau: np.ndarray        # the saturated total command
    tau_ff: np.ndarray     # the feed-forward part as applied (g_ff · τ_FF)
    saturated: bool        # some axis hit ±τ_max (logged per tick)
    tau_dob: np.ndarray = field(default_factory=lambda: np.zeros(3))   # the DOB part as applied


class StationKeepingController:
    def __init__(self, params: ParameterTable, vehicle: VehicleParams):
        self.params = params
        self.vehicle = vehicle
        self._prev_error: np.ndarray | None = None
        self._gains_key: tuple[int, int] | None = None
        self._gains: tuple[np.ndarray, ...] = ()

    def gains(self) -> tuple[np.ndarray, ...]:
        """(K_p (1/s), K_d, ν_max (m/s, rad/s), K_pv (s/m), τ_max (N, N m)) per axis [surge, heave, pitch],
        read from the parameter table again only when it has changed (its ``version``)."""
        key = (id(self.params), self.params.version)
        if key != self._gains_key:
            self._gains = tuple(np.array(self.params.axes(name)) for name in _GAIN_FAMILIES)
            self._gains_key = key
        return self._gains

    def reset(self) -> None:
        self._prev_error = None

    def disturbance_feedback(self, d_hat: np.ndarray | None) -> np.ndarray:
        """τ_DOB = −g_dob · d̂, limited to WK_DOB_LIM_* · τ_max; zeros when the DOB is off or d̂ is None."""
        p = self.params
        if d_hat is None or not p["WK_DOB_ENABLE"]:
            return np.zeros(3)
        lim = np.array(p.axes("WK_DOB_LIM")) * self.gains()[4]
        return np.clip(-p["WK_DOB_GAIN"] * np.asarray(d_hat, dtype=float), -lim, lim)

    def update(self, x_hat: np.ndarray, setpoint: np.ndarray, tau_ff: np.ndarray | None, dt: float,
               d_hat: np.ndarray | None = None) -> ControlOutput:
        """One control step from the estimate x̂ = [x, z, θ, u, w, q] to the setpoint [x, z, θ]
        (``d_hat``: the estimated disturbance wrench, fed back when the DOB is on)."""
        p = self.params
        eta, nu = x_hat[:3], x_hat[3:]
        e_n = np.asarray(setpoint, dtype=float) - eta
        e = np.array([*ned_to_body(float(eta[2]), e_n[0], e_n[1]), e_n[2]])
        de = np.zeros(3) if self._prev_error is None else (e - self._prev_error) / dt
        self._prev_error = e
        kp, kd, vmax, kv, tau_max = self.gains()
        v_d = np.minimum(np.maximum(kp * e + kd * de, -vmax), vmax)   # np.clip's result, without its overhead
        u_pd = kv * (v_d - nu)
        ff = np.zeros(3) if tau_ff is None else p["WK_FF_GAIN"] * np.asarray(tau_ff, dtype=float)
        dob = self.disturbance_feedback(d_hat)
        u = u_pd + (ff + dob) / tau_max
        if p["WK_G_COMP"]:
            g_est = restoring_forces(self.vehicle, eta)
            g_ref = restoring_forces(self.vehicle, np.asarray(setpoint, dtype=float))
            u = u + np.array([g_est[0], g_est[1], g_ref[2]]) / tau_max
        u_sat = np.minimum(np.maximum(u, -1.0), 1.0)
        return ControlOutput(tau=tau_max * u_sat, tau_ff=ff, saturated=bool((u_sat != u).any()), tau_dob=dob)
