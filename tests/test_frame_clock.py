"""The launcher's frame reader (sitl/harness/frame_clock.py) agrees with pymavlink on what it reads.

The ground station follows a flight without decoding the downlink: each frame is checked as
pymavlink checks it and only its vehicle-time fields are read. Every message the vehicle streams
must give the same time_boot_ms / time_unix_usec and the same bytes as pymavlink's decoder, and
whatever pymavlink would refuse must send the reader back to pymavlink (None).
"""
from __future__ import annotations

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sitl.harness.frame_clock import read_frames


def _messages() -> list:
    """One of each message the vehicle streams, with a time field where it has one (some zero: truncated)."""
    m = mavlink
    return [
        m.MAVLink_heartbeat_message(m.MAV_TYPE_SUBMARINE, m.MAV_AUTOPILOT_ARDUPILOTMEGA, 217, 19, 4, 3),
        m.MAVLink_attitude_message(123456, 0.0, 0.1, 0.0, 0.0, -0.02, 0.0),
        m.MAVLink_system_time_message(1_796_000_000_123_456, 600_050),
        m.MAVLink_named_value_float_message(4_294_967_295, b"FF_AGE", 0.5),
        m.MAVLink_named_value_float_message(0, b"TICK_MISS", 0.0),          # all zero after the name
        m.MAVLink_rc_channels_message(77, 11, *([1500] * 8), 1100, 1100, 1100, *([65535] * 7), 255),
        m.MAVLink_local_position_ned_message(50, 1.0, 0.0, 5.0, 0.0, 0.0, 0.0),
        m.MAVLink_global_position_int_message(50, 1, 2, -5000, -5000, 0, 0, 0, 0),
        m.MAVLink_vfr_hud_message(0.0, 0.0, 0, 50, -5.0, 0.0),
        m.MAVLink_servo_output_raw_message(1_000_000, 0, *([1500] * 8), *([0] * 8)),
        m.MAVLink_statustext_message(6, b"Armed"),
        m.MAVLink_command_ack_message(400, 0, 0, 0, 255, 190),
    ]


@pytest.mark.parametrize("msg", _messages(), ids=lambda m: m.get_type())
def test_a_frame_reads_as_pymavlink_decodes_it(msg):
    buf = msg.pack(mavlink.MAVLink(None, srcSystem=1, srcComponent=1))
    frames = read_frames(buf)
    ref = mavlink.MAVLink(None).decode(bytearray(buf))
    assert frames is not None and len(frames) == 1
    f = frames[0]
    assert f.buf == buf == bytes(ref.get_msgbuf())
    assert (f.msg_id, f.src_system) == (ref.get_msgId(), ref.get_srcSystem())
    assert f.time_boot_ms == getattr(ref, "time_boot_ms", None)
    assert f.time_unix_usec == getattr(ref, "time_unix_usec", None)


def test_several_frames_in_one_datagram():
    mav = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    bufs = [m.pack(mav) for m in _messages()[:4]]
    frames = read_frames(b"".join(bufs))
    assert frames is not None and [f.buf for f in frames] == bufs


def test_what_pymavlink_would_refuse_goes_back_to_pymavlink():
    mav = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    buf = mavlink.MAVLink_attitude_message(1, 0, 0, 0, 0, 0, 0).pack(mav)
    bad_crc = bytearray(buf)
    bad_crc[-1] ^= 0x01
    unknown_flags = bytearray(buf)
    unknown_flags[2] = 0x02
    v1 = mavlink.MAVLink_attitude_message(1, 0, 0, 0, 0, 0, 0).pack(mavlink.MAVLink(None), force_mavlink1=True)
    for data in (bytes(bad_crc), bytes(unknown_flags), buf[:-3], buf + b"\x00", v1, b"\xfd"):
        assert read_frames(data) is None, data
    assert read_frames(b"") == []
