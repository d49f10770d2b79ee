"""The vehicle's clock in raw MAVLink 2 frames, read without decoding them (the launcher's flight loop).

A ground station that follows a mission needs, of most downlink messages, only
three things: the frame's bytes (for the .tlog), who sent it, and the vehicle
time it carries (``time_boot_ms``; SYSTEM_TIME also ``time_unix_usec``).
pymavlink builds a full message object for each — about ten times the cost of
reading two integers at a known offset, for ~90 messages per simulated second
(ArduSub's default stream rates). :func:`read_frames` checks each frame as
pymavlink's parser does (MAVLink 2 header, length, known message id, CRC with
its CRC_EXTRA) and returns what the launcher logs; anything it does not take
(MAVLink 1, unknown flags, a bad checksum) makes the caller fall back to
pymavlink for that datagram.
"""
from __future__ import annotations

import re
import struct
from dataclasses import dataclass
from functools import cache
from typing import NamedTuple

__all__ = ["Frame", "read_frames"]

_V2 = 0xFD
_HEADER = struct.Struct("<BBBBBBBHB")     # magic, len, incompat, compat, seq, sysid, compid, msgid low 16, high 8
_SIGNED = 0x01
_SIGNATURE_LEN = 13
_TOKEN = re.compile(r"(\d*)([a-zA-Z?])")


class Frame(NamedTuple):
    """One checked MAVLink 2 frame: its id, sender, vehicle time fields (None where it has none) and bytes."""

    msg_id: int
    src_system: int
    time_boot_ms: int | None
    time_unix_usec: int | None
    buf: bytes


@dataclass(frozen=True)
class _Layout:
    crc_extra: bytes                     # the message's CRC_EXTRA byte, appended to the checksummed bytes
    payload_len: int                     # untruncated payload (bytes)
    boot_ms: struct.Struct | None        # time_boot_ms (uint32) at its offset, when the message has it
    unix_us: struct.Struct | None        # time_unix_usec (uint64) at its offset, when it has it


def _field_offsets(fmt: str, names: list[str]) -> dict[str, tuple[int, str]]:
    """Wire offset (bytes) and struct code of each field of a pymavlink ``unpacker`` format."""
    tokens = _TOKEN.findall(fmt.lstrip("<"))
    out, prefix = {}, "<"
    for name, (count, code) in zip(names, tokens, strict=True):
        out[name] = (struct.calcsize(prefix), code)
        prefix += count + code
    return out


@cache
def _layouts() -> dict[int, _Layout]:
    """Message id → what :func:`read_frames` needs of it, from pymavlink's dialect (built once)."""
    from pymavlink.dialects.v20 import ardupilotmega as dialect

    table = {}
    for msg_id, cls in dialect.mavlink_map.items():
        fields = _field_offsets(cls.unpacker.format, list(cls.ordered_fieldnames))

        def at(name: str, code: str, fields=fields) -> struct.Struct | None:
            where = fields.get(name)
            return struct.Struct(f"<{where[0]}x{code}") if where is not None and where[1] == code else None

        table[msg_id] = _Layout(bytes((cls.crc_extra,)), cls.unpacker.size, at("time_boot_ms", "I"),
                                at("time_unix_usec", "Q"))
    return table


def read_frames(data: bytes) -> list[Frame] | None:
    """The frames of one datagram, checked; None if any part of it needs pymavlink's parser instead."""
    from pymavlink.dialects.v20.ardupilotmega import x25crc  # pymavlink's own (fastcrc when installed)

    layouts = _layouts()
    frames, i, n = [], 0, len(data)
    while i < n:
        if n - i < _HEADER.size + 2 or data[i] != _V2:
            return None
        _, mlen, incompat, _, _, src, _, low, high = _HEADER.unpack_from(data, i)
        if incompat & ~_SIGNED:
            return None
        end = i + _HEADER.size + mlen + 2 + (_SIGNATURE_LEN if incompat & _SIGNED else 0)
        lay = layouts.get(low | high << 16)
        if end > n or lay is None or mlen > lay.payload_len:
            return None
        body = i + _HEADER.size
        if x25crc(data[i + 1:body + mlen] + lay.crc_extra).crc != int.from_bytes(data[body + mlen:body + mlen + 2],
                                                                                   "little"):
            return None
        # MAVLink 2 drops a payload's trailing zero bytes: put them back before reading a field
        payload = data[body:body + mlen] + bytes(lay.payload_len - mlen)
        boot = lay.boot_ms.unpack_from(payload)[0] if lay.boot_ms is not None else None
        unix = lay.unix_us.unpack_from(payload)[0] if lay.unix_us is not None else None
        frames.append(Frame(low | high << 16, src, boot, unix, bytes(data[i:end])))
        i = end
    return frames
