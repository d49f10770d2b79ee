"""Wave feed-forward: the forecast's flow at the body → the feed-forward wrench τ_FF.

Paper Eq. 12 adds τ_FF = −τ̂_E to the cascaded PD's command, with τ̂_E the wave
load of Eq. 11 predicted from the forecast. Three laws, selected by
``WK_FF_MODE`` (docs/feedforward.md):

* **0, paper.** τ̂_E = F_h(0, flow): the plant's own load model
  (:func:`~bridge.models.vehicle.hydrodynamic_load`, nominal parameters) for
  the vehicle *holding station* (ν = 0) at the estimated pose, at the end of
  the control period. When a wave group carries the vehicle with the water
  this predicts the full relative flow: loads the vehicle does not feel, and
  in pitch a Munk moment (Z_ẇ − X_u̇) u_p w_p larger than the pitch authority.
* **1, robust.** The load at the filtered estimated velocity ν̄, its u and w
  bounded between 0 and the water's velocity (:meth:`WaveFeedForward._bounded`),
  as the relative-velocity model says it acts: P(ν̄) = F_h(ν̄, flow) + D(ν̄) ν̄, i.e.
  everything hydrodynamic except the vehicle's own still-water damping (which
  the feedback relies on). In pitch that is the strip moment plus the Munk
  moment of the *relative* velocity (Z_ẇ − X_u̇) ū_r w̄_r, which vanishes
  when the vehicle moves with the water. Then a per-axis authority limit
  ``WK_FF_LIM_*``·τ_max, so the feedback keeps headroom, and a consistency
  monitor: the load the EKF's motion reveals, d = M ν̂̇ + C_RB(ν̂) ν̂ + g(η̂)
  − τ_thr + D(ν̂) ν̂, is compared with P(ν̂) (both low-passed over
  ``WK_FF_MON_TC``); where they disagree by more than ``WK_FF_MON_THR``·τ_max
  the axis' weight fades (to ``WK_FF_W_MIN`` at twice the threshold) within a
  few ticks and recovers over ``WK_FF_MON_TC``. The firmware announces a fade
  by STATUSTEXT and logs the weights.
* **2, wave part at the estimated velocity.** τ̂_E = F_h(ν̄, flow) − F_h(ν̄, still):
  a measured alternative (it still tips the vehicle: the wave part of the Munk
  moment is −Munk(ν̄) when the vehicle moves with the water).

A forecast that evaluates to a non-finite load (e.g. at a diverged pose) is
no forecast: it is counted in :attr:`WaveFeedForward.faults` and the tick runs
without feed-forward.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from bridge.models.vehicle import (
    BodyFlow,
    VehicleParams,
    hydrodynamic_load_terms,
    restoring_terms,
)

from ..estimation.inertial_velocity import InertialVelocity
from ..hal.sensors import SensorFrame
from ..modes import MAV_SEVERITY
from ..numerics.floats import clip_float, ratio, sqrt
from ..params.table import ParameterTable

__all__ = ["FF_MODES", "FadeNotices", "FeedForwardOutput", "WaveFeedForward", "skill_weighted_flow"]

Vec3 = tuple[float, float, float]
"""Three per-axis floats [X (N), Z (N), M (N m)] (or [u, w, q]): the robust law's per-tick arithmetic runs on
floats, which cost less than three-element arrays for the same IEEE operations (the same bits)."""

FF_MODES = {0: "paper", 1: "robust", 2: "wave part at the estimated velocity"}
"""``WK_FF_MODE`` values and their names."""


@dataclass(frozen=True)
class FeedForwardOutput:
    """One tick's feed-forward, body frame [X (N), Z (N), M (N m)].

    ``tau_e_hat`` is the predicted load, ``tau_ff`` the wrench handed to the
    controller (before its ``WK_FF_GAIN``; None when inactive), ``active``
    whether there is one, ``weight`` the monitor's per-axis weight (ones
    unless the robust law faded an axis), ``skill`` the forecast's skill per
    axis (:meth:`WaveFeedForward._update_skill`; ones until measured).
    """

    tau_e_hat: np.ndarray
    tau_ff: np.ndarray | None
    active: bool
    weight: np.ndarray
    skill: np.ndarray = field(default_factory=lambda: np.ones(3))


def skill_weighted_flow(flow: BodyFlow, weight: np.ndarray) -> BodyFlow:
    """The forecast's flow at the strips as far as each axis has shown skill, weights [X, Z, M] in [0, 1].

    The surge kinematics (u, a_x) are scaled by w_X; the heave kinematics' mean over the body by w_Z and
    their variation along it, which makes the strips' pitch moment, by w_M. Weights of one return the flow
    itself; zeros, still water. For the estimator's prediction: where a forecast has no skill its loads
    are noise the filter would believe, so it predicts there as without a forecast.
    """
    if bool((weight >= 1.0).all()):
        return flow
    wx, wz, wm = (float(v) for v in weight)
    w_mean = flow.w @ flow.wts
    az_mean = flow.az @ flow.wts
    return BodyFlow(flow.xs, flow.wts, wx * flow.u, wz * w_mean[:, None] + wm * (flow.w - w_mean[:, None]),
                    wx * flow.ax, wz * az_mean[:, None] + wm * (flow.az - az_mean[:, None]))


def _own_damping(p: VehicleParams, u: float, w: float, q: float) -> tuple[float, float, float]:
    """D(ν) ν (N, N, N m): the vehicle's own still-water damping at body velocity ν = [u, w, q]."""
    return (p.X_u + p.X_uu * abs(u)) * u, (p.Z_w + p.Z_ww * abs(w)) * w, (p.M_q + p.M_qq * abs(q)) * q


def _revealed_load(p: VehicleParams, nu: Vec3, nu_dot: np.ndarray, eta: np.ndarray, tau_thr: Vec3) -> Vec3:
    """The load a motion reveals, in the robust law's terms: paper Eq. 2 solved for F_h, plus D(ν) ν,

    d = M ν̇ + C_RB(ν) ν + g(η) − τ_thr + D(ν) ν   (N, N, N m; body frame).

    Summed per axis in floats, term by term in that order (M ν̇ is numpy's product).
    """
    u, w, q = nu
    m = p.M_RB
    p_x, p_z = m[0, 0] * u + m[0, 2] * q, m[1, 1] * w + m[1, 2] * q
    c_rb = (p_z * q, -p_x * q, -p_z * u + p_x * w)
    g = restoring_terms(p, eta[1], eta[2])
    d = _own_damping(p, u, w, q)
    m_nu_dot = (p.M @ nu_dot).tolist()
    return (m_nu_dot[0] + c_rb[0] + g[0] - tau_thr[0] + d[0], m_nu_dot[1] + c_rb[1] + g[1] - tau_thr[1] + d[1],
            m_nu_dot[2] + c_rb[2] + g[2] - tau_thr[2] + d[2])


def _correlation(cov: float, var_a: float, var_b: float) -> float:
    """cov / √(var_a var_b) clipped to [−1, 1]; 1 where it is undefined (no variance yet)."""
    r = ratio(cov, sqrt(var_a * var_b))
    return min(max(r, -1.0), 1.0) if math.isfinite(r) else 1.0


def _axis_limits(p: ParameterTable) -> tuple[Vec3, Vec3]:
    """τ_max and the FF's authority limit ``WK_FF_LIM_*``·τ_max (N, N, N m), per axis."""
    tau_max, lim = p.axes("WK_TAU_MAX"), p.axes("WK_FF_LIM")
    return tau_max, (lim[0] * tau_max[0], lim[1] * tau_max[1], lim[2] * tau_max[2])


def _lowpass(prev: Vec3 | None, new: Vec3, h: float, tc: float) -> Vec3:
    """One step of a first-order low-pass filter (time constant tc s, step h s); tc = 0 passes through."""
    if prev is None or tc <= 0.0:
        return new
    a = 1.0 - math.exp(-h / tc)
    return prev[0] + a * (new[0] - prev[0]), prev[1] + a * (new[1] - prev[1]), prev[2] + a * (new[2] - prev[2])


def _finite(v: Vec3) -> bool:
    return math.isfinite(v[0]) and math.isfinite(v[1]) and math.isfinite(v[2])


class WaveFeedForward:
    """Turns the forecast's flow at the body's strips into the feed-forward wrench; counts faults.

    ``h`` is the control period (s). State carried between ticks (robust law):
    the filtered velocity ν̄, the previous estimate and thrust for the load
    observer, the monitor's filtered loads and its weights.
    """

    def __init__(self, vehicle: VehicleParams, params: ParameterTable, h: float = 0.05):
        self.vehicle = vehicle
        self.params = params
        self.h = h
        self.faults = 0                 # forecasts that evaluated to non-finite loads
        self.trust = 1.0                # the smallest weight, averaged over WK_FF_TRUST_TC
        self.distrusted = False         # the forecast is set aside: FF, preview and the EKF's wave model off
        self.set_aside = 0              # times the forecast was set aside (kept across resets)
        self._aside_left = 0.0          # s the forecast stays aside whatever the monitor says
        self._inertial = InertialVelocity(h, params["WK_FF_SKILL_VTC"], vehicle.g)   # the skill's velocity
        self.reset()

    def reset(self) -> None:
        """Forget the filters and the monitor (FF off, or a new arming): weights back to 1."""
        self._nu_f: Vec3 | None = None
        self._prev_nu: list[float] | None = None
        self._obs_f: Vec3 | None = None
        self._pred_f: Vec3 | None = None
        self._skill_obs_f: Vec3 | None = None    # the skill's loads, low-passed
        self._skill_pred_f: Vec3 | None = None
        self._prev_gyro: float | None = None
        self.weight = np.ones(3)
        self.skill = np.ones(3)
        self.skill_weight = np.ones(3)    # per axis, from the skill (WK_FF_SKILL_LO/HI)
        self._moments = np.zeros((5, 3))   # windowed means of o, p and (co)variances oo, pp, op of the loads
        self._skill_age = 0.0              # s of loads in the window

    # ------------------------------------------------------------------ models
    def _load(self, nu: Vec3, flow: BodyFlow, i: int, mode: int) -> Vec3:
        """The predicted load (N, N, N m) at body velocity ν in ``flow`` at its instant i, per law ``mode``."""
        u, w, q = nu
        p = self.vehicle
        f_h = hydrodynamic_load_terms(p, u, w, q, flow, i)
        # mode 2: the wave part, F_h(ν, flow) − F_h(ν, still); else F_h(ν, flow) + D(ν) ν: all but the
        # vehicle's own still-water damping
        d = hydrodynamic_load_terms(p, u, w, q, None) if mode == 2 else _own_damping(p, u, w, q)
        if mode == 2:
            return f_h[0] - d[0], f_h[1] - d[1], f_h[2] - d[2]
        return f_h[0] + d[0], f_h[1] + d[1], f_h[2] + d[2]

    @staticmethod
    def _bounded(nu: Vec3, flow: BodyFlow) -> Vec3:
        """ν with u and w each clamped between 0 (holding station) and the water's mean velocity at the body.

        A vehicle is pushed by the waves, never faster than the water: bounding the estimate this
        way keeps an estimator's transient error (e.g. gated position fixes in a saturating
        wave) from predicting relative flows beyond the paper law's, so the robust law's load
        lies between the station-holding load and none.
        """
        u_p, w_p = float(np.dot(flow.wts, flow.u[2])), float(np.dot(flow.wts, flow.w[2]))
        return (min(max(nu[0], min(0.0, u_p)), max(0.0, u_p)), min(max(nu[1], min(0.0, w_p)), max(0.0, w_p)), nu[2])

    def _observed_load(self, x_hat: np.ndarray, tau_thr: Vec3) -> Vec3 | None:
        """The load the estimate's motion reveals over the last period, in the terms of :meth:`_load` (mode 1).

        d = M ν̂̇ + C_RB(ν̂) ν̂ + g(η̂) − τ_thr + D(ν̂) ν̂ (Eq. 2 solved for F_h, plus D(ν̂) ν̂),
        ν̂̇ by differencing consecutive estimates and ν̂ their mean; ``tau_thr`` the mean thrust (N, N, N m).
        """
        now = x_hat[3:6].tolist()
        prev, self._prev_nu = self._prev_nu, now
        if prev is None:
            return None
        h = self.h
        nu = (0.5 * (now[0] + prev[0]), 0.5 * (now[1] + prev[1]), 0.5 * (now[2] + prev[2]))
        nu_dot = np.array([(now[0] - prev[0]) / h, (now[1] - prev[1]) / h, (now[2] - prev[2]) / h])
        return _revealed_load(self.vehicle, nu, nu_dot, x_hat, tau_thr)

    def _skill_loads(self, flow: BodyFlow, x_hat: np.ndarray, tau_thr: Vec3, frame: SensorFrame | None,
                     uw: np.ndarray | None) -> tuple[Vec3, Vec3] | None:
        """The observed and the predicted load for the skill, in the terms of :meth:`_load` (mode 1).

        As :meth:`_observed_load` and the monitor's prediction, but at a velocity the forecast has not
        touched: ν = [u, w] = ``uw`` of :class:`~firmware_py.estimation.inertial_velocity.InertialVelocity`
        (IMU and fixes) and the gyro's q, with ν̇ from the accelerometer, u̇ = f_x − q w − g sin θ,
        ẇ = f_z + q u + g cos θ (:func:`~firmware_py.hal.sensors.specific_force` inverted), and q̇ from
        consecutive gyro rates. The
        estimator predicts with the forecast, so its ν̂ follows a wrong forecast as well as a right one, and
        loads computed from it agree with any forecast. None without an IMU this tick.
        """
        if uw is None or frame is None or not math.isfinite(frame.pitch_rate):
            self._prev_gyro = None
            return None
        q = float(frame.pitch_rate)
        prev, self._prev_gyro = self._prev_gyro, q
        if prev is None:
            return None
        p = self.vehicle
        u, w = float(uw[0]), float(uw[1])
        th, g = float(frame.pitch), p.g
        nu_dot = np.array([frame.acc_x - q * w - g * math.sin(th), frame.acc_z + q * u + g * math.cos(th),
                           (q - prev) / self.h])
        return _revealed_load(p, (u, w, q), nu_dot, x_hat, tau_thr), self._load((u, w, q), flow, 0, 1)

    # ------------------------------------------------------------------ the tick
    def update(self, flow: BodyFlow | None, x_hat: np.ndarray, tau_thr: np.ndarray | None = None,
               frame: SensorFrame | None = None) -> FeedForwardOutput:
        """The feed-forward for this tick from ``flow`` (stages t, t + h/2, t + h) at the estimate x̂.

        ``flow`` None (no forecast, or FF not wanted this tick) gives an inactive output and
        resets the robust law's state. ``tau_thr`` is the mean thruster wrench over the last
        period (for the monitor; None skips it this tick), ``frame`` this tick's sensors (for the skill;
        None, or no accelerometer: the skill is not updated).
        """
        mode = int(self.params["WK_FF_MODE"])
        # the skill's velocity filter runs whether or not FF is on, so it is settled when FF starts
        measure_skill = mode == 1 and self.params["WK_FF_SKILL_TC"] > 0.0 and frame is not None
        uw = self._inertial.update(frame) if measure_skill and frame is not None else None
        if flow is None:
            self.reset()
            return FeedForwardOutput(np.zeros(3), None, False, self.weight.copy())
        tau_e_hat: Vec3
        if mode == 0:
            # The paper's law: the vehicle holding station (ν = 0) at the end of the period
            tau_e_hat = hydrodynamic_load_terms(self.vehicle, 0.0, 0.0, 0.0, flow, 2)
        else:
            self._nu_f = nu_f = _lowpass(self._nu_f, tuple(x_hat[3:6].tolist()), self.h, self.params["WK_FF_VEL_TC"])
            tau_e_hat = self._load(self._bounded(nu_f, flow) if mode == 1 else nu_f, flow, 2, mode)
            if mode == 1:
                self._monitor(flow, x_hat, tau_thr, frame if measure_skill else None, uw)
        if not _finite(tau_e_hat):
            self.faults += 1
            self.reset()
            return FeedForwardOutput(np.zeros(3), None, False, self.weight.copy())
        self.skill_weight = self._skill_weight()
        weight = self.weight * self.skill_weight if not self.distrusted else np.zeros(3)
        if mode == 1:
            lim, wt = self.params.derived(_axis_limits)[1], weight.tolist()
            tau_ff = np.array([wt[i] * clip_float(-tau_e_hat[i], -lim[i], lim[i]) for i in range(3)])
        else:
            tau_ff = -np.array(tau_e_hat)
        return FeedForwardOutput(np.array(tau_e_hat), tau_ff, True, weight, self.skill.copy())

    def _monitor(self, flow: BodyFlow, x_hat: np.ndarray, tau_thr: np.ndarray | None,
                 frame: SensorFrame | None = None, uw: np.ndarray | None = None) -> None:
        """Compare the predicted with the observed load over the last period; fade or restore the weights."""
        p = self.params
        thr = p["WK_FF_MON_THR"]
        if thr <= 0.0 or tau_thr is None:
            self.weight = np.ones(3)
            return
        tau = tuple(np.asarray(tau_thr, dtype=float).tolist())
        observed = self._observed_load(x_hat, tau)
        if observed is None or not _finite(observed):
            return
        # The prediction at the start of this period's end (stage 0 = now) and the estimate's velocity
        predicted = self._load(tuple(x_hat[3:6].tolist()), flow, 0, 1)
        tc, h = p["WK_FF_MON_TC"], self.h
        self._obs_f = obs_f = _lowpass(self._obs_f, observed, h, tc)
        self._pred_f = pred_f = _lowpass(self._pred_f, predicted, h, tc)
        if frame is not None:       # the skill is wanted (WK_FF_SKILL_TC > 0)
            loads = self._skill_loads(flow, x_hat, tau, frame, uw)
            if loads is not None and _finite(loads[0]) and _finite(loads[1]):
                self._skill_obs_f = _lowpass(self._skill_obs_f, loads[0], h, tc)
                self._skill_pred_f = _lowpass(self._skill_pred_f, loads[1], h, tc)
                self._update_skill(self._skill_obs_f, self._skill_pred_f)
        tau_max, w_min = p.derived(_axis_limits)[0], p["WK_FF_W_MIN"]
        # Fade within a few ticks, recover over WK_FF_MON_TC
        fade, recover = 1.0 - math.exp(-h / 0.1), 1.0 - math.exp(-h / tc)
        weight = self.weight.tolist()
        for i in range(3):
            disagreement = abs(obs_f[i] - pred_f[i]) / tau_max[i]
            target = clip_float(1.0 - (disagreement - thr) / thr, w_min, 1.0)
            weight[i] = weight[i] + (fade if target < weight[i] else recover) * (target - weight[i])
        self.weight = np.array(weight)
        self._update_trust()

    def _update_skill(self, observed: Vec3 | np.ndarray, predicted: Vec3 | np.ndarray) -> None:
        """The forecast's skill per axis: the correlation of the predicted with the observed load over an
        exponential window of ``WK_FF_SKILL_TC`` s (both loads low-passed over ``WK_FF_MON_TC``).

        A correlation, not a difference: it is blind to a steady offset (a current, a buoyancy error) and
        to a scale error, which the feedback and the authority limits absorb, and it does not grow with the
        sea as the monitor's disagreement does, so one threshold serves W1 to W3. The estimator's noise on
        the observed load is uncorrelated with the forecast: it lowers the correlation, by the same factor
        whatever the forecast. Ones until the window holds ``WK_FF_SKILL_TC`` s of loads.
        """
        tc = self.params["WK_FF_SKILL_TC"]
        if self._skill_age == 0.0:      # the means start at the first loads, not at zero
            self._moments[0], self._moments[1] = observed, predicted
        a = 1.0 - math.exp(-self.h / tc)
        b = 1.0 - a
        mo, mp, voo, vpp, vop = self._moments.tolist()     # per axis in floats: three short sums each
        obs, pred = list(observed), list(predicted)
        for k in range(3):
            d_o, d_p = obs[k] - mo[k], pred[k] - mp[k]
            mo[k] += a * d_o
            mp[k] += a * d_p
            # exponentially weighted (co)variances about the running means (West 1979): no E[x²] − E[x]²
            # cancellation under a large steady load
            voo[k] = b * (voo[k] + a * (d_o * d_o))
            vpp[k] = b * (vpp[k] + a * (d_p * d_p))
            vop[k] = b * (vop[k] + a * (d_o * d_p))
        self._moments[:] = (mo, mp, voo, vpp, vop)
        self._skill_age += self.h
        if self._skill_age < tc:
            return
        self.skill = np.array([_correlation(vop[k], voo[k], vpp[k]) for k in range(3)])

    def _skill_weight(self) -> np.ndarray:
        """Per axis: 0 at a skill of ``WK_FF_SKILL_LO`` or less, 1 at ``WK_FF_SKILL_HI`` or more, linear between."""
        lo, hi = self.params["WK_FF_SKILL_LO"], self.params["WK_FF_SKILL_HI"]
        if self.params["WK_FF_SKILL_TC"] <= 0.0 or hi <= lo:
            return np.ones(3)
        return np.array([clip_float((r - lo) / (hi - lo), 0.0, 1.0) for r in self.skill.tolist()])

    def _update_trust(self) -> None:
        """Set the forecast aside while the monitor has faded some axis for most of ``WK_FF_TRUST_TC``.

        A fade that lasts a wave group is the monitor at work; one that lasts many wave periods says the
        forecast and the measured motion disagree for good (a depth reading with the waves' dynamic
        pressure in it, docs/sea-errors.md). The three loads come from one flow at one pose, so then no
        axis is trusted, nor the preview or the estimator's wave model that use the same flow: the
        vehicle flies C-PD. With the forecast out of the loop the monitor may see no disagreement, so it
        stays aside for 4·``WK_FF_TRUST_TC``, doubling each time it is set aside again (at most 600 s),
        and then until the smallest weight's average is back above 0.75.
        """
        tc = self.params["WK_FF_TRUST_TC"]
        if tc <= 0.0:
            self.trust, self.distrusted = 1.0, False
            return
        self.trust += (1.0 - math.exp(-self.h / tc)) * (float(self.weight.min()) - self.trust)
        self._aside_left = max(0.0, self._aside_left - self.h)
        if not self.distrusted and self.trust < 0.5:
            self.distrusted = True
            self.set_aside += 1
            self._aside_left = min(600.0, 4.0 * tc * 2.0 ** (self.set_aside - 1))
        elif self.distrusted and self._aside_left <= 0.0 and self.trust > 0.75:
            self.distrusted = False


class FadeNotices:
    """What the pilot is told of the FF monitor (``say(severity, text)``: STATUSTEXT): an axis faded below half
    weight, all of them recovered; the forecast set aside (``WK_FF_TRUST_TC``) or trusted again."""

    def __init__(self, say: Callable[[int, str], None]):
        self.say = say
        self.faded = False
        self.aside = False

    def update(self, distrusted: bool, weight: np.ndarray) -> None:
        """This tick's monitor state: the forecast set aside, and the weights [X, Z, M]."""
        if distrusted != self.aside:
            self.aside = distrusted
            self.say(MAV_SEVERITY.WARNING if distrusted else MAV_SEVERITY.INFO,
                     "FF off: forecast set aside" if distrusted else "FF: forecast trusted again")
        faded = bool((weight < 0.5).any())
        if faded and not self.faded:
            axes = ",".join(a for a, w in zip("XZM", weight, strict=True) if w < 0.5)
            self.say(MAV_SEVERITY.WARNING, f"FF faded {axes}: forecast disagrees")
        elif not faded and self.faded and (weight > 0.9).all():
            self.say(MAV_SEVERITY.INFO, "FF restored")
        else:
            return
        self.faded = faded
