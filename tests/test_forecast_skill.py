"""The forecast's skill and the feed-forward's skill fade (docs/feedforward.md, "Skill").

The skill is the correlation of the load the forecast predicts with the load the vehicle's motion
reveals, per axis over ``WK_FF_SKILL_TC``. Truth here: the correlation of signals whose correlation is
known in closed form (a scaled and offset copy, a quadrature pair), the flow's own mean and variation
along the body, and C-PD flown in the same sea for a forecast with no skill.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from bridge.models.vehicle import BodyFlow, VehicleParams, body_flow, strip_nodes
from firmware_py.control.feedforward import WaveFeedForward, skill_weighted_flow
from firmware_py.estimation.inertial_velocity import InertialVelocity
from firmware_py.hal.sensors import SensorFrame
from firmware_py.params.table import load_params
from sitl.harness.results import COLUMN
from sitl.harness.run import run_mission
from sitl.harness.spec import RunSpec
from sitl.sea import Sea

H = 0.05


def _skill(observed, predicted, tc=30.0):
    """Feed series (N, 3) of observed and predicted loads to the skill estimator; its last skill."""
    params = load_params().copy()
    params.set("WK_FF_SKILL_TC", tc)
    ff = WaveFeedForward(VehicleParams.load("bluerov2_heavy"), params, H)
    for o, p in zip(observed, predicted, strict=True):
        ff._update_skill(o, p)
    return ff.skill


def test_the_skill_is_the_correlation_of_predicted_and_observed_loads():
    t = np.arange(0.0, 240.0, H)
    s, c = np.sin(0.9 * t), np.cos(0.9 * t)
    p = np.stack([s, s, s], 1) * [40.0, 60.0, 2.0]
    # blind to a steady offset and a scale (a current, a buoyancy error, drag): still 1
    assert _skill(3.0 * p + [50.0, -80.0, 4.0], p) == pytest.approx(np.ones(3), abs=1e-6)
    # a load in quadrature with the prediction (a crest predicted a quarter period off): 0; opposite: −1
    assert _skill(np.stack([c, c, c], 1), p) == pytest.approx(np.zeros(3), abs=0.02)
    assert _skill(-p, p) == pytest.approx(-np.ones(3), abs=1e-6)
    # noise on the observed load lowers it by σ_p / √(σ_p² + σ_n²): here 1/√2
    rng = np.random.default_rng(0)
    noisy = p + rng.standard_normal(p.shape) * p.std(axis=0)
    assert _skill(noisy, p, tc=60.0) == pytest.approx(np.full(3, 1 / math.sqrt(2)), abs=0.06)


def test_the_skill_is_not_claimed_before_its_window_is_full():
    t = np.arange(0.0, 20.0, H)
    p = np.stack([np.sin(t)] * 3, 1)
    assert np.all(_skill(-p, p, tc=30.0) == 1.0)


@pytest.fixture(scope="module")
def flow() -> BodyFlow:
    sea = Sea.load("W2")
    vehicle = VehicleParams.load("bluerov2_heavy")
    return body_flow(sea.components, np.array([0.0, 5.0, 0.0]), 30.0 + np.array([0.0, H / 2, H]),
                     strip_nodes(vehicle.length, 3))


def test_the_skill_weighted_flow_keeps_what_each_axis_has_skill_for(flow):
    assert skill_weighted_flow(flow, np.ones(3)) is flow
    none = skill_weighted_flow(flow, np.zeros(3))
    for k in ("u", "w", "ax", "az"):
        assert np.all(getattr(none, k) == 0.0)
    # surge only: the heave kinematics untouched
    surge = skill_weighted_flow(flow, np.array([0.5, 1.0, 1.0]))
    assert np.allclose(surge.u, 0.5 * flow.u) and np.allclose(surge.ax, 0.5 * flow.ax)
    assert np.allclose(surge.w, flow.w) and np.allclose(surge.az, flow.az)
    # heave without pitch: the body-mean heave kinematics kept, their variation along the body gone
    heave = skill_weighted_flow(flow, np.array([1.0, 1.0, 0.0]))
    for k in ("w", "az"):
        v, v0 = getattr(heave, k), getattr(flow, k)
        assert np.allclose(v @ flow.wts, v0 @ flow.wts)
        assert np.allclose(v, (v0 @ flow.wts)[:, None])
    # pitch without heave: the variation kept, the mean gone
    pitch = skill_weighted_flow(flow, np.array([1.0, 0.0, 1.0]))
    assert np.allclose(pitch.w @ flow.wts, 0.0)
    assert np.allclose(pitch.w - flow.w, -(flow.w @ flow.wts)[:, None])


def test_an_exact_forecast_keeps_its_whole_feed_forward():
    """The exact forecast's skill stays far above WK_FF_SKILL_HI: the fade never acts, bit for bit."""
    spec = RunSpec("W2", "cpd_ff", seed=3, duration=90.0)
    faded = run_mission(spec)
    plain = run_mission(RunSpec("W2", "cpd_ff", seed=3, duration=90.0, overrides={"WK_FF_SKILL_HI": 0.0,
                                                                                   "WK_FF_SKILL_LO": 0.0}))
    log = faded.timeseries
    after = log[:, COLUMN["t"]] > 35.0
    skill = log[after][:, [COLUMN["ff_skill_X"], COLUMN["ff_skill_Z"], COLUMN["ff_skill_M"]]]
    assert skill.min() > 0.7
    assert faded.results["rmse"] == plain.results["rmse"]


def test_a_forecast_without_skill_fades_itself_out():
    """A forecast with three times more error than wave (−10 dB): FF and the estimator's wave model fade
    out on every axis, the lateral plane's with them, and the vehicle flies about as C-PD does in the same
    sea. (Measured with the
    estimator's velocity, the skill stayed above 0.9 here: the estimator, predicting with the forecast,
    agreed with it while it diverged.)"""
    flown = run_mission(RunSpec("W2", "cpd_ff", seed=3, duration=150.0, snr_db=-10.0))
    ff = flown.timeseries
    cpd = run_mission(RunSpec("W2", "cpd", seed=3, duration=150.0)).timeseries
    # nor sideways: the lateral feed-forward fades with the heave skill (it rolled the vehicle past 70° before)
    six = flown.results["six_dof"]
    assert math.degrees(six["max_abs_error"]["roll"]) < 5.0 and six["rmse"]["y"] < 0.05
    late = ff[:, COLUMN["t"]] > 60.0
    weights = ff[late][:, [COLUMN["ff_w_X"], COLUMN["ff_w_Z"], COLUMN["ff_w_M"]]]
    assert weights.mean(axis=0).max() < 0.3
    for axis in ("x", "z", "theta"):
        rms = [float(np.sqrt(np.mean((log[late, COLUMN[axis]] - log[late, COLUMN["sp_" + axis]]) ** 2)))
               for log in (ff, cpd)]
        assert rms[0] < 1.15 * rms[1], axis


def _frames(duration=60.0, bias=(0.0, 0.0), th0=0.1, noise=0.0, seed=0):
    """Sensor frames of a body heaving and surging sinusoidally at a fixed pitch: the analytic truth."""
    rng = np.random.default_rng(seed)
    g, c, s = 9.81, math.cos(th0), math.sin(th0)
    for t in np.arange(0.0, duration, H):
        # NED motion: x = 0.5 sin 0.8t, z = 5 + 0.3 sin 1.1t
        xdd, zdd = -0.32 * math.sin(0.8 * t), -0.363 * math.sin(1.1 * t)
        xd, zd = 0.4 * math.cos(0.8 * t), 0.33 * math.cos(1.1 * t)
        # specific force in the body frame: R(θ)ᵀ (a − g), FRD
        f_x = c * xdd - s * (zdd - g) + bias[0]
        f_z = s * xdd + c * (zdd - g) + bias[1]
        frame = SensorFrame(t, 0.5 * math.sin(0.8 * t) + noise * rng.standard_normal(),
                            5.0 + 0.3 * math.sin(1.1 * t) + noise * rng.standard_normal(), th0, 0.0,
                            acc_x=f_x, acc_z=f_z)
        yield t, frame, np.array([c * xd - s * zd, s * xd + c * zd])


def test_the_inertial_velocity_follows_the_motion_without_a_model():
    iv = InertialVelocity(H, 1.0, 9.81)
    errors = []
    for t, frame, uw in _frames():
        out = iv.update(frame)
        if t > 10.0:
            errors.append(out - uw)
    assert np.max(np.abs(errors)) < 0.003        # 0.4 and 0.33 m/s of motion


def test_the_inertial_velocity_learns_the_accelerometer_bias():
    iv = InertialVelocity(H, 1.0, 9.81)
    errors = []
    for t, frame, uw in _frames(duration=90.0, bias=(0.05, -0.08), noise=0.01):
        out = iv.update(frame)
        if t > 30.0:
            errors.append(out - uw)
    assert np.sqrt(np.mean(np.square(errors), axis=0)).max() < 0.03
    # the bias, rotated into NED, is learnt
    c, s = math.cos(0.1), math.sin(0.1)
    assert iv.bias == pytest.approx([c * 0.05 + s * -0.08, -s * 0.05 + c * -0.08], abs=0.005)
