"""The MAVLink parameter protocol over the firmware's parameter table (ArduPilot's GCS_Param).

PARAM_REQUEST_LIST streams every PARAM_VALUE (with index and count) in batches
of :attr:`ParamProtocol.PER_UPDATE` per link update; PARAM_REQUEST_READ answers
one parameter by index or name; PARAM_SET of a known name answers every GCS
with the value in force (the new one, or the old one after a refusal, which is
also said in a STATUSTEXT). Unknown names are ignored and counted.
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Callable

from ..modes import MAV_SEVERITY
from .wire import ID, WAVEKEEP_VERSION, mavlink, tidy_float32

if TYPE_CHECKING:
    from .link import MavlinkLink

__all__ = ["ParamProtocol", "PARAM_TYPE", "BANNER"]

PARAM_TYPE = mavlink.MAV_PARAM_TYPE_REAL32
BANNER = "Wavekeep V%d.%d.%d (ArduSub-compatible)" % WAVEKEEP_VERSION


class ParamProtocol:
    """Serves ``link.fw.params`` to ground stations; runs in the link's update (scheduler thread).

    Parameters
    ----------
    link : MavlinkLink
        Where replies are queued and refusals counted.
    """

    PER_UPDATE = 20

    def __init__(self, link: "MavlinkLink"):
        self.link = link
        self._cursor: dict[int, int] = {}       # endpoint → next index of a PARAM_REQUEST_LIST
        self.messages: dict[int, Callable[[int, object], None]] = {
            ID["PARAM_REQUEST_LIST"]: self.on_request_list,
            ID["PARAM_REQUEST_READ"]: self.on_request_read,
            ID["PARAM_SET"]: self.on_set,
        }
        """Message id → handler ``(endpoint, msg)``."""

    @property
    def params(self):
        return self.link.fw.params

    def value_message(self, index: int) -> mavlink.MAVLink_param_value_message:
        """PARAM_VALUE of the parameter at ``index``."""
        params = self.params
        name, value = params.by_index(index)
        return mavlink.MAVLink_param_value_message(name.encode("ascii"), float(value), PARAM_TYPE,
                                                   len(params), index)

    def send_batches(self) -> None:
        """Queue the next :attr:`PER_UPDATE` values of every PARAM_REQUEST_LIST in progress."""
        if not self._cursor:
            return
        count = len(self.params)
        for ep, i in list(self._cursor.items()):
            end = min(count, i + self.PER_UPDATE)
            for j in range(i, end):
                self.link.queue(self.value_message(j), ep)
            if end >= count:
                del self._cursor[ep]
            else:
                self._cursor[ep] = end

    def on_request_list(self, ep: int, msg) -> None:
        """PARAM_REQUEST_LIST: the banner (as ArduPilot sends it), then every value over the next updates."""
        self.link.statustext(MAV_SEVERITY.INFO, BANNER, ep)
        self._cursor[ep] = 0

    def on_request_read(self, ep: int, msg) -> None:
        """PARAM_REQUEST_READ by index (≥ 0) or by name."""
        params = self.params
        if msg.param_index >= 0:
            if msg.param_index >= len(params):
                return self.link.ignored()
            index = msg.param_index
        else:
            if msg.param_id not in params:
                return self.link.ignored()
            index = params.index_of(msg.param_id)
        self.link.queue(self.value_message(index), ep)

    def on_set(self, ep: int, msg) -> None:
        """PARAM_SET: set if allowed; every GCS learns the value in force."""
        params = self.params
        name = msg.param_id
        if name not in params:
            return self.link.ignored()
        why = params.set(name, tidy_float32(msg.param_value))
        if why:
            self.link.fw.say(MAV_SEVERITY.WARNING, f"{name} not set: {why}")
        self.link.queue(self.value_message(params.index_of(name)))
