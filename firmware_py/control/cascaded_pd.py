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
from typing import NamedTuple

import numpy as np

from bridge.models.vehicle import VehicleParams, ned_to_body, restoring_forces

from ..logger.tick_columns import SolveStatus
from ..numerics.floats import clip_float
from ..params.table import ParameterTable

__all__ = ["ControlOutput", "Gains", "SolveInfo", "SolveStatus", "StationKeepingController", "cascade"]

_GAIN_FAMILIES = ("WK_PD_KP", "WK_PD_KD", "WK_VEL_MAX", "WK_VEL_KP", "WK_TAU_MAX")


@dataclass(frozen=True)
class SolveInfo:
    """One tick's solver record: status, iterations and compute time (ms, wall clock)."""

    status: SolveStatus = SolveStatus.NONE
    iterations: int = 0
    solve_ms: float = 0.0


NO_SOLVE = SolveInfo()


@dataclass(frozen=True)
class ControlOutput:
    """Body-frame wrenches [X (N), Z (N), M (N m)]."""

    tau: np.ndarray        # the saturated total command
    tau_ff: np.ndarray     # the feed-forward part as applied (g_ff · τ_FF)
    saturated: bool        # some axis hit ±τ_max, or the command the limits (logged per tick)
    tau_dob: np.ndarray = field(default_factory=lambda: np.zeros(3))   # the DOB part as applied
    target_offset: np.ndarray = field(default_factory=lambda: np.zeros(3))   # the target moved by (preview)
    solve: SolveInfo = NO_SOLVE


class _Gains(NamedTuple):
    """The controller's gains per axis, as arrays and as floats, and the DOB's limits (N, N, N m)."""

    arrays: tuple[np.ndarray, ...]
    floats: tuple[tuple[float, float, float], ...]
    dob_lim: tuple[float, float, float]


def _read_gains(p: ParameterTable) -> _Gains:
    arrays = tuple(np.array(p.axes(name)) for name in _GAIN_FAMILIES)
    # np.array(axes) * τ_max, the same products
    dob_lim = tuple((np.array(p.axes("WK_DOB_LIM")) * arrays[4]).tolist())
    return _Gains(arrays, tuple(tuple(g.tolist()) for g in arrays), dob_lim)


Gains = tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...], tuple[float, ...], tuple[float, ...]]
"""Per axis: (K_p, K_d, ν_max, K_pv, τ_max), each a tuple over the axes."""


def cascade(e, de, nu, gains: Gains, push, g) -> tuple[list[float], bool]:
    """The cascaded PD of each axis, on floats: ν_d = sat(K_p e + K_d ė, ν_max), u = K_pv (ν_d − ν) + push/τ_max
    (+ g/τ_max when ``g`` is not None: adding 0 could flip a −0), τ = τ_max sat(u, 1).

    ``e``, ``de``, ``nu`` the errors, their rates and the velocities per axis; ``push`` the wrench added ahead
    of the saturation (feed-forward + DOB; N or N m); ``g`` the hydrostatic compensation or None. Returns the
    wrench and whether any axis saturated (NaN counts as saturated, as ``(u_sat != u).any()`` has it).
    """
    kp, kd, vmax, kv, tau_max = gains
    tau, saturated = [], False
    for i, nu_i in enumerate(nu):
        v_d = clip_float(kp[i] * e[i] + kd[i] * de[i], -vmax[i], vmax[i])
        u_i = kv[i] * (v_d - nu_i) + push[i] / tau_max[i]
        if g is not None:
            u_i = u_i + g[i] / tau_max[i]
        u_sat = clip_float(u_i, -1.0, 1.0)
        saturated = saturated or u_sat != u_i
        tau.append(tau_max[i] * u_sat)
    return tau, saturated


class StationKeepingController:
    def __init__(self, params: ParameterTable, vehicle: VehicleParams):
        self.params = params
        self.vehicle = vehicle
        self._prev_error: tuple[float, float, float] | None = None
        self._g_ref_key: tuple[float, float] | None = None
        self._g_ref = 0.0

    def gains(self) -> tuple[np.ndarray, ...]:
        """(K_p (1/s), K_d, ν_max (m/s, rad/s), K_pv (s/m), τ_max (N, N m)) per axis [surge, heave, pitch],
        read from the parameter table again only when it has changed (its ``version``)."""
        return self.params.derived(_read_gains).arrays

    def reset(self) -> None:
        self._prev_error = None

    def disturbance_feedback(self, d_hat: np.ndarray | None) -> np.ndarray:
        """τ_DOB = −g_dob · d̂, limited to WK_DOB_LIM_* · τ_max; zeros when the DOB is off or d̂ is None."""
        return np.array(self._disturbance_feedback(d_hat))

    def _disturbance_feedback(self, d_hat: np.ndarray | None) -> list[float]:
        """:meth:`disturbance_feedback` as floats."""
        p = self.params
        if d_hat is None or not p["WK_DOB_ENABLE"]:
            return [0.0, 0.0, 0.0]
        g = -p["WK_DOB_GAIN"]
        return [clip_float(g * d, -lim, lim)
                for d, lim in zip(np.asarray(d_hat, dtype=float).tolist(), p.derived(_read_gains).dob_lim, strict=True)]

    def update(self, x_hat: np.ndarray, setpoint: np.ndarray, tau_ff: np.ndarray | None, dt: float,
               d_hat: np.ndarray | None = None) -> ControlOutput:
        """One control step from the estimate x̂ = [x, z, θ, u, w, q] to the setpoint [x, z, θ]
        (``d_hat``: the estimated disturbance wrench, fed back when the DOB is on).

        In Python floats, axis by axis: the same IEEE operations in the same order as the array
        form (everything here is element-wise), a third of the time on three-element arrays.
        """
        p = self.params
        x, z, th, u, w, q = np.asarray(x_hat, dtype=float).tolist()
        sp = np.asarray(setpoint, dtype=float)
        ref = sp.tolist()
        e_x, e_z = ned_to_body(th, ref[0] - x, ref[1] - z)
        e = (e_x, e_z, ref[2] - th)
        prev = self._prev_error
        de = (0.0, 0.0, 0.0) if prev is None else tuple((ei - pi) / dt for ei, pi in zip(e, prev, strict=True))
        self._prev_error = e
        kp, kd, vmax, kv, tau_max = p.derived(_read_gains).floats
        ff = (0.0, 0.0, 0.0) if tau_ff is None else tuple(
            p["WK_FF_GAIN"] * t for t in np.asarray(tau_ff, dtype=float).tolist())
        dob = self._disturbance_feedback(d_hat)
        g: tuple[float, float, float] | None = None      # None: no hydrostatic term (adding 0 could flip a −0)
        if p["WK_G_COMP"]:
            g_est = restoring_forces(self.vehicle, x_hat[:3])
            g = (float(g_est[0]), float(g_est[1]), self._restoring_moment(sp))
        tau, saturated = cascade(e, de, (u, w, q), (kp, kd, vmax, kv, tau_max),
                                 [f + d for f, d in zip(ff, dob, strict=True)], g)
        return ControlOutput(tau=np.array(tau), tau_ff=np.array(ff), saturated=saturated, tau_dob=np.array(dob))

    def _restoring_moment(self, setpoint: np.ndarray) -> float:
        """The restoring moment (N m) at the setpoint pose [x, z, θ]; recomputed only when its depth or pitch moves."""
        key = (float(setpoint[1]), float(setpoint[2]))
        if key != self._g_ref_key:
            self._g_ref = float(restoring_forces(self.vehicle, setpoint)[2])
            self._g_ref_key = key
        return self._g_ref
