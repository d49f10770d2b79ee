"""The complete linear wave load in six DoF: strips over the vehicle's length and beam.

The planar strip model (:func:`bridge.models.vehicle.hydrodynamic_load`, docs/models.md) cut along
the length; here the body is cut into a grid of n_x × n_y strip points r_j = (x_j, y_j, 0) (body
FRD, m; Gauss–Legendre in each direction, weights w_j summing to 1), so that a flow varying across
the beam rolls the vehicle and one varying along it yaws it. At each point the sea's NED velocity
and local acceleration three-vectors are rotated into the body with Rᵀ(Θ): ν_f,j, ν̇_f,j. With the
displaced water ρ∇ and the diagonal added mass A = (X_u̇, Y_v̇, Z_ẇ) spread evenly over the strips
and ν_r,j = ν₁ − ν_f,j the strip's relative velocity, per strip and axis::

    dF_j = w_j [ (ρ∇ + A) ν̇_f,j − (D_L + D_Q |ν_r,j|) ν_r,j ]

Morison's form ρ(1 + C_a)∇_s u̇_f − ρ C_a ∇_s ẍ + drag with C_a ρ∇ = A: its −ρ C_a ∇_s ẍ part is
M_A ν̇, kept on the left of the equations of motion; the drag is the vehicle's identified damping
on the relative velocity, strip by strip. The load on the body (body frame, about the origin)::

    F = Σ dF_j
    M = Σ r_j × dF_j + r_b,z ẑ × ρ∇ ν̄̇_f + M_A[3:, :3] ν̄̇_f − (D_L + D_Q |ω|) ω
    τ_h = [F; M] − C_A(ν̄_r) ν̄_r,    ν̄_r = [ν₁ − Σ w_j ν_f,j; ω]

The strips lie in the origin's plane: the Froude–Krylov force acts at the centre of buoyancy, whose
height z_b gives it a lever (a forward push above the CG pitches the nose down, a push to starboard
above it rolls to port); M_A[3:, :3] holds the added-mass coupling M_u̇ = X_q̇ on the fluid's surge
acceleration. A wave flow is irrotational, so the added mass's rotational rows see no fluid angular
acceleration; the Munk moment −C_A ν acts on the mean relative velocity. In still water τ_h is exactly
−C_A(ν) ν − D(ν) ν. In a head, long-crested sea with the body level it is the planar load in
(X, Z, M) and zero in (Y, K, N) (tested).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .directional_sea import kinematics_xyz
from .rigid_body6 import RigidBody6Params, coriolis_matrix6, rotation_matrix
from .vehicle import strip_nodes
from .waves import WaveComponents

__all__ = ["BodyFlow6", "body_flow6", "hydrodynamic_load6", "strip_grid", "wave_load6"]


def strip_grid(length: float, beam: float, n_x: int, n_y: int) -> tuple[np.ndarray, np.ndarray]:
    """Strip points r_j (S, 3) in body FRD (m), S = n_x n_y, at z = 0, and weights (S,) summing to 1:
    the tensor product of Gauss–Legendre nodes over [−L/2, L/2] and [−b/2, b/2]."""
    if n_x < 1 or n_y < 1:
        raise ValueError(f"need at least one strip each way, got {n_x} × {n_y}")
    xs, wx = strip_nodes(length, n_x)
    ys, wy = strip_nodes(beam, n_y)
    X, Y = np.meshgrid(xs, ys, indexing="ij")
    points = np.stack([X.ravel(), Y.ravel(), np.zeros(X.size)], axis=-1)
    return points, np.outer(wx, wy).ravel()


@dataclass(frozen=True)
class BodyFlow6:
    """The fluid's velocity ``nu_f`` (T, S, 3; m/s) and local acceleration ``a_f`` (T, S, 3; m/s²) at the strip
    points ``points`` (S, 3; m) with weights ``weights`` (S,), in the body frame, at T instants."""

    points: np.ndarray
    weights: np.ndarray
    nu_f: np.ndarray
    a_f: np.ndarray

    @classmethod
    def uniform(cls, strips: tuple[np.ndarray, np.ndarray], nu_f, a_f) -> BodyFlow6:
        """A flow uniform over the body (body frame): one velocity (3,) and acceleration (3,), one instant."""
        points, weights = strips
        S = points.shape[0]
        return cls(points, weights, np.broadcast_to(np.asarray(nu_f, dtype=float), (1, S, 3)),
                   np.broadcast_to(np.asarray(a_f, dtype=float), (1, S, 3)))


def body_flow6(waves: WaveComponents, eta, t, strips: tuple[np.ndarray, np.ndarray],
               current_ned=(0.0, 0.0, 0.0)) -> BodyFlow6:
    """The sea's flow at the strips of a body at pose η = [x, y, z, φ, θ, ψ], at time(s) t (s).

    Strip j sits at the earth point p + R(Θ) r_j; its depth is clipped to [0, d] (a breaching strip feels
    the surface flow, none is below the seabed). ``current_ned`` (m/s) is a steady, depth-uniform current
    added to the waves' velocity. Velocities and accelerations are rotated into the body with Rᵀ(Θ).
    """
    points, weights = strips
    eta = np.asarray(eta, dtype=float)
    R = rotation_matrix(eta[3], eta[4], eta[5])
    earth = eta[:3] + points @ R.T
    depth = np.clip(earth[:, 2], 0.0, waves.water_depth)
    vel, acc = kinematics_xyz(waves, earth[:, 0], earth[:, 1], depth, t)      # (T, S, 3) NED
    vel = vel + np.asarray(current_ned, dtype=float)
    return BodyFlow6(points, weights, vel @ R, acc @ R)                      # vᵀ R = (Rᵀ v)ᵀ


def hydrodynamic_load6(p: RigidBody6Params, nu, flow: BodyFlow6 | None = None, i: int = 0) -> np.ndarray:
    """τ_h (6,): the hydrodynamic load on the body moving with ν in ``flow`` at its instant i (None: still
    water), excluding −M_A ν̇ (N, N m; body frame, about the origin). See the module docstring."""
    nu = np.asarray(nu, dtype=float)
    nu1, omega = nu[:3], nu[3:]
    DL, DQ = p.linear_damping, p.quadratic_damping
    load = np.zeros(6)
    if flow is None:
        nu_r_bar = nu1
        load[:3] = -(DL[:3] + DQ[:3] * np.abs(nu1)) * nu1
    else:
        w = flow.weights
        vf, af = flow.nu_f[i], flow.a_f[i]                                   # (S, 3)
        vr = nu1 - vf
        dF = w[:, None] * ((p.fk_mass + p.added_mass[:3]) * af - (DL[:3] + DQ[:3] * np.abs(vr)) * vr)
        load[:3] = dF.sum(axis=0)
        load[3:] = np.cross(flow.points, dF).sum(axis=0)
        a_bar = w @ af
        if p.wave_load_model == "complete":   # the Froude–Krylov force's lever at z_b, the added-mass coupling
            z_fk = p.r_B[2] * p.rho_V                                      # ẑ z_b × ρ∇ ā = z_b ρ∇ (−ā_y, ā_x, 0)
            load[3:] += np.array([-z_fk * a_bar[1], z_fk * a_bar[0], 0.0]) + p.M_A[3:, :3] @ a_bar
        nu_r_bar = nu1 - w @ vf
    load[3:] -= (DL[3:] + DQ[3:] * np.abs(omega)) * omega
    nu_r = np.concatenate([nu_r_bar, omega])
    return load - coriolis_matrix6(p.M_A, nu_r) @ nu_r


def wave_load6(p: RigidBody6Params, waves: WaveComponents, eta, nu, t, strips: tuple[np.ndarray, np.ndarray],
               current_ned=(0.0, 0.0, 0.0)) -> np.ndarray:
    """τ_wave (6,) or (T, 6): what the sea adds to the still-water load, τ_h(ν, flow) − τ_h(ν, still water),
    on a body at pose η moving with ν, at a time or an array of T times (s)."""
    flow = body_flow6(waves, eta, t, strips, current_ned)
    still = hydrodynamic_load6(p, nu, None)
    out = np.array([hydrodynamic_load6(p, nu, flow, i) - still for i in range(flow.nu_f.shape[0])])
    return out if np.ndim(t) else out[0]
