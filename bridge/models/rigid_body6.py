"""Fossen's six-DoF vehicle model of the BlueROV2 Heavy: rigid body, added mass, damping, restoring, kinematics.

    η̇ = J(η) ν
    M ν̇ + C(ν) ν + D(ν) ν + g(η) = τ + τ_wave,     M = M_RB + M_A,  C = C_RB + C_A

η = [x, y, z, φ, θ, ψ]: NED position of the body origin (m; z is depth, positive down) and the
zyx Euler angles roll, pitch, yaw (rad). ν = [u, v, w, p, q, r]: body FRD linear velocity (m/s)
and angular velocity (rad/s). τ = [X, Y, Z, K, M, N]: body-frame force (N) and moment about the
body origin (N m). The body origin is the centre of gravity in the shipped vehicle (r_g = 0).

Added-mass and damping coefficients are stored as positive numbers (the magnitudes of Fossen's
hydrodynamic derivatives: X_u̇ here is −X_u̇ in Fossen's notation), so M_A = diag(X_u̇, Y_v̇, Z_ẇ,
K_ṗ, M_q̇, N_ṙ) with the surge–pitch coupling X_q̇ = M_u̇ at (0, 4) and (4, 0), as in the planar
model (:mod:`bridge.models.vehicle`), and D(ν) = D_L + D_Q |ν| diagonal.

With y, φ, ψ, v, p, r = 0 and the off-plane loads zero this is the planar model's Eq. 2 in
(x, z, θ, u, w, q): :attr:`RigidBody6Params.planar` is that planar model, and tests hold the two
to each other. The rates and the RK4 step are in :mod:`bridge.models.motion6`, the wave load in
:mod:`bridge.models.strip_load6`.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .vehicle import RHO_SEAWATER, WAVE_LOAD_MODELS, VehicleParams, submerged_fraction
from .waves import G

__all__ = ["RigidBody6Params", "coriolis_matrix6", "damping_matrix6", "euler_rate_matrix", "kinematics_J",
           "kinetic_energy", "restoring_forces6", "rigid_body_mass", "rotation_matrix", "skew"]


def skew(a) -> np.ndarray:
    """S(a), the skew-symmetric cross-product matrix: S(a) b = a × b (Fossen 2011, Eq. 2.9)."""
    a1, a2, a3 = (float(v) for v in a)
    return np.array([[0.0, -a3, a2], [a3, 0.0, -a1], [-a2, a1, 0.0]])


@dataclass(frozen=True)
class RigidBody6Params:
    """The six-DoF parameters (SI units, body FRD, origin at the body's reference point).

    Inertias I_x, I_y, I_z are about the centre of gravity (principal axes along the body's); the
    rigid-body mass matrix about the origin follows by the parallel-axis theorem. ``length`` and
    ``beam`` (m) span the strips of the wave load; ``height`` (m) is the band over which the
    buoyancy fades when the vehicle breaches (as the planar model).
    """

    W: float                 # weight (N)
    B: float                 # buoyancy (N)
    I_x: float               # roll inertia about the CG (kg m²)
    I_y: float               # pitch inertia about the CG (kg m²)
    I_z: float               # yaw inertia about the CG (kg m²)
    r_G: np.ndarray          # centre of gravity, body FRD (m)
    r_B: np.ndarray          # centre of buoyancy, body FRD (m); z < 0 is above the origin
    length: float            # body length (m), body x
    beam: float              # body beam (m), body y
    height: float            # body height (m)
    added_mass: np.ndarray   # [X_u̇, Y_v̇, Z_ẇ, K_ṗ, M_q̇, N_ṙ] (kg, kg m²)
    X_qdot: float            # surge–pitch coupling X_q̇ = M_u̇ (kg m)
    linear_damping: np.ndarray     # [X_u, Y_v, Z_w, K_p, M_q, N_r] (kg/s, kg m²/s)
    quadratic_damping: np.ndarray  # [X_u|u|, Y_v|v|, Z_w|w|, K_p|p|, M_q|q|, N_r|r|] (N s²/m², N m s²)
    g: float = G
    displaced_volume: float | None = None   # ∇ (m³); None: B / (ρ g)
    water_density: float = RHO_SEAWATER     # ρ (kg/m³)
    wave_load_model: str = "complete"       # one of WAVE_LOAD_MODELS
    M_RB: np.ndarray = field(init=False, repr=False)
    M_A: np.ndarray = field(init=False, repr=False)
    M: np.ndarray = field(init=False, repr=False)
    M_inv: np.ndarray = field(init=False, repr=False)
    planar: VehicleParams = field(init=False, repr=False)

    def __post_init__(self) -> None:
        for name in ("r_G", "r_B", "added_mass", "linear_damping", "quadratic_damping"):
            object.__setattr__(self, name, np.array(getattr(self, name), dtype=float))
        if self.wave_load_model not in WAVE_LOAD_MODELS:
            raise ValueError(f"wave_load_model must be one of {', '.join(WAVE_LOAD_MODELS)}, "
                             f"got {self.wave_load_model!r}")
        M_RB = rigid_body_mass(self.mass, np.diag([self.I_x, self.I_y, self.I_z]), self.r_G)
        M_A = np.diag(self.added_mass)
        M_A[0, 4] = M_A[4, 0] = self.X_qdot
        M = M_RB + M_A
        for name, value in (("M_RB", M_RB), ("M_A", M_A), ("M", M), ("M_inv", np.linalg.inv(M))):
            object.__setattr__(self, name, value)
        object.__setattr__(self, "planar", self._planar())

    @property
    def mass(self) -> float:
        """Dry mass m = W / g (kg)."""
        return self.W / self.g

    @property
    def rho_V(self) -> float:
        """ρ∇ (kg): the displaced water's mass, ρ · ``displaced_volume``, or B / g when the volume is not stated."""
        return self.B / self.g if self.displaced_volume is None else self.water_density * self.displaced_volume

    @property
    def fk_mass(self) -> float:
        """The Froude–Krylov mass on the fluid's acceleration (kg): ρ∇, or 0 in the paper's load model."""
        return self.rho_V if self.wave_load_model == "complete" else 0.0

    def _planar(self) -> VehicleParams:
        """The planar (surge, heave, pitch) model of the same vehicle: pitch inertia about the origin,
        the x–z coefficients; what the six-DoF model reduces to in the vertical plane."""
        A, DL, DQ = self.added_mass, self.linear_damping, self.quadratic_damping
        return VehicleParams(W=self.W, B=self.B, I_y=float(self.M_RB[4, 4]), r_G=self.r_G.copy(),
                             r_B=self.r_B.copy(), length=self.length, height=self.height, X_udot=A[0],
                             Z_wdot=A[2], M_qdot=A[4], X_qdot=self.X_qdot, X_u=DL[0], Z_w=DL[2], M_q=DL[4],
                             X_uu=DQ[0], Z_ww=DQ[2], M_qq=DQ[4], g=self.g, displaced_volume=self.displaced_volume,
                             water_density=self.water_density, wave_load_model=self.wave_load_model)

    @classmethod
    def from_config(cls, cfg: dict) -> RigidBody6Params:
        """Build from a validated six-DoF vehicle config (:mod:`bridge.models.vehicle6_config`)."""
        mp, am, dp = cfg["mass_properties"], cfg["added_mass"], cfg["damping"]
        dofs = (("X_u", "X_uu"), ("Y_v", "Y_vv"), ("Z_w", "Z_ww"), ("K_p", "K_pp"), ("M_q", "M_qq"), ("N_r", "N_rr"))
        return cls(W=mp["W"], B=mp["B"], I_x=mp["I_x"], I_y=mp["I_y"], I_z=mp["I_z"], r_G=np.array(mp["r_G"]),
                   r_B=np.array(mp["r_B"]), length=mp["length"], beam=mp["beam"], height=mp["height"],
                   added_mass=np.array([am[k] for k in ("X_udot", "Y_vdot", "Z_wdot", "K_pdot", "M_qdot", "N_rdot")]),
                   X_qdot=am["X_qdot"], linear_damping=np.array([dp[a] for a, _ in dofs]),
                   quadratic_damping=np.array([dp[b] for _, b in dofs]), displaced_volume=mp.get("displaced_volume"),
                   water_density=mp["water_density"])


def rigid_body_mass(m: float, I_g: np.ndarray, r_g) -> np.ndarray:
    """M_RB (6, 6) about the body origin (Fossen 2011, Eq. 3.44) for mass m (kg), inertia I_g (3, 3) about
    the CG (kg m²) and the CG at r_g (m): [[m I, −m S(r_g)], [m S(r_g), I_g − m S(r_g)²]]."""
    S = skew(r_g)
    return np.block([[m * np.eye(3), -m * S], [m * S, I_g - m * S @ S]])


def coriolis_matrix6(M: np.ndarray, nu) -> np.ndarray:
    """C(ν) (6, 6) of a mass matrix M by its momenta (Fossen 2011, Thm 3.2 and Eq. 6.43).

    With [P₁; P₂] = M ν: C = [[0, −S(P₁)], [−S(P₁), −S(P₂)]], so C(ν) ν = [ω × P₁; ν₁ × P₁ + ω × P₂].
    Skew-symmetric for any symmetric M: νᵀ C ν = 0, it does no work. C_RB = C(M_RB), C_A = C(M_A); in
    C_A the ν₁ × P₁ moment is the Munk moment, e.g. (Z_ẇ − X_u̇) u w in pitch, (X_u̇ − Y_v̇) u v in yaw.
    """
    P = M @ np.asarray(nu, dtype=float)
    C = np.zeros((6, 6))
    C[:3, 3:] = C[3:, :3] = -skew(P[:3])
    C[3:, 3:] = -skew(P[3:])
    return C


def damping_matrix6(p: RigidBody6Params, nu) -> np.ndarray:
    """D(ν) = D_L + D_Q |ν| (6, 6), diagonal (kg/s, kg m²/s)."""
    return np.diag(p.linear_damping + p.quadratic_damping * np.abs(np.asarray(nu, dtype=float)))


def restoring_forces6(p: RigidBody6Params, eta) -> np.ndarray:
    """g(η) (6,): hydrostatic restoring forces and moments in the body frame (Fossen 2011, Eq. 4.6).

    Weight W at r_g and buoyancy B at r_b, both vertical in NED, as body-frame loads; the buoyancy
    fades over the body's height as it breaches (:func:`bridge.models.vehicle.submerged_fraction`).
    For a submerged body with the centre of buoyancy a height BG above the CG (the origin) the roll
    and pitch moments are B·BG sin φ cos θ and B·BG sin θ: the metacentric restoring of a submerged
    body, whose metacentre is its centre of buoyancy.
    """
    _, _, z, phi, th, _ = (float(v) for v in eta)
    W, B = p.W, p.B * submerged_fraction(p.planar, z)
    sf, cf, st, ct = np.sin(phi), np.cos(phi), np.sin(th), np.cos(th)
    (xg, yg, zg), (xb, yb, zb) = p.r_G, p.r_B
    return np.array([
        (W - B) * st,
        -(W - B) * ct * sf,
        -(W - B) * ct * cf,
        -(yg * W - yb * B) * ct * cf + (zg * W - zb * B) * ct * sf,
        (zg * W - zb * B) * st + (xg * W - xb * B) * ct * cf,
        -(xg * W - xb * B) * ct * sf - (yg * W - yb * B) * st,
    ])


def rotation_matrix(phi: float, theta: float, psi: float) -> np.ndarray:
    """R(Θ) (3, 3) from body FRD to NED for zyx Euler angles (rad): R = R_z(ψ) R_y(θ) R_x(φ) (Fossen Eq. 2.18)."""
    cf, sf, ct, st, cp, sp = np.cos(phi), np.sin(phi), np.cos(theta), np.sin(theta), np.cos(psi), np.sin(psi)
    return np.array([
        [cp * ct, -sp * cf + cp * st * sf, sp * sf + cp * cf * st],
        [sp * ct, cp * cf + sf * st * sp, -cp * sf + st * sp * cf],
        [-st, ct * sf, ct * cf],
    ])


def euler_rate_matrix(phi: float, theta: float) -> np.ndarray:
    """T(Θ) (3, 3): body angular velocity [p, q, r] → Euler angle rates [φ̇, θ̇, ψ̇] (Fossen Eq. 2.29);
    singular at θ = ±90°."""
    cf, sf, ct, tt = np.cos(phi), np.sin(phi), np.cos(theta), np.tan(theta)
    return np.array([[1.0, sf * tt, cf * tt], [0.0, cf, -sf], [0.0, sf / ct, cf / ct]])


def kinematics_J(eta) -> np.ndarray:
    """J(η) (6, 6) = diag(R(Θ), T(Θ)): η̇ = J(η) ν (Fossen 2011, Eq. 2.40)."""
    phi, th, psi = (float(v) for v in np.asarray(eta, dtype=float)[3:6])
    J = np.zeros((6, 6))
    J[:3, :3] = rotation_matrix(phi, th, psi)
    J[3:, 3:] = euler_rate_matrix(phi, th)
    return J


def kinetic_energy(p: RigidBody6Params, nu) -> float:
    """½ νᵀ M ν (J): the kinetic energy of the body and of the water it carries (added mass)."""
    nu = np.asarray(nu, dtype=float)
    return float(0.5 * nu @ p.M @ nu)
