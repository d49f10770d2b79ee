"""Saturation preview: pre-position the station target ahead of a wave load the thrusters cannot hold.

The feed-forward cancels the predicted wave load only up to the thrusters' authority
τ_max. When a wave group's load exceeds it for seconds (in W3 at 5 m depth, 190 N of
heave load against 140 N), the vehicle is carried off station whatever the
controller does; how far depends on where the group finds it. Feedback alone is
sometimes lucky (the preceding trough has lifted it); a vehicle that the FF holds
exactly on station meets the crest with no margin at all.

The forecast says such a group is coming. Every ``WK_PRV_PERIOD`` s this module
simulates the next ``WK_PRV_HORIZON`` s of surge and heave for a handful of constant
target shifts s (body frame, within ±``WK_PRV_MAX_*``), starting from the estimate:

    (M_RB + M_A) ν̇ = F_h(ν, flow(t)) + τ,   τ = τ_max sat(K_v (ν_d − ν) + τ_FF / τ_max),
    ν_d = sat(K_p (s(t) − e) − K_d ν, ν_max),   τ_FF = −sat(F_h(ν, flow) + D(ν) ν, lim τ_max)

with the firmware's own load model F_h (:func:`~bridge.models.vehicle.hydrodynamic_load_at`),
C-PD gains and robust FF law, and s(t) approaching the candidate at ``WK_PRV_RATE``. When
the predicted largest excursion with no shift exceeds ``WK_PRV_THR``, the shift that
minimises the largest excursion becomes the target offset (slew-limited at
``WK_PRV_RATE``), and stays chosen until that prediction falls below half the
threshold; otherwise the offset returns to zero. Unsaturated, the FF holds the
vehicle near the target, the predicted excursion is small and the preview never acts,
so it costs nothing in moderate seas. It is a reference governor on the forecast: it
changes where the controller aims, never the control law.

Simplifications (docs/feedforward.md): pitch is held (q = 0, θ = θ̂), the flow is taken
at the current pose over the whole horizon, and surge and heave are simulated as the
load model couples them (through the strips only). Errors are the vehicle's body-frame
offset from the mission target; the chosen shift is applied to the NED target as it is
(the pitch is a few degrees when it matters, and rotating by θ̂ would make the target
jitter with the pitch estimate).
"""
from __future__ import annotations

import math

import numpy as np

from bridge.models import kernels
from bridge.models.vehicle import VehicleParams, WaveComponents, body_flow, hydrodynamic_load_at, ned_to_body

from ..numerics.floats import clip_float
from ..params.table import ParameterTable

__all__ = ["SaturationPreview", "preview_excursions", "preview_gains"]

N_CANDIDATES = 7
"""Target shifts tried per axis: evenly spaced in [−WK_PRV_MAX, WK_PRV_MAX] (odd, so 0 is one)."""


def preview_gains(params: ParameterTable) -> np.ndarray:
    """(6, 2): K_p, K_d, K_v, ν_max, τ_max and the FF limit (N) for the [X, Z] axes, from the table."""
    tau_max = np.array(params.axes("WK_TAU_MAX"))[:2]
    rows = [np.array(params.axes(name))[:2] for name in ("WK_PD_KP", "WK_PD_KD", "WK_VEL_KP", "WK_VEL_MAX")]
    return np.array([*rows, tau_max, np.array(params.axes("WK_FF_LIM"))[:2] * tau_max])


def preview_excursions(vehicle: VehicleParams, params: ParameterTable, components: WaveComponents,
                       eta: np.ndarray, nu: np.ndarray, error0: np.ndarray, shift0: np.ndarray,
                       candidates: np.ndarray, t: float, strips: tuple[np.ndarray, np.ndarray],
                       gains: np.ndarray | None = None) -> np.ndarray:
    """The largest |offset from the mission target| (m) over the horizon, per candidate shift and axis.

    ``eta``, ``nu``: the estimated pose [x, z, θ] and velocity [u, w, q]; ``error0`` (2,) the
    body-frame offset [x, z] (m) of the vehicle from the mission target now; ``shift0`` (2,) the
    target shift applied now; ``candidates`` (C, 2) constant shifts to try (m, body frame);
    ``gains``: :func:`preview_gains` of ``params`` when the caller keeps them (else read here).
    Returns (C, 2). Pure: the firmware's model, gains and limits from ``params``; the compiled
    kernel (:func:`~bridge.models.kernels.preview_worst_arr`) when enabled, else this reference.
    """
    p = params
    dt = p["WK_PRV_DT"]
    n = max(1, int(round(p["WK_PRV_HORIZON"] / dt)))
    flow = body_flow(components, eta, t + dt * np.arange(n), strips)
    if gains is None:
        gains = preview_gains(p)
    step = p["WK_PRV_RATE"] * dt
    cands = np.asarray(candidates, dtype=float)
    e0, v0, s0 = (np.asarray(a, dtype=float)[:2] for a in (error0, nu, shift0))
    if kernels.ENABLED:
        return kernels.preview_worst_arr(vehicle.kernel_params, gains, flow.xs, flow.wts, flow.u, flow.w,
                                         flow.ax, flow.az, cands, e0, v0, s0, dt, step)
    kp, kd, kv, vmax, tau_max, lim = gains
    mass = np.array([vehicle.M[0, 0], vehicle.M[1, 1]])
    lin, quad = np.array([vehicle.X_u, vehicle.Z_w]), np.array([vehicle.X_uu, vehicle.Z_ww])
    e, v, s = (np.tile(a, (len(cands), 1)) for a in (e0, v0, s0))
    worst = np.abs(e)
    for j in range(n):
        f_h = np.array([hydrodynamic_load_at(vehicle, ui, wi, 0.0, flow, j)[:2] for ui, wi in v])
        tau_ff = -np.clip(f_h + (lin + quad * np.abs(v)) * v, -lim, lim)
        v_d = np.clip(kp * (s - e) - kd * v, -vmax, vmax)
        v = v + dt * (f_h + tau_max * np.clip(kv * (v_d - v) + tau_ff / tau_max, -1.0, 1.0)) / mass
        e = e + dt * v
        s = s + np.clip(cands - s, -step, step)
        worst = np.maximum(worst, np.abs(e))
    return worst


def _preview_tables(p: ParameterTable) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The candidate shifts (C, 2) m, their tie-break penalty 1e-3 |s| and :func:`preview_gains`
    (read through :meth:`ParameterTable.derived <firmware_py.params.table.ParameterTable.derived>`)."""
    s_max = np.array([p["WK_PRV_MAX_X"], p["WK_PRV_MAX_Z"]])
    cands = np.linspace(-1.0, 1.0, N_CANDIDATES)[:, None] * s_max
    return cands, 1e-3 * np.abs(cands), preview_gains(p)


class SaturationPreview:
    """The target offset (NED, m) that keeps a forecast saturating wave group's excursion smallest.

    ``h`` the control period (s), ``strips`` the firmware's strip nodes. State: the offset now
    ([x, z] m: chosen in the body frame, applied to the NED target as is), the offset it is
    slewing to, and when the preview next runs.
    """

    def __init__(self, vehicle: VehicleParams, params: ParameterTable, strips: tuple[np.ndarray, np.ndarray],
                 h: float = 0.05):
        self.vehicle = vehicle
        self.params = params
        self.strips = strips
        self.h = h
        self.reset()

    def reset(self) -> None:
        """No offset, and preview at the next chance (FF off, or a new arming)."""
        self.shift = np.zeros(2)
        self._goal = np.zeros(2)
        self._next_t = -math.inf

    def update(self, components: WaveComponents | None, x_hat: np.ndarray, setpoint: np.ndarray,
               t: float, trusted: bool = True) -> np.ndarray:
        """The offset [x, z, θ] (NED, m, m, rad) to add to the target this tick; zeros when off.

        ``trusted`` False (the FF monitor has faded the forecast) slews any shift back to zero: the
        preview's model is the FF's, and a forecast that disagrees with the motion cannot place the target.
        """
        p = self.params
        if components is None or not p["WK_PRV_ENABLE"]:
            self.reset()
            return np.zeros(3)
        if not trusted:
            self._goal = np.zeros(2)
        elif t >= self._next_t:
            self._next_t = t + p["WK_PRV_PERIOD"]
            self._goal = self._choose(components, x_hat, setpoint, t)
        # The slew in floats (np.clip on two elements, without its overhead; the bounds are never zero)
        step = p["WK_PRV_RATE"] * self.h
        (sx, sz), (gx, gz) = self.shift.tolist(), self._goal.tolist()
        sx, sz = sx + clip_float(gx - sx, -step, step), sz + clip_float(gz - sz, -step, step)
        self.shift = np.array([sx, sz])
        return np.array([sx, sz, 0.0])

    def _choose(self, components: WaveComponents, x_hat: np.ndarray, setpoint: np.ndarray, t: float) -> np.ndarray:
        """The candidate shift per axis with the smallest predicted largest excursion (0 unless it matters)."""
        p = self.params
        cands, penalty, gains = p.derived(_preview_tables)
        th = float(x_hat[2])
        error0 = np.array(ned_to_body(th, float(x_hat[0] - setpoint[0]), float(x_hat[1] - setpoint[1])))
        worst = preview_excursions(self.vehicle, p, components, np.asarray(x_hat[:3]), np.asarray(x_hat[3:]),
                                   error0, self.shift, cands, t, self.strips, gains)
        if not np.isfinite(worst).all():
            return np.zeros(2)
        # Per axis in floats (7 candidates, 2 axes): argmin(worst + 1e-3 |cands|), the first of equals
        # (ties: the smaller shift); then the hysteresis. Once shifted, hold on until the unshifted
        # prediction falls below half the threshold: the model under-predicts a saturated excursion (it
        # holds pitch and the pose's flow), and releasing as soon as the pre-positioned vehicle looks
        # safe would drop the shift just before the group arrives.
        w, c, pen, g_prev = worst.tolist(), cands.tolist(), penalty.tolist(), self._goal.tolist()
        zero = N_CANDIDATES // 2
        goal = []
        for a in (0, 1):
            score = [w[k][a] + pen[k][a] for k in range(N_CANDIDATES)]
            best = min(range(N_CANDIDATES), key=score.__getitem__)
            thr = (0.5 if g_prev[a] != 0.0 else 1.0) * p["WK_PRV_THR"]
            keep = w[zero][a] > thr and w[best][a] < w[zero][a] - 0.02
            goal.append(c[best][a] if keep else 0.0)
        return np.array(goal)

