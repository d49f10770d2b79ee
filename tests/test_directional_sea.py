"""The directional sea (bridge.models.directional_sea) against independent truths.

The long-crested kinematics of bridge.models.waves at β = 0, rotations of the plane, the linear
formulas written out by hand, the flow's incompressibility and irrotationality and the surface's
kinematic condition (finite differences), and for the cos-2s sampler its density's integral and
circular moments by quadrature against the sampled directions' statistics.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.integrate import quad

from bridge.models.directional_sea import (
    cos2s_density,
    cos2s_directions,
    directional_moments,
    kinematics_xyz,
    spread_components,
)
from bridge.models.waves import WaveComponents, elevation_xy, particle_kinematics_grid

DEPTH = 54.0
SEA = WaveComponents.from_spectrum_lines([0.9, 0.5, 0.3, 0.2], [0.55, 0.8, 1.2, 1.9], [0.2, 1.7, 3.1, 5.0], DEPTH,
                                         True)
SPREAD = replace(SEA, direction=np.radians([15.0, -40.0, 100.0, 170.0]))
X = np.array([-30.0, 0.0, 12.5, 40.0])
Y = np.array([3.0, -7.0, 0.0, 22.0])
S = np.array([0.0, 2.0, 5.0, 20.0])
T = np.array([0.0, 3.3, 61.7])


@pytest.mark.parametrize("second_order", [True, False])
def test_a_head_sea_is_the_long_crested_kinematics(second_order):
    c = replace(SEA, second_order=second_order)
    vel, acc = kinematics_xyz(c, X, Y, S, T)
    u, w, ud, wd = particle_kinematics_grid(c, X, S, T)
    np.testing.assert_allclose(vel[..., 0], u, atol=1e-12)
    np.testing.assert_allclose(vel[..., 2], w, atol=1e-12)
    np.testing.assert_allclose(acc[..., 0], ud, atol=1e-12)
    np.testing.assert_allclose(acc[..., 2], wd, atol=1e-12)
    assert np.abs(vel[..., 1]).max() == 0.0 and np.abs(acc[..., 1]).max() == 0.0
    c0 = replace(c, direction=np.zeros(c.n))          # β = 0 given explicitly: the same sea
    np.testing.assert_allclose(kinematics_xyz(c0, X, Y, S, T)[0], vel, atol=1e-13)


def test_a_spread_sea_on_the_vertical_plane_is_the_planar_models_in_plane_share():
    vel, acc = kinematics_xyz(SPREAD, X, 0.0, S, T)
    u, w, ud, wd = particle_kinematics_grid(SPREAD, X, S, T)
    for got, want in ((vel[..., 0], u), (vel[..., 2], w), (acc[..., 0], ud), (acc[..., 2], wd)):
        np.testing.assert_allclose(got, want, atol=1e-12)


@pytest.mark.parametrize("gamma_deg", [90.0, 37.0, -120.0])
def test_turning_the_sea_turns_the_flow(gamma_deg):
    """Sea and points turned by γ about the vertical: the flow at the turned points is R_z(γ) of the flow."""
    g = math.radians(gamma_deg)
    Rz = np.array([[math.cos(g), -math.sin(g), 0.0], [math.sin(g), math.cos(g), 0.0], [0.0, 0.0, 1.0]])
    turned = replace(SPREAD, direction=SPREAD.direction + g)
    pts = Rz @ np.stack([X, Y, S])
    vel, acc = kinematics_xyz(SPREAD, X, Y, S, T)
    vel_t, acc_t = kinematics_xyz(turned, pts[0], pts[1], pts[2], T)
    np.testing.assert_allclose(vel_t, vel @ Rz.T, atol=1e-12)
    np.testing.assert_allclose(acc_t, acc @ Rz.T, atol=1e-12)
    if gamma_deg == 90.0:      # a 90° turn swaps u into v
        head = replace(SEA, direction=np.zeros(SEA.n))
        v90 = kinematics_xyz(replace(SEA, direction=np.full(SEA.n, g)), -Y, X, S, T)[0]
        u0 = kinematics_xyz(head, X, Y, S, T)[0]
        np.testing.assert_allclose(v90[..., 1], u0[..., 0], atol=1e-12)
        np.testing.assert_allclose(v90[..., 0], 0.0, atol=1e-12)


def test_one_linear_component_by_hand():
    A, om, eps, beta = 0.7, 0.9, 1.1, math.radians(40.0)
    c = replace(WaveComponents.from_spectrum_lines([A], [om], [eps], DEPTH, False), direction=np.array([beta]))
    k = float(c.k[0])
    assert om**2 == pytest.approx(9.81 * k * math.tanh(k * DEPTH), rel=1e-13)
    x, y, s, t = 13.0, -4.0, 6.0, 2.5
    chi = k * (x * math.cos(beta) + y * math.sin(beta)) - om * t + eps
    ch, sh = math.cosh(k * (DEPTH - s)) / math.sinh(k * DEPTH), math.sinh(k * (DEPTH - s)) / math.sinh(k * DEPTH)
    vel, acc = kinematics_xyz(c, x, y, s, t)
    want_v = [om * A * ch * math.cos(beta) * math.cos(chi), om * A * ch * math.sin(beta) * math.cos(chi),
              -om * A * sh * math.sin(chi)]
    want_a = [om**2 * A * ch * math.cos(beta) * math.sin(chi), om**2 * A * ch * math.sin(beta) * math.sin(chi),
              om**2 * A * sh * math.cos(chi)]
    np.testing.assert_allclose(vel[0, 0], want_v, atol=1e-14)
    np.testing.assert_allclose(acc[0, 0], want_a, atol=1e-14)


def test_the_flow_is_incompressible_and_irrotational_and_follows_the_surface():
    """Finite differences (central, 1e-3 m / s): ∇·u = 0 and ∇×u = 0 at points below the surface, with
    the Stokes terms; and at the still surface the linear sea's w↑ = ∂ζ/∂t (the kinematic condition)."""
    h = 1e-3
    p0 = np.array([4.0, -3.0, 3.0])
    grads = np.empty((3, 3))                   # grads[i, j] = ∂u_i/∂x_j (NED: x_3 is depth)
    for j in range(3):
        d = np.zeros(3)
        d[j] = h
        up, dn = (kinematics_xyz(SPREAD, *(p0 + sgn * d), 7.0)[0][0, 0] for sgn in (1, -1))
        grads[:, j] = (up - dn) / (2 * h)
    scale = np.abs(grads).max()
    assert abs(np.trace(grads)) < 1e-6 * scale
    np.testing.assert_allclose(grads, grads.T, atol=1e-6 * scale)
    linear = replace(SPREAD, second_order=False)
    xs, ys, t = np.array([0.0, 10.0]), np.array([0.0, -5.0]), 4.0
    w_up = -kinematics_xyz(linear, xs, ys, 0.0, t)[0][0, :, 2]
    dzeta = (elevation_xy(linear, xs, ys, t + h) - elevation_xy(linear, xs, ys, t - h)) / (2 * h)
    np.testing.assert_allclose(w_up, dzeta, atol=1e-6 * np.abs(dzeta).max())


# ---------------------------------------------------------------------------- spreading

@pytest.mark.parametrize("s", [0.5, 2.0, 10.0, 75.0, 200.0])
def test_the_spreading_density_integrates_to_one(s):
    total, _ = quad(lambda th: float(cos2s_density(th, s, 0.4)), 0.4 - math.pi, 0.4 + math.pi, limit=200,
                    points=[0.4])
    assert total == pytest.approx(1.0, abs=1e-10)


def _moment(s: float, n: int) -> float:
    """E[cos n(θ − θ_p)] under D, by quadrature."""
    val, _ = quad(lambda d: float(cos2s_density(d, s)) * math.cos(n * d), -math.pi, math.pi, limit=200, points=[0.0])
    return val


@pytest.mark.parametrize("s", [2.0, 10.0, 75.0])
def test_sampled_directions_have_the_first_moment_and_spread_of_cos_2s(s):
    """Over N = 50 000 components: R̄ = mean cos(β − θ_p) ≈ s/(s + 1) and the spread √(2(1 − R̄)) ≈
    √(2/(s + 1)), each within 4 standard errors of the sample mean (its variance (1 + m₂)/2 − m₁² over N,
    m₂ = E[cos 2Δ] by quadrature). The tabulated inverse CDF's own error (grid 1.5e-3 rad) is below 1e-6."""
    n, theta_p = 50_000, math.radians(-30.0)
    beta = cos2s_directions(s, theta_p, n, np.random.default_rng(11))
    m1, m2 = s / (s + 1), _moment(s, 2)
    assert _moment(s, 1) == pytest.approx(m1, abs=1e-10)
    se = math.sqrt(((1 + m2) / 2 - m1**2) / n)
    r_bar = float(np.mean(np.cos(beta - theta_p)))
    assert abs(r_bar - m1) < 4 * se
    assert abs(float(np.mean(np.sin(beta - theta_p)))) < 4 * math.sqrt((1 - m2) / 2 / n)
    spread = math.sqrt(2 * (1 - r_bar))
    assert abs(spread - math.sqrt(2 / (s + 1))) < 4 * se / math.sqrt(2 * (1 - m1))


def test_sampled_directions_follow_the_cos_2s_distribution():
    """Kolmogorov–Smirnov against the CDF by quadrature: D_N below its 0.1 % critical value 1.95/√N."""
    s, n = 10.0, 20_000
    beta = np.sort(cos2s_directions(s, 0.0, n, np.random.default_rng(5)))
    probe = beta[:: n // 200]
    cdf = np.array([quad(lambda d: float(cos2s_density(d, s)), -math.pi, b, limit=200)[0] for b in probe])
    ecdf = (np.arange(0, n, n // 200) + 1) / n
    assert np.abs(ecdf - cdf).max() < 1.95 / math.sqrt(n)


@pytest.mark.parametrize("s", [None, math.inf])
def test_long_crested_is_every_component_at_the_mean_direction(s):
    rng = np.random.default_rng(1)
    state = rng.bit_generator.state
    beta = cos2s_directions(s, 0.7, 9, rng)
    assert beta.tolist() == [0.7] * 9
    assert rng.bit_generator.state == state             # no draws taken
    c = spread_components(SEA, s, math.radians(90.0), rng)
    v = kinematics_xyz(c, X, Y, S, T)[0]
    np.testing.assert_allclose(v[..., 0], 0.0, atol=1e-12)    # a beam sea: no flow along x


def test_spreading_keeps_the_frequency_components():
    c = spread_components(SEA, 10.0, 0.3, np.random.default_rng(2))
    for name in ("amplitude", "omega", "k", "phase"):
        np.testing.assert_array_equal(getattr(c, name), getattr(SEA, name))
    assert c.hs() == SEA.hs() and c.direction is not None and c.direction.shape == (SEA.n,)


def test_the_worlds_sampler_is_this_one():
    from sitl import sea
    assert sea.cos2s_directions is cos2s_directions


@pytest.mark.parametrize("s", [2.0, 10.0, 75.0])
def test_a_spread_seas_realised_spread_is_the_input_s(s):
    """The oracle for a realised sea: a JONSWAP sea of 4096 components (W2, frequencies jittered in their bins)
    spread about 60°: the energy-weighted first moment is s/(s + 1) and the spread √(2/(s + 1)) within 4
    standard errors for its effective number of components, the mean direction within 4 of its own."""
    from sitl.sea import discretise_spectrum, jonswap_spectrum
    rng = np.random.default_rng(7)
    wp = 2 * math.pi / 9.5
    omega, amp = discretise_spectrum(lambda w: jonswap_spectrum(w, 3.47, 9.5), 0.5 * wp, 5 * wp, 4096, rng)
    c = WaveComponents.from_spectrum_lines(amp, omega, rng.uniform(0, 2 * math.pi, omega.size), DEPTH)
    theta_p = math.radians(60.0)
    mom = directional_moments(spread_components(c, s, theta_p, rng))
    m1, m2 = s / (s + 1), _moment(s, 2)
    se = math.sqrt(((1 + m2) / 2 - m1**2) / mom.n_eff)
    assert 400 < mom.n_eff < 4096                      # the spectrum's peak carries the energy
    assert abs(mom.r1 - m1) < 4 * se
    assert abs(mom.spread - math.sqrt(2 / (s + 1))) < 4 * se / math.sqrt(2 * (1 - m1))
    assert abs(mom.mean - theta_p) < 4 * math.sqrt((1 - m2) / 2 / mom.n_eff) / m1
    long_crested = directional_moments(c)
    assert long_crested.r1 == pytest.approx(1.0, abs=1e-14) and long_crested.mean == 0.0
