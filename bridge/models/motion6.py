"""The six-DoF equations of motion: the state's rates and one RK4 step, and the planar limit.

x = [η; ν] (12,) with η = [x, y, z, φ, θ, ψ] (NED m, zyx Euler rad) and ν = [u, v, w, p, q, r] (body
FRD m/s, rad/s)::

    η̇ = J(η) ν
    ν̇ = M⁻¹ (τ + τ_h(ν, flow) − C_RB(ν) ν − g(η))

τ (6,) is the thrusters' (and any other prescribed) load, τ_h the hydrodynamic load of
:func:`~bridge.models.strip_load6.hydrodynamic_load6`: in still water −C_A(ν)ν − D(ν)ν, in a sea
that plus τ_wave (:func:`~bridge.models.strip_load6.wave_load6`), so that ẋ = f(x, τ, τ_wave).

The step keeps the planar plant's discipline (:func:`bridge.models.vehicle.rk4_step`): τ is given at
the stage times t, t + h/2, t + h and the flow sampled at those instants for the pose at the start of
the step (one batched evaluation serves the four stages).
"""
from __future__ import annotations

import math

import numpy as np

from .rigid_body6 import RigidBody6Params, coriolis_matrix6, kinematics_J, restoring_forces6
from .strip_load6 import BodyFlow6, hydrodynamic_load6

__all__ = ["LATERAL_DOFS", "PLANAR_DOFS", "from_planar", "from_planes", "rk4_step6", "specific_force6",
           "state_derivative6", "to_lateral", "to_planar"]

PLANAR_DOFS = (0, 2, 4)
"""Indices of (x, z, θ) in η and of (u, w, q) in ν: the planar model's degrees of freedom."""

LATERAL_DOFS = (1, 3, 5)
"""Indices of (y, φ, ψ) in η and of (v, p, r) in ν: the lateral-directional degrees of freedom. For a body
symmetric port to starboard, level and at rest, the linearised motion splits exactly into these and the
planar ones (the longitudinal plane)."""

_PLANAR_STATE = np.array([0, 2, 4, 6, 8, 10])   # (x, z, θ, u, w, q) in x = [η; ν]
_LATERAL_STATE = np.array([1, 3, 5, 7, 9, 11])  # (y, φ, ψ, v, p, r) in x = [η; ν]


def state_derivative6(p: RigidBody6Params, x, tau, flow: BodyFlow6 | None = None, i: int = 0) -> np.ndarray:
    """ẋ (12,) for x = [η; ν] under the load τ (6,; N, N m) in ``flow`` at its instant i (None: still water)."""
    x = np.asarray(x, dtype=float)
    eta, nu = x[:6], x[6:]
    rhs = (np.asarray(tau, dtype=float) + hydrodynamic_load6(p, nu, flow, i)
           - coriolis_matrix6(p.M_RB, nu) @ nu - restoring_forces6(p, eta))
    return np.concatenate([kinematics_J(eta) @ nu, p.M_inv @ rhs])


def rk4_step6(p: RigidBody6Params, x, h: float, tau_stages, flow: BodyFlow6 | None = None) -> np.ndarray:
    """One classical RK4 step of :func:`state_derivative6` over h seconds.

    ``tau_stages`` (3, 6): τ at t, t + h/2 and t + h; ``flow``: the fluid at the strips at those three
    instants (:func:`~bridge.models.strip_load6.body_flow6` at t + [0, h/2, h]), or None for still water.
    """
    x = np.asarray(x, dtype=float)
    tau0, tau_half, tau1 = np.asarray(tau_stages, dtype=float)
    f = (lambda i: (flow, i)) if flow is not None else (lambda i: (None, 0))
    k1 = state_derivative6(p, x, tau0, *f(0))
    k2 = state_derivative6(p, x + (0.5 * h) * k1, tau_half, *f(1))
    k3 = state_derivative6(p, x + (0.5 * h) * k2, tau_half, *f(1))
    k4 = state_derivative6(p, x + h * k3, tau1, *f(2))
    return x + (h / 6.0) * (k1 + 2.0 * (k2 + k3) + k4)


def from_planar(x3) -> np.ndarray:
    """The six-DoF state (12,) of a planar state [x, z, θ, u, w, q]: y, φ, ψ, v, p, r = 0."""
    x = np.zeros(12)
    x[_PLANAR_STATE] = np.asarray(x3, dtype=float)
    return x


def to_planar(x6) -> np.ndarray:
    """The planar part [x, z, θ, u, w, q] of a six-DoF state or its rates (12,)."""
    return np.asarray(x6, dtype=float)[_PLANAR_STATE]


def to_lateral(x6) -> np.ndarray:
    """The lateral-directional part [y, φ, ψ, v, p, r] of a six-DoF state or its rates (12,)."""
    return np.asarray(x6, dtype=float)[_LATERAL_STATE]


def from_planes(x_planar, x_lateral) -> np.ndarray:
    """The six-DoF state (12,) of its planar part [x, z, θ, u, w, q] and lateral part [y, φ, ψ, v, p, r]."""
    x = np.empty(12)
    x[_PLANAR_STATE] = np.asarray(x_planar, dtype=float)
    x[_LATERAL_STATE] = np.asarray(x_lateral, dtype=float)
    return x


def specific_force6(eta, nu, nu_dot, g: float) -> list[float]:
    """What a body-fixed accelerometer at the origin reads (m/s², body FRD): ν̇₁ + ω × ν₁ − Rᵀ(Θ) [0, 0, g],
    for η (6,), ν (6,) and ν̇ (6,) (≈ [0, 0, −g] at rest). On Python floats: the JSON SITL state's
    ``imu.accel_body`` and the in-process HAL's accelerometer are this one function."""
    _x, _y, _z, phi, theta, _psi = (float(c) for c in eta)
    u, v, w, p, q, r = (float(c) for c in nu)
    du, dv, dw = (float(c) for c in nu_dot[:3])
    sf, cf, st, ct = math.sin(phi), math.cos(phi), math.sin(theta), math.cos(theta)
    return [du + q * w - r * v + g * st, dv + r * u - p * w - g * ct * sf, dw + p * v - q * u - g * ct * cf]
