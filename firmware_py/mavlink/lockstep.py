"""Lockstep with a companion computer (SITL only): the vehicle waits, each tick, for the companion's answer.

ArduPilot's SITL runs in lockstep with its physics (JSON SITL), never with a
companion over MAVLink: a real companion's commands arrive when they arrive.
For a deterministic, as-fast-as-possible ``wavekeep sim --companion`` the
stand-in autopilot (``wavekeep firmware --companion-lockstep``) closes that
loop too, with one marker each way:

* after a tick's telemetry the vehicle sends NAMED_VALUE_INT ``LOCKSTEP``
  (``time_boot_ms`` = the tick's time): "that was all of tick k";
* the companion runs its control task on it, sends its commands, then answers
  NAMED_VALUE_INT ``LOCKSTEP`` with the same ``time_boot_ms``;
* the vehicle waits for that answer (at most ``timeout_s`` of wall time), then
  handles the commands before its next control tick: a fixed one-tick
  telemetry-to-command latency, the same in every run.

A companion that stops answering costs ``timeout_s`` per tick until
``max_misses`` ticks in a row have gone unanswered; the vehicle then stops
waiting ("Companion lockstep lost") until an answer comes again.
"""
from __future__ import annotations

import threading
from typing import TYPE_CHECKING

from ..modes import MAV_SEVERITY
from .wire import mavlink

if TYPE_CHECKING:
    from .port import LinkPort

__all__ = ["MARKER", "CompanionLockstep"]

MARKER = b"LOCKSTEP"


class CompanionLockstep:
    """The vehicle's half of the lockstep (the link's update calls :meth:`after_streams`)."""

    def __init__(self, link: LinkPort, timeout_s: float = 1.0, max_misses: int = 3):
        self.link = link
        self.timeout_s = float(timeout_s)
        self.max_misses = int(max_misses)
        self._acked_ms = -1
        self._cond = threading.Condition()
        self._last_sent_ms: int | None = None
        self.misses = 0                 # ticks the companion did not answer in time
        self._consecutive = 0
        self.lost = False

    def is_marker(self, msg) -> bool:
        """Called by the I/O thread for each NAMED_VALUE_INT: a companion's answer is taken here."""
        name = msg.name.encode() if isinstance(msg.name, str) else bytes(msg.name)
        if name.rstrip(b"\0") != MARKER:
            return False
        with self._cond:
            self._acked_ms = max(self._acked_ms, int(msg.time_boot_ms))
            self._cond.notify_all()
        return True

    def after_streams(self, t: float | None) -> bool:
        """Mark the end of tick ``t`` (s) and wait for the companion's answer; True when it answered."""
        if t is None:
            return False
        ms = int(round(t * 1000))
        if ms == self._last_sent_ms:          # the same tick again (held before arming): nothing new
            return False
        self._last_sent_ms = ms
        self.link.queue(mavlink.MAVLink_named_value_int_message(ms, MARKER, ms))
        self.link.wake()
        with self._cond:
            answered = self._cond.wait_for(lambda: self._acked_ms >= ms, 0.0 if self.lost else self.timeout_s)
        if answered:
            if self.lost:
                self.link.statustext(MAV_SEVERITY.INFO, "Companion lockstep back")
            self.lost, self._consecutive = False, 0
            return True
        if not self.lost:
            self.misses += 1
            self._consecutive += 1
            if self._consecutive >= self.max_misses:
                self.lost = True
                self.link.statustext(MAV_SEVERITY.WARNING, "Companion lockstep lost")
        return False
