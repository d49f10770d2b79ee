"""The MAVLink parameter protocol over the firmware's parameter table (ArduPilot's GCS_Param).

PARAM_REQUEST_LIST streams every PARAM_VALUE (with index and count) in batches
of :attr:`ParamProtocol.PER_UPDATE` per link update; PARAM_REQUEST_READ answers
one parameter by index or name; PARAM_SET of a known name answers every GCS
with the value in force (the new one, or the old one after a refusal, which is
also said in a STATUSTEXT). Unknown names are ignored and counted.

Types are ArduPilot's: PARAM_VALUE carries the parameter's own MAV_PARAM_TYPE
(INT8 / INT16 / INT32 for integer parameters, REAL32 for the rest), the value
always as a float (MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT). PARAM_SET ignores the
sender's type and converts to the parameter's as ``AP_Param::set_float`` does:
an integer parameter takes the value plus 0.01 towards its sign, clamped to the
type's range and truncated towards zero (3.5 → 3, 2.999 → 3, −1.5 → −1).
"""
from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING

from ..modes import MAV_SEVERITY
from ..params.table import INT_TYPE_RANGES, ParamDef
from .identity import banner
from .wire import ID, mavlink, tidy_float32

if TYPE_CHECKING:
    from .port import LinkPort

__all__ = ["MAV_PARAM_TYPES", "ParamProtocol", "wire_to_value"]

MAV_PARAM_TYPES = {name: getattr(mavlink, f"MAV_PARAM_TYPE_{name}") for name in ("REAL32", "INT8", "INT16", "INT32")}
"""Parameter storage type (:attr:`firmware_py.params.table.ParamDef.ptype`) → MAV_PARAM_TYPE."""
UNLISTED = 65535         # PARAM_VALUE.param_index of an answer to PARAM_SET (ArduPilot sends it so)
INT_ROUNDING = 0.01      # AP_Param::set_float adds this (towards the value's sign) before truncating


def wire_to_value(d: ParamDef, value: float) -> float:
    """A PARAM_SET value (float32 on the wire) as the parameter's type stores it.

    Parameters
    ----------
    d : ParamDef
        The parameter.
    value : float
        The value received (any float, NaN and inf included: those pass unchanged, to be refused).

    Returns
    -------
    float
        REAL32: the decimal the sender most likely meant (0.1f → 0.1). Integer types:
        ``trunc(value ± 0.01)`` clamped to the type's range, as ArduPilot converts.
    """
    if not math.isfinite(value):
        return value
    if not d.integer:
        return tidy_float32(value)
    lo, hi = INT_TYPE_RANGES[d.ptype]
    v = value + math.copysign(INT_ROUNDING, value)
    return float(math.trunc(min(float(hi), max(float(lo), v))))


class ParamProtocol:
    """Serves ``link.fw.params`` to ground stations; runs in the link's update (scheduler thread).

    Parameters
    ----------
    link : LinkPort
        Where replies are queued and refusals counted.
    """

    PER_UPDATE = 40

    def __init__(self, link: LinkPort):
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

    def value_message(self, index: int, echo: bool = False) -> mavlink.MAVLink_param_value_message:
        """PARAM_VALUE of the parameter at ``index``; ``echo``: the answer to a PARAM_SET, whose index is
        65535 (ArduPilot's: "not from a list")."""
        params = self.params
        name, value = params.by_index(index)
        ptype = MAV_PARAM_TYPES[params.definition(name).ptype]
        return mavlink.MAVLink_param_value_message(name.encode("ascii"), float(value), ptype, len(params),
                                                   UNLISTED if echo else index)

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
        for line in banner(int(self.params["MAV_SYSID"])):
            self.link.statustext(MAV_SEVERITY.INFO, line, ep)
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
        if params.definition(name).readonly:          # ArduPilot: the text, then the value in force
            self.link.statustext(MAV_SEVERITY.WARNING, f"Param write denied ({name})")
            self.link.queue(self.value_message(params.index_of(name), echo=True))
            return None
        why = params.set(name, wire_to_value(params.definition(name), msg.param_value))
        if why:
            self.link.fw.say(MAV_SEVERITY.WARNING, f"{name} not set: {why}")
        self.link.queue(self.value_message(params.index_of(name), echo=True))
