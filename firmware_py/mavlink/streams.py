"""The telemetry schedule: which message is due when (ArduPilot's stream groups and per-message intervals).

Each streamed message goes out at its group's ``MAV1_*`` rate (:data:`.telemetry.STREAM_GROUPS`), or at
the interval MAV_CMD_SET_MESSAGE_INTERVAL gave it (or not at, −1); HEARTBEAT at 1 Hz. The due times are
kept on the firmware's clock (ns), on a grid that does not drift; a changed interval starts afresh.
ArduPilot also asks each ground station for a TIMESYNC every 10 s (:data:`TIMESYNC_PERIOD_NS`).
"""
from __future__ import annotations

from .telemetry import HEARTBEAT_INTERVAL_NS, MSG_GROUP, STREAMED
from .wire import ID

__all__ = ["TIMESYNC_PERIOD_NS", "Streams"]

TIMESYNC_PERIOD_NS = 10_000_000_000


class Streams:
    """The schedule of one link (its update thread); ``params`` is the firmware's parameter table."""

    def __init__(self, params):
        self.params = params
        self.overrides: dict[int, int] = {}          # msg id → interval ns, or -1: disabled
        self._schedule: tuple[tuple[int, int | None], ...] = ()
        self._key: tuple | None = None
        self._next_due: dict[int, int] = {}
        self._interval: dict[int, int | None] = {}
        self._next_timesync: int | None = None

    def set_interval(self, mid: int, interval_ns: int | None) -> None:
        """A message's own interval (ns), −1 to turn it off, None to go back to its group's rate."""
        if interval_ns is None:
            self.overrides.pop(mid, None)
        else:
            self.overrides[mid] = int(interval_ns)

    def interval(self, mid: int) -> int | None:
        """ns between two sends of a streamed message, or None when it is off."""
        ov = self.overrides.get(mid)
        if ov is not None:
            return None if ov < 0 else ov
        if mid == ID["HEARTBEAT"]:
            return HEARTBEAT_INTERVAL_NS
        group = MSG_GROUP.get(mid)
        if group is None:                  # sent on request, or at a SET_MESSAGE_INTERVAL rate
            return None
        rate = self.params[group]
        return int(1e9 / rate) if rate > 0 else None

    def restart(self, now_ns: int) -> None:
        """Every stream's schedule afresh at ``now_ns`` (after the firmware's clock was rebased)."""
        for mid in list(self._next_due):
            self._next_due[mid] = int(now_ns)
        self._next_timesync = None

    def _table(self) -> tuple[tuple[int, int | None], ...]:
        """(message id, interval ns or None) of every scheduled message, in send order.

        Rebuilt only when a parameter or a message's own interval changed (the MAV1_* rates
        and overrides change rarely; reading ~24 of them from the table every tick cost more
        than the sends), so a change still takes effect on the next tick.
        """
        params = self.params
        key = (id(params), params.version, tuple(self.overrides.items()))   # overrides: usually none
        if key != self._key:
            extra = tuple(mid for mid in self.overrides if mid not in MSG_GROUP and mid != ID["HEARTBEAT"])
            self._schedule = tuple((mid, self.interval(mid)) for mid in STREAMED + extra)
            self._key = key
        return self._schedule

    def due(self, now: int) -> list[int]:
        """The ids of the messages due at ``now`` (ns), in send order; each one's next time is set."""
        out = []
        for mid, interval in self._table():
            if interval != self._interval.get(mid):
                self._interval[mid] = interval
                self._next_due[mid] = now
            if interval is None or now < self._next_due[mid]:
                continue
            due = self._next_due[mid] + interval
            self._next_due[mid] = due if due > now else now + interval
            out.append(mid)
        return out

    def timesync_due(self, now: int) -> bool:
        """True every 10 s of vehicle time (the first at the first call)."""
        if self._next_timesync is not None and now < self._next_timesync:
            return False
        self._next_timesync = now + TIMESYNC_PERIOD_NS
        return True
