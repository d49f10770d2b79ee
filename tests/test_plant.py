"""The vehicle plant against hydrostatics, energy and rigid-body identities."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from bridge.models.vehicle import (
    J,
    VehicleParams,
    body_flow,
    coriolis_matrix,
    damping_matrix,
    hydrodynamic_load,
    restoring_forces,
    state_rates,
    strip_nodes,
    wave_load,
)
from bridge.models.waves import WaveComponents
from sitl.plant import Plant
from sitl.sea import Sea

NEUTRAL = np.full(8, 1500.0)


@pytest.fixture(scope="module")
def vehicle() -> VehicleParams:
    return VehicleParams.load("bluerov2_heavy")


def still_plant(substeps: int = 1) -> Plant:
    plant = Plant.from_configs(Sea.still_water(), dof="planar")   # the planar model's own checks
    plant.substeps = substeps
    return plant


def test_table_ii_parameters_reach_the_model(vehicle):
    # Paper Table II: W 112.8 N, B 114.8 N, I_y 0.253, X_u̇ 6.36, Z_ẇ 18.68, M_q̇ 0.135, X_q̇ = M_u̇ 0.67
    m = 112.8 / 9.81
    expected = np.array([[m + 6.36, 0.0, 0.67], [0.0, m + 18.68, 0.0], [0.67, 0.0, 0.253 + 0.135]])
    np.testing.assert_allclose(vehicle.M, expected, rtol=1e-12)
    assert np.all(np.linalg.eigvalsh(vehicle.M) > 0)


def test_coriolis_is_skew_symmetric_and_does_no_work(vehicle):
    rng = np.random.default_rng(1)
    for _ in range(20):
        nu = rng.normal(size=3)
        C = coriolis_matrix(vehicle, nu)
        np.testing.assert_allclose(C, -C.T, atol=1e-12)
        assert abs(nu @ C @ nu) < 1e-12


def test_munk_moment_has_fossen_form(vehicle):
    # Pure translation u, w: the pitch row of C_A(ν)ν is the Munk moment (X_u̇ − Z_ẇ) u w
    # (rigid-body terms cancel for a body with r_G = 0).
    u, w = 0.3, -0.2
    C = coriolis_matrix(vehicle, np.array([u, w, 0.0]))
    assert (C @ np.array([u, w, 0.0]))[2] == pytest.approx((6.36 - 18.68) * u * w, rel=1e-12)


def test_state_rates_match_the_matrix_form(vehicle):
    rng = np.random.default_rng(2)
    for _ in range(20):
        eta, nu, tau = rng.normal(size=3), rng.normal(size=3), rng.normal(size=3) * 10
        eta[1] = 5.0 + abs(eta[1])   # submerged
        rhs = (tau - coriolis_matrix(vehicle, nu) @ nu - damping_matrix(vehicle, nu) @ nu
               - restoring_forces(vehicle, eta))
        expected = np.concatenate([J(eta) @ nu, np.linalg.solve(vehicle.M, rhs)])
        np.testing.assert_allclose(state_rates(vehicle, np.concatenate([eta, nu]), tau), expected, atol=1e-12)


def test_buoyant_vehicle_rises_at_the_terminal_speed_of_heave_damping():
    # B − W = 2 N up; terminal speed solves Z_w w + Z_w|w| w² = 2 N.
    w_term = (-33.0 + np.sqrt(33.0**2 + 4 * 190.0 * 2.0)) / (2 * 190.0)
    plant = still_plant()
    plant.reset(eta=[0.0, 20.0, 0.0])
    for _ in range(400):  # 20 s
        plant.step(NEUTRAL, 0.05)
    assert plant.state.nu[1] == pytest.approx(-w_term, rel=1e-4)   # FRD: rising is negative w
    assert abs(plant.state.nu[0]) < 1e-9 and abs(plant.state.eta[2]) < 1e-9
    z0 = plant.state.eta[1]
    for _ in range(200):
        plant.step(NEUTRAL, 0.05)
    assert z0 - plant.state.eta[1] == pytest.approx(10.0 * w_term, rel=1e-4)


def test_initial_pitch_decays_to_the_restoring_equilibrium():
    plant = still_plant()
    plant.reset(eta=[0.0, 20.0, 0.4])
    peak = []
    for _ in range(600):
        plant.step(NEUTRAL, 0.05)
        peak.append(abs(plant.state.eta[2]))
    # Natural frequency of the linearised pitch: √(BG·B / (I_y + M_q̇)); restoring 0.028 m × 114.8 N
    assert max(peak[-100:]) < 1e-3
    assert max(peak) <= 0.4 + 1e-9


def test_small_pitch_oscillation_has_the_hydrostatic_period():
    # Undamped linear pitch: ω_n = √(z_BG B / (I_y + M_q̇)) — check the zero-crossing period with damping off.
    base = VehicleParams.load("bluerov2_heavy")
    # Neutral buoyancy and no surge–pitch coupling make pitch a clean pendulum.
    v = replace(base, W=base.B, X_qdot=0.0, X_u=0.0, X_uu=0.0, Z_w=0.0, Z_ww=0.0, M_q=0.0, M_qq=0.0)
    plant = still_plant()
    plant.vehicle = v
    plant.reset(eta=[0.0, 20.0, 0.01])
    theta, dt = [], 0.005
    for _ in range(2000):
        plant.step(NEUTRAL, dt)
        theta.append(plant.state.eta[2])
    theta = np.array(theta)
    crossings = np.flatnonzero(np.diff(np.sign(theta)) > 0) * dt
    period = np.mean(np.diff(crossings))
    omega_n = np.sqrt(0.028 * 114.8 / (0.253 + 0.135))
    assert period == pytest.approx(2 * np.pi / omega_n, rel=2e-3)


def test_undamped_unforced_motion_conserves_energy():
    # With D = 0, W = B and r_B = r_G the body is free: kinetic energy ½νᵀMν is conserved (C is skew).
    base = VehicleParams.load("bluerov2_heavy")
    v = replace(base, W=base.B, r_B=np.zeros(3), X_u=0.0, Z_w=0.0, M_q=0.0, X_uu=0.0, Z_ww=0.0, M_qq=0.0)
    plant = still_plant()
    plant.vehicle = v
    nu0 = np.array([0.4, -0.3, 0.8])
    plant.reset(eta=[0.0, 20.0, 0.0], nu=nu0)
    e0 = 0.5 * nu0 @ v.M @ nu0
    for _ in range(400):
        plant.step(NEUTRAL, 0.01)
    nu = plant.state.nu
    assert 0.5 * nu @ v.M @ nu == pytest.approx(e0, rel=1e-6)


def _final_state(sea: Sea, substeps: int, steps: int = 40) -> np.ndarray:
    plant = Plant.from_configs(sea)
    plant.substeps = substeps
    pwm = np.array([1600, 1450, 1550, 1500, 1700, 1300, 1500, 1650], dtype=float)
    for _ in range(steps):
        plant.step(pwm, 0.05)
    return np.concatenate([plant.state.eta, plant.state.nu])


def test_a_surfaced_vehicle_floats():
    # Buoyancy fades over the body height as it breaches: the 2 N buoyant vehicle settles where
    # W = B·fraction, i.e. depth = height·(W/B − 0.5).
    plant = still_plant()
    plant.reset(eta=[0.0, 1.0, 0.0])
    for _ in range(2400):
        plant.step(NEUTRAL, 0.05)
    v = plant.vehicle
    assert plant.state.eta[1] == pytest.approx(v.height * (v.W / v.B - 0.5), abs=1e-4)
    assert abs(plant.state.nu[1]) < 1e-4


def test_rk4_converges_at_fourth_order_in_still_water():
    sea = Sea.still_water()
    ref = _final_state(sea, 32)
    e1, e2 = (np.abs(_final_state(sea, n) - ref).max() for n in (1, 2))
    assert e2 < e1 / 12  # 2⁴ = 16 for a smooth problem; |ν|ν is smooth away from ν = 0


def test_wave_load_sampled_at_the_step_pose_costs_millimetres():
    # The wave load is sampled at the RK4 stage times for the pose at the start of each
    # step. Against a 16× finer integration, one step per 50 ms stays within millimetres
    # after 2 s of hard thrusting in W1 (wavelengths ≈ 80 m).
    sea = Sea.load("W1")
    err = np.abs(_final_state(sea, 1) - _final_state(sea, 16))
    assert err[:2].max() < 0.01 and err[2] < 0.01


def test_same_seed_same_trajectory():
    def run(seed):
        plant = Plant.from_configs(Sea.load("W2", seed=seed))
        for _ in range(100):
            plant.step(NEUTRAL, 0.05)
        return plant.state.eta.copy()

    np.testing.assert_array_equal(run(5), run(5))
    assert not np.array_equal(run(5), run(6))


def test_motor_lag_is_first_order_with_the_configured_time_constant():
    plant = still_plant()
    plant.reset(eta=[0.0, 20.0, 0.0])
    pwm = np.full(8, 1700.0)
    target = plant.curve.thrust(1700.0)
    plant.step(pwm, 0.1)  # one time constant
    np.testing.assert_allclose(plant.state.thrust, target * (1 - np.exp(-1.0)), rtol=1e-12)


def test_pwm_is_saturated_to_the_esc_range():
    plant = still_plant()
    plant.reset(eta=[0.0, 20.0, 0.0])
    for _ in range(200):     # 10 s in control periods (one 10 s RK4 step is far outside what it integrates)
        plant.step(np.full(8, 2500.0), 0.05)
    np.testing.assert_allclose(plant.state.thrust, 5.25 * 9.80665, rtol=1e-9)


def test_bad_pwm_is_rejected_without_touching_the_state():
    plant = still_plant()
    before = plant.state.copy()
    for bad in (np.full(7, 1500.0), np.array([np.nan] + [1500.0] * 7)):
        with pytest.raises(ValueError):
            plant.step(bad, 0.05)
    assert plant.state.t == before.t
    np.testing.assert_array_equal(plant.state.eta, before.eta)


def test_strip_quadrature_integrates_the_pitch_moment_of_a_linear_load():
    # A heave load density varying linearly along the body, q(x') = a + b x', gives
    # Z = L·a, M = −b L³/12. Gauss–Legendre with 3 nodes integrates it exactly.
    xs, w = strip_nodes(0.457, 3)
    a, b, L = 2.0, 5.0, 0.457
    assert (a + b * xs) @ w * L == pytest.approx(a * L)
    assert -((a + b * xs) * xs) @ w * L == pytest.approx(-b * L**3 / 12)


RHO_V = 114.8 / 9.81
"""ρ∇ (kg) of Table II's vehicle: the displaced water's mass, B / g."""


def inertia_masses(model: str) -> tuple[float, float, float]:
    """The fluid-acceleration masses (surge kg, heave kg) and the pitch coupling c_θ (kg m) of a load
    model, from Table II by hand: complete ρ∇ + X_u̇, ρ∇ + Z_ẇ and M_u̇ + ρ∇ z_B (z_B = −0.028 m);
    the paper's X_u̇, Z_ẇ and no coupling."""
    if model == "paper":
        return 6.36, 18.68, 0.0
    return RHO_V + 6.36, RHO_V + 18.68, 0.67 - 0.028 * RHO_V


@pytest.mark.parametrize("model", ["complete", "paper"])
def test_wave_load_in_a_uniform_oscillating_flow(vehicle, model):
    # A very long wave in very deep water is a spatially uniform flow at the body: the load is
    # (ρ∇ + M_A) a + D(v) v per axis (the paper's Eq. 11 without ρ∇), and in pitch the flow's Munk
    # moment plus, in the complete model, c_θ a_x.
    A, omega, d = 0.5, 0.2, 1e5
    comps = WaveComponents.from_spectrum_lines(np.array([A]), np.array([omega]), np.array([0.3]), d, False)
    k = comps.k[0]
    t = 7.0
    tau = wave_load(vehicle.with_wave_load(model), comps, np.array([0.0, 5.0, 0.0]), np.zeros(3), t,
                    strip_nodes(vehicle.length, 3))
    th = -omega * t + 0.3
    att = np.exp(-k * 5.0)
    u, w_dn = A * omega * att * np.cos(th), -A * omega * att * np.sin(th)
    ud, wd_dn = A * omega**2 * att * np.sin(th), A * omega**2 * att * np.cos(th)
    m_x, m_z, c_th = inertia_masses(model)
    X = m_x * ud + (13.7 + 141 * abs(u)) * u
    Z = m_z * wd_dn + (33 + 190 * abs(w_dn)) * w_dn
    np.testing.assert_allclose(tau[:2], [X, Z], rtol=1e-4)
    # The flow's Munk moment (X_u̇ − Z_ẇ) u w on a body held in it, and the coupling
    assert tau[2] == pytest.approx(-(6.36 - 18.68) * u * w_dn + c_th * ud, rel=2e-2)  # + a sliver of strip moment


@pytest.mark.parametrize("model", ["complete", "paper"])
def test_a_body_drifting_with_the_flow_feels_only_its_inertia(vehicle, model):
    # Relative-velocity model: moving with the water removes drag and Munk moment; what is
    # left is the fluid-acceleration force (ρ∇ + M_A) ν̇_p.
    A, omega, d = 0.5, 0.2, 1e5
    comps = WaveComponents.from_spectrum_lines(np.array([A]), np.array([omega]), np.array([0.3]), d, False)
    strips = strip_nodes(vehicle.length, 3)
    eta = np.array([0.0, 5.0, 0.0])
    flow = body_flow(comps, eta, 7.0, strips)
    nu = np.array([flow.u[0].mean(), flow.w[0].mean(), 0.0])
    tau = wave_load(vehicle.with_wave_load(model), comps, eta, nu, 7.0, strips)
    damping_removed = np.array([(13.7 + 141 * abs(nu[0])) * nu[0], (33 + 190 * abs(nu[1])) * nu[1]])
    m_x, m_z, _ = inertia_masses(model)
    inertia = np.array([m_x * flow.ax[0].mean(), m_z * flow.az[0].mean()])
    # τ_E = F_h(ν, flow) − F_h(ν, still): with ν = ν_p the flow term is pure inertia and the
    # still-water term is the vehicle's own damping, which the waves "remove".
    np.testing.assert_allclose(tau[:2], inertia + damping_removed, rtol=1e-6)


def test_still_water_hydrodynamics_are_eq2_damping_and_added_mass_coriolis(vehicle):
    rng = np.random.default_rng(3)
    for _ in range(10):
        u, w, q = rng.normal(size=3)
        nu = np.array([u, w, q])
        m = vehicle.mass
        M_RB_part = np.array([[0, 0, m * w], [0, 0, -m * u], [-m * w, m * u, 0]])
        C_A = coriolis_matrix(vehicle, nu) - M_RB_part
        expected = -(C_A @ nu) - damping_matrix(vehicle, nu) @ nu
        np.testing.assert_allclose(hydrodynamic_load(vehicle, u, w, q, None), expected, atol=1e-12)


@pytest.mark.parametrize("model", ["complete", "paper"])
def test_wave_load_on_a_short_body_matches_the_point_load(vehicle, model):
    # The body (0.46 m) is short against the waves (≈ 80 m in W1): the strip-integrated
    # surge and heave loads on a body at rest must equal the point load at the centre to within ~1 %.
    sea = Sea.load("W1")
    t = np.linspace(0, 60, 1201)
    tau = wave_load(vehicle.with_wave_load(model), sea.components, np.array([0.0, 5.0, 0.0]), np.zeros(3), t,
                    strip_nodes(vehicle.length, 3))
    u, w, ud, wd = sea.particle_kinematics(0.0, 5.0, t)
    m_x, m_z, c_th = inertia_masses(model)
    X = m_x * ud + (13.7 + 141 * np.abs(u)) * u
    Z = m_z * wd + (33 + 190 * np.abs(w)) * w
    assert np.sqrt(np.mean((tau[:, 0] - X) ** 2)) < 0.01 * np.sqrt(np.mean(X**2))
    assert np.sqrt(np.mean((tau[:, 1] - Z) ** 2)) < 0.01 * np.sqrt(np.mean(Z**2))
    # Its pitch moment: the flow's Munk moment and the coupling, plus the heave load's variation along the body.
    munk = -(6.36 - 18.68) * u * w + c_th * ud
    assert np.sqrt(np.mean((tau[:, 2] - munk) ** 2)) < 0.1 * np.sqrt(np.mean(munk**2))
