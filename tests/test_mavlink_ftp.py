"""MAVLink FTP against a live vehicle: every request answered at once (NAK / ACK), so clients fall back."""
from __future__ import annotations

import os
import re
import struct
import subprocess
import sys
import threading
import time

import pytest

os.environ["MAVLINK20"] = "1"
# fixtures, one live vehicle per module
from mavlink_gcs import free_port, mavproxy_available
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from firmware_py.mavlink.ftp import ERR, OP
from sitl.harness.live import LiveSim
from sitl.harness.spec import RunSpec

HEADER = struct.Struct("<HBBBBBBI")


def request(seq: int, opcode: int, data: bytes = b"", session: int = 0, target=(1, 1)):
    body = HEADER.pack(seq, session, opcode, len(data), 0, 0, 0, 0) + data
    return mavlink.MAVLink_file_transfer_protocol_message(0, *target, list(body.ljust(251, b"\0")))


def decode(msg) -> tuple:
    """(seq, session, opcode, size, req_opcode, data) of an FTP reply."""
    payload = bytes(bytearray(msg.payload))
    seq, session, opcode, size, req, _b, _p, _o = HEADER.unpack_from(payload)
    return seq, session, opcode, size, req, payload[12:12 + size]


@pytest.mark.parametrize("opcode, session, reply, error", [
    (OP["OpenFileRO"], 0, OP["NAK"], ERR["FileNotFound"]),          # what MAVProxy asks first: @PARAM/param.pck
    (OP["ListDirectory"], 0, OP["NAK"], ERR["FileNotFound"]),
    (OP["CalcFileCRC32"], 0, OP["NAK"], ERR["FileNotFound"]),
    (OP["ReadFile"], 3, OP["NAK"], ERR["InvalidSession"]),
    (OP["BurstReadFile"], 3, OP["NAK"], ERR["InvalidSession"]),
    (OP["TerminateSession"], 3, OP["NAK"], ERR["InvalidSession"]),
    (OP["ResetSessions"], 0, OP["ACK"], None),
    (99, 0, OP["NAK"], ERR["UnknownCommand"]),
])
def test_every_ftp_request_is_answered(v, opcode, session, reply, error):
    gs = v.gs
    since = gs.mark()
    t0 = time.monotonic()
    gs.send(request(41, opcode, b"@PARAM/param.pck?withdefaults=1\0", session))
    m = gs.wait_type("FILE_TRANSFER_PROTOCOL", timeout=3.0, since=since)
    assert m is not None and time.monotonic() - t0 < 1.0
    assert (m.target_system, m.target_component) == (255, 190)
    seq, sess, op, size, req, data = decode(m)
    assert (seq, sess, op, req) == (42, session, reply, opcode)
    assert (list(data), size) == (([error], 1) if error is not None else ([], 0))


def test_ftp_replies_and_garbage_are_survived(v):
    gs, link = v.gs, v.link
    before = dict(link.counters)
    gs.send(request(1, OP["NAK"]))                      # a reply sent to the vehicle: ignored, counted
    gs.send(mavlink.MAVLink_file_transfer_protocol_message(0, 1, 1, [255] * 251))     # opcode 255, size 255
    m = gs.wait_type("FILE_TRANSFER_PROTOCOL", timeout=3.0)
    assert decode(m)[2:5] == (OP["NAK"], 1, 255) and decode(m)[0] == 0             # seq 65535 + 1 wraps to 0
    time.sleep(0.2)
    assert link.counters["rx_ignored"] == before["rx_ignored"] + 1
    assert link.counters["handler_errors"] == before["handler_errors"] and link.alive


@pytest.mark.processes
@pytest.mark.skipif(not mavproxy_available(), reason="MAVProxy not installed")
def test_mavproxy_with_ftp_falls_back_to_the_parameter_protocol(tmp_path):
    """MAVProxy's param module tries MAVFTP first; the NAK sends it to PARAM_REQUEST_LIST with no stall."""
    port = free_port()
    sim = LiveSim(RunSpec("W1", "cpd"), mavlink=[f"udpout:127.0.0.1:{port}"]).start()
    proc = subprocess.Popen([sys.executable, "-m", "MAVProxy.mavproxy", f"--master=udpin:127.0.0.1:{port}",
                             "--no-state", "--default-modules=ftp,param"],
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            cwd=tmp_path, env={**os.environ, "PYTHONUNBUFFERED": "1"})
    lines: list[str] = []
    threading.Thread(target=lambda: lines.extend(proc.stdout), daemon=True).start()
    try:
        end, found = time.monotonic() + 20.0, None
        while found is None and time.monotonic() < end:
            found = next((m for line in list(lines) if (m := re.search(r"Received (\d+) parameters", line))), None)
            time.sleep(0.1)
        assert found is not None, "".join(lines[-30:])
        assert int(found[1]) == len(sim.firmware.params)
        assert sim.link.counters["ftp_requests"] >= 1                 # it did ask by FTP first
    finally:
        proc.kill()
        proc.wait(5)
        sim.stop()
