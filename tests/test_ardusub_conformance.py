"""Differential conformance: the real ArduSub and Wavekeep asked the same things by the same ground stations.

One boot of each vehicle for the whole module (``pair``: :mod:`ardusub_pair`), both in a still-water
plant, both run at :data:`ardusub_pair.SPEEDUP` times real time. Each test asks both vehicles the
same questions (a pymavlink ground station; MAVSDK-Python and dronekit2 where the item is theirs)
and compares the answers item by item; where they differ, the difference must be one of the
documented, deliberate ones (:data:`conformance_differences.DIFFERENCES`, listed with their reasons in
docs/mavlink.md). Skipped, with the reason, when ``WAVEKEEP_ARDUSUB`` does not name the binary.
"""
from __future__ import annotations

import asyncio
import math
import random
import re
import subprocess

import pytest
from ardusub_pair import ROOT, Pair, Vehicle, documented, read_param_list, start_pair, write_report
from conformance_differences import DIFFERENCES
from conformance_probes import (
    MODE_NAMES,
    M,
    bits,
    command,
    disarm,
    heartbeat,
    listen,
    read_params,
    reference_table,
    set_mode,
    texts,
    to_manual,
    wait_position,
)
from mavlink_gcs import dronekit_installed, free_port, mavsdk_server

pytestmark = pytest.mark.processes

@pytest.fixture(scope="module")
def pair(tmp_path_factory):
    p = start_pair(tmp_path_factory.mktemp("conformance"))
    try:
        for v in p.vehicles:
            v.wait(3.0)                   # the boot's texts and first streams
            v.boot_log_end = len(v.gs.log)
        yield p
    finally:
        write_report(p)
        p.stop()


def test_every_documented_difference_is_in_the_docs():
    """Each documented difference's topic is a bold label in docs/mavlink.md's list of differences."""
    doc = (ROOT / "docs" / "mavlink.md").read_text()
    section = doc[doc.index("## Where Wavekeep differs from ArduSub"):]
    missing = sorted({topic for topic, _why in DIFFERENCES.values() if f"**{topic}**" not in section})
    assert not missing, f"docs/mavlink.md's differences do not list: {missing}"


# --------------------------------------------------------------------------- identity

def test_heartbeat_boot_texts_and_autopilot_version(pair: Pair):
    def probe(v: Vehicle) -> dict:
        assert wait_position(v), f"{v.name}: no position estimate"      # booted and settled
        hb = heartbeat(v)
        boot = [t for _s, t in texts(v.gs.log[:v.boot_log_end], noise=True)]
        out = {f"heartbeat.{f}": getattr(hb, f) for f in ("type", "autopilot", "base_mode", "custom_mode",
                                                            "system_status", "mavlink_version")}
        out["boot.text.ArduPilot Ready"] = "ArduPilot Ready" in boot
        result, msgs = command(v, M.MAV_CMD_REQUEST_MESSAGE, M.MAVLINK_MSG_ID_AUTOPILOT_VERSION)
        av = next((m for m in msgs if m.get_type() == "AUTOPILOT_VERSION"), None)
        out["autopilot_version.ack"] = result
        if av is not None:
            caps = [n[len("MAV_PROTOCOL_CAPABILITY_"):] for n in dir(M) if n.startswith("MAV_PROTOCOL_CAPABILITY_")
                    and n != "MAV_PROTOCOL_CAPABILITY_ENUM_END" and av.capabilities & getattr(M, n)]
            out["autopilot_version.capabilities"] = sorted(caps)
            sw = av.flight_sw_version
            out["autopilot_version.flight_sw_version"] = f"{sw >> 24}.{sw >> 16 & 255}.{sw >> 8 & 255} type {sw & 255}"
            custom = bytes(av.flight_custom_version).rstrip(b"\0").decode(errors="replace")
            out["autopilot_version.flight_custom_version"] = ("8 hex digits of a git hash"
                                                              if re.fullmatch(r"[0-9a-f]{8}", custom) else custom)
            for f in ("middleware_sw_version", "os_sw_version", "board_version", "vendor_id", "product_id", "uid"):
                out[f"autopilot_version.{f}"] = getattr(av, f)
            out["autopilot_version.uid2 set"] = any(av.uid2)
        result, msgs = command(v, M.MAV_CMD_DO_SEND_BANNER)
        banner = [t for _s, t in texts(msgs)]
        out["banner.ack"] = result
        out["banner.lines"] = len(banner)
        if banner:
            out["banner.version line"] = ("NAME Vx.y.z (8 hex digits)"
                                          if re.fullmatch(r"\S+ V\d+\.\d+\.\d+\S* \([0-9a-f]{8}\)", banner[0])
                                          else banner[0])
            out["banner.name"] = banner[0].split(" ")[0]
            out["banner.last line"] = banner[-1]
        return out
    pair.conform(*pair.ask(probe))


# --------------------------------------------------------------------------- parameters

SAFETY = ("FS_PILOT_INPUT", "FS_PILOT_TIMEOUT", "ARMING_CHECK", "FS_EKF_ACTION", "FS_EKF_THRESH", "SERVO9_FUNCTION",
          "SERVO10_FUNCTION", "FS_GCS_ENABLE", "FS_GCS_TIMEOUT", "FS_LEAK_ENABLE", "FRAME_CONFIG")
NAMES_OF_4_7 = ("MAV_SYSID", "MAV_GCS_SYSID", "SYSID_THISMAV", "SYSID_MYGCS", "SR0_EXTRA1", "MAV1_RAW_SENS",
                "MAV1_EXT_STAT", "MAV1_RC_CHAN", "MAV1_POSITION", "MAV1_EXTRA1", "MAV1_EXTRA2", "MAV1_EXTRA3",
                "MAV1_PARAMS", "SURFACE_DEPTH", "PILOT_SPEED_UP", "PILOT_SPEED_DN", "PILOT_ACCEL_Z", "WPNAV_SPEED",
                "ANGLE_MAX", "MNT1_TYPE", "MNT1_PITCH_MIN", "MNT1_PITCH_MAX", "COMPASS_USE", "COMPASS_OFS_X",
                "INS_GYROFFS_X", "INS_ACCSCAL_X", "FS_PRESS_ENABLE", "FS_PRESS_MAX", "FS_TEMP_ENABLE", "FS_TEMP_MAX",
                "FS_TERRAIN_ENAB", "JS_LIGHTS_STEPS", "JS_LIGHTS_STEP", "JS_CAM_TILT_STEP", "JS_GAIN_DEFAULT",
                "RC_OVERRIDE_TIME", "BATT_MONITOR", "BATT_CAPACITY", "BATT_VOLT_MULT", "BATT_AMP_PERVLT",
                "BATT_LOW_VOLT")


def test_safety_defaults_are_ardusubs(pair: Pair):
    a, w = pair.ask(lambda v: {f"param.{n}": val for n, val in read_params(v, SAFETY).items()})
    pair.conform(a, w)


def test_parameter_names_are_those_of_ardusub_4_7(pair: Pair):
    def probe(v: Vehicle) -> dict:
        got = read_params(v, NAMES_OF_4_7)
        out = {f"param.{n}": val for n, val in got.items()}
        since = v.gs.mark()
        v.gs.send(M.MAVLink_param_request_read_message(1, 1, b"MAV_GCS_SYSID", -1))
        m = v.gs.wait_type("PARAM_VALUE", timeout=v.wall(2.0), since=since)
        out["params.count"] = None if m is None else m.param_count
        return out
    pair.conform(*pair.ask(probe))


def test_the_whole_table_is_served_with_ardusubs_types_and_defaults(pair: Pair):
    """Wavekeep's full list against ArduSub's table (configs/firmware/ardusub_params.csv, read from this binary:
    :func:`test_the_reference_table_is_the_binarys` checks that it still is)."""
    ref = reference_table()
    served = read_param_list(pair.wavekeep)
    a = {"params.names": [], "params.types": {}, "params.values": {}}
    w = {"params.names": sorted(n for n in ref if n not in served), "params.types": {}, "params.values": {}}
    for n, (value, ptype) in ref.items():
        if n not in served:
            continue
        if served[n][1] != ptype:
            w["params.types"][n] = [ptype, served[n][1]]
        if not math.isclose(served[n][0], value, rel_tol=1e-6, abs_tol=1e-6):
            key = f"param.value.{n}"
            if documented(key):
                a[key], w[key] = value, served[n][0]
            else:
                w["params.values"][n] = [value, served[n][0]]
    pair.conform(a, w)


def test_the_reference_table_is_the_binarys(pair: Pair):
    """The stored table still says what the binary serves: a sample of names, their types and values, and the count."""
    ref = reference_table()
    sample = sorted(random.Random(29).sample(sorted(n for n in ref if not n.startswith(("STAT_", "BARO"))), 40))
    got = read_params(pair.ardusub, sample)
    bad = {n: [ref[n], got[n]] for n in sample if got[n] is None or not math.isclose(got[n][0], ref[n][0],
                                                                                  rel_tol=1e-6, abs_tol=1e-6)}
    assert not bad, f"configs/firmware/ardusub_params.csv is not what the binary serves: {bad}"


# --------------------------------------------------------------------------- what the vehicle says it has

def test_sys_status_sensor_bits(pair: Pair):
    names = {**bits("MAV_SYS_STATUS_SENSOR_"), **{M.MAV_SYS_STATUS_AHRS: "AHRS", M.MAV_SYS_STATUS_GEOFENCE: "GEOFENCE",
                                                   M.MAV_SYS_STATUS_LOGGING: "LOGGING",
                                                   M.MAV_SYS_STATUS_PREARM_CHECK: "PREARM_CHECK",
                                                   M.MAV_SYS_STATUS_REVERSE_MOTOR: "REVERSE_MOTOR",
                                                   M.MAV_SYS_STATUS_TERRAIN: "TERRAIN",
                                                   M.MAV_SYS_STATUS_OBSTACLE_AVOIDANCE: "OBSTACLE_AVOIDANCE"}}
    names[M.MAV_SYS_STATUS_SENSOR_3D_ACCEL] = "3D_ACCEL"    # (pymavlink also names 2 LEAK: an extended bit)

    def probe(v: Vehicle) -> dict:
        assert wait_position(v), f"{v.name}: no position estimate"
        s = v.gs.wait_type("SYS_STATUS", timeout=v.wall(2.0), since=v.gs.mark())
        out = {}
        for bit, name in names.items():
            flags = "".join(c if getattr(s, f"onboard_control_sensors_{f}") & bit else "-"
                            for c, f in (("P", "present"), ("E", "enabled"), ("H", "health")))
            if flags != "---":
                out[f"sys_status.{name}"] = flags
        return out
    a, w = pair.ask(probe)
    for d in (a, w):
        for k in set(a) | set(w):
            d.setdefault(k, "---")
    pair.conform(a, w)


def test_named_value_floats_for_qgcs_sub_panel(pair: Pair):
    def probe(v: Vehicle) -> dict:
        msgs = [m for m in listen(v, 6.0) if m.get_type() == "NAMED_VALUE_FLOAT"]
        by: dict[str, list] = {}
        for m in msgs:
            by.setdefault(m.name, []).append(m)
        out = {"named_value_float.names": sorted(n for n in by if not n.startswith(("FF_", "TICK_"))),
               "named_value_float.wavekeep's own": sorted(n for n in by if n.startswith(("FF_", "TICK_")))}
        for n, ms in by.items():
            if n.startswith(("FF_", "TICK_")):
                continue
            t = [m.time_boot_ms / 1000.0 for m in ms]
            out[f"named_value_float.{n}.rate_hz"] = round((len(t) - 1) / (t[-1] - t[0]) * 2) / 2 if len(t) > 2 else 0
            out[f"named_value_float.{n}.value"] = round(ms[-1].value, 3)
        return out
    pair.conform(*pair.ask(probe))


def test_streams_and_their_rates(pair: Pair):
    def probe(v: Vehicle) -> dict:
        msgs = listen(v, 8.0)
        clock = [i for i, m in enumerate(msgs) if m.get_type() == "SYSTEM_TIME"]
        inside = msgs[clock[0]:clock[-1]]              # between the first and the last SYSTEM_TIME: a known span
        span = (msgs[clock[-1]].time_boot_ms - msgs[clock[0]].time_boot_ms) / 1000.0
        counts: dict[str, int] = {}
        for m in inside:
            counts[m.get_type()] = counts.get(m.get_type(), 0) + 1
        out = {}
        for t, n in counts.items():
            if t in ("STATUSTEXT", "COMMAND_ACK", "PARAM_VALUE"):
                continue
            names = len({m.name for m in inside if m.get_type() == t}) if t == "NAMED_VALUE_FLOAT" else 1
            rate = n / span / names            # NAMED_VALUE_FLOAT: per name
            out[f"stream.{t}"] = round(rate) if rate >= 1.5 else round(rate * 2) / 2
        return out
    a, w = pair.ask(probe)
    for d in (a, w):
        for k in set(a) | set(w):
            d.setdefault(k, 0)
    pair.conform(a, w)


def test_gps_raw_int_and_ekf_status(pair: Pair):
    def probe(v: Vehicle) -> dict:
        g = v.gs.wait_type("GPS_RAW_INT", timeout=v.wall(2.0), since=v.gs.mark())
        e = v.gs.wait_type("EKF_STATUS_REPORT", timeout=v.wall(2.0), since=v.gs.mark())
        flags = sorted(n for bit, n in bits("EKF_").items() if bit and e.flags & bit and n not in ("UNINITIALIZED",))
        return {"gps_raw_int.fix_type": g.fix_type, "gps_raw_int.satellites_visible": g.satellites_visible,
                "gps_raw_int.has position": g.lat != 0, "ekf_status.flags": flags}
    pair.conform(*pair.ask(probe))


# --------------------------------------------------------------------------- modes

MODE_ORDER = (1, 7, 21, 20, 3, 99, 0, 2, 4, 16, 9, 19)


def test_mode_changes_and_their_feedback(pair: Pair):
    def probe(v: Vehicle) -> dict:
        assert wait_position(v), f"{v.name}: no position estimate"
        out = {}
        for mode in MODE_ORDER:
            out[f"SET_MODE {MODE_NAMES[mode]}"] = set_mode(v, mode)
            to_manual(v)
            v.wait(0.5)
        for mode in (3, 99, 16):
            result, msgs = command(v, M.MAV_CMD_DO_SET_MODE, M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, mode)
            out[f"DO_SET_MODE {MODE_NAMES[mode]}"] = {"ack": result, "texts": texts(msgs)}
            to_manual(v)
        result, msgs = command(v, M.MAV_CMD_DO_SET_MODE, 0, 16)
        out["DO_SET_MODE without the custom-mode flag"] = {"ack": result, "mode": heartbeat(v).custom_mode}
        to_manual(v)
        return out
    pair.conform(*pair.ask(probe))


# --------------------------------------------------------------------------- arming, home, failsafes

def test_arming_moves_home_and_pushes_it(pair: Pair):
    def probe(v: Vehicle) -> dict:
        assert wait_position(v)
        pos = v.gs.wait_type("GLOBAL_POSITION_INT", timeout=v.wall(2.0), since=v.gs.mark())
        result, msgs = command(v, M.MAV_CMD_COMPONENT_ARM_DISARM, 1)
        ack_at = next((i for i, m in enumerate(msgs) if m.get_type() == "COMMAND_ACK"), len(msgs))
        after = msgs[ack_at:]
        home = next((m for m in after if m.get_type() == "HOME_POSITION"), None)
        out = {"arm.ack": result, "arm.texts": texts(msgs),
               "arm.pushes HOME_POSITION": home is not None,
               "arm.pushes GPS_GLOBAL_ORIGIN": any(m.get_type() == "GPS_GLOBAL_ORIGIN" for m in after)}
        if home is not None:
            out["home.at the arming spot (1 m)"] = (abs(home.latitude - pos.lat) * 0.0111 < 1.0
                                                    and abs(home.altitude - pos.alt) < 1000)
            out["home.q"] = "NaN" if all(math.isnan(q) for q in home.q) else list(home.q)
        result, msgs = command(v, M.MAV_CMD_COMPONENT_ARM_DISARM, 0)
        out["disarm.ack"], out["disarm.texts"] = result, texts(msgs)
        return out
    pair.conform(*pair.ask(probe))


def test_gcs_failsafe_texts_and_severities(pair: Pair):
    def probe(v: Vehicle) -> dict:
        # ArduSub counts its 30 s between "heartbeat lost" texts from boot: the first can come only after
        # 30 s of vehicle time, so both vehicles go silent past it (on a loaded machine one boots later)
        while (v.clock(len(v.gs.log)) or 0.0) < 31.0:
            v.wait(1.0)
        to_manual(v)
        assert v.gs.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1, timeout=v.wall(2.0)).result == 0
        v.wait(1.0)
        v.gs.heartbeats(False)
        try:
            first = v.wait(8.0)                 # FS_GCS_TIMEOUT 5 s: the first text comes in these 8 s
            # the next 22 s end 30 s after the silence began, 25 s after the first text at the earliest: no
            # repeat there (every 30 s), with room for a loaded machine's clocks
            later = v.wait(22.0)
            since = v.gs.mark()
        finally:
            v.gs.heartbeats(True)
        v.wait(2.0)
        back = v.gs.log[since:]
        hb = [m for m in first if m.get_type() == "HEARTBEAT"]
        out = {"gcs_failsafe.texts": texts(first),
               "gcs_failsafe.armed after": bool(hb and hb[-1].base_mode & M.MAV_MODE_FLAG_SAFETY_ARMED),
               "gcs_failsafe.repeated within 30 s": texts(later),
               "gcs_failsafe.on recovery": texts(back)}
        disarm(v)
        return out
    pair.conform(*pair.ask(probe))


def test_pilot_input_failsafe(pair: Pair):
    """Joystick stream stopped while armed. ArduSub's SITL build leaves this failsafe out (its code is
    compiled only for a real board), so the binary stays armed; Wavekeep acts as ArduSub on a vehicle."""
    def probe(v: Vehicle) -> dict:
        to_manual(v)
        assert v.gs.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1, timeout=v.wall(2.0)).result == 0
        for _ in range(20):                     # 2 s of sticks at 10 Hz of vehicle time
            v.gs.send(M.MAVLink_manual_control_message(1, 0, 0, 500, 0, 0))
            v.wait(0.1)
        msgs = v.wait(5.0)                      # FS_PILOT_TIMEOUT 3 s
        hb = [m for m in msgs if m.get_type() == "HEARTBEAT"]
        out = {"pilot_failsafe.texts": texts(msgs),
               "pilot_failsafe.armed after": bool(hb and hb[-1].base_mode & M.MAV_MODE_FLAG_SAFETY_ARMED)}
        disarm(v)
        return out
    pair.conform(*pair.ask(probe))


# --------------------------------------------------------------------------- commands, missions, parameters set

def test_commands_missions_and_parameter_sets(pair: Pair):
    def probe(v: Vehicle) -> dict:
        out = {}
        gs = v.gs
        since = gs.mark()
        gs.send(M.MAVLink_mission_request_list_message(1, 1, 0))
        count = gs.wait_type("MISSION_COUNT", timeout=v.wall(2.0), since=since)
        out["mission.count"] = None if count is None else count.count
        since = gs.mark()
        gs.send(M.MAVLink_mission_request_int_message(1, 1, 0, 0))
        item = gs.wait_type("MISSION_ITEM_INT", timeout=v.wall(2.0), since=since)
        out["mission.item 0"] = None if item is None else [item.frame, item.command, item.autocontinue]
        gs.send(M.MAVLink_mission_ack_message(1, 1, 0, 0))
        result, msgs = command(v, M.MAV_CMD_DO_MOTOR_TEST, 1, 1, 1600, 0.2)
        out["motor_test disarmed"] = [result, texts(msgs)]
        result, msgs = command(v, M.MAV_CMD_PREFLIGHT_CALIBRATION, 0, 0, 1)
        out["pressure calibration disarmed"] = [result, texts(msgs + v.wait(3.0))]
        result, msgs = command(v, 31999)
        out["unknown command"] = [result, texts(msgs)]
        result, msgs = command(v, M.MAV_CMD_SET_MESSAGE_INTERVAL, 12000, 100000)
        out["SET_MESSAGE_INTERVAL unknown id"] = [result, texts(msgs)]
        result, msgs = command(v, M.MAV_CMD_GET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_ATTITUDE)
        mi = next((m for m in msgs if m.get_type() == "MESSAGE_INTERVAL"), None)
        out["GET_MESSAGE_INTERVAL ATTITUDE"] = [result, None if mi is None else mi.interval_us]
        result, msgs = command(v, M.MAV_CMD_REQUEST_MESSAGE, M.MAVLINK_MSG_ID_EXTENDED_SYS_STATE)
        ess = next((m for m in msgs if m.get_type() == "EXTENDED_SYS_STATE"), None)
        out["EXTENDED_SYS_STATE"] = [result, None if ess is None else ess.landed_state]
        for label, name, value in (("PARAM_SET accepted", "JS_GAIN_DEFAULT", 0.6),
                                   ("PARAM_SET NaN", "JS_GAIN_DEFAULT", float("nan")),
                                   ("PARAM_SET out of range", "JS_GAIN_DEFAULT", 7.0),
                                   ("PARAM_SET of one that means nothing here", "COMPASS_OFS_X", 5.0),
                                   ("PARAM_SET unknown name", "NO_SUCH_PARAM", 1.0)):
            since = gs.mark()
            gs.send(M.MAVLink_param_set_message(1, 1, name.encode(), value, M.MAV_PARAM_TYPE_REAL32))
            msgs = v.wait(2.0)            # an answer comes within a tick; 2 s leave room for a loaded machine
            pv = [m for m in msgs if m.get_type() == "PARAM_VALUE" and m.param_id == name]
            out[label] = {"texts": texts(msgs),
                          "answer": None if not pv else [round(pv[-1].param_value, 4), pv[-1].param_index
                                                         if pv[-1].param_index == 65535 else "its index"]}
        gs.send(M.MAVLink_param_set_message(1, 1, b"JS_GAIN_DEFAULT", 0.5, M.MAV_PARAM_TYPE_REAL32))
        v.wait(0.5)
        return out
    pair.conform(*pair.ask(probe))


# --------------------------------------------------------------------------- third-party clients

@pytest.mark.skipif(mavsdk_server() is None, reason="MAVSDK-Python (mavsdk<4, with mavsdk_server) not installed")
def test_mavsdk_health_and_parameters(pair: Pair, tmp_path):
    def probe(v: Vehicle) -> dict:
        from mavsdk import System
        grpc = free_port(__import__("socket").SOCK_STREAM)
        log = (tmp_path / f"mavsdk-{v.name}.log").open("w")
        server = subprocess.Popen([mavsdk_server(), "-p", str(grpc), "--sysid", "255", v.notes["mavsdk"]],
                                  stdout=log, stderr=subprocess.STDOUT)

        async def session() -> dict:
            drone = System(mavsdk_server_address="127.0.0.1", port=grpc)
            await drone.connect()
            async for state in drone.core.connection_state():
                if state.is_connected:
                    break
            got: dict = {}

            async def health_all_ok():
                async for ok in drone.telemetry.health_all_ok():
                    if ok:
                        return True
            try:
                got["mavsdk.health_all_ok"] = await asyncio.wait_for(health_all_ok(), v.wall(20.0))
            except TimeoutError:
                h = await anext(drone.telemetry.health())
                got["mavsdk.health_all_ok"] = False
                got["mavsdk.health"] = {k: getattr(h, k) for k in dir(h) if k.startswith("is_")}
            for name in ("MAV_GCS_SYSID", "MAV_SYSID", "SYSID_MYGCS"):
                try:
                    got[f"mavsdk.get_param_int {name}"] = await asyncio.wait_for(drone.param.get_param_int(name),
                                                                                  v.wall(10.0))
                except Exception as exc:       # a parameter the vehicle does not have
                    got[f"mavsdk.get_param_int {name}"] = type(exc).__name__
            return got
        try:
            return asyncio.run(asyncio.wait_for(session(), 90.0))
        finally:
            server.terminate()
            server.wait(10)
            log.close()
    pair.conform(*pair.ask(probe))


@pytest.mark.skipif(not dronekit_installed(),
                    reason="dronekit2 not installed (dronekit 2.9 does not import on Python 3.11)")
def test_dronekit_identity(pair: Pair):
    def probe(v: Vehicle) -> dict:
        from dronekit import connect
        vehicle = connect(v.notes["dronekit"], wait_ready=["autopilot_version", "gps_0", "armed", "mode", "attitude"],
                          timeout=60, heartbeat_timeout=30, source_system=255)
        try:
            ver = vehicle.version
            caps = vehicle.capabilities
            return {"dronekit.version": [ver.major, ver.minor, ver.patch, ver.release_type()],
                    "dronekit.is_stable": ver.is_stable(),
                    "dronekit.capabilities": {k: getattr(caps, k) for k in ("mission_float", "param_float",
                                                                            "mission_int", "command_int",
                                                                            "ftp", "set_attitude_target",
                                                                            "set_attitude_target_local_ned",
                                                                            "set_altitude_target_global_int",
                                                                            "terrain",
                                                                            "compass_calibration")},
                    "dronekit.mode": vehicle.mode.name, "dronekit.gps fix": vehicle.gps_0.fix_type}
        finally:
            vehicle.close()
    pair.conform(*pair.ask(probe))
