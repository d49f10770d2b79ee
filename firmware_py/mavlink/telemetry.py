"""Telemetry: each message the vehicle streams, built from a :class:`TelemetrySnapshot` (ArduSub's streams).

A builder is a pure function ``build(snap, link) -> list[message]`` of the
firmware's snapshot and the link's own state (:class:`LinkState`: its clock,
counters, scheduler statistics, RC channels). It returns an empty list when it
has nothing to report yet (before the first control tick), and never raises on
odd values: NaN, inf and out-of-range numbers are clipped into the field.

:data:`STREAM_GROUPS` says which ``MAV1_*`` parameter paces which message,
as ArduPilot's stream groups do.
"""
from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, NamedTuple, cast

from ..hal.sensors import depth_to_pressure
from ..modes import AUTO_AXES, GUIDED_GROUP
from ..telemetry_snapshot import TelemetrySnapshot
from .identity import CAPABILITIES, FLIGHT_SW_VERSION, board_id, custom_version
from .wire import ID, INT16_MAX, RC_NEUTRAL, UINT16_MAX, clip_int, mavlink

if TYPE_CHECKING:
    from .battery import BatteryState
    from .vibration import VibrationMonitor

__all__ = [
    "BUILDERS",
    "DATA_STREAM_PARAMS",
    "HEARTBEAT_INTERVAL_NS",
    "MSG_GROUP",
    "STREAMED",
    "STREAM_GROUPS",
    "Builder",
    "LinkState",
    "autopilot_version",
]

BASE_MODE_ALWAYS = (mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | mavlink.MAV_MODE_FLAG_STABILIZE_ENABLED
                    | mavlink.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED)

_S = mavlink
_SENSORS = (_S.MAV_SYS_STATUS_SENSOR_3D_GYRO | _S.MAV_SYS_STATUS_SENSOR_3D_ACCEL | _S.MAV_SYS_STATUS_SENSOR_3D_MAG
            | _S.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE)
_ATTITUDE = (_S.MAV_SYS_STATUS_SENSOR_ANGULAR_RATE_CONTROL | _S.MAV_SYS_STATUS_SENSOR_ATTITUDE_STABILIZATION
             | _S.MAV_SYS_STATUS_SENSOR_YAW_POSITION | _S.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS)
_Z, _XY = _S.MAV_SYS_STATUS_SENSOR_Z_ALTITUDE_CONTROL, _S.MAV_SYS_STATUS_SENSOR_XY_POSITION_CONTROL
SENSORS_PRESENT = (_SENSORS | _S.MAV_SYS_STATUS_SENSOR_GPS | _ATTITUDE | _Z | _XY | _S.MAV_SYS_STATUS_GEOFENCE
                   | _S.MAV_SYS_STATUS_AHRS | _S.MAV_SYS_STATUS_SENSOR_BATTERY | _S.MAV_SYS_STATUS_PREARM_CHECK)
"""MAV_SYS_STATUS_SENSOR bits this vehicle has, as ArduSub reports them for a BlueROV2: IMU, compass, pressure,
the position fix (an acoustic positioning system reaches ArduSub as a GPS), the controllers and motor outputs,
a fence (never enabled), the AHRS, the battery monitor and the pre-arm checks; the RC receiver once a pilot
has been heard (the joystick's RC overrides)."""
_FIX_FRESH_S = 1.0                   # s: a position fix newer than this makes GPS_RAW_INT a 3D fix

WATER_TEMPERATURE_CDEG = 1000        # SCALED_PRESSURE2.temperature: nominal 10 °C (no temperature sensor)
EARTH_RADIUS_M = 6378137.0
HEARTBEAT_INTERVAL_NS = 1_000_000_000

STREAM_GROUPS: dict[str, tuple[int, ...]] = {
    "MAV1_RAW_SENS": (ID["RAW_IMU"], ID["SCALED_PRESSURE"], ID["SCALED_PRESSURE2"]),
    "MAV1_EXT_STAT": (ID["SYS_STATUS"], ID["POWER_STATUS"], ID["MEMINFO"], ID["MISSION_CURRENT"], ID["GPS_RAW_INT"],
                     ID["NAV_CONTROLLER_OUTPUT"], ID["NAMED_VALUE_FLOAT"]),
    "MAV1_RC_CHAN": (ID["SERVO_OUTPUT_RAW"], ID["RC_CHANNELS"]),
    "MAV1_POSITION": (ID["GLOBAL_POSITION_INT"], ID["LOCAL_POSITION_NED"]),
    "MAV1_EXTRA1": (ID["ATTITUDE"], ID["AHRS2"]),
    "MAV1_EXTRA2": (ID["VFR_HUD"],),
    "MAV1_EXTRA3": (ID["SYSTEM_TIME"], ID["BATTERY_STATUS"], ID["EKF_STATUS_REPORT"], ID["VIBRATION"]),
}
"""Stream-rate parameter (Hz) → the messages it paces (ArduPilot's MAV1_* groups)."""

DATA_STREAM_PARAMS = {
    mavlink.MAV_DATA_STREAM_RAW_SENSORS: "MAV1_RAW_SENS",
    mavlink.MAV_DATA_STREAM_EXTENDED_STATUS: "MAV1_EXT_STAT",
    mavlink.MAV_DATA_STREAM_RC_CHANNELS: "MAV1_RC_CHAN",
    mavlink.MAV_DATA_STREAM_POSITION: "MAV1_POSITION",
    mavlink.MAV_DATA_STREAM_EXTRA1: "MAV1_EXTRA1",
    mavlink.MAV_DATA_STREAM_EXTRA2: "MAV1_EXTRA2",
    mavlink.MAV_DATA_STREAM_EXTRA3: "MAV1_EXTRA3",
}
"""REQUEST_DATA_STREAM's req_stream_id → the MAV1_ parameter it sets (MAV_DATA_STREAM_ALL sets them all)."""

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
        RC channels 1–8 as the pilot last set them (µs), ArduSub's channel order: 1 pitch, 2 roll,
        3 throttle, 4 yaw, 5 forward, 6 lateral, 7, 8.
    rc_in : dict
        RC inputs 9–16 an RC_CHANNELS_OVERRIDE holds now: channel → µs.
    servo : list of int
        Outputs 9–16 (µs; 0 never set): the accessories, DO_SET_SERVO and the pass-throughs (:mod:`.accessories`).
    sub_info : tuple
        ArduSub's Sub-panel NAMED_VALUE_FLOATs, (name, value) in its order.
    pilot_seen, pilot_fresh : bool
        A joystick or RC override has been heard; and within FS_PILOT_TIMEOUT (SYS_STATUS's RC receiver).
    fix : tuple of float or None
        The last position fix: (vehicle time s, x m north).
    battery : BatteryState or None
        The simulated battery's last reading.
    vibration : VibrationMonitor or None
        Body acceleration and vibration levels (RAW_IMU, VIBRATION).
    ekf_sd_bad : float
        WK_EKF_SD_BAD (m): EKF_STATUS_REPORT's test ratios are the position 1-sigma over it.
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
    rc: list[int] = field(default_factory=lambda: [RC_NEUTRAL] * 8)
    rc_in: dict[int, int] = field(default_factory=dict)
    servo: list[int] = field(default_factory=lambda: [0] * 8)
    sub_info: tuple[tuple[str, float], ...] = ()
    pilot_seen: bool = False
    pilot_fresh: bool = False
    fix: tuple[float, float] | None = None
    battery: BatteryState | None = None
    vibration: VibrationMonitor | None = None
    ekf_sd_bad: float = 2.5
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


class Pose6(NamedTuple):
    """The estimate as a ground station sees it: NED position (m), zyx Euler angles (rad), NED velocity (m/s)
    and body rates (rad/s)."""

    x: float
    y: float
    z: float
    roll: float
    pitch: float
    yaw: float
    vn: float
    ve: float
    vd: float
    p: float
    q: float
    r: float


def pose6(snap: TelemetrySnapshot) -> Pose6:
    """The six-DoF estimate: with the lateral plane's [y, φ, ψ, v, p, r] when the vehicle has one (the NED velocity
    R(Θ) [u, v, w]), else the vertical plane's with y, roll, yaw and their rates 0 (:func:`ned_state`'s numbers)."""
    if not snap.lateral:
        x, z, th, vn, vd, q = ned_state(snap)
        return Pose6(x, 0.0, z, 0.0, th, 0.0, vn, 0.0, vd, 0.0, q, 0.0)
    x, z, th, u, w, q = snap.x_hat[:6]
    y, phi, psi, v, p, r = snap.lateral[:6]
    sf, cf = _sin_cos(phi)
    st, ct = _sin_cos(th)
    sp, cp = _sin_cos(psi)
    vn = cp * ct * u + (cp * st * sf - sp * cf) * v + (sp * sf + cp * cf * st) * w
    ve = sp * ct * u + (cp * cf + sf * st * sp) * v + (st * sp * cf - cp * sf) * w
    vd = -st * u + ct * sf * v + ct * cf * w
    return Pose6(x, y, z, phi, th, psi, vn, ve, vd, p, q, r)


def _sin_cos(a: float) -> tuple[float, float]:
    """sin and cos of an angle (rad); NaN for a non-finite one (math's raise: a diverged estimate is reported, the
    builders clip it)."""
    return (math.sin(a), math.cos(a)) if math.isfinite(a) else (math.nan, math.nan)


def heading_deg(yaw: float) -> float:
    """A heading (rad) as compass degrees in [0, 360) (0 when not finite)."""
    return math.degrees(yaw) % 360.0 if math.isfinite(yaw) else 0.0


def heartbeat(snap: TelemetrySnapshot, link: LinkState) -> list:
    """HEARTBEAT: a Sub running ArduPilot; base_mode flags as ArduSub sets them."""
    base = BASE_MODE_ALWAYS
    if snap.mode in GUIDED_GROUP:
        base |= mavlink.MAV_MODE_FLAG_GUIDED_ENABLED
    if snap.armed:
        base |= mavlink.MAV_MODE_FLAG_SAFETY_ARMED
    return [mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_SUBMARINE, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA,
                                              base, snap.mode, snap.system_status, 3)]


def _sensor_bits(snap: TelemetrySnapshot, link: LinkState) -> tuple[int, int, int]:
    """(present, enabled, health) MAV_SYS_STATUS_SENSOR bit fields, as ArduSub sets them."""
    present = SENSORS_PRESENT
    enabled = _SENSORS | _S.MAV_SYS_STATUS_SENSOR_GPS | _ATTITUDE | _S.MAV_SYS_STATUS_AHRS
    health = _ATTITUDE | _S.MAV_SYS_STATUS_GEOFENCE
    axes = cast("dict[int, tuple[bool, bool, bool]]", AUTO_AXES)
    surge, heave, _pitch = axes.get(snap.mode, (False, False, False))
    enabled |= (_Z if heave else 0) | (_XY if surge else 0)
    health |= (_Z if heave else 0) | (_XY if surge else 0)
    if snap.sensors_healthy:
        health |= _SENSORS
    if _fix_fresh(snap, link):
        health |= _S.MAV_SYS_STATUS_SENSOR_GPS
    if snap.ekf_converged:
        health |= _S.MAV_SYS_STATUS_AHRS
    if link.pilot_seen:
        present |= _S.MAV_SYS_STATUS_SENSOR_RC_RECEIVER
        enabled |= _S.MAV_SYS_STATUS_SENSOR_RC_RECEIVER
        health |= _S.MAV_SYS_STATUS_SENSOR_RC_RECEIVER if link.pilot_fresh else 0
    return present, enabled, health


def _fix_fresh(snap: TelemetrySnapshot, link: LinkState) -> bool:
    return link.fix is not None and snap.t is not None and snap.t - link.fix[0] <= _FIX_FRESH_S


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
    present, enabled, health = _sensor_bits(snap, link)
    c = link.counters
    st = link.sched_stats or {}
    received = c["rx"] + c["rx_bad"]
    drop = clip_int(10000.0 * (c["rx_bad"] + c["inbox_dropped"]) / received, 0, 10000) if received else 0
    u16 = lambda v: clip_int(v, 0, UINT16_MAX)   # noqa: E731
    enabled |= _S.MAV_SYS_STATUS_PREARM_CHECK
    if snap.prearm_ok:
        health |= _S.MAV_SYS_STATUS_PREARM_CHECK
    b = link.battery
    volt_mv, current_ca, remaining = UINT16_MAX, -1, -1
    if b is not None:
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
    """NAMED_VALUE_FLOAT: ArduSub's Sub-panel values (:mod:`.accessories`), then Wavekeep's own × 7.

    Wavekeep's: FF_AGE forecast age (s), FF_ON feed-forward on, FF_X/Z/M the predicted wave load (N, N m),
    TICK_P99 the control task's compute p99 (ms), TICK_MISS the missed deadlines (overruns, plus slots a
    paced SITL run fell behind), as ArduPilot reports its loop timing.
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
    sub = [(name.encode(), v) for name, v in link.sub_info]
    return [mavlink.MAVLink_named_value_float_message(ms, name, float(v)) for name, v in (*sub, *values)]


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
    """GPS_RAW_INT of the position fix, as ArduSub reports an acoustic positioning system fed to it as a GPS:
    a 3D fix at the fix's latitude (x north of the origin) and the origin's longitude, altitude −depth, while
    fixes come (within 1 s); satellites and DOPs unknown. Without one: fix type 0, no position."""
    if not _fix_fresh(snap, link) or not math.isfinite(snap.measured_depth):
        return [mavlink.MAVLink_gps_raw_int_message(0, mavlink.GPS_FIX_TYPE_NO_GPS, 0, 0, 0, UINT16_MAX,
                                                    UINT16_MAX, 0, 0, 0)]
    assert link.fix is not None
    t, x = link.fix
    lat = snap.origin_lat + math.degrees(x / EARTH_RADIUS_M)
    return [mavlink.MAVLink_gps_raw_int_message(
        clip_int(t * 1e6, 0, 2**63), mavlink.GPS_FIX_TYPE_3D_FIX, clip_int(lat * 1e7, -900000000, 900000000),
        clip_int(snap.origin_lon * 1e7, -1800000000, 1800000000), clip_int(-snap.measured_depth * 1000.0, -2**31,
                                                                            2**31 - 1),
        UINT16_MAX, UINT16_MAX, UINT16_MAX, UINT16_MAX, 255)]


def home_location(snap: TelemetrySnapshot, link: LinkState) -> tuple[float, float, float]:
    """Home: (latitude deg, longitude deg, altitude m, the sea surface 0)."""
    return link.home if link.home is not None else (snap.origin_lat, snap.origin_lon, 0.0)


def home_position(snap: TelemetrySnapshot, link: LinkState) -> list:
    """HOME_POSITION: home (degE7, mm) and its NED offset from the origin (m); q NaN (not known, as ArduSub)."""
    lat, lon, alt = home_location(snap, link)
    north = math.radians(lat - snap.origin_lat) * EARTH_RADIUS_M
    east = math.radians(lon - snap.origin_lon) * EARTH_RADIUS_M * math.cos(math.radians(snap.origin_lat))
    return [mavlink.MAVLink_home_position_message(
        clip_int(lat * 1e7, -900000000, 900000000), clip_int(lon * 1e7, -1800000000, 1800000000),
        clip_int(alt * 1000.0, -2**31, 2**31 - 1), north, east, -alt, [math.nan] * 4, 0.0, 0.0, 0.0,
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
    """RC_CHANNELS: the pilot's channels 1–8 (µs) and RC inputs 9–16 an override holds (0 otherwise)."""
    if not snap.has_tick:
        return []
    rc = [clip_int(v, 0, UINT16_MAX) for v in link.rc[:8]]
    rc += [clip_int(link.rc_in.get(ch, 0), 0, UINT16_MAX) for ch in range(9, 17)]
    return [mavlink.MAVLink_rc_channels_message(time_boot_ms(snap, link), len(rc), *rc, UINT16_MAX, UINT16_MAX, 255)]


def global_position_int(snap: TelemetrySnapshot, link: LinkState) -> list:
    """GLOBAL_POSITION_INT: the estimate about the WK_ORIGIN_LAT/LON origin (degE7, mm, cm/s, heading cdeg)."""
    if not snap.has_tick:
        return []
    e = pose6(snap)
    lat, lon = lat_lon(snap, e.x, e.y)
    alt_mm = clip_int(-e.z * 1000.0, -2**31, 2**31 - 1)
    hdg = clip_int(heading_deg(e.yaw) * 100.0, 0, 35999) if snap.lateral else 0
    return [mavlink.MAVLink_global_position_int_message(
        time_boot_ms(snap, link), clip_int(lat * 1e7, -900000000, 900000000),
        clip_int(lon * 1e7, -1800000000, 1800000000), alt_mm, alt_mm,
        clip_int(e.vn * 100.0, -32768, INT16_MAX), clip_int(e.ve * 100.0, -32768, INT16_MAX),
        clip_int(e.vd * 100.0, -32768, INT16_MAX), hdg)]


def lat_lon(snap: TelemetrySnapshot, x: float, y: float) -> tuple[float, float]:
    """Latitude and longitude (deg) of the NED point (x, y) (m) about the origin (a flat earth over the site)."""
    lat = snap.origin_lat + math.degrees(x / EARTH_RADIUS_M) if math.isfinite(x) else snap.origin_lat
    if y == 0.0 or not math.isfinite(y):
        return lat, snap.origin_lon
    return lat, snap.origin_lon + math.degrees(y / (EARTH_RADIUS_M * math.cos(math.radians(snap.origin_lat))))


def local_position_ned(snap: TelemetrySnapshot, link: LinkState) -> list:
    """LOCAL_POSITION_NED: position (m) and NED velocities (m/s); y 0 in a planar world."""
    if not snap.has_tick:
        return []
    e = pose6(snap)
    return [mavlink.MAVLink_local_position_ned_message(time_boot_ms(snap, link), e.x, e.y, e.z, e.vn, e.ve, e.vd)]


def attitude(snap: TelemetrySnapshot, link: LinkState) -> list:
    """ATTITUDE: roll, pitch, yaw (rad) and their body rates (rad/s); roll and yaw 0 in a planar world."""
    if not snap.has_tick:
        return []
    e = pose6(snap)
    return [mavlink.MAVLink_attitude_message(time_boot_ms(snap, link), e.roll, e.pitch, e.yaw, e.p, e.q, e.r)]


def vfr_hud(snap: TelemetrySnapshot, link: LinkState) -> list:
    """VFR_HUD: speed (m/s), throttle (%, 50 neutral, from the heave command), altitude −depth (m), climb (m/s)."""
    if not snap.has_tick:
        return []
    e = pose6(snap)
    throttle = clip_int(50.0 - 50.0 * snap.heave_force / snap.tau_max_z, 0, 100, 50)
    speed = math.hypot(e.vn, e.ve) if snap.lateral else abs(e.vn)
    speed = speed if math.isfinite(speed) else 0.0
    heading = clip_int(heading_deg(e.yaw), 0, 359) if snap.lateral else 0
    return [mavlink.MAVLink_vfr_hud_message(speed, speed, heading, throttle, -e.z, -e.vd)]


def system_time(snap: TelemetrySnapshot, link: LinkState) -> list:
    """SYSTEM_TIME: Unix time (µs) = a fixed epoch + the vehicle's time, and the time since boot (ms).

    The epoch is the wall clock at vehicle time 0 (:attr:`LinkState.epoch_us`), so the two fields
    agree in every run, paced or not; in a real-time run the Unix time is the wall clock.
    """
    t = snap.t if snap.t is not None else link.now_ns * 1e-9
    epoch = link.epoch_us if link.epoch_us is not None else int(time.time() * 1e6 - t * 1e6)
    return [mavlink.MAVLink_system_time_message(clip_int(epoch + t * 1e6, 0, 2**63), time_boot_ms(snap, link))]


def autopilot_version(snap: TelemetrySnapshot, link: LinkState) -> list:
    """AUTOPILOT_VERSION: capabilities, the ArduSub release followed, Wavekeep's commit, the board id
    (:mod:`.identity`)."""
    return [mavlink.MAVLink_autopilot_version_message(
        CAPABILITIES, FLIGHT_SW_VERSION, 0, 0, 0, list(custom_version()), [0] * 8, [0] * 8, 0, 0, 0,
        list(board_id(link.sysid)))]


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
