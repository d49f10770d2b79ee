"""The firmware's behaviour: controller, feed-forward, estimator, mixer, parameters, forecast hand-off."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from bridge.configfile import ConfigError
from bridge.forecast import Forecast, inject_spectral_noise, oracle_forecast
from bridge.models.thrusters import T200Curve, ThrusterLayout
from bridge.models.waves import elevation
from bridge.schemas import load_vehicle_config
from firmware_py.forecast.handoff import ForecastHandoff
from firmware_py.motors.mixer import MotorMixer
from firmware_py.params.ardusub import reference_table
from firmware_py.params.table import PARAM_DEFS, load_params
from sitl.harness.run import TIMESERIES_COLUMNS, run_mission
from sitl.harness.spec import RunSpec
from sitl.sea import Sea

COL = {c: i for i, c in enumerate(TIMESERIES_COLUMNS)}

# Perfect sensing: no sensor noise, the estimator told so, a position fix every tick
PERFECT_SENSORS = dict(SIM_POS_RND=0.0, SIM_DEPTH_RND=0.0, SIM_PITCH_RND=0.0, SIM_GYRO_RND=0.0, SIM_POS_RATE=20.0,
                       WK_EKF_R_POS=1e-3, WK_EKF_R_DEPTH=1e-3, WK_EKF_R_PITCH=1e-4, WK_EKF_R_GYRO=1e-4,
                       SIM_DVL_RND=0.0, SIM_DVL_DROP=0.0, SIM_ACC_RND=0.0, WK_EKF_R_DVL=1e-4, WK_EKF_R_ACC=1e-3)


@pytest.fixture(scope="module")
def thrusters():
    cfg = load_vehicle_config("bluerov2_heavy")["thrusters"]
    return ThrusterLayout.from_config(cfg), T200Curve.from_config(cfg)


def sea_file(tmp_path, hs: float | None = None, name: str = "W1") -> str:
    """A copy of a sea config with another Hs (None: still water, via a vanishing Hs)."""
    import yaml

    from bridge.configfile import configs_dir
    data = yaml.safe_load((configs_dir() / "sea" / f"{name}.yaml").read_text())
    data["spectrum"]["hs"] = hs if hs is not None else 1e-9
    path = tmp_path / f"{name}_hs{hs}.yaml"
    path.write_text(yaml.safe_dump(data))
    return str(path)


# ----------------------------------------------------------------------------- controller behaviour

def test_setpoint_step_converges_with_no_steady_state_error_in_still_water(tmp_path):
    """Start 0.5 m aft, 0.5 m shallow and 0.1 rad nose-down of the setpoint; the C-PD must settle on it."""
    still = sea_file(tmp_path, None)
    result = run_mission(RunSpec(still, "cpd", duration=40.0), params=load_params(overrides=PERFECT_SENSORS),
                         initial_eta=[-0.5, 4.5, -0.1])
    L = result.timeseries
    err = L[:, 1:4] - np.array([0.0, 5.0, 0.0])
    assert np.abs(err[0]).max() > 0.09                         # it really started off station
    assert np.abs(err[-100:]).max(axis=0).tolist() == pytest.approx([0, 0, 0], abs=2e-3)
    # and got there without a large overshoot
    assert err[:, 0].max() < 0.15 and err[:, 1].max() < 0.15 and err[:, 2].max() < 0.03


def test_feed_forward_cancels_the_wave_load_with_perfect_knowledge(tmp_path):
    """Perfect state, exact forecast, exact model, a sea small enough not to saturate:
    the station-keeping error with FF is at least five times smaller than C-PD's."""
    calm = sea_file(tmp_path, 0.8)
    params = load_params(overrides=PERFECT_SENSORS)
    cpd = run_mission(RunSpec(calm, "cpd", duration=60.0), params=params)
    ff = run_mission(RunSpec(calm, "cpd_ff", duration=60.0), params=params)
    tau_max = np.array([params[f"WK_TAU_MAX_{a}"] for a in "XZP"])
    assert np.all(np.abs(cpd.timeseries[:, COL["tau_X"]:COL["tau_M"] + 1]) < tau_max)   # no saturation
    for dof in ("surge", "heave", "pitch"):
        assert ff.results["rmse"][dof] * 5 < cpd.results["rmse"][dof], dof
    # The feed-forward is the negated true load, to a few per cent
    tau_ff = ff.timeseries[:, COL["tau_ff_X"]:COL["tau_ff_Z"] + 1]
    tau_e = ff.timeseries[:, COL["tauE_X"]:COL["tauE_Z"] + 1]
    resid = np.sqrt(np.mean((tau_ff[20:-1] + tau_e[20:-1]) ** 2, axis=0))
    assert np.all(resid < 0.1 * np.sqrt(np.mean(tau_e**2, axis=0)))


def test_feed_forward_is_off_without_a_forecast_and_when_disabled():
    params = load_params()
    r = run_mission(RunSpec("W1", "cpd", duration=2.0), params=params)
    assert r.results["ff_active_fraction"] == 0.0
    assert np.all(r.timeseries[:, COL["tau_ff_X"]:COL["tau_ff_M"] + 1] == 0.0)
    r = run_mission(RunSpec("W1", "cpd_ff", duration=2.0))
    assert r.results["ff_active_fraction"] > 0.95


def test_noisy_forecast_differs_from_the_sea_as_the_snr_says():
    sea = Sea.load("W3")
    t = np.arange(0.0, 600.0, 0.5)
    truth = sea.elevation(0.0, t)
    f = oracle_forecast(sea.components, 15.0, np.random.default_rng(0))
    predicted = elevation(f.components(), 0.0, t)
    coherence = np.corrcoef(truth, predicted)[0, 1]
    # Phase noise σ = √(mean(ε²)/10^1.5) ≈ 0.65 rad for ε uniform in [0, 2π): coherence ≈ e^{−σ²/2} ≈ 0.8
    assert 0.6 < coherence < 0.95
    exact = elevation(oracle_forecast(sea.components, None, None).components(), 0.0, t)
    np.testing.assert_allclose(exact, truth, atol=1e-9)


def test_spectral_noise_has_the_requested_snr():
    rng = np.random.default_rng(1)
    x = rng.uniform(0, 2 * np.pi, 200_000)
    noisy = inject_spectral_noise(x, 15.0, rng)
    snr = 10 * np.log10(np.mean(x**2) / np.mean((noisy - x) ** 2))
    assert snr == pytest.approx(15.0, abs=0.05)


# ----------------------------------------------------------------------------- estimator

def test_ekf_error_is_consistent_with_its_covariance():
    """Normalised estimation error squared on the measured-and-modelled states stays near its dimension."""
    r = run_mission(RunSpec("W3", "cpd_ff", duration=120.0))
    L = r.timeseries[100:]
    err = L[:, [COL["x_hat"], COL["z_hat"], COL["theta_hat"]]] - L[:, [1, 2, 3]]
    sig = L[:, [COL["sigma_x"], COL["sigma_z"], COL["sigma_theta"]]]
    nees = (err / sig) ** 2
    # Per-state mean NEES of a consistent filter is 1; allow a factor of 3 either way
    assert np.all(nees.mean(axis=0) < 3.0) and np.all(nees.mean(axis=0) > 1 / 3)
    assert r.results["ekf"]["rms_error"]["x"] < 0.05 and r.results["ekf"]["rms_error"]["z"] < 0.02


def test_ekf_gates_outliers_and_recovers():
    from bridge.models.vehicle import VehicleParams
    from firmware_py.estimation.estimator import PlanarEKF
    from firmware_py.hal.sensors import SensorFrame

    params = load_params()
    ekf = PlanarEKF(VehicleParams.load("bluerov2_heavy"), params, 0.05)
    hover = np.zeros((3, 3))
    hover[:, 1] = -2.0   # thrusters cancel the 2 N buoyancy
    ekf.update(SensorFrame(0.0, 0.0, 5.0, 0.0, 0.0))
    for k in range(1, 40):
        ekf.predict(hover)
        ekf.update(SensorFrame(k * 0.05, 0.0, 5.0, 0.0, 0.0))
    x_before = ekf.x.copy()
    ekf.predict(hover)
    accepted = ekf.update(SensorFrame(2.0, 25.0, 5.0, 0.0, 0.0))      # a 25 m position outlier
    assert not accepted[0] and ekf.rejected["position"] == 1
    assert abs(ekf.x[0] - x_before[0]) < 0.01
    # A sensor that keeps disagreeing for longer than WK_EKF_RST_T is believed again (reset)
    for k in range(41, 41 + int(params["WK_EKF_RST_T"] / 0.05) + 2):
        ekf.predict(hover)
        ekf.update(SensorFrame(k * 0.05, 3.0, 5.0, 0.0, 0.0))
    assert ekf.resets["position"] >= 1 and abs(ekf.x[0] - 3.0) < 0.05
    assert ekf.converged()


# ----------------------------------------------------------------------------- mixer

def test_mixer_gives_pitch_priority_over_heave(thrusters):
    layout, curve = thrusters
    params = load_params(overrides={"WK_MOT_COMP": 0})
    mixer = MotorMixer(layout, curve, params, 0.05)
    f = mixer.allocate(np.array([0.0, 200.0, 8.0]), 35.0)      # heave beyond the 140 N the verticals have
    assert np.all(np.abs(f) <= 35.0 + 1e-9)
    wrench = layout.allocation_matrix() @ f
    assert wrench[2] == pytest.approx(8.0)                       # the moment is kept whole
    assert 0 < wrench[1] < 140.0                                 # heave gets what is left


def test_motor_lag_compensation_reaches_the_demand_in_one_period(thrusters):
    layout, curve = thrusters
    params = load_params()
    mixer = MotorMixer(layout, curve, params, 0.05)
    out = mixer.mix(np.array([10.0, 5.0, 0.0]))
    demand = out.thrust_demand
    # The firmware's motor model ends the period at the demand (to the PWM's 1 µs resolution)
    np.testing.assert_allclose(mixer.f_hat, demand, atol=0.1)
    assert np.all((out.pwm >= 1100) & (out.pwm <= 1900)) and out.pwm.dtype.kind == "i"


def test_allocation_is_the_array_form_to_the_last_bit(thrusters):
    """MotorMixer.allocate (floats, skipping B⁺'s exact zeros) against the array form it replaced, bit for bit,
    non-finite and signed-zero demands included."""
    layout, curve = thrusters
    mixer = MotorMixer(layout, curve, load_params(), 0.05)

    def array_form(tau: np.ndarray, f_max: float) -> np.ndarray:
        f = np.zeros(layout.n)
        for axis in (2, 1, 0):
            g = mixer.B_pinv[:, axis] * tau[axis]
            with np.errstate(divide="ignore", invalid="ignore"):
                room = np.where(g > 0, (f_max - f) / g, np.where(g < 0, (-f_max - f) / g, np.inf))
            room = [r for r in room.tolist() if r == r]         # min() over the thrusters that bound s (NaN never does)
            f = f + np.clip(min([np.inf, *room]), 0.0, 1.0) * g
        return f

    rng = np.random.default_rng(11)
    for k in range(3000):
        tau = rng.normal(0.0, float(rng.choice([1.0, 100.0, 1e5])), 3)
        if k % 4 == 0:
            tau[rng.integers(3)] = rng.choice([0.0, -0.0, np.inf, -np.inf, np.nan, 1e308])
        with np.errstate(invalid="ignore", over="ignore"):
            ref = array_form(tau, 35.0)
        assert np.array_equal(mixer.allocate(tau, 35.0).view(np.int64), ref.view(np.int64)), tau


def test_neutral_output_is_1500(thrusters):
    layout, curve = thrusters
    out = MotorMixer(layout, curve, load_params(), 0.05).neutral()
    assert out.pwm.tolist() == [1500] * 8


# ----------------------------------------------------------------------------- parameters and forecast

def test_parameter_table_names_ranges_and_runtime_sets():
    params = load_params()
    ardusub = {row[0] for row in reference_table()}
    # Wavekeep's own, then the rest of ArduSub 4.7's table (read-only)
    assert len(params) == len(PARAM_DEFS) + len(ardusub - {d.name for d in PARAM_DEFS})
    assert ardusub <= set(params.names())
    assert all(params.definition(n).readonly for n in ardusub - {d.name for d in PARAM_DEFS})
    assert all(len(n) <= 16 for n in params.names())
    v0 = params.version
    assert params.set("WK_PD_KP_X", 2.0) is None and params["WK_PD_KP_X"] == 2.0 and params.version == v0 + 1
    assert "allowed" in params.set("WK_PD_KP_X", float("nan")) and params["WK_PD_KP_X"] == 2.0
    assert "allowed" in params.set("WK_PD_KP_X", 1e6) and params["WK_PD_KP_X"] == 2.0
    assert "unknown" in params.set("NOPE", 1.0)
    assert params.by_index(params.index_of("WK_FF_ENABLE")) == ("WK_FF_ENABLE", 1.0)


def test_bad_parameter_file_names_the_key(tmp_path):
    import yaml

    from bridge.configfile import configs_dir
    data = yaml.safe_load((configs_dir() / "firmware" / "params.yaml").read_text())
    data["WK_THR_MAX"] = 500
    path = tmp_path / "params.yaml"
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ConfigError, match=r"'WK_THR_MAX'.*\[1, 60\]"):
        load_params(path)
    del data["WK_THR_MAX"]
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ConfigError, match=r"'WK_THR_MAX'.*missing"):
        load_params(path)


def test_forecast_handoff_serves_the_newest_valid_forecast():
    sea = Sea.load("W1")
    handoff = ForecastHandoff()
    assert handoff.current(0.0) is None
    f1 = oracle_forecast(sea.components, None, None, valid_from=0.0, valid_until=10.0, seq=1)
    handoff.offer(f1)
    a = handoff.current(5.0)
    assert a is not None and a.forecast.seq == 1
    assert handoff.current(5.0) is a                                # components cached, not rebuilt
    assert handoff.current(10.5) is None                            # stale
    handoff.offer(replace(f1, seq=2, valid_until=20.0))
    assert handoff.current(10.5).forecast.seq == 2


def test_forecast_reference_position_and_time_base_are_honoured():
    sea = Sea.load("W2")
    t = np.linspace(100.0, 160.0, 300)
    truth = sea.elevation(3.0, t)
    f = oracle_forecast(sea.components, None, None, x_ref=-50.0, time_base=100.0)
    assert isinstance(f, Forecast) and f.x_ref == -50.0
    np.testing.assert_allclose(elevation(f.components(), 3.0, t), truth, atol=1e-9)


def test_same_seed_same_run():
    a = run_mission(RunSpec("W2", "cpd_ff", 15.0, duration=5.0)).timeseries
    b = run_mission(RunSpec("W2", "cpd_ff", 15.0, duration=5.0)).timeseries
    np.testing.assert_array_equal(a, b)


# ----------------------------------------------------------------------------- property-based

from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

_TABLE = load_params()


@settings(max_examples=400, deadline=None)
@given(st.sampled_from(_TABLE.names()),
       st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-10**12, 10**12)))
def test_parameter_set_accepts_exactly_the_allowed_values(name, value):
    table = _TABLE.copy()
    d = table.definition(name)
    old = table[name]
    why = table.set(name, value)
    ok = (np.isfinite(float(value)) and d.lo <= float(value) <= d.hi
          and (not d.integer or float(value).is_integer())
          and (d.allowed is None or float(value) in d.allowed))
    if ok:
        assert why is None and table[name] == float(value)
    else:
        assert why and table[name] == old


def test_a_bad_ardusub_table_names_the_file_and_the_line(tmp_path):
    """configs/firmware/ardusub_params.csv is read and checked: a bad row is a ConfigError naming its line."""
    from bridge.configfile import ConfigError
    from firmware_py.params.ardusub import reference_table

    bad = tmp_path / "ardusub_params.csv"
    bad.write_text("# a comment\nname,value,type\nANGLE_MAX,4500,INT16\nFS_PRESS_MAX,lots,INT32\n")
    with pytest.raises(ConfigError, match="line 4"):
        reference_table(str(bad))
    bad.write_text("name,value,type\nANGLE_MAX,4500,INT64\n")
    with pytest.raises(ConfigError, match="INT64"):
        reference_table(str(bad))
