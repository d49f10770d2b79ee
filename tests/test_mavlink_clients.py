"""Unmodified third-party clients against a live vehicle over UDP: MAVSDK, dronekit, QGroundControl's connect."""
from __future__ import annotations

import asyncio
import os
import subprocess

import pytest

os.environ["MAVLINK20"] = "1"
# fixtures, one live vehicle per module
from mavlink_gcs import dronekit_installed, free_port, mavsdk_server
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from firmware_py.modes import MAV_RESULT


@pytest.mark.skipif(mavsdk_server() is None, reason="MAVSDK-Python (mavsdk<4, with mavsdk_server) not installed")
def test_mavsdk_reads_and_sets_the_vehicle(v, tmp_path):
    from mavsdk import System

    grpc = free_port(__import__("socket").SOCK_STREAM)
    log = open(tmp_path / "mavsdk_server.log", "w")   # noqa: SIM115
    server = subprocess.Popen([mavsdk_server(), "-p", str(grpc), "--sysid", "255",
                               f"udpout://127.0.0.1:{v.in_port}"], stdout=log, stderr=subprocess.STDOUT)

    steps: list[str] = []

    async def session():
        drone = System(mavsdk_server_address="127.0.0.1", port=grpc)
        await drone.connect()
        async for state in drone.core.connection_state():
            if state.is_connected:
                break
        steps.append('got = {"sysid_mygcs')
        got = {"sysid_mygcs": await drone.param.get_param_int("MAV_GCS_SYSID")}
        steps.append('await drone.param.set_param_int')
        await drone.param.set_param_int("JS_GAIN_STEPS", 5)
        steps.append('await drone.param.set_param_float')
        await drone.param.set_param_float("JS_GAIN_DEFAULT", 0.6)
        steps.append('home')
        got["home"] = await anext(drone.telemetry.home())
        steps.append('async for h in')
        async for h in drone.telemetry.health():
            if h.is_armable:
                got["armable"] = True
                break
        steps.append('battery')
        got["battery"] = await anext(drone.telemetry.battery())
        steps.append('in_air')
        try:            # MAVSDK publishes in_air only for a landed state ON_GROUND / IN_AIR: ArduSub sends UNDEFINED
            got["in_air"] = await asyncio.wait_for(anext(drone.telemetry.in_air()), 3.0)
        except TimeoutError:
            got["in_air"] = None
        steps.append('mission')
        got["mission"] = await drone.mission_raw.download_mission()
        return got

    try:
        got = asyncio.run(asyncio.wait_for(session(), 60.0))
    except TimeoutError:
        pytest.fail(f"MAVSDK stalled after {steps}")
    finally:
        server.terminate()
        server.wait(10)
        log.close()
    p = v.fw.params
    assert got["sysid_mygcs"] == 255
    assert p["JS_GAIN_STEPS"] == 5 and abs(p["JS_GAIN_DEFAULT"] - 0.6) < 1e-6
    assert abs(got["home"].latitude_deg - p["WK_ORIGIN_LAT"]) < 1e-6
    assert got["armable"] is True                               # SYS_STATUS's PREARM_CHECK health bit
    assert 14.0 < got["battery"].voltage_v <= 16.8 and got["battery"].remaining_percent > 90
    assert got["in_air"] is None                                # ArduSub reports no landed state: never set
    assert len(got["mission"]) == 1 and got["mission"][0].seq == 0     # home alone


@pytest.mark.skipif(not dronekit_installed(),
                    reason="dronekit2 not installed (dronekit 2.9 does not import on Python 3.11)")
def test_dronekit_connects_downloads_home_and_uploads_a_mission(v):
    from dronekit import Command, connect

    vehicle = connect(f"udpout:127.0.0.1:{v.in_port}", wait_ready=True, timeout=60, heartbeat_timeout=30,
                      source_system=255)
    try:
        cmds = vehicle.commands
        cmds.download()
        cmds.wait_ready(timeout=30)
        home = vehicle.home_location
        assert home is not None and abs(home.lat - v.fw.params["WK_ORIGIN_LAT"]) < 1e-5    # MISSION_ITEM: float32
        lat, lon = v.fw.params["WK_ORIGIN_LAT"], v.fw.params["WK_ORIGIN_LON"]
        cmds.clear()
        for k in (1, 2):
            cmds.add(Command(0, 0, 0, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, mavlink.MAV_CMD_NAV_WAYPOINT, 0, 1,
                             0, 0, 0, 0, lat + 1e-5 * k, lon, -2.0 * k))
        cmds.upload(timeout=30)
        cmds.download()
        cmds.wait_ready(timeout=30)
        back = list(cmds)
        assert len(back) == 2 and [round(c.z, 3) for c in back] == [-2.0, -4.0]
        assert abs(back[1].x - (lat + 2e-5)) < 1e-6
    finally:
        vehicle.close()
    v.gs.send(mavlink.MAVLink_mission_clear_all_message(1, 1, 0))


def test_qgroundcontrol_connect_sequence_is_answered(v):
    """QGC's InitialConnectStateMachine and APMFirmwarePlugin requests, each answered as ArduSub answers it."""
    g = v.gs
    answered: dict[str, object] = {}

    def command(name, cmd, *params, expect=MAV_RESULT.ACCEPTED, then=None):
        since = g.mark()
        ack = g.command(cmd, *params)
        assert ack is not None and ack.result == expect, name
        answered[name] = MAV_RESULT(ack.result).name
        if then is not None:
            assert g.wait_type(then, timeout=3.0, since=since) is not None, name
            answered[name] += f" + {then}"

    command("AUTOPILOT_VERSION", mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION,
            then="AUTOPILOT_VERSION")
    command("COMPONENT_INFORMATION", mavlink.MAV_CMD_REQUEST_MESSAGE, 395,
            expect=MAV_RESULT.FAILED)                           # ArduPilot: no such ap_message
    command("PROTOCOL_VERSION", mavlink.MAV_CMD_REQUEST_PROTOCOL_VERSION, 1, expect=MAV_RESULT.UNSUPPORTED)
    since = g.mark()
    g.send(mavlink.MAVLink_param_request_list_message(1, 1))
    last = g.wait_type("PARAM_VALUE", lambda m: m.param_index == m.param_count - 1, 15.0, since)
    assert last is not None
    got = {m.param_id for m in g.log[since:] if m.get_type() == "PARAM_VALUE"}
    assert {"FRAME_CONFIG", "BATT_CAPACITY", "JS_GAIN_DEFAULT", "BTN0_FUNCTION", "SERVO16_FUNCTION",
            "RCMAP_THROTTLE", "MAV1_PARAMS", "MOT_PWM_MIN", "ARMING_CHECK", "FS_PILOT_INPUT"} <= got
    answered["PARAM_REQUEST_LIST"] = f"{last.param_count} PARAM_VALUE"
    for kind in (0, 1, 2):                                      # mission, fence, rally
        since = g.mark()
        g.send(mavlink.MAVLink_mission_request_list_message(1, 1, kind))
        count = g.wait_type("MISSION_COUNT", lambda m, k=kind: m.mission_type == k, 3.0, since)
        assert count is not None and count.count == (1 if kind == 0 else 0)
        answered[f"MISSION_REQUEST_LIST type {kind}"] = f"MISSION_COUNT {count.count}"
    for stream, hz in ((mavlink.MAV_DATA_STREAM_RAW_SENSORS, 2), (mavlink.MAV_DATA_STREAM_EXTENDED_STATUS, 2),
                       (mavlink.MAV_DATA_STREAM_EXTRA3, 3)):
        g.send(mavlink.MAVLink_request_data_stream_message(1, 1, stream, hz, 1))
    assert g.wait_type("BATTERY_STATUS", timeout=3.0) is not None
    answered["REQUEST_DATA_STREAM"] = "rates set (no reply, as ArduPilot)"
    command("SET_MESSAGE_INTERVAL HOME", mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_HOME_POSITION,
            1_000_000, then="HOME_POSITION")
    command("GET_HOME_POSITION", mavlink.MAV_CMD_GET_HOME_POSITION, then="HOME_POSITION")
    command("REQUEST_MESSAGE EXTENDED_SYS_STATE", mavlink.MAV_CMD_REQUEST_MESSAGE,
            mavlink.MAVLINK_MSG_ID_EXTENDED_SYS_STATE, then="EXTENDED_SYS_STATE")
    g.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_HOME_POSITION, 0)
    print("\nQGroundControl connect sequence:\n" + "\n".join(f"  {k}: {a}" for k, a in answered.items()))
    assert len(answered) == 11

