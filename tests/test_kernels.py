"""The compiled kernels (bridge/models/kernels.py) against the numpy/Python reference path.

Each public entry point is called twice on the same inputs: with the kernels
(the default when numba is installed) and with ``kernels.ENABLED`` off (the
reference, unchanged from before the kernels). They agree to 1e-12 relative to
the size of the quantity; a whole mission on the two paths agrees to 1e-9.
"""
from __future__ import annotations

import numpy as np
import pytest

from bridge.models import kernels
from bridge.models.vehicle import (
    VehicleParams,
    body_flow,
    hydrodynamic_load_at,
    rates_jacobian,
    rk4_step,
    state_rates_at,
    strip_nodes,
    wave_load,
)
from sitl.sea import Sea

pytestmark = pytest.mark.skipif(not kernels.ENABLED, reason="numba not installed or WAVEKEEP_NUMBA=0")


@pytest.fixture(scope="module")
def vehicle() -> VehicleParams:
    return VehicleParams.load("bluerov2_heavy")


@pytest.fixture(scope="module")
def sea() -> Sea:
    return Sea.load("W3")


def both(monkeypatch, fn):
    """fn() with the kernels, then with the reference path."""
    fast = fn()
    monkeypatch.setattr(kernels, "ENABLED", False)
    ref = fn()
    monkeypatch.setattr(kernels, "ENABLED", True)
    return fast, ref


def close(a, b, scale=None, tol=1e-12):
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    scale = float(np.max(np.abs(b))) if scale is None else scale
    assert np.max(np.abs(a - b)) <= tol * max(scale, 1e-300), (a, b)


@pytest.mark.parametrize("strips", [1, 3, 6])
@pytest.mark.parametrize("pose", [(0.0, 5.0, 0.0), (3.2, 1.1, 0.3), (-7.0, 0.05, -0.4), (1.0, 80.0, 0.1)])
def test_body_flow_matches_numpy(monkeypatch, sea, vehicle, strips, pose):
    xs = strip_nodes(vehicle.length, strips)
    t = 123.4 + np.array([0.0, 0.025, 0.05])
    fast, ref = both(monkeypatch, lambda: body_flow(sea.components, np.array(pose), t, xs))
    for name in ("u", "w", "ax", "az"):
        close(getattr(fast, name), getattr(ref, name))


def test_body_flow_linear_sea_and_one_time(monkeypatch, sea, vehicle):
    from dataclasses import replace
    linear = replace(sea.components, second_order=False)
    xs = strip_nodes(vehicle.length, 3)
    fast, ref = both(monkeypatch, lambda: body_flow(linear, np.array([0.5, 4.0, 0.05]), 17.0, xs))
    assert fast.u.shape == ref.u.shape == (1, 3)
    for name in ("u", "w", "ax", "az"):
        close(getattr(fast, name), getattr(ref, name))


def test_loads_rates_rk4_and_jacobian_match_python(monkeypatch, sea, vehicle):
    rng = np.random.default_rng(4)
    xs = strip_nodes(vehicle.length, 3)
    for _ in range(20):
        x = np.array([rng.normal(), rng.uniform(0.0, 8.0), rng.normal(0, 0.3), *rng.normal(0, 0.5, 3)])
        tau = rng.normal(0, 40.0, (3, 3))
        flow = body_flow(sea.components, x[:3], rng.uniform(0, 600) + np.array([0.0, 0.025, 0.05]), xs)
        for f in (flow, None):
            for i in range(3):
                fast, ref = both(monkeypatch, lambda f=f, i=i, x=x: hydrodynamic_load_at(vehicle, *x[3:], f, i))
                close(fast, ref)
                fast, ref = both(monkeypatch, lambda f=f, i=i, x=x, tau=tau: state_rates_at(vehicle, x, tau[i], f, i))
                close(fast, ref)
            fast, ref = both(monkeypatch, lambda f=f, x=x, tau=tau: rk4_step(vehicle, x, 0.05, tau, f))
            close(fast, ref)
            fast, ref = both(monkeypatch, lambda f=f, x=x, tau=tau: rates_jacobian(vehicle, x, tau[0], f, 0))
            close(fast, ref)


def test_wave_load_matches_python(monkeypatch, sea, vehicle):
    xs = strip_nodes(vehicle.length, 3)
    t = np.linspace(0.0, 30.0, 7)
    fast, ref = both(monkeypatch, lambda: wave_load(vehicle, sea.components, [0.0, 5.0, 0.02], [0.1, -0.2, 0.05],
                                                    t, xs))
    close(fast, ref)


def test_allocation_matches_python_bit_for_bit(monkeypatch):
    """The mixer's allocation kernel is its float reference's operations one for one: equal bits, non-finite
    and signed-zero demands included."""
    from bridge.models.thrusters import T200Curve, ThrusterLayout
    from bridge.schemas import load_vehicle_config
    from firmware_py.mixer import MotorMixer
    from firmware_py.params import load_params

    cfg = load_vehicle_config("bluerov2_heavy")["thrusters"]
    mixer = MotorMixer(ThrusterLayout.from_config(cfg), T200Curve.from_config(cfg), load_params(), 0.05)
    rng = np.random.default_rng(17)
    for k in range(2000):
        tau = rng.normal(0.0, float(rng.choice([1.0, 100.0, 1e5])), 3)
        if k % 4 == 0:
            tau[rng.integers(3)] = rng.choice([0.0, -0.0, np.inf, -np.inf, np.nan, 1e308])
        f_max = float(rng.choice([35.0, 1.0, 60.0]))
        fast, ref = both(monkeypatch, lambda t=tau, m=f_max: mixer.allocate(t, m))
        assert np.array_equal(fast.view(np.int64), ref.view(np.int64)), tau


def test_t200_command_matches_python_bit_for_bit(monkeypatch):
    """The T200 curve's whole-µs command, compiled, against its reference and the array path: equal PWM and bits
    at the tables' knots and their neighbouring floats, zero, NaN, ±inf and beyond the limits."""
    from bridge.models.thrusters import T200Curve
    from bridge.schemas import load_vehicle_config

    curve = T200Curve.from_config(load_vehicle_config("bluerov2_heavy")["thrusters"])
    rng = np.random.default_rng(19)
    tables = np.concatenate([curve._fwd_f, curve._rev_f])
    f = np.concatenate([rng.uniform(-45.0, 55.0, 40000), rng.uniform(-1e-3, 1e-3, 8000), tables,
                        np.nextafter(tables, 100.0), np.nextafter(tables, -100.0),
                        [0.0, -0.0, np.nan, np.inf, -np.inf, curve.thrust_min, curve.thrust_max, 5e-324]])
    for chunk in np.array_split(f, len(f) // 8):
        (pwm, thrust), (pwm_ref, thrust_ref) = both(monkeypatch, lambda c=chunk: curve.command(c.tolist()))
        assert pwm.dtype == pwm_ref.dtype == np.int64 and np.array_equal(pwm, pwm_ref), chunk
        assert np.array_equal(thrust.view(np.int64), thrust_ref.view(np.int64)), chunk
    pwm_array = np.rint(curve.pwm(f.reshape(1, -1))[0]).astype(np.int64)        # the array path, as mix() had it
    pwm, thrust = curve.command(f.tolist())
    assert np.array_equal(pwm, pwm_array)
    assert np.array_equal(thrust.view(np.int64), curve.thrust(pwm_array.reshape(1, -1))[0].view(np.int64))


@pytest.mark.processes
def test_a_mission_on_both_paths_agrees_to_1e9(monkeypatch):
    """Summation order moves last bits (the kernels sum per component, numpy's BLAS in blocks); through a
    closed loop with whole-µs PWM that stays below 1e-9 relative in every result."""
    from sitl.harness.run import run_mission
    from sitl.harness.spec import RunSpec

    spec = RunSpec("W3", "cpd_ff", duration=20.0)
    fast, ref = both(monkeypatch, lambda: run_mission(spec).results)
    for key in ("rmse", "max_abs_error", "mean_power_w"):
        for dof, v in ref[key].items():
            assert fast[key][dof] == pytest.approx(v, rel=1e-9, abs=1e-15), (key, dof)
