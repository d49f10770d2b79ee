"""The world's linear wave loads against independent truth: the long-wave limit, closed forms, and BEM.

For a body small against the wavelength, held in an accelerating flow a, the linear inertia load
is (ρ∇ + m_a)·a: the Froude–Krylov force of the wave's pressure gradient on the displaced water,
plus the added-mass force (Morison: C_M = 1 + C_a). The truths here are written from linear wave
theory by hand (the dispersion relation solved with scipy, the strip integrals in closed form) and
from a boundary-element solution (capytaine, ``benchmarks/bem_wave_loads.py``, stored with its
provenance in ``benchmarks/results/bem_wave_loads.json``): none of it is the code's own output.
"""
from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

from bridge.models.vehicle import VehicleParams, strip_nodes, wave_load
from bridge.models.waves import WaveComponents
from sitl.plant import Plant
from sitl.sea import Sea

G = 9.81
BEM = Path(__file__).resolve().parents[1] / "benchmarks" / "results" / "bem_wave_loads.json"
TABLE_II = VehicleParams.load("bluerov2_heavy")
RHO_V = 114.8 / G            # kg: ρ∇ = B / g, Table II's buoyancy
Z_B = -0.028                 # m: the buoyancy centre above the CG (FRD)


def still_damping(p: VehicleParams) -> VehicleParams:
    """The vehicle with its damping off: what is left of the wave load is linear in the wave."""
    return replace(p, X_u=0.0, Z_w=0.0, M_q=0.0, X_uu=0.0, Z_ww=0.0, M_qq=0.0)


def wavenumber(omega: float, depth: float) -> float:
    """k from ω² = g k tanh(k d), by bracketing (independent of the models' Newton solver)."""
    return brentq(lambda k: G * k * math.tanh(k * depth) - omega**2, 1e-12, 10.0 * omega**2 / G + 10.0, xtol=1e-15,
                  rtol=1e-15)


def one_wave(amplitude: float, omega: float, depth: float, phase: float = 0.3) -> WaveComponents:
    return WaveComponents.from_spectrum_lines(np.array([amplitude]), np.array([omega]), np.array([phase]), depth, False)


def closed_form_load(p: VehicleParams, amplitude: float, omega: float, water_depth: float, z: float,
                     psi0: np.ndarray, length: float) -> np.ndarray:
    """The complete model's load (N, N, N m) on a level body at rest, damping off, written out by hand.

    Linear wave ζ = A cos(kx − ωt + ε) at depth z (down): a_x = A ω² c_h sin ψ, a_z = A ω² s_h cos ψ (NED),
    u = A ω c_h cos ψ, w = −A ω s_h sin ψ, with ψ = k x + ψ0 along the body. Over x ∈ [−L/2, L/2] with the
    mass spread evenly: the mean of cos(kx + ψ0) is S cos ψ0 (S = sin(kL/2)/(kL/2)) and (1/L)∫ x cos(kx + ψ0)
    dx = −J sin ψ0, J = (2/L)(sin(kL/2) − (kL/2) cos(kL/2))/k². Then X = (ρ∇ + X_u̇) ā_x,
    Z = (ρ∇ + Z_ẇ) ā_z, M = −(ρ∇ + Z_ẇ)(1/L)∫ x a_z dx + (M_u̇ + ρ∇ z_B) ā_x + (Z_ẇ − X_u̇) ū w̄ (Munk).
    """
    k = wavenumber(omega, water_depth)
    ch = math.cosh(k * (water_depth - z)) / math.sinh(k * water_depth)
    sh = math.sinh(k * (water_depth - z)) / math.sinh(k * water_depth)
    h = 0.5 * k * length
    S = math.sin(h) / h
    J = (2.0 / length) * (math.sin(h) - h * math.cos(h)) / k**2
    rho_v = p.rho_V
    ax_mean = amplitude * omega**2 * ch * S * np.sin(psi0)
    az_mean = amplitude * omega**2 * sh * S * np.cos(psi0)
    x_az = -amplitude * omega**2 * sh * J * np.sin(psi0)           # (1/L) ∫ x a_z dx
    u_mean = amplitude * omega * ch * S * np.cos(psi0)
    w_mean = -amplitude * omega * sh * S * np.sin(psi0)
    X = (rho_v + p.X_udot) * ax_mean
    Z = (rho_v + p.Z_wdot) * az_mean
    M = -(rho_v + p.Z_wdot) * x_az + (p.X_qdot + rho_v * float(p.r_B[2])) * ax_mean \
        + (p.Z_wdot - p.X_udot) * u_mean * w_mean
    return np.stack([X, Z, M], axis=-1)


# ----------------------------------------------------------------------------- the long-wave limit

def test_the_displaced_water_is_b_over_g_unless_the_config_states_it():
    assert TABLE_II.rho_V == pytest.approx(RHO_V, rel=1e-12)          # 11.70 kg against X_u̇ 6.36, Z_ẇ 18.68
    stated = replace(TABLE_II, displaced_volume=0.02, water_density=1000.0)
    assert stated.rho_V == pytest.approx(20.0, rel=1e-12)
    assert TABLE_II.with_wave_load("paper").fk_mass == 0.0


def test_long_wave_limit_on_a_fixed_vehicle_is_rho_v_plus_added_mass_times_acceleration():
    """A 126 s wave in deep water is a uniform accelerating flow over the 0.46 m body: X = (ρ∇ + X_u̇) a_x and
    Z = (ρ∇ + Z_ẇ) a_z at the body, to 1e-6, from linear theory by hand (deep water: k = ω²/g)."""
    p = still_damping(TABLE_II)
    A, omega, d, z = 0.5, 0.05, 1.0e5, 5.0
    k = omega**2 / G
    t = np.linspace(0.0, 2 * math.pi / omega, 97)
    tau = wave_load(p, one_wave(A, omega, d, 0.3), np.array([0.0, z, 0.0]), np.zeros(3), t, strip_nodes(p.length, 3))
    psi = -omega * t + 0.3
    a_x = A * omega**2 * math.exp(-k * z) * np.sin(psi)
    a_z = A * omega**2 * math.exp(-k * z) * np.cos(psi)
    scale = (RHO_V + 18.68) * A * omega**2
    np.testing.assert_allclose(tau[:, 0], (RHO_V + 6.36) * a_x, rtol=0, atol=1e-6 * scale)
    np.testing.assert_allclose(tau[:, 1], (RHO_V + 18.68) * a_z, rtol=0, atol=1e-6 * scale)


@pytest.mark.parametrize("period", [4.0, 5.0, 7.1, 9.5, 11.1, 14.0, 20.0])
def test_the_plant_load_on_a_fixed_vehicle_is_the_inertia_load_at_its_centre(period):
    """In the paper's 54 m of water, for periods of 4–20 s, the plant's linear load on the vehicle held at
    5 m is (ρ∇ + m_a)·a of the flow at its centre to 1 % in amplitude (the body is short against the wave),
    and not the paper's m_a·a alone."""
    omega, A, d = 2 * math.pi / period, 0.01, 54.0
    comps = one_wave(A, omega, d)
    sea = Sea("one wave", comps, lambda w: np.zeros_like(w), omega, 4 * A / math.sqrt(2), 0)
    vehicle = still_damping(TABLE_II)
    plant = Plant(vehicle, sea, *_thrusters(), strips=6)
    t = np.linspace(0.0, period, 200, endpoint=False)
    tau = plant.wave_load(np.array([0.0, 5.0, 0.0]), np.zeros(3), t)
    k = wavenumber(omega, d)
    ch, sh = (f(k * (d - 5.0)) / math.sinh(k * d) for f in (math.cosh, math.sinh))
    for axis, mass, att in ((0, RHO_V + 6.36, ch), (1, RHO_V + 18.68, sh)):
        amp = math.sqrt(2.0 * np.mean(tau[:, axis] ** 2))
        assert amp == pytest.approx(mass * A * omega**2 * att, rel=0.01)
    paper = Plant(vehicle, replace(sea, wave_load="paper"), *_thrusters(), strips=6)
    ratio = math.sqrt(np.mean(paper.wave_load(np.array([0.0, 5.0, 0.0]), np.zeros(3), t)[:, 0] ** 2)
                      / np.mean(tau[:, 0] ** 2))
    assert ratio == pytest.approx(6.36 / (RHO_V + 6.36), rel=0.01)       # the paper's 0.35 of the surge load


def _thrusters():
    from bridge.models.thrusters import T200Curve, ThrusterLayout
    from bridge.schemas import load_vehicle_config
    th = load_vehicle_config("bluerov2_heavy")["thrusters"]
    return ThrusterLayout.from_config(th), T200Curve.from_config(th), th["time_constant"]


def test_the_froude_krylov_term_is_rho_v_a_in_phase_with_the_acceleration():
    """complete − paper is the Froude–Krylov force alone: ρ∇·ā in surge and heave, in phase with the fluid's
    acceleration (no lag, unit ratio), in a W1-period wave."""
    p = still_damping(TABLE_II)
    omega, A = 2 * math.pi / 7.1, 0.01
    comps, strips = one_wave(A, omega, 54.0), strip_nodes(p.length, 3)
    t = np.linspace(0.0, 7.1, 256, endpoint=False)
    eta = np.array([0.0, 5.0, 0.0])
    fk = wave_load(p, comps, eta, np.zeros(3), t, strips) - wave_load(p.with_wave_load("paper"), comps, eta,
                                                                       np.zeros(3), t, strips)
    k = wavenumber(omega, 54.0)
    ch, sh = (f(k * 49.0) / math.sinh(k * 54.0) for f in (math.cosh, math.sinh))
    S = math.sin(0.5 * k * p.length) / (0.5 * k * p.length)
    psi = -omega * t + 0.3
    for axis, acc in ((0, A * omega**2 * ch * S * np.sin(psi)), (1, A * omega**2 * sh * S * np.cos(psi))):
        # the complex amplitude of the FK force over that of the acceleration: ρ∇ with zero phase
        ratio = np.fft.rfft(fk[:, axis])[1] / np.fft.rfft(acc)[1]
        assert abs(ratio) == pytest.approx(RHO_V, rel=1e-9)
        assert abs(np.angle(ratio)) < 1e-9


@pytest.mark.parametrize("period", [4.0, 7.1, 11.1, 20.0])
def test_pitch_load_matches_its_closed_form(period):
    """The pitch moment on the fixed vehicle: the heave inertia's lever along the body, the M_u̇ coupling and
    the Froude–Krylov surge force's lever at the buoyancy centre, (M_u̇ + ρ∇ z_B) ā_x, and the flow's Munk
    moment — against the closed form (exact integrals; the model's 3 Gauss strips) to 1e-6."""
    p = still_damping(TABLE_II)
    omega, A, d = 2 * math.pi / period, 0.05, 54.0
    t = np.linspace(0.0, period, 64, endpoint=False)
    tau = wave_load(p, one_wave(A, omega, d, 0.3), np.array([0.0, 5.0, 0.0]), np.zeros(3), t,
                    strip_nodes(p.length, 3))
    want = closed_form_load(p, A, omega, d, 5.0, -omega * t + 0.3, p.length)
    for axis in range(3):
        np.testing.assert_allclose(tau[:, axis], want[:, axis], rtol=0, atol=1e-6 * np.abs(want[:, axis]).max())
    # the coupling is what dominates the long-wave pitch load: c_θ = M_u̇ + ρ∇ z_B = 0.67 − 0.328 kg m
    assert p.fluid_pitch_coupling == pytest.approx(0.67 + RHO_V * Z_B, rel=1e-12)


# ----------------------------------------------------------------------------- against BEM

def _bem_rows():
    data = json.loads(BEM.read_text())
    return data, data["table"]


def _plant_ratio(p: VehicleParams, omega: float, depth: float, water_depth: float, axis: int) -> complex:
    """The model's linear load over the fluid's acceleration at the centre (kg, complex: in-phase, quadrature),
    fixed body, from one period of the load."""
    A = 0.01
    period = 2 * math.pi / omega
    t = np.linspace(0.0, period, 256, endpoint=False)
    tau = wave_load(p, one_wave(A, omega, water_depth, 0.0), np.array([0.0, depth, 0.0]), np.zeros(3), t,
                    strip_nodes(p.length, 6))
    k = wavenumber(omega, water_depth)
    att = (math.cosh if axis == 0 else math.sinh)(k * (water_depth - depth)) / math.sinh(k * water_depth)
    psi = -omega * t
    acc = A * omega**2 * att * (np.sin(psi) if axis == 0 else np.cos(psi))
    return complex(np.fft.rfft(tau[:, axis])[1] / np.fft.rfft(acc)[1])


def test_bem_table_is_the_documented_oracle():
    data, rows = _bem_rows()
    assert data["provenance"]["solver"] == "capytaine"
    assert data["mesh_convergence"]["max_rel_change_coarse_to_fine"] < 0.02
    assert rows[0]["period_s"] <= 4.0 and rows[-1]["period_s"] >= 20.0
    assert data["volume_m3"] == pytest.approx(114.8 / (1025.0 * G), rel=1e-6)   # the vehicle's displaced volume


def test_plant_excitation_agrees_with_bem_on_a_box_of_the_vehicles_volume():
    """The load model with the box's own volume and added masses (from the BEM's radiation solution) gives the
    BEM's excitation (Froude–Krylov + diffraction) in surge and heave within 10 %, periods 4–20 s; the paper's
    model (no ρ∇) does not."""
    data, rows = _bem_rows()
    box_length = data["box_m"][0]
    for r in rows:
        omega = r["omega_rad_s"]
        box = still_damping(replace(TABLE_II, length=box_length, displaced_volume=data["volume_m3"],
                                    water_density=data["rho_kg_m3"], X_udot=r["surge"]["added_mass_kg"],
                                    Z_wdot=r["heave"]["added_mass_kg"]))
        for axis, dof in ((0, "surge"), (1, "heave")):
            bem = complex(*r[dof]["ratio_kg"])
            ours = _plant_ratio(box, omega, data["centre_depth_m"], data["water_depth_m"], axis)
            assert abs(ours) == pytest.approx(abs(bem), rel=0.10), (r["period_s"], dof)
            assert abs(np.angle(ours)) < math.radians(5) and abs(np.angle(bem)) < math.radians(5)
            paper = _plant_ratio(box.with_wave_load("paper"), omega, data["centre_depth_m"], data["water_depth_m"],
                                 axis)
            assert abs(paper) < 0.7 * abs(bem)
