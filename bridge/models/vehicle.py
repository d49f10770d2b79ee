"""Fossen 3-DoF longitudinal (surge, heave, pitch) vehicle model — paper Eq. 2.

    η̇ = J(η) ν
    M ν̇ + C(ν) ν + D(ν) ν + g(η) = τ + τ_E

η = [x, z, θ] (NED position in m, pitch in rad, nose up positive);
ν = [u, w, q] (body FRD velocities in m/s, pitch rate in rad/s);
τ = [X, Z, M] (body-frame force in N along x and z, pitch moment in N m).

Added-mass coefficients are stored as positive numbers (the paper's Table II),
so M_A = [[X_u̇, 0, X_q̇], [0, Z_ẇ, 0], [M_u̇, 0, M_q̇]] with M_u̇ = X_q̇.

The fluid's inertia load in waves comes in two forms (``wave_load_model``,
docs/models.md): ``complete`` (default), the Froude–Krylov force of the wave's
pressure gradient ρ∇·a plus the added-mass force M_A·a, with the X_q̇ = M_u̇
coupling and the Froude–Krylov force's moment about the body origin (Morison's
C_M = 1 + C_a; Fossen's equations of relative motion in an accelerating flow);
``paper``, the added-mass force alone (paper Eq. 10/11), kept to reproduce the paper.

The same functions serve the simulated plant (true parameters) and the
firmware's estimator and feed-forward (nominal parameters).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from . import kernels
from .waves import G, WaveComponents, particle_kinematics_grid

__all__ = [
    "RHO_SEAWATER",
    "WAVE_LOAD_MODELS",
    "BodyFlow",
    "J",
    "VehicleParams",
    "body_flow",
    "body_to_ned",
    "coriolis_matrix",
    "damping_matrix",
    "hydrodynamic_load",
    "hydrodynamic_load_at",
    "motor_lag_factors",
    "motor_lag_stages",
    "ned_to_body",
    "rates_jacobian",
    "restoring_forces",
    "rk4_step",
    "state_rates",
    "strip_nodes",
    "submerged_fraction",
    "wave_load",
]


RHO_SEAWATER = 1025.0
"""Sea-water density (kg/m³), the default for a vehicle config's ``water_density``."""

WAVE_LOAD_MODELS = ("complete", "paper")
"""The fluid-inertia load models (:attr:`VehicleParams.wave_load_model`): ``complete`` is
(ρ∇ + M_A)·a with the pitch coupling, ``paper`` the paper's M_A·a (Eq. 10/11)."""


@dataclass(frozen=True)
class VehicleParams:
    """Rigid-body and hydrodynamic parameters (SI units, FRD body frame).

    ``displaced_volume`` ∇ (m³; None: B/(ρ g), the volume the buoyancy implies) and
    ``water_density`` ρ (kg/m³) give the Froude–Krylov mass ρ∇ of the ``complete``
    :attr:`wave_load_model`; the ``paper`` model leaves it and the X_q̇ coupling out.
    """

    W: float                 # weight (N)
    B: float                 # buoyancy (N)
    I_y: float               # pitch inertia about the CG (kg m²)
    r_G: np.ndarray          # centre of gravity in body FRD (m)
    r_B: np.ndarray          # centre of buoyancy in body FRD (m); z < 0 is above the CG
    length: float            # body length L (m), for the strip integral of Eq. 11
    height: float            # body height (m): buoyancy fades out over it when the vehicle breaches
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
    displaced_volume: float | None = None   # ∇ (m³); None: B / (ρ g)
    water_density: float = RHO_SEAWATER     # ρ (kg/m³)
    wave_load_model: str = "complete"       # one of WAVE_LOAD_MODELS
    # Derived in __post_init__ from the load model. fk_mass m_FK (kg): the Froude–Krylov mass on the fluid's
    # acceleration, ρ∇ (complete) or 0 (paper). fluid_pitch_coupling c_θ = M_u̇ + ρ∇ z_B (kg m): the pitch
    # moment per unit mean surge acceleration of the fluid — the added-mass coupling M_u̇ = X_q̇, and the
    # moment about the body origin of the Froude–Krylov surge force, which acts at the buoyancy centre's
    # height z_B (r × F: a forward push above the origin pitches the nose down); 0 in the paper's model.
    fk_mass: float = field(init=False)
    fluid_pitch_coupling: float = field(init=False)
    M_RB: np.ndarray = field(init=False, repr=False)
    M_A: np.ndarray = field(init=False, repr=False)
    M: np.ndarray = field(init=False, repr=False)
    M_inv: np.ndarray = field(init=False, repr=False)
    _M_RB_rows: tuple = field(init=False, repr=False)    # M_RB and M⁻¹ as nested float tuples: the scalar
    _M_inv_rows: tuple = field(init=False, repr=False)   # hot path of state_rates reads them without numpy
    kernel_params: np.ndarray = field(init=False, repr=False)   # the compiled kernels' vector (bridge.models.kernels)

    def __post_init__(self) -> None:
        if self.wave_load_model not in WAVE_LOAD_MODELS:
            raise ValueError(f"wave_load_model must be one of {', '.join(WAVE_LOAD_MODELS)}, "
                             f"got {self.wave_load_model!r}")
        complete = self.wave_load_model == "complete"
        object.__setattr__(self, "fk_mass", self.rho_V if complete else 0.0)
        object.__setattr__(self, "fluid_pitch_coupling", self.X_qdot + self.rho_V * float(self.r_B[2]) if complete
                           else 0.0)
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
        object.__setattr__(self, "_M_RB_rows", tuple(map(tuple, M_RB.tolist())))
        object.__setattr__(self, "_M_inv_rows", tuple(map(tuple, np.linalg.inv(M).tolist())))
        r_G, r_B = self.r_G, self.r_B
        kp = [self.W, self.B, self.height, r_G[0], r_G[2], r_B[0], r_B[2], self.X_udot, self.Z_wdot, self.X_qdot,
              self.X_u, self.Z_w, self.M_q, self.X_uu, self.Z_ww, self.M_qq, M_RB[0, 0], M_RB[0, 2], M_RB[1, 1],
              M_RB[1, 2], *np.linalg.inv(M).ravel(), self.fk_mass, self.fluid_pitch_coupling]
        object.__setattr__(self, "kernel_params", np.array(kp, dtype=float))
        kernels.warm_up()   # load the compiled kernels now, not on a real-time loop's first ticks

    @property
    def mass(self) -> float:
        """Dry mass m = W / g (kg)."""
        return self.W / self.g

    @property
    def rho_V(self) -> float:
        """ρ∇ (kg): the displaced water's mass, ρ · ``displaced_volume``, or B / g when the volume is not stated."""
        if self.displaced_volume is None:
            return self.B / self.g
        return self.water_density * self.displaced_volume

    def with_wave_load(self, model: str) -> VehicleParams:
        """The same vehicle under another fluid-inertia load model (one of :data:`WAVE_LOAD_MODELS`)."""
        return self if model == self.wave_load_model else replace(self, wave_load_model=model)

    @property
    def D_L(self) -> np.ndarray:
        return np.diag([self.X_u, self.Z_w, self.M_q])

    @property
    def D_Q(self) -> np.ndarray:
        return np.diag([self.X_uu, self.Z_ww, self.M_qq])

    @classmethod
    def from_config(cls, cfg: dict) -> VehicleParams:
        """Build from a validated ``configs/vehicle/*.yaml`` mapping (see :mod:`bridge.schemas`)."""
        mp, am, dp = cfg["mass_properties"], cfg["added_mass"], cfg["damping"]
        return cls(W=mp["W"], B=mp["B"], I_y=mp["I_y"], r_G=np.array(mp["r_G"]), r_B=np.array(mp["r_B"]),
                   length=mp["length"], height=mp["height"],
                   X_udot=am["X_udot"], Z_wdot=am["Z_wdot"], M_qdot=am["M_qdot"],
                   X_qdot=am["X_qdot"], X_u=dp["X_u"], Z_w=dp["Z_w"], M_q=dp["M_q"], X_uu=dp["X_uu"],
                   Z_ww=dp["Z_ww"], M_qq=dp["M_qq"], displaced_volume=mp.get("displaced_volume"),
                   water_density=mp.get("water_density", RHO_SEAWATER))

    @classmethod
    def load(cls, path: str | Path) -> VehicleParams:
        from bridge.schemas import load_vehicle_config
        return cls.from_config(load_vehicle_config(path))


def body_to_ned(theta: float, u, w):
    """NED rates (ẋ, ż) of body velocities (u, w) at pitch θ: the translational rows of J(η) (Fossen Eq. 2.40)."""
    c, s = math.cos(theta), math.sin(theta)
    return c * u + s * w, -s * u + c * w


def ned_to_body(theta: float, vn, vd):
    """Body components (u, w) of an NED vector (north, down) at pitch θ: J(η)ᵀ, the inverse of :func:`body_to_ned`."""
    c, s = math.cos(theta), math.sin(theta)
    return c * vn - s * vd, s * vn + c * vd


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


def submerged_fraction(p: VehicleParams, depth: float) -> float:
    """Fraction of the buoyancy acting at a depth (m) of the origin: 1 when fully submerged,
    falling linearly to 0 as the body (height ``p.height``) rises through the still surface."""
    return min(1.0, max(0.0, depth / p.height + 0.5))


def restoring_forces(p: VehicleParams, eta: np.ndarray) -> np.ndarray:
    """g(η): hydrostatic restoring forces in the body frame (Fossen 2011, Eq. 4.6, φ = 0).

    Buoyancy is scaled by :func:`submerged_fraction` so a vehicle that reaches
    the surface floats there instead of flying out of the water.
    """
    return np.array(restoring_terms(p, eta[1], eta[2]))


def restoring_terms(p: VehicleParams, z: float, theta: float) -> tuple[float, float, float]:
    """:func:`restoring_forces` at depth z (m) and pitch θ (rad), as three floats (the per-tick scalar path)."""
    s, c = math.sin(theta), math.cos(theta)
    W, B = p.W, p.B * submerged_fraction(p, z)
    return ((W - B) * s,
            -(W - B) * c,
            (p.r_G[2] * W - p.r_B[2] * B) * s + (p.r_G[0] * W - p.r_B[0] * B) * c)


@dataclass(frozen=True)
class BodyFlow:
    """Fluid velocity and local acceleration at the body's strips, body frame, at T instants.

    xs, wts: strip positions x' (m) and quadrature weights (sum 1); u, w (m/s)
    and ax, az (m/s²) have shape (T, S). Built by :func:`body_flow`.
    """

    xs: np.ndarray
    wts: np.ndarray
    u: np.ndarray
    w: np.ndarray
    ax: np.ndarray
    az: np.ndarray
    _stages: tuple = field(init=False, repr=False)      # per instant, as plain floats (see stage())

    def __post_init__(self) -> None:
        object.__setattr__(self, "_stages", None)

    def stage(self, i: int) -> tuple:
        """The flow at instant i as plain float lists (the scalar hot path's input), converted on first use."""
        if self._stages is None:
            xs, wts = self.xs.tolist(), self.wts.tolist()
            stages = tuple((xs, wts, u, w, ax, az) for u, w, ax, az in
                           zip(self.u.tolist(), self.w.tolist(), self.ax.tolist(), self.az.tolist(), strict=False))
            object.__setattr__(self, "_stages", stages)
        return self._stages[i]

    def arrays(self, i: int) -> tuple:
        """(xs, wts, u, w, ax, az) at instant i as float arrays (the compiled kernels' input)."""
        return self.xs, self.wts, self.u[i], self.w[i], self.ax[i], self.az[i]


def body_flow(waves: WaveComponents, eta, t, strips: tuple[np.ndarray, np.ndarray],
              current_x: float = 0.0) -> BodyFlow:
    """The sea's flow at the strips of a body at pose η = [x, z, θ], at time(s) t.

    Each strip at body position x' sits at earth (x + x' cos θ, z − x' sin θ);
    its NED velocity and acceleration are rotated into the body frame by R_y(θ)ᵀ.
    ``current_x`` (m/s, NED north) is a steady, depth-uniform current added to the
    waves' velocity (its acceleration is zero), so the loads act on ν_r = ν − ν_p − ν_c.
    """
    flow = _wave_flow(waves, eta, t, strips)
    if current_x == 0.0:
        return flow
    uc, wc = ned_to_body(float(eta[2]), current_x, 0.0)
    return BodyFlow(flow.xs, flow.wts, flow.u + uc, flow.w + wc, flow.ax, flow.az)


def _wave_flow(waves: WaveComponents, eta, t, strips: tuple[np.ndarray, np.ndarray]) -> BodyFlow:
    """The waves' flow of :func:`body_flow` (no current)."""
    xs, wts = strips
    th = float(eta[2])
    tt = np.atleast_1d(np.asarray(t, dtype=float))
    if kernels.ENABLED:
        x_e2d, _, inv, inv4 = waves._depth_constants
        coef, rate = waves._series_constants
        out = kernels.body_flow_arrays(waves.k, waves.omega, waves.phase, coef, rate, x_e2d, inv, inv4,
                                       waves.water_depth, float(eta[0]), float(eta[1]), th, xs, tt,
                                       waves.kx, waves.in_plane_or_ones)
        return BodyFlow(xs, wts, out[0], out[1], out[2], out[3])
    c, s = math.cos(th), math.sin(th)
    # Linear kinematics do not hold above the still surface: a breaching strip feels the surface flow.
    depth = np.clip(eta[1] - xs * s, 0.0, waves.water_depth)   # and nothing below the seabed
    u, w, ud, wd = particle_kinematics_grid(waves, eta[0] + xs * c, depth, tt)   # (T, S)
    return BodyFlow(xs, wts, *ned_to_body(th, u, w), *ned_to_body(th, ud, wd))


def hydrodynamic_load(p: VehicleParams, u: float, w: float, q: float, flow: tuple | None = None):
    """Hydrodynamic force on the moving body (N, N, N m), excluding −M_A ν̇.

    The relative-velocity Morison strip model (Fossen 2011 §10.3, equations of
    relative motion in a non-uniform, accelerating flow; Morison's inertia
    coefficient C_M = 1 + C_a). Per unit length at strip x', with ν_r = ν − ν_p(x')
    and m_FK = ρ∇ the displaced water's mass spread evenly over the strips:

        X' = (m_FK + X_u̇) u̇_p − (X_u + X_u|u| |u_r|) u_r,   Z' = (m_FK + Z_ẇ) ẇ_p − (Z_w + Z_w|w| |w_r|) w_r

    integrated over the length for X and Z, with the pitch moment −∫ Z' x' dx'
    plus c_θ ū̇_p, c_θ = M_u̇ + ρ∇ z_B (:attr:`VehicleParams.fluid_pitch_coupling`:
    the added-mass coupling and the Froude–Krylov surge force's lever at the
    buoyancy centre); plus the added-mass Coriolis force −C_A(ν̄_r) ν̄_r on the
    mean relative velocity (Munk moment) and the rotational damping
    −(M_q + M_q|q| |q|) q. In the ``paper`` load model m_FK = c_θ = 0 (Eq. 10/11).
    ``flow`` is a :meth:`BodyFlow.stage` tuple, or None for still water, where
    this is exactly −C_A(ν)ν − D(ν)ν of paper Eq. 2; for a body at rest it is
    the wave load τ_E (plus the flow's Munk moment).
    """
    if flow is None:
        ur, wr = u, w
        X = -(p.X_u + p.X_uu * abs(u)) * u
        Z = -(p.Z_w + p.Z_ww * abs(w)) * w
        Mh = 0.0
    else:
        xs, wts, up, wp, ax, az = flow
        m_x, m_z = p.X_udot + p.fk_mass, p.Z_wdot + p.fk_mass   # inertia on the fluid's acceleration (kg)
        X = Z = Mh = ub = wb = axb = 0.0
        for xj, wj, upj, wpj, axj, azj in zip(xs, wts, up, wp, ax, az, strict=False):
            urj, wrj = u - upj, w - wpj
            fz = m_z * azj - (p.Z_w + p.Z_ww * abs(wrj)) * wrj
            X += wj * (m_x * axj - (p.X_u + p.X_uu * abs(urj)) * urj)
            Z += wj * fz
            Mh -= wj * xj * fz
            ub += wj * upj
            wb += wj * wpj
            axb += wj * axj
        Mh += p.fluid_pitch_coupling * axb
        ur, wr = u - ub, w - wb
    pAx, pAz = p.X_udot * ur + p.X_qdot * q, p.Z_wdot * wr     # added-mass momenta of the relative motion
    X -= pAz * q
    Z += pAx * q
    Mh += pAz * ur - pAx * wr - (p.M_q + p.M_qq * abs(q)) * q
    return X, Z, Mh


def hydrodynamic_load_at(p: VehicleParams, u: float, w: float, q: float, flow: BodyFlow | None = None,
                         i: int = 0) -> np.ndarray:
    """:func:`hydrodynamic_load` (N, N, N m) in ``flow`` at its instant i (None: still water), as an array (3,).

    The compiled kernel when :data:`~bridge.models.kernels.ENABLED`, else the reference.
    """
    return np.array(hydrodynamic_load_terms(p, u, w, q, flow, i))


def hydrodynamic_load_terms(p: VehicleParams, u: float, w: float, q: float, flow: BodyFlow | None = None,
                            i: int = 0) -> tuple[float, float, float]:
    """:func:`hydrodynamic_load_at` as three floats (X, Z, M), for callers that go on in scalars."""
    if not kernels.ENABLED:
        return hydrodynamic_load(p, u, w, q, None if flow is None else flow.stage(i))
    return kernels.hydro_load(p.kernel_params, float(u), float(w), float(q), *_flow_args(flow, i))


_NO_FLOW = (np.zeros(1), np.ones(1), np.zeros((3, 1)))
"""Placeholder flow arrays for the kernels in still water: strips, weights, one zero per stage; never read."""


def _flow_args(flow: BodyFlow | None, i: int | None) -> tuple:
    """The kernels' (has_flow, xs, wts, u, w, ax, az) for ``flow`` at instant i (None: all instants)."""
    if flow is None:
        xs, wts, z = _NO_FLOW
        zi = z if i is None else z[0]
        return False, xs, wts, zi, zi, zi, zi
    if i is None:
        return True, flow.xs, flow.wts, flow.u, flow.w, flow.ax, flow.az
    return (True, *flow.arrays(i))


def state_rates_at(p: VehicleParams, x: np.ndarray, tau, flow: BodyFlow | None = None, i: int = 0) -> np.ndarray:
    """:func:`state_rates` in ``flow`` at its instant i: the compiled kernel, or the reference."""
    if not kernels.ENABLED:
        return state_rates(p, x, tau, None if flow is None else flow.stage(i))
    return kernels.state_rates_arr(p.kernel_params, np.asarray(x, dtype=float), np.asarray(tau, dtype=float),
                                   *_flow_args(flow, i))


def rates_jacobian(p: VehicleParams, x: np.ndarray, tau, flow: BodyFlow | None = None, i: int = 0) -> np.ndarray:
    """A = ∂ẋ/∂x (6, 6) of :func:`state_rates` by forward differences, step 1e-6·max(1, |x_j|)."""
    x = np.asarray(x, dtype=float)
    if kernels.ENABLED:
        return kernels.jacobian_arr(p.kernel_params, x, np.asarray(tau, dtype=float), *_flow_args(flow, i))
    stage = None if flow is None else flow.stage(i)
    f0 = state_rates(p, x, tau, stage)
    A = np.empty((6, 6))
    for j in range(6):
        d = 1e-6 * max(1.0, abs(x[j]))
        xp = x.copy()
        xp[j] += d
        A[:, j] = (state_rates(p, xp, tau, stage) - f0) / d
    return A


def state_rates(p: VehicleParams, x, tau, flow: tuple | None = None) -> np.ndarray:
    """ẋ for x = [η, ν] = [x, z, θ, u, w, q] under the thruster load τ in the flow — paper Eq. 2.

    η̇ = J(η) ν and ν̇ = M⁻¹ (τ + F_h(ν, flow) − C_RB(ν)ν − g(η)), with F_h the
    :func:`hydrodynamic_load`. Written out in scalars: this is the innermost
    call of the plant's RK4 and of the estimator's prediction.
    """
    _, z, th, u, w, q = x.tolist() if isinstance(x, np.ndarray) else x
    X, Z, Mt = tau.tolist() if isinstance(tau, np.ndarray) else tau
    c, s = math.cos(th), math.sin(th)
    (m00, _, m02), (_, m11, m12), _ = p._M_RB_rows
    p_x, p_z = m00 * u + m02 * q, m11 * w + m12 * q          # rigid-body momenta for C_RB(ν)ν
    Xh, Zh, Mh = hydrodynamic_load(p, u, w, q, flow)
    B = p.B if z >= 0.5 * p.height else p.B * submerged_fraction(p, z)
    WB = p.W - B
    BG_z = p.r_G[2] * p.W - p.r_B[2] * B
    BG_x = p.r_G[0] * p.W - p.r_B[0] * B
    r0 = X + Xh - p_z * q - WB * s
    r1 = Z + Zh + p_x * q + WB * c
    r2 = Mt + Mh + p_z * u - p_x * w - BG_z * s - BG_x * c
    (a0, a1, a2), (b0, b1, b2), (c0, c1, c2) = p._M_inv_rows
    return np.array([c * u + s * w, -s * u + c * w, q,
                     a0 * r0 + a1 * r1 + a2 * r2, b0 * r0 + b1 * r1 + b2 * r2, c0 * r0 + c1 * r1 + c2 * r2])


def rk4_step(p: VehicleParams, x: np.ndarray, h: float, tau_stages, flow: BodyFlow | None = None) -> np.ndarray:
    """One classical RK4 step of :func:`state_rates` over h seconds.

    ``tau_stages`` holds the thruster load τ at the stage times t, t + h/2 and
    t + h (three rows) and ``flow`` the fluid at the strips at those instants
    (None: still water), so loads known in closed form (motor lag) or sampled
    in one batch (waves) cost nothing extra per stage. Used by the plant (true
    parameters and sea) and the estimator's prediction (nominal parameters, forecast).
    """
    if kernels.ENABLED:
        return kernels.rk4_arr(p.kernel_params, np.asarray(x, dtype=float), float(h),
                               np.asarray(tau_stages, dtype=float), *_flow_args(flow, None))
    tau0, tau_half, tau1 = tau_stages
    f0, fh, f1 = (None, None, None) if flow is None else (flow.stage(0), flow.stage(1), flow.stage(2))
    k1 = state_rates(p, x, tau0, f0)
    k2 = state_rates(p, x + (0.5 * h) * k1, tau_half, fh)
    k3 = state_rates(p, x + (0.5 * h) * k2, tau_half, fh)
    k4 = state_rates(p, x + h * k3, tau1, f1)
    return x + (h / 6.0) * (k1 + 2.0 * (k2 + k3) + k4)


def motor_lag_stages(f_cmd: np.ndarray, f0: np.ndarray, t_m: float, offsets) -> np.ndarray:
    """Thrust of first-order motors at time offsets s after a command step: f_cmd + (f₀ − f_cmd) e^{−s/t_m}.

    ``offsets`` (S,) in s; returns (S, n) thrusts (N).
    """
    return f_cmd + motor_lag_factors(t_m, offsets) * (f0 - f_cmd)


def motor_lag_factors(t_m: float, offsets) -> np.ndarray:
    """e^{−s/t_m} at the time offsets s (S,), as a column (S, 1): the share of a thrust step still to come.

    For callers that step at fixed offsets and keep them: :func:`motor_lag_stages` is
    ``f_cmd + motor_lag_factors(t_m, offsets) * (f0 − f_cmd)``.
    """
    return np.exp(-np.asarray(offsets, dtype=float) / t_m)[:, None]


def strip_nodes(length: float, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss–Legendre strip positions x' (m, body x) and weights summing to 1 over [−L/2, L/2]."""
    xi, wts = np.polynomial.legendre.leggauss(n)
    return 0.5 * length * xi, 0.5 * wts


def wave_load(p: VehicleParams, waves: WaveComponents, eta, nu, t, strips: tuple[np.ndarray, np.ndarray],
              current_x: float = 0.0):
    """The wave-induced load τ_E (N, N, N m) on a body at pose η moving with ν — paper Eq. 11, completed.

    τ_E = F_h(ν, flow) − F_h(ν, still water) with F_h the :func:`hydrodynamic_load`:
    everything the waves add to the forces of Eq. 2. For ν = 0 it is, strip by
    strip, (ρ∇ + M_A) ν̇_p + (D_L + D_Q|ν_p|) ν_p for surge and heave (the paper's
    Eq. 11 without ρ∇ in the ``paper`` load model) and M_E = −∫ Z_E′(x′) x′ dx′
    + c_θ ū̇_p for pitch (the sign of r × F: a downward load ahead of the centre
    pitches the nose down; the paper prints it without), plus the Munk moment of the flow. ``t`` is a time or
    an array of T times
    (result (3,) or (T, 3)). ``current_x``: a steady current (m/s, NED north), see :func:`body_flow`.
    """
    flow = body_flow(waves, eta, t, strips, current_x)
    u, w, q = (float(v) for v in nu)
    still = hydrodynamic_load_at(p, u, w, q, None)
    out = np.array([hydrodynamic_load_at(p, u, w, q, flow, i) - still for i in range(flow.u.shape[0])])
    return out if np.ndim(t) else out[0]
