"""The mission protocol (ArduPilot's MissionItemProtocol for MAV_MISSION_TYPE_MISSION), with home at seq 0.

* **Store**: item 0 is home (the WK_ORIGIN_LAT/LON origin at the surface, as
  ArduPilot's item 0 is home); uploaded items 1… follow. The store holds
  items as MISSION_ITEM_INT fields; Wavekeep has no AUTO mode, so a mission is
  kept and served back but not flown.
* **Upload**: MISSION_COUNT → MISSION_REQUEST for each seq in turn (re-sent
  after :data:`REQUEST_RESEND_S` without an answer) → MISSION_ITEM_INT (or
  MISSION_ITEM, with ArduPilot's one-time warning) → MISSION_ACK ACCEPTED
  after the last. A wrong seq gets MISSION_ACK INVALID_SEQUENCE (the upload
  goes on); another system starting an upload meanwhile is DENIED; silence for
  :data:`UPLOAD_TIMEOUT_S` cancels (MISSION_ACK OPERATION_CANCELLED). Item 0
  of an upload is home: accepted, and home stays the origin.
* **Download**: MISSION_REQUEST_LIST → MISSION_COUNT; MISSION_REQUEST_INT →
  MISSION_ITEM_INT; MISSION_REQUEST → MISSION_ITEM. An unknown seq: MISSION_COUNT
  (to tell the GCS the size) then MISSION_ACK INVALID_SEQUENCE. Refused
  (DENIED) while an upload is in progress.
* **Guided goto**: MISSION_ITEM(_INT) with ``current`` = 2 sets the GUIDED
  target from its latitude and altitude (MISSION_ACK ACCEPTED, or ERROR
  outside GUIDED), as ArduSub's ``handle_guided_request``.

Other mission types (fence, rally) are answered with a count of 0 and uploads
UNSUPPORTED.
"""
from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from ..modes import MAV_RESULT, MAV_SEVERITY
from .wire import finite, mavlink

if TYPE_CHECKING:
    from .port import LinkPort

__all__ = ["MAX_ITEMS", "REQUEST_RESEND_S", "UPLOAD_TIMEOUT_S", "MissionItem", "MissionProtocol"]

MAX_ITEMS = 700                 # ArduPilot's mission storage on a typical board holds about this many
UPLOAD_TIMEOUT_S = 8.0          # ArduPilot's upload_timeout_ms
REQUEST_RESEND_S = 1.0          # re-send a MISSION_REQUEST after this long without the item
EARTH_RADIUS_M = 6378137.0
GLOBAL_FRAMES = (mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, mavlink.MAV_FRAME_GLOBAL_INT,
                 mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT,
                 mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT)
MISSION = mavlink.MAV_MISSION_TYPE_MISSION
M = mavlink


@dataclass(frozen=True)
class MissionItem:
    """One stored item, as MISSION_ITEM_INT carries it (x, y in degE7 for global frames; z in m)."""

    frame: int
    command: int
    autocontinue: int
    params: tuple[float, float, float, float]
    x: int
    y: int
    z: float

    @classmethod
    def from_message(cls, msg) -> MissionItem:
        """From a MISSION_ITEM_INT, or a MISSION_ITEM (float degrees → degE7 in global frames)."""
        x, y = msg.x, msg.y
        if msg.get_type() == "MISSION_ITEM":
            scale = 1e7 if msg.frame in GLOBAL_FRAMES else 1.0
            x, y = (int(round(v * scale)) if finite(v) and abs(v * scale) < 2**31 else 0 for v in (x, y))
        return cls(int(msg.frame), int(msg.command), int(msg.autocontinue),
                   (float(msg.param1), float(msg.param2), float(msg.param3), float(msg.param4)), int(x), int(y),
                   float(msg.z))

    def message(self, seq: int, current: int, to: tuple[int, int], as_int: bool = True):
        """This item as MISSION_ITEM_INT (or MISSION_ITEM, degrees as floats) for the GCS ``to`` (sysid, compid)."""
        if as_int:
            return M.MAVLink_mission_item_int_message(to[0], to[1], seq, self.frame, self.command, current,
                                                      self.autocontinue, *self.params, self.x, self.y, self.z,
                                                      MISSION)
        scale = 1e-7 if self.frame in GLOBAL_FRAMES else 1.0
        return M.MAVLink_mission_item_message(to[0], to[1], seq, self.frame, self.command, current,
                                              self.autocontinue, *self.params, self.x * scale, self.y * scale,
                                              self.z, MISSION)


@dataclass
class _Upload:
    ep: int
    peer: tuple[int, int]
    count: int
    next_seq: int
    items: list
    last_rx: float
    last_request: float


class MissionProtocol:
    """Mission upload, download and guided goto over one link (scheduler thread).

    Parameters
    ----------
    link : LinkPort
        Where replies are queued and whose firmware takes guided targets.
    """

    def __init__(self, link: LinkPort):
        self.link = link
        self.items: list[MissionItem] = []        # seq 1…; seq 0 (home) is built from the origin
        self.current = 0
        self._upload: _Upload | None = None
        self._warned: set[str] = set()
        self.messages: dict[int, Callable[[int, object], None]] = {
            M.MAVLINK_MSG_ID_MISSION_REQUEST_LIST: self.on_request_list,
            M.MAVLINK_MSG_ID_MISSION_COUNT: self.on_count,
            M.MAVLINK_MSG_ID_MISSION_ITEM: self.on_item,
            M.MAVLINK_MSG_ID_MISSION_ITEM_INT: self.on_item,
            M.MAVLINK_MSG_ID_MISSION_REQUEST: self.on_request,
            M.MAVLINK_MSG_ID_MISSION_REQUEST_INT: self.on_request,
            M.MAVLINK_MSG_ID_MISSION_CLEAR_ALL: self.on_clear_all,
            M.MAVLINK_MSG_ID_MISSION_SET_CURRENT: self.on_set_current,
            M.MAVLINK_MSG_ID_MISSION_ACK: lambda ep, msg: None,     # the GCS's ACK of a download: nothing to do
        }
        """Message id → handler ``(endpoint, msg)``."""

    # ------------------------------------------------------------------ store
    @property
    def count(self) -> int:
        """Items in the mission, home included."""
        return 1 + len(self.items)

    def home(self) -> MissionItem:
        """Item 0: home — the local origin (WK_ORIGIN_LAT/LON) at the sea surface, or where DO_SET_HOME put it."""
        p = self.link.fw.params
        lat, lon, alt = self.link.state.home or (p["WK_ORIGIN_LAT"], p["WK_ORIGIN_LON"], 0.0)
        return MissionItem(M.MAV_FRAME_GLOBAL, M.MAV_CMD_NAV_WAYPOINT, 1, (0.0, 0.0, 0.0, 0.0),
                           int(round(lat * 1e7)), int(round(lon * 1e7)), float(alt))

    def item(self, seq: int) -> MissionItem | None:
        if seq == 0:
            return self.home()
        return self.items[seq - 1] if 0 < seq < self.count else None

    # ------------------------------------------------------------------ helpers
    def _ack(self, ep: int, to: tuple[int, int], result: int, mission_type: int = MISSION) -> None:
        self.link.queue(M.MAVLink_mission_ack_message(to[0], to[1], result, mission_type), ep)

    @staticmethod
    def _peer(msg) -> tuple[int, int]:
        return msg.get_srcSystem(), msg.get_srcComponent()

    def _warn_once(self, text: str, ep: int) -> None:
        if text not in self._warned:
            self._warned.add(text)
            self.link.statustext(MAV_SEVERITY.WARNING, text, ep)

    def _request(self, up: _Upload) -> None:
        up.last_request = time.monotonic()
        self.link.queue(M.MAVLink_mission_request_message(*up.peer, up.next_seq, MISSION), up.ep)

    # ------------------------------------------------------------------ download
    def on_request_list(self, ep: int, msg) -> None:
        """MISSION_REQUEST_LIST: the count (home included); DENIED during an upload."""
        if msg.mission_type != MISSION:
            return self.link.queue(M.MAVLink_mission_count_message(*self._peer(msg), 0, msg.mission_type), ep)
        if self._upload is not None:
            return self._ack(ep, self._peer(msg), M.MAV_MISSION_DENIED)
        self.link.queue(M.MAVLink_mission_count_message(*self._peer(msg), self.count, MISSION), ep)

    def on_request(self, ep: int, msg) -> None:
        """MISSION_REQUEST_INT → MISSION_ITEM_INT; MISSION_REQUEST → MISSION_ITEM (with a one-time warning)."""
        peer = self._peer(msg)
        if msg.mission_type != MISSION:
            return self._ack(ep, peer, M.MAV_MISSION_UNSUPPORTED, msg.mission_type)
        as_int = msg.get_type() == "MISSION_REQUEST_INT"
        if as_int and self._upload is not None:
            return self._ack(ep, peer, M.MAV_MISSION_DENIED)
        item = self.item(msg.seq)
        if item is None:
            if as_int:
                self.link.queue(M.MAVLink_mission_count_message(*peer, self.count, MISSION), ep)
            return self._ack(ep, peer, M.MAV_MISSION_INVALID_SEQUENCE)
        if not as_int:
            self._warn_once("got MISSION_REQUEST; use MISSION_REQUEST_INT!", ep)
        self.link.queue(item.message(msg.seq, int(msg.seq == self.current), peer, as_int), ep)

    # ------------------------------------------------------------------ upload
    def on_count(self, ep: int, msg) -> None:
        """MISSION_COUNT starts an upload (count 0: clear, ACCEPTED at once)."""
        peer = self._peer(msg)
        if msg.mission_type != MISSION:
            return self._ack(ep, peer, M.MAV_MISSION_UNSUPPORTED, msg.mission_type)
        if self._upload is not None and self._upload.peer != peer:
            return self._ack(ep, peer, M.MAV_MISSION_DENIED)
        self._upload = None
        if msg.count > MAX_ITEMS:
            self.link.statustext(MAV_SEVERITY.WARNING, f"Only {MAX_ITEMS} items are supported", ep)
            return self._ack(ep, peer, M.MAV_MISSION_NO_SPACE)
        if msg.count == 0:
            self.items, self.current = [], 0
            return self._ack(ep, peer, M.MAV_MISSION_ACCEPTED)
        now = time.monotonic()
        self._upload = _Upload(ep, peer, int(msg.count), 0, [], now, now)
        self._request(self._upload)

    def on_item(self, ep: int, msg) -> None:
        """MISSION_ITEM(_INT): the next item of an upload, or (current = 2) a guided goto."""
        peer = self._peer(msg)
        if msg.mission_type != MISSION:
            return self._ack(ep, peer, M.MAV_MISSION_UNSUPPORTED, msg.mission_type)
        if msg.current == 2:
            return self._ack(ep, peer, self.guided_goto(MissionItem.from_message(msg)))
        up = self._upload
        if up is None:
            return self._ack(ep, peer, M.MAV_MISSION_ERROR)
        if peer != up.peer:
            return self._ack(ep, peer, M.MAV_MISSION_DENIED)
        if msg.seq != up.next_seq:
            return self._ack(ep, peer, M.MAV_MISSION_INVALID_SEQUENCE)
        if msg.get_type() == "MISSION_ITEM":
            self._warn_once("got MISSION_ITEM; GCS should send MISSION_ITEM_INT", ep)
        if msg.seq > 0:                              # item 0 is home: accepted, home stays the origin
            up.items.append(MissionItem.from_message(msg))
        up.next_seq += 1
        up.last_rx = time.monotonic()
        if up.next_seq < up.count:
            return self._request(up)
        self.items, self.current, self._upload = up.items, 0, None
        self._ack(ep, peer, M.MAV_MISSION_ACCEPTED)

    def on_clear_all(self, ep: int, msg) -> None:
        """MISSION_CLEAR_ALL: only home remains (another system's upload in progress: DENIED)."""
        peer = self._peer(msg)
        if msg.mission_type != MISSION:
            return self._ack(ep, peer, M.MAV_MISSION_ACCEPTED, msg.mission_type)
        if self._upload is not None and self._upload.peer != peer:
            return self._ack(ep, peer, M.MAV_MISSION_DENIED)
        self.items, self.current, self._upload = [], 0, None
        self._ack(ep, peer, M.MAV_MISSION_ACCEPTED)

    def on_set_current(self, ep: int, msg) -> None:
        """MISSION_SET_CURRENT: the current item (answered with MISSION_CURRENT); an unknown seq is ignored."""
        if not 0 <= msg.seq < self.count:
            return self.link.ignored()
        self.current = int(msg.seq)
        self.link.queue(M.MAVLink_mission_current_message(self.current, self.count), ep)

    def update(self) -> None:
        """Once per link update: re-request a missing item, cancel a silent upload."""
        up = self._upload
        if up is None:
            return
        now = time.monotonic()
        if now - up.last_rx > UPLOAD_TIMEOUT_S:
            self._upload = None
            self._ack(up.ep, up.peer, M.MAV_MISSION_OPERATION_CANCELLED)
        elif now - up.last_request > REQUEST_RESEND_S:
            self._request(up)

    # ------------------------------------------------------------------ guided
    def guided_goto(self, item: MissionItem) -> int:
        """Set the GUIDED target from a global position: north of the origin (m) and depth = −alt (m).

        Returns
        -------
        int
            MAV_MISSION_RESULT: ACCEPTED; ERROR outside GUIDED (ArduSub's ``do_guided``
            refuses); UNSUPPORTED_FRAME for a non-global frame; INVALID_PARAM5_X for a bad latitude.
        """
        if item.frame not in GLOBAL_FRAMES:
            return M.MAV_MISSION_UNSUPPORTED_FRAME
        lat = item.x * 1e-7
        if not -90.0 <= lat <= 90.0:
            return M.MAV_MISSION_INVALID_PARAM5_X
        if not finite(item.z):
            return M.MAV_MISSION_INVALID_PARAM7
        north = math.radians(lat - self.link.fw.params["WK_ORIGIN_LAT"]) * EARTH_RADIUS_M
        depth = max(0.0, -item.z)
        ok = self.link.fw.set_target(north, depth, None) == MAV_RESULT.ACCEPTED
        return M.MAV_MISSION_ACCEPTED if ok else M.MAV_MISSION_ERROR

