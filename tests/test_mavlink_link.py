"""The link itself: garbage and floods, endpoints, signing, and an unmodified MAVProxy, on 127.0.0.1."""
from __future__ import annotations

import math
import os
import random
import re
import socket
import subprocess
import sys
import threading
import time

import pytest

os.environ["MAVLINK20"] = "1"
# fixtures, one live vehicle per module
from mavlink_gcs import GroundStation, frame, free_port, mavproxy_available
from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from firmware_py.mavlink import MavlinkLink, load_signing_key
from firmware_py.modes import MAV_RESULT, Mode
from firmware_py.params.table import load_params
from sitl.harness.live import LiveSim
from sitl.harness.spec import RunSpec

# --------------------------------------------------------------------------- robustness

def test_garbage_truncated_and_hostile_values_are_counted_and_survived(v, fast_heartbeat):
    gs, link = v.gs, v.link
    rng = random.Random(1)
    c0, s0 = dict(link.counters), v.stats()
    raw = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    valid = frame(mavlink.MAVLink_command_long_message(1, 1, mavlink.MAV_CMD_DO_SET_MODE, 0, 1, 16, 0, 0, 0, 0, 0))
    bad_crc = bytearray(valid)
    bad_crc[-1] ^= 0xFF
    unknown_id = bytes([0xFD, 4, 0, 0, 0, 255, 190, 0xDE, 0xBC, 0x0A]) + b"\1\2\3\4" + b"\0\0"
    junk = [rng.randbytes(rng.randint(1, 300)) for _ in range(40)]
    junk += [valid[:k] for k in range(1, len(valid))]               # every truncation of a valid frame
    junk += [bytes(bad_crc), b"\xfd\xff" + rng.randbytes(20), b"\xfe\x05" + bytes(10), unknown_id,
             b"\xfd" * 600, bytes(valid[:-3]) + valid]
    for j in junk:
        raw.sendto(j, ("127.0.0.1", v.in_port))                    # the vehicle's udpin endpoint
        gs.send_raw(j)                                              # and its udpout endpoint
    raw.close()
    # Well-formed messages with hostile values
    nan, inf = math.nan, math.inf
    assert gs.command(mavlink.MAV_CMD_DO_SET_MODE, 1, nan).result == MAV_RESULT.FAILED
    assert gs.command(mavlink.MAV_CMD_DO_SET_MODE, inf, 1e30).result == MAV_RESULT.FAILED
    assert gs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, nan).result == MAV_RESULT.UNSUPPORTED
    assert gs.command(mavlink.MAV_CMD_DO_MOTOR_TEST, inf, 1, nan, -inf).result == MAV_RESULT.FAILED
    assert gs.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 1e30, 1e30).result == MAV_RESULT.DENIED
    assert gs.command(mavlink.MAV_CMD_REQUEST_MESSAGE, -inf).result == MAV_RESULT.FAILED
    assert gs.command(mavlink.MAV_CMD_DO_SET_MODE, 1, 2**40, use_int=True).result == MAV_RESULT.FAILED
    gs.send(mavlink.MAVLink_manual_control_message(1, -32768, 32767, -32768, 32767, 65535))
    gs.send(mavlink.MAVLink_rc_channels_override_message(1, 1, *([65534] * 8)))
    gs.send(mavlink.MAVLink_request_data_stream_message(1, 1, 200, 65535, 1))
    gs.send(mavlink.MAVLink_request_data_stream_message(1, 1, 1, 65535, 7))
    gs.send(mavlink.MAVLink_param_request_read_message(1, 1, b"\xff\xfe\x00", 30000))
    gs.send(mavlink.MAVLink_param_set_message(1, 1, b"\xff\xfe\xfd", inf, 200))
    gs.send(mavlink.MAVLink_mission_request_list_message(1, 1, 0))
    assert gs.wait_type("MISSION_COUNT", lambda m: m.count == 1, timeout=2.0) is not None     # home only
    # Still the same vehicle: alive, responsive, on time
    assert gs.command(mavlink.MAV_CMD_DO_SET_MODE, 1, Mode.POSHOLD).result == 0
    assert gs.heartbeat(lambda m: m.custom_mode == Mode.POSHOLD) is not None
    s1, c1 = v.stats(), link.counters
    assert link.alive
    assert c1["rx_bad"] - c0["rx_bad"] >= 2 * 40                   # every junk datagram counted, on both sockets
    assert c1["rx_unsupported"] > c0["rx_unsupported"]
    assert c1["handler_errors"] == c0["handler_errors"] and c1["io_errors"] == c0["io_errors"]
    assert s1["tasks"]["gcs"]["errors"] == 0 and s1["overruns"] - s0["overruns"] <= 3
    assert v.fw.params["MAV1_RAW_SENS"] == v.defaults["MAV1_RAW_SENS"]      # start_stop 7: ignored


def test_flood_keeps_the_loop_on_time(v):
    """About 3000 messages in one second from a second GCS: the vehicle keeps 20 Hz and its heartbeat."""
    link = v.link
    flood = mavutil.mavlink_connection(f"udpout:127.0.0.1:{v.in_port}", source_system=255, source_component=191,
                                       dialect="ardupilotmega")
    kinds = [mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_GCS, 8, 0, 0, 0, 3),
             mavlink.MAVLink_manual_control_message(1, 0, 0, 500, 0, 0),
             mavlink.MAVLink_command_long_message(1, 1, 31337, 0, 0, 0, 0, 0, 0, 0, 0),
             mavlink.MAVLink_param_request_read_message(1, 1, b"", 5),
             mavlink.MAVLink_timesync_message(0, 1),
             mavlink.MAVLink_system_time_message(0, 0)]
    sent = [0]

    def blast():
        t0 = time.monotonic()
        for burst in range(100):                                   # 100 bursts of 30, one every 10 ms
            for i in range(30):
                flood.mav.send(kinds[(burst + i) % len(kinds)])
                sent[0] += 1
            delay = t0 + (burst + 1) * 0.01 - time.monotonic()
            if delay > 0:
                time.sleep(delay)

    s0, c0 = v.stats(), dict(link.counters)
    t0 = time.monotonic()
    th = threading.Thread(target=blast)
    th.start()
    msgs = v.gs.collect(3.0)
    th.join()
    elapsed = time.monotonic() - t0
    s1, c1 = v.stats(), link.counters
    flood.close()
    assert sent[0] == 3000
    assert c1["rx"] - c0["rx"] >= 1500                     # most of it arrived (UDP may drop some)
    hb = [m._t for m in msgs if m.get_type() == "HEARTBEAT"]
    assert len(hb) >= 2 and max(b - a for a, b in zip([t0, *hb], [*hb, time.monotonic()], strict=False)) < 2.0
    assert s1["ticks"] - s0["ticks"] >= 0.85 * 20 * elapsed                         # 20 Hz kept
    assert s1["overruns"] - s0["overruns"] <= 3
    assert s1["tasks"]["gcs"]["compute"]["p50_us"] < 5000
    assert link.alive and v.gs.command(mavlink.MAV_CMD_REQUEST_MESSAGE, 148).result == 0

# --------------------------------------------------------------------------- endpoints

def test_a_second_endpoint_gets_its_own_replies(v):
    gs2 = GroundStation(f"udpout:127.0.0.1:{v.in_port}", sysid=254, compid=1)
    try:
        gs2.send(mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_GCS, 8, 0, 0, 0, 3))
        assert gs2.heartbeat() is not None                          # udpin replies once spoken to
        v.gs.drain()
        ack = gs2.command(mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION)
        assert ack.result == 0 and ack.target_system == 254
        assert gs2.wait_type("AUTOPILOT_VERSION") is not None
        assert not [m for m in v.gs.collect(0.5) if m.get_type() in ("COMMAND_ACK", "AUTOPILOT_VERSION")]
        # Pilot input from a system that is not MAV_GCS_SYSID is refused
        before = v.link.counters["rx_ignored"]
        gs2.send(mavlink.MAVLink_manual_control_message(1, 1000, 0, 500, 0, 0))
        time.sleep(0.4)
        assert v.link.counters["rx_ignored"] == before + 1
    finally:
        gs2.close()


def test_tcp_server_endpoint_with_the_loop_driven_by_hand():
    """``tcpin:`` with a pymavlink ``tcp:`` client; the link's task is called as a scheduler would."""
    from sitl.harness.run import build_mission
    m = build_mission(RunSpec("W1", "cpd"), params=load_params())
    port = free_port(socket.SOCK_STREAM)
    link = MavlinkLink(m.firmware, [f"tcpin:127.0.0.1:{port}"]).start()
    client = None
    try:
        client = GroundStation(f"tcp:127.0.0.1:{port}")
        stop = threading.Event()

        def fly():
            while not stop.is_set():
                slot = m.firmware.scheduler.next_slot_ns()
                m.firmware.scheduler.run_tick()
                m.hal.step_world()
                link.update(slot)
                time.sleep(0.01)

        th = threading.Thread(target=fly, daemon=True)
        th.start()
        try:
            hb = client.heartbeat(timeout=5.0)
            assert hb is not None and hb.type == mavlink.MAV_TYPE_SUBMARINE
            assert client.command(mavlink.MAV_CMD_DO_SET_MODE, 1, Mode.ALT_HOLD).result == 0
            assert client.heartbeat(lambda h: h.custom_mode == Mode.ALT_HOLD) is not None
        finally:
            stop.set()
            th.join()
    finally:
        if client is not None:
            client.close()
        link.stop()
    assert not link.alive

def test_bad_construction_is_refused():
    from sitl.harness.run import build_mission
    fw = build_mission(RunSpec("W1", "cpd"), params=load_params()).firmware
    for bad in ("serial:/dev/ttyS0", "udpout:127.0.0.1", "udpin:host:port", "tcp::5760", "udpout:127.0.0.1:0"):
        with pytest.raises(ValueError):
            MavlinkLink(fw, [bad])
    with pytest.raises(ValueError):
        MavlinkLink(fw, ["udpout:127.0.0.1:14550"], signing_key=b"short")
    port = free_port()
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as busy:
        busy.bind(("127.0.0.1", port))
        with pytest.raises(OSError, match=f"udpin:127.0.0.1:{port}"):
            MavlinkLink(fw, [f"udpin:127.0.0.1:{port}"])


# --------------------------------------------------------------------------- signing

def test_load_signing_key(tmp_path):
    key = bytes(range(32))
    for name, data in (("raw", key), ("hex", key.hex().encode() + b"\n"),
                       ("b64", __import__("base64").b64encode(key) + b"\n")):
        (tmp_path / name).write_bytes(data)
        assert load_signing_key(tmp_path / name) == key
    (tmp_path / "bad").write_text("not a key\n")
    with pytest.raises(ValueError, match="32 raw bytes, 64 hex digits or base64"):
        load_signing_key(tmp_path / "bad")
    with pytest.raises(OSError):
        load_signing_key(tmp_path / "missing")


def test_signing_rejects_unsigned_and_wrongly_signed_commands():
    key = bytes(range(1, 33))
    gcs_port = free_port()
    gs = GroundStation(f"udpin:127.0.0.1:{gcs_port}")
    sim = LiveSim(RunSpec("W1", "cpd"), mavlink=[f"udpout:127.0.0.1:{gcs_port}"], signing_key=key).start()
    try:
        assert gs.heartbeat(timeout=10.0) is not None          # signed, but readable without the key
        request = (mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION)
        assert gs.command(*request, timeout=1.5) is None        # unsigned: dropped
        assert sim.link.counters["rx_unsigned"] >= 1
        gs.conn.setup_signing(bytes(32), sign_outgoing=True)   # the wrong key: dropped too
        before = sim.link.counters["rx_unsigned"]
        assert gs.command(*request, timeout=1.5) is None
        assert sim.link.counters["rx_unsigned"] > before
        gs.conn.setup_signing(key, sign_outgoing=True)          # the right key
        ack = gs.command(*request)
        assert ack is not None and ack.result == MAV_RESULT.ACCEPTED
        hb = gs.heartbeat()
        assert hb.get_signed()                                  # the vehicle signs what it sends
        assert sim.link.counters["rx_bad"] == 0
    finally:
        gs.close()
        sim.stop()


# --------------------------------------------------------------------------- MAVProxy acceptance

@pytest.mark.processes
@pytest.mark.skipif(not mavproxy_available(),
                    reason="MAVProxy not installed (pip install --no-deps MAVProxy pyserial)")
def test_unmodified_mavproxy_flies_the_sub(tmp_path):
    """Headless MAVProxy: sees a Sub with ArduSub's mode names, switches to POSHOLD, arms, lists and sets
    parameters, and sees SERVO_OUTPUT_RAW move."""
    port = free_port()
    sim = LiveSim(RunSpec("W1", "cpd_ff"), mavlink=[f"udpout:127.0.0.1:{port}"]).start()
    proc = subprocess.Popen([sys.executable, "-m", "MAVProxy.mavproxy", f"--master=udpin:127.0.0.1:{port}",
                             "--no-state", "--default-modules=param,mode,arm,cmdlong,misc,relay,rc"],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            cwd=tmp_path, env={**os.environ, "PYTHONUNBUFFERED": "1"})
    lines: list[str] = []
    reader = threading.Thread(target=lambda: lines.extend(proc.stdout), daemon=True)
    reader.start()

    def expect(pattern: str, timeout: float = 10.0, since: int = 0) -> re.Match:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            for line in lines[since:]:
                if (m := re.search(pattern, line)) is not None:
                    return m
            time.sleep(0.05)
        raise AssertionError(f"MAVProxy never printed /{pattern}/; it printed:\n" + "".join(lines[-40:]))

    def do(command: str, pattern: str, timeout: float = 10.0) -> re.Match:
        since = len(lines)
        proc.stdin.write(command + "\n")
        proc.stdin.flush()
        return expect(pattern, timeout, since)

    try:
        expect(r"Detected vehicle 1:1")
        expect(rf"Received {len(sim.firmware.params)} parameters", timeout=15.0)     # the whole list
        modes = do("mode", r"Available modes: (.*)")                    # ArduSub's mode names: a Sub
        assert {"MANUAL", "POSHOLD", "ALT_HOLD", "SURFACE", "STABILIZE", "GUIDED"} <= set(re.findall(r"\w+", modes[1]))
        assert do("status HEARTBEAT", r"HEARTBEAT \{type : (\d+)")[1] == str(mavlink.MAV_TYPE_SUBMARINE)
        assert float(do("param show WK_FF_GAIN", r"WK_FF_GAIN\s+([-\d.]+)")[1]) == 1.0
        proc.stdin.write("param set WK_FF_GAIN 0.5\n")
        proc.stdin.flush()
        end = time.monotonic() + 5
        while sim.firmware.params["WK_FF_GAIN"] != 0.5 and time.monotonic() < end:
            time.sleep(0.05)
        assert sim.firmware.params["WK_FF_GAIN"] == 0.5
        assert float(do("param show WK_FF_GAIN", r"WK_FF_GAIN\s+([-\d.]+)")[1]) == 0.5
        before = do("status SERVO_OUTPUT_RAW", r"SERVO_OUTPUT_RAW \{(.*)\}")[1]
        assert re.findall(r"servo[1-8]_raw : (\d+)", before) == ["1500"] * 8
        do("mode POSHOLD", r"POSHOLD>")
        do("arm throttle", r"ARMED")
        assert sim.firmware.mode == Mode.POSHOLD and sim.firmware.armed
        end, moved = time.monotonic() + 10, False
        while not moved and time.monotonic() < end:
            time.sleep(0.5)
            after = do("status SERVO_OUTPUT_RAW", r"SERVO_OUTPUT_RAW \{(.*)\}")[1]
            moved = any(int(p) != 1500 for p in re.findall(r"servo[1-8]_raw : (\d+)", after))
        assert moved, after
        # Commands a BlueROV2 pilot types, each answered as ArduSub answers them
        assert do("motortest 1 1 1600 1", r"Got COMMAND_ACK: DO_MOTOR_TEST: (\w+)")[1] == "ACCEPTED"
        assert do("long DO_SET_SERVO 9 1700", r"Got COMMAND_ACK: DO_SET_SERVO: (\w+)")[1] == "ACCEPTED"
        do("mode MANUAL", r"MANUAL>")
        proc.stdin.write("rc 5 1800\n")       # forward stick, as an RC override
        proc.stdin.flush()
        end = time.monotonic() + 5
        while sim.firmware.pilot.surge <= 0.0 and time.monotonic() < end:
            time.sleep(0.05)
        assert sim.firmware.pilot.surge > 0.0
        assert not any("fence breach" in line.lower() for line in lines), "MAVProxy saw a fence"
    finally:
        proc.kill()
        proc.wait(5)
        sim.stop()
