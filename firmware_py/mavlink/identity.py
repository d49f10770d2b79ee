"""Who the vehicle says it is: the ArduSub release it follows, Wavekeep's own version and commit, its board id.

* AUTOPILOT_VERSION's ``flight_sw_version`` is the ArduSub release Wavekeep follows (4.7.0, development
  type, as the reference binary reports), so a ground station picks that release's parameter metadata
  and firmware checks; ``flight_custom_version`` is Wavekeep's own git commit (8 hex digits, as
  ArduPilot puts its own there); ``uid2`` the board id (:func:`board_id`).
* The banner (PARAM_REQUEST_LIST, MAV_CMD_DO_SEND_BANNER) is ArduSub's three lines: the firmware and its
  commit (here Wavekeep's name and version), the board id, and the frame.
"""
from __future__ import annotations

import hashlib
import socket
from functools import lru_cache

from bridge.version import git_commit

from ..params.ardusub import ARDUSUB_RELEASE
from .wire import mavlink

__all__ = ["CAPABILITIES", "FLIGHT_SW_VERSION", "FRAME_TEXT", "WAVEKEEP_VERSION", "banner", "board_id",
           "custom_version"]

WAVEKEEP_VERSION = (0, 1, 0)
FLIGHT_SW_VERSION = ((ARDUSUB_RELEASE[0] << 24) | (ARDUSUB_RELEASE[1] << 16) | (ARDUSUB_RELEASE[2] << 8)
                     | mavlink.FIRMWARE_VERSION_TYPE_DEV)
"""ArduPilot's encoding (major << 24 | minor << 16 | patch << 8 | type) of the ArduSub release followed."""
FRAME_TEXT = "Frame: VECTORED_6DOF"
"""The banner's last line: the BlueROV2 Heavy's frame (FRAME_CONFIG 2)."""

_C = mavlink
CAPABILITIES = (_C.MAV_PROTOCOL_CAPABILITY_MAVLINK2 | _C.MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT
                | _C.MAV_PROTOCOL_CAPABILITY_MISSION_INT | _C.MAV_PROTOCOL_CAPABILITY_MISSION_FLOAT
                | _C.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED
                | _C.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_GLOBAL_INT)
"""What AUTOPILOT_VERSION claims: ArduSub's capabilities that this link implements (docs/mavlink.md says which
of ArduSub's it does not: FTP, fence and rally missions, attitude targets, compass calibration, termination).
COMMAND_INT is handled but, as by ArduSub, not claimed."""


@lru_cache(maxsize=1)
def custom_version() -> bytes:
    """Wavekeep's git commit as 8 ASCII hex digits (zeros outside a git checkout)."""
    commit = git_commit(8, dirty=False)
    return commit.encode("ascii")[:8] if commit else b"\0" * 8


@lru_cache(maxsize=4)
def board_id(sysid: int) -> bytes:
    """18 bytes that identify this board (AUTOPILOT_VERSION's ``uid2``): a hash of the host and the system id."""
    return hashlib.sha256(f"wavekeep:{socket.gethostname()}:{sysid}".encode()).digest()[:18]


def banner(sysid: int) -> list[str]:
    """ArduSub's banner, three STATUSTEXT lines: firmware and commit, board id, frame."""
    commit = custom_version().rstrip(b"\0").decode() or "00000000"
    return ["Wavekeep V{}.{}.{} ({})".format(*WAVEKEEP_VERSION, commit),
            f"Wavekeep SITL {board_id(sysid)[:12].hex()}", FRAME_TEXT]
