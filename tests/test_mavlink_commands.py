"""Inbound messages and commands against a live vehicle: modes, arming, pilot input, motor test, targets, failsafe."""
from __future__ import annotations

import math
import os
import time

import pytest

os.environ["MAVLINK20"] = "1"
# fixtures, one live vehicle per module
from mavlink_gcs import POS_ONLY, servos
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from firmware_py.modes import MAV_RESULT, Mode


def test_unknown_commands_and_wrong_targets(v, fast_heartbeat):
    gs = v.gs
    assert gs.command(31337, 1, 2, 3).result == MAV_RESULT.UNSUPPORTED
    assert gs.command(31337, use_int=True).result == MAV_RESULT.UNSUPPORTED
    # COMMAND_INT carries the same commands
    assert gs.command(mavlink.MAV_CMD_DO_SET_MODE, 1, Mode.STABILIZE, use_int=True).result == 0
    assert gs.heartbeat(lambda m: m.custom_mode == Mode.STABILIZE) is not None
    # Addressed to another system: ignored (no ACK, no effect) and counted
    before = v.link.counters["rx_wrong_target"]
    assert gs.command(mavlink.MAV_CMD_DO_SET_MODE, 1, Mode.MANUAL, target=7, timeout=1.5) is None
    gs.send(mavlink.MAVLink_param_set_message(9, 1, b"WK_FF_GAIN", 0.25, mavlink.MAV_PARAM_TYPE_REAL32))
    gs.send(mavlink.MAVLink_manual_control_message(0, 1000, 0, 500, 0, 0))   # sticks must name the vehicle
    time.sleep(0.5)
    assert v.fw.mode == Mode.STABILIZE and v.fw.params["WK_FF_GAIN"] == 1.0
    assert v.link.counters["rx_wrong_target"] >= before + 3
    # Broadcast (target 0) is accepted where allowed
    assert gs.command(mavlink.MAV_CMD_DO_SET_MODE, 1, Mode.MANUAL, target=0).result == 0


# --------------------------------------------------------------------------- modes and arming

def test_mode_switches_and_unknown_mode(v, fast_heartbeat):
    gs = v.gs
    gs.drain()
    since = gs.mark()
    gs.send(mavlink.MAVLink_set_mode_message(1, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, Mode.STABILIZE))
    assert gs.heartbeat(lambda m: m.custom_mode == Mode.STABILIZE).base_mode == 81
    assert gs.command(mavlink.MAV_CMD_DO_SET_MODE, 1, Mode.POSHOLD).result == MAV_RESULT.ACCEPTED
    assert gs.heartbeat(lambda m: m.custom_mode == Mode.POSHOLD).base_mode == 89     # GUIDED_ENABLED
    # ArduSub 4.7: no COMMAND_ACK for SET_MODE, and no STATUSTEXT for a mode that was entered
    gs.collect(0.3)
    assert not [m for m in gs.log[since:] if m.get_type() == "STATUSTEXT" or (m.get_type() == "COMMAND_ACK"
                                                                              and m.command == 11)]
    for bad, text in ((Mode.AUTO, "Flight mode change failed AUTO"), (42, "No such mode 42"),
                      (Mode.MOTOR_DETECT, "Flight mode change failed MOTOR_DETECT")):
        since = gs.mark()
        assert gs.command(mavlink.MAV_CMD_DO_SET_MODE, 1, bad).result == MAV_RESULT.FAILED
        said = gs.wait_type("STATUSTEXT", lambda m, text=text: m.text == text, timeout=2.0, since=since)
        assert said is not None and said.severity == mavlink.MAV_SEVERITY_WARNING
    since = gs.mark()
    gs.send(mavlink.MAVLink_set_mode_message(1, 1, 77))
    assert gs.wait_type("STATUSTEXT", lambda m: m.text == "No such mode 77", timeout=2.0, since=since)
    assert gs.heartbeat().custom_mode == Mode.POSHOLD and v.fw.mode == Mode.POSHOLD
    # Without the custom-mode flag ArduPilot's base modes are refused (ArduSub: DENIED)
    assert gs.command(mavlink.MAV_CMD_DO_SET_MODE, 0, Mode.MANUAL).result == MAV_RESULT.DENIED
    assert gs.command(mavlink.MAV_CMD_DO_SET_MODE, 1, Mode.MANUAL).result == MAV_RESULT.ACCEPTED


def test_arming_prearm_failure_then_force_then_success(v, fast_heartbeat):
    gs = v.gs
    assert gs.set_param("ARMING_CHECK", 1).param_value == 1.0     # all checks (ArduSub's 448 has no INS check)
    assert gs.set_param("WK_EKF_CONV", 1e-4).param_value == pytest.approx(1e-4)   # nothing converges to that
    assert v.fw.params["WK_EKF_CONV"] == 1e-4                                        # the float32 tidied
    since = gs.mark()
    ack = gs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    assert ack.result == MAV_RESULT.FAILED
    assert gs.wait_type("STATUSTEXT", lambda m: m.text == "Arm: AHRS not healthy", timeout=2.0, since=since)
    assert not gs.heartbeat().base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED
    assert gs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1, 21196).result == MAV_RESULT.ACCEPTED
    assert gs.heartbeat(lambda m: m.base_mode == 209) is not None
    assert gs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0).result == MAV_RESULT.ACCEPTED
    assert gs.heartbeat(lambda m: m.base_mode == 81) is not None
    gs.set_param("WK_EKF_CONV", 0.3)
    assert gs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == MAV_RESULT.ACCEPTED
    hb = gs.heartbeat(lambda m: m.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
    assert hb.base_mode == 209 and hb.system_status == mavlink.MAV_STATE_ACTIVE
    assert gs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 2).result == MAV_RESULT.UNSUPPORTED
    assert gs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0).result == MAV_RESULT.ACCEPTED


# --------------------------------------------------------------------------- pilot input and outputs

def test_disarmed_neutral_then_manual_control_and_rc_override_move_the_servos(v, fast_servo):
    gs = v.gs
    gs.send(mavlink.MAVLink_manual_control_message(1, 800, 0, 900, 0, 0))
    time.sleep(0.3)
    gs.drain()
    assert all(servos(m) == [1500] * 8 for m in gs.collect(0.5) if m.get_type() == "SERVO_OUTPUT_RAW")
    assert gs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == 0
    # Forward stick in MANUAL: the four horizontal thrusters (1-4) push
    for _ in range(15):
        gs.send(mavlink.MAVLink_manual_control_message(1, 600, 0, 500, 0, 0))
        time.sleep(0.1)
    out = [m for m in gs.collect(0.6) if m.get_type() in ("SERVO_OUTPUT_RAW", "RC_CHANNELS")]   # RC at 2 Hz
    s = [servos(m) for m in out if m.get_type() == "SERVO_OUTPUT_RAW"][-1]
    assert all(abs(p - 1500) > 50 for p in s[:4]) and all(abs(p - 1500) < 30 for p in s[4:])
    rc = [m for m in out if m.get_type() == "RC_CHANNELS"]
    assert rc and rc[-1].chan5_raw == 1620 and rc[-1].chan3_raw == 1500     # 1500 + 400 × 0.6 × gain 0.5
    # RC override in ArduSub's channel order: 3 throttle up → the vertical thrusters (5-8)
    for _ in range(15):
        gs.send(mavlink.MAVLink_rc_channels_override_message(1, 1, 1500, 65535, 1800, 65535, 1500, 65535, 0, 0))
        time.sleep(0.1)
    s = servos(gs.wait_type("SERVO_OUTPUT_RAW", since=gs.mark()))
    assert all(abs(p - 1500) > 50 for p in s[4:]) and all(abs(p - 1500) < 30 for p in s[:4])
    assert gs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0).result == 0
    assert gs.wait_type("SERVO_OUTPUT_RAW", lambda m: servos(m) == [1500] * 8, timeout=2.0) is not None


def test_motor_test_armed_only_and_times_out(v, fast_servo):
    gs = v.gs
    motor_test = mavlink.MAV_CMD_DO_MOTOR_TEST
    since = gs.mark()                           # disarmed: FAILED, in ArduSub's words
    assert gs.command(motor_test, 1, mavlink.MOTOR_TEST_THROTTLE_PWM, 1700, 1).result == MAV_RESULT.FAILED
    assert gs.wait_type("STATUSTEXT", lambda m: m.text == "Arm motors before testing motors.", 2.0, since=since)
    assert gs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == 0
    for _ in range(6):                         # the GCS re-sends at >= 2 Hz
        assert gs.command(motor_test, 3, mavlink.MOTOR_TEST_THROTTLE_PWM, 1700, 1).result == 0
        time.sleep(0.2)
    s = servos(gs.wait_type("SERVO_OUTPUT_RAW", since=gs.mark()))
    assert s[2] == 1700 and s[:2] + s[3:] == [1500] * 7
    # 0.5 s after the last command the motor stops
    assert gs.wait_type("SERVO_OUTPUT_RAW", lambda m: servos(m) == [1500] * 8, timeout=2.0) is not None
    # percent of the ESC range: 75 % → 1700 µs
    assert gs.command(motor_test, 2, mavlink.MOTOR_TEST_THROTTLE_PERCENT, 75, 1).result == 0
    assert gs.wait_type("SERVO_OUTPUT_RAW", lambda m: m.servo2_raw == 1700, timeout=1.0) is not None
    assert gs.command(motor_test, 9, 1, 1700, 1).result == MAV_RESULT.DENIED
    assert gs.command(motor_test, 1, mavlink.MOTOR_TEST_THROTTLE_PILOT, 0, 1).result == MAV_RESULT.FAILED


def test_position_target_only_in_guided(v, fast_heartbeat):
    gs = v.gs
    x0, z0 = v.fw.last.x_hat[:2]
    ignored = v.link.counters["rx_ignored"]
    sp = v.fw.setpoint.copy()
    gs.send(mavlink.MAVLink_set_position_target_local_ned_message(0, 1, 1, mavlink.MAV_FRAME_LOCAL_NED, POS_ONLY,
                                                                  x0 + 1, 0, z0 + 1, 0, 0, 0, 0, 0, 0, 0, 0))
    time.sleep(0.4)
    assert (v.fw.setpoint == sp).all() and v.link.counters["rx_ignored"] == ignored + 1   # MANUAL: ignored
    assert gs.command(mavlink.MAV_CMD_DO_SET_MODE, 1, Mode.GUIDED).result == 0
    assert gs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == 0
    target = (float(x0) + 0.3, float(z0) + 0.4)
    gs.send(mavlink.MAVLink_set_position_target_local_ned_message(0, 1, 1, mavlink.MAV_FRAME_LOCAL_NED, POS_ONLY,
                                                                  target[0], 0, target[1], 0, 0, 0, 0, 0, 0, 0, 0))
    end = time.monotonic() + 3
    while time.monotonic() < end and abs(v.fw.setpoint[1] - target[1]) > 1e-4:
        time.sleep(0.05)
    assert v.fw.setpoint[:2].tolist() == pytest.approx(list(target), abs=1e-4)
    # The vehicle goes there: LOCAL_POSITION_NED (at 10 Hz here) settles near the new target
    gs.send(mavlink.MAVLink_request_data_stream_message(1, 1, mavlink.MAV_DATA_STREAM_POSITION, 10, 1))
    since, end, z = gs.mark(), time.monotonic() + 10, []
    while time.monotonic() < end:
        lp = gs.wait_type("LOCAL_POSITION_NED", timeout=1.0, since=since)
        since = gs.log.index(lp) + 1 if lp is not None else len(gs.log)
        z = ([*z, lp.z] if lp is not None else z)[-10:]
        if len(z) == 10 and abs(sum(z) / 10 - target[1]) < 0.1:
            break
    assert len(z) == 10 and abs(sum(z) / 10 - target[1]) < 0.1, z
    # Position-ignore bits are honoured: x ignored, depth moves
    gs.send(mavlink.MAVLink_set_position_target_local_ned_message(0, 1, 1, mavlink.MAV_FRAME_LOCAL_NED,
                                                                  POS_ONLY | 1, 99, 0, 5.2, 0, 0, 0, 0, 0, 0, 0, 0))
    time.sleep(0.4)
    assert v.fw.setpoint[:2].tolist() == pytest.approx([target[0], 5.2], abs=1e-4)
    # Velocity-only targets are not supported, NaN positions are refused: both counted, target kept
    before = v.link.counters["rx_ignored"]
    gs.send(mavlink.MAVLink_set_position_target_local_ned_message(0, 1, 1, mavlink.MAV_FRAME_LOCAL_NED,
                                                                  0b110111000111, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0))
    gs.send(mavlink.MAVLink_set_position_target_local_ned_message(0, 1, 1, mavlink.MAV_FRAME_LOCAL_NED, POS_ONLY,
                                                                  math.nan, 0, 5.0, 0, 0, 0, 0, 0, 0, 0, 0))
    time.sleep(0.4)
    assert v.link.counters["rx_ignored"] == before + 2
    assert v.fw.setpoint[:2].tolist() == pytest.approx([target[0], 5.2], abs=1e-4)

# --------------------------------------------------------------------------- failsafe

def test_gcs_failsafe_disarms_after_silence(v, fast_heartbeat):
    gs = v.gs
    # 2 s against the GCS's 1 Hz heartbeats: a 1 s timeout left no margin for a late beat on a loaded machine
    assert gs.set_param("FS_GCS_TIMEOUT", 2.0).param_value == 2.0
    assert gs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == 0
    time.sleep(2.6)                                     # heartbeats keep it armed past the timeout
    assert v.fw.armed
    gs.heartbeats(False)
    gs.send(mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0, 3))
    t0, since = time.monotonic(), gs.mark()                # the last heartbeat: now (not up to 1 s ago)
    # ArduSub's words: the disarm, and "MYGCS: 255, heartbeat lost" (WARNING) once 30 s of vehicle time have
    # passed since boot (its warning clock starts at boot), then every 30 s
    assert gs.wait_type("STATUSTEXT", lambda m: m.text == "Disarming motors", timeout=8.0, since=since) is not None
    hb = gs.heartbeat(lambda m: not m.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED, timeout=3.0)
    assert hb is not None and hb.system_status == mavlink.MAV_STATE_CRITICAL
    assert 1.8 < time.monotonic() - t0 < 7.0
    if v.fw.last.t > 32.0:
        lost = gs.wait_type("STATUSTEXT", lambda m: m.text == "MYGCS: 255, heartbeat lost", timeout=1.0, since=since)
        assert lost is not None and lost.severity == mavlink.MAV_SEVERITY_WARNING
    since = gs.mark()
    gs.heartbeats(True)
    cleared = gs.wait_type("STATUSTEXT", lambda m: m.text == "GCS Failsafe Cleared", timeout=4.0, since=since)
    assert cleared is not None and cleared.severity == mavlink.MAV_SEVERITY_WARNING
    assert gs.heartbeat(lambda m: m.system_status == mavlink.MAV_STATE_STANDBY) is not None


def test_home_position_origin_and_do_set_home(v):
    gs, p = v.gs, v.fw.params
    lat0, lon0 = p["WK_ORIGIN_LAT"], p["WK_ORIGIN_LON"]
    try:
        # Asked for by id, or with GET_HOME_POSITION (both messages follow its ACK)
        assert gs.command(mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_HOME_POSITION).result == 0
        home = gs.wait_type("HOME_POSITION", timeout=3.0)
        assert (home.latitude, home.longitude, home.altitude) == (round(lat0 * 1e7), round(lon0 * 1e7), 0)
        assert (home.x, home.y, home.z) == (0.0, 0.0, 0.0) and all(math.isnan(q) for q in home.q)   # q unknown
        assert gs.command(mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN).result == 0
        origin = gs.wait_type("GPS_GLOBAL_ORIGIN", timeout=3.0)
        assert (origin.latitude, origin.longitude, origin.altitude) == (round(lat0 * 1e7), round(lon0 * 1e7), 0)
        since = gs.mark()
        assert gs.command(mavlink.MAV_CMD_GET_HOME_POSITION).result == MAV_RESULT.ACCEPTED
        assert gs.wait_type("HOME_POSITION", timeout=3.0, since=since) is not None
        assert gs.wait_type("GPS_GLOBAL_ORIGIN", timeout=3.0, since=since) is not None
        # DO_SET_HOME with a position (p1 0): home moves, the origin does not
        since = gs.mark()
        assert gs.command(mavlink.MAV_CMD_DO_SET_HOME, 0, 0, 0, 0, lat0 + 1e-4, lon0, -2.0).result == 0
        home = gs.wait_type("HOME_POSITION", timeout=3.0, since=since)
        assert home.latitude == pytest.approx((lat0 + 1e-4) * 1e7, abs=20) and home.altitude == -2000   # float32 p5
        assert home.x == pytest.approx(math.radians(1e-4) * 6378137.0, abs=0.3) and home.z == pytest.approx(2.0)
        gs.send(mavlink.MAVLink_mission_request_int_message(1, 1, 0, 0))          # mission item 0 is home
        assert gs.wait_type("MISSION_ITEM_INT", timeout=3.0).x == home.latitude
        # COMMAND_INT carries degE7; p1 1: the current position (north of the origin by the estimate)
        since = gs.mark()
        assert gs.command(mavlink.MAV_CMD_DO_SET_HOME, 0, 0, 0, 0, round(lat0 * 1e7), round(lon0 * 1e7), 0,
                          use_int=True).result == 0
        # its HOME_POSITION follows the ACK: take it before asking again, so it is not mistaken for the next
        assert gs.wait_type("HOME_POSITION", timeout=3.0, since=since).x == pytest.approx(0.0, abs=1e-6)
        since = gs.mark()
        assert gs.command(mavlink.MAV_CMD_DO_SET_HOME, 1).result == MAV_RESULT.ACCEPTED
        home = gs.wait_type("HOME_POSITION", timeout=3.0, since=since)
        assert home.x == pytest.approx(float(v.fw.last.x_hat[0]), abs=0.5)
        assert home.z == pytest.approx(float(v.fw.last.x_hat[1]), abs=0.5)
        # Refused as ArduPilot refuses: p1 neither 0 nor 1, a latitude beyond 90°, NaN
        assert gs.command(mavlink.MAV_CMD_DO_SET_HOME, 2, 0, 0, 0, lat0, lon0, 0).result == MAV_RESULT.FAILED
        assert gs.command(mavlink.MAV_CMD_DO_SET_HOME, 0, 0, 0, 0, 95.0, lon0, 0).result == MAV_RESULT.FAILED
        assert gs.command(mavlink.MAV_CMD_DO_SET_HOME, 0, 0, 0, 0, math.nan, lon0, 0).result == MAV_RESULT.FAILED
        # Arming moves home to the vehicle and pushes GPS_GLOBAL_ORIGIN and HOME_POSITION (ArduSub)
        since = gs.mark()
        assert gs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == 0
        origin = gs.wait_type("GPS_GLOBAL_ORIGIN", timeout=3.0, since=since)
        home = gs.wait_type("HOME_POSITION", timeout=3.0, since=since)
        assert origin is not None and home is not None
        assert home.altitude == pytest.approx(-1000.0 * float(v.fw.last.x_hat[1]), abs=300.0)
        assert home.x == pytest.approx(float(v.fw.last.x_hat[0]), abs=0.5)
        assert gs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0).result == 0
        # Streamable at a rate of one's choosing
        assert gs.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_HOME_POSITION,
                          200_000).result == 0
        assert len([m for m in gs.collect(1.2) if m.get_type() == "HOME_POSITION"]) >= 4
        assert gs.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_HOME_POSITION, 0).result == 0
        gs.drain()
        time.sleep(0.3)
        assert not [m for m in gs.collect(0.8) if m.get_type() == "HOME_POSITION"]
    finally:
        v.link.state.home = None
