"""MAVLink FTP (FILE_TRANSFER_PROTOCOL): every request answered at once, so a client falls back without a stall.

Wavekeep serves no files. As ArduPilot answers what it does not have, each
request gets a reply in the same message: NAK ``FileNotFound`` for operations
on a path (a client asking for ``@PARAM/param.pck`` then falls back to the
parameter protocol, as MAVProxy and QGroundControl do), NAK ``InvalidSession``
for operations on a session (none is ever open), ACK for ``ResetSessions``
(ArduPilot acknowledges it), NAK ``UnknownCommand`` for an opcode it does not know.
Replies (ACK/NAK) sent to the vehicle are ignored.

Payload layout (MAVLink FTP): seq_number u16, session u8, opcode u8, size u8,
req_opcode u8, burst_complete u8, padding u8, offset u32, data[239].
"""
from __future__ import annotations

import struct
from typing import TYPE_CHECKING

from .wire import mavlink

if TYPE_CHECKING:
    from .port import LinkPort

__all__ = ["ERR", "OP", "FtpResponder"]

OP = {"TerminateSession": 1, "ResetSessions": 2, "ListDirectory": 3, "OpenFileRO": 4, "ReadFile": 5,
      "CreateFile": 6, "WriteFile": 7, "RemoveFile": 8, "CreateDirectory": 9, "RemoveDirectory": 10,
      "OpenFileWO": 11, "TruncateFile": 12, "Rename": 13, "CalcFileCRC32": 14, "BurstReadFile": 15,
      "ACK": 128, "NAK": 129}
"""FTP opcodes."""
ERR = {"Fail": 1, "FailErrno": 2, "InvalidDataSize": 3, "InvalidSession": 4, "NoSessionsAvailable": 5,
       "EndOfFile": 6, "UnknownCommand": 7, "FileExists": 8, "FileProtected": 9, "FileNotFound": 10}
"""FTP NAK error codes (data[0] of a NAK)."""

PATH_OPS = frozenset(OP[k] for k in ("ListDirectory", "OpenFileRO", "CreateFile", "RemoveFile", "CreateDirectory",
                                     "RemoveDirectory", "OpenFileWO", "TruncateFile", "Rename", "CalcFileCRC32"))
SESSION_OPS = frozenset(OP[k] for k in ("TerminateSession", "ReadFile", "WriteFile", "BurstReadFile"))
HEADER = struct.Struct("<HBBBBBBI")       # the 12-byte header before data[]
PAYLOAD_LEN = 251


class FtpResponder:
    """Answers FILE_TRANSFER_PROTOCOL requests on one link; counts them in ``counters['ftp_requests']``.

    Parameters
    ----------
    link : LinkPort
        Where replies are queued.
    """

    def __init__(self, link: LinkPort):
        self.link = link
        link.counters.setdefault("ftp_requests", 0)
        self.messages = {mavlink.MAVLINK_MSG_ID_FILE_TRANSFER_PROTOCOL: self.on_request}
        """Message id → handler ``(endpoint, msg)``."""

    @staticmethod
    def reply_for(opcode: int) -> tuple[int, int | None]:
        """(reply opcode, NAK error code or None for an ACK) for a request opcode."""
        if opcode == OP["ResetSessions"]:
            return OP["ACK"], None
        if opcode in PATH_OPS:
            return OP["NAK"], ERR["FileNotFound"]
        if opcode in SESSION_OPS:
            return OP["NAK"], ERR["InvalidSession"]
        return OP["NAK"], ERR["UnknownCommand"]

    def on_request(self, ep: int, msg) -> None:
        """One request → one reply: seq_number + 1, same session, req_opcode = the request's opcode."""
        payload = bytes(bytearray(msg.payload)[:PAYLOAD_LEN]).ljust(PAYLOAD_LEN, b"\0")
        seq, session, opcode, _size, _req, _burst, _pad, offset = HEADER.unpack_from(payload)
        if opcode in (OP["ACK"], OP["NAK"]):
            return self.link.ignored()
        self.link.counters["ftp_requests"] += 1
        reply, error = self.reply_for(opcode)
        data = b"" if error is None else bytes([error])
        header = HEADER.pack((seq + 1) & 0xFFFF, session, reply, len(data), opcode, 0, 0, offset)
        body = (header + data).ljust(PAYLOAD_LEN, b"\0")
        self.link.queue(mavlink.MAVLink_file_transfer_protocol_message(
            0, msg.get_srcSystem(), msg.get_srcComponent(), list(body)), ep)
