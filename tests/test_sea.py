"""The simulated sea checked against independent truth.

Every expectation here comes from an analytic limit, a textbook formula
(Dean & Dalrymple; DNV-RP-C205; Pierson–Moskowitz) or a property any correct
implementation must have (energy conservation, ∂ζ/∂t = w at the surface, …) —
never from numbers captured from the code's own output.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.signal import welch

from bridge.models.waves import (
    G,
    WaveComponents,
    elevation,
    particle_kinematics,
    particle_kinematics_grid,
    wavenumber,
)
from sitl.sea import MeasuredSpectrum, Sea, jonswap_spectrum, load_sea_config

# Published sea states (Walker et al. Table I) as written in configs/sea/*.yaml.
CASES = {"W1": (2.78, 7.1), "W2": (3.47, 9.5), "W3": (3.24, 11.1)}
DEPTH = 54.0


# ---------------------------------------------------------------------------- helpers

def pm_closed_form(omega, hs, tp):
    """Pierson–Moskowitz in Hs, ω_p: (5/16) Hs² ω_p⁴ ω⁻⁵ exp(−1.25 (ω_p/ω)⁴)."""
    wp = 2 * np.pi / tp
    omega = np.asarray(omega, dtype=float)
    return 5.0 / 16.0 * hs**2 * wp**4 * omega**-5 * np.exp(-1.25 * (wp / omega) ** 4)


def jonswap_dnv(omega, hs, tp, gamma):
    """DNV-RP-C205 Eq. 3.5.5.x: A_γ S_PM γ^exp(−(ω−ω_p)²/(2σ²ω_p²)), A_γ = 1 − 0.287 ln γ."""
    wp = 2 * np.pi / tp
    omega = np.asarray(omega, dtype=float)
    sigma = np.where(omega <= wp, 0.07, 0.09)
    peak = gamma ** np.exp(-((omega - wp) ** 2) / (2 * sigma**2 * wp**2))
    return (1 - 0.287 * np.log(gamma)) * pm_closed_form(omega, hs, tp) * peak


def single(amplitude, omega, depth, phase=0.3, second_order=False):
    return WaveComponents.from_spectrum_lines([amplitude], [omega], [phase], depth, second_order)


def single_sea(amplitude, omega, depth, phase=0.3, buoy_x=-50.0, rate=2.0):
    c = single(amplitude, omega, depth, phase, second_order=False)
    return Sea("one", c, lambda w: np.zeros_like(w), omega, c.hs(), 0, buoy_x, rate)


@pytest.fixture(scope="module")
def seas():
    return {name: Sea.load(name) for name in CASES}


# ---------------------------------------------------------------------------- 1. JONSWAP

@pytest.mark.parametrize("hs,tp,gamma", [(2.78, 7.1, 3.3), (3.47, 9.5, 3.3), (3.24, 11.1, 1.0),
                                         (1.0, 5.0, 1.0), (5.0, 14.0, 2.0), (2.0, 8.0, 7.0)])
def test_jonswap_integrates_to_hs_squared_over_16(hs, tp, gamma):
    wp = 2 * np.pi / tp
    f = lambda w: float(jonswap_spectrum(np.array([w]), hs, tp, gamma)[0])  # noqa: E731
    m0 = (quad(f, 1e-3, wp, limit=400, points=[0.7 * wp])[0]
          + quad(f, wp, 3 * wp, limit=400, points=[1.3 * wp])[0]
          + quad(f, 3 * wp, np.inf, limit=400)[0])
    assert m0 == pytest.approx(hs**2 / 16, rel=5e-3)


@pytest.mark.parametrize("gamma", [1.0, 3.3, 7.0])
@pytest.mark.parametrize("tp", [7.1, 11.1])
def test_jonswap_peak_is_at_two_pi_over_tp(tp, gamma):
    wp = 2 * np.pi / tp
    w = np.linspace(0.5 * wp, 2.0 * wp, 150_001)           # step 1e-5 ω_p
    s = jonswap_spectrum(w, 3.0, tp, gamma)
    assert abs(w[np.argmax(s)] - wp) <= 2e-5 * wp


def test_jonswap_gamma_one_is_pierson_moskowitz():
    for hs, tp in [(2.78, 7.1), (3.24, 11.1), (0.5, 3.0)]:
        wp = 2 * np.pi / tp
        w = np.linspace(0.3 * wp, 6 * wp, 2001)
        np.testing.assert_allclose(jonswap_spectrum(w, hs, tp, 1.0), pm_closed_form(w, hs, tp),
                                   rtol=1e-9, atol=0)


@pytest.mark.parametrize("gamma", [2.0, 3.3, 5.0])
def test_jonswap_agrees_with_dnv_closed_form(gamma):
    hs, tp = 2.78, 7.1
    wp = 2 * np.pi / tp
    w = np.linspace(0.5 * wp, 5 * wp, 4001)
    ref = jonswap_dnv(w, hs, tp, gamma)
    got = jonswap_spectrum(w, hs, tp, gamma)
    sig = ref > 1e-4 * ref.max()
    rel = np.abs(got[sig] / ref[sig] - 1)
    assert rel.max() < 0.02
    # it is *not* simply PM: the peak is raised
    assert got.max() > 1.5 * pm_closed_form(wp, hs, tp)


@pytest.mark.parametrize("gamma", [2.0, 3.3, 5.0])
def test_jonswap_peak_enhancement_ratio_is_gamma(gamma):
    """S_J(ω_p)/S_PM(ω_p) = γ · C(γ) with C(γ) = (Hs²/16)/∫ PM·γ^Γ dω (the normalisation)."""
    hs, tp = 3.0, 9.0
    wp = 2 * np.pi / tp
    # C(γ) computed independently from the unnormalised DNV shape (A_γ divided out)
    shape = lambda w: float(jonswap_dnv(w, hs, tp, gamma) / (1 - 0.287 * np.log(gamma)))  # noqa: E731
    integral = (quad(shape, 0.2 * wp, wp, limit=400)[0] + quad(shape, wp, 3 * wp, limit=400)[0]
                + quad(shape, 3 * wp, np.inf, limit=400)[0])
    c_gamma = hs**2 / 16 / integral
    ratio = float(jonswap_spectrum(np.array([wp]), hs, tp, gamma)[0]) / pm_closed_form(wp, hs, tp)
    assert ratio == pytest.approx(gamma * c_gamma, rel=2e-4)
    # and the shape ratio away from the peak tends to the normalisation alone
    w_far = 3 * wp
    far = float(jonswap_spectrum(np.array([w_far]), hs, tp, gamma)[0]) / pm_closed_form(w_far, hs, tp)
    assert far == pytest.approx(c_gamma, rel=1e-6)


def test_jonswap_vanishes_at_low_frequency():
    w = np.array([0.0, -1.0, 1e-6, 1e-3, 0.05])
    s = jonswap_spectrum(w, 2.78, 7.1, 3.3)
    assert s.shape == w.shape
    assert s[0] == 0.0 and s[1] == 0.0
    assert np.all(np.isfinite(s)) and np.all(s >= 0)
    assert np.all(s[2:] < 1e-30)           # exp(−1.25 (ω_p/ω)⁴) kills it


@pytest.mark.parametrize("hs,tp,gamma", [(0.0, 7.0, 3.3), (-1.0, 7.0, 3.3), (2.0, 0.0, 3.3),
                                         (2.0, -5.0, 3.3), (2.0, 7.0, 0.5), (np.nan, 7.0, 3.3)])
def test_jonswap_rejects_invalid_parameters(hs, tp, gamma):
    with pytest.raises(ValueError):
        jonswap_spectrum(np.array([1.0]), hs, tp, gamma)


# ---------------------------------------------------------------------------- 2. realised record

@pytest.fixture(scope="module")
def long_records(seas):
    """3 h at 2 Hz at x = 0 (the configs are 2nd order)."""
    t = np.arange(0.0, 3 * 3600.0, 0.5)
    return {name: seas[name].elevation(0.0, t) for name in ("W1", "W3")}


@pytest.mark.parametrize("name", ["W1", "W3"])
def test_record_hs_matches_config(name, long_records):
    hs, _ = CASES[name]
    z = long_records[name]
    assert abs(np.mean(z)) < 0.05 * hs
    assert 4 * np.std(z) == pytest.approx(hs, rel=0.05)


@pytest.mark.parametrize("name", ["W1", "W3"])
def test_record_welch_peak_and_energy_match_jonswap(name, long_records):
    hs, tp = CASES[name]
    f, p = welch(long_records[name], fs=2.0, nperseg=1024)
    df = f[1] - f[0]
    assert abs(f[np.argmax(p)] - 1 / tp) <= 1.5 * df
    # energy near the peak agrees with the target spectrum, S(f) = 2π S(ω)
    s_f = 2 * np.pi * jonswap_spectrum(2 * np.pi * f, hs, tp, 3.3)
    band = (f >= 0.8 / tp) & (f <= 1.2 / tp)
    assert p[band].sum() / s_f[band].sum() == pytest.approx(1.0, rel=0.10)


@pytest.mark.parametrize("name", list(CASES))
def test_realised_component_hs_matches_target(name, seas):
    hs, _ = CASES[name]
    assert seas[name].hs_target == hs
    assert seas[name].hs() == pytest.approx(hs, rel=0.01)


# ---------------------------------------------------------------------------- 3. non-repetition

@pytest.mark.parametrize("name", list(CASES))
def test_record_does_not_repeat_within_600s(name, seas):
    """Correlate the 600 s window [0, 600) with [τ, τ + 600) for τ = 60 … 600 s."""
    t = np.arange(0.0, 1200.0, 0.5)
    z = seas[name].elevation(0.0, t)
    n = 1200                                        # 600 s at 2 Hz
    a = (z[:n] - z[:n].mean()) / z[:n].std()
    windows = np.lib.stride_tricks.sliding_window_view(z, n)[120:1201]   # τ = 60 … 600 s
    b = (windows - windows.mean(axis=1, keepdims=True)) / windows.std(axis=1, keepdims=True)
    corr = b @ a / n
    assert np.max(np.abs(corr)) < 0.5


def test_record_decorrelates_after_a_few_periods(seas):
    """Lags 30–100 s: far below 1 (the continuous JONSWAP ACF is ≲ 0.2 there)."""
    t = np.arange(0.0, 800.0, 0.5)
    for name in CASES:
        z = seas[name].elevation(0.0, t)
        n = 1200
        a = (z[:n] - z[:n].mean()) / z[:n].std()
        windows = np.lib.stride_tricks.sliding_window_view(z, n)[60:201]
        b = (windows - windows.mean(axis=1, keepdims=True)) / windows.std(axis=1, keepdims=True)
        assert np.max(np.abs(b @ a / n)) < 0.5


# ---------------------------------------------------------------------------- 4. dispersion

def test_dispersion_deep_water_limit():
    omega = np.linspace(1.0, 8.0, 50)
    for d in (1000.0, 5000.0):
        k = wavenumber(omega, d)
        assert np.all(k * d > 50)
        np.testing.assert_allclose(k, omega**2 / G, rtol=1e-12)


def test_dispersion_shallow_water_limit():
    d = 0.5
    omega = np.array([0.005, 0.01, 0.02, 0.05])
    k = wavenumber(omega, d)
    kd = k * d
    assert np.all(kd < 0.02)
    # ω = k√(gd)(1 − (kd)²/6 + …): relative error of the shallow limit is ≈ (kd)²/6
    rel = np.abs(omega / (k * np.sqrt(G * d)) - 1)
    assert np.all(rel < 1e-4)
    np.testing.assert_allclose(rel, kd**2 / 6, rtol=0.05)


def test_dispersion_relation_residual():
    omega = np.geomspace(0.05, 10.0, 80)
    for d in (1.0, 5.0, 20.0, 54.0, 200.0, 5000.0):
        k = wavenumber(omega, d)
        resid = G * k * np.tanh(k * d) - omega**2
        assert np.max(np.abs(resid) / omega**2) < 1e-12
    # another g is honoured
    k = wavenumber(omega, 30.0, g=3.71)
    assert np.max(np.abs(3.71 * k * np.tanh(k * 30.0) / omega**2 - 1)) < 1e-12


def test_dispersion_published_value():
    """Textbook example: T = 10 s in 10 m of water → L ≈ 92.3 m (Dean & Dalrymple tables, g = 9.81)."""
    k = float(wavenumber(2 * np.pi / 10.0, 10.0))
    assert 2 * np.pi / k == pytest.approx(92.3, abs=0.2)
    # and deep water L0 = gT²/2π = 156.1 m for the same period
    k0 = float(wavenumber(2 * np.pi / 10.0, 1.0e4))
    assert 2 * np.pi / k0 == pytest.approx(G * 100 / (2 * np.pi), rel=1e-12)


def test_dispersion_shape_preserved():
    omega = np.linspace(0.3, 3.0, 12).reshape(3, 4)
    k = wavenumber(omega, 54.0)
    assert k.shape == (3, 4)
    np.testing.assert_allclose(k.ravel(), wavenumber(omega.ravel(), 54.0), rtol=0, atol=0)
    assert np.shape(wavenumber(1.0, 54.0)) == ()


@pytest.mark.parametrize("omega,depth", [(1.0, 0.0), (1.0, -5.0), (1.0, np.inf), (1.0, np.nan),
                                         (0.0, 54.0), (-1.0, 54.0), ([1.0, np.nan], 54.0),
                                         ([1.0, np.inf], 54.0)])
def test_dispersion_rejects_bad_input(omega, depth):
    with pytest.raises(ValueError):
        wavenumber(omega, depth)


# ---------------------------------------------------------------------------- 5. linear kinematics

def test_deep_water_linear_kinematics():
    A, omega, d = 0.8, 0.9, 5000.0
    c = single(A, omega, d, phase=0.4)
    k = omega**2 / G
    x = np.array([0.0, 13.0, -40.0, 100.0])[:, None]
    s = np.array([0.0, 1.0, 5.0, 20.0])[None, :]
    t = np.linspace(0.0, 30.0, 7)[:, None, None]
    x, s, t = np.broadcast_arrays(x, s, t)
    u, w, ud, wd = particle_kinematics(c, x, s, t)
    th = k * x - omega * t + 0.4
    decay = A * omega * np.exp(-k * s)
    np.testing.assert_allclose(u, decay * np.cos(th), atol=1e-12)
    np.testing.assert_allclose(w, -decay * np.sin(th), atol=1e-12)      # NED: w down
    np.testing.assert_allclose(ud, omega * decay * np.sin(th), atol=1e-12)
    np.testing.assert_allclose(wd, omega * decay * np.cos(th), atol=1e-12)
    # and elevation
    np.testing.assert_allclose(elevation(c, x, t), A * np.cos(th), atol=1e-12)


def test_finite_depth_velocity_matches_paper_form():
    """u = gH/(2c) cosh k(z'+d)/cosh kd · cos θ and w↑ = gH/(2c) sinh k(z'+d)/cosh kd · sin θ."""
    A, d = 1.1, DEPTH
    for omega in (0.4, 0.7, 1.2):
        c = single(A, omega, d, phase=-1.0)
        k = float(c.k[0])
        cel = omega / k
        H = 2 * A
        s = np.linspace(0.0, d, 9)
        x, t = 7.0, 3.3
        th = k * x - omega * t - 1.0
        zp = -s
        u, w, _, _ = particle_kinematics(c, np.full_like(s, x), s, np.full_like(s, t))
        np.testing.assert_allclose(u, G * H / (2 * cel) * np.cosh(k * (zp + d)) / np.cosh(k * d) * np.cos(th),
                                   rtol=1e-10, atol=1e-13)
        np.testing.assert_allclose(-w, G * H / (2 * cel) * np.sinh(k * (zp + d)) / np.cosh(k * d) * np.sin(th),
                                   rtol=1e-10, atol=1e-13)
        assert abs(w[-1]) < 1e-12                    # no flow through the sea bed


def test_accelerations_are_time_derivatives(seas):
    """Central finite difference in t of (u, w) equals (u̇, ẇ), 2nd-order sea at finite depth."""
    sea = seas["W1"]
    assert sea.components.second_order
    x = np.array([-20.0, 0.0, 35.0])
    s = np.array([0.0, 3.0, 12.0])
    t = np.array([10.0, 123.4, 777.7])
    h = 1e-4
    up, wp = sea.particle_velocity(x, s, t + h)
    um, wm = sea.particle_velocity(x, s, t - h)
    ud, wd = sea.particle_acceleration(x, s, t)
    scale = np.max(np.abs(np.concatenate([ud, wd])))
    np.testing.assert_allclose((up - um) / (2 * h), ud, atol=1e-6 * scale)
    np.testing.assert_allclose((wp - wm) / (2 * h), wd, atol=1e-6 * scale)
    # single linear component, too
    c = single(1.0, 0.8, DEPTH)
    for sd in (0.0, 10.0):
        _u1, _w1, ud1, wd1 = particle_kinematics(c, 5.0, sd, 4.0)
        u2, w2, _, _ = particle_kinematics(c, 5.0, sd, 4.0 + h)
        u0, w0, _, _ = particle_kinematics(c, 5.0, sd, 4.0 - h)
        assert (u2 - u0) / (2 * h) == pytest.approx(ud1, abs=1e-7)
        assert (w2 - w0) / (2 * h) == pytest.approx(wd1, abs=1e-7)


def test_kinematics_broadcast_depth_with_x_and_t():
    """Docstring contract: x, depth and t broadcast together to a shape S."""
    c = single(1.0, 0.8, DEPTH)
    s = np.array([0.0, 5.0, 10.0])
    u, w, ud, wd = particle_kinematics(c, 0.0, s, 0.0)
    ref = particle_kinematics(c, np.zeros(3), s, np.zeros(3))
    for got, want in zip((u, w, ud, wd), ref, strict=False):
        assert got.shape == (3,)
        np.testing.assert_array_equal(got, want)


# ---------------------------------------------------------------------------- 6. second order

def _second_order_parts(A_scale):
    amp = A_scale * np.array([1.0, 0.6, 0.3])
    omega = np.array([0.6, 0.9, 1.4])
    phase = np.array([0.1, 2.0, -1.2])
    c1 = WaveComponents.from_spectrum_lines(amp, omega, phase, DEPTH, second_order=False)
    c2 = WaveComponents.from_spectrum_lines(amp, omega, phase, DEPTH, second_order=True)
    x = np.linspace(-30, 30, 5)[:, None]
    t = np.linspace(0, 20, 6)[None, :]
    s = 2.0
    lin = (elevation(c1, x, t), *particle_kinematics(c1, x, s, t))
    non = (elevation(c2, x, t), *particle_kinematics(c2, x, s, t))
    return lin, non


def test_second_order_terms_scale_as_amplitude_squared():
    lin_a, non_a = _second_order_parts(0.5)
    lin_b, non_b = _second_order_parts(0.05)
    for la, na, lb, nb in zip(lin_a, non_a, lin_b, non_b, strict=False):
        da = np.max(np.abs(na - la))
        db = np.max(np.abs(nb - lb))
        assert da > 0
        assert da / db == pytest.approx(100.0, rel=1e-6)
        # small amplitude: second order ≪ first order
        assert db < 0.01 * np.max(np.abs(lb))


def test_second_order_elevation_deep_water_limit():
    """Paper Eq. 5: ζ₂ → (k A²/2) cos 2θ for kd ≫ 1; deep-water 2nd-order velocity vanishes."""
    A, omega = 1.5, 1.0
    t = np.linspace(0, 12, 25)
    x = 4.0
    for d in (200.0, 5000.0):
        c1 = single(A, omega, d, phase=0.2, second_order=False)
        c2 = single(A, omega, d, phase=0.2, second_order=True)
        k = float(c2.k[0])
        assert k * d > 20
        th = k * x - omega * t + 0.2
        np.testing.assert_allclose(elevation(c2, x, t) - elevation(c1, x, t), k * A**2 / 2 * np.cos(2 * th),
                                   rtol=1e-12, atol=1e-12)
        u1, w1, _, _ = particle_kinematics(c1, x, 0.0, t)
        u2, w2, _, _ = particle_kinematics(c2, x, 0.0, t)
        bound = 3 / 4 * omega * k * A**2 * 8 * np.exp(-2 * k * d)   # ∝ e^{−2kd}
        assert np.max(np.abs(u2 - u1)) <= 1.001 * bound + 1e-14
        assert np.max(np.abs(w2 - w1)) <= 1.001 * bound + 1e-14


def test_second_order_finite_depth_matches_dean_dalrymple():
    """ζ₂ = (H²k/16) cosh kd (2 + cosh 2kd)/sinh³ kd cos 2θ;
    u₂ = (3/16) H² ω k cosh 2k(d+z')/sinh⁴ kd cos 2θ; w₂↑ likewise with sinh and sin 2θ."""
    A, d = 1.0, 20.0
    for omega in (0.5, 0.8):
        c1 = single(A, omega, d, phase=0.7, second_order=False)
        c2 = single(A, omega, d, phase=0.7, second_order=True)
        k = float(c2.k[0])
        H = 2 * A
        x, t = 3.0, np.linspace(0, 15, 11)
        th = k * x - omega * t + 0.7
        kd = k * d
        eta2 = H**2 * k / 16 * np.cosh(kd) * (2 + np.cosh(2 * kd)) / np.sinh(kd) ** 3 * np.cos(2 * th)
        np.testing.assert_allclose(elevation(c2, x, t) - elevation(c1, x, t), eta2, rtol=1e-10, atol=1e-13)
        for s in (0.0, 5.0, d):
            zp = -s
            u1, w1, _, _ = particle_kinematics(c1, x, s, t)
            u2, w2, _, _ = particle_kinematics(c2, x, s, t)
            amp = 3 / 16 * H**2 * omega * k / np.sinh(kd) ** 4
            np.testing.assert_allclose(u2 - u1, amp * np.cosh(2 * k * (d + zp)) * np.cos(2 * th),
                                       rtol=1e-10, atol=1e-13)
            np.testing.assert_allclose(-(w2 - w1), amp * np.sinh(2 * k * (d + zp)) * np.sin(2 * th),
                                       rtol=1e-10, atol=1e-13)


# ---------------------------------------------------------------------------- 7. surface kinematics

@pytest.mark.parametrize("depth", [DEPTH, 10.0, 5000.0])
def test_surface_vertical_velocity_is_dzeta_dt(depth):
    c = single(0.9, 0.75, depth, phase=1.3)
    x = np.array([-25.0, 0.0, 17.0])[:, None]
    t = np.linspace(0, 20, 9)[None, :]
    h = 1e-4
    dzdt = (elevation(c, x, t + h) - elevation(c, x, t - h)) / (2 * h)
    _, w, _, _ = particle_kinematics(c, x, 0.0, t)
    np.testing.assert_allclose(-w, dzdt, atol=1e-7)
    # deep water: at the surface u = ω ζ (both ∝ cos θ with ratio ω)
    if depth > 1000:
        u, _, _, _ = particle_kinematics(c, x, 0.0, t)
        np.testing.assert_allclose(u, 0.75 * elevation(c, x, t), atol=1e-12)   # u = ω ζ at the surface


# ---------------------------------------------------------------------------- 8. grid == pointwise

@pytest.mark.parametrize("second_order", [True, False])
def test_grid_equals_pointwise(second_order):
    cfg = load_sea_config("W1")
    cfg["second_order"] = second_order
    sea = Sea.from_config(cfg)
    c = sea.components
    assert c.second_order is second_order
    rng = np.random.default_rng(7)
    x = rng.uniform(-60, 60, 17)
    s = rng.uniform(0, 30, 17)
    t = np.sort(rng.uniform(0, 2000, 23))
    grid = particle_kinematics_grid(c, x, s, t)
    point = particle_kinematics(c, x[None, :], s[None, :], t[:, None])
    for g_, p_ in zip(grid, point, strict=False):
        assert g_.shape == (23, 17)
        np.testing.assert_allclose(g_, p_, rtol=0, atol=1e-12)


# ---------------------------------------------------------------------------- 9. determinism & measured spectra

def test_same_seed_same_sea_different_seed_different_phases():
    a, b = Sea.load("W2", seed=42), Sea.load("W2", seed=42)
    for name in ("amplitude", "omega", "k", "phase"):
        np.testing.assert_array_equal(getattr(a.components, name), getattr(b.components, name))
    c = Sea.load("W2", seed=43)
    assert c.components.n == a.components.n
    assert np.mean(np.abs(np.angle(np.exp(1j * (c.components.phase - a.components.phase))))) > 0.5
    # the config seed is the default
    d = Sea.load("W2")
    assert d.seed == load_sea_config("W2")["seed"]
    np.testing.assert_array_equal(d.components.phase, Sea.load("W2").components.phase)


def test_measured_spectrum_csv_round_trip(tmp_path):
    hs, tp = 2.78, 7.1
    f = np.linspace(0.04, 0.6, 120)
    s_f = 2 * np.pi * jonswap_spectrum(2 * np.pi * f, hs, tp, 3.3)
    path = tmp_path / "buoy.csv"
    path.write_text("frequency_hz,density_m2_per_hz\n"
                    + "".join(f"{float(fi)!r},{float(si)!r}\n" for fi, si in zip(f, s_f, strict=True)),
                    encoding="utf-8")
    m = MeasuredSpectrum.from_csv(path)
    np.testing.assert_allclose(m(2 * np.pi * f), jonswap_spectrum(2 * np.pi * f, hs, tp, 3.3), rtol=1e-12)
    # outside the measured band: zero
    assert np.all(m(np.array([0.01, 2 * np.pi * 0.7])) == 0)
    # energy over the band ≈ Hs²/16 (the JONSWAP tail outside 0.04–0.6 Hz is tiny)
    w = np.linspace(2 * np.pi * 0.04, 2 * np.pi * 0.6, 20001)
    assert np.trapezoid(m(w), w) == pytest.approx(hs**2 / 16, rel=0.01)
    assert m.omega_peak == pytest.approx(2 * np.pi / tp, abs=2 * np.pi * (f[1] - f[0]))


@pytest.mark.parametrize("body", [
    "f,s\n0.05,0.1\nabc,0.2\n0.2,0.3\n0.3,0.1\n",        # non-numeric row after the header
    "f,s\n0.05,0.1\n0.2,0.2\n0.1,0.3\n0.3,0.1\n",        # decreasing frequency
    "f,s\n0.05,0.1\n0.1,-0.2\n0.2,0.3\n0.3,0.1\n",       # negative density
    "f,s\n0.05,0.1\n0.1\n0.2,0.3\n0.3,0.1\n",            # missing column
    "f,s\n0.05,0.1\n0.1,0.2\n",                          # too few rows
])
def test_malformed_measured_csv_raises(tmp_path, body):
    path = tmp_path / "bad.csv"
    path.write_text(body, encoding="utf-8")
    with pytest.raises(ValueError):
        MeasuredSpectrum.from_csv(path)


# ---------------------------------------------------------------------------- 10. buoy

def test_buoy_records_elevation_at_its_position(seas):
    sea = seas["W1"]
    buoy = sea.buoy()
    assert buoy.x == -50.0 and buoy.sample_rate == 2.0
    t, z = buoy.record(0.0, 100.0)
    np.testing.assert_allclose(t, np.arange(201) * 0.5, rtol=0, atol=1e-12)
    assert np.allclose(np.diff(t), 0.5)
    np.testing.assert_allclose(z, sea.elevation(-50.0, t), rtol=0, atol=1e-12)
    assert np.std(z) > 0.1


def test_buoy_sees_the_wave_earlier_by_dx_over_c():
    omega = 0.8
    sea = single_sea(1.2, omega, DEPTH, phase=0.5, buoy_x=-50.0)
    k = float(sea.components.k[0])
    celerity = omega / k
    t, z_buoy = sea.buoy().record(0.0, 60.0)
    z_vehicle_later = sea.elevation(0.0, t + 50.0 / celerity)
    np.testing.assert_allclose(z_buoy, z_vehicle_later, atol=1e-10)
    # the same record is *not* what the vehicle sees at the same instant
    assert np.max(np.abs(z_buoy - sea.elevation(0.0, t))) > 0.1


def test_the_tabulated_jonswap_norms_are_the_quadratures_to_the_bit():
    """sitl.sea skips scipy.integrate for the configs' γ: the table must be quad's own result, bit for bit."""
    from sitl.sea import _KNOWN_NORMS, _jonswap_norm, _jonswap_norm_quad
    for gamma, norm in _KNOWN_NORMS.items():
        assert _jonswap_norm_quad(gamma) == norm
        assert _jonswap_norm(gamma) == norm
    configs = sorted((Path(__file__).resolve().parent.parent / "configs" / "sea").rglob("*.yaml"))
    gammas = {load_sea_config(p)["spectrum"].get("gamma") for p in configs}
    assert gammas - {None} <= set(_KNOWN_NORMS), gammas
