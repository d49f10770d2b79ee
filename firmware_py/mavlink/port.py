"""What a message handler may use of the link that owns it: a narrow interface, so no handler imports the link.

The link (:class:`~firmware_py.mavlink.link.MavlinkLink`) builds its handlers (commands, parameters,
missions, FTP, joystick, lockstep) and hands each itself as a :class:`LinkPort`; a handler queues
replies, says things and counts refusals through it. The link imports the handlers; the handlers
import this module only, so the package's import graph has no cycles.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any, Protocol

if TYPE_CHECKING:
    from ..telemetry_snapshot import TelemetrySnapshot
    from .telemetry import Builder, LinkState

__all__ = ["LinkPort"]


class LinkPort(Protocol):
    """The link as its handlers see it (all calls from the link's update, the scheduler thread)."""

    fw: Any
    """The vehicle (:class:`firmware_py.firmware.Firmware`)."""
    counters: dict[str, int]
    state: LinkState
    snapshot: TelemetrySnapshot | None
    after: list
    """Messages a command asked for, sent after its COMMAND_ACK."""
    builders: dict[int, Builder]
    last_error: str | None

    def queue(self, msg, ep: int | None = None) -> None:
        """Queue a message for one endpoint, or all (None)."""

    def ack(self, ep: int, msg, command: int, result: int) -> None:
        """COMMAND_ACK of ``command`` to the sender of ``msg``."""

    def statustext(self, severity: int, text: str, ep: int | None = None) -> None:
        """A STATUSTEXT to one endpoint or all."""

    def ignored(self) -> None:
        """Count a message that was handled but refused."""

    def build(self, mid: int) -> list:
        """The message(s) with id ``mid`` as they would be streamed now."""

    def set_interval(self, mid: int, interval_ns: int | None) -> None:
        """A message's own interval (ns), −1 off, None back to its group's rate."""

    def stream_interval(self, mid: int) -> int | None:
        """ns between two sends of a streamed message, or None when it is off."""

    def wake(self) -> None:
        """Wake the I/O thread: something is queued."""
