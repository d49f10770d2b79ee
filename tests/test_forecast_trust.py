"""A depth reading with the waves' dynamic pressure in it: corrected by the forecast (WK_BARO_WAVE), and,
left uncorrected, a forecast the FF monitor sets aside rather than let it hurt (WK_FF_TRUST_TC).

Truth here is the linear pressure transfer function (bridge.models.waves.pressure_head, itself tested
against cosh k(d − s)/cosh kd) and the plant's true depth, not a recorded run. docs/sea-errors.md.
"""
from __future__ import annotations

import numpy as np
import pytest

from bridge.models.waves import pressure_head
from firmware_py.hal.sensors import wave_corrected_depth
from sitl.harness.results import COLUMN
from sitl.harness.run import run_mission
from sitl.harness.spec import RunSpec
from sitl.sea import Sea

DYNAMIC = {"depth_sensor.dynamic_pressure": True}


def test_the_corrected_depth_inverts_the_pressure_reading():
    c = Sea.load("W3").components
    depths = np.linspace(2.0, 10.0, 9)
    worst_raw = 0.0
    for t in np.linspace(100.0, 160.0, 13):
        for s in depths:
            reading = s + float(pressure_head(c, 1.5, s, t))
            worst_raw = max(worst_raw, abs(reading - s))
            assert wave_corrected_depth(reading, c, 1.5, t) == pytest.approx(s, abs=1e-3)
    assert worst_raw > 0.5        # W3's head at these depths: the correction has work to do


def _mission(overrides=None, sea=DYNAMIC, controller="cpd_ff", duration=60.0):
    r = run_mission(RunSpec("W2", controller, seed=1, duration=duration, sea=sea, overrides=overrides or {}))
    return r.timeseries


def _rms(log, a, b="", after=5.0):
    m = log[:, COLUMN["t"]] > after
    d = log[m, COLUMN[a]] - (log[m, COLUMN[b]] if b else 0.0)
    return float(np.sqrt(np.mean(d**2)))


@pytest.fixture(scope="module")
def raw_and_corrected():
    return _mission({"WK_FF_TRUST_TC": 5}), _mission({"WK_BARO_WAVE": 1, "WK_FF_TRUST_TC": 5})


def test_the_forecast_takes_the_dynamic_pressure_out_of_the_depth(raw_and_corrected):
    raw, corrected = raw_and_corrected
    # Uncorrected, the EKF believes the wave-driven reading; corrected, its depth is the plant's to centimetres
    assert _rms(raw, "z_hat", "z") > 0.3
    assert _rms(corrected, "z_hat", "z") < 0.05
    assert _rms(corrected, "z", "sp_z") < 0.5 * _rms(raw, "z", "sp_z")
    weights = corrected[:, [COLUMN["ff_w_X"], COLUMN["ff_w_Z"], COLUMN["ff_w_M"]]]
    assert np.all(weights.min(axis=1) > 0.0)   # the corrected forecast is never set aside


def test_the_estimator_starts_from_a_corrected_depth():
    """W1 seed 2 starts under a crest (0.47 m of head): an EKF started from the raw reading and then fed
    corrected ones diverged within 0.3 s (the campaign's ff_bar30 W1 seed 2: 24 m of surge RMSE). Its depth
    is now reset when the correction starts (firmware_py/control/depth_correction.py)."""
    r = run_mission(RunSpec("W1", "cpd_ff", seed=2, duration=10.0, sea=DYNAMIC, overrides={"WK_BARO_WAVE": 1}))
    log = r.timeseries
    assert np.max(np.abs(log[:, COLUMN["z_hat"]] - log[:, COLUMN["z"]])) < 0.05
    assert r.results["rmse"]["surge"] < 0.2


def test_a_forecast_that_disagrees_for_long_is_set_aside(raw_and_corrected):
    raw, _ = raw_and_corrected
    t = raw[:, COLUMN["t"]]
    weights = raw[:, [COLUMN["ff_w_X"], COLUMN["ff_w_Z"], COLUMN["ff_w_M"]]]
    off = np.all(weights == 0.0, axis=1)
    assert not off[t < 2.0].any()              # trusted at first: a fade must last before it counts
    assert off[t > 20.0].all()                 # then FF, on every axis, stays off
    assert np.all(raw[t > 20.0][:, [COLUMN["tau_ff_X"], COLUMN["tau_ff_Z"], COLUMN["tau_ff_M"]]] == 0.0)
    # Once set aside the vehicle flies as C-PD does in the same world
    cpd = _mission(controller="cpd")
    assert _rms(raw, "theta", after=20.0) < 1.1 * _rms(cpd, "theta", after=20.0)


def test_a_nominal_sea_never_sets_the_forecast_aside():
    log = _mission({"WK_FF_TRUST_TC": 5}, sea={}, duration=120.0)
    weights = log[:, [COLUMN["ff_w_X"], COLUMN["ff_w_Z"], COLUMN["ff_w_M"]]]
    assert not np.all(weights == 0.0, axis=1).any()


def test_the_firmware_says_when_it_sets_the_forecast_aside():
    from firmware_py.params.table import load_params
    from sitl.harness.run import build_mission, take_off

    params = load_params().copy()
    params.set("WK_FF_TRUST_TC", 5.0)
    m = build_mission(RunSpec("W2", "cpd_ff", seed=1, duration=20.0, sea=DYNAMIC), params=params)
    fw = m.firmware
    take_off(m)
    for _ in range(300):
        fw.scheduler.run_tick()
        m.hal.step_world()
    assert fw.feedforward.distrusted and fw.feedforward.set_aside == 1
    assert "FF off: forecast set aside" in [text for _, text in fw.events]
