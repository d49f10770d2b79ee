"""ArduSub's other messages, battery, pre-arm health, vehicle commands, parameters and joystick, over real UDP."""
from __future__ import annotations

import math
import os
import time

import pytest

os.environ["MAVLINK20"] = "1"
# fixtures, one live vehicle per module
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from firmware_py.mavlink.battery import BatterySim
from firmware_py.modes import MAV_RESULT, Mode
from firmware_py.params.table import load_params

GROUPED = ("RAW_IMU", "SCALED_PRESSURE", "POWER_STATUS", "MEMINFO", "NAV_CONTROLLER_OUTPUT", "AHRS2",
           "BATTERY_STATUS", "EKF_STATUS_REPORT", "VIBRATION")
PREARM = mavlink.MAV_SYS_STATUS_PREARM_CHECK


def _manual(v, x=0, z=500, buttons=0):
    v.gs.send(mavlink.MAVLink_manual_control_message(1, x, 0, z, 0, buttons))


def _request(v, mid: int, mtype: str, pred=lambda m: True):
    since = v.gs.mark()
    assert v.gs.command(mavlink.MAV_CMD_REQUEST_MESSAGE, mid).result == MAV_RESULT.ACCEPTED
    return v.gs.wait_type(mtype, pred, 3.0, since)


def test_ardusub_groups_stream_the_other_messages(v):
    msgs = v.gs.collect(3.0)
    types = {m.get_type() for m in msgs}
    assert set(GROUPED) <= types
    assert not {"ATTITUDE_QUATERNION", "EXTENDED_SYS_STATE"} & types     # in none of ArduSub's groups
    last = {m.get_type(): m for m in msgs}
    assert last["EKF_STATUS_REPORT"].flags & mavlink.EKF_POS_HORIZ_ABS
    assert 0.0 <= last["EKF_STATUS_REPORT"].pos_horiz_variance < 1.0
    assert -1600 < last["RAW_IMU"].zacc < -400                             # gravity (and waves), body FRD, mG
    assert last["SCALED_PRESSURE"].press_abs == 1013.25
    assert last["MEMINFO"].freemem32 > 0
    b = last["BATTERY_STATUS"]
    assert 14000 < b.voltages[0] <= 16800 and b.battery_remaining >= 99     # the hotel load drains it
    s = last["SYS_STATUS"]
    assert abs(s.voltage_battery - b.voltages[0]) < 200 and s.battery_remaining >= 99 and s.current_battery > 0
    for field in ("present", "enabled", "health"):
        bits = getattr(s, f"onboard_control_sensors_{field}")
        assert bits & PREARM and bits & mavlink.MAV_SYS_STATUS_SENSOR_BATTERY
    # a fence, never enabled and healthy (ArduSub's): MAVProxy reports no breach
    assert [bool(getattr(s, f"onboard_control_sensors_{f}") & mavlink.MAV_SYS_STATUS_GEOFENCE)
            for f in ("present", "enabled", "health")] == [True, False, True]
    # on request: EXTENDED_SYS_STATE (ArduSub reports no landed state) and the attitude quaternion
    ext = _request(v, mavlink.MAVLINK_MSG_ID_EXTENDED_SYS_STATE, "EXTENDED_SYS_STATE")
    assert ext is not None and ext.landed_state == mavlink.MAV_LANDED_STATE_UNDEFINED
    q = _request(v, mavlink.MAVLINK_MSG_ID_ATTITUDE_QUATERNION, "ATTITUDE_QUATERNION")
    roll = math.atan2(2 * (q.q1 * q.q2 + q.q3 * q.q4), 1 - 2 * (q.q2 ** 2 + q.q3 ** 2))
    pitch = math.asin(max(-1.0, min(1.0, 2 * (q.q1 * q.q3 - q.q4 * q.q2))))
    yaw = math.atan2(2 * (q.q1 * q.q4 + q.q2 * q.q3), 1 - 2 * (q.q3 ** 2 + q.q4 ** 2))
    assert abs(q.q1 ** 2 + q.q2 ** 2 + q.q3 ** 2 + q.q4 ** 2 - 1.0) < 1e-6       # a unit quaternion
    lateral = v.fw.lateral.ekf.x                                # the six-DoF world: the estimate's roll and yaw
    assert abs(pitch - v.fw.ekf.x[2]) < 0.1 and abs(roll - lateral[1]) < 0.05 and abs(yaw - lateral[2]) < 0.05
    assert v.gs.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_EXTENDED_SYS_STATE,
                        200_000).result == MAV_RESULT.ACCEPTED
    got = [m for m in v.gs.collect(1.5) if m.get_type() == "EXTENDED_SYS_STATE"]
    assert len(got) >= 4
    v.gs.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_EXTENDED_SYS_STATE, 0)


def test_system_time_is_vehicle_time_plus_a_fixed_epoch(v):
    st = [m for m in v.gs.collect(2.0) if m.get_type() == "SYSTEM_TIME"]
    assert len(st) >= 4
    epochs = [m.time_unix_usec - m.time_boot_ms * 1000 for m in st]
    assert max(epochs) - min(epochs) <= 1000
    assert abs(epochs[0] / 1e6 + st[-1].time_boot_ms / 1e3 - time.time()) < 5.0   # real time: the wall clock


def test_battery_drains_with_thruster_power():
    p = load_params()
    b = BatterySim(p)
    idle = b.update(0.0, [0.0] * 8)
    assert abs(idle.voltage - 16.8) < 0.1 and idle.remaining_pct == 100
    full = b.update(0.05, [35.0] * 8)
    assert full.current > 20.0 and full.voltage < idle.voltage           # sag under ~8 × 250 W... per thruster fit
    for k in range(2, 20 * 600):                                         # ten minutes flat out
        s = b.update(k * 0.05, [35.0] * 8)
    assert 0 < s.remaining_pct < 100 and s.consumed_mah > 1000 and s.voltage < full.voltage
    assert b.update(math.nan, [35.0] * 8) == s                             # a bad clock changes nothing


def test_battery_current_follows_the_thrusters_on_the_vehicle(v):
    idle = _request(v, mavlink.MAVLINK_MSG_ID_BATTERY_STATUS, "BATTERY_STATUS").current_battery
    assert v.fw.request_arm(True)[0] == MAV_RESULT.ACCEPTED
    end = time.monotonic() + 2.0
    while time.monotonic() < end:
        _manual(v, x=1000)
        time.sleep(0.1)
    busy = _request(v, mavlink.MAVLINK_MSG_ID_BATTERY_STATUS, "BATTERY_STATUS")
    assert busy.current_battery > idle + 200 and busy.current_consumed > 0       # cA: 2 A more at least


def test_prearm_health_follows_arming_check(v):
    def prearm_healthy():
        s = _request(v, mavlink.MAVLINK_MSG_ID_SYS_STATUS, "SYS_STATUS")
        return bool(s.onboard_control_sensors_health & PREARM)
    assert prearm_healthy()
    assert v.gs.set_param("ARMING_CHECK", 1).param_value == 1.0               # all (ArduSub's 448: no INS check)
    assert v.gs.set_param("WK_EKF_CONV", 1e-4).param_value < 1e-3             # the EKF is never converged now
    time.sleep(0.2)
    assert not prearm_healthy()
    assert v.gs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == MAV_RESULT.FAILED
    assert v.gs.set_param("ARMING_CHECK", 448).param_value == 448.0           # ArduSub's: RC, voltage, battery
    time.sleep(0.2)
    assert prearm_healthy()
    assert v.gs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == MAV_RESULT.ACCEPTED


def test_read_only_parameters_are_denied_as_ardupilot_does(v):
    since = v.gs.mark()
    pv = v.gs.set_param("FRAME_CONFIG", 1)
    assert pv.param_value == 2.0 and pv.param_type == mavlink.MAV_PARAM_TYPE_INT8
    assert v.gs.wait_type("STATUSTEXT", lambda m: m.text == "Param write denied (FRAME_CONFIG)", 2.0, since)
    assert v.gs.set_param("SERVO3_FUNCTION", 0).param_value == 35.0          # a thruster stays a thruster
    assert v.gs.param("BTN6_FUNCTION").param_value == 3.0                    # arm, ArduSub's default
    assert abs(v.gs.set_param("JS_GAIN_DEFAULT", 0.7).param_value - 0.7) < 1e-6


def _servo(v):
    return _request(v, mavlink.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW, "SERVO_OUTPUT_RAW")


def _sub_info(v, name: str) -> float:
    return v.gs.wait_type("NAMED_VALUE_FLOAT", lambda m: m.name == name, 3.0, v.gs.mark()).value


def test_do_set_servo_and_pass_through(v):
    g = v.gs
    # output 9 passes RC input 9 through (ArduSub's SERVO9_FUNCTION 59): DO_SET_SERVO holds until the input moves
    assert g.command(mavlink.MAV_CMD_DO_SET_SERVO, 9, 1700).result == MAV_RESULT.ACCEPTED
    assert _servo(v).servo9_raw == 1700
    g.send(mavlink.MAVLink_rc_channels_override_message(1, 1, *[65535] * 8, 1600, *[0] * 7, 0, 0))
    assert g.wait_type("SERVO_OUTPUT_RAW", lambda m: m.servo9_raw == 1600, 3.0)
    assert _request(v, mavlink.MAVLINK_MSG_ID_RC_CHANNELS, "RC_CHANNELS").chan9_raw == 1600
    since = g.mark()
    assert g.command(mavlink.MAV_CMD_DO_SET_SERVO, 3, 1700).result == MAV_RESULT.FAILED
    assert g.wait_type("STATUSTEXT", lambda m: "Channel 3 is already in use" in m.text, 2.0, since)
    assert g.command(mavlink.MAV_CMD_DO_SET_SERVO, 10, 1700).result == MAV_RESULT.FAILED   # the camera's
    assert g.command(mavlink.MAV_CMD_DO_SET_SERVO, 17, 1700).result == MAV_RESULT.FAILED
    assert g.command(mavlink.MAV_CMD_DO_SET_SERVO, math.nan, 1700).result == MAV_RESULT.FAILED


def test_lights_camera_tilt_and_the_sub_panel_values(v):
    """ArduSub 4.7's accessories: lights on outputs with function 181, one JS_LIGHTS_STEPS step a press; the
    camera mount on function 7 (output 10), tilting at MNT1_RC_RATE while its button is held; and the
    NAMED_VALUE_FLOATs QGroundControl's Sub panel reads (CamTilt, Lights1, PilotGain...)."""
    g = v.gs
    g.set_param("SERVO11_FUNCTION", 181)
    time.sleep(0.2)
    assert _servo(v).servo11_raw == 0                                          # not set until the light changes
    _manual(v, buttons=1 << 14)                                                # lights 1 brighter (32)
    _manual(v, buttons=0)
    assert g.wait_type("SERVO_OUTPUT_RAW", lambda m: m.servo11_raw == 1200, 3.0)   # 1100 + 800 / 8
    assert _sub_info(v, "Lights1") == pytest.approx(0.125)                     # (1200 − 1500) / 400 / 2 + ½
    level = _servo(v).servo10_raw
    assert level == 1754                                                       # 0° in −90…20° over 1100–1900
    assert _sub_info(v, "CamTilt") == pytest.approx(1.0 - ((1754 - 1500) / 400 / 2 + 0.5), abs=1e-6)
    end = time.monotonic() + 1.0
    while time.monotonic() < end:                                              # tilt up (22) held for 1 s
        _manual(v, buttons=1 << 10)
        time.sleep(0.05)
    _manual(v, buttons=0)
    up = _servo(v).servo10_raw - level                                         # 30°/s over 110° of 800 µs
    assert 800 * 30 / 110 * 0.6 < up < 800 * 30 / 110 * 1.6
    _manual(v, buttons=1 << 7)                                                 # centre (21)
    _manual(v, buttons=0)
    assert g.wait_type("SERVO_OUTPUT_RAW", lambda m: m.servo10_raw == 1754, 3.0)
    assert _sub_info(v, "PilotGain") == pytest.approx(v.link.joystick.gain)
    assert _sub_info(v, "RFTarget") == pytest.approx(-0.01)


def test_do_reposition_as_ardusub(v):
    g, fw = v.gs, v.fw
    lat0 = fw.params["WK_ORIGIN_LAT"]
    north = math.degrees(1.5 / 6378137.0)
    lat_e7 = int(round((lat0 + north) * 1e7))
    lon_e7 = int(round(fw.params["WK_ORIGIN_LON"] * 1e7))

    def reposition(flags, lat, lon, alt, frame=mavlink.MAV_FRAME_GLOBAL_INT):
        since = g.mark()
        g.send(mavlink.MAVLink_command_int_message(1, 1, frame, mavlink.MAV_CMD_DO_REPOSITION, 0, 0, -1, flags, 0,
                                                   math.nan, lat, lon, alt))
        return g.wait_type("COMMAND_ACK", lambda m: m.command == mavlink.MAV_CMD_DO_REPOSITION, 5.0, since).result
    assert reposition(0, lat_e7, lon_e7, -3.0) == MAV_RESULT.DENIED             # not GUIDED, no change-mode flag
    assert reposition(1, 0, 0, -3.0) == MAV_RESULT.DENIED                       # no location
    assert reposition(1, lat_e7, lon_e7, -3.0, mavlink.MAV_FRAME_LOCAL_NED) == MAV_RESULT.DENIED
    assert fw.mode == Mode.MANUAL
    assert reposition(1, lat_e7, lon_e7, -3.0) == MAV_RESULT.ACCEPTED
    assert fw.mode == Mode.GUIDED
    assert abs(fw.setpoint[0] - 1.5) < 0.01 and abs(fw.setpoint[1] - 3.0) < 1e-9
    ack = g.command(mavlink.MAV_CMD_DO_REPOSITION, -1, 0, 0, math.nan, lat0, fw.params["WK_ORIGIN_LON"], -2.0)
    assert ack.result == MAV_RESULT.ACCEPTED and fw.setpoint[1] == 2.0
    assert abs(fw.setpoint[0]) < 0.5                                             # float32 degrees: ~0.4 m


def test_condition_yaw_answered_as_ardusub(v):
    assert v.gs.command(mavlink.MAV_CMD_CONDITION_YAW, 90, 10, 1, 0).result == MAV_RESULT.ACCEPTED
    assert v.gs.command(mavlink.MAV_CMD_CONDITION_YAW, 400, 10, 1, 0).result == MAV_RESULT.DENIED
    assert v.gs.command(mavlink.MAV_CMD_CONDITION_YAW, 90, 10, 1, 2).result == MAV_RESULT.DENIED
    assert v.gs.command(mavlink.MAV_CMD_CONDITION_YAW, math.nan).result == MAV_RESULT.DENIED


def test_joystick_gain_and_buttons(v):
    g, fw = v.gs, v.fw
    v.link.joystick.gain = 0.5                                                   # JS_GAIN_DEFAULT
    _manual(v, x=1000)
    assert g.wait_type("RC_CHANNELS", lambda m: m.chan5_raw == 1700, 3.0)       # 1500 + 400 × 0.5
    since = g.mark()
    _manual(v, x=1000, buttons=1 << 11)                                          # gain up: 0.25 + 0.75/3 steps
    assert g.wait_type("STATUSTEXT", lambda m: m.text == "#Gain is 75%", 3.0, since)
    assert g.wait_type("RC_CHANNELS", lambda m: m.chan5_raw == 1800, 3.0)
    _manual(v, buttons=1 << 2)                                                   # depth hold
    assert g.heartbeat(lambda m: m.custom_mode == Mode.ALT_HOLD, 3.0)
    _manual(v, buttons=1 << 6)                                                   # arm
    assert g.heartbeat(lambda m: m.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED, 3.0)
    _manual(v, buttons=(1 << 6) | (1 << 4))                                      # held arm, new disarm
    assert g.heartbeat(lambda m: not m.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED, 3.0)
    _manual(v, buttons=0)
    assert not fw.armed
    v.link.joystick.gain = 0.5


def test_pilot_input_failsafe_disarms(v):
    g = v.gs
    g.set_param("FS_PILOT_INPUT", 2)
    g.set_param("FS_PILOT_TIMEOUT", 0.5)
    assert v.fw.request_arm(True)[0] == MAV_RESULT.ACCEPTED
    since = g.mark()
    _manual(v, x=300)
    assert g.wait_type("STATUSTEXT", lambda m: m.text == "Lost manual control", 5.0, since)
    assert g.heartbeat(lambda m: not m.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED, 3.0)
    assert v.link.state.rc[4] == 1500


def test_pilot_input_failsafe_at_ardusubs_default_disarms_when_the_joystick_stops(v):
    """FS_PILOT_INPUT at ArduSub's default (2, disarm): the joystick streams, the vehicle is armed, the stream
    stops; FS_PILOT_TIMEOUT (3 s) later "Lost manual control" (CRITICAL), a disarm, a CRITICAL heartbeat. As
    ArduSub's, it trips once per loss: a vehicle armed after a loss and flown without sticks stays armed."""
    g, defaults = v.gs, load_params()
    assert defaults["FS_PILOT_INPUT"] == 2 and defaults["FS_PILOT_TIMEOUT"] == 3.0
    g.set_param("FS_PILOT_INPUT", 2)                  # the fixture's GCS has no joystick: it turned it off
    end = time.monotonic() + 1.0
    while time.monotonic() < end:
        _manual(v)
        time.sleep(0.1)
    assert g.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == MAV_RESULT.ACCEPTED
    end = time.monotonic() + 2.0
    while time.monotonic() < end:                     # sticks for 2 s: no failsafe
        _manual(v)
        time.sleep(0.1)
    assert v.fw.armed and not v.link.joystick.failsafe
    t0, since = time.monotonic(), g.mark()           # the joystick stops
    lost = g.wait_type("STATUSTEXT", lambda m: m.text == "Lost manual control", 8.0, since)
    assert lost is not None and lost.severity == mavlink.MAV_SEVERITY_CRITICAL
    assert 2.0 < time.monotonic() - t0 < 6.0
    hb = g.heartbeat(lambda m: not m.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED, 3.0)
    assert hb is not None and hb.system_status == mavlink.MAV_STATE_CRITICAL and not v.fw.armed
    assert g.wait_type("STATUSTEXT", lambda m: m.text == "Disarming motors", 2.0, since)
    # the loss is over for the failsafe: armed again without sticks (a GCS flying GUIDED), it stays armed
    assert g.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1).result == MAV_RESULT.ACCEPTED
    time.sleep(4.0)
    assert v.fw.armed
    _manual(v)                                         # sticks again: the failsafe clears
    assert g.heartbeat(lambda m: m.system_status == mavlink.MAV_STATE_ACTIVE, 3.0)


def test_pressure_calibration_zeroes_the_depth(v):
    g, fw = v.gs, v.fw
    assert g.command(mavlink.MAV_CMD_PREFLIGHT_CALIBRATION, 0, 0, 0, 0, 0, 1).result == MAV_RESULT.UNSUPPORTED
    fw.request_arm(True, force=True)
    since = g.mark()
    assert g.command(mavlink.MAV_CMD_PREFLIGHT_CALIBRATION, 0, 0, 1).result == MAV_RESULT.FAILED
    assert g.wait_type("STATUSTEXT", lambda m: m.text == "Disarm before calibration.", 2.0, since)
    fw.request_arm(False)
    depth = fw.last.frame.depth
    try:
        assert g.command(mavlink.MAV_CMD_PREFLIGHT_CALIBRATION, 0, 0, 1).result == MAV_RESULT.ACCEPTED
        assert abs(fw.depth_offset - depth) < 0.5                               # the last second's mean
        time.sleep(0.3)
        assert abs(fw.last.frame.depth) < 0.5 < depth                          # the depth reads ~0 here now
    finally:
        fw.depth_offset = 0.0
