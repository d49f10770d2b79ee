"""The aided estimator (issue #19): DVL range and dropouts, graceful degradation, consistency, the DOB."""
from __future__ import annotations

import math

import numpy as np
import pytest

from firmware_py.hal.sensors import SensorFrame, SimulatedSensors, specific_force
from firmware_py.modes import Mode
from firmware_py.params.table import load_params
from sitl.harness.run import build_mission, run_mission
from sitl.harness.spec import RunSpec


def tick(m, n: int = 1):
    for _ in range(n):
        m.firmware.scheduler.run_tick()
        m.hal.step_world()


def test_dvl_reads_only_within_its_altitude_range():
    params = load_params()
    s = SimulatedSensors(params, 1)
    params.set("SIM_DVL_DROP", 0.0)
    params.set("SIM_WATER_DEPTH", 54.0)
    ok = [s.read(k / 20.0, [0.0, 5.0, 0.0], [0.1, 0.0, 0.0]) for k in range(40)]
    got = [f.dvl_u for f in ok if math.isfinite(f.dvl_u)]
    assert len(got) == 8                                              # 4 Hz over 2 s
    assert abs(np.mean(got) - 0.1) < 3 * params["SIM_DVL_RND"]
    far = [s.read(2.0 + k / 20.0, [0.0, 3.0, 0.0], [0.1, 0.0, 0.0]) for k in range(40)]   # altitude 51 m
    assert all(math.isnan(f.dvl_u) and math.isnan(f.dvl_w) for f in far)


def test_specific_force_at_rest_is_gravity_up():
    f = specific_force([0.0, 5.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], 9.81)
    np.testing.assert_allclose(f, [0.0, -9.81])


def test_dvl_beyond_its_range_degrades_gracefully_and_the_failsafe_acts():
    """No bottom lock (water too deep): velocity σ grows but the estimate stays honest; with the
    position fix lost as well, σ grows past FS_EKF_THRESH × WK_EKF_SD_BAD and the failsafe disarms
    the vehicle (FS_EKF_ACTION 2)."""
    from dataclasses import replace as dc_replace

    def velocity_sigma(water_depth: float) -> tuple[float, object]:
        m = build_mission(RunSpec("W1", "cpd", duration=20.0,
                                  overrides={"SIM_WATER_DEPTH": water_depth, "WK_EKF_MODE": 1}),
                          params=load_params())
        m.firmware.params.set("SIM_WATER_DEPTH", water_depth)
        tick(m)
        m.firmware.request_mode(Mode.POSHOLD)
        m.firmware.request_arm(True)
        tick(m, 200)
        return float(m.firmware.ekf.sigma()[3]), m

    s_lock, _ = velocity_sigma(54.0)
    s_deep, m = velocity_sigma(200.0)            # altitude 195 m > 50 m: no DVL reading at all
    fw, hal = m.firmware, m.hal
    assert fw.ekf.accepted["dvl_u"] == 0 and s_deep > 1.5 * s_lock
    err = abs(fw.ekf.x[3] - m.plant.state.nu[0])
    assert err < 4 * s_deep and not fw.failsafe_ekf
    fw.params.set("FS_EKF_ACTION", 2)
    fw.params.set("FS_EKF_THRESH", 0.12)                   # a 0.3 m 1-sigma
    read = hal.read_sensors
    hal.read_sensors = lambda: dc_replace(read(), x=float("nan"))
    for _ in range(1200):
        tick(m)
        if fw.failsafe_ekf:
            break
    assert fw.failsafe_ekf and not fw.armed
    assert fw.ekf.sigma()[0] > fw.params["FS_EKF_THRESH"] * fw.params["WK_EKF_SD_BAD"]


@pytest.fixture(scope="module")
def w1_runs():
    """Short W1 missions without a forecast (C-PD) and with the exact one (C-PD+FF), aided estimator."""
    return {c: run_mission(RunSpec("W1", c, seed=3, duration=120.0, overrides={"WK_EKF_MODE": 1}))
            for c in ("cpd", "cpd_ff")}


@pytest.mark.parametrize("controller", ["cpd", "cpd_ff"])
def test_nees_within_bounds_in_a_short_w1_mission(w1_runs, controller):
    """Against the plant's true state: the campaign's bounds ([0.5, 2], 95 % within 2σ) for pitch, the
    velocities and the pitch rate, with and without the forecast in the model; position looser (120 s)."""
    ekf = w1_runs[controller].results["ekf"]
    for state in ("theta", "u", "w", "q"):
        assert 0.5 <= ekf["nees"][state] <= 2.0, (state, ekf["nees"][state])
        assert ekf["within_2sigma"][state] >= 0.95, (state, ekf["within_2sigma"][state])
    for state in ("x", "z"):
        assert 0.3 <= ekf["nees"][state] <= 2.0, (state, ekf["nees"][state])
        assert ekf["within_2sigma"][state] >= 0.9, state
    assert 0.5 <= ekf["nis_per_dof"] <= 2.0
    assert max(ekf["vel_error_ratio"]["u"], ekf["vel_error_ratio"]["w"]) <= 0.25


def test_accelerometer_is_a_consider_measurement_for_pitch():
    """WK_EKF_ACC_TH 0: an accelerometer reading moves the disturbance and velocities but neither θ nor its
    variance (Schmidt update, Joseph form), and the covariance stays symmetric positive definite."""
    m = build_mission(RunSpec("W1", "cpd", duration=10.0, overrides={"WK_EKF_MODE": 1}), params=load_params())
    tick(m, 40)
    ekf = m.firmware.ekf
    assert ekf.params["WK_EKF_ACC_TH"] == 0
    x0, P0 = ekf.kf.x[:, 0].copy(), ekf.P.copy()
    hx, _ = ekf._model(accel=True)   # the accelerometer's predicted [f_x, f_z] in channels 6, 7
    nan = math.nan
    frame = SensorFrame(t=m.firmware.ekf._last_accept_t.max() + 0.05, x=nan, depth=nan, pitch=nan,
                        pitch_rate=nan, acc_x=float(hx[6]) + 0.03, acc_z=float(hx[7]) - 0.03)
    assert ekf.update(frame)[6:].all()
    assert ekf.kf.x[2, 0] == x0[2] and ekf.P[2, 2] == pytest.approx(P0[2, 2], rel=1e-12)
    assert abs(ekf.kf.x[6, 0] - x0[6]) > 1e-3 and abs(ekf.kf.x[7, 0] - x0[7]) > 1e-3
    np.testing.assert_allclose(ekf.P, ekf.P.T, atol=1e-15)
    assert np.all(np.linalg.eigvalsh(ekf.P) > 0)


def test_paper_mode_keeps_todays_estimator():
    r = run_mission(RunSpec("W1", "cpd", seed=1, duration=10.0))        # the default: the paper's estimator
    assert set(r.results["ekf"]["accepted"]) == {"position", "depth", "pitch", "pitch_rate"}


def test_dob_feeds_back_the_estimated_disturbance():
    m = build_mission(RunSpec("W2", "cpd_dob", duration=10.0), params=load_params())
    assert m.firmware.params["WK_DOB_ENABLE"] == 1 and m.firmware.params["WK_EKF_MODE"] == 1
    with pytest.raises(ValueError, match="aided estimator"):
        RunSpec("W2", "cpd_dob", overrides={"WK_EKF_MODE": 0})
    tick(m)
    m.firmware.request_mode(Mode.GUIDED)
    m.firmware.request_arm(True)
    tick(m, 100)
    r = m.firmware.last
    lim = np.array(m.firmware.params.axes("WK_DOB_LIM")) * np.array(m.firmware.params.axes("WK_TAU_MAX"))
    np.testing.assert_allclose(r.control.tau_dob, np.clip(-r.d_hat, -lim, lim))
    assert np.any(np.abs(r.d_hat) > 1.0)


def _hovering_ekf(params, ticks: int = 40):
    """A paper-mode EKF that has fused ``ticks`` steady frames at 5 m depth (thrust cancelling buoyancy)."""
    from bridge.models.vehicle import VehicleParams
    from firmware_py.estimation.estimator import PlanarEKF

    ekf = PlanarEKF(VehicleParams.load("bluerov2_heavy"), params, 0.05)
    hover = np.zeros((3, 3))
    hover[:, 1] = -2.0
    ekf.update(SensorFrame(0.0, 0.0, 5.0, 0.0, 0.0))
    for k in range(1, ticks):
        ekf.predict(hover)
        ekf.update(SensorFrame(k * 0.05, 0.0, 5.0, 0.0, 0.0))
    return ekf, hover


def test_ekf_per_tick_caches_follow_parameter_changes():
    """The gate, R and Q are read once per parameter-table version: a change made through the table
    (MAVLink PARAM_SET) acts from the next tick."""
    params = load_params()
    ekf, hover = _hovering_ekf(params)
    ekf.predict(hover)
    sigma_pos = math.sqrt(ekf.P[0, 0] + params["WK_EKF_R_POS"] ** 2)
    assert ekf.update(SensorFrame(2.0, 3.0 * sigma_pos, 5.0, 0.0, 0.0))[0]     # 3 σ: within the 5 σ gate
    assert params.set("WK_EKF_GATE", 2.0) is None
    ekf.predict(hover)
    sigma_pos = math.sqrt(ekf.P[0, 0] + params["WK_EKF_R_POS"] ** 2)
    assert not ekf.update(SensorFrame(2.05, ekf.x[0] + 3.0 * sigma_pos, 5.0, 0.0, 0.0))[0]
    assert params.set("WK_EKF_R_POS", 0.05) is None and params.set("WK_EKF_Q_POS", 0.02) is None
    ekf.predict(hover)
    assert ekf.kf.Q[0, 0] == 0.02**2 * 0.05
    ekf.update(SensorFrame(2.1, ekf.x[0], 5.0, 0.0, 0.0))
    assert ekf.kf.R[0, 0] == 0.05**2


def test_ekf_non_finite_covariance_gates_everything_out():
    """With a non-finite entry anywhere in P, no reading passes the gate (S = H P Hᵀ + R is NaN, as the
    general sum gives it), whatever the shortcut the paper's mode takes for a finite P."""
    params = load_params()
    ekf, hover = _hovering_ekf(params, 10)
    ekf.predict(hover)
    ekf.kf.P[0, 4] = ekf.kf.P[4, 0] = math.inf
    accepted = ekf.update(SensorFrame(0.5, 0.0, 5.0, 0.0, 0.0))
    assert not accepted.any() and np.isnan(ekf.last_nis).all()
