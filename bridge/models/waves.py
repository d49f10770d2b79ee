"""Wave kinematics of a sum of regular components: linear + 2nd-order Stokes, finite depth.

One module serves both sides (docs/architecture.md):
the SITL sea evaluates it with the true components, the firmware's feed-forward
with the forecast's components.

Conventions
-----------
* Waves travel in +x (earth frame, NED north). Phase θ_i = k_i x − ω_i t + ε_i.
* Vertical position is given as *depth* s ≥ 0 below the still surface (NED z);
  the elevation coordinate of docs/reference.md §2 is z' = −s.
* Velocities and accelerations are returned in NED: u along +x, w positive *down*.
* Accelerations are local (∂/∂t at a fixed point), as used in the Morison-type
  load of the paper's Eq. 11.

Formulas (Dean & Dalrymple; paper Eqs. 5, 9, 10 with H = 2A, g H/(2c) = A ω
cosh(kd)/sinh(kd) through the dispersion relation)::

    ζ   = Σ A cos θ + Σ (k A²/4) cosh kd (2 + cosh 2kd)/sinh³ kd · cos 2θ
    u   = Σ A ω cosh k(d−s)/sinh kd · cos θ + Σ (3/4) ω k A² cosh 2k(d−s)/sinh⁴ kd · cos 2θ
    w↑  = Σ A ω sinh k(d−s)/sinh kd · sin θ + Σ (3/4) ω k A² sinh 2k(d−s)/sinh⁴ kd · sin 2θ

The paper prints the 2nd-order elevation as (k A²/2) cos 2θ, the deep-water
limit of the finite-depth Stokes term used here. Hyperbolic ratios are computed
in exponential form so that large k·d neither overflows nor loses precision.
Components are summed with array operations; nothing loops over components.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

__all__ = [
    "G",
    "WaveComponents",
    "elevation",
    "elevation_grid",
    "elevation_xy",
    "particle_acceleration",
    "particle_kinematics",
    "particle_kinematics_grid",
    "particle_velocity",
    "pressure_head",
    "wavenumber",
]

G = 9.81
"""Gravitational acceleration (m/s²), as in the paper."""


def wavenumber(omega: np.ndarray, depth: float, g: float = G) -> np.ndarray:
    """Solve the finite-depth dispersion relation ω² = g k tanh(k d) for k (rad/m).

    Vectorised over ``omega`` (rad/s). Starts from Eckart's approximation and
    polishes with Newton's method to machine precision.
    """
    omega = np.asarray(omega, dtype=float)
    if depth <= 0 or not np.isfinite(depth):
        raise ValueError(f"water depth must be positive and finite, got {depth!r}")
    if np.any(omega <= 0) or not np.all(np.isfinite(omega)):
        raise ValueError("angular frequencies must be positive and finite")
    k0 = omega**2 / g
    k = k0 / np.sqrt(np.tanh(k0 * depth))  # Eckart (1952), within ~5 %
    for _ in range(50):
        th = np.tanh(k * depth)
        f = g * k * th - omega**2
        df = g * th + g * k * depth * (1.0 - th**2)
        step = f / df
        k = k - step
        if np.all(np.abs(step) <= 1e-14 * k):
            break
    return k


@dataclass(frozen=True)
class WaveComponents:
    """A sea as N regular components travelling in +x.

    amplitude: A_i (m); omega: ω_i (rad/s); k: wavenumber k_i (rad/m) on the
    finite-depth dispersion relation; phase: ε_i (rad) at t = 0, x = 0;
    water_depth: d (m); second_order: include the Stokes 2nd-order terms.
    direction: None for a long-crested sea travelling in +x, or β_i (rad), each component's direction
    of travel from +x in the horizontal plane (a short-crested sea). The plane y = 0 (the x–z plane of
    the vehicle and the buoy) then sees the phase θ = k cos β x − ω t + ε, the vertical kinematics in
    full and the in-plane part cos β of each horizontal velocity and acceleration; the cross-plane part
    (sin β) is left out.
    """

    amplitude: np.ndarray
    omega: np.ndarray
    k: np.ndarray
    phase: np.ndarray
    water_depth: float
    second_order: bool = True
    direction: np.ndarray | None = None

    def __post_init__(self) -> None:
        n = np.shape(self.amplitude)
        for name in ("omega", "k", "phase") + (("direction",) if self.direction is not None else ()):
            if np.shape(getattr(self, name)) != n:
                raise ValueError(f"WaveComponents.{name} has shape {np.shape(getattr(self, name))}, expected {n}")

    @cached_property
    def kx(self) -> np.ndarray:
        """The wavenumber along x, k cos β (rad/m): k itself for a long-crested sea."""
        return self.k if self.direction is None else self.k * np.cos(self.direction)

    @cached_property
    def in_plane(self) -> np.ndarray | None:
        """cos β per component, the in-plane share of the horizontal kinematics; None when long-crested."""
        return None if self.direction is None else np.cos(self.direction)

    @cached_property
    def in_plane_or_ones(self) -> np.ndarray:
        """:attr:`in_plane`, or ones (× 1.0 is exact: the compiled kernel's long-crested input)."""
        return np.ones(self.n) if self.direction is None else np.cos(self.direction)

    @classmethod
    def from_spectrum_lines(cls, amplitude, omega, phase, water_depth: float,
                            second_order: bool = True, g: float = G) -> WaveComponents:
        """Build components, solving the dispersion relation for k."""
        omega = np.asarray(omega, dtype=float)
        return cls(np.asarray(amplitude, dtype=float), omega, wavenumber(omega, water_depth, g),
                   np.asarray(phase, dtype=float), float(water_depth), second_order)

    @cached_property
    def _depth_constants(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """e^{−2kd}, e^{−2kd}, 1/(1 − e^{−2kd}) and 8/(1 − e^{−2kd})⁴, per component."""
        x = np.exp(-2.0 * self.k * self.water_depth)
        inv = 1.0 / (1.0 - x)
        return x, x, inv, 8.0 * inv**4

    @cached_property
    def _series_constants(self) -> tuple[np.ndarray, np.ndarray]:
        """Velocity amplitudes per order [A ω, (3/4) ω k A²] and their time-derivative factors [ω, 2ω]."""
        coef = np.stack([self.amplitude * self.omega, 0.75 * self.omega * self.k * self.amplitude**2])
        rate = np.stack([self.omega, 2.0 * self.omega])
        return (coef, rate) if self.second_order else (coef[:1], rate[:1])

    @property
    def n(self) -> int:
        return int(np.size(self.amplitude))

    def m0(self) -> float:
        """Zeroth spectral moment of the linear sea, Σ A²/2 (m²)."""
        return float(0.5 * np.sum(self.amplitude**2))

    def hs(self) -> float:
        """Significant wave height 4√m0 (m) of the linear components."""
        return 4.0 * np.sqrt(self.m0())


def _phase(c: WaveComponents, x, t) -> np.ndarray:
    x = np.asarray(x, dtype=float)[..., None]
    t = np.asarray(t, dtype=float)[..., None]
    return c.kx * x - c.omega * t + c.phase


def _depth_factors_into(c: WaveComponents, s, ch: np.ndarray, sh: np.ndarray) -> None:
    """Fill ch[o] and sh[o] (o = order) with the depth attenuation of each component at depth s.

    Order 1: cosh k(d−s)/sinh kd and sinh k(d−s)/sinh kd.
    Order 2: cosh 2k(d−s)/sinh⁴ kd and sinh 2k(d−s)/sinh⁴ kd, i.e.
    8 (e^{−2kd−2ks} ± e^{−6kd+2ks}) / (1 − e^{−2kd})⁴.
    ``ch`` and ``sh`` have shape shape(s) + (orders, N).
    """
    x, e2d, inv, inv4 = c._depth_constants
    a = np.exp(np.multiply.outer(-np.asarray(s, dtype=float), c.k))   # e^{−ks}
    b = e2d / a                                                          # e^{−k(2d−s)}
    ch1, sh1 = ch[..., 0, :], sh[..., 0, :]
    np.add(a, b, out=ch1)
    ch1 *= inv
    np.subtract(a, b, out=sh1)
    sh1 *= inv
    if ch.shape[-2] > 1:
        ch2, sh2 = ch[..., 1, :], sh[..., 1, :]
        a *= a
        a *= x
        b *= b
        b *= x
        np.add(a, b, out=ch2)
        ch2 *= inv4
        np.subtract(a, b, out=sh2)
        sh2 *= inv4


def _depth_factors(c: WaveComponents, s):
    """(ch1, sh1, ch2, sh2) at depth(s) s, each of shape shape(s) + (N,); ch2/sh2 None for linear seas."""
    orders = 2 if c.second_order else 1
    shape = (*np.shape(s), orders, c.n)
    ch, sh = np.empty(shape), np.empty(shape)
    _depth_factors_into(c, s, ch, sh)
    if orders == 1:
        return ch[..., 0, :], sh[..., 0, :], None, None
    return ch[..., 0, :], sh[..., 0, :], ch[..., 1, :], sh[..., 1, :]


def elevation(c: WaveComponents, x, t) -> np.ndarray:
    """Surface elevation ζ(x, t) (m, positive up) — paper Eq. 5 (finite-depth 2nd order).

    ``x`` (m) and ``t`` (s) broadcast together; the result has their shape.
    """
    return _elevation_of_phase(c, _phase(c, x, t))


def elevation_xy(c: WaveComponents, x, y, t) -> np.ndarray:
    """Surface elevation ζ(x, y, t) (m, up) anywhere on the horizontal plane (a wave-gauge array).

    Component i travels at β_i (``c.direction``; 0 for a long-crested sea), phase
    θ_i = k_i (x cos β_i + y sin β_i) − ω_i t + ε_i; on y = 0 this is :func:`elevation`.
    ``x``, ``y`` (m) and ``t`` (s) broadcast together.
    """
    x, y, t = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(y, dtype=float), np.asarray(t, dtype=float))
    th = _phase(c, x, t)
    if c.direction is not None:
        th = th + y[..., None] * (c.k * np.sin(c.direction))
    return _elevation_of_phase(c, th)


def _second_order_amplitude(c: WaveComponents) -> np.ndarray:
    """Amplitude (m) of each component's Stokes self-interaction term, the cos 2θ wave."""
    xx = np.exp(-2.0 * c.k * c.water_depth)
    factor = 2.0 * (1.0 + xx) * (1.0 + 4.0 * xx + xx * xx) / (1.0 - xx) ** 3
    return 0.25 * c.k * c.amplitude**2 * factor


def _elevation_of_phase(c: WaveComponents, th: np.ndarray) -> np.ndarray:
    """Σ A cos θ plus the Stokes self-interaction terms, given the phases θ (shape S + (N,))."""
    eta = np.cos(th) @ c.amplitude
    if c.second_order:
        eta = eta + np.cos(2.0 * th) @ _second_order_amplitude(c)
    return eta


def elevation_grid(c: WaveComponents, x, t) -> np.ndarray:
    """ζ (m, up) on the grid of times ``t`` (s, T) × points ``x`` (m, X along y = 0): :func:`elevation`
    of every pair, as complex matrix products (the phase k x − ω t + ε splits into a factor of x and
    one of t), for drawing a sea surface over a whole run at once. Shape (T, X)."""
    x, t = np.asarray(x, dtype=float).ravel(), np.asarray(t, dtype=float).ravel()
    ex = np.exp(1j * (c.kx * x[:, None] + c.phase))         # X × N
    et = np.exp(-1j * (c.omega * t[:, None]))                # T × N
    eta = ((et * c.amplitude) @ ex.T).real
    if c.second_order:
        eta += ((et * et * _second_order_amplitude(c)) @ (ex * ex).T).real
    return eta


def pressure_head(c: WaveComponents, x, depth, t, y=0.0) -> np.ndarray:
    """Linear dynamic pressure head p_d/(ρ g) (m) at (x (m), depth s ≥ 0 (m, down), t (s)).

    p_d/(ρ g) = Σ A_i K_p(k_i, s) cos θ_i with the pressure transfer function
    K_p = cosh k(d − s)/cosh kd (finite depth d; deep water e^{−ks}; K_p = 1 at
    the still surface). A pressure sensor at depth s reads p/(ρ g) = s + this
    head (first order: the Stokes 2nd-order pressure is left out). The ratio is
    evaluated as (e^{−ks} + e^{−k(2d−s)})/(1 + e^{−2kd}), so large kd cannot overflow.
    ``x``, ``depth`` and ``t`` broadcast together; the result has their shape. ``y`` (m, east) places the
    point off the x–z plane in a sea whose components have directions (phase k (x cos β + y sin β) − ω t + ε).
    """
    x, depth, t = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(depth, dtype=float),
                                      np.asarray(t, dtype=float))
    s = np.clip(depth, 0.0, c.water_depth)[..., None]
    e2d = np.exp(-2.0 * c.k * c.water_depth)
    kp = (np.exp(-c.k * s) + e2d * np.exp(c.k * s)) / (1.0 + e2d)
    th = _phase(c, x, t)
    if c.direction is not None and np.any(np.asarray(y) != 0.0):
        th = th + np.asarray(y, dtype=float)[..., None] * (c.k * np.sin(c.direction))
    return (kp * np.cos(th)) @ c.amplitude


def _kinematics_from_trig(c: WaveComponents, ct, st, depth):
    """Sum the velocity and acceleration series given cos θ, sin θ (shape S+(N,)) and depth (broadcastable)."""
    ch1, sh1, ch2, sh2 = _depth_factors(c, depth)
    aw = c.amplitude * c.omega
    awx = aw if c.in_plane is None else aw * c.in_plane          # in-plane share of the horizontal terms
    u = np.sum(ct * (ch1 * awx), axis=-1)
    w_up = np.sum(st * (sh1 * aw), axis=-1)
    u_dot = np.sum(st * (ch1 * (awx * c.omega)), axis=-1)
    w_up_dot = -np.sum(ct * (sh1 * (aw * c.omega)), axis=-1)
    if c.second_order:
        c2 = ct * ct - st * st
        s2 = 2.0 * st * ct
        b2 = 0.75 * c.omega * c.k * c.amplitude**2
        b2x = b2 if c.in_plane is None else b2 * c.in_plane
        u = u + np.sum(c2 * (ch2 * b2x), axis=-1)
        w_up = w_up + np.sum(s2 * (sh2 * b2), axis=-1)
        u_dot = u_dot + np.sum(s2 * (ch2 * (2.0 * c.omega * b2x)), axis=-1)
        w_up_dot = w_up_dot - np.sum(c2 * (sh2 * (2.0 * c.omega * b2)), axis=-1)
    return u, -w_up, u_dot, -w_up_dot


def particle_kinematics(c: WaveComponents, x, depth, t):
    """Fluid particle velocity and local acceleration at (x, depth, t) — paper Eqs. 9–10.

    ``x`` (m), ``depth`` (m, positive down) and ``t`` (s) broadcast together to a
    shape S. Returns ``(u, w, u_dot, w_dot)``, each of shape S, in the NED frame
    (m/s, m/s²; w positive down).
    """
    x, depth, t = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(depth, dtype=float),
                                      np.asarray(t, dtype=float))
    th = _phase(c, x, t)
    return _kinematics_from_trig(c, np.cos(th), np.sin(th), depth)


def particle_kinematics_grid(c: WaveComponents, x, depth, t):
    """:func:`particle_kinematics` on the grid of P points × T times, results of shape (T, P).

    ``x`` and ``depth`` have shape (P,), ``t`` shape (T,). The phase separates,
    θ = a − b with a = k x + ε (per point) and b = ω t (per time), so

        Σ_n W_pn cos θ = cos b · (W cos a)ᵀ + sin b · (W sin a)ᵀ   (and likewise for sin θ)

    is two small matrix products, and only (P + T)·N sines and cosines are
    evaluated instead of P·T·N. This is the plant's hot path (RK4 stage times ×
    body strips); tests check it against :func:`particle_kinematics`.
    """
    x = np.asarray(x, dtype=float)
    depth = np.asarray(depth, dtype=float)
    t = np.asarray(t, dtype=float)
    orders = 2 if c.second_order else 1
    P, T, N = x.size, t.size, c.n
    a = np.multiply.outer(x, c.kx)
    a += c.phase                                     # (P, N)
    b = np.multiply.outer(t, c.omega)                # (T, N)
    # cos/sin of each order, laid out (2, rows, orders, N); order 2 by the double-angle formulas
    ta = np.empty((2, P, orders, N))
    tb = np.empty((2, T, orders, N))
    for trig, ang in ((ta, a), (tb, b)):
        np.cos(ang, out=trig[0, :, 0])
        np.sin(ang, out=trig[1, :, 0])
        if orders == 2:
            np.subtract(trig[0, :, 0] ** 2, trig[1, :, 0] ** 2, out=trig[0, :, 1])
            np.multiply(trig[0, :, 0], trig[1, :, 0], out=trig[1, :, 1])
            trig[1, :, 1] *= 2.0
    # Series weights W[K, P, orders, N]: u ~ cos θ, w↑ ~ sin θ, u̇ ~ sin θ, ẇ↑ ~ −cos θ
    coef, rate = c._series_constants                 # (orders, N) each
    W = np.empty((4, P, orders, N))
    _depth_factors_into(c, depth, W[0], W[1])
    W[:2] *= coef
    if c.in_plane is not None:
        W[0] *= c.in_plane                           # u (and so u̇): the in-plane share cos β
    np.multiply(W[:2], rate, out=W[2:])
    # Contract over (order, component) in one matrix product per term: (4P, ON) @ (ON, T)
    Wc = (W * ta[0]).reshape(4 * P, orders * N)
    Ws = (W * ta[1]).reshape(4 * P, orders * N)
    cb, sb = tb[0].reshape(T, orders * N).T, tb[1].reshape(T, orders * N).T
    cos_sum = (Wc @ cb + Ws @ sb).reshape(4, P, T)   # Σ W cos θ
    sin_sum = (Ws @ cb - Wc @ sb).reshape(4, P, T)   # Σ W sin θ
    return cos_sum[0].T, -sin_sum[1].T, sin_sum[2].T, cos_sum[3].T


def particle_velocity(c: WaveComponents, x, depth, t) -> tuple[np.ndarray, np.ndarray]:
    """(u, w) fluid velocity (m/s, NED, w positive down) at (x, depth, t)."""
    u, w, _, _ = particle_kinematics(c, x, depth, t)
    return u, w


def particle_acceleration(c: WaveComponents, x, depth, t) -> tuple[np.ndarray, np.ndarray]:
    """(u̇, ẇ) local fluid acceleration (m/s², NED, positive down) at (x, depth, t)."""
    _, _, ud, wd = particle_kinematics(c, x, depth, t)
    return ud, wd
