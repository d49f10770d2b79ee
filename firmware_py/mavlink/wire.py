"""Wire-level constants and value helpers shared by the MAVLink link's modules.

Everything here is protocol fact (message ids, ArduSub's numbers) or a pure
function that turns a firmware value into something a MAVLink field accepts
without raising (NaN, inf and out-of-range values are clipped or replaced).
"""
from __future__ import annotations

import math
import os

os.environ["MAVLINK20"] = "1"   # for any mavutil in this process (pymavlink reads it at import); the link
                                # itself packs and parses with the MAVLink 2 dialect module directly

from pymavlink.dialects.v20 import ardupilotmega as mavlink

__all__ = [
    "COMPONENT_ID",
    "ID",
    "INT16_MAX",
    "RC_NEUTRAL",
    "RC_RANGE",
    "SIGNING_EPOCH_S",
    "UINT16_MAX",
    "clip_int",
    "finite",
    "is_integer_value",
    "mavlink",
    "tidy_float32",
]

COMPONENT_ID = 1                      # MAV_COMP_ID_AUTOPILOT1
SIGNING_EPOCH_S = 1420070400          # MAVLink 2 signing timestamps count 10 µs from 2015-01-01

UINT16_MAX = 65535
INT16_MAX = 32767
RC_NEUTRAL = 1500                     # µs
RC_RANGE = 400                        # µs from neutral to full stick (1100–1900)

ID: dict[str, int] = {name: getattr(mavlink, f"MAVLINK_MSG_ID_{name}") for name in (
    "HEARTBEAT", "SYS_STATUS", "SYSTEM_TIME", "ATTITUDE", "LOCAL_POSITION_NED", "GLOBAL_POSITION_INT",
    "SERVO_OUTPUT_RAW", "RC_CHANNELS", "VFR_HUD", "SCALED_PRESSURE2", "NAMED_VALUE_FLOAT", "AUTOPILOT_VERSION",
    "SET_MODE", "PARAM_REQUEST_READ", "PARAM_REQUEST_LIST", "PARAM_SET", "REQUEST_DATA_STREAM", "MANUAL_CONTROL",
    "RC_CHANNELS_OVERRIDE", "COMMAND_LONG", "COMMAND_INT", "SET_POSITION_TARGET_LOCAL_NED", "TIMESYNC",
    "SET_POSITION_TARGET_GLOBAL_INT",
    "MISSION_REQUEST_LIST", "MISSION_COUNT", "MISSION_CLEAR_ALL", "AUTOPILOT_VERSION_REQUEST", "RADIO_STATUS",
    "RADIO", "GPS_RAW_INT", "MISSION_CURRENT", "HOME_POSITION", "GPS_GLOBAL_ORIGIN", "EXTENDED_SYS_STATE",
    "BATTERY_STATUS", "ATTITUDE_QUATERNION", "SCALED_PRESSURE", "RAW_IMU", "EKF_STATUS_REPORT", "POWER_STATUS",
    "MEMINFO", "VIBRATION", "NAV_CONTROLLER_OUTPUT", "AHRS2", "NAMED_VALUE_INT")}
"""Message ids by name, for the messages this link sends or handles."""


def clip_int(v: object, lo: int, hi: int, default: int = 0) -> int:
    """``round(v)`` clipped to [lo, hi]; ``default`` for NaN, inf or non-numbers (values from the firmware).

    Parameters
    ----------
    v : object
        Any value; numbers are rounded to the nearest integer.
    lo, hi : int
        Inclusive bounds of the field.
    default : int
        What a value that is not a finite number becomes.
    """
    try:
        f = float(v)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return default
    if not math.isfinite(f):
        return default
    return int(min(hi, max(lo, round(f))))


def finite(*values: object) -> bool:
    """True when every value is a finite int or float."""
    return all(isinstance(v, (int, float)) and math.isfinite(v) for v in values)


def is_integer_value(v: float) -> bool:
    """True for a finite float with no fractional part (a usable message id, mode number...)."""
    return finite(v) and v == int(v)


def tidy_float32(value: float) -> float:
    """A float32 from the wire as the decimal the sender most likely meant (0.1f → 0.1).

    Range bounds such as 1e-4 are then not missed by float32 rounding. Non-finite values pass unchanged.
    """
    if not math.isfinite(value):
        return value
    return float(f"{value:.7g}")
