"""The six-DoF world: its compiled step against the numpy models, the planar limit in a head sea, a beam sea,
a full wrench through the eight thrusters, the spread sea on its config path, and the JSON state it serves."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from bridge.configfile import ConfigError
from bridge.json_sitl import decode_state, servo_packet
from bridge.models.body6 import Body6
from bridge.models.directional_sea import directional_moments
from bridge.models.vehicle6_config import load_rigid_body6, rigid_body6_from_vehicle
from bridge.models.waves import elevation_xy
from bridge.schemas import load_vehicle_config
from sitl.harness.run import run_mission
from sitl.harness.spec import RunSpec
from sitl.physics_server import PhysicsServer
from sitl.plant import Plant, PlantDiverged
from sitl.sea import Sea, load_sea_config

NEUTRAL = np.full(8, 1500.0)


def test_the_plant_flies_the_sourced_six_dof_vehicle():
    """The six-DoF world builds its body from the planar vehicle config and its ``lateral`` section (so a true
    vehicle and the firmware's nominal one stay one file); for the shipped vehicle that is the sourced
    ``bluerov2_heavy_6dof.yaml`` value for value."""
    a, b = rigid_body6_from_vehicle(load_vehicle_config()), load_rigid_body6()
    for name in ("W", "B", "I_x", "I_y", "I_z", "length", "beam", "height", "X_qdot", "water_density"):
        assert getattr(a, name) == getattr(b, name), name
    for name in ("r_G", "r_B", "added_mass", "linear_damping", "quadratic_damping", "M"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name


@pytest.mark.parametrize("eta", [[1.3, -0.4, 5.0, 0.05, -0.08, 0.6],      # submerged: the separable grid
                                 [1.3, -0.4, 0.04, 0.05, -0.08, 0.6]])    # breaching: depths clipped, per point
def test_compiled_six_dof_step_matches_the_numpy_reference(eta):
    """Flow, load, rates and one RK4 step of the compiled body against :mod:`bridge.models.strip_load6` and
    :mod:`bridge.models.motion6` (the reference), in a spread sea from 40° with a current, to 1e-12 of scale."""
    sea = Sea.load("W3", overrides={"spreading.s": 10.0, "spreading.direction": 40.0})
    p = load_rigid_body6()
    fast, ref = Body6(p, compiled=True), Body6(p, compiled=False)
    eta = np.array(eta)
    nu = np.array([0.2, -0.1, 0.3, 0.05, -0.1, 0.2])
    x, t, cur = np.concatenate([eta, nu]), 17.0 + np.array([0.0, 0.025, 0.05]), np.array([0.1, 0.2, 0.0])
    ff, fr = fast.flow(sea.components, eta, t, cur), ref.flow(sea.components, eta, t, cur)
    for a, b in ((ff.vel, fr.vel), (ff.acc, fr.acc)):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-12 * np.abs(b).max())
    tau = np.random.default_rng(2).normal(0.0, 20.0, (3, 6))
    for flow_f, flow_r in ((ff, fr), (None, None)):
        for got, want in ((fast.load(nu, flow_f, 2), ref.load(nu, flow_r, 2)),
                          (fast.rates(x, tau[0], flow_f, 1), ref.rates(x, tau[0], flow_r, 1)),
                          (fast.rk4(x, 0.05, tau, flow_f), ref.rk4(x, 0.05, tau, flow_r))):
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-12 * max(1.0, np.abs(want).max()))


def test_a_head_long_crested_sea_gives_the_planar_world():
    """The acceptance of the planar limit: W3, same seed, 90 s of C-PD+FF: the six-DoF world's x, z, θ RMSE
    within 15 % of the planar world's, with the firmware holding sway, roll and heading on noisy sensors
    (measured: 1.06, 1.15, 1.04): y within 2 cm, roll and yaw RMSE within 0.2° (measured 0.11° and 0.14°; their
    maxima, 0.4° and 0.5°, are the loops' answer to the AHRS's 0.3° and 0.6° noise). The planar world has no
    lateral motion at all."""
    runs = {dof: run_mission(RunSpec(case="W3", controller="cpd_ff", duration=90.0, sea={"dof": dof})).results
            for dof in ("planar", "six")}
    planar, six = runs["planar"]["six_dof"], runs["six"]["six_dof"]
    assert planar["world_dof"] == "planar" and six["world_dof"] == "six"
    for k in ("x", "z", "pitch"):
        assert six["rmse"][k] == pytest.approx(planar["rmse"][k], rel=0.15), k
    assert six["max_abs_error"]["y"] <= 0.02
    assert max(six["rmse"]["roll"], six["rmse"]["yaw"]) <= math.radians(0.2)
    assert planar["max_abs_error"]["y"] == planar["max_abs_error"]["yaw"] == 0.0


def _unpowered(direction: float, seconds: float = 40.0) -> np.ndarray:
    """An unpowered vehicle at 12 m in a long-crested W3 travelling towards ``direction`` (deg): its η (T, 6)."""
    plant = Plant.from_configs(Sea.load("W3", overrides={"spreading.direction": direction, "dof": "six"}))
    plant.reset(eta=[0.0, 12.0, 0.0])
    rows = []
    for _ in range(int(seconds * 20)):
        plant.step(NEUTRAL, 0.05)
        rows.append(plant.state.eta6.copy())
    return np.array(rows)


def test_a_beam_sea_sways_and_rolls_the_vehicle_and_leaves_surge_and_pitch_alone():
    """Waves towards +y (90°): the vehicle sways with the orbital flow as it surges in the head sea (their
    excursions within 35 %: sway and surge differ in added mass and damping) and rolls; by the body's fore–aft
    symmetry nothing pushes it along x or pitches it (a long-crested sea's surge there is nil)."""
    beam, head = _unpowered(90.0), _unpowered(0.0)
    assert np.ptp(beam[:, 1]) == pytest.approx(np.ptp(head[:, 0]), rel=0.35)
    assert np.std(beam[:, 3]) > math.radians(0.3)               # roll
    assert np.abs(beam[:, 0]).max() < 1e-6 and np.abs(beam[:, 4]).max() < 1e-6   # x, pitch
    assert np.abs(head[:, [1, 3, 5]]).max() < 1e-9             # and the head sea loads nothing out of its plane


def test_a_full_wrench_through_the_eight_thrusters_reaches_the_plant():
    """A wrench in all six DoF, allocated over the Heavy's eight T200s by the 6 × 8 matrix's pseudo-inverse and
    sent as whole-µs PWM in servo packets: once the motor lag settles the plant's thruster load is that wrench
    (to the PWM's 1 µs quantisation)."""
    server = PhysicsServer(lambda: Plant.from_configs(Sea.still_water(), dof="six"), port=0)
    try:
        server.handle(servo_packet(20, 0, [1500] * 8), ("127.0.0.1", 9))
        plant = server.plant
        wrench = np.array([12.0, -8.0, 15.0, 1.2, -0.9, 1.5])           # N, N m
        f = np.linalg.pinv(plant.B6) @ wrench
        assert np.abs(f).max() < 30.0 and np.count_nonzero(np.abs(f) > 0.4) == 8      # every thruster works
        pwm = np.rint(plant.curve.pwm(f)).astype(int)
        for k in range(1, 41):                                           # 2 s: 20 motor time constants
            server.handle(servo_packet(20, k, pwm), ("127.0.0.1", 9))
        np.testing.assert_allclose(server.plant.tau6, plant.B6 @ plant.curve.thrust(pwm.astype(float)), rtol=1e-6)
        np.testing.assert_allclose(server.plant.tau6, wrench, rtol=0.03, atol=0.05)
    finally:
        server.close()


def test_the_sea_configs_spread_is_the_input_s():
    """The spreading oracle on the config path: W2 with 4096 components spread by s = 10 about −120°: the
    realised first moment s/(s + 1) within 4 standard errors, the mean direction within 3°."""
    s, mean = 10.0, -120.0
    sea = Sea.load("W2", overrides={"spreading.s": s, "spreading.direction": mean, "components": 4096})
    mom = directional_moments(sea.components)
    m1 = s / (s + 1)
    m2 = s * (s - 1) / ((s + 1) * (s + 2))                     # E cos 2(θ − θ_p) of cos-2s
    assert abs(mom.r1 - m1) < 4 * math.sqrt(((1 + m2) / 2 - m1**2) / mom.n_eff)
    assert abs(math.degrees(mom.mean) - mean) < 3.0
    long_crested = Sea.load("W2", overrides={"spreading.direction": 135.0})
    assert np.all(long_crested.components.direction == math.radians(135.0))
    assert Sea.load("W2").components.direction is None         # along north: the planar sea, bit for bit


def test_the_buoy_sits_up_wave_on_the_mean_direction():
    sea = Sea.load("W3", overrides={"spreading.direction": 90.0})
    buoy = sea.buoy()
    t = np.arange(0.0, 20.0, 0.5)
    np.testing.assert_allclose(buoy.record(0.0, 19.9)[1], elevation_xy(sea.components, 0.0, -50.0, t), atol=1e-12)


def test_dof_and_direction_are_validated_on_load(tmp_path):
    with pytest.raises(ConfigError, match=r"dof"):
        load_sea_config("W3", {"dof": "five"})
    with pytest.raises(ConfigError, match=r"spreading\.direction.*180"):
        load_sea_config("W3", {"spreading.direction": 200.0})
    assert load_sea_config("W3")["dof"] == "six" and load_sea_config("W3", {"dof": "auto"})["dof"] == "auto"


@pytest.mark.parametrize("overrides, world", [({}, "planar"), ({"spreading.direction": 90.0}, "six"),
                                               ({"spreading.s": 10.0}, "six"), ({"current.speed": 0.2}, "planar"),
                                               ({"current.speed": 0.2, "current.direction": 30.0}, "six")])
def test_auto_is_the_plane_for_a_sea_in_it_and_six_dof_otherwise(overrides, world):
    sea = Sea.load("W1", overrides={"dof": "auto", **overrides})
    assert sea.dof == world and Plant.from_configs(sea).dof == world


@pytest.mark.parametrize("overrides, world", [({}, "six"), ({"dof": "planar", "spreading.s": 10.0}, "planar"),
                                               ({"dof": "planar"}, "planar")])
def test_six_dof_is_the_default_and_planar_the_papers_named_world(overrides, world):
    sea = Sea.load("W1", overrides=overrides)
    assert sea.dof == world and Plant.from_configs(sea).dof == world


def test_the_divergence_guard_covers_all_six_dof():
    plant = Plant.from_configs(Sea.still_water(), dof="six")
    plant.reset(eta=[0.0, 0.0, 5.0, 0.0, 0.0, 0.0], nu=[0.0, 0.0, 0.0, 25.0, 0.0, 0.0])
    with pytest.raises(PlantDiverged, match=r"p \d+.*20 rad/s"):
        plant.step(NEUTRAL, 0.05)


def test_the_json_state_carries_y_roll_and_yaw_in_an_oblique_sea():
    """Served over the JSON SITL protocol in a short-crested sea from 45°, the state ArduPilot parses has the
    plant's east position, roll and yaw, their rates and the sway velocity, none of them zero; Wavekeep's own
    planar fields stay [x, z, θ], [u, w, q]."""
    sea = Sea.load("W3", overrides={"spreading.s": 10.0, "spreading.direction": 45.0})
    server = PhysicsServer(lambda: Plant.from_configs(sea), port=0)
    try:
        for k in range(200):                                              # 10 s at 20 Hz
            reply = server.handle(servo_packet(20, k, [1500] * 8), ("127.0.0.1", 9))
        s = server.plant.state
        msg = json.loads(reply)
        assert msg["position"] == s.eta6[:3].tolist() and msg["attitude"] == s.eta6[3:].tolist()
        assert msg["imu"]["gyro"] == s.nu6[3:].tolist()
        for value in (msg["position"][1], msg["attitude"][0], msg["attitude"][2], msg["imu"]["gyro"][0],
                      msg["imu"]["gyro"][2], msg["velocity"][1], msg["imu"]["accel_body"][1]):
            assert abs(value) > 1e-4
        planar = decode_state(reply)
        assert planar.eta.tolist() == s.eta.tolist() and planar.nu.tolist() == s.nu.tolist()
    finally:
        server.close()
