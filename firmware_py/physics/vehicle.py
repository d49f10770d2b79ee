"""Fossen 3-DoF longitudinal (surge, heave, pitch) vehicle model — paper Eq. 2.

    η̇ = J(η) ν
    M ν̇ + C(ν) ν + D(ν) ν + g(η) = τ + τ_E

η = [x, z, θ] (NED position in m, pitch in rad, nose up positive);
ν = [u, w, q] (body FRD velocities in m/s, pitch rate in rad/s);
τ = [X, Z, M] (body-frame force in N along x and z, pitch moment in N m).

Added-mass coefficients are stored as positive numbers (the paper's Table II),
so M_A = [[X_u̇, 0, X_q̇], [0, Z_ẇ, 0], [M_u̇, 0, M_q̇]] with M_u̇ = X_q̇.

The same functions serve the simulated plant (true parameters) and the
firmware's estimator and feed-forward (nominal parameters).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from .waves import G, WaveComponents, particle_kinematics_grid

__all__ = [
    "VehicleParams",
    "J",
    "coriolis_matrix",
    "damping_matrix",
    "restoring_forces",
    "coriolis_forces",
    "nu_dot",
    "state_rates",
    "strip_nodes",
    "wave_load",
]


@dataclass(frozen=True)
class VehicleParams:
    """Rigid-body and hydrodynamic parameters (SI units, FRD body frame)."""

    W: float                 # weight (N)
    B: float                 # buoyancy (N)
    I_y: float               # pitch inertia about the CG (kg m²)
    r_G: np.ndarray          # centre of gravity in body FRD (m)
    r_B: np.ndarray          # centre of buoyancy in body FRD (m); z < 0 is above the CG
    length: float            # body length L (m), for the strip integral of Eq. 11
    X_udot: float            # added mass (kg)
    Z_wdot: float            # added mass (kg)
    M_qdot: float            # added inertia (kg m²)
    X_qdot: float            # surge–pitch coupling X_q̇ = M_u̇ (kg m)
    X_u: float               # linear damping (kg/s)
    Z_w: float               # linear damping (kg/s)
    M_q: float               # linear damping (kg m²/s)
    X_uu: float              # quadratic damping (N s²/m²)
    Z_ww: float              # quadratic damping (N s²/m²)
    M_qq: float              # quadratic damping (N m s²)
    g: float = G
    M_RB: np.ndarray = field(init=False, repr=False)
    M_A: np.ndarray = field(init=False, repr=False)
    M: np.ndarray = field(init=False, repr=False)
    M_inv: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        m = self.mass
        x_g, z_g = float(self.r_G[0]), float(self.r_G[2])
        # Rigid-body inertia about the body origin (Fossen 2011, Eq. 3.44, planar part)
        M_RB = np.array([[m, 0.0, m * z_g], [0.0, m, -m * x_g], [m * z_g, -m * x_g, self.I_y]])
        M_A = np.array([[self.X_udot, 0.0, self.X_qdot], [0.0, self.Z_wdot, 0.0], [self.X_qdot, 0.0, self.M_qdot]])
        M = M_RB + M_A
        object.__setattr__(self, "r_G", np.asarray(self.r_G, dtype=float))
        object.__setattr__(self, "r_B", np.asarray(self.r_B, dtype=float))
        object.__setattr__(self, "M_RB", M_RB)
        object.__setattr__(self, "M_A", M_A)
        object.__setattr__(self, "M", M)
        object.__setattr__(self, "M_inv", np.linalg.inv(M))
        # Float copies for the scalar hot path (state_rates)
        object.__setattr__(self, "_M_rows", tuple(map(tuple, M.tolist())))
        object.__setattr__(self, "_M_inv_rows", tuple(map(tuple, np.linalg.inv(M).tolist())))
        r_G, r_B = np.asarray(self.r_G, dtype=float), np.asarray(self.r_B, dtype=float)
        object.__setattr__(self, "_BG_z", float(r_G[2] * self.W - r_B[2] * self.B))
        object.__setattr__(self, "_BG_x", float(r_G[0] * self.W - r_B[0] * self.B))

    @property
    def mass(self) -> float:
        """Dry mass m = W / g (kg)."""
        return self.W / self.g

    @property
    def D_L(self) -> np.ndarray:
        return np.diag([self.X_u, self.Z_w, self.M_q])

    @property
    def D_Q(self) -> np.ndarray:
        return np.diag([self.X_uu, self.Z_ww, self.M_qq])

    def scaled(self, **factors: float) -> "VehicleParams":
        """A copy with named scalar parameters multiplied by the given factors (model mismatch studies)."""
        return replace(self, **{k: getattr(self, k) * v for k, v in factors.items()})

    @classmethod
    def from_config(cls, cfg: dict) -> "VehicleParams":
        """Build from a validated ``configs/vehicle/*.yaml`` mapping (see :mod:`firmware_py.config`)."""
        mp, am, dp = cfg["mass_properties"], cfg["added_mass"], cfg["damping"]
        return cls(W=mp["W"], B=mp["B"], I_y=mp["I_y"], r_G=np.array(mp["r_G"]), r_B=np.array(mp["r_B"]),
                   length=mp["length"], X_udot=am["X_udot"], Z_wdot=am["Z_wdot"], M_qdot=am["M_qdot"],
                   X_qdot=am["X_qdot"], X_u=dp["X_u"], Z_w=dp["Z_w"], M_q=dp["M_q"], X_uu=dp["X_uu"],
                   Z_ww=dp["Z_ww"], M_qq=dp["M_qq"])

    @classmethod
    def load(cls, path: str | Path) -> "VehicleParams":
        from firmware_py.config import load_vehicle_config
        return cls.from_config(load_vehicle_config(path))


def J(eta: np.ndarray) -> np.ndarray:
    """Kinematic transformation J(η): body velocities ν → NED rates η̇ (planar, Fossen Eq. 2.40)."""
    c, s = np.cos(eta[2]), np.sin(eta[2])
    return np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])


def coriolis_matrix(p: VehicleParams, nu: np.ndarray) -> np.ndarray:
    """C(ν) = C_RB(ν) + C_A(ν), skew-symmetric (Fossen 2011, Eqs. 3.56 and 6.43, planar part).

    From the momenta p = M[:2] ν (linear) and h = M[2] ν (angular): the
    surge/heave rows are ω × p, the pitch row v × p. Both parts do no work: νᵀ C ν = 0.
    """
    u, w, q = nu
    M = p.M
    p_x = M[0, 0] * u + M[0, 2] * q   # (m + X_u̇) u + (m z_g + X_q̇) q
    p_z = M[1, 1] * w + M[1, 2] * q   # (m + Z_ẇ) w − m x_g q
    return np.array([[0.0, 0.0, p_z], [0.0, 0.0, -p_x], [-p_z, p_x, 0.0]])


def damping_matrix(p: VehicleParams, nu: np.ndarray) -> np.ndarray:
    """D(ν) = D_L + D_Q |ν| (paper Eq. 4)."""
    a = np.abs(nu)
    return np.diag([p.X_u + p.X_uu * a[0], p.Z_w + p.Z_ww * a[1], p.M_q + p.M_qq * a[2]])


def restoring_forces(p: VehicleParams, eta: np.ndarray) -> np.ndarray:
    """g(η): hydrostatic restoring forces in the body frame (Fossen 2011, Eq. 4.6, φ = 0)."""
    s, c = math.sin(eta[2]), math.cos(eta[2])
    W, B = p.W, p.B
    return np.array([
        (W - B) * s,
        -(W - B) * c,
        (p.r_G[2] * W - p.r_B[2] * B) * s + (p.r_G[0] * W - p.r_B[0] * B) * c,
    ])


def coriolis_forces(p: VehicleParams, nu) -> np.ndarray:
    """C(ν) ν without forming the matrix."""
    u, w, q = nu
    M = p.M
    p_x = M[0, 0] * u + M[0, 2] * q
    p_z = M[1, 1] * w + M[1, 2] * q
    return np.array([p_z * q, -p_x * q, -p_z * u + p_x * w])


def state_rates(p: VehicleParams, x, tau) -> np.ndarray:
    """ẋ for x = [η, ν] = [x, z, θ, u, w, q] under the total load τ (control + wave), paper Eq. 2.

    η̇ = J(η) ν and ν̇ = M⁻¹ (τ − C(ν)ν − D(ν)ν − g(η)), written out in scalars:
    this is the innermost call of the plant's RK4 and of the estimator's
    prediction, and 3-vectors cost more as arrays than as floats.
    """
    _, _, th, u, w, q = x.tolist() if isinstance(x, np.ndarray) else x
    X, Z, Mt = tau.tolist() if isinstance(tau, np.ndarray) else tau
    c, s = math.cos(th), math.sin(th)
    (m00, _, m02), (_, m11, m12), _ = p._M_rows
    p_x, p_z = m00 * u + m02 * q, m11 * w + m12 * q          # momenta for C(ν)ν
    WB = p.W - p.B
    r0 = X - p_z * q - (p.X_u + p.X_uu * abs(u)) * u - WB * s
    r1 = Z + p_x * q - (p.Z_w + p.Z_ww * abs(w)) * w + WB * c
    r2 = (Mt + p_z * u - p_x * w - (p.M_q + p.M_qq * abs(q)) * q
          - p._BG_z * s - p._BG_x * c)
    (a0, a1, a2), (b0, b1, b2), (c0, c1, c2) = p._M_inv_rows
    return np.array([c * u + s * w, -s * u + c * w, q,
                     a0 * r0 + a1 * r1 + a2 * r2, b0 * r0 + b1 * r1 + b2 * r2, c0 * r0 + c1 * r1 + c2 * r2])


def nu_dot(p: VehicleParams, eta, nu, tau) -> np.ndarray:
    """ν̇ = M⁻¹ (τ − C(ν)ν − D(ν)ν − g(η)), with τ the total (control + wave) load."""
    return state_rates(p, np.concatenate([eta, nu]), tau)[3:]


def strip_nodes(length: float, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss–Legendre strip positions x' (m, body x) and weights summing to 1 over [−L/2, L/2]."""
    xi, wts = np.polynomial.legendre.leggauss(n)
    return 0.5 * length * xi, 0.5 * wts


def wave_load(p: VehicleParams, waves: WaveComponents, eta: np.ndarray, t, strips: tuple[np.ndarray, np.ndarray]):
    """Wave-induced load τ_E = [X_E, Z_E, M_E] (N, N, N m) on the body — paper Eq. 11.

    Each strip at body position x' feels the fluid velocity ν_p and local
    acceleration ν̇_p at its own earth position, rotated into the body frame
    by R_y(θ)ᵀ. The load per unit length is (M_A,ii ν̇_p + (D_L,ii + D_Q,ii |ν_p|) ν_p)/L
    for surge and heave; X_E and Z_E integrate it over the length, and the pitch
    moment integrates the heave load's moment arm, M_E = −∫ Z_E'(x') x' dx'
    (a downward force ahead of the origin pitches the nose down; the paper
    prints the integral without the sign of r × F).

    ``eta`` is one pose [x, z, θ]; ``t`` a time (s) or an array of T times, giving
    a (3,) or (T, 3) result. The strip integral is Gauss–Legendre quadrature
    (:func:`strip_nodes`).
    """
    xs, wts = strips
    th = float(eta[2])
    c, s = np.cos(th), np.sin(th)
    tt = np.atleast_1d(np.asarray(t, dtype=float))
    u, w, ud, wd = particle_kinematics_grid(waves, eta[0] + xs * c, eta[1] - xs * s, tt)   # (T, strips)
    # NED → body: [u_b, w_b] = R_y(θ)ᵀ [u_n, w_n]
    ub, wb = c * u - s * w, s * u + c * w
    aub, awb = c * ud - s * wd, s * ud + c * wd
    fx = p.X_udot * aub + (p.X_u + p.X_uu * np.abs(ub)) * ub
    fz = p.Z_wdot * awb + (p.Z_w + p.Z_ww * np.abs(wb)) * wb
    out = np.stack([fx @ wts, fz @ wts, -(fz @ (wts * xs))], axis=-1)
    return out if np.ndim(t) else out[0]
