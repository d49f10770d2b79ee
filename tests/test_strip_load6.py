"""The six-DoF strip wave load (bridge.models.strip_load6) against closed forms written out by hand.

For a held, level body the load of one linear component is a strip integral of trigonometric
functions over the length × beam rectangle, which has a closed form: these tests integrate it by
hand (complex exponentials) rather than by the code's Gauss–Legendre strips.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from bridge.models.rigid_body6 import RigidBody6Params, rotation_matrix
from bridge.models.strip_load6 import BodyFlow6, body_flow6, hydrodynamic_load6, strip_grid, wave_load6
from bridge.models.vehicle6_config import load_rigid_body6
from bridge.models.waves import WaveComponents, wavenumber

# Damping off: a held body's drag on the flow's velocity would hide the inertia load
HELD = replace(load_rigid_body6(), linear_damping=np.zeros(6), quadratic_damping=np.zeros(6))
DEPTH, WATER = 5.0, 54.0


def _one_wave(period: float, beta: float, amplitude: float = 1.0, phase: float = 0.3,
              depth: float = WATER) -> WaveComponents:
    """One linear component of the period (s) travelling towards β (rad) in water of the depth (m)."""
    om = np.array([2 * math.pi / period])
    return WaveComponents(np.array([amplitude]), om, wavenumber(om, depth), np.array([phase]), depth, False,
                          np.array([beta]))


def _mean_exp(a: float, span: float) -> float:
    """(1/span) ∫ e^{i a s} ds over [−span/2, span/2]: real, sin(a span/2)/(a span/2)."""
    z = 0.5 * a * span
    return 1.0 if z == 0 else math.sin(z) / z


def _mean_s_exp(a: float, span: float) -> complex:
    """(1/span) ∫ s e^{i a s} ds over [−span/2, span/2]: i · (2/span)(sin(a h)/a² − h cos(a h)/a), h = span/2."""
    h = 0.5 * span
    if abs(a * h) < 1e-3:                 # the series a h³/3 (next term ~ (a h)⁵): no cancellation
        return 1j * (2.0 / span) * (a * h**3 / 3.0 - a**3 * h**5 / 30.0)
    return 1j * (2.0 / span) * (math.sin(a * h) / a**2 - h * math.cos(a * h) / a)


def _closed_form(p: RigidBody6Params, c: WaveComponents, t: float) -> np.ndarray:
    """The load (6,) of one linear component on the body held level at the origin, depth DEPTH, heading 0:
    the strip integrals over the rectangle done exactly, the Froude–Krylov lever at z_b, the X_q̇ coupling
    and the Munk moment of the mean flow."""
    A, om, k, eps, beta = (float(v[0]) for v in (c.amplitude, c.omega, c.k, c.phase, c.direction))
    d = c.water_depth
    ch, sh = math.cosh(k * (d - DEPTH)) / math.sinh(k * d), math.sinh(k * (d - DEPTH)) / math.sinh(k * d)
    ax, ay = k * math.cos(beta), k * math.sin(beta)
    E = np.exp(1j * (eps - om * t))
    L, b = p.length, p.beam
    m0 = E * _mean_exp(ax, L) * _mean_exp(ay, b)             # ⟨e^{iχ}⟩
    mx = E * _mean_s_exp(ax, L) * _mean_exp(ay, b)           # ⟨x e^{iχ}⟩
    my = E * _mean_exp(ax, L) * _mean_s_exp(ay, b)           # ⟨y e^{iχ}⟩
    # NED: v_h = ωA ch cos χ (cos β, sin β), w↓ = −ωA sh sin χ; a_h = ω²A ch sin χ (…), a↓ = ω²A sh cos χ
    horiz = np.array([math.cos(beta), math.sin(beta)])
    v_bar = np.array([*(om * A * ch * m0.real * horiz), -om * A * sh * m0.imag])
    a_bar = np.array([*(om**2 * A * ch * m0.imag * horiz), om**2 * A * sh * m0.real])
    mass = p.rho_V + p.added_mass[:3]
    F = mass * a_bar
    # ⟨x dF⟩, ⟨y dF⟩ per axis
    xF = mass * np.array([*(om**2 * A * ch * mx.imag * horiz), om**2 * A * sh * mx.real])
    yF = mass * np.array([*(om**2 * A * ch * my.imag * horiz), om**2 * A * sh * my.real])
    moment = np.array([yF[2], -xF[2], xF[1] - yF[0]])          # ⟨r × dF⟩ with r = (x, y, 0)
    z_b = p.r_B[2]
    moment += np.array([-z_b * p.rho_V * a_bar[1], z_b * p.rho_V * a_bar[0], 0.0])
    moment[1] += p.X_qdot * a_bar[0]
    A_lin = p.added_mass[:3]
    moment -= np.cross(v_bar, A_lin * v_bar)                   # Munk: −ν_r × A ν_r, ν_r = −ν̄_f
    return np.concatenate([F, moment])


@pytest.mark.parametrize("beta_deg", [0.0, 30.0, 90.0, 150.0, -120.0])
@pytest.mark.parametrize("period", [4.0, 7.1, 11.1])
def test_load_of_one_component_equals_the_exact_strip_integral(beta_deg, period):
    c = _one_wave(period, math.radians(beta_deg))
    strips = strip_grid(HELD.length, HELD.beam, 6, 6)
    eta = np.array([0.0, 0.0, DEPTH, 0.0, 0.0, 0.0])
    for t in (0.0, 1.3, 2.9):
        got = wave_load6(HELD, c, eta, np.zeros(6), t, strips)
        want = _closed_form(HELD, c, t)
        scale = np.abs(want[:3]).max(), np.abs(want[3:]).max()
        np.testing.assert_allclose(got[:3], want[:3], atol=1e-9 * scale[0])
        np.testing.assert_allclose(got[3:], want[3:], atol=1e-7 * scale[1])


def test_uniform_accelerating_flow_gives_the_inertia_load_in_all_three_axes():
    """A flow uniform over the body accelerating at a (the long-wave limit): F = (ρ∇ + m_a,i) a_i per axis;
    moments: the Froude–Krylov force ρ∇ a at the centre of buoyancy (z_b) and the coupling M_u̇ = X_q̇."""
    strips = strip_grid(HELD.length, HELD.beam, 3, 3)
    a = np.array([0.3, -0.2, 0.5])
    load = hydrodynamic_load6(HELD, np.zeros(6), BodyFlow6.uniform(strips, np.zeros(3), a))
    rho_V, z_b = HELD.B / HELD.g, -0.028
    np.testing.assert_allclose(load[:3], (rho_V + np.array([6.36, 7.12, 18.68])) * a, rtol=1e-14)
    expected_moment = [-z_b * rho_V * a[1], z_b * rho_V * a[0] + 0.67 * a[0], 0.0]
    np.testing.assert_allclose(load[3:], expected_moment, atol=1e-14)


@pytest.mark.parametrize("beta_deg", [0.0, 45.0, 90.0, 180.0])
def test_a_very_long_wave_loads_the_held_body_as_a_uniform_flow(beta_deg):
    """A 126 s wave in deep water (kL ~ 1e-4, kd = 25): the load is (ρ∇ + m_a)·a with a the flow's acceleration at the
    origin, written out by hand; a beam sea pushes sideways and not ahead; the force turns with the sea."""
    beta = math.radians(beta_deg)
    om = 2 * math.pi / 126.0
    k = om**2 / 9.81
    c = _one_wave(126.0, beta, amplitude=5.0, phase=0.4, depth=1e5)
    strips = strip_grid(HELD.length, HELD.beam, 3, 3)
    eta = np.array([0.0, 0.0, DEPTH, 0.0, 0.0, 0.0])
    t = 40.0                                  # near the flow's largest horizontal acceleration
    chi = 0.4 - om * t
    decay = 5.0 * om**2 * math.exp(-k * DEPTH)
    a = np.array([decay * math.sin(chi) * math.cos(beta), decay * math.sin(chi) * math.sin(beta),
                  decay * math.cos(chi)])
    load = wave_load6(HELD, c, eta, np.zeros(6), t, strips)
    F = (HELD.rho_V + HELD.added_mass[:3]) * a
    np.testing.assert_allclose(load[:3], F, atol=1e-7 * np.abs(F).max())
    if beta_deg == 90.0:
        assert abs(load[0]) < 1e-12 * abs(load[1]) and abs(load[1]) > 0.1
    if beta_deg == 0.0:
        assert np.abs(load[[1, 3, 5]]).max() < 1e-12 * np.abs(load).max()


def test_turning_the_sea_turns_the_horizontal_force():
    """With equal surge and sway added mass, the long-wave horizontal force of a sea turned by β is the head
    sea's turned by β: F_h(β) = R_z(β) F_h(0)."""
    p = replace(HELD, added_mass=np.array([7.0, 7.0, 18.68, 0.189, 0.135, 0.222]))
    strips = strip_grid(p.length, p.beam, 3, 3)
    eta = np.array([0.0, 0.0, DEPTH, 0.0, 0.0, 0.0])
    head = wave_load6(p, _one_wave(126.0, 0.0, 5.0, 0.4, 1e5), eta, np.zeros(6), 40.0, strips)
    for beta in np.radians([30.0, 90.0, 200.0]):
        load = wave_load6(p, _one_wave(126.0, beta, 5.0, 0.4, 1e5), eta, np.zeros(6), 40.0, strips)
        turned = np.array([[math.cos(beta), -math.sin(beta)], [math.sin(beta), math.cos(beta)]]) @ head[:2]
        np.testing.assert_allclose(load[:2], turned, atol=1e-7 * abs(head[0]))
        assert load[2] == pytest.approx(head[2], rel=1e-7)


def test_rotating_sea_and_heading_together_leaves_the_body_load_unchanged():
    """The load depends on the sea's direction relative to the heading, β − ψ (Rᵀ(Θ) of the flow): a sea and a
    vehicle both turned by 70° about the vertical through the vehicle feel what they felt before."""
    waves = WaveComponents.from_spectrum_lines([0.5, 0.4, 0.3], [0.6, 0.9, 1.3], [0.1, 2.0, 4.0], WATER, True)
    base = replace(waves, direction=np.radians([10.0, -25.0, 40.0]))
    turned = replace(waves, direction=base.direction + math.radians(70.0))
    strips = strip_grid(HELD.length, HELD.beam, 4, 3)
    nu = np.array([0.2, -0.1, 0.05, 0.1, -0.05, 0.2])
    p = load_rigid_body6()                       # with damping: relative velocity and Munk both
    eta0 = np.array([0.0, 0.0, DEPTH, 0.1, -0.05, 0.3])
    eta1 = eta0.copy()
    eta1[5] += math.radians(70.0)
    t = np.array([3.0, 3.5])
    np.testing.assert_allclose(wave_load6(p, turned, eta1, nu, t, strips), wave_load6(p, base, eta0, nu, t, strips),
                               atol=1e-11)


def test_flow_is_rotated_into_the_body_frame():
    """The body-frame flow at the strips is Rᵀ(Θ) of the NED flow at p + R r_j (checked at a tilted pose)."""
    from bridge.models.directional_sea import kinematics_xyz
    waves = replace(WaveComponents.from_spectrum_lines([0.5, 0.4], [0.6, 1.1], [0.1, 2.0], WATER, True),
                    direction=np.radians([20.0, 110.0]))
    strips = strip_grid(HELD.length, HELD.beam, 2, 2)
    eta = np.array([3.0, -2.0, 4.0, 0.2, -0.3, 1.0])
    flow = body_flow6(waves, eta, 5.0, strips)
    R = rotation_matrix(*eta[3:])
    for j, r in enumerate(strips[0]):
        e = eta[:3] + R @ r
        v, a = kinematics_xyz(waves, e[0], e[1], e[2], 5.0)
        np.testing.assert_allclose(flow.nu_f[0, j], R.T @ v[0, 0], atol=1e-14)
        np.testing.assert_allclose(flow.a_f[0, j], R.T @ a[0, 0], atol=1e-14)


def test_a_body_moving_with_the_water_feels_only_the_inertia_load():
    """ν = the uniform flow's velocity: no drag and no Munk moment; the load is (ρ∇ + M_A) ν̇_f (minus the
    still-water load of its own motion, which wave_load6 takes off)."""
    p = load_rigid_body6()
    strips = strip_grid(p.length, p.beam, 3, 3)
    v, a = np.array([0.3, -0.2, 0.1]), np.array([0.1, 0.2, -0.3])
    load = hydrodynamic_load6(p, np.concatenate([v, np.zeros(3)]), BodyFlow6.uniform(strips, v, a))
    expected = np.concatenate([(p.rho_V + p.added_mass[:3]) * a,
                               [0.028 * p.rho_V * a[1], -0.028 * p.rho_V * a[0] + 0.67 * a[0], 0.0]])
    np.testing.assert_allclose(load, expected, atol=1e-14)


def test_a_current_is_rotated_into_the_body_and_drifts_a_body_that_moves_with_it_freely():
    """A steady current (NED) in still water: the body-frame flow is Rᵀ(Θ) U_c at every strip, and a body
    moving with it feels no load at all (no drag, no Munk moment, no acceleration)."""
    p = load_rigid_body6()
    still = WaveComponents(np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0), WATER, False)
    strips = strip_grid(p.length, p.beam, 3, 3)
    eta = np.array([0.0, 0.0, DEPTH, 0.1, -0.2, 2.0])
    current = np.array([0.4, -0.3, 0.0])
    flow = body_flow6(still, eta, 0.0, strips, current)
    body = rotation_matrix(*eta[3:]).T @ current
    np.testing.assert_allclose(flow.nu_f[0], np.tile(body, (9, 1)), atol=1e-15)
    np.testing.assert_allclose(flow.a_f, 0.0, atol=0.0)
    np.testing.assert_allclose(hydrodynamic_load6(p, np.concatenate([body, np.zeros(3)]), flow), 0.0, atol=1e-14)


def test_three_by_three_strips_converge_the_load_in_a_spread_sea():
    """W1, s = 10 about 45°, the vehicle held at 5 m: 3 × 3 strips give every DoF's load within 1e-3 of its rms
    of 12 × 12 strips; a single point misses the roll and yaw moments (they come from the levers across the
    beam and along the length), and strips along the length alone miss the yaw moment."""
    from bridge.models.directional_sea import spread_components
    from sitl.sea import Sea
    p = load_rigid_body6()
    c = spread_components(Sea.load("W1").components, 10.0, math.radians(45.0), np.random.default_rng(3))
    eta, t = np.array([0.0, 0.0, DEPTH, 0.0, 0.0, 0.0]), np.linspace(0.0, 120.0, 241)
    ref = wave_load6(p, c, eta, np.zeros(6), t, strip_grid(p.length, p.beam, 12, 12))
    rms = np.sqrt((ref**2).mean(axis=0))
    err = {n: np.abs(wave_load6(p, c, eta, np.zeros(6), t, strip_grid(p.length, p.beam, *n)) - ref).max(axis=0) / rms
           for n in ((3, 3), (1, 1), (3, 1))}
    assert err[(3, 3)].max() < 1e-3
    assert err[(1, 1)][3] > 0.1 and err[(1, 1)][5] > 0.1 and err[(3, 1)][5] > 0.1
