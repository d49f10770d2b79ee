"""The six-DoF rigid body (bridge.models.rigid_body6, motion6) against closed forms worked out by hand.

Each truth here is independent of the code: linear ODE solutions, the parallel-axis theorem, the
Munk moment of slender-body theory, the Kirchhoff invariants of a body in an ideal fluid, the
kinematics identity Ṙ = R S(ω), and the planar model of bridge.models.vehicle (the six-DoF model's
limit in the vertical plane).
"""
from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from bridge.configfile import ConfigError
from bridge.models import vehicle
from bridge.models.motion6 import from_planar, rk4_step6, state_derivative6, to_planar
from bridge.models.rigid_body6 import (
    RigidBody6Params,
    coriolis_matrix6,
    euler_rate_matrix,
    kinetic_energy,
    restoring_forces6,
    rotation_matrix,
)
from bridge.models.strip_load6 import body_flow6, hydrodynamic_load6, strip_grid
from bridge.models.vehicle6_config import load_rigid_body6
from bridge.models.waves import WaveComponents

DEFAULT = load_rigid_body6()
ZERO6 = np.zeros(6)


def _simulate(p: RigidBody6Params, x0, h: float, n: int) -> np.ndarray:
    """States (n + 1, 12) of n still-water, unforced RK4 steps."""
    xs = [np.asarray(x0, dtype=float)]
    tau = np.zeros((3, 6))
    for _ in range(n):
        xs.append(rk4_step6(p, xs[-1], h, tau))
    return np.array(xs)


def _free(p: RigidBody6Params, **kw) -> RigidBody6Params:
    """p neutrally buoyant with only linear damping (the given one), no coupling, unless kw says otherwise."""
    base = dict(B=p.W, quadratic_damping=np.zeros(6), X_qdot=0.0, r_B=np.zeros(3))
    base.update(kw)
    return replace(p, **base)


# ---------------------------------------------------------------------------- matrices

def test_the_config_loads_with_the_planar_values_of_table_ii():
    p = DEFAULT
    assert (p.W, p.B, p.I_y, p.X_qdot) == (112.8, 114.8, 0.253, 0.67)
    assert p.r_B.tolist() == [0.0, 0.0, -0.028]
    assert p.added_mass.tolist() == [6.36, 7.12, 18.68, 0.189, 0.135, 0.222]
    planar = vehicle.VehicleParams.load("bluerov2_heavy")
    np.testing.assert_array_equal(p.planar.M, planar.M)       # the planar world's own vehicle, exactly
    for k in ("X_u", "Z_w", "M_q", "X_uu", "Z_ww", "M_qq", "W", "B", "length", "height", "rho_V"):
        assert getattr(p.planar, k) == getattr(planar, k), k


def test_mass_matrix_is_symmetric_positive_definite_with_the_parallel_axis_terms():
    r_g = np.array([0.01, -0.02, 0.03])
    p = replace(DEFAULT, r_G=r_g)
    m = p.mass
    np.testing.assert_allclose(p.M, p.M.T, atol=0.0)
    assert np.linalg.eigvalsh(p.M).min() > 0.0
    # by hand: the force of an angular acceleration is m α × r_g, and the inertia about the origin
    # I_o = I_g + m (|r_g|² 1 − r_g r_gᵀ)
    I_o = np.diag([p.I_x, p.I_y, p.I_z]) + m * (r_g @ r_g * np.eye(3) - np.outer(r_g, r_g))
    np.testing.assert_allclose(p.M_RB[3:, 3:], I_o, rtol=1e-14)
    for j in range(3):
        alpha = np.eye(3)[j]
        np.testing.assert_allclose(p.M_RB[:3, 3 + j], m * np.cross(alpha, r_g), atol=1e-15)


@pytest.mark.parametrize("seed", range(5))
def test_coriolis_is_skew_symmetric_and_does_no_work(seed):
    nu = np.random.default_rng(seed).normal(size=6)
    p = replace(DEFAULT, r_G=np.array([0.01, 0.02, 0.015]))
    for M in (p.M_RB, p.M_A, p.M):
        C = coriolis_matrix6(M, nu)
        np.testing.assert_allclose(C + C.T, 0.0, atol=1e-15)
        assert abs(nu @ C @ nu) < 1e-13


def test_rotation_is_the_zyx_composition_and_euler_rates_integrate_the_body_rate():
    phi, th, psi = 0.3, -0.4, 1.2
    Rx = np.array([[1, 0, 0], [0, math.cos(phi), -math.sin(phi)], [0, math.sin(phi), math.cos(phi)]])
    Ry = np.array([[math.cos(th), 0, math.sin(th)], [0, 1, 0], [-math.sin(th), 0, math.cos(th)]])
    Rz = np.array([[math.cos(psi), -math.sin(psi), 0], [math.sin(psi), math.cos(psi), 0], [0, 0, 1]])
    R = rotation_matrix(phi, th, psi)
    np.testing.assert_allclose(R, Rz @ Ry @ Rx, atol=1e-15)
    # Ṙ = R S(ω): the Euler rates T(Θ) ω move R as the body rate ω does (central difference)
    omega, h = np.array([0.2, -0.5, 0.7]), 1e-6
    d = h * euler_rate_matrix(phi, th) @ omega
    dR = (rotation_matrix(phi + d[0], th + d[1], psi + d[2]) - rotation_matrix(phi - d[0], th - d[1], psi - d[2]))
    S = np.array([[0, -omega[2], omega[1]], [omega[2], 0, -omega[0]], [-omega[1], omega[0], 0]])
    np.testing.assert_allclose(dR / (2 * h), R @ S, atol=1e-8)


def test_restoring_is_the_weight_and_buoyancy_at_their_points_in_the_body_frame():
    p = replace(DEFAULT, r_G=np.array([0.01, -0.005, 0.02]), r_B=np.array([-0.02, 0.01, -0.03]))
    eta = np.array([0.0, 0.0, 5.0, 0.3, -0.2, 0.9])
    R = rotation_matrix(*eta[3:])
    down = R.T @ np.array([0.0, 0.0, 1.0])            # NED down in the body frame
    f_w, f_b = p.W * down, -p.B * down
    load = np.concatenate([f_w + f_b, np.cross(p.r_G, f_w) + np.cross(p.r_B, f_b)])
    np.testing.assert_allclose(restoring_forces6(p, eta), -load, atol=1e-13)


# ---------------------------------------------------------------------------- free motion, closed forms

@pytest.mark.parametrize("dof, damping", [(0, 13.7), (1, 5.0), (2, 33.0), (5, 0.4)])
def test_free_decay_without_restoring_is_exponential(dof, damping):
    """ν_i(t) = ν_i(0) exp(−d_i t / M_ii): surge, sway, heave, yaw with linear damping only."""
    DL = np.zeros(6)
    DL[dof] = damping
    p = _free(DEFAULT, linear_damping=DL)
    x0 = np.zeros(12)
    x0[2] = 5.0
    x0[6 + dof] = 0.4
    h, n = 0.01, 500
    xs = _simulate(p, x0, h, n)
    t = h * np.arange(n + 1)
    expected = 0.4 * np.exp(-damping * t / p.M[dof, dof])
    np.testing.assert_allclose(xs[:, 6 + dof], expected, rtol=1e-9)
    others = np.delete(xs[:, 6:], dof, axis=1)
    assert np.abs(others).max() < 1e-12


@pytest.mark.parametrize("dof", [0, 1, 2, 5])
def test_free_decay_under_quadratic_damping_is_hyperbolic(dof):
    """M_ii ν̇ = −d_q ν|ν|: ν(t) = ν0 / (1 + d_q ν0 t / M_ii), with the BlueROV2's quadratic coefficients."""
    DQ = np.zeros(6)
    DQ[dof] = DEFAULT.quadratic_damping[dof]
    p = _free(DEFAULT, linear_damping=np.zeros(6), quadratic_damping=DQ)
    x0 = np.zeros(12)
    x0[2], x0[6 + dof] = 5.0, 0.5
    h, n = 0.005, 600                      # RK4's error at d_q ν0 / M_ii ≈ 4 /s (surge): ~5e-9
    xs = _simulate(p, x0, h, n)
    expected = 0.5 / (1.0 + DQ[dof] * 0.5 * h * np.arange(n + 1) / p.M[dof, dof])
    np.testing.assert_allclose(xs[:, 6 + dof], expected, rtol=1e-8)


def test_still_water_load_is_minus_the_added_mass_coriolis_and_the_damping():
    """τ_h(ν, still water) = −C_A(ν) ν − D(ν) ν (Fossen's Eq. 6.1 terms), at arbitrary velocities."""
    from bridge.models.rigid_body6 import damping_matrix6
    for seed in range(3):
        nu = np.random.default_rng(seed).normal(size=6)
        want = -coriolis_matrix6(DEFAULT.M_A, nu) @ nu - damping_matrix6(DEFAULT, nu) @ nu
        np.testing.assert_allclose(hydrodynamic_load6(DEFAULT, nu), want, atol=1e-13)


@pytest.mark.parametrize("dof, inertia, damping", [(3, "I_x", 0.3), (4, "I_y", 0.8)])
def test_roll_and_pitch_free_decay_is_the_damped_hydrostatic_oscillation(dof, inertia, damping):
    """(I + A) φ̈ + d φ̇ + W·BG φ = 0, φ(0) = φ0, φ̇(0) = 0: φ0 e^{−σt} (cos ω_d t + σ/ω_d sin ω_d t)."""
    DL = np.zeros(6)
    DL[dof] = damping
    p = _free(DEFAULT, linear_damping=DL, r_B=np.array([0.0, 0.0, -0.028]))
    J = getattr(p, inertia) + p.added_mass[dof]
    k = p.W * 0.028                                    # W · BG (N m/rad), neutrally buoyant
    sigma = damping / (2 * J)
    wd = math.sqrt(k / J - sigma**2)
    phi0, h, n = 1e-3, 0.005, 1500
    x0 = np.zeros(12)
    x0[2], x0[dof] = 5.0, phi0
    xs = _simulate(p, x0, h, n)
    t = h * np.arange(n + 1)
    expected = phi0 * np.exp(-sigma * t) * (np.cos(wd * t) + sigma / wd * np.sin(wd * t))
    # the linearisation sin φ ≈ φ shifts the phase by ~φ0²/16 per radian: 1e-6 φ0 over these 3 periods
    np.testing.assert_allclose(xs[:, dof], expected, atol=2e-6 * phi0)


def _period(t: np.ndarray, y: np.ndarray) -> float:
    """Mean period from the upward zero crossings (linear interpolation)."""
    i = np.nonzero((y[:-1] < 0) & (y[1:] >= 0))[0]
    tc = t[i] - y[i] * (t[i + 1] - t[i]) / (y[i + 1] - y[i])
    return float((tc[-1] - tc[0]) / (len(tc) - 1))


@pytest.mark.parametrize("dof", [3, 4])
def test_hydrostatic_roll_and_pitch_periods_of_the_bluerov2(dof):
    """The submerged body's metacentre is its centre of buoyancy: the restoring moment is W·BG sin φ
    (neutrally buoyant), BG = 0.028 m. Roll: T = 2π √((I_x + K_ṗ)/(W BG)). Pitch, with the surge free
    and coupled through X_q̇: the effective inertia is the Schur complement I_y + M_q̇ − X_q̇²/(m + X_u̇)."""
    p = replace(DEFAULT, B=DEFAULT.W, linear_damping=np.zeros(6), quadratic_damping=np.zeros(6))
    m = p.mass
    J = p.I_x + p.added_mass[3] if dof == 3 else p.I_y + p.added_mass[4] - p.X_qdot**2 / (m + p.added_mass[0])
    T_expected = 2 * math.pi * math.sqrt(J / (p.W * 0.028))
    x0 = np.zeros(12)
    x0[2], x0[dof] = 5.0, 1e-3
    h = 0.005      # RK4's phase error ~(ωh)⁵/120 a step, 1e-12 here; the crossings sit where y'' = 0
    xs = _simulate(p, x0, h, int(5 * T_expected / h))
    T_sim = _period(h * np.arange(xs.shape[0]), xs[:, dof])
    assert T_sim == pytest.approx(T_expected, rel=2e-6)
    assert T_expected == pytest.approx(2.369 if dof == 3 else 2.130, abs=1e-3)   # s, the numbers themselves


# ---------------------------------------------------------------------------- Munk moment, energy

@pytest.mark.parametrize("axis", ["pitch", "yaw"])
def test_munk_moment_turns_the_body_broadside(axis):
    """Slender-body theory: a body moving at U with angle of attack α feels (m₂ − m₁) U² sin α cos α towards
    broadside (m₁ < m₂ the added masses along and across): pitch (Z_ẇ − X_u̇) u w, yaw (X_u̇ − Y_v̇) u v."""
    p = replace(DEFAULT, linear_damping=np.zeros(6), quadratic_damping=np.zeros(6), X_qdot=0.0)
    U, alpha = 1.0, math.radians(5.0)
    nu = np.zeros(6)
    nu[0] = U * math.cos(alpha)
    across, row, m2 = (2, 4, p.added_mass[2]) if axis == "pitch" else (1, 5, p.added_mass[1])
    nu[across] = U * math.sin(alpha)
    load = hydrodynamic_load6(p, nu)
    munk = (m2 - p.added_mass[0]) * U**2 * math.sin(alpha) * math.cos(alpha)
    # pitch: w > 0 is the flow from below the nose, nose up (+M) raises α; yaw: v > 0 is drift to
    # starboard, nose to port (−N) raises the drift angle: both destabilising
    expected = munk if axis == "pitch" else -munk
    assert load[row] == pytest.approx(expected, rel=1e-12)
    assert expected > 0 if axis == "pitch" else expected < 0
    np.testing.assert_allclose(np.delete(load, row), 0.0, atol=1e-14)
    # and the motion: released with no damping or restoring, the angle of attack grows
    p = replace(p, B=p.W, r_B=np.zeros(3))
    x0 = np.concatenate([[0.0, 0.0, 5.0, 0.0, 0.0, 0.0], nu])
    xs = _simulate(p, x0, 0.01, 200)
    aoa = np.arctan2(xs[:, 6 + across], xs[:, 6])
    assert aoa[-1] > 1.5 * alpha


def test_kinetic_energy_and_kirchhoff_invariants_are_conserved_by_rk4():
    """No damping, no restoring (W = B at one point): M ν̇ = −C(ν) ν. ½νᵀMν, |P₁| and P₁·P₂ (P = Mν, the
    Kirchhoff impulse) are invariants of the exact motion. RK4 at 100 Hz keeps them to 3e-8 (relative) over
    20 s, and the drift is the integrator's: it falls at least 12-fold when the step halves (h⁴: 16)."""
    r = np.array([0.01, -0.005, 0.02])
    p = replace(DEFAULT, B=DEFAULT.W, r_G=r, r_B=r, linear_damping=np.zeros(6), quadratic_damping=np.zeros(6))
    nu0 = np.array([0.5, -0.3, 0.2, 0.4, -0.6, 0.8])
    drift = {}
    for h in (0.02, 0.01):
        xs = _simulate(p, np.concatenate([[0, 0, 5.0, 0, 0, 0], nu0]), h, int(round(20.0 / h)))
        E = np.array([kinetic_energy(p, x[6:]) for x in xs])
        P = xs[:, 6:] @ p.M.T
        dot = np.einsum("ij,ij->i", P[:, :3], P[:, 3:])
        drift[h] = (np.abs(E / E[0] - 1).max(),
                    np.abs(np.linalg.norm(P[:, :3], axis=1) / np.linalg.norm(P[0, :3]) - 1).max(),
                    np.abs(dot / dot[0] - 1).max())
        assert np.abs(xs[-1, 6:] - nu0).max() > 0.1          # the motion itself is far from trivial
    assert max(drift[0.01]) < 3e-8
    for coarse, fine in zip(drift[0.02], drift[0.01], strict=True):
        assert coarse / fine > 12.0            # fourth order: 16 in the limit


# ---------------------------------------------------------------------------- the planar limit

_STATES = [np.array([1.0, 5.0, 0.1, 0.3, -0.2, 0.4]), np.array([-2.0, 3.0, -0.3, -0.5, 0.4, -0.9]),
           np.array([0.0, 0.05, 0.2, 0.1, 0.1, 0.1])]    # the last breaching (buoyancy fading)


@pytest.mark.parametrize("r_g", [(0.0, 0.0, 0.0), (0.01, 0.0, 0.02)])
@pytest.mark.parametrize("model", ["complete", "paper"])
def test_planar_limit_equals_the_planar_model(r_g, model):
    """y, φ, ψ, v, p, r = 0 and no off-plane load: the six-DoF rates are the planar model's (x, z, θ, u, w, q)
    rates (bridge.models.vehicle's reference path) and zero elsewhere, in still water and in a head,
    long-crested sea with Stokes second-order terms, strips over the beam or not."""
    p = replace(DEFAULT, r_G=np.array(r_g), wave_load_model=model)
    waves = WaveComponents.from_spectrum_lines([0.6, 0.3, 0.2], [0.6, 0.9, 1.4], [0.2, 1.0, 4.0], 54.0, True)
    tau3 = np.array([4.0, -3.0, 0.7])
    tau6 = np.zeros(6)
    tau6[[0, 2, 4]] = tau3
    t = np.array([7.0, 7.025, 7.05])
    for x3 in _STATES:
        x6 = from_planar(x3)
        ref = vehicle.state_rates(p.planar, x3, tau3)
        got = state_derivative6(p, x6, tau6)
        np.testing.assert_allclose(to_planar(got), ref, rtol=1e-13, atol=1e-13)
        assert np.abs(np.delete(got, [0, 2, 4, 6, 8, 10])).max() == 0.0
        flow3 = vehicle.body_flow(waves, x3[:3], t, vehicle.strip_nodes(p.length, 6))
        for n_y in (1, 3):
            flow6 = body_flow6(waves, x6[:6], t, strip_grid(p.length, p.beam, 6, n_y))
            for i in range(3):
                ref = vehicle.state_rates(p.planar, x3, tau3, flow3.stage(i))
                got = state_derivative6(p, x6, tau6, flow6, i)
                np.testing.assert_allclose(to_planar(got), ref, rtol=1e-12, atol=1e-12)
                assert np.abs(np.delete(got, [0, 2, 4, 6, 8, 10])).max() < 1e-12


def test_planar_limit_of_a_trajectory_in_a_head_sea():
    """RK4 of both models, 20 s at 20 Hz with thrust, in a head sea: the same x, z, θ, u, w, q to 1e-9."""
    p = DEFAULT
    waves = WaveComponents.from_spectrum_lines([0.8, 0.4], [0.7, 1.1], [0.3, 2.0], 54.0, True)
    strips3, strips6 = vehicle.strip_nodes(p.length, 6), strip_grid(p.length, p.beam, 6, 3)
    x3, x6, h = np.array([0.0, 5.0, 0.0, 0.0, 0.0, 0.0]), from_planar([0.0, 5.0, 0.0, 0.0, 0.0, 0.0]), 0.05
    tau3 = np.tile([[5.0, -2.0, 0.3]], (3, 1))
    tau6 = np.zeros((3, 6))
    tau6[:, [0, 2, 4]] = tau3
    for k in range(400):
        t = k * h + np.array([0.0, 0.5 * h, h])
        x3 = _planar_reference_step(p.planar, x3, h, tau3, waves, t, strips3)
        x6 = rk4_step6(p, x6, h, tau6, body_flow6(waves, x6[:6], t, strips6))
    np.testing.assert_allclose(to_planar(x6), x3, rtol=1e-9, atol=1e-9)
    assert np.abs(np.delete(x6, [0, 2, 4, 6, 8, 10])).max() < 1e-12
    assert abs(x3[0]) > 1.0                       # it moved


def _planar_reference_step(p, x, h, tau_stages, waves, t, strips):
    """The planar reference path's RK4 step (vehicle.state_rates), whatever WAVEKEEP_NUMBA says."""
    flow = vehicle.body_flow(waves, x[:3], t, strips)
    k1 = vehicle.state_rates(p, x, tau_stages[0], flow.stage(0))
    k2 = vehicle.state_rates(p, x + 0.5 * h * k1, tau_stages[1], flow.stage(1))
    k3 = vehicle.state_rates(p, x + 0.5 * h * k2, tau_stages[1], flow.stage(1))
    k4 = vehicle.state_rates(p, x + h * k3, tau_stages[2], flow.stage(2))
    return x + (h / 6.0) * (k1 + 2.0 * (k2 + k3) + k4)


# ---------------------------------------------------------------------------- the config

def test_config_errors_name_the_file_the_key_and_the_range(tmp_path):
    from bridge.models.vehicle6_config import load_vehicle6_config
    src = Path(__file__).resolve().parents[1] / "configs" / "vehicle" / "bluerov2_heavy_6dof.yaml"
    bad = tmp_path / "bad.yaml"
    bad.write_text(src.read_text().replace("I_x: 0.26", "I_x: -0.26"))
    with pytest.raises(ConfigError) as e:
        load_vehicle6_config(bad)
    assert str(bad) in str(e.value) and "mass_properties.I_x" in str(e.value) and "(0, 1000]" in str(e.value)
    bad.write_text(src.read_text().replace("X_qdot: 0.67", "X_qdot: 20.0"))
    with pytest.raises(ConfigError, match=r"added_mass\.X_qdot.*positive definite"):
        load_vehicle6_config(bad)
    bad.write_text(src.read_text().replace("N_rr: 1.5", "N_rr: 1.5\n  N_rrr: 1.0"))
    with pytest.raises(ConfigError, match=r"damping\.N_rrr.*unknown key"):
        load_vehicle6_config(bad)
