"""A sea from any direction: cos-2s spreading by single summation, and three-dimensional kinematics.

The long-crested functions of :mod:`bridge.models.waves` see the sea in the vertical plane y = 0.
A six-DoF body needs the flow as a three-vector at points off that plane. Here each component i
travels towards its own direction β_i (rad, measured in the horizontal plane from north +x
towards east +y; ``WaveComponents.direction``, None meaning β = 0 for all): *single summation*,
one direction per component, so the field stays spatially homogeneous (a double summation,
several directions per frequency, phase-locks them).

Frames and units: earth NED. Points are (x north, y east, s depth ≥ 0 below the still surface) in
m; velocities (m/s) and local accelerations ∂/∂t (m/s²) are NED three-vectors, w positive *down*.
With χ_i = k_i (x cos β_i + y sin β_i) − ω_i t + ε_i and z' = −s the elevation coordinate::

    (u, v) = Σ ω_i A_i cosh k_i(z' + d)/sinh k_i d · (cos β_i, sin β_i) · cos χ_i
    w↑     = Σ ω_i A_i sinh k_i(z' + d)/sinh k_i d · sin χ_i

plus, when ``second_order`` is set, each component's own Stokes self-interaction term along its
direction (the terms :mod:`bridge.models.waves` keeps; the directional cross-interaction of a
spread sea, Sharma & Dean's kernel, is not modelled). The depth attenuation and the series
constants are :mod:`bridge.models.waves`' own.

The spreading function (Longuet-Higgins et al. 1963; Mitsuyasu et al. 1975)::

    D(θ) = Γ(s + 1) / (2 √π Γ(s + ½)) · cos^{2s}((θ − θ_p)/2),   ∫ D dθ = 1 over a circle

has the first circular moment E[cos(θ − θ_p)] = s/(s + 1) and the circular spread
σ_θ = √(2 (1 − s/(s + 1))) = √(2/(s + 1)) rad.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from .waves import WaveComponents, _depth_factors_into

__all__ = ["DirectionalMoments", "cos2s_density", "cos2s_directions", "directional_moments", "kinematics_xyz",
           "spread_components"]


def cos2s_density(theta, s: float, theta_p: float = 0.0) -> np.ndarray:
    """D(θ) (1/rad) of the cos-2s spreading function about the mean direction θ_p (rad), θ in rad.

    The normalisation Γ(s + 1)/(2√π Γ(s + ½)) is taken through log-gamma, so large s cannot overflow.
    """
    if not s > 0:
        raise ValueError(f"the spreading exponent s must be positive, got {s}")
    log_norm = math.lgamma(s + 1.0) - math.lgamma(s + 0.5) - math.log(2.0 * math.sqrt(math.pi))
    return math.exp(log_norm) * np.abs(np.cos(0.5 * (np.asarray(theta, dtype=float) - theta_p))) ** (2.0 * s)


def cos2s_directions(s: float | None, mean: float, n: int, rng: np.random.Generator) -> np.ndarray:
    """n directions of travel β (rad) drawn from the cos-2s spreading function about ``mean`` (rad).

    Inverse-CDF sampling: the CDF of D(β) ∝ cos^{2s}((β − β_m)/2) on [β_m − π, β_m + π] tabulated by the
    trapezoidal rule on 4097 points and inverted by linear interpolation of n uniform draws of ``rng``.
    ``s`` None or infinite: a long-crested sea, every component at ``mean`` (no draws are taken).
    """
    if s is None or math.isinf(s):
        return np.full(n, float(mean))
    grid = np.linspace(-np.pi, np.pi, 4097)
    dens = np.cos(0.5 * grid) ** (2.0 * s)
    cdf = np.concatenate([[0.0], np.cumsum(0.5 * (dens[1:] + dens[:-1]) * np.diff(grid))])
    return mean + np.interp(rng.uniform(0.0, 1.0, n), cdf / cdf[-1], grid)


def spread_components(components: WaveComponents, s: float | None, theta_p: float,
                      rng: np.random.Generator) -> WaveComponents:
    """The components (frequencies already jittered in their bins, e.g. by ``sitl.sea.discretise_spectrum``)
    with one direction of travel each drawn from D(θ) about θ_p (rad): single summation.

    Amplitudes, frequencies and phases are kept, so the frequency spectrum and Hs are the drawn ones;
    ``s`` None or infinite gives a long-crested sea travelling towards θ_p.
    """
    return replace(components, direction=cos2s_directions(s, theta_p, components.n, rng))


@dataclass(frozen=True)
class DirectionalMoments:
    """The energy-weighted circular statistics of a sea's directions (what a directional buoy reports).

    ``mean`` θ̄ (rad), the direction of Σ w_i (cos β_i, sin β_i) with w_i = A_i²/ΣA²; ``r1`` the first
    circular moment |Σ w_i e^{iβ_i}| (s/(s + 1) for a cos-2s sea); ``spread`` √(2 (1 − r1)) (rad,
    √(2/(s + 1))); ``n_eff`` = 1/Σ w_i², the number of equally energetic components the same
    statistics would have (their sampling error goes as 1/√n_eff).
    """

    mean: float
    r1: float
    spread: float
    n_eff: float


def directional_moments(c: WaveComponents) -> DirectionalMoments:
    """The realised directional spread of the components: :class:`DirectionalMoments` (long-crested: r1 = 1)."""
    w = c.amplitude**2 / np.sum(c.amplitude**2)
    beta = np.zeros(c.n) if c.direction is None else np.asarray(c.direction, dtype=float)
    z = complex(w @ np.cos(beta), w @ np.sin(beta))
    r1 = min(abs(z), 1.0)
    return DirectionalMoments(math.atan2(z.imag, z.real), r1, math.sqrt(2.0 * (1.0 - r1)), float(1.0 / (w @ w)))


def _points(x, y, depth) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    arrays = np.broadcast_arrays(*(np.atleast_1d(np.asarray(v, dtype=float)) for v in (x, y, depth)))
    return arrays[0].ravel(), arrays[1].ravel(), arrays[2].ravel()


def _order_trig(angle: np.ndarray, orders: int) -> tuple[np.ndarray, np.ndarray]:
    """cos and sin of n·angle for n = 1..orders, laid out (rows, orders, N); order 2 by the double angle."""
    c, s = np.empty((*angle.shape[:-1], orders, angle.shape[-1])), np.empty((*angle.shape[:-1], orders,
                                                                              angle.shape[-1]))
    np.cos(angle, out=c[..., 0, :])
    np.sin(angle, out=s[..., 0, :])
    if orders == 2:
        c[..., 1, :] = c[..., 0, :] ** 2 - s[..., 0, :] ** 2
        s[..., 1, :] = 2.0 * c[..., 0, :] * s[..., 0, :]
    return c, s


def kinematics_xyz(c: WaveComponents, x, y, depth, t) -> tuple[np.ndarray, np.ndarray]:
    """Fluid velocity and local acceleration three-vectors (NED) at P points and T times.

    ``x``, ``y`` (m, north and east) and ``depth`` (m, ≥ 0 down; the caller clips it to [0, d])
    broadcast to P points; ``t`` (s) holds T times. Returns (velocity, acceleration), each of
    shape (T, P, 3), components (north, east, down) in m/s and m/s².

    Vectorised over points, times and components: the phase separates, χ = a − b with
    a = k (x cos β + y sin β) + ε per point and b = ω t per time, so every sum is two matrix
    products of the per-point weights with cos b and sin b (as
    :func:`~bridge.models.waves.particle_kinematics_grid`).
    """
    x, y, depth = _points(x, y, depth)
    t = np.atleast_1d(np.asarray(t, dtype=float)).ravel()
    beta = np.zeros(c.n) if c.direction is None else np.asarray(c.direction, dtype=float)
    kx = c.kx
    ky = c.k * np.sin(beta)
    orders = 2 if c.second_order else 1
    P, T, N = x.size, t.size, c.n
    a = np.multiply.outer(x, kx) + np.multiply.outer(y, ky) + c.phase       # (P, N)
    ca, sa = _order_trig(a, orders)                                          # (P, orders, N)
    cb, sb = _order_trig(np.multiply.outer(t, c.omega), orders)             # (T, orders, N)
    coef, rate = c._series_constants                                         # (orders, N)
    ch, sh = np.empty((P, orders, N)), np.empty((P, orders, N))
    _depth_factors_into(c, depth, ch, sh)
    H, V = ch * coef, sh * coef               # horizontal speed and upward speed amplitudes per point
    cosb, sinb = np.cos(beta), np.sin(beta)
    # weights: u, v ~ cos χ; w↑ ~ sin χ; u̇, v̇ ~ sin χ; ẇ↑ ~ −cos χ
    W = np.stack([H * cosb, H * sinb, V, H * cosb * rate, H * sinb * rate, V * rate])   # (6, P, orders, N)
    Wc = (W * ca).reshape(6 * P, orders * N)
    Ws = (W * sa).reshape(6 * P, orders * N)
    cbt, sbt = cb.reshape(T, orders * N).T, sb.reshape(T, orders * N).T
    cos_sum = (Wc @ cbt + Ws @ sbt).reshape(6, P, T)    # Σ W cos(a − b)
    sin_sum = (Ws @ cbt - Wc @ sbt).reshape(6, P, T)    # Σ W sin(a − b)
    vel = np.stack([cos_sum[0], cos_sum[1], -sin_sum[2]], axis=-1)          # (P, T, 3), w down
    acc = np.stack([sin_sum[3], sin_sum[4], cos_sum[5]], axis=-1)            # ẇ down = +Σ V ω cos χ
    return vel.transpose(1, 0, 2), acc.transpose(1, 0, 2)
