"""ArduSub 4.7's parameters: the ones Wavekeep acts on, and the rest of ArduSub's table, read-only.

Wavekeep follows ArduSub 4.7 (the release of the reference binary, "ArduSub V4.7.0-dev"): it serves
that release's names (``MAV_SYSID``, ``MAV_GCS_SYSID``, the ``MAV1_*`` stream rates...), with that
release's types and defaults, so a ground station that reads or sets an ArduSub parameter finds it.

* :data:`ARDUSUB_DEFS`: the ArduSub parameters that act here (failsafes, arming checks, joystick,
  outputs, stream rates, ids, the camera mount), with ranges; their defaults are in
  ``configs/firmware/params.yaml`` (ArduSub's, where docs/mavlink.md does not say otherwise).
* :func:`reference_defs`: every other parameter of ArduSub's table, from
  ``configs/firmware/ardusub_params.csv`` (read from the real binary; its header says how), served
  read-only with ArduSub's default: they mean nothing on this vehicle (compass and IMU calibration,
  position-controller gains, terrain, logging...). ArduPilot SITL's own ``SIM_*`` are not in it.
"""
from __future__ import annotations

import csv
from functools import lru_cache
from pathlib import Path

from bridge.configfile import ConfigError, configs_dir

from .definitions import INT_TYPE_RANGES, PARAM_TYPES, ParamDef

__all__ = ["ARDUSUB_DEFS", "ARDUSUB_RELEASE", "RCIN_PASSTHROUGH", "REFERENCE_FILE", "reference_defs",
           "reference_table"]

ARDUSUB_RELEASE = (4, 7, 0)
"""The ArduSub release whose MAVLink, parameters and texts Wavekeep follows."""
REFERENCE_FILE = "ardusub_params.csv"
"""ArduSub's parameter table, in ``configs/firmware/``."""
RCIN_PASSTHROUGH = range(59, 67)
"""SERVOn_FUNCTION values RCIN9…RCIN16: the output passes RC input 9–16 through."""
_FLOAT32_MAX = 3.4028234663852886e38


def _defs() -> list[ParamDef]:
    i8, i16, i32 = "INT8", "INT16", "INT32"
    defs = [
        ParamDef("ARMING_CHECK", 0, 2**20, "", "pre-arm checks (bitmask): 1 all, 2 baro, 16 INS/AHRS, "
                 "64 RC, 128 board voltage, 256 battery", ptype=i32),
        ParamDef("FS_PILOT_INPUT", 0, 2, "", "pilot input failsafe: 0 off, 1 warn, 2 disarm", ptype=i8),
        ParamDef("FS_PILOT_TIMEOUT", 0.1, 3.0, "s", "pilot input failsafe timeout"),
        ParamDef("FS_GCS_ENABLE", 0, 4, "", "GCS failsafe: 0 off, 1 warn, 2 disarm, 3 depth hold, 4 surface",
                 ptype=i8),
        ParamDef("FS_GCS_TIMEOUT", 0.1, 120.0, "s", "GCS heartbeat timeout"),
        ParamDef("FS_EKF_ACTION", 0, 2, "", "EKF failsafe: 0 off, 1 warn, 2 disarm", ptype=i8),
        ParamDef("FS_EKF_THRESH", 0.0, 10.0, "", "EKF failsafe when its velocity test ratio (EKF_STATUS_REPORT: "
                 "position 1-sigma / WK_EKF_SD_BAD) stays above this for 2 s, or the state is not finite"),
        ParamDef("MAV_SYSID", 1, 255, "", "this vehicle's MAVLink system id", ptype=i16),
        ParamDef("MAV_GCS_SYSID", 1, 255, "", "the ground station's MAVLink system id", ptype=i16),
        ParamDef("JS_GAIN_DEFAULT", 0.1, 1.0, "", "pilot gain at boot"),
        ParamDef("JS_GAIN_MAX", 0.2, 1.0, "", "largest pilot gain"),
        ParamDef("JS_GAIN_MIN", 0.1, 0.8, "", "smallest pilot gain"),
        ParamDef("JS_GAIN_STEPS", 1, 10, "", "pilot gain steps from min to max", ptype=i8),
        ParamDef("JS_THR_GAIN", 0.5, 4.0, "", "extra gain on the throttle stick"),
        ParamDef("JS_LIGHTS_STEPS", 1, 100, "", "lights brighter/dimmer steps from off to full", ptype=i16),
        ParamDef("MNT1_RC_RATE", 0, 90, "deg/s", "camera mount: tilt rate while a tilt button is held", ptype=i16),
        ParamDef("MNT1_PITCH_MIN", -90, 90, "deg", "camera mount: lowest tilt (the output's minimum)", ptype=i16),
        ParamDef("MNT1_PITCH_MAX", -90, 90, "deg", "camera mount: highest tilt (the output's maximum)", ptype=i16),
        ParamDef("ACRO_RP_P", 1.0, 10.0, "", "ACRO: pitch rate at full stick, in ANGLE_MAX per second"),
        ParamDef("ANGLE_MAX", 1000, 8000, "cdeg", "largest pitch target (ACRO)", ptype=i16),
        ParamDef("BATT_CAPACITY", 0, 2**20, "mAh", "battery capacity: remaining % is counted against it", ptype=i32),
        ParamDef("RC_OVERRIDE_TIME", -1.0, 120.0, "s", "RC_CHANNELS_OVERRIDE expires after this "
                 "(-1 never); pass-through outputs go neutral"),
    ]
    for group, doc in (("RAW_SENS", "RAW_IMU, SCALED_PRESSURE, SCALED_PRESSURE2"),
                       ("EXT_STAT", "SYS_STATUS, MISSION_CURRENT, GPS_RAW_INT, NAMED_VALUE_FLOAT..."),
                       ("RC_CHAN", "SERVO_OUTPUT_RAW, RC_CHANNELS"),
                       ("POSITION", "GLOBAL_POSITION_INT, LOCAL_POSITION_NED"), ("EXTRA1", "ATTITUDE, AHRS, AHRS2"),
                       ("EXTRA2", "VFR_HUD"), ("EXTRA3", "SYSTEM_TIME, BATTERY_STATUS, EKF_STATUS_REPORT...")):
        defs.append(ParamDef(f"MAV1_{group}", 0, 50, "Hz", f"stream rate of {doc}", ptype=i16))
    for b in range(16):
        defs.append(ParamDef(f"BTN{b}_FUNCTION", 0, 127, "", f"joystick button {b} function", ptype=i8))
        defs.append(ParamDef(f"BTN{b}_SFUNCTION", 0, 127, "", f"joystick button {b} function with shift", ptype=i8))
    for ch in range(1, 9):     # a thruster output: its motor, or RC input 9-16 passed through (companion servo mode)
        defs.append(ParamDef(f"SERVO{ch}_FUNCTION", -1, 200, "", f"output {ch} function (32+{ch}: motor {ch}, "
                             "59-66: RCIN9-16 pass-through)", ptype=i16,
                             allowed=frozenset({32.0 + ch, *(float(f) for f in RCIN_PASSTHROUGH)})))
    for ch in range(9, 17):
        defs.append(ParamDef(f"SERVO{ch}_FUNCTION", -1, 200, "", f"output {ch} function (51-66 RC input "
                             "pass-through, 7 camera tilt, 181/182 lights 1/2, 183 video switch)", ptype=i16))
    return defs


ARDUSUB_DEFS: tuple[ParamDef, ...] = tuple(_defs())
"""The ArduSub parameters Wavekeep acts on (docs/mavlink.md says how each acts)."""


@lru_cache(maxsize=4)
def reference_table(path: str | None = None) -> tuple[tuple[str, float, str], ...]:
    """ArduSub's table as (name, default, MAV_PARAM_TYPE name) rows, from ``configs/firmware/ardusub_params.csv``.

    A malformed file is a :class:`~bridge.configfile.ConfigError` naming the file and the line.
    """
    file = Path(path) if path is not None else configs_dir() / "firmware" / REFERENCE_FILE
    rows = []
    try:
        with file.open(newline="", encoding="utf-8") as fh:
            lines = [(n, line) for n, line in enumerate(fh, 1) if line.strip() and not line.startswith("#")]
    except OSError as exc:
        raise ConfigError(file, None, f"cannot read ArduSub's parameter table: {exc}") from None
    for (n, _), row in zip(lines[1:], csv.reader(line for _, line in lines[1:]), strict=True):
        try:
            name, value, ptype = row
            if ptype not in PARAM_TYPES:
                raise ValueError(f"type {ptype!r} is not one of {', '.join(PARAM_TYPES)}")
            rows.append((name, float(value), ptype))
        except ValueError as exc:
            raise ConfigError(file, f"line {n}", f"expected name,value,type: {exc}") from None
    return tuple(rows)


def reference_defs(defined: set[str], path: str | None = None) -> tuple[list[ParamDef], dict[str, float]]:
    """Read-only definitions and values of every ArduSub parameter not in ``defined`` (Wavekeep's own).

    A parameter Wavekeep defines under an ArduSub name must have ArduSub's type: a ValueError otherwise.
    """
    defs, values = [], {}
    types = {}
    for name, value, ptype in reference_table(path):
        types[name] = ptype
        if name in defined:
            continue
        lo, hi = INT_TYPE_RANGES.get(ptype, (-_FLOAT32_MAX, _FLOAT32_MAX))
        defs.append(ParamDef(name, lo, hi, "", "ArduSub 4.7's; read-only: it means nothing on this vehicle",
                             ptype=ptype, readonly=True))
        values[name] = value
    for d in ARDUSUB_DEFS:
        if d.name in types and types[d.name] != d.ptype:
            raise ValueError(f"parameter {d.name} is {d.ptype} here but {types[d.name]} in ArduSub")
    return defs, values
