"""Modes, arming, pilot input, motor test and the GCS failsafe, driven through the firmware's API."""
from __future__ import annotations

import numpy as np
import pytest

from firmware_py.modes import MAV_RESULT, MAV_STATE, Mode
from firmware_py.params.table import load_params
from sitl.harness.run import build_mission
from sitl.harness.spec import RunSpec
from sitl.harness.thrust import csv_profile, pattern_profile


def tick(m, n: int = 1):
    for _ in range(n):
        m.firmware.scheduler.run_tick()
        m.hal.step_world()


@pytest.fixture
def mission():
    return build_mission(RunSpec("W1", "cpd_ff", duration=10.0), params=load_params())


def test_boots_disarmed_in_manual_with_neutral_thrusters(mission):
    fw = mission.firmware
    assert fw.mode == Mode.MANUAL and not fw.armed and fw.system_status() == MAV_STATE.BOOT
    tick(mission, 5)
    assert mission.hal.last_pwm.tolist() == [1500] * 8
    assert fw.system_status() == MAV_STATE.STANDBY


def test_prearm_checks_and_force(mission):
    fw = mission.firmware
    result, why = fw.request_arm(True)                 # before the first tick: no estimate yet
    assert result == MAV_RESULT.FAILED and why
    assert fw.request_arm(True, force=True)[0] == MAV_RESULT.ACCEPTED and fw.armed
    assert fw.request_arm(False)[0] == MAV_RESULT.ACCEPTED and not fw.armed
    tick(mission)
    assert fw.request_arm(True)[0] == MAV_RESULT.ACCEPTED
    assert fw.system_status() == MAV_STATE.ACTIVE
    assert any(text == "Arming motors" for _, text in fw.events)        # ArduSub's words


def test_unknown_mode_is_refused_and_the_mode_kept(mission):
    fw = mission.firmware
    tick(mission)
    for bad in (3, 42, -1, Mode.MOTOR_DETECT):
        assert fw.request_mode(bad) == MAV_RESULT.FAILED
        assert fw.mode == Mode.MANUAL
    assert fw.request_mode(Mode.POSHOLD) == MAV_RESULT.ACCEPTED and fw.mode == Mode.POSHOLD
    np.testing.assert_allclose(fw.setpoint[:2], fw.ekf.x[:2])    # holds where it was entered


def test_guided_target_only_in_guided(mission):
    fw = mission.firmware
    tick(mission)
    assert fw.set_target(1.0, 6.0) == MAV_RESULT.DENIED
    fw.request_mode(Mode.GUIDED)
    assert fw.set_target(1.0, 6.0) == MAV_RESULT.ACCEPTED
    assert fw.setpoint[:2].tolist() == [1.0, 6.0]
    assert fw.set_target(float("nan"), 6.0) == MAV_RESULT.DENIED and fw.setpoint[0] == 1.0


def test_manual_pilot_input_goes_to_the_thrusters_and_times_out(mission):
    fw = mission.firmware
    tick(mission)
    fw.request_arm(True)
    fw.pilot_input(0.5, 0.0, 0.0)
    tick(mission)
    pwm = mission.hal.last_pwm
    assert np.any(pwm[:4] != 1500)                       # horizontal thrusters push forward
    surge = mission.firmware.mixer.B @ mission.firmware.mixer.curve.thrust(pwm)
    assert surge[0] > 10.0
    tick(mission, int(fw.params["WK_PILOT_TMO"] * 20) + 5)   # no more input: sticks neutral
    assert np.all(np.abs(fw.last.mix.thrust_demand) < 1e-9)


def test_motor_test_is_armed_only_and_times_out(mission):
    fw = mission.firmware
    tick(mission)
    assert fw.motor_test(3, 1700, 0.5) == MAV_RESULT.DENIED
    fw.request_arm(True)
    assert fw.motor_test(9, 1700, 0.5) == MAV_RESULT.DENIED
    assert fw.motor_test(3, 1700, 2.0) == MAV_RESULT.ACCEPTED
    tick(mission)
    assert mission.hal.last_pwm.tolist() == [1500, 1500, 1700, 1500, 1500, 1500, 1500, 1500]
    tick(mission, 12)                                    # > 0.5 s without a re-send
    assert mission.hal.last_pwm.tolist() == [1500] * 8


@pytest.mark.parametrize("action, expect", [(1, "warn"), (2, "disarm"), (3, Mode.ALT_HOLD), (4, Mode.SURFACE)])
def test_gcs_failsafe_actions(mission, action, expect):
    fw = mission.firmware
    fw.params.set("FS_GCS_ENABLE", action)
    fw.params.set("FS_GCS_TIMEOUT", 1.0)
    tick(mission)
    fw.request_mode(Mode.POSHOLD)
    fw.request_arm(True)
    tick(mission, 40)                                    # no GCS seen yet: no failsafe
    assert not fw.failsafe_gcs
    fw.gcs_heartbeat()
    tick(mission, 10)
    assert not fw.failsafe_gcs
    tick(mission, 20)                                    # 1.5 s of silence
    assert fw.failsafe_gcs and fw.system_status() in (MAV_STATE.CRITICAL, MAV_STATE.STANDBY)
    if expect == "disarm":
        assert not fw.armed
    elif expect == "warn":
        assert fw.armed and fw.mode == Mode.POSHOLD
    else:
        assert fw.armed and fw.mode == expect
    fw.gcs_heartbeat()
    assert not fw.failsafe_gcs


def test_surface_mode_rises(mission):
    fw = mission.firmware
    tick(mission)
    fw.request_arm(True)
    fw.request_mode(Mode.SURFACE)
    z0 = mission.plant.state.eta[1]
    tick(mission, 200)
    assert mission.plant.state.eta[1] < z0 - 1.5


def test_thrust_profiles(tmp_path):
    p = pattern_profile("step", "heave", 0.3, 3.0)
    assert p.at(0.5).tolist() == [0, 0, 0] and p.at(2.0).tolist() == [0, 0.3, 0]
    s = pattern_profile("sine", "pitch", 0.5, 8.0, period=4.0)
    assert np.abs(s.demand[:, 2]).max() == pytest.approx(0.5, rel=1e-3)
    f = tmp_path / "demands.csv"
    f.write_text("t,surge,heave,pitch\n0,0.1,0,0\n1,0.2,-0.1,0\n")
    c = csv_profile(f)
    assert c.at(0.5).tolist() == [0.1, 0, 0] and c.at(1.5).tolist() == [0.2, -0.1, 0]
    f.write_text("t,surge,heave,pitch\n0,0.1,0,0\n1,abc,0,0\n")
    with pytest.raises(ValueError, match="line 3"):
        csv_profile(f)
    with pytest.raises(ValueError):
        pattern_profile("zigzag", "surge", 1, 1)


def test_lost_position_fix_grows_the_covariance_honestly_and_trips_the_ekf_failsafe(mission):
    """No position fix: the EKF's position 1-σ grows; once its test ratio (σ / WK_EKF_SD_BAD) has stayed at
    FS_EKF_THRESH or above for 2 s the failsafe says "EKF bad" and, with FS_EKF_ACTION 2, disarms (ArduSub's
    failsafe_ekf_check); when fixes return it clears."""
    from dataclasses import replace as dc_replace

    fw, hal = mission.firmware, mission.hal
    fw.params.set("FS_EKF_ACTION", 2)
    fw.params.set("FS_EKF_THRESH", 0.12)                     # x WK_EKF_SD_BAD 2.5 m: a 0.3 m 1-sigma
    tick(mission)
    fw.request_mode(Mode.POSHOLD)
    fw.request_arm(True)
    tick(mission, 20)
    read = hal.read_sensors
    # the position fix and the DVL (DVL-aided navigation) both lost: with the DVL the position drifts slowly
    hal.read_sensors = lambda: dc_replace(read(), x=float("nan"), dvl_u=float("nan"), dvl_w=float("nan"))
    sigmas, bad_at = [], None
    for _ in range(800):
        tick(mission)
        sigmas.append(fw.ekf.sigma()[0])
        if bad_at is None and sigmas[-1] / fw.params["WK_EKF_SD_BAD"] >= fw.params["FS_EKF_THRESH"]:
            bad_at = len(sigmas)
        if fw.failsafe_ekf:
            break
    assert fw.failsafe_ekf and not fw.armed and fw.system_status() == MAV_STATE.CRITICAL
    assert bad_at is not None and len(sigmas) - bad_at >= 2.0 * mission.rate_hz - 1      # bad for 2 s first
    assert sigmas[-1] > 5 * sigmas[0]                            # grows without a fix
    assert [text for _, text in fw.events].count("EKF bad") == 1
    hal.read_sensors = read
    tick(mission, 5)
    assert not fw.failsafe_ekf and fw.ekf.sigma()[0] < 0.1
