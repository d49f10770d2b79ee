"""Telemetry, continued: the other messages ArduSub streams or sends on request (docs/mavlink.md).

Same contract as :mod:`.telemetry`: ``build(snap, link) -> list[message]``, empty
while there is nothing to report, never raising on odd values. Their stream
groups are in :data:`.telemetry.STREAM_GROUPS` (ArduSub's); ATTITUDE_QUATERNION
and EXTENDED_SYS_STATE are in none of ArduSub's groups and go out on request or
at a SET_MESSAGE_INTERVAL rate.
"""
from __future__ import annotations

import math
import os

from ..telemetry_snapshot import TelemetrySnapshot
from .telemetry import Builder, LinkState, lat_lon, ned_state, pose6, time_boot_ms
from .vibration import G_MSS
from .wire import ID, INT16_MAX, UINT16_MAX, clip_int, mavlink

__all__ = ["ENCLOSURE_PRESSURE_HPA", "EXTRA_BUILDERS"]

ENCLOSURE_PRESSURE_HPA = 1013.25     # SCALED_PRESSURE: the autopilot's own barometer, in the sealed tube
ENCLOSURE_TEMPERATURE_CDEG = 2500    # nominal 25 °C in the electronics tube
_EKF_GOOD = (mavlink.EKF_ATTITUDE | mavlink.EKF_VELOCITY_HORIZ | mavlink.EKF_VELOCITY_VERT
             | mavlink.EKF_POS_HORIZ_REL | mavlink.EKF_POS_HORIZ_ABS | mavlink.EKF_POS_VERT_ABS
             | mavlink.EKF_PRED_POS_HORIZ_REL | mavlink.EKF_PRED_POS_HORIZ_ABS)


def _usec(snap: TelemetrySnapshot) -> int:
    return clip_int((snap.t or 0.0) * 1e6, 0, 2**63)


def raw_imu(snap: TelemetrySnapshot, link: LinkState) -> list:
    """RAW_IMU: the accelerometer (mG, body FRD, gravity included) and the gyro (mrad/s); no magnetometer."""
    if not snap.has_tick:
        return []
    ax, _ay, az = link.vibration.accel if link.vibration is not None else (0.0, 0.0, -G_MSS)
    q = snap.x_hat[5] if len(snap.x_hat) > 5 else 0.0
    p, r = (snap.lateral[4], snap.lateral[5]) if snap.lateral else (0.0, 0.0)
    mg = lambda a: clip_int(1000.0 * a / G_MSS, -32768, INT16_MAX)   # noqa: E731
    mrad = lambda w: clip_int(w * 1000.0, -32768, INT16_MAX)          # noqa: E731
    return [mavlink.MAVLink_raw_imu_message(_usec(snap), mg(ax), 0, mg(az), mrad(p), mrad(q), mrad(r), 0, 0, 0, 0,
                                            ENCLOSURE_TEMPERATURE_CDEG)]


def scaled_pressure(snap: TelemetrySnapshot, link: LinkState) -> list:
    """SCALED_PRESSURE: the autopilot board's barometer inside the sealed tube (nominal 1013.25 hPa, 25 °C)."""
    if not snap.has_tick:
        return []
    return [mavlink.MAVLink_scaled_pressure_message(time_boot_ms(snap, link), ENCLOSURE_PRESSURE_HPA, 0.0,
                                                    ENCLOSURE_TEMPERATURE_CDEG)]


def power_status(snap: TelemetrySnapshot, link: LinkState) -> list:
    """POWER_STATUS: the board's 5 V rail from the Power Sense Module's regulator (brick valid)."""
    return [mavlink.MAVLink_power_status_message(5000, 0, mavlink.MAV_POWER_STATUS_BRICK_VALID)]


def meminfo(snap: TelemetrySnapshot, link: LinkState) -> list:
    """MEMINFO: the companion computer's available memory (bytes; freemem saturates at 65535)."""
    try:
        free = int(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        free = 0
    return [mavlink.MAVLink_meminfo_message(0, min(free, UINT16_MAX), min(free, 2**32 - 1))]


def nav_controller_output(snap: TelemetrySnapshot, link: LinkState) -> list:
    """NAV_CONTROLLER_OUTPUT: target pitch (deg), bearing and distance to the x target, depth error (m)."""
    if not snap.has_tick or len(snap.setpoint) < 3:
        return []
    x, z, _th, _vx, _vz, _q = ned_state(snap)
    sx, sz, sth = snap.setpoint[:3]
    dx = sx - x if math.isfinite(sx - x) else 0.0
    bearing = 0 if dx >= 0 else 180
    alt_error = z - sz if math.isfinite(z - sz) else 0.0     # target altitude − altitude (altitude = −depth)
    return [mavlink.MAVLink_nav_controller_output_message(
        0.0, math.degrees(sth) if math.isfinite(sth) else 0.0, bearing, bearing, clip_int(abs(dx), 0, UINT16_MAX),
        alt_error, 0.0, 0.0)]


def ahrs2(snap: TelemetrySnapshot, link: LinkState) -> list:
    """AHRS2: the secondary attitude/position solution; here the same estimate (roll and yaw 0 in a planar world)."""
    if not snap.has_tick:
        return []
    e = pose6(snap)
    lat, lon = lat_lon(snap, e.x, e.y)
    return [mavlink.MAVLink_ahrs2_message(e.roll, e.pitch, e.yaw, -e.z, clip_int(lat * 1e7, -900000000, 900000000),
                                          clip_int(lon * 1e7, -1800000000, 1800000000))]


def attitude_quaternion(snap: TelemetrySnapshot, link: LinkState) -> list:
    """ATTITUDE_QUATERNION: the attitude as a quaternion (w, x, y, z) of its zyx Euler angles, and the body rates
    (the pitch alone in a planar world)."""
    if not snap.has_tick:
        return []
    e = pose6(snap)
    if not snap.lateral:
        half = e.pitch / 2.0 if math.isfinite(e.pitch) else 0.0
        return [mavlink.MAVLink_attitude_quaternion_message(time_boot_ms(snap, link), math.cos(half), 0.0,
                                                            math.sin(half), 0.0, 0.0, e.q, 0.0)]
    angles = [a if math.isfinite(a) else 0.0 for a in (e.roll, e.pitch, e.yaw)]
    cr, sr = math.cos(angles[0] / 2.0), math.sin(angles[0] / 2.0)
    cp, sp = math.cos(angles[1] / 2.0), math.sin(angles[1] / 2.0)
    cy, sy = math.cos(angles[2] / 2.0), math.sin(angles[2] / 2.0)
    qw, qx = cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy
    qy, qz = cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy
    return [mavlink.MAVLink_attitude_quaternion_message(time_boot_ms(snap, link), qw, qx, qy, qz, e.p, e.q, e.r)]


def extended_sys_state(snap: TelemetrySnapshot, link: LinkState) -> list:
    """EXTENDED_SYS_STATE: as ArduSub, which reports no landed state: UNDEFINED, and no VTOL state."""
    return [mavlink.MAVLink_extended_sys_state_message(mavlink.MAV_VTOL_STATE_UNDEFINED,
                                                       mavlink.MAV_LANDED_STATE_UNDEFINED)]


def ekf_status_report(snap: TelemetrySnapshot, link: LinkState) -> list:
    """EKF_STATUS_REPORT: solution flags, and each 1-sigma over WK_EKF_SD_BAD as the test ratio (< 1 healthy)."""
    if not snap.has_tick or len(snap.sigma) < 2:
        return [mavlink.MAVLink_ekf_status_report_message(mavlink.EKF_UNINITIALIZED, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)]
    flags = _EKF_GOOD if snap.ekf_converged else (mavlink.EKF_ATTITUDE | mavlink.EKF_VELOCITY_VERT
                                                  | mavlink.EKF_POS_VERT_ABS)
    thresh = max(float(link.ekf_sd_bad), 1e-6)
    ratio = lambda s: min(max(s / thresh, 0.0), 100.0) if math.isfinite(s) else 100.0   # noqa: E731
    horiz, vert = ratio(snap.sigma[0]), ratio(snap.sigma[1])
    return [mavlink.MAVLink_ekf_status_report_message(flags, horiz, horiz, vert, 0.0, 0.0, 0.0)]


def vibration(snap: TelemetrySnapshot, link: LinkState) -> list:
    """VIBRATION: the accelerometer's vibration levels (m/s²); no clipping."""
    if not snap.has_tick or link.vibration is None:
        return []
    vx, vy, vz = link.vibration.levels()
    return [mavlink.MAVLink_vibration_message(_usec(snap), vx, vy, vz, 0, 0, 0)]


def battery_status(snap: TelemetrySnapshot, link: LinkState) -> list:
    """BATTERY_STATUS of the simulated 4S pack, as ArduPilot sends it without cell monitoring."""
    b = link.battery
    if b is None:
        return []
    cells = [clip_int(b.voltage * 1000.0, 0, UINT16_MAX - 1)] + [UINT16_MAX] * 9
    return [mavlink.MAVLink_battery_status_message(
        0, mavlink.MAV_BATTERY_FUNCTION_UNKNOWN, mavlink.MAV_BATTERY_TYPE_UNKNOWN, INT16_MAX, cells,
        clip_int(b.current * 100.0, -1, INT16_MAX), clip_int(b.consumed_mah, -1, 2**31 - 1),
        clip_int(b.consumed_wh * 36.0, -1, 2**31 - 1), clip_int(b.remaining_pct, -1, 100), 0,
        mavlink.MAV_BATTERY_CHARGE_STATE_OK)]


EXTRA_BUILDERS: dict[int, Builder] = {
    ID["RAW_IMU"]: raw_imu,
    ID["SCALED_PRESSURE"]: scaled_pressure,
    ID["POWER_STATUS"]: power_status,
    ID["MEMINFO"]: meminfo,
    ID["NAV_CONTROLLER_OUTPUT"]: nav_controller_output,
    ID["AHRS2"]: ahrs2,
    ID["ATTITUDE_QUATERNION"]: attitude_quaternion,
    ID["EXTENDED_SYS_STATE"]: extended_sys_state,
    ID["EKF_STATUS_REPORT"]: ekf_status_report,
    ID["VIBRATION"]: vibration,
    ID["BATTERY_STATUS"]: battery_status,
}
"""Message id → builder of the messages this module adds."""
