"""Wavekeep's MAVLink: the vehicle's ground-station link, ArduSub-compatible.

Mirrors ArduPilot's split between the GCS_MAVLink library and the vehicle's
GCS_Mavlink.cpp:

* :mod:`.transports` — the endpoints (udpout, udpin, tcp, tcpin);
* :mod:`.link` — :class:`MavlinkLink`: queues, the I/O thread, signing, parsing, outbox;
* :mod:`.telemetry` — the streamed messages, built from the firmware's telemetry snapshot;
* :mod:`.commands` — inbound messages and COMMAND_LONG/INT handlers;
* :mod:`.param_protocol` — the parameter protocol.

What goes on the wire, and where it differs from ArduSub, is in ``docs/mavlink.md``.
"""
from __future__ import annotations

from .identity import CAPABILITIES, FLIGHT_SW_VERSION
from .keys import load_signing_key
from .link import MavlinkLink
from .telemetry import DATA_STREAM_PARAMS, STREAM_GROUPS
from .wire import SIGNING_EPOCH_S

__all__ = [
           "CAPABILITIES",
           "DATA_STREAM_PARAMS",
           "FLIGHT_SW_VERSION",
           "SIGNING_EPOCH_S",
           "STREAM_GROUPS",
           "MavlinkLink",
           "load_signing_key",
]
