"""The vehicle's out-of-plane motion: sway, roll and yaw, for autopilots that control all six DoF.

Wavekeep's plant is planar (surge, heave, pitch: the paper's model). A foreign
autopilot such as ArduSub holds heading, roll and the lateral position too; if
those never respond (a planar world reports them as zero) its integrators wind
up and its horizontal thrusters creep, spending authority that surge needs.
This module closes those loops with the simplest honest model: each of sway,
roll and yaw is a decoupled rigid body + added mass + linear and quadratic
damping (Fossen 2011, the diagonal terms), roll with its hydrostatic
restoring moment, driven by the thrusters' Y, K and N (the layout's wrench
matrix). The waves are long-crested along north (head seas), so they load none
of these DoFs; the planar motion enters only through the kinematics.

State ``[y, φ, ψ, v, p, r]``: east position (m, NED), roll and yaw (rad, ZYX
Euler angles), body sway velocity (m/s) and body roll and yaw rates (rad/s).
The planar states (θ, u, w, q) are held over a step. Euler rates follow the
exact kinematics φ̇ = p + tan θ (q sin φ + r cos φ), ψ̇ = (q sin φ + r cos φ)/cos θ;
the east velocity is the second row of R(φ, θ, ψ) ν. The planar plant keeps x
along north: with the autopilot holding heading the yaw stays small, and the
north position's error from it is second order in ψ.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["LateralModel", "LateralParams"]


@dataclass(frozen=True)
class LateralParams:
    """Sway, roll and yaw coefficients (positive added-mass and damping convention)."""

    mass: float        # kg (W / g)
    I_x: float         # kg m²
    I_z: float         # kg m²
    Y_vdot: float      # kg
    K_pdot: float      # kg m²
    N_rdot: float      # kg m²
    Y_v: float         # kg/s
    K_p: float         # kg m²/s
    N_r: float         # kg m²/s
    Y_vv: float        # N s²/m²
    K_pp: float        # N m s²
    N_rr: float        # N m s²
    W: float           # weight (N)
    B: float           # buoyancy (N)
    z_G: float         # centre of gravity, body z (m)
    z_B: float         # centre of buoyancy, body z (m; negative: above the origin)

    @classmethod
    def from_config(cls, cfg: dict, g: float) -> LateralParams:
        """From a validated vehicle config (``lateral`` section and the mass properties)."""
        mp, lat = cfg["mass_properties"], cfg["lateral"]
        return cls(mass=mp["W"] / g, I_x=lat["I_x"], I_z=lat["I_z"], Y_vdot=lat["Y_vdot"], K_pdot=lat["K_pdot"],
                   N_rdot=lat["N_rdot"], Y_v=lat["Y_v"], K_p=lat["K_p"], N_r=lat["N_r"], Y_vv=lat["Y_vv"],
                   K_pp=lat["K_pp"], N_rr=lat["N_rr"], W=mp["W"], B=mp["B"], z_G=mp["r_G"][2], z_B=mp["r_B"][2])


class LateralModel:
    """Integrates ``[y, φ, ψ, v, p, r]`` beside the planar plant; ``state`` and ``rates`` after each step."""

    def __init__(self, params: LateralParams, wrench_rows: np.ndarray):
        self.p = params
        self.rows = np.asarray(wrench_rows, dtype=float)      # 3×n: unit thrusts → [Y, K, N]
        self.state = np.zeros(6)
        self.rates = np.zeros(6)                               # ẋ at the end of the last step

    def reset(self) -> None:
        self.state = np.zeros(6)
        self.rates = np.zeros(6)

    def _rates(self, s: np.ndarray, planar: tuple[float, float, float, float], tau: np.ndarray) -> np.ndarray:
        """ẋ of the state s under the planar motion (θ, u, w, q) and the thrusters' [Y, K, N]."""
        p = self.p
        theta, u, w, q = planar
        _, phi, psi, v, rp, r = s.tolist()
        sf, cf, st, ct = math.sin(phi), math.cos(phi), math.sin(theta), math.cos(theta)
        sp, cp = math.sin(psi), math.cos(psi)
        # g(η), Fossen 2011 Eq. 4.6: sway −(W − B) cos θ sin φ, roll −(y_G W − y_B B) … + (z_G W − z_B B) cos θ sin φ
        g_y = -(p.W - p.B) * ct * sf
        g_k = (p.z_G * p.W - p.z_B * p.B) * ct * sf
        v_dot = (tau[0] - p.Y_v * v - p.Y_vv * v * abs(v) - g_y) / (p.mass + p.Y_vdot)
        p_dot = (tau[1] - p.K_p * rp - p.K_pp * rp * abs(rp) - g_k) / (p.I_x + p.K_pdot)
        r_dot = (tau[2] - p.N_r * r - p.N_rr * r * abs(r)) / (p.I_z + p.N_rdot)
        turn = q * sf + r * cf
        phi_dot = rp + st / ct * turn
        psi_dot = turn / ct
        east = u * ct * sp + v * (sf * st * sp + cf * cp) + w * (cf * st * sp - sf * cp)
        return np.array([east, phi_dot, psi_dot, v_dot, p_dot, r_dot])

    def step(self, planar: tuple[float, float, float, float], thrust0: np.ndarray, thrust1: np.ndarray,
             dt: float) -> np.ndarray:
        """Advance dt seconds (one RK4 step) with the thrusts going linearly from ``thrust0`` to ``thrust1`` (N)."""
        t0, t1 = self.rows @ np.asarray(thrust0, dtype=float), self.rows @ np.asarray(thrust1, dtype=float)
        th = 0.5 * (t0 + t1)
        s = self.state
        k1 = self._rates(s, planar, t0)
        k2 = self._rates(s + 0.5 * dt * k1, planar, th)
        k3 = self._rates(s + 0.5 * dt * k2, planar, th)
        k4 = self._rates(s + dt * k3, planar, t1)
        self.state = s + (dt / 6.0) * (k1 + 2.0 * (k2 + k3) + k4)
        self.rates = self._rates(self.state, planar, t1)
        return self.state
