"""T200 curve against Blue Robotics' published points; layout against ArduSub's Vectored_6DOF factors."""
from __future__ import annotations

import numpy as np
import pytest

from bridge.models.thrusters import KGF, T200Curve, ThrusterLayout, power_per_dof
from bridge.schemas import load_vehicle_config

# docs/reference.md §5: 16 V samples, PWM µs → kgf (Blue Robotics T200 performance data)
PUBLISHED = [(1100, -4.07), (1184, -2.94), (1308, -1.35), (1472, 0.0), (1528, 0.0), (1624, 0.87),
             (1728, 2.22), (1840, 4.25), (1864, 4.71), (1900, 5.25)]

# docs/reference.md §3: ArduSub AP_Motors6DOF, SUB_FRAME_VECTORED_6DOF (roll, pitch, yaw, throttle, forward, lateral)
ARDUSUB_FACTORS = np.array([
    [0, 0, +1, 0, -1, +1],
    [0, 0, -1, 0, -1, -1],
    [0, 0, -1, 0, +1, +1],
    [0, 0, +1, 0, +1, -1],
    [+1, -1, 0, -1, 0, 0],
    [-1, -1, 0, -1, 0, 0],
    [+1, +1, 0, -1, 0, 0],
    [-1, +1, 0, -1, 0, 0],
])


@pytest.fixture(scope="module")
def cfg():
    return load_vehicle_config("bluerov2_heavy")["thrusters"]


@pytest.fixture(scope="module")
def curve(cfg):
    return T200Curve.from_config(cfg)


@pytest.fixture(scope="module")
def layout(cfg):
    return ThrusterLayout.from_config(cfg)


def test_curve_passes_the_published_points(curve):
    pwm, kgf = np.array(PUBLISHED).T
    np.testing.assert_allclose(curve.thrust(pwm), kgf * KGF, atol=1e-9)


def test_curve_is_asymmetric_with_a_dead_band_and_monotone(curve):
    assert curve.thrust_max == pytest.approx(5.25 * KGF)
    assert curve.thrust_min == pytest.approx(-4.07 * KGF)
    band = np.linspace(1472, 1528, 57)
    assert np.all(curve.thrust(band) == 0.0)
    p = np.linspace(1100, 1900, 8001)
    assert np.all(np.diff(curve.thrust(p)) >= 0)
    assert curve.thrust(1500.0) == 0.0


def test_pwm_is_the_exact_inverse_of_thrust(curve):
    f = np.concatenate([np.linspace(-39.9, -0.01, 200), np.linspace(0.01, 51.4, 200)])
    np.testing.assert_allclose(curve.thrust(curve.pwm(f)), f, atol=1e-5)
    assert curve.pwm(0.0) == 1500.0
    # Beyond the thruster's range the command saturates at the ESC limits
    assert curve.pwm(1000.0) == pytest.approx(1900.0)
    assert curve.pwm(-1000.0) == pytest.approx(1100.0)
    # Thrust outside the ESC's PWM range is clipped
    assert curve.thrust(2400.0) == pytest.approx(curve.thrust_max)


def test_bad_curves_are_refused():
    with pytest.raises(ValueError):
        T200Curve([1100, 1500, 1400, 1900], [-1, 0, 0, 1])      # PWM not increasing
    with pytest.raises(ValueError):
        T200Curve([1100, 1300, 1700, 1900], [-1, -0.5, 0.5, 1])  # no dead band


def test_layout_reproduces_ardusub_motor_factor_signs(layout):
    W = layout.wrench_matrix()  # rows X, Y, Z, K, M, N
    X, Y, Z, K, M, N = W
    # ArduSub's throttle is positive up (−Z in FRD); roll, pitch, yaw are the body moments.
    ours = np.stack([K, M, N, -Z, X, Y], axis=1)
    np.testing.assert_array_equal(np.sign(np.round(ours, 12)), ARDUSUB_FACTORS)


def test_planar_allocation_matrix_is_derived_and_full_rank(layout):
    B = layout.allocation_matrix()
    assert B.shape == (3, 8)
    assert np.linalg.matrix_rank(B) == 3
    c45 = np.cos(np.pi / 4)
    # Surge row: the 45° horizontal thrusters contribute cos 45° each (the authors' rows)
    np.testing.assert_allclose(np.abs(B[0, :4]), c45, rtol=1e-8)
    np.testing.assert_allclose(B[0, 4:], 0.0, atol=1e-12)
    # Heave row: the vertical thrusters push along body z; pitch arms ±0.12 m
    np.testing.assert_allclose(B[1, 4:], 1.0)
    np.testing.assert_allclose(np.abs(B[2, 4:]), 0.12)


def test_pure_surge_wrench_gives_no_heave_or_pitch(layout, curve):
    B = layout.allocation_matrix()
    for surge in (-40.0, -5.0, 3.0, 60.0):
        f = np.linalg.pinv(B) @ np.array([surge, 0.0, 0.0])
        applied = B @ curve.thrust(curve.pwm(f))
        assert applied[0] == pytest.approx(surge, rel=1e-5)
        assert abs(applied[1]) < 1e-5 and abs(applied[2]) < 1e-5


def test_pure_heave_and_pitch_wrenches_do_not_leak(layout, curve):
    B = layout.allocation_matrix()
    for tau in ([0.0, 30.0, 0.0], [0.0, 0.0, 4.0], [0.0, -20.0, -3.0]):
        applied = B @ curve.thrust(curve.pwm(np.linalg.pinv(B) @ np.array(tau)))
        np.testing.assert_allclose(applied, tau, atol=1e-5)


def test_power_polynomial_matches_the_paper():
    # P = 0.0011 τ³ + 0.02078 τ² + 0.297 τ on |τ|
    assert power_per_dof(10.0) == pytest.approx(1.1 + 2.078 + 2.97)
    assert power_per_dof(-10.0) == pytest.approx(power_per_dof(10.0))
    assert power_per_dof(0.0) == 0.0


def test_pchip_is_scipys_to_the_last_bit():
    """bridge.models.pchip reproduces scipy.interpolate.PchipInterpolator exactly (coefficients and values)."""
    from scipy.interpolate import PchipInterpolator

    from bridge.models.pchip import Pchip

    rng = np.random.default_rng(13)
    curve = T200Curve.from_config(load_vehicle_config("bluerov2_heavy")["thrusters"])
    cases = [(curve.pwm_samples, curve.thrust_samples)]
    for _ in range(100):
        n = int(rng.integers(3, 20))
        x = np.cumsum(rng.uniform(0.1, 3.0, n))
        y = rng.normal(size=n) if rng.random() < 0.5 else np.cumsum(np.abs(rng.normal(size=n)))
        cases.append((x, y))
    for x, y in cases:
        ref, ours = PchipInterpolator(x, y), Pchip(x, y)
        q = np.concatenate([x, rng.uniform(x[0] - 1.0, x[-1] + 1.0, 2000)])
        assert np.array_equal(ref.c, ours.c)
        assert np.array_equal(ref(q), ours(q))
        assert np.array_equal(ours.values(q.tolist()), ours(q))


def _bits(a) -> np.ndarray:
    return np.asarray(a, dtype=float).view(np.int64)


def test_float_paths_are_the_array_paths_to_the_last_bit(curve):
    """thrust_values/pwm_values (and thrust/pwm on a few values) give the vectorised results bit for bit:
    knots, their neighbouring floats, the dead band, the limits, signed zeros and NaN included."""
    rng = np.random.default_rng(5)
    pwm = np.concatenate([rng.uniform(1000.0, 2000.0, 20000), np.arange(1000.0, 2001.0), curve.pwm_samples,
                          np.nextafter(curve.pwm_samples, 0.0), np.nextafter(curve.pwm_samples, 3000.0),
                          [np.inf, -np.inf, 0.0, -0.0, np.nan]])
    ref = curve.thrust(pwm.reshape(1, -1))[0]                   # 2-D: the array path
    assert np.array_equal(_bits(curve.thrust_values(pwm.tolist())), _bits(ref))
    assert np.array_equal(_bits(curve.thrust_values(pwm.tolist())), _bits(ref))         # again, from the memo
    whole = np.trunc(pwm[np.isfinite(pwm)])
    assert np.array_equal(_bits(curve.thrust_values(whole.astype(int).tolist())),        # whole µs as ints
                          _bits(curve.thrust(whole.reshape(1, -1))[0]))
    assert np.array_equal(_bits(curve.thrust(pwm[-8:])), _bits(ref[-8:]))
    tables = np.concatenate([curve._fwd_f, curve._rev_f])
    f = np.concatenate([rng.uniform(-45.0, 55.0, 20000), rng.uniform(-1e-4, 1e-4, 5000), tables,
                        np.nextafter(tables, 100.0), np.nextafter(tables, -100.0),
                        [np.inf, -np.inf, 0.0, -0.0, np.nan, 5e-324, -5e-324, curve.thrust_min, curve.thrust_max]])
    ref = curve.pwm(f.reshape(1, -1))[0]
    assert np.array_equal(_bits(curve.pwm_values(f.tolist())), _bits(ref))
    assert np.array_equal(_bits(curve.pwm(f[-9:])), _bits(ref[-9:]))
    assert curve.pwm(0.0) == curve.pwm_neutral and curve.thrust(1500.0) == 0.0


def test_an_integer_neutral_gives_the_same_fractional_pwm(cfg):
    """PWM limits and neutral given as integers (as NEUTRAL_PWM_US is) must not truncate pwm()'s µs."""
    samples = (cfg["curve"]["pwm_us"], np.asarray(cfg["curve"]["thrust_kgf"]) * KGF)
    as_int = T200Curve(*samples, pwm_min=1100, pwm_max=1900, pwm_neutral=1500)
    as_float = T200Curve(*samples, pwm_min=1100.0, pwm_max=1900.0, pwm_neutral=1500.0)
    thrust = np.array([-30.0, -7.3, 0.0, 3.3, 12.1, 40.0])
    many = np.linspace(-40.0, 50.0, 101)
    for f in (thrust, many):
        got = as_int.pwm(f)
        assert got.dtype == np.float64
        assert np.array_equal(got, as_float.pwm(f))
        assert np.any(got != np.round(got))     # fractional µs survive
