"""The firmware in six DoF: lateral sensors, the lateral plane's estimate and hold, the 6-DoF mixer, MAVLink.

Truth comes from the six-DoF world (its state at each tick) and from closed forms (B f = τ for an unsaturated
allocation); the firmware's own output is never its own reference.
"""
from __future__ import annotations

import math
import time

import numpy as np
import pytest
from mavlink_gcs import GroundStation, free_port

from bridge.json_sitl import decode_state, encode_state, state_message
from bridge.models.thrusters import T200Curve, ThrusterLayout
from bridge.schemas import load_vehicle_config
from firmware_py.hal.sensors import SimulatedSensors
from firmware_py.modes import Mode
from firmware_py.motors.mixer import MotorMixer
from firmware_py.params.table import load_params
from sitl.harness.live import LiveSim
from sitl.harness.results import COLUMN
from sitl.harness.run import build_mission, run_mission, take_off
from sitl.harness.spec import RunSpec

BEAM = {"spreading.direction": 90.0, "dof": "six"}
DOFS = ("x", "y", "z", "roll", "pitch", "yaw")


def _mixer(params=None) -> MotorMixer:
    th = load_vehicle_config("bluerov2_heavy")["thrusters"]
    return MotorMixer(ThrusterLayout.from_config(th), T200Curve.from_config(th), params or load_params(), 0.05)


# ------------------------------------------------------------------ sensors and the JSON state

def test_the_lateral_channels_read_only_a_six_dof_world_and_leave_the_others_noise_alone():
    params = load_params()
    eta, nu = np.array([1.0, 5.0, 0.02]), np.array([0.1, 0.0, 0.01])
    lateral = np.array([0.3, 0.05, 3.1, 0.2, -0.1, 0.02])      # y, φ, ψ, v, p, r
    sa, sb = SimulatedSensors(params, 7), SimulatedSensors(params, 7)
    planar = [sa.read(0.05 * k, eta, nu) for k in range(40)]
    six = [sb.read(0.05 * k, eta, nu, lateral=lateral) for k in range(40)]
    for a, b in zip(planar, six, strict=True):
        assert (a.x, a.depth, a.pitch, a.pitch_rate) == (b.x, b.depth, b.pitch, b.pitch_rate) or math.isnan(a.x)
        assert all(math.isnan(v) for v in a.lateral_readings())
        assert math.isfinite(b.roll) and math.isfinite(b.yaw) and math.isfinite(b.yaw_rate)
        assert -math.pi < b.yaw <= math.pi
        assert math.isnan(b.y) == math.isnan(b.x)              # the fix gives both coordinates at once
    rolls = np.array([f.roll for f in six])
    assert rolls.mean() == pytest.approx(0.05, abs=3 * params["SIM_PITCH_RND"])
    yaw_err = np.array([math.remainder(f.yaw - 3.1, 2 * math.pi) for f in six])
    assert np.std(yaw_err) == pytest.approx(params["SIM_YAW_RND"], rel=0.4)


def test_the_json_state_carries_the_lateral_truth_in_a_six_dof_world_only():
    eta6, nu6, dnu6 = np.array([1.0, 0.4, 5.0, 0.05, 0.02, -0.3]), np.array([0.1, 0.2, 0.0, 0.01, 0.02, 0.03]), \
        np.zeros(6)
    six = decode_state(encode_state(state_message(1.0, eta6[[0, 2, 4]], nu6[[0, 2, 4]], np.zeros(3), np.zeros(8),
                                                  9.81, 3, None, (eta6, nu6, dnu6))))
    assert six.lateral is not None and np.array_equal(six.lateral, [0.4, 0.05, -0.3, 0.2, 0.01, 0.03])
    planar = decode_state(encode_state(state_message(1.0, eta6[[0, 2, 4]], nu6[[0, 2, 4]], np.zeros(3),
                                                     np.zeros(8), 9.81, 3)))
    assert planar.lateral is None
    bad = b'{"timestamp": 1.0, "wavekeep": {"eta": [0.0, 1.0, 0.0], "nu": [0.0, 0.0, 0.0], "lateral": [0.0, 1.0]}}'
    with pytest.raises(ValueError, match="lateral"):
        decode_state(bad)


# ------------------------------------------------------------------ the mixer

def test_a_full_six_dof_wrench_is_allocated_exactly_when_it_fits():
    mixer = _mixer()
    rng = np.random.default_rng(3)
    for _ in range(50):
        tau = rng.uniform(-1, 1, 6) * np.array([40.0, 40.0, 50.0, 6.0, 4.0, 5.0])
        f = mixer.allocate(tau, 35.0)
        assert np.abs(f).max() <= 35.0 + 1e-9
        if np.abs(np.linalg.pinv(mixer.B6) @ tau).max() < 35.0:
            assert mixer.B6 @ f == pytest.approx(tau, abs=1e-9)


def test_attitude_first_when_the_thrusters_saturate_and_surge_and_sway_keep_their_direction():
    mixer = _mixer()
    # heave far past the vertical thrusters' 140 N with a roll and a pitch moment: the moments are kept whole
    f = mixer.allocate(np.array([0.0, 0.0, 400.0, 10.0, 5.0, 0.0]), 35.0)
    w = mixer.B6 @ f
    assert w[3] == pytest.approx(10.0, abs=1e-9) and w[4] == pytest.approx(5.0, abs=1e-9)
    assert 0.0 < w[2] < 140.0
    # a yaw moment and a horizontal push past the vectored thrusters' reach: yaw whole, surge : sway kept
    f = mixer.allocate(np.array([150.0, 100.0, 0.0, 0.0, 0.0, 4.0]), 35.0)
    w = mixer.B6 @ f
    assert w[5] == pytest.approx(4.0, abs=1e-9)
    assert w[0] / w[1] == pytest.approx(1.5, rel=1e-9) and w[0] < 150.0


def test_the_logged_pwm_gives_the_commanded_six_dof_wrench():
    """A beam sea's C-PD+FF without motor-lag compensation: each unsaturated tick's eight PWM values, through the
    T200 curve and the layout, give the logged [X, Y, Z, K, M, N] to the curve's whole-µs resolution."""
    res = run_mission(RunSpec(case="W1", duration=20.0, sea=BEAM, overrides={"WK_MOT_COMP": 0}))
    ts = res.timeseries
    th = load_vehicle_config("bluerov2_heavy")["thrusters"]
    curve, B6 = T200Curve.from_config(th), ThrusterLayout.from_config(th).wrench_matrix()
    pwm = ts[:, [COLUMN[f"pwm{i}"] for i in range(1, 9)]]
    tau = ts[:, [COLUMN[c] for c in ("tau_X", "tau_Y", "tau_Z", "tau_K", "tau_M", "tau_N")]]
    thrust = curve.thrust(pwm)
    wrench = thrust @ B6.T
    # the ticks the allocation did not scale (every thruster short of WK_THR_MAX) and off the dead band
    fits = (np.abs(thrust) < 34.0).all(axis=1) & (np.abs(pwm - 1500) > 40).all(axis=1)
    assert fits.sum() > 50
    err = np.abs(wrench[fits] - tau[fits]).max(axis=0)
    assert (err <= [0.5, 0.5, 0.5, 0.05, 0.05, 0.05]).all(), err
    assert np.abs(tau[:, [1, 3, 5]]).max(axis=0).min() > 0.1      # every lateral axis was commanded


# ------------------------------------------------------------------ the lateral plane in the six-DoF world

def test_a_beam_sea_flies_with_every_dof_reported_and_the_feed_forward_holds_sway():
    runs = {c: run_mission(RunSpec(case="W3", controller=c, duration=60.0, sea=BEAM)).results["six_dof"]
            for c in ("cpd", "cpd_ff")}
    for r in runs.values():
        assert r["world_dof"] == "six"
        assert set(DOFS) <= set(r["rmse"]) and set(DOFS) <= set(r["max_abs_error"])
        assert max(r["max_abs_error"]["roll"], r["max_abs_error"]["pitch"]) < math.radians(20.0)
    assert runs["cpd_ff"]["rmse"]["y"] < 0.6 * runs["cpd"]["rmse"]["y"]      # measured: 0.25 against 0.56 m


def test_the_heading_is_held_in_a_head_sea():
    """Without the lateral plane the Munk moment turned the vehicle broadside within minutes (−89° by 300 s). Held,
    a commanded turn to 0.2 rad in W3's head sea settles there: within 1° over the last 30 s of 60."""
    m = build_mission(RunSpec(case="W3", duration=60.0, sea={"dof": "six"}))
    take_off(m)
    fw, plant = m.firmware, m.plant
    fw.lateral.target[1] = 0.2
    psi = []
    for _ in range(1199):
        fw.scheduler.run_tick()
        m.hal.step_world()
        psi.append(plant.state.eta6[5])
    assert np.abs(np.array(psi[-600:]) - 0.2).max() < math.radians(1.0)


def test_the_lateral_estimate_is_consistent_with_a_forecast_in_its_model():
    """A beam sea with C-PD+FF: NEES of every lateral state within [0.5, 2] and the sway velocity's error under
    25 % of its motion, checked against the world's truth tick by tick."""
    m = build_mission(RunSpec(case="W3", duration=90.0, sea=BEAM))
    take_off(m)
    fw, plant, hal = m.firmware, m.plant, m.hal
    nees, err, truth = [], [], []
    for k in range(1800):
        fw.scheduler.run_tick()
        ekf, s = fw.lateral.ekf, plant.state
        assert ekf is not None
        x = np.array([s.eta6[1], s.eta6[3], s.eta6[5], s.nu6[1], s.nu6[3], s.nu6[5]])
        if k >= 200:                     # after the start's transient
            e = ekf.x - x
            nees.append(e * e / ekf.kf.P.diagonal())
            err.append(e)
            truth.append(x)
        hal.step_world()
    mean_nees = np.mean(nees, axis=0)
    assert ((mean_nees >= 0.5) & (mean_nees <= 2.0)).all(), mean_nees
    rms = lambda a: np.sqrt(np.mean(np.square(a), axis=0))   # noqa: E731
    assert rms(err)[3] < 0.25 * rms(truth)[3]


def test_a_planar_world_never_builds_the_lateral_plane():
    planar = {"dof": "planar"}
    res = run_mission(RunSpec(case="W1", duration=5.0, sea=planar))
    assert np.isnan(res.timeseries[:, COLUMN["y_hat"]]).all() and np.isnan(res.timeseries[:, COLUMN["tau_N"]]).all()
    m = build_mission(RunSpec(case="W1", duration=5.0, sea=planar))
    take_off(m)
    assert m.firmware.lateral.ekf is None and not m.firmware.lateral.estimating


def test_a_mode_that_holds_where_entered_takes_the_heading_and_sway_there():
    m = build_mission(RunSpec(case="still", duration=5.0, sea={"dof": "six"}))
    take_off(m)
    fw = m.firmware
    for _ in range(20):
        fw.scheduler.run_tick()
        m.hal.step_world()
    fw.lateral.ekf.kf.x[2, 0] = 0.5          # as if the vehicle had turned 0.5 rad
    assert fw.request_mode(Mode.POSHOLD) == 0
    assert fw.lateral.target[1] == pytest.approx(0.5)


# ------------------------------------------------------------------ MAVLink

def test_mavlink_reports_the_vehicles_y_roll_and_yaw():
    """Real MAVLink over UDP from the firmware flying a beam sea: ATTITUDE, LOCAL_POSITION_NED,
    GLOBAL_POSITION_INT and VFR_HUD carry the lateral estimate, not zeros."""
    port = free_port()
    gs = GroundStation(f"udpin:127.0.0.1:{port}")
    sim = LiveSim(RunSpec("W3", "cpd_ff", seed=7, sea=BEAM, overrides={"FS_PILOT_INPUT": 0}),
                  mavlink=[f"udpout:127.0.0.1:{port}"], speedup=2.0)
    try:
        sim.start()
        assert gs.heartbeat(timeout=10.0) is not None
        fw = sim.firmware
        end = time.monotonic() + 10.0
        while not (fw.ekf.converged() and fw.lateral.estimating) and time.monotonic() < end:
            time.sleep(0.05)
        assert fw.request_mode(Mode.GUIDED) == 0 and fw.request_arm(True)[0] == 0
        time.sleep(3.0)
        by: dict[str, list] = {}
        for msg in gs.collect(3.0):
            by.setdefault(msg.get_type(), []).append(msg)
        att, lp = by["ATTITUDE"], by["LOCAL_POSITION_NED"]
        assert max(abs(m.roll) for m in att) > 1e-3 and max(abs(m.rollspeed) for m in att) > 1e-3
        assert any(m.yaw != 0.0 for m in att) and all(abs(m.yaw) < 0.2 for m in att)
        assert max(abs(m.y) for m in lp) > 1e-3 and max(abs(m.vy) for m in lp) > 1e-3
        gp = by["GLOBAL_POSITION_INT"][-1]
        assert 0 <= gp.hdg <= 35999 and gp.lon != round(fw.params["WK_ORIGIN_LON"] * 1e7)
        assert 0 <= by["VFR_HUD"][-1].heading <= 359
        last = fw.telemetry_snapshot()
        assert last.lateral and len(last.lateral) == 6
    finally:
        gs.close()
        sim.stop()


def test_a_lateral_estimate_that_stops_being_finite_starts_again():
    """A non-finite prediction (here a NaN thrust) restarts the lateral block from the next readings rather than
    raise in the control task; the next full frame initialises it again."""
    m = build_mission(RunSpec(case="W1", duration=5.0, sea=BEAM))
    take_off(m)
    fw = m.firmware
    ekf = fw.lateral.ekf
    assert ekf is not None and ekf.initialised
    ekf.predict(fw.ekf.x, np.full((3, 6), np.nan), None)
    assert not ekf.initialised and ekf.restarts == 1 and not fw.lateral.estimating
    for _ in range(3):
        fw.scheduler.run_tick()
        m.hal.step_world()
    assert ekf.initialised and np.isfinite(ekf.x).all()
    assert fw.fault_counts()["estimator"] == 1
