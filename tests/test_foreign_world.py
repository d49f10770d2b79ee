"""The world a foreign autopilot (real ArduSub SITL) needs, checked without the binary.

The vehicle boots at the surface and stays there until its thrusters run (an
autopilot that zeroes its depth at boot must boot where depth is 0); the water
is still until the sea starts, then the same sea from its t = 0; out of the
water a thruster pushes nothing; sway, roll and yaw move (against analytic
limits: a quadratic-damped terminal rate, the small-angle roll period), and the
JSON state is kinematically consistent; the plant steps at its own rate under
1200 Hz frames and answers the frames between by interpolation.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from bridge.json_sitl import decode_state, servo_packet
from bridge.schemas import load_vehicle_config
from sitl.physics_rate import PhysicsHold, plant_state_message
from sitl.physics_server import PhysicsServer
from sitl.plant import Plant
from sitl.sea import Sea

NEUTRAL = np.full(8, 1500.0)


@pytest.fixture(scope="module")
def sea():
    return Sea.load("W1")


def test_surface_start_holds_the_vehicle_until_the_thrusters_run(sea):
    plant = Plant.from_configs(sea, start="surface")
    for _ in range(100):                                   # 5 s of an idle autopilot booting
        plant.step(NEUTRAL, 0.05)
    assert plant.state.eta.tolist() == [0.0, 0.0, 0.0] and plant.state.t == pytest.approx(5.0)
    down = NEUTRAL.copy()
    down[4:] = 1700.0                                       # the verticals push down (+Z)
    for _ in range(40):
        plant.step(down, 0.05)
    assert not plant.moored and plant.state.eta[1] > 0.05


def test_thrust_fades_out_of_the_water(sea):
    """Pushing up at the surface, the vehicle settles where buoyancy and thrust, both fading as it breaches
    (the submerged fraction f), balance its weight: (B + F_up) f = W; it never leaves the water."""
    plant = Plant.from_configs(sea, start="surface", sea_start=1e6)
    up = NEUTRAL.copy()
    up[4:] = 1100.0                                         # the verticals push up, full: more than the weight
    f_up = -4 * float(plant.curve.thrust(np.array([1100.0]))[0])
    assert f_up > plant.vehicle.W                           # thrust that did not fade would lift it out for good
    depths = []
    for _ in range(600):
        plant.step(up, 0.05)
        depths.append(plant.state.eta[1])
    p = plant.vehicle
    frac = p.W / (p.B + f_up)
    assert min(depths) > -0.5 * p.height                    # never out of the water, let alone into the sky
    assert depths[-1] == pytest.approx((frac - 0.5) * p.height, abs=0.01)


def test_still_water_until_the_sea_starts_then_the_same_sea(sea):
    late = Plant.from_configs(sea, sea_start=30.0)
    now = Plant.from_configs(sea)
    eta, nu = np.array([0.0, 5.0, 0.0]), np.zeros(3)
    assert late.wave_load(eta, nu, 29.99).tolist() == [0.0, 0.0, 0.0]
    for tau in (0.0, 3.3, 17.0):
        np.testing.assert_allclose(late.wave_load(eta, nu, 30.0 + tau), now.wave_load(eta, nu, tau), rtol=1e-12,
                                   atol=1e-12)
    times = np.array([0.0, 29.99, 30.0, 33.3, 47.0])        # a series of times, as the load tests ask for
    series = late.wave_load(eta, nu, times)
    assert series.shape == (5, 3) and not series[:2].any()
    np.testing.assert_allclose(series[2:], now.wave_load(eta, nu, times[2:] - 30.0), rtol=1e-12, atol=1e-12)


def _six_dof(sea) -> Plant:
    plant = Plant.from_configs(sea, sea_start=1e6, dof="six")
    plant.reset(eta=np.array([0.0, 5.0, 0.0]))
    return plant


def test_yaw_reaches_the_quadratic_damping_terminal_rate(sea):
    """A steady yaw moment N against N_r|r| r|r| (N_r = 0): r → √(N / N_r|r|)."""
    plant = _six_dof(sea)
    pwm = NEUTRAL.copy()
    pwm[[0, 3]], pwm[[1, 2]] = 1650.0, 1350.0               # ArduSub's yaw factors: +m1 −m2 −m3 +m4
    n_cmd = float(plant.B6[5] @ plant.curve.thrust(pwm))
    for _ in range(600):
        plant.step(pwm, 0.05)
    lat = load_vehicle_config()["lateral"]
    r = plant.state.nu6[5]
    assert abs(n_cmd) > 1.0
    assert r == pytest.approx(math.copysign(math.sqrt(abs(n_cmd) / lat["N_rr"]), n_cmd), rel=0.02)


def test_roll_oscillates_at_the_hydrostatic_small_angle_period(sea):
    """Released at 2° the roll swings with T = 2π √((I_x + K_ṗ) / ((z_G W − z_B B))) (quadratic damping at that
    amplitude shortens it by well under 1 %)."""
    plant = _six_dof(sea)
    plant.reset(eta=np.array([0.0, 0.0, 5.0, math.radians(2.0), 0.0, 0.0]))
    phi, t = [], []
    for _ in range(4000):
        plant.step(NEUTRAL, 0.005)
        phi.append(plant.state.eta6[3])
        t.append(plant.state.t)
    phi, t = np.array(phi), np.array(t)
    up = t[1:][(phi[:-1] < 0) & (phi[1:] >= 0)]            # upward zero crossings
    cfg = load_vehicle_config()
    mp, lat = cfg["mass_properties"], cfg["lateral"]
    k = mp["r_G"][2] * mp["W"] - mp["r_B"][2] * mp["B"]
    period = 2 * math.pi * math.sqrt((lat["I_x"] + lat["K_pdot"]) / k)
    assert np.mean(np.diff(up)) == pytest.approx(period, rel=0.01)


def test_six_dof_state_is_kinematically_consistent(sea):
    """What the autopilot integrates agrees with what it is told: east position with east velocity, yaw with the
    gyro's r, and a level vehicle's accelerometer reads −g on z."""
    plant = _six_dof(sea)
    pwm = NEUTRAL.copy()
    pwm[[0, 2]], pwm[[1, 3]] = 1620.0, 1380.0               # lateral: +m1 −m2 +m3 −m4
    msgs = []
    for _ in range(400):
        plant.step(pwm, 0.005)
        msgs.append(plant_state_message(plant))
    t = np.array([m["timestamp"] for m in msgs])
    ve = np.array([m["velocity"][1] for m in msgs])
    y = np.array([m["position"][1] for m in msgs])
    r = np.array([m["imu"]["gyro"][2] for m in msgs])
    psi = np.array([m["attitude"][2] for m in msgs])
    assert abs(y[-1]) > 0.01
    assert y[-1] - y[0] == pytest.approx(np.trapezoid(ve, t), rel=1e-3)
    assert psi[-1] - psi[0] == pytest.approx(np.trapezoid(r, t), abs=1e-6)
    acc = msgs[-1]["imu"]["accel_body"]
    assert acc[2] == pytest.approx(-plant.vehicle.g, abs=0.05)


def test_plant_steps_at_its_own_rate_under_faster_frames(sea):
    """1200 Hz frames, a 200 Hz physics: one step per 6 frames under the frame's PWM that starts it, the replies
    in between interpolated, each on its own frame's time; the step boundaries are a 200 Hz plant's, bit for bit."""
    server = PhysicsServer(lambda: Plant.from_configs(sea), port=0, physics_rate_hz=200.0)
    reference = Plant.from_configs(sea)
    rng = np.random.default_rng(3)
    try:
        server.handle(servo_packet(1200, 0, [1500] * 8), ("127.0.0.1", 9))
        for count in range(1, 121):
            if count % 6 == 1:
                pwm = rng.integers(1300, 1700, 8).astype(float)
                reference.step(pwm, 6 / 1200)
            reply = decode_state(server.handle(servo_packet(1200, count, pwm.astype(int)), ("127.0.0.1", 9)))
            assert reply.timestamp == pytest.approx(count / 1200, abs=1e-12)
            if count % 6 == 0:
                assert reply.eta.tolist() == reference.state.eta.tolist()
        assert server.counters.steps == 20
    finally:
        server.close()


def test_one_frame_one_step_is_the_plain_lockstep(sea):
    hold = PhysicsHold(None)
    hold.start(20)
    a, b = Plant.from_configs(sea), Plant.from_configs(sea)
    pwm = np.array([1600, 1400, 1550, 1450, 1700, 1700, 1300, 1300], dtype=float)
    for _ in range(20):
        hold.frame(a, pwm, 20)
        b.step(pwm, 1.0 / 20)
        assert hold.message(a, 1) == plant_state_message(b, 1)
