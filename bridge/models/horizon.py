"""The vehicle model along a control horizon: a rollout and its linearisation (for a preview MPC).

A horizon is N steps of lengths Δ_k (s). Over step k the thrusters' wrench moves from τ_k to the
demand v_k as first-order motors do under the held command that reaches v_k at the step's end,

    τ(s) = v_{k−1} + α(s) (v_k − v_{k−1}),   α(s) = (1 − e^{−s/t_m}) / (1 − e^{−Δ_k/t_m}),

with τ_0 = v_{−1} the wrench the motors give now; the command itself is
c_k = (v_k − e_k v_{k−1}) / (1 − e_k), e_k = e^{−Δ_k/t_m}, what the mixer's lag compensation sends
(:mod:`firmware_py.motors.mixer`). The body follows paper Eq. 2 with the relative-velocity wave loads
(:func:`~bridge.models.vehicle.state_rates`) in the flow sampled at each step's RK4 stage times, plus a
constant disturbance wrench d (N, N, N m), integrated by one RK4 step per horizon step.

:func:`linearise_horizon` returns the states x_0..x_N of that rollout and, per step, the Jacobians of
x_{k+1} = F_k(x_k, v_{k−1}, v_k): A_k = ∂F_k/∂x_k, B_k = ∂F_k/∂v_k, E_k = ∂F_k/∂v_{k−1}. With the kernels
enabled, exactly, by the chain rule through the RK4 stages (:func:`~bridge.models.horizon_kernels.horizon_lin_arr`);
else the reference below, by forward differences (state step 1e-6·max(1, |x_j|), input step
1e-6·max(1, |v_j|) N), which agrees to the differences' truncation (≈ 1e-6 of the Jacobians' scale). The
rollout is the same arithmetic on both paths.
"""
from __future__ import annotations

import numpy as np

from . import horizon_kernels, kernels
from .vehicle import BodyFlow, VehicleParams, body_flow, rk4_step
from .waves import WaveComponents

__all__ = ["OffsetPhases", "horizon_flow", "horizon_grid", "lag_profile", "linearise_horizon", "stage_times",
           "warm_up"]

warm_up = horizon_kernels.warm_up


def lag_profile(dt: np.ndarray, t_m: float) -> tuple[np.ndarray, np.ndarray]:
    """(α(Δ_k/2), e_k) per step: the share of the step's thrust change reached at its middle, and e^{−Δ_k/t_m}."""
    dt = np.asarray(dt, dtype=float)
    e = np.exp(-dt / t_m)
    return (1.0 - np.exp(-0.5 * dt / t_m)) / (1.0 - e), e


def _stages(v_prev, v, a_mid, d) -> np.ndarray:
    """The wrench at a step's three RK4 stage times (start, middle, end), plus the disturbance: (3, 3)."""
    return np.array([v_prev + d, v_prev + a_mid * (v - v_prev) + d, v + d])


def _step(p: VehicleParams, x, h, v_prev, v, a_mid, d, flow: BodyFlow | None):
    return rk4_step(p, x, h, _stages(v_prev, v, a_mid, d), flow)


def linearise_horizon(p: VehicleParams, x0: np.ndarray, tau0: np.ndarray, V: np.ndarray, dt: np.ndarray,
                      a_mid: np.ndarray, d: np.ndarray, flow: BodyFlow | None):
    """Rollout (N+1, 6) and Jacobians A (N, 6, 6), B (N, 6, 3), E (N, 6, 3) of the horizon (module docstring).

    ``x0`` [x, z, θ, u, w, q]; ``tau0`` (3,) the wrench now; ``V`` (N, 3) the demands; ``dt`` (N,) s;
    ``a_mid`` (N,) of :func:`lag_profile`; ``d`` (3,) the disturbance; ``flow`` the flow at the strips with
    3N instants, step k's stages at rows 3k, 3k + 1, 3k + 2 (None: still water).
    """
    x0, tau0, V = (np.ascontiguousarray(a, dtype=float) for a in (x0, tau0, V))
    dt, a_mid, d = (np.ascontiguousarray(a, dtype=float) for a in (dt, a_mid, d))
    if kernels.ENABLED:
        if flow is None:
            z = np.zeros((3 * V.shape[0], 1))
            return horizon_kernels.horizon_lin_arr(p.kernel_params, x0, tau0, V, dt, a_mid, d, False, np.zeros(1),
                                                   np.ones(1), z, z, z, z)
        return horizon_kernels.horizon_lin_arr(p.kernel_params, x0, tau0, V, dt, a_mid, d, True, flow.xs, flow.wts,
                                               flow.u, flow.w, flow.ax, flow.az)
    n = V.shape[0]
    X = np.empty((n + 1, 6))
    A, B, E = np.empty((n, 6, 6)), np.empty((n, 6, 3)), np.empty((n, 6, 3))
    X[0] = x0
    for k in range(n):
        fk = None if flow is None else BodyFlow(flow.xs, flow.wts, flow.u[3 * k:3 * k + 3], flow.w[3 * k:3 * k + 3],
                                                flow.ax[3 * k:3 * k + 3], flow.az[3 * k:3 * k + 3])
        v_prev = tau0 if k == 0 else V[k - 1]
        x = X[k]
        f0 = _step(p, x, dt[k], v_prev, V[k], a_mid[k], d, fk)
        X[k + 1] = f0
        for j in range(6):
            h = 1e-6 * max(1.0, abs(x[j]))
            xp = x.copy()
            xp[j] += h
            A[k, :, j] = (_step(p, xp, dt[k], v_prev, V[k], a_mid[k], d, fk) - f0) / h
        for j in range(3):
            h = 1e-6 * max(1.0, abs(V[k, j]))
            vp = V[k].copy()
            vp[j] += h
            B[k, :, j] = (_step(p, x, dt[k], v_prev, vp, a_mid[k], d, fk) - f0) / h
            h = 1e-6 * max(1.0, abs(v_prev[j]))
            vq = v_prev.copy()
            vq[j] += h
            E[k, :, j] = (_step(p, x, dt[k], vq, V[k], a_mid[k], d, fk) - f0) / h
    return X, A, B, E


def horizon_grid(h: float, step: float, n: int) -> np.ndarray:
    """Step lengths (s) of an n-step horizon: the control period h first (the command being sent), then ``step``."""
    return np.array([h] + [step] * (n - 1), dtype=float) if n > 0 else np.zeros(0)


def stage_times(dt: np.ndarray, exact_steps: int | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The instants (s from now) at which a horizon's flow is evaluated, and how its 3N RK4 stages take them.

    Every step's start and end (a step's end is the next one's start) and, for the first ``exact_steps``
    steps (default: all), its middle: 2N + 1 instants at most. Step k's stages (rows 3k, 3k + 1, 3k + 2)
    are the mean of the instants ``a`` and ``b`` (both (3N,)): the same instant where it is evaluated, the
    step's two ends for a middle that is not. A step of 0.1 s against waves of 4 s or more puts that
    linear interpolation within 0.1 % of the flow (the curvature term Δ²ω²/8).
    """
    dt = np.asarray(dt, dtype=float)
    n = dt.size
    exact = n if exact_steps is None else min(n, max(0, int(exact_steps)))
    knots = np.concatenate([[0.0], np.cumsum(dt)])
    offsets = np.concatenate([knots, knots[:exact] + 0.5 * dt[:exact]])
    start, end = np.arange(n), np.arange(1, n + 1)
    mid_a = np.where(np.arange(n) < exact, n + 1 + np.arange(n), start)
    mid_b = np.where(np.arange(n) < exact, n + 1 + np.arange(n), end)
    a = np.stack([start, mid_a, end], axis=1).ravel()
    b = np.stack([start, mid_b, end], axis=1).ravel()
    return offsets, a, b


class OffsetPhases:
    """cos(ω o_i), sin(ω o_i) (T, N) of one set of wave components at a horizon's instants o_i (s after its start):
    built once per forecast and horizon, so that each tick's flow along the horizon (:func:`horizon_flow`) takes
    N sines and cosines for its start time instead of T·N."""

    def __init__(self, waves: WaveComponents, offsets: np.ndarray):
        self.waves, self.offsets = waves, np.asarray(offsets, dtype=float)
        b = np.multiply.outer(self.offsets, waves.omega)
        self.cos, self.sin = np.cos(b), np.sin(b)

    def fits(self, waves: WaveComponents, offsets: np.ndarray) -> bool:
        """Built for these components and instants?"""
        return waves is self.waves and np.array_equal(offsets, self.offsets)


def horizon_flow(phases: OffsetPhases, eta, t0: float, strips: tuple[np.ndarray, np.ndarray]) -> BodyFlow:
    """:func:`~bridge.models.vehicle.body_flow` of ``phases.waves`` at pose η at the instants t0 + o_i (s), no
    current: the time phases by angle addition from ``phases`` (equal to the direct ones to rounding)."""
    waves = phases.waves
    if not kernels.ENABLED:
        return body_flow(waves, eta, t0 + phases.offsets, strips)
    xs, wts = strips
    x_e2d, _, inv, inv4 = waves._depth_constants
    coef, rate = waves._series_constants
    cb, sb = kernels.shifted_time_phases(waves.omega, float(t0), phases.cos, phases.sin, coef.shape[0])
    out = kernels.body_flow_at_phases(waves.k, waves.phase, coef, rate, x_e2d, inv, inv4, waves.water_depth,
                                      float(eta[0]), float(eta[1]), float(eta[2]), xs, cb, sb, waves.kx,
                                      waves.in_plane_or_ones)
    return BodyFlow(xs, wts, out[0], out[1], out[2], out[3])
