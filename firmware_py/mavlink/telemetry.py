"""Telemetry: each message the vehicle streams, built from a :class:`TelemetrySnapshot` (ArduSub's streams).

A builder is a pure function ``build(snap, link) -> list[message]`` of the
firmware's snapshot and the link's own state (:class:`LinkState`: its clock,
counters, scheduler statistics, RC channels). It returns an empty list when it
has nothing to report yet (before the first control tick), and never raises on
odd values: NaN, inf and out-of-range numbers are clipped into the field.

:data:`STREAM_GROUPS` says which ``SR0_*`` parameter paces which message,
as ArduPilot's stream groups do.
"""
from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, cast

from ..modes import AUTO_AXES, GUIDED_GROUP
from ..sensors import depth_to_pressure
from ..telemetry_snapshot import TelemetrySnapshot
from .wire import FLIGHT_SW_VERSION, ID, INT16_MAX, RC_NEUTRAL, UINT16_MAX, clip_int, mavlink

if TYPE_CHECKING:
    from .battery import BatteryState
    from .vibration import VibrationMonitor

__all__ = [
    "BUILDERS",
    "CAPABILITIES",
    "DATA_STREAM_PARAMS",
    "HEARTBEAT_INTERVAL_NS",
    "MSG_GROUP",
    "STREAMED",
    "STREAM_GROUPS",
    "Builder",
    "LinkState",
    "autopilot_version",
]

CAPABILITIES = (mavlink.MAV_PROTOCOL_CAPABILITY_MAVLINK2 | mavlink.MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT
                | mavlink.MAV_PROTOCOL_CAPABILITY_COMMAND_INT
                | mavlink.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED
                | mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_INT | mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_FLOAT)
"""What AUTOPILOT_VERSION claims: only what this link implements."""

BASE_MODE_ALWAYS = (mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | mavlink.MAV_MODE_FLAG_STABILIZE_ENABLED
                    | mavlink.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED)

_S = mavlink
SENSORS_PRESENT = (_S.MAV_SYS_STATUS_SENSOR_3D_GYRO | _S.MAV_SYS_STATUS_SENSOR_3D_ACCEL
                   | _S.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE | _S.MAV_SYS_STATUS_SENSOR_VISION_POSITION
                   | _S.MAV_SYS_STATUS_SENSOR_ANGULAR_RATE_CONTROL | _S.MAV_SYS_STATUS_SENSOR_ATTITUDE_STABILIZATION
                   | _S.MAV_SYS_STATUS_SENSOR_Z_ALTITUDE_CONTROL | _S.MAV_SYS_STATUS_SENSOR_XY_POSITION_CONTROL
                   | _S.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS | _S.MAV_SYS_STATUS_AHRS)
"""MAV_SYS_STATUS_SENSOR bits this vehicle has."""
_SENSOR_BITS = (_S.MAV_SYS_STATUS_SENSOR_3D_GYRO | _S.MAV_SYS_STATUS_SENSOR_3D_ACCEL
                | _S.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE)
_CONTROL_BITS = (_S.MAV_SYS_STATUS_SENSOR_ATTITUDE_STABILIZATION | _S.MAV_SYS_STATUS_SENSOR_Z_ALTITUDE_CONTROL
                 | _S.MAV_SYS_STATUS_SENSOR_XY_POSITION_CONTROL | _S.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS)

WATER_TEMPERATURE_CDEG = 1000        # SCALED_PRESSURE2.temperature: nominal 10 °C (no temperature sensor)
EARTH_RADIUS_M = 6378137.0
HEARTBEAT_INTERVAL_NS = 1_000_000_000

STREAM_GROUPS: dict[str, tuple[int, ...]] = {
    "SR0_RAW_SENS": (ID["RAW_IMU"], ID["SCALED_PRESSURE"], ID["SCALED_PRESSURE2"]),
    "SR0_EXT_STAT": (ID["SYS_STATUS"], ID["POWER_STATUS"], ID["MEMINFO"], ID["MISSION_CURRENT"], ID["GPS_RAW_INT"],
                     ID["NAV_CONTROLLER_OUTPUT"], ID["NAMED_VALUE_FLOAT"]),
    "SR0_RC_CHAN": (ID["SERVO_OUTPUT_RAW"], ID["RC_CHANNELS"]),
    "SR0_POSITION": (ID["GLOBAL_POSITION_INT"], ID["LOCAL_POSITION_NED"]),
    "SR0_EXTRA1": (ID["ATTITUDE"], ID["AHRS2"]),
    "SR0_EXTRA2": (ID["VFR_HUD"],),
    "SR0_EXTRA3": (ID["SYSTEM_TIME"], ID["BATTERY_STATUS"], ID["EKF_STATUS_REPORT"], ID["VIBRATION"]),
}
"""Stream-rate parameter (Hz) → the messages it paces (ArduPilot's SR0_* groups)."""

DATA_STREAM_PARAMS = {
    mavlink.MAV_DATA_STREAM_RAW_SENSORS: "SR0_RAW_SENS",
    mavlink.MAV_DATA_STREAM_EXTENDED_STATUS: "SR0_EXT_STAT",
    mavlink.MAV_DATA_STREAM_RC_CHANNELS: "SR0_RC_CHAN",
    mavlink.MAV_DATA_STREAM_POSITION: "SR0_POSITION",
    mavlink.MAV_DATA_STREAM_EXTRA1: "SR0_EXTRA1",
    mavlink.MAV_DATA_STREAM_EXTRA2: "SR0_EXTRA2",
    mavlink.MAV_DATA_STREAM_EXTRA3: "SR0_EXTRA3",
}
"""REQUEST_DATA_STREAM's req_stream_id → the SR0_ parameter it sets (MAV_DATA_STREAM_ALL sets them all)."""

MSG_GROUP = {mid: group for group, ids in STREAM_GROUPS.items() for mid in ids}
STREAMED = (ID["HEARTBEAT"], *tuple(MSG_GROUP))
"""Every message sent on a schedule: HEARTBEAT (1 Hz) and the stream groups' messages."""


@dataclass
class LinkState:
    """The link's side of what telemetry reports (filled by the link, read by the builders).

    Attributes
    ----------
    now_ns : int
        The link's current slot on the firmware's clock (ns); the timestamp before the first tick.
    sysid : int
        This vehicle's system id.
    counters : mapping
        The link's counters (SYS_STATUS reports drops and errors).
    sched_stats : dict or None
        The firmware scheduler's statistics (load, overruns, control-task timing).
    rc : list of int
        RC channels 1–11 as the pilot last set them (µs), ArduSub's channel order: 1 pitch, 2 roll,
        3 throttle, 4 yaw, 5 forward, 6 lateral, 7, 8 camera tilt, 9 lights 1, 10 lights 2, 11 video switch.
    servo : list of int
        Outputs 9–16 (µs; 0 never set): DO_SET_SERVO and the SERVOn_FUNCTION pass-throughs.
    battery : BatteryState or None
        The simulated battery's last reading.
    vibration : VibrationMonitor or None
        Body acceleration and vibration levels (RAW_IMU, VIBRATION).
    ekf_thresh : float
        FS_EKF_THRESH (m): EKF_STATUS_REPORT's test ratios are 1-sigma over it.
    epoch_us : int or None
        Unix time (µs) at vehicle time 0: SYSTEM_TIME's clock is this plus the vehicle time.
    mission_seq, mission_total : int
        The current mission item and the number of items (home included).
    home : tuple of float or None
        Home (latitude deg, longitude deg, altitude m) as MAV_CMD_DO_SET_HOME set it; None: the
        local origin (WK_ORIGIN_LAT/LON) at the sea surface.
    """

    now_ns: int = 0
    sysid: int = 1
    counters: Mapping[str, int] = field(default_factory=dict)
    sched_stats: dict | None = None
    rc: list[int] = field(default_factory=lambda: [RC_NEUTRAL] * 8 + [1100, 1100, 1100])
    servo: list[int] = field(default_factory=lambda: [0] * 8)
    battery: BatteryState | None = None
    vibration: VibrationMonitor | None = None
    ekf_thresh: float = 2.0
    epoch_us: int | None = None
    mission_seq: int = 0
    mission_total: int = 1
    home: tuple[float, float, float] | None = None


Builder = Callable[[TelemetrySnapshot, LinkState], list]


def time_boot_ms(snap: TelemetrySnapshot, link: LinkState) -> int:
    """The vehicle time of the snapshot's tick (the link's clock before the first tick), ms, wrapped to uint32."""
    t = snap.t if snap.t is not None else link.now_ns * 1e-9
    return clip_int(t * 1000.0, 0, 2**63) & 0xFFFFFFFF


def ned_state(snap: TelemetrySnapshot) -> tuple[float, float, float, float, float, float]:
    """x (m), depth (m), pitch θ (rad), NED velocities vx, vz (m/s) and pitch rate q (rad/s) of the estimate."""
    x, z, th, u, w, q = snap.x_hat[:6]
    c, s = (math.cos(th), math.sin(th)) if math.isfinite(th) else (math.nan, math.nan)
    return x, z, th, u * c + w * s, -u * s + w * c, q


def heartbeat(snap: TelemetrySnapshot, link: LinkState) -> list:
    """HEARTBEAT: a Sub running ArduPilot; base_mode flags as ArduSub sets them."""
    base = BASE_MODE_ALWAYS
    if snap.mode in GUIDED_GROUP:
        base |= mavlink.MAV_MODE_FLAG_GUIDED_ENABLED
    if snap.armed:
        base |= mavlink.MAV_MODE_FLAG_SAFETY_ARMED
    return [mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_SUBMARINE, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA,
                                              base, snap.mode, snap.system_status, 3)]


def _sensor_bits(snap: TelemetrySnapshot) -> tuple[int, int]:
    """(enabled, health) MAV_SYS_STATUS_SENSOR bit fields."""
    enabled = SENSORS_PRESENT & ~_CONTROL_BITS
    axes = cast("dict[int, tuple[bool, bool, bool]]", AUTO_AXES)
    surge, heave, pitch = axes.get(snap.mode, (False, False, False))
    if pitch:
        enabled |= _S.MAV_SYS_STATUS_SENSOR_ATTITUDE_STABILIZATION
    if heave:
        enabled |= _S.MAV_SYS_STATUS_SENSOR_Z_ALTITUDE_CONTROL
    if surge:
        enabled |= _S.MAV_SYS_STATUS_SENSOR_XY_POSITION_CONTROL
    if snap.armed:
        enabled |= _S.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS
    health = SENSORS_PRESENT
    if not snap.sensors_healthy:
        health &= ~_SENSOR_BITS
    if not snap.ekf_converged:
        health &= ~(_S.MAV_SYS_STATUS_AHRS | _S.MAV_SYS_STATUS_SENSOR_VISION_POSITION)
    return enabled, health


def _load_permille(st: dict) -> int:
    """The firmware's own tasks' mean compute per period, ‰ (a SITL world's step is not its load)."""
    tasks = st.get("tasks") or {}
    if not tasks or not st.get("period_ns"):
        return 0
    busy_us = sum((t["compute"].get("mean_us") or 0.0) * t["rate_hz"] / st["loop_rate_hz"]
                  for name, t in tasks.items() if name != "world")
    return clip_int(1000.0 * busy_us / (st["period_ns"] / 1e3), 0, 1000)


def sys_status(snap: TelemetrySnapshot, link: LinkState) -> list:
    """SYS_STATUS: sensors, load (‰), link drop rate (c%) and error counters (scheduler overruns, skips)."""
    if not snap.has_tick:
        return []
    enabled, health = _sensor_bits(snap)
    c = link.counters
    st = link.sched_stats or {}
    received = c["rx"] + c["rx_bad"]
    drop = clip_int(10000.0 * (c["rx_bad"] + c["inbox_dropped"]) / received, 0, 10000) if received else 0
    u16 = lambda v: clip_int(v, 0, UINT16_MAX)   # noqa: E731
    present = SENSORS_PRESENT | _S.MAV_SYS_STATUS_PREARM_CHECK
    enabled |= _S.MAV_SYS_STATUS_PREARM_CHECK
    if snap.prearm_ok:
        health |= _S.MAV_SYS_STATUS_PREARM_CHECK
    b = link.battery
    volt_mv, current_ca, remaining = UINT16_MAX, -1, -1
    if b is not None:
        present |= _S.MAV_SYS_STATUS_SENSOR_BATTERY
        enabled |= _S.MAV_SYS_STATUS_SENSOR_BATTERY
        health |= _S.MAV_SYS_STATUS_SENSOR_BATTERY
        volt_mv = clip_int(b.voltage * 1000.0, 0, UINT16_MAX - 1)
        current_ca = clip_int(b.current * 100.0, -1, INT16_MAX)
        remaining = clip_int(b.remaining_pct, -1, 100)
    return [mavlink.MAVLink_sys_status_message(
        present, enabled, health, _load_permille(st), volt_mv, current_ca, remaining, drop, u16(c["rx_bad"]),
        u16(c["inbox_dropped"]), u16(c["rx_unsigned"]), u16(st.get("overruns", 0)),
        u16(st.get("skipped_slots", 0)))]


def named_values(snap: TelemetrySnapshot, link: LinkState) -> list:
    """NAMED_VALUE_FLOAT × 7: forecast age (s), feed-forward on, predicted wave load (N, N m), loop timing.

    TICK_P99 is the control task's compute p99 (ms); TICK_MISS the missed deadlines (overruns, plus
    slots a paced SITL run fell behind), as ArduPilot reports its loop timing.
    """
    if not snap.has_tick:
        return []
    st = link.sched_stats or {}
    control = (st.get("tasks") or {}).get("control") or {}
    p99 = (control.get("compute") or {}).get("p99_us")
    tau = snap.tau_e_hat
    values = ((b"FF_AGE", snap.forecast_age), (b"FF_ON", 1.0 if snap.ff_active else 0.0),
              (b"FF_X", tau[0]), (b"FF_Z", tau[1]), (b"FF_M", tau[2]), (b"TICK_P99", (p99 or 0.0) / 1e3),
              (b"TICK_MISS", float(st.get("overruns", 0) + snap.late_slots)))
    ms = time_boot_ms(snap, link)
    return [mavlink.MAVLink_named_value_float_message(ms, name, float(v)) for name, v in values]


def scaled_pressure2(snap: TelemetrySnapshot, link: LinkState) -> list:
    """SCALED_PRESSURE2 (the Bar30 on a BlueROV2): absolute pressure (hPa) of the measured depth."""
    if not snap.has_tick:
        return []
    depth = snap.measured_depth if math.isfinite(snap.measured_depth) else snap.x_hat[1]
    if not math.isfinite(depth):
        return []
    return [mavlink.MAVLink_scaled_pressure2_message(time_boot_ms(snap, link), depth_to_pressure(depth) / 100.0,
                                                     0.0, WATER_TEMPERATURE_CDEG)]


def gps_raw_int(snap: TelemetrySnapshot, link: LinkState) -> list:
    """GPS_RAW_INT as ArduPilot sends it without a GPS: fix_type 0 (NO_GPS), no position, DOPs unknown.

    A submarine has no GPS under water; clients that wait for this message (dronekit) get it all the same.
    """
    return [mavlink.MAVLink_gps_raw_int_message(0, mavlink.GPS_FIX_TYPE_NO_GPS, 0, 0, 0, UINT16_MAX, UINT16_MAX,
                                                0, 0, 0)]


def home_location(snap: TelemetrySnapshot, link: LinkState) -> tuple[float, float, float]:
    """Home: (latitude deg, longitude deg, altitude m, the sea surface 0)."""
    return link.home if link.home is not None else (snap.origin_lat, snap.origin_lon, 0.0)


def home_position(snap: TelemetrySnapshot, link: LinkState) -> list:
    """HOME_POSITION: home (degE7, mm) and its NED offset from the origin (m); q identity, no approach."""
    lat, lon, alt = home_location(snap, link)
    north = math.radians(lat - snap.origin_lat) * EARTH_RADIUS_M
    east = math.radians(lon - snap.origin_lon) * EARTH_RADIUS_M * math.cos(math.radians(snap.origin_lat))
    return [mavlink.MAVLink_home_position_message(
        clip_int(lat * 1e7, -900000000, 900000000), clip_int(lon * 1e7, -1800000000, 1800000000),
        clip_int(alt * 1000.0, -2**31, 2**31 - 1), north, east, -alt, [1.0, 0.0, 0.0, 0.0], 0.0, 0.0, 0.0,
        clip_int((snap.t or 0.0) * 1e6, 0, 2**63))]


def gps_global_origin(snap: TelemetrySnapshot, link: LinkState) -> list:
    """GPS_GLOBAL_ORIGIN: the local NED origin, WK_ORIGIN_LAT/LON at the sea surface (degE7, mm)."""
    return [mavlink.MAVLink_gps_global_origin_message(
        clip_int(snap.origin_lat * 1e7, -900000000, 900000000),
        clip_int(snap.origin_lon * 1e7, -1800000000, 1800000000), 0, clip_int((snap.t or 0.0) * 1e6, 0, 2**63))]


def mission_current(snap: TelemetrySnapshot, link: LinkState) -> list:
    """MISSION_CURRENT: the current item and the mission's size (home included)."""
    return [mavlink.MAVLink_mission_current_message(clip_int(link.mission_seq, 0, UINT16_MAX),
                                                    clip_int(link.mission_total, 0, UINT16_MAX))]


def servo_output_raw(snap: TelemetrySnapshot, link: LinkState) -> list:
    """SERVO_OUTPUT_RAW: the eight thruster PWMs (µs) of the last tick."""
    if not snap.has_tick:
        return []
    pwm = [clip_int(v, 0, UINT16_MAX) for v in snap.pwm[:8]]
    pwm += [0] * (8 - len(pwm))
    aux = [clip_int(v, 0, UINT16_MAX) for v in link.servo[:8]]
    aux += [0] * (8 - len(aux))
    t_us = clip_int((snap.t or 0.0) * 1e6, 0, 2**63)
    return [mavlink.MAVLink_servo_output_raw_message(t_us & 0xFFFFFFFF, 0, *pwm, *aux)]


def rc_channels(snap: TelemetrySnapshot, link: LinkState) -> list:
    """RC_CHANNELS: the pilot's channels 1–11 (µs) as MANUAL_CONTROL / RC_CHANNELS_OVERRIDE set them."""
    if not snap.has_tick:
        return []
    rc = [clip_int(v, 0, UINT16_MAX) for v in link.rc[:18]]
    return [mavlink.MAVLink_rc_channels_message(time_boot_ms(snap, link), len(rc), *rc,
                                                *([UINT16_MAX] * (18 - len(rc))), 255)]


def global_position_int(snap: TelemetrySnapshot, link: LinkState) -> list:
    """GLOBAL_POSITION_INT: the estimate about the WK_ORIGIN_LAT/LON origin (degE7, mm, cm/s)."""
    if not snap.has_tick:
        return []
    x, z, _th, vx, vz, _q = ned_state(snap)
    lat = snap.origin_lat + math.degrees(x / EARTH_RADIUS_M) if math.isfinite(x) else snap.origin_lat
    alt_mm = clip_int(-z * 1000.0, -2**31, 2**31 - 1)
    return [mavlink.MAVLink_global_position_int_message(
        time_boot_ms(snap, link), clip_int(lat * 1e7, -900000000, 900000000),
        clip_int(snap.origin_lon * 1e7, -1800000000, 1800000000), alt_mm, alt_mm,
        clip_int(vx * 100.0, -32768, INT16_MAX), 0, clip_int(vz * 100.0, -32768, INT16_MAX), 0)]


def local_position_ned(snap: TelemetrySnapshot, link: LinkState) -> list:
    """LOCAL_POSITION_NED: x and depth (m), NED velocities (m/s); y is 0 in this 3-DoF vehicle."""
    if not snap.has_tick:
        return []
    x, z, _th, vx, vz, _q = ned_state(snap)
    return [mavlink.MAVLink_local_position_ned_message(time_boot_ms(snap, link), x, 0.0, z, vx, 0.0, vz)]


def attitude(snap: TelemetrySnapshot, link: LinkState) -> list:
    """ATTITUDE: pitch (rad) and pitch rate (rad/s); roll and yaw are 0."""
    if not snap.has_tick:
        return []
    _x, _z, th, _vx, _vz, q = ned_state(snap)
    return [mavlink.MAVLink_attitude_message(time_boot_ms(snap, link), 0.0, th, 0.0, 0.0, q, 0.0)]


def vfr_hud(snap: TelemetrySnapshot, link: LinkState) -> list:
    """VFR_HUD: speed (m/s), throttle (%, 50 neutral, from the heave command), altitude −depth (m), climb (m/s)."""
    if not snap.has_tick:
        return []
    _x, z, _th, vx, vz, _q = ned_state(snap)
    throttle = clip_int(50.0 - 50.0 * snap.heave_force / snap.tau_max_z, 0, 100, 50)
    speed = abs(vx) if math.isfinite(vx) else 0.0
    return [mavlink.MAVLink_vfr_hud_message(speed, speed, 0, throttle, -z, -vz)]


def system_time(snap: TelemetrySnapshot, link: LinkState) -> list:
    """SYSTEM_TIME: Unix time (µs) = a fixed epoch + the vehicle's time, and the time since boot (ms).

    The epoch is the wall clock at vehicle time 0 (:attr:`LinkState.epoch_us`), so the two fields
    agree in every run, paced or not; in a real-time run the Unix time is the wall clock.
    """
    t = snap.t if snap.t is not None else link.now_ns * 1e-9
    epoch = link.epoch_us if link.epoch_us is not None else int(time.time() * 1e6 - t * 1e6)
    return [mavlink.MAVLink_system_time_message(clip_int(epoch + t * 1e6, 0, 2**63), time_boot_ms(snap, link))]


def autopilot_version(snap: TelemetrySnapshot, link: LinkState) -> list:
    """AUTOPILOT_VERSION: capabilities (:data:`CAPABILITIES`) and the firmware version."""
    return [mavlink.MAVLink_autopilot_version_message(
        CAPABILITIES, FLIGHT_SW_VERSION, 0, 0, 0, [0] * 8, [0] * 8, [0] * 8, 0, 0, link.sysid)]


BUILDERS: dict[int, Builder] = {
    ID["HEARTBEAT"]: heartbeat,
    ID["SYS_STATUS"]: sys_status,
    ID["NAMED_VALUE_FLOAT"]: named_values,
    ID["SCALED_PRESSURE2"]: scaled_pressure2,
    ID["SERVO_OUTPUT_RAW"]: servo_output_raw,
    ID["GPS_RAW_INT"]: gps_raw_int,
    ID["MISSION_CURRENT"]: mission_current,
    ID["HOME_POSITION"]: home_position,
    ID["GPS_GLOBAL_ORIGIN"]: gps_global_origin,
    ID["RC_CHANNELS"]: rc_channels,
    ID["GLOBAL_POSITION_INT"]: global_position_int,
    ID["LOCAL_POSITION_NED"]: local_position_ned,
    ID["ATTITUDE"]: attitude,
    ID["VFR_HUD"]: vfr_hud,
    ID["SYSTEM_TIME"]: system_time,
    ID["AUTOPILOT_VERSION"]: autopilot_version,
}
"""Message id → its builder: what can be streamed or asked for with MAV_CMD_REQUEST_MESSAGE."""
