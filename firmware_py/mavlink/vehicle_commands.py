"""ArduSub's vehicle commands beyond modes and arming: servos, reposition, yaw, pressure calibration.

Handlers of COMMAND_LONG / COMMAND_INT with the signature of :mod:`.commands`
(``(endpoint, msg, params) -> MAV_RESULT``), registered into the link's
dispatcher. Results are ArduSub's (``ArduSub/GCS_MAVLink_Sub.cpp`` and
GCS_Common); where Wavekeep's three degrees of freedom make a command moot,
docs/mavlink.md says so.
"""
from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from typing import TYPE_CHECKING

from ..modes import MAV_RESULT, MAV_SEVERITY, Mode
from .pilot import Joystick
from .telemetry import EARTH_RADIUS_M, home_location
from .wire import finite, mavlink

if TYPE_CHECKING:
    from .port import LinkPort

__all__ = ["BARO_SAMPLES", "VehicleCommands"]

BARO_SAMPLES = 20          # the pressure calibration averages the last second of depth readings (20 Hz)
Params7 = tuple[float, float, float, float, float, float, float]
_ABSOLUTE = (mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_FRAME_GLOBAL_INT)
_RELATIVE = (mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT)


class VehicleCommands:
    """DO_SET_SERVO, DO_REPOSITION, CONDITION_YAW and PREFLIGHT_CALIBRATION for one link."""

    def __init__(self, link: LinkPort, joystick: Joystick):
        self.link = link
        self.joystick = joystick      # DO_SET_SERVO drives the outputs it keeps
        self.fw = link.fw
        self.depths: deque[float] = deque(maxlen=BARO_SAMPLES)   # recent pressure depths (m), for calibration
        self.commands: dict[int, Callable[[int, object, Params7], int]] = {
            mavlink.MAV_CMD_DO_SET_SERVO: self.cmd_set_servo,
            mavlink.MAV_CMD_DO_REPOSITION: self.cmd_reposition,
            mavlink.MAV_CMD_CONDITION_YAW: self.cmd_condition_yaw,
            mavlink.MAV_CMD_PREFLIGHT_CALIBRATION: self.cmd_preflight_calibration,
        }
        """MAV_CMD → handler."""

    def sample(self, depth: float) -> None:
        """One tick's pressure depth (m), as the firmware used it."""
        if math.isfinite(depth):
            self.depths.append(float(depth))

    def cmd_set_servo(self, ep: int, msg, p: Params7) -> int:
        """MAV_CMD_DO_SET_SERVO: p1 output 1–16, p2 PWM (µs); outputs 9–16 whose function is free."""
        return self.joystick.set_servo(p[0], p[1])

    def cmd_condition_yaw(self, ep: int, msg, p: Params7) -> int:
        """MAV_CMD_CONDITION_YAW: ArduSub accepts p1 in [0, 360] with p4 0 or 1, else DENIED.

        Yaw is not a degree of freedom here: an accepted command changes nothing.
        """
        if 0.0 <= p[0] <= 360.0 and p[3] in (0.0, 1.0):
            return MAV_RESULT.ACCEPTED
        return MAV_RESULT.DENIED

    def cmd_reposition(self, ep: int, msg, p: Params7) -> int:
        """MAV_CMD_DO_REPOSITION: go to p5 lat, p6 lon, p7 alt in GUIDED (p2 bit 0: switch to GUIDED).

        As ArduSub: DENIED outside GUIDED without the change-mode flag, for an invalid or zero
        location or an unsupported frame; FAILED if GUIDED cannot be entered. COMMAND_LONG is taken
        as MAV_FRAME_GLOBAL (as ArduPilot converts it); COMMAND_INT's frame may be GLOBAL or
        GLOBAL_RELATIVE_ALT (to home). x follows the latitude; the longitude is not a DoF here.
        """
        fw = self.fw
        change_mode = finite(p[1]) and int(p[1]) & mavlink.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE
        if fw.mode != Mode.GUIDED and not change_mode:
            return MAV_RESULT.DENIED
        is_int = msg.get_type() == "COMMAND_INT"
        frame = msg.frame if is_int else mavlink.MAV_FRAME_GLOBAL
        scale = 1e-7 if is_int else 1.0
        if not finite(p[4], p[5], p[6]) or frame not in _ABSOLUTE + _RELATIVE:
            return MAV_RESULT.DENIED
        lat, lon, alt = p[4] * scale, p[5] * scale, p[6]
        if (lat == 0.0 and lon == 0.0) or not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
            return MAV_RESULT.DENIED
        snap = self.link.snapshot
        if snap is None:
            return MAV_RESULT.FAILED
        if frame in _RELATIVE:
            alt += home_location(snap, self.link.state)[2]
        x = math.radians(lat - snap.origin_lat) * EARTH_RADIUS_M
        if fw.mode != Mode.GUIDED and fw.request_mode(Mode.GUIDED) != MAV_RESULT.ACCEPTED:
            return MAV_RESULT.FAILED
        return MAV_RESULT.ACCEPTED if fw.set_target(x, -alt, None) == MAV_RESULT.ACCEPTED else MAV_RESULT.FAILED

    def cmd_preflight_calibration(self, ep: int, msg, p: Params7) -> int:
        """MAV_CMD_PREFLIGHT_CALIBRATION: p3 = 1 zeroes the depth at the vehicle's depth now (at the surface).

        As ArduSub's barometer calibration: FAILED armed ("Disarm before calibration.") or without a
        working depth sensor; the compass-motor calibration (p6 = 1) is UNSUPPORTED with ArduSub's
        text; the other calibrations are UNSUPPORTED (no magnetometer or accelerometer to calibrate).
        """
        if p[5] == 1.0:
            self.link.statustext(MAV_SEVERITY.INFO, "#CompassMot calibration not supported", ep)
            return MAV_RESULT.UNSUPPORTED
        if p[2] != 1.0:
            return MAV_RESULT.UNSUPPORTED
        fw = self.fw
        if fw.armed:
            self.link.statustext(MAV_SEVERITY.INFO, "Disarm before calibration.", ep)
            return MAV_RESULT.FAILED
        if not fw.sensors_healthy or not self.depths:
            self.link.statustext(MAV_SEVERITY.WARNING, "Depth sensor is not connected.", ep)
            return MAV_RESULT.FAILED
        fw.depth_offset += sum(self.depths) / len(self.depths)
        self.depths.clear()
        self.link.statustext(MAV_SEVERITY.INFO, "Barometer calibration complete", ep)
        return MAV_RESULT.ACCEPTED
