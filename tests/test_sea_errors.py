"""Errors as they come at sea (docs/sea-errors.md): a real buoy, DSWP's options, a current, a vehicle
that is not its model, and the depth sensor's dynamic pressure — each off by default, each shown acting.

Truth is independent of the code under test: the sea's own elevation, the linear pressure transfer
function written out with cosh, the terminal speeds of force balances solved by hand.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from bridge.configfile import ConfigError
from bridge.dswp import predict_from_buoy
from bridge.models.waves import WaveComponents, elevation, pressure_head
from bridge.schemas import apply_true_vehicle, load_true_vehicle, load_vehicle_config
from sitl.buoy import NO_BUOY_ERRORS, BuoyErrors
from sitl.plant import Plant
from sitl.sea import Sea, load_sea_config

DEPTH = 54.0
NEUTRAL = np.full(8, 1500.0)
T_REC = 300.0


def lines_sea(errors: BuoyErrors = NO_BUOY_ERRORS, freq_hz=(30 / T_REC, 45 / T_REC, 62 / T_REC),
              amp=(1.0, 0.6, 0.35), phase=(0.3, 2.0, -1.0)) -> Sea:
    """A linear sea of a few on-bin lines (for a 300 s record at 2 Hz), with a buoy at −50 m."""
    comps = WaveComponents.from_spectrum_lines(np.array(amp), 2 * np.pi * np.array(freq_hz), np.array(phase),
                                               DEPTH, False)
    return dataclasses.replace(Sea.still_water(DEPTH), components=comps, buoy_errors=errors)


# ---------------------------------------------------------------------------- 1. the buoy

def test_a_perfect_buoy_records_the_sea_exactly():
    sea = Sea.load("W1")
    assert not sea.buoy_errors.active and sea.current == (0.0, 0.0) and not sea.dynamic_pressure
    t, eta = sea.buoy().record(-20.0, 20.0)
    assert np.array_equal(eta, sea.elevation(sea.buoy_x, t))


def test_buoy_noise_has_the_requested_snr_and_is_the_same_in_every_window():
    sea = Sea.load("W1", overrides={"buoy.noise_snr_db": 10.0})
    b = sea.buoy()
    t, eta = b.record(0.0, 12000.0)
    noise = eta - sea.elevation(b.x, t)
    snr = 10 * np.log10(sea.components.m0() / np.var(noise))
    assert abs(snr - 10.0) < 0.15                      # 24 000 samples: var estimated to ~1 %
    assert abs(np.mean(noise)) < 0.03 and abs(np.corrcoef(noise[:-1], noise[1:])[0, 1]) < 0.03   # white
    _, eta2 = b.record(50.0, 700.0)                   # an overlapping window reads the same samples
    np.testing.assert_allclose(eta2, eta[(t >= 50.0) & (t <= 700.0)], rtol=0, atol=1e-12)


def test_buoy_dropouts_lose_the_requested_share_of_samples():
    sea = Sea.load("W1", overrides={"buoy.dropout": 0.2})
    t, eta = sea.buoy().record(0.0, 5000.0)
    lost = np.isnan(eta)
    assert abs(lost.mean() - 0.2) < 3 * np.sqrt(0.2 * 0.8 / t.size)
    np.testing.assert_allclose(eta[~lost], sea.elevation(sea.buoy_x, t[~lost]), rtol=0, atol=1e-12)


def test_buoy_clock_offset_stamps_the_sea_late_or_early():
    delta = 0.75
    sea = Sea.load("W2", overrides={"buoy.clock_offset": delta})
    b = sea.buoy()
    t, eta = b.record(0.0, 60.0)
    np.testing.assert_allclose(eta, sea.elevation(b.x, t - delta), atol=1e-12)
    # causality: the newest sample at vehicle time 10 s was measured at or before 10 s
    stamp = b.newest_stamp(10.0)
    assert stamp - delta <= 10.0 < stamp - delta + 1.0 / b.sample_rate


def test_dswp_fits_around_lost_samples_exactly():
    sea = lines_sea(BuoyErrors(dropout=0.3, seed=4))
    b = sea.buoy()
    t, eta = b.record(100.0, 100.0 + T_REC - 0.5)
    assert np.isnan(eta).sum() > 100
    with pytest.raises(ValueError, match="NaN"):
        predict_from_buoy(t, eta, b.x, 0.0, DEPTH, window_s=T_REC)
    f = predict_from_buoy(t, eta, b.x, 0.0, DEPTH, window_s=T_REC, allow_gaps=True)
    tt = np.linspace(f.valid_from, f.valid_until, 50)
    truth = elevation(sea.components, 0.0, tt)     # the lines lie in the fit's span: recovered exactly
    np.testing.assert_allclose(elevation(f.components(), 0.0, tt), truth, atol=1e-8)
    lost = eta.copy()
    lost[: int(0.6 * eta.size)] = np.nan
    with pytest.raises(ValueError, match="lost"):
        predict_from_buoy(t, lost, b.x, 0.0, DEPTH, window_s=T_REC, allow_gaps=True)


def test_dswp_from_an_offset_clock_is_late_by_the_offset():
    # A single line: the forecast from a buoy whose clock runs δ ahead is the true wave δ later.
    delta = 0.8
    one = {"freq_hz": (45 / T_REC,), "amp": (1.0,), "phase": (0.4,)}
    sea = lines_sea(BuoyErrors(clock_offset=delta), **one)
    t, eta = sea.buoy().record(100.0, 100.0 + T_REC - 0.5)
    f = predict_from_buoy(t, eta, sea.buoy_x, 0.0, DEPTH, window_s=T_REC)
    tt = np.linspace(f.valid_from, f.valid_until, 40)
    np.testing.assert_allclose(elevation(f.components(), 0.0, tt), elevation(sea.components, 0.0, tt - delta),
                               atol=1e-8)


# ---------------------------------------------------------------------------- DSWP options

def test_dswp_horizon_and_dispersion_options_act():
    sea = lines_sea()
    t, eta = sea.buoy().record(100.0, 100.0 + T_REC - 0.5)
    zone = predict_from_buoy(t, eta, sea.buoy_x, 0.0, DEPTH, window_s=T_REC)
    fixed = predict_from_buoy(t, eta, sea.buoy_x, 0.0, DEPTH, window_s=T_REC, horizon_s=12.0)
    assert fixed.valid_until == pytest.approx(t[-1] + 12.0) and zone.valid_until < t[-1] + 12.0
    deep = predict_from_buoy(t, eta, sea.buoy_x, 0.0, DEPTH, window_s=T_REC, deep_water=True)
    np.testing.assert_allclose(deep.k, deep.omega**2 / 9.81, rtol=1e-14)
    assert np.all(zone.k > deep.k)                   # finite depth: tanh kd < 1, so k > ω²/g
    narrow = predict_from_buoy(t, eta, sea.buoy_x, 0.0, DEPTH, window_s=T_REC, f_max=0.18)
    assert narrow.omega.max() < 2 * np.pi * 0.18 and zone.omega.size == 3 and narrow.omega.size == 2


class _Handoff:
    def __init__(self):
        self.offered = []

    def offer(self, f):
        self.offered.append(f)


def test_dswp_feeder_defaults_are_the_former_behaviour():
    from sitl.harness.run import DSWPFeeder
    from sitl.harness.spec import RunSpec

    sea = Sea.load("W1")
    fw = type("FW", (), {"forecast": _Handoff()})()
    DSWPFeeder(sea, fw, 0.0, **RunSpec(forecast="dswp").dswp_options()).advance(30.0)
    t, eta = sea.buoy().record(30.0 - 120.0, 30.0)
    before = predict_from_buoy(t, eta, sea.buoy_x, 0.0, DEPTH, window_s=120.0, oversample=2, seq=1)
    got = fw.forecast.offered[0]
    for name in ("omega", "k"):
        assert np.array_equal(getattr(got, name), getattr(before, name))
    # The feeder's BuoyTape measures each sample once, in blocks: BLAS may round a sample's sum in
    # the last bit otherwise than for the whole window, so the fit agrees to rounding, not bit for bit.
    np.testing.assert_allclose(got.amplitude, before.amplitude, rtol=1e-10, atol=0)
    np.testing.assert_allclose(got.phase, before.phase, rtol=0, atol=1e-10)
    assert (got.valid_from, got.valid_until) == (before.valid_from, before.valid_until)
    with pytest.raises(ValueError, match=r"dswp\.window_s"):
        RunSpec(forecast="dswp", dswp={"window_s": 5.0})
    with pytest.raises(ValueError, match="dswp"):
        RunSpec(controller="cpd", dswp={"window_s": 60.0})


# ---------------------------------------------------------------------------- 2. current and true vehicle

def _drift(sea: Sea, true_vehicle=None, seconds=60.0, depth=30.0, dof=None) -> tuple[Plant, np.ndarray]:
    plant = Plant.from_configs(sea, true_vehicle=true_vehicle, dof=dof)
    plant.reset(eta=[0.0, depth, 0.0])
    xs = []
    for _ in range(int(seconds * 20)):
        plant.step(NEUTRAL, 0.05)
        xs.append(plant.state.eta.copy())
    return plant, np.array(xs)


@pytest.mark.parametrize("direction, in_plane", [(0.0, 0.3), (60.0, 0.15), (180.0, -0.3)])
def test_an_unpowered_vehicle_drifts_with_the_current(direction, in_plane):
    """The planar world feels the current's in-plane part U cos ψ_c."""
    sea = dataclasses.replace(Sea.still_water(), current=(0.3, direction))
    _, eta = _drift(sea, dof="planar")
    x_rate = (eta[-1, 0] - eta[-201, 0]) / 10.0       # over the last 10 s
    assert x_rate == pytest.approx(in_plane, abs=1e-4)


@pytest.mark.parametrize("direction", [0.0, 60.0, 135.0, -90.0])
def test_in_six_dof_an_unpowered_vehicle_drifts_with_the_whole_current(direction):
    """The six-DoF world takes the current as an NED vector: the vehicle drifts north and east with it (sway's
    damping is quadratic only, so the last of the relative sway decays as 1/t: a few mm/s after a minute)."""
    sea = dataclasses.replace(Sea.still_water(), current=(0.3, direction))
    plant, _ = _drift(sea, seconds=90.0, dof="six")
    rows = []
    for _ in range(200):
        plant.step(NEUTRAL, 0.05)
        rows.append(plant.state.eta6[:2].copy())
    rate = (rows[-1] - rows[0]) / (199 * 0.05)
    np.testing.assert_allclose(rate, 0.3 * np.array([np.cos(np.radians(direction)), np.sin(np.radians(direction))]),
                               atol=4e-3)


def test_current_is_the_same_on_the_numpy_reference_path(monkeypatch):
    from bridge.models import kernels

    sea = dataclasses.replace(Sea.load("W1"), current=(0.3, 20.0))
    _, fast = _drift(sea, seconds=3.0, depth=5.0)
    monkeypatch.setattr(kernels, "ENABLED", False)
    _, ref = _drift(sea, seconds=3.0, depth=5.0)
    np.testing.assert_allclose(fast, ref, rtol=0, atol=1e-9)


def test_zero_current_leaves_the_plant_bit_for_bit():
    w1 = Sea.load("W1")
    _, a = _drift(w1, seconds=5.0, depth=5.0, dof="planar")
    _, b = _drift(dataclasses.replace(w1, current=(0.0, 30.0)), seconds=5.0, depth=5.0, dof="planar")
    _, c = _drift(dataclasses.replace(w1, current=(0.2, 90.0)), seconds=5.0, depth=5.0, dof="planar")   # cross-plane
    _, d = _drift(dataclasses.replace(w1, current=(0.0, 30.0)), seconds=5.0, depth=5.0, dof="six")   # and six DoF
    _, e = _drift(w1, seconds=5.0, depth=5.0, dof="six")
    assert np.array_equal(d, e)
    assert np.array_equal(a, b) and np.allclose(a, c, rtol=0, atol=1e-12)


def test_true_vehicle_scales_only_the_plant():
    nominal = load_vehicle_config("bluerov2_heavy")
    true = apply_true_vehicle(nominal, load_true_vehicle("added_mass_plus20"))
    assert true["added_mass"]["Z_wdot"] == pytest.approx(1.2 * nominal["added_mass"]["Z_wdot"])
    assert true["damping"] == nominal["damping"] and load_vehicle_config("bluerov2_heavy") == nominal
    plant = Plant.from_configs(Sea.still_water(), true_vehicle="drag_minus20")
    assert plant.vehicle.Z_ww == pytest.approx(0.8 * nominal["damping"]["Z_ww"])


@pytest.mark.parametrize("true_vehicle", [None, "drag_minus20", "drag_plus20"])
def test_buoyant_rise_speed_is_the_force_balance(true_vehicle, tmp_path):
    # Terminal heave: (B − W) = (Z_w + Z_ww |w|) |w|, solved by hand for the plant's own coefficients.
    plant, eta = _drift(Sea.still_water(), true_vehicle, seconds=40.0)
    p = plant.vehicle
    w = (-p.Z_w + np.sqrt(p.Z_w**2 + 4 * p.Z_ww * (p.B - p.W))) / (2 * p.Z_ww)
    rise = (eta[-201, 1] - eta[-1, 1]) / 10.0
    assert rise == pytest.approx(w, rel=1e-4)


def test_true_vehicle_volume_and_centre_of_buoyancy(tmp_path):
    f = tmp_path / "heavier.yaml"
    f.write_text("name: heavier\nscale: {B: 0.98, r_B: 2.0}\n")
    plant = Plant.from_configs(Sea.still_water(), true_vehicle=str(f))
    assert pytest.approx(0.98 * 114.8) == plant.vehicle.B
    assert pytest.approx(-0.056) == plant.vehicle.r_B[2]
    f.write_text("name: bad\nscale: {Z_wdot: 20}\n")
    with pytest.raises(ConfigError, match=r"scale.Z_wdot.*\[0.1, 10\]"):
        load_true_vehicle(str(f))


# ---------------------------------------------------------------------------- 3. dynamic pressure

def test_pressure_head_is_the_linear_transfer_function():
    a, f, ph = np.array([0.8, 0.3]), np.array([0.08, 0.2]), np.array([0.2, 1.1])
    c = WaveComponents.from_spectrum_lines(a, 2 * np.pi * f, ph, DEPTH, True)
    x, s, t = 3.0, 5.0, np.linspace(0.0, 30.0, 61)
    kp = np.cosh(c.k * (DEPTH - s)) / np.cosh(c.k * DEPTH)
    truth = (a * kp * np.cos(c.k * x - np.multiply.outer(t, c.omega) + ph)).sum(axis=-1)
    np.testing.assert_allclose(pressure_head(c, x, s, t), truth, atol=1e-12)
    np.testing.assert_allclose(pressure_head(dataclasses.replace(c, second_order=False), x, 0.0, t),
                               elevation(dataclasses.replace(c, second_order=False), x, t), atol=1e-12)
    deep = WaveComponents.from_spectrum_lines([1.0], [2.0], [0.0], 5000.0, False)     # kd ≫ 1: e^{−ks}
    assert pressure_head(deep, 0.0, s, 0.0) == pytest.approx(np.exp(-deep.k[0] * s), rel=1e-12)


def test_the_depth_sensor_reads_the_dynamic_pressure_when_asked():
    from firmware_py.hal.base import InProcessSITLHAL
    from firmware_py.params.table import load_params

    params = load_params().copy()
    params.set("SIM_DEPTH_RND", 0.0)
    readings = {}
    for on in (False, True):
        sea = Sea.load("W3", overrides={"depth_sensor.dynamic_pressure": on})
        plant = Plant.from_configs(sea)
        hal = InProcessSITLHAL(plant, params, 0.05, 7)
        plant.step(NEUTRAL, 0.05)
        s = plant.state
        readings[on] = hal.read_sensors().depth - s.eta[1]
        if on:
            assert readings[on] == pytest.approx(float(sea.pressure_head(s.eta[0], s.eta[1], s.t)), abs=1e-12)
            assert abs(readings[on]) > 1e-3
    assert readings[False] == 0.0


# ---------------------------------------------------------------------------- configs

def test_sea_options_are_validated_with_file_key_and_range():
    with pytest.raises(ConfigError, match=r"W1.yaml: key 'buoy.dropout'.*\[0, 0.9\]"):
        load_sea_config("W1", {"buoy.dropout": 0.95})
    with pytest.raises(ConfigError, match=r"key 'current.speedd'.*unknown key"):
        load_sea_config("W1", {"current.speedd": 0.3})
    cfg = load_sea_config("W1")
    assert cfg["buoy"]["noise_snr_db"] is None and cfg["buoy"]["dropout"] == 0.0
    assert cfg["current"] == {"speed": 0.0, "direction": 0.0} and cfg["depth_sensor"]["dynamic_pressure"] is False


# ---------------------------------------------------------------------------- campaigns

def test_the_sea_errors_campaign_reaches_every_option():
    from pathlib import Path

    from sitl.harness.campaign_spec import load_campaign_spec

    c = load_campaign_spec(Path(__file__).resolve().parents[1] / "configs/campaign/sea_errors.yaml")
    assert len(c.tasks()) == 3 * 20 * len(c.variants) == 1560 and c.duration == 600
    by = {v.name: v for v in c.variants}
    assert by["ff_dswp_buoy10db"].sea == {"buoy.noise_snr_db": 10}
    assert by["ff_current03"].sea == {"current.speed": 0.3, "current.direction": 0}
    assert by["ff_am_p20"].true_vehicle == "added_mass_plus20" and by["ff_am_p20"].baseline == "cpd_am_p20"
    spec = next(t.spec for t in c.tasks() if t.variant == "ff_bar30")
    assert spec.sea == {"depth_sensor.dynamic_pressure": True} and spec.overrides == {"WK_BARO_WAVE": 1}
    raw = next(t.spec for t in c.tasks() if t.variant == "ff_bar30_raw")
    assert raw.sea == spec.sea and not raw.overrides and by["ff_bar30_raw"].baseline == "cpd_bar30"


def test_world_options_leave_a_default_spec_and_its_hash_as_they_were():
    import hashlib
    import json
    from dataclasses import asdict

    from sitl.harness.campaign_spec import spec_hash
    from sitl.harness.spec import RunSpec

    spec = RunSpec(case="W2", controller="cpd_ff", seed=4, overrides={"WK_FF_GAIN": 0.8})
    d = {k: v for k, v in asdict(spec).items() if k not in ("sea", "true_vehicle", "dswp")}
    legacy = hashlib.sha1(json.dumps(d, sort_keys=True).encode()).hexdigest()[:16]
    assert spec_hash(spec) == legacy
    assert spec_hash(dataclasses.replace(spec, sea={"current.speed": 0.3})) != legacy


@pytest.mark.parametrize("variant, key", [
    ({"name": "x", "controller": "cpd", "sea": {"buoy": {"dropout": 2.0}}}, r"variants\[1\]\.sea.*buoy\.dropout"),
    ({"name": "x", "controller": "cpd", "true_vehicle": "no_such"}, r"variants\[1\]\.true_vehicle"),
    ({"name": "x", "controller": "cpd_ff", "forecast": "dswp", "dswp": {"f_max": 9}}, r"variants\[1\]\.dswp"),
    ({"name": "x", "controller": "cpd_ff", "baseline": "x"}, r"variants\[1\]\.baseline"),
])
def test_bad_world_options_fail_the_campaign_naming_the_key(tmp_path, variant, key):
    import yaml

    from sitl.harness.campaign_spec import load_campaign_spec

    doc = {"name": "t", "cases": ["W1"], "seeds": [1], "baseline": "cpd",
           "variants": [{"name": "cpd", "controller": "cpd"}, variant]}
    path = tmp_path / "c.yaml"
    path.write_text(yaml.safe_dump(doc))
    with pytest.raises(ConfigError, match=key):
        load_campaign_spec(path)


def test_a_variant_is_compared_with_its_own_baseline():
    from sitl.harness.metrics import DOF
    from sitl.harness.stats import summarise_campaign

    def row(variant, seed, rmse):
        return {"case": "W1", "variant": variant, "seed": seed, "status": "ok",
                **{f"rmse_{d}": rmse for d in DOF},
                **{f"max_abs_error_{d}": rmse for d in DOF}}

    rows = [row(v, s, r) for s in (1, 2, 3) for v, r in (("cpd", 1.0), ("cpd_cur", 2.0), ("ff_cur", 1.0))]
    s = summarise_campaign(rows, ["W1"], ["cpd", "cpd_cur", "ff_cur"], "cpd", 200, 0, {"ff_cur": "cpd_cur"})
    assert s["overall"]["ff_cur"]["reduction_pct_mean"] == pytest.approx(50.0)     # against cpd_cur
    assert s["overall"]["cpd_cur"]["reduction_pct_mean"] == pytest.approx(-100.0)  # the error's cost to C-PD


# ---------------------------------------------------------------------------- 5. short-crested seas

@pytest.mark.parametrize("s", [1.0, 10.0, 30.0])
def test_cos2s_directions_have_the_analytic_first_moment(s):
    from sitl.sea import cos2s_directions

    beta = cos2s_directions(s, np.radians(20.0), 200_000, np.random.default_rng(3))
    c = np.cos(beta - np.radians(20.0))
    assert abs(c.mean() - s / (s + 1)) < 4 * c.std() / np.sqrt(c.size)
    assert abs(np.mean(np.sin(beta - np.radians(20.0)))) < 4 / np.sqrt(c.size)     # symmetric about the mean


def test_a_component_at_an_angle_has_in_plane_kinematics():
    from bridge.models.waves import particle_kinematics, particle_kinematics_grid

    beta = np.radians(35.0)
    c = WaveComponents.from_spectrum_lines([1.2], [0.7], [0.4], DEPTH, False)
    c = dataclasses.replace(c, direction=np.array([beta]))
    k, w, a = c.k[0], 0.7, 1.2
    x, s, t = np.array([3.0, -20.0]), np.array([5.0, 12.0]), 7.5
    th = k * np.cos(beta) * x - w * t + 0.4
    u_truth = a * w * np.cosh(k * (DEPTH - s)) / np.sinh(k * DEPTH) * np.cos(th) * np.cos(beta)
    w_up_truth = a * w * np.sinh(k * (DEPTH - s)) / np.sinh(k * DEPTH) * np.sin(th)
    u, wd, _, _ = particle_kinematics(c, x, s, t)
    np.testing.assert_allclose(u, u_truth, atol=1e-12)
    np.testing.assert_allclose(wd, -w_up_truth, atol=1e-12)
    np.testing.assert_allclose(elevation(c, x, t), a * np.cos(th), atol=1e-12)
    grid = particle_kinematics_grid(c, x, s, np.array([t]))
    np.testing.assert_allclose(np.concatenate(grid[:2]).ravel(), np.concatenate([u, wd]), atol=1e-12)


def test_spread_sea_config_keeps_the_spectrum_and_phases():
    long = Sea.load("W2")
    spread = Sea.load("W2", overrides={"spreading.s": 10.0, "spreading.direction": 20.0})
    assert long.components.direction is None and spread.components.direction is not None
    for name in ("amplitude", "omega", "k", "phase"):
        assert np.array_equal(getattr(long.components, name), getattr(spread.components, name))
    assert np.mean(np.cos(spread.components.direction - np.radians(20.0))) > 0.8
    with pytest.raises(ConfigError, match=r"spreading.s.*focus"):
        load_sea_config("design/W2F", {"spreading.s": 10.0})


def test_spread_sea_kernels_match_the_numpy_reference(monkeypatch):
    from bridge.models import kernels
    from bridge.models.vehicle import body_flow, strip_nodes

    if not kernels.ENABLED:
        pytest.skip("numba not installed or WAVEKEEP_NUMBA=0")
    c = Sea.load("W3", overrides={"spreading.s": 10.0, "spreading.direction": 20.0}).components
    xs = strip_nodes(0.457, 6)
    t = np.array([10.0, 10.025, 10.05])
    fast = body_flow(c, np.array([0.3, 5.0, 0.05]), t, xs)
    monkeypatch.setattr(kernels, "ENABLED", False)
    ref = body_flow(c, np.array([0.3, 5.0, 0.05]), t, xs)
    for name in ("u", "w", "ax", "az"):
        np.testing.assert_allclose(getattr(fast, name), getattr(ref, name), rtol=0, atol=1e-12)


@pytest.mark.parametrize("s, mean", [(10.0, 20.0), (30.0, 0.0), (3.0, -30.0)])
def test_a_small_array_recovers_the_spreading(s, mean):
    # Longuet-Higgins' first moments from three gauges: r1 = s/(s+1) and the mean direction, over seeds
    from bridge.models.waves import elevation_xy
    from sitl.harness.directional import directional_moments, triangle_array

    gx, gy = triangle_array(0.0, 1.0)
    t = np.arange(0.0, 2400.0, 0.5)
    got = []
    for seed in (1, 2, 3, 4):
        sea = Sea.load("W2", seed=seed, overrides={"spreading.s": s, "spreading.direction": mean, "components": 600})
        eta = elevation_xy(sea.components, gx[None, :], gy[None, :], t[:, None])
        fp = sea.omega_peak / (2 * np.pi)
        got.append(directional_moments(eta, gx, gy, 0.5, (0.5 * fp, 2.0 * fp)))
    assert np.mean([g["r1"] for g in got]) == pytest.approx(s / (s + 1), abs=0.02)
    assert np.mean([g["mean_direction_deg"] for g in got]) == pytest.approx(mean, abs=4.0)


def test_a_long_crested_sea_is_the_same_on_every_line():
    from bridge.models.waves import elevation_xy

    c = Sea.load("W1").components
    t = np.linspace(0.0, 30.0, 31)
    assert np.array_equal(elevation_xy(c, 2.0, 7.0, t), elevation(c, 2.0, t))


def test_the_run_command_takes_the_world_options():
    import argparse

    from sitl.harness.commands.options import UsageError, run_spec

    ns = argparse.Namespace(case="W1", controller="cpd_ff", forecast="dswp", forecast_snr_db=None, seed=1,
                            duration=10.0, mission="station_keeping", vehicle="bluerov2_heavy", params=None, set=None,
                            sea_set=["buoy.noise_snr_db=10", "current.speed=0.3"], true_vehicle="drag_plus20",
                            dswp_set=["deep_water=true"])
    spec = run_spec(ns)
    assert spec.sea == {"buoy.noise_snr_db": 10, "current.speed": 0.3} and spec.dswp == {"deep_water": True}
    assert spec.true_vehicle == "drag_plus20"
    with pytest.raises(UsageError, match=r"--sea-set.*buoy\.dropout"):
        run_spec(argparse.Namespace(**{**vars(ns), "sea_set": ["buoy.dropout=2"]}))
    with pytest.raises(UsageError, match=r"--dswp-set"):
        run_spec(argparse.Namespace(**{**vars(ns), "forecast": "oracle"}))


# ---------------------------------------------------------------------------- the networked buoy

class _Session:
    def __init__(self):
        self.sent = []

    def declare_publisher(self, key):
        return type("Pub", (), {"put": lambda _, payload: self.sent.append(payload), "undeclare": lambda _: None})()


def test_the_networked_buoy_sends_the_real_buoy_and_the_service_marks_its_gaps():
    from bridge.buoy_codec import decode_buoy
    from bridge.forecast_service import append_record
    from sitl.buoy_publisher import BuoyPublisher

    sea = Sea.load("W1", overrides={"buoy.noise_snr_db": 10.0, "buoy.dropout": 0.2, "buoy.clock_offset": 0.5})
    session = _Session()
    pub = BuoyPublisher(session, "moray", sea, history_s=20.0)
    for t in np.arange(0.05, 20.0, 0.05):
        pub.advance(float(t))
    recs = [decode_buoy(p) for p in session.sent]
    t, eta = np.zeros(0), np.zeros(0)
    for r in recs:
        np.testing.assert_allclose(r.eta, sea.buoy().measure(r.t), rtol=0, atol=1e-12)   # noise and offset
        t, eta = append_record(t, eta, r.t, r.eta, r.dt)
    assert np.allclose(np.diff(t), 0.5) and t[0] == -20.0 and t[-1] <= 20.0 + 0.5   # stamps: up to now + δ
    want = sea.buoy().measure(t)
    np.testing.assert_array_equal(np.isnan(eta), np.isnan(want))                     # the lost ones, as NaN
    assert 0.1 < np.isnan(eta).mean() < 0.3


def test_a_perfect_networked_buoy_sends_what_it_always_sent():
    from bridge.buoy_codec import decode_buoy
    from sitl.buoy_publisher import BuoyPublisher

    sea = Sea.load("W1")
    session = _Session()
    pub = BuoyPublisher(session, "moray", sea, history_s=10.0)
    for t in np.arange(0.05, 5.0, 0.05):
        pub.advance(float(t))
    recs = [decode_buoy(p) for p in session.sent]
    assert len(recs) == pub.published
    for r in recs:
        assert np.array_equal(r.eta, sea.elevation(sea.buoy_x, r.t0 + 0.5 * np.arange(r.eta.size)))
