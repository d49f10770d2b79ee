"""Telemetry of the MAVLink link against a live vehicle: identity, default streams, stream control, request-message."""
from __future__ import annotations

import math
import os
import time

import pytest

os.environ["MAVLINK20"] = "1"
# fixtures, one live vehicle per module
import itertools

from mavlink_gcs import free_port, rate
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from firmware_py.hal.sensors import depth_to_pressure
from firmware_py.mavlink import CAPABILITIES, MavlinkLink
from firmware_py.mavlink.streams import Streams
from firmware_py.modes import MAV_RESULT, Mode
from firmware_py.params.table import load_params


def test_heartbeat_and_default_streams(v):
    msgs = v.gs.collect(4.2)
    by = {}
    for m in msgs:
        if m.get_srcSystem() == 1:
            by.setdefault(m.get_type(), []).append(m)
    hb = by["HEARTBEAT"]
    assert 3 <= len(hb) <= 6
    gaps = [b._t - a._t for a, b in itertools.pairwise(hb)]
    assert 0.6 < sum(gaps) / len(gaps) < 1.4                 # 1 Hz
    h = hb[-1]
    assert (h.type, h.autopilot, h.base_mode, h.custom_mode, h.system_status, h.mavlink_version) == (
        mavlink.MAV_TYPE_SUBMARINE, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, 81, Mode.MANUAL, mavlink.MAV_STATE_STANDBY, 3)
    assert h.get_srcComponent() == 1 and h.get_msgbuf()[0] == 0xFD      # MAVLink 2
    # ArduSub's default rates (Hz), measured on the vehicle's timestamps
    ms = lambda m: m.time_boot_ms / 1000.0 if hasattr(m, "time_boot_ms") else m._t   # noqa: E731
    for mtype, hz in (("ATTITUDE", 10), ("VFR_HUD", 10), ("GLOBAL_POSITION_INT", 3), ("LOCAL_POSITION_NED", 3),
                      ("SYSTEM_TIME", 3), ("SCALED_PRESSURE2", 2), ("RC_CHANNELS", 2)):
        assert mtype in by, mtype
        assert rate(by[mtype], ms) == pytest.approx(hz, rel=0.25), mtype
    assert rate(by["SERVO_OUTPUT_RAW"], lambda m: m.time_usec / 1e6) == pytest.approx(2, rel=0.25)
    assert 1.4 <= len(by["SYS_STATUS"]) / 4.2 <= 3.0        # no timestamp: count it
    # Contents: the position messages of one tick agree with each other and with the estimate
    lp = by["LOCAL_POSITION_NED"][-1]
    depth = lp.z
    assert depth == pytest.approx(v.fw.last.x_hat[1], abs=1.0)
    assert lp.y == pytest.approx(v.fw.last.lateral.x_hat[0], abs=0.5) and abs(lp.y) < 0.5   # six DoF: the estimate's y
    gp = next(m for m in by["GLOBAL_POSITION_INT"] if m.time_boot_ms == lp.time_boot_ms)
    assert gp.alt == pytest.approx(-1000 * depth, abs=2) and gp.relative_alt == gp.alt
    assert gp.vz == pytest.approx(100 * lp.vz, abs=1) and gp.vx == pytest.approx(100 * lp.vx, abs=1)
    assert gp.lat / 1e7 == pytest.approx(v.fw.params["WK_ORIGIN_LAT"] + math.degrees(lp.x / 6378137.0), abs=2e-7)
    assert gp.lon / 1e7 == pytest.approx(v.fw.params["WK_ORIGIN_LON"], abs=1e-5)    # y within 0.5 m
    sp = min(by["SCALED_PRESSURE2"], key=lambda m: abs(m.time_boot_ms - lp.time_boot_ms))
    assert sp.press_abs == pytest.approx(depth_to_pressure(depth) / 100.0, abs=25.0)    # measured, 0.25 m
    assert sp.temperature == 1000
    att = by["ATTITUDE"][-1]
    assert abs(att.roll) < 0.1 and abs(att.yaw) < 0.1 and abs(att.pitch) < 0.5       # held level, on heading
    assert by["VFR_HUD"][-1].alt == pytest.approx(-depth, abs=1.0)
    servo = by["SERVO_OUTPUT_RAW"][-1]
    assert servo.port == 0 and [getattr(servo, f"servo{i}_raw") for i in range(1, 9)] == [1500] * 8
    ss = by["SYS_STATUS"][-1]
    assert ss.onboard_control_sensors_present & mavlink.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE
    assert ss.onboard_control_sensors_health & mavlink.MAV_SYS_STATUS_AHRS          # EKF converged
    assert ss.onboard_control_sensors_enabled & mavlink.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS   # even disarmed (ArduSub)
    assert ss.onboard_control_sensors_health & mavlink.MAV_SYS_STATUS_SENSOR_GPS         # the position fix
    assert not ss.onboard_control_sensors_enabled & mavlink.MAV_SYS_STATUS_SENSOR_Z_ALTITUDE_CONTROL    # MANUAL
    named = {m.name: m.value for m in by["NAMED_VALUE_FLOAT"]}
    assert set(named) == {"FF_AGE", "FF_ON", "FF_X", "FF_Z", "FF_M", "TICK_P99", "TICK_MISS", "CamTilt", "CamPan",
                          "TetherTrn", "Lights1", "Lights2", "PilotGain", "InputHold", "RollPitch", "RFTarget"}
    assert 0.0 < named["TICK_P99"] < 50.0 and named["TICK_MISS"] >= 0.0   # control-task compute p99 (ms)
    assert named["FF_AGE"] >= 0.0 and named["FF_ON"] == 0.0        # a forecast, but disarmed: FF off


def test_request_data_stream_and_message_interval(v):
    gs = v.gs
    attitude = lambda s: [m for m in gs.collect(s) if m.get_type() == "ATTITUDE"]   # noqa: E731
    gs.send(mavlink.MAVLink_request_data_stream_message(1, 1, mavlink.MAV_DATA_STREAM_EXTRA1, 2, 1))
    time.sleep(0.3)
    gs.drain()
    slow = attitude(2.1)
    assert 3 <= len(slow) <= 6 and rate(slow, lambda m: m.time_boot_ms / 1e3) == pytest.approx(2, rel=0.3)
    assert v.fw.params["MAV1_EXTRA1"] == 2
    # A per-message interval overrides the group: ATTITUDE at 20 Hz
    ack = gs.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_ATTITUDE, 50_000)
    assert ack.result == MAV_RESULT.ACCEPTED
    fast = attitude(1.0)
    assert rate(fast, lambda m: m.time_boot_ms / 1e3) == pytest.approx(20, rel=0.2)
    # GET_MESSAGE_INTERVAL reports it
    gs.drain()
    gs.send(mavlink.MAVLink_command_long_message(1, 1, mavlink.MAV_CMD_GET_MESSAGE_INTERVAL, 0,
                                                 mavlink.MAVLINK_MSG_ID_ATTITUDE, 0, 0, 0, 0, 0, 0))
    mi = gs.wait_type("MESSAGE_INTERVAL")
    assert (mi.message_id, mi.interval_us) == (mavlink.MAVLINK_MSG_ID_ATTITUDE, 50_000)
    # −1 turns a message off, 0 brings back its default
    assert gs.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_VFR_HUD, -1).result == 0
    time.sleep(0.2)
    gs.drain()
    assert not [m for m in gs.collect(0.8) if m.get_type() == "VFR_HUD"]
    assert gs.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_VFR_HUD, 0).result == 0
    assert gs.wait_type("VFR_HUD", timeout=2.0) is not None
    # REQUEST_DATA_STREAM start_stop 0 stops a group (and resets its messages' own intervals)
    gs.send(mavlink.MAVLink_request_data_stream_message(1, 1, mavlink.MAV_DATA_STREAM_EXTRA1, 10, 0))
    time.sleep(0.3)
    assert v.fw.params["MAV1_EXTRA1"] == 0
    gs.drain()
    assert not attitude(0.8)
    # An unknown message id is refused with ArduPilot's words
    gs.drain()
    gs.send(mavlink.MAVLink_command_long_message(1, 1, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 0, 12345, 1e5,
                                                 0, 0, 0, 0, 0))
    gs.send(mavlink.MAVLink_request_data_stream_message(1, 1, mavlink.MAV_DATA_STREAM_ALL, 4, 1))
    replies = [m for m in gs.collect(0.6) if m.get_type() in ("COMMAND_ACK", "STATUSTEXT")]
    assert [m.result for m in replies if m.get_type() == "COMMAND_ACK"] == [MAV_RESULT.DENIED]
    assert [m.text for m in replies if m.get_type() == "STATUSTEXT"] == ["No ap_message for mavlink id (12345)"]
    assert all(v.fw.params[g] == 4 for g in ("MAV1_RAW_SENS", "MAV1_EXTRA1", "MAV1_EXTRA3"))


def test_request_message_capabilities_and_timesync(v):
    gs = v.gs
    ack = gs.command(mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION)
    assert ack.result == MAV_RESULT.ACCEPTED and (ack.target_system, ack.target_component) == (255, 190)
    av = gs.wait_type("AUTOPILOT_VERSION")
    assert av.capabilities == CAPABILITIES
    assert av.capabilities & mavlink.MAV_PROTOCOL_CAPABILITY_MAVLINK2
    assert av.capabilities & mavlink.MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT
    assert av.capabilities & mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_INT          # missions: ArduSub's protocol
    assert not av.capabilities & mavlink.MAV_PROTOCOL_CAPABILITY_FTP                # FTP is NAKed, not served
    assert gs.command(mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, 1).result == MAV_RESULT.ACCEPTED
    assert gs.wait_type("AUTOPILOT_VERSION") is not None
    # Any streamed message, once, on request — also while its stream is off
    v.fw.params.set("MAV1_EXTRA3", 0)
    assert gs.command(mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_SYSTEM_TIME).result == 0
    st = gs.wait_type("SYSTEM_TIME")
    assert st is not None and abs(st.time_unix_usec / 1e6 - time.time()) < 5
    assert gs.command(mavlink.MAV_CMD_REQUEST_MESSAGE, 9999).result == MAV_RESULT.FAILED
    # TIMESYNC: answered with the vehicle's time, our timestamp echoed; answers are not answered
    gs.drain()
    gs.send(mavlink.MAVLink_timesync_message(0, 123456789))
    ts = gs.wait_type("TIMESYNC", lambda m: m.ts1 == 123456789)
    assert ts is not None and ts.tc1 > 0
    gs.send(mavlink.MAVLink_timesync_message(5, 42))
    assert gs.wait_type("TIMESYNC", lambda m: m.ts1 == 42, timeout=1.0) is None

@pytest.mark.parametrize("dof", ["planar", "six"])
def test_telemetry_packs_whatever_the_estimate_holds(dof):
    """NaN and huge values in the firmware's state (in six DoF its lateral estimate's too) become valid (clipped)
    messages, never an exception."""
    import dataclasses

    import numpy as np

    from sitl.harness.run import build_mission
    from sitl.harness.spec import RunSpec
    m = build_mission(RunSpec("W1", "cpd", sea={"dof": dof}), params=load_params())
    fw = m.firmware
    link = MavlinkLink(fw, [f"udpout:127.0.0.1:{free_port()}"])
    try:
        fw.scheduler.run_tick()
        assert (fw.last.lateral is not None) == (dof == "six")
        for x_hat in (np.full(6, np.nan), np.full(6, np.inf), np.array([1e12, -1e12, 1e3, 1e9, -1e9, 1e9])):
            lateral = None if fw.last.lateral is None else dataclasses.replace(fw.last.lateral, x_hat=x_hat)
            fw.last = dataclasses.replace(fw.last, x_hat=x_hat, tau_e_hat=x_hat[:3], lateral=lateral)
            link.streams = Streams(fw.params)          # every stream due now
            link._outbox.clear()
            link.update(fw.scheduler.next_slot_ns())
            types = set()
            mav = mavlink.MAVLink(None, 1, 1)
            for _ep, msg in link._outbox:
                msg.pack(mav)
                types.add(msg.get_type())
            assert link.counters["handler_errors"] == 0, link.last_error
            assert {"HEARTBEAT", "ATTITUDE", "GLOBAL_POSITION_INT", "LOCAL_POSITION_NED", "VFR_HUD",
                    "SERVO_OUTPUT_RAW", "NAMED_VALUE_FLOAT", "SYS_STATUS"} <= types
    finally:
        link.stop()


def test_gps_raw_int_reports_the_position_fix_in_extended_status(v):
    """GPS_RAW_INT streams with SYS_STATUS (MAV1_EXT_STAT, 2 Hz): the position fix, as ArduSub reports an
    acoustic positioning system fed to it as a GPS — a 3D fix at the fix's latitude, altitude −depth,
    satellites and DOPs unknown."""
    msgs = [m for m in v.gs.collect(2.6) if m.get_type() == "GPS_RAW_INT"]
    assert 4 <= len(msgs) <= 7
    g = msgs[-1]
    p = v.fw.params
    assert (g.fix_type, g.lon, g.satellites_visible, g.eph, g.epv) == (
        mavlink.GPS_FIX_TYPE_3D_FIX, round(p["WK_ORIGIN_LON"] * 1e7), 255, 65535, 65535)
    x = math.radians(g.lat * 1e-7 - p["WK_ORIGIN_LAT"]) * 6378137.0
    assert abs(x - float(v.fw.last.x_hat[0])) < 0.5 and abs(g.alt / 1000.0 + float(v.fw.last.x_hat[1])) < 0.5
    # The group's rate paces it; and it can be asked for
    gs = v.gs
    gs.send(mavlink.MAVLink_request_data_stream_message(1, 1, mavlink.MAV_DATA_STREAM_EXTENDED_STATUS, 0, 0))
    time.sleep(0.3)
    gs.drain()
    assert not [m for m in gs.collect(1.0) if m.get_type() == "GPS_RAW_INT"]
    assert gs.command(mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_GPS_RAW_INT).result == MAV_RESULT.ACCEPTED
    assert gs.wait_type("GPS_RAW_INT", lambda m: m.fix_type == mavlink.GPS_FIX_TYPE_3D_FIX, timeout=2.0) is not None
