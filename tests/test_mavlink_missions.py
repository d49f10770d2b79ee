"""The mission protocol against a live vehicle: upload, download, home at seq 0, guided goto, MISSION_CURRENT."""
from __future__ import annotations

import math
import os
import time

import pytest

os.environ["MAVLINK20"] = "1"
# fixtures, one live vehicle per module
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from firmware_py.modes import Mode

M = mavlink
GCS = (1, 1)            # the vehicle's sysid / compid, as a target


def waypoint(seq: int, lat: float, lon: float, alt: float, current: int = 0, as_int: bool = True):
    if as_int:
        return M.MAVLink_mission_item_int_message(*GCS, seq, M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                                                  M.MAV_CMD_NAV_WAYPOINT, current, 1, 0, 0, 0, 0,
                                                  int(round(lat * 1e7)), int(round(lon * 1e7)), alt)
    return M.MAVLink_mission_item_message(*GCS, seq, M.MAV_FRAME_GLOBAL_RELATIVE_ALT, M.MAV_CMD_NAV_WAYPOINT,
                                          current, 1, 0, 0, 0, 0, lat, lon, alt)


def upload(gs, items: list, as_int: bool = True):
    """Upload ``items`` (seq 0 = home) answering each MISSION_REQUEST(_INT); returns the final MISSION_ACK."""
    since = gs.mark()
    gs.send(M.MAVLink_mission_count_message(*GCS, len(items), 0))
    for _ in items:
        req = gs.wait(lambda m: m.get_type() in ("MISSION_REQUEST", "MISSION_REQUEST_INT", "MISSION_ACK"),
                      timeout=3.0, since=since)
        assert req is not None and req.get_type() != "MISSION_ACK", req
        since = gs.log.index(req) + 1
        gs.send(waypoint(req.seq, *items[req.seq], as_int=as_int))
    return gs.wait_type("MISSION_ACK", timeout=3.0, since=since)


def download(gs) -> list:
    since = gs.mark()
    gs.send(M.MAVLink_mission_request_list_message(*GCS, 0))
    count = gs.wait_type("MISSION_COUNT", timeout=3.0, since=since).count
    got = []
    for seq in range(count):
        since = gs.mark()
        gs.send(M.MAVLink_mission_request_int_message(*GCS, seq, 0))
        got.append(gs.wait_type("MISSION_ITEM_INT", lambda m, seq=seq: m.seq == seq, timeout=3.0, since=since))
    gs.send(M.MAVLink_mission_ack_message(*GCS, M.MAV_MISSION_ACCEPTED, 0))
    return got


def test_upload_then_download_with_home_at_seq_0(v):
    gs, p = v.gs, v.fw.params
    lat0, lon0 = p["WK_ORIGIN_LAT"], p["WK_ORIGIN_LON"]
    home = download(gs)
    assert len(home) == 1 and (home[0].x, home[0].y, home[0].z) == (round(lat0 * 1e7), round(lon0 * 1e7), 0.0)
    items = [(0.0, 0.0, 0.0), (lat0 + 1e-5, lon0, -3.0), (lat0 + 2e-5, lon0 + 1e-5, -4.5)]
    ack = upload(gs, items)
    assert ack.type == M.MAV_MISSION_ACCEPTED and (ack.target_system, ack.target_component) == (255, 190)
    got = download(gs)
    assert [m.seq for m in got] == [0, 1, 2]
    assert got[0].x == round(lat0 * 1e7)                                    # home stays the origin
    for m, (lat, lon, alt) in zip(got[1:], items[1:], strict=False):
        assert (m.x, m.y, m.z, m.command) == (round(lat * 1e7), round(lon * 1e7), alt, M.MAV_CMD_NAV_WAYPOINT)
    # MISSION_CURRENT streams with the mission's size; the float protocol works too (with ArduPilot's warning)
    cur = gs.wait_type("MISSION_CURRENT", lambda m: m.total == 3, timeout=3.0)
    assert cur is not None and cur.seq == 0
    since = gs.mark()
    assert upload(gs, items[:2], as_int=False).type == M.MAV_MISSION_ACCEPTED
    assert gs.wait_type("STATUSTEXT", lambda m: "MISSION_ITEM_INT" in m.text, timeout=2.0, since=since)
    gs.send(M.MAVLink_mission_request_message(*GCS, 1, 0))
    item = gs.wait_type("MISSION_ITEM", lambda m: m.seq == 1, timeout=3.0)
    assert item.x == pytest.approx(items[1][0], abs=1e-6) and item.z == -3.0
    # Clear all: home only
    gs.send(M.MAVLink_mission_clear_all_message(*GCS, 0))
    assert gs.wait_type("MISSION_ACK", timeout=3.0).type == M.MAV_MISSION_ACCEPTED
    assert len(download(gs)) == 1


def test_upload_errors_are_answered_and_survived(v):
    gs = v.gs
    lat0, lon0 = v.fw.params["WK_ORIGIN_LAT"], v.fw.params["WK_ORIGIN_LON"]
    # An unknown seq is answered with the count, then INVALID_SEQUENCE
    since = gs.mark()
    gs.send(M.MAVLink_mission_request_int_message(*GCS, 40, 0))
    assert gs.wait_type("MISSION_COUNT", lambda m: m.count == 1, timeout=3.0, since=since) is not None
    assert gs.wait_type("MISSION_ACK", timeout=3.0, since=since).type == M.MAV_MISSION_INVALID_SEQUENCE
    # Out of order during an upload: INVALID_SEQUENCE, and the upload goes on
    since = gs.mark()
    gs.send(M.MAVLink_mission_count_message(*GCS, 2, 0))
    assert gs.wait_type("MISSION_REQUEST", lambda m: m.seq == 0, timeout=3.0, since=since) is not None
    gs.send(waypoint(1, lat0, lon0, -1.0))
    assert gs.wait_type("MISSION_ACK", timeout=3.0, since=since).type == M.MAV_MISSION_INVALID_SEQUENCE
    # A download meanwhile is refused; the vehicle re-requests the missing item after a second
    since = gs.mark()
    gs.send(M.MAVLink_mission_request_list_message(*GCS, 0))
    assert gs.wait_type("MISSION_ACK", timeout=3.0, since=since).type == M.MAV_MISSION_DENIED
    assert gs.wait_type("MISSION_REQUEST", lambda m: m.seq == 0, timeout=3.0, since=since) is not None
    since = gs.mark()
    gs.send(waypoint(0, 0, 0, 0))
    gs.send(waypoint(1, lat0, lon0, -1.0))
    assert gs.wait_type("MISSION_ACK", timeout=3.0, since=since).type == M.MAV_MISSION_ACCEPTED
    # Too many items, other mission types, NaN positions: answered, never a crash
    since = gs.mark()
    gs.send(M.MAVLink_mission_count_message(*GCS, 65535, 0))
    assert gs.wait_type("MISSION_ACK", timeout=3.0, since=since).type == M.MAV_MISSION_NO_SPACE
    since = gs.mark()
    gs.send(M.MAVLink_mission_count_message(*GCS, 3, M.MAV_MISSION_TYPE_FENCE))
    assert gs.wait_type("MISSION_ACK", timeout=3.0, since=since).type == M.MAV_MISSION_UNSUPPORTED
    since = gs.mark()
    gs.send(waypoint(0, math.nan, math.inf, math.nan, current=2, as_int=False))
    assert gs.wait_type("MISSION_ACK", timeout=3.0, since=since) is not None
    assert v.link.counters["handler_errors"] == 0 and v.link.alive


def test_mission_item_current_2_is_a_guided_goto(v):
    gs, fw = v.gs, v.fw
    lat0, lon0 = fw.params["WK_ORIGIN_LAT"], fw.params["WK_ORIGIN_LON"]
    x0, z0 = (float(c) for c in fw.last.x_hat[:2])
    goal_x, goal_depth = x0 + 0.5, z0 + 0.3
    lat = lat0 + math.degrees(goal_x / 6378137.0)
    # Outside GUIDED: refused as ArduSub refuses (MISSION_ACK ERROR), target unchanged
    sp, stored = fw.setpoint.copy(), v.link.missions.count
    since = gs.mark()
    gs.send(waypoint(0, lat, lon0, -goal_depth, current=2))
    assert gs.wait_type("MISSION_ACK", timeout=3.0, since=since).type == M.MAV_MISSION_ERROR
    assert (fw.setpoint == sp).all()
    assert gs.command(M.MAV_CMD_DO_SET_MODE, 1, Mode.GUIDED).result == 0
    since = gs.mark()
    gs.send(waypoint(0, lat, lon0, -goal_depth, current=2))
    assert gs.wait_type("MISSION_ACK", timeout=3.0, since=since).type == M.MAV_MISSION_ACCEPTED
    end = time.monotonic() + 2.0
    while time.monotonic() < end and abs(fw.setpoint[1] - goal_depth) > 1e-3:
        time.sleep(0.05)
    assert fw.setpoint[:2].tolist() == pytest.approx([goal_x, goal_depth], abs=0.02)
    # The stored mission is not touched by a guided goto
    assert v.link.missions.count == stored
