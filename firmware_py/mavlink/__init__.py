"""Wavekeep's MAVLink: the vehicle's ground-station link, as ArduSub 4.7 speaks it.

Mirrors ArduPilot's split between the GCS_MAVLink library and the vehicle's
GCS_Mavlink.cpp:

* :mod:`.transports` — the endpoints (udpout, udpin, tcp, tcpin);
* :mod:`.link` — :class:`MavlinkLink`: queues, the I/O thread, signing, parsing, outbox;
* :mod:`.telemetry` — the streamed messages, built from the firmware's telemetry snapshot;
* :mod:`.streams` — which message is due when;
* :mod:`.identity` — AUTOPILOT_VERSION, the capabilities, the banner;
* :mod:`.port` — the narrow interface the link hands its handlers (no handler imports the link);
* :mod:`.commands`, :mod:`.vehicle_commands` — inbound messages and COMMAND_LONG/INT handlers;
* :mod:`.param_protocol` — the parameter protocol;
* :mod:`.pilot`, :mod:`.accessories` — the joystick and its failsafe; the camera mount, lights, outputs 9–16.

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
