"""Inbound messages and commands: what the vehicle does with what a ground station sends (ArduSub's GCS_Mavlink).

:class:`Dispatcher` holds two dispatch tables: :attr:`~Dispatcher.messages`
(message id → handler) and :attr:`~Dispatcher.commands` (MAV_CMD → handler for
COMMAND_LONG and COMMAND_INT alike). Handlers run in the link's update (the
scheduler thread) and turn messages into firmware calls; replies are queued on
the link. A command handler returns a MAV_RESULT; the COMMAND_ACK goes out
first, then whatever the command asked for (``link.after``).
"""
from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING

from ..modes import MAV_RESULT, MAV_SEVERITY, Mode
from .identity import banner
from .pilot import Joystick
from .telemetry import DATA_STREAM_PARAMS, EARTH_RADIUS_M, STREAM_GROUPS, STREAMED, home_location
from .wire import ID, RC_NEUTRAL, RC_RANGE, UINT16_MAX, clip_int, finite, is_integer_value, mavlink

if TYPE_CHECKING:
    from .port import LinkPort

__all__ = ["FORCE_ARM_MAGIC", "MOTOR_TEST_TIMEOUT_S", "Dispatcher"]

FORCE_ARM_MAGIC = 21196.0             # COMPONENT_ARM_DISARM param2 that skips the pre-arm checks
MOTOR_TEST_TIMEOUT_S = 0.5            # ArduSub stops a motor test 0.5 s after the last command

Params7 = tuple[float, float, float, float, float, float, float]


def _stick(value: float) -> int:
    """A normalised stick value in [−1, 1] as an RC channel (µs)."""
    return clip_int(RC_NEUTRAL + RC_RANGE * value, RC_NEUTRAL - RC_RANGE, RC_NEUTRAL + RC_RANGE, RC_NEUTRAL)


class Dispatcher:
    """The handlers of inbound messages and commands, bound to one link.

    Parameters
    ----------
    link : LinkPort
        The link whose firmware the handlers drive and on which they queue replies.
    joystick : Joystick
        The pilot's joystick (MANUAL_CONTROL's gain and buttons; RC overrides restart its failsafe).
    """

    def __init__(self, link: LinkPort, joystick: Joystick):
        self.link = link
        self.joystick = joystick
        self.fw = link.fw
        self.messages: dict[int, Callable[[int, object], None]] = {
            ID["HEARTBEAT"]: self.on_heartbeat,
            ID["SET_MODE"]: self.on_set_mode,
            ID["REQUEST_DATA_STREAM"]: self.on_request_data_stream,
            ID["MANUAL_CONTROL"]: self.on_manual_control,
            ID["RC_CHANNELS_OVERRIDE"]: self.on_rc_override,
            ID["COMMAND_LONG"]: self.on_command_long,
            ID["COMMAND_INT"]: self.on_command_int,
            ID["SET_POSITION_TARGET_LOCAL_NED"]: self.on_position_target,
            ID["SET_POSITION_TARGET_GLOBAL_INT"]: self.on_position_target_global,
            ID["TIMESYNC"]: self.on_timesync,
            ID["AUTOPILOT_VERSION_REQUEST"]: self.on_autopilot_version_request,
        }
        """Message id → handler ``(endpoint, msg)``."""
        self.commands: dict[int, Callable[[int, object, Params7], int]] = {
            mavlink.MAV_CMD_DO_SET_MODE: self.cmd_set_mode,
            mavlink.MAV_CMD_COMPONENT_ARM_DISARM: self.cmd_arm,
            mavlink.MAV_CMD_DO_MOTOR_TEST: self.cmd_motor_test,
            mavlink.MAV_CMD_SET_MESSAGE_INTERVAL: self.cmd_set_message_interval,
            mavlink.MAV_CMD_GET_MESSAGE_INTERVAL: self.cmd_get_message_interval,
            mavlink.MAV_CMD_REQUEST_MESSAGE: self.cmd_request_message,
            mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES: self.cmd_autopilot_capabilities,
            mavlink.MAV_CMD_NAV_LOITER_UNLIM: lambda *_: self.fw.request_mode(Mode.POSHOLD),
            mavlink.MAV_CMD_NAV_LAND: lambda *_: self.fw.request_mode(Mode.SURFACE),
            mavlink.MAV_CMD_DO_SEND_BANNER: self.cmd_banner,
            mavlink.MAV_CMD_GET_HOME_POSITION: self.cmd_get_home_position,
            mavlink.MAV_CMD_DO_SET_HOME: self.cmd_do_set_home,
        }
        """MAV_CMD → handler ``(endpoint, msg, params) -> MAV_RESULT``."""

    # ------------------------------------------------------------------ messages
    def _from_gcs(self, msg) -> bool:
        return msg.get_srcSystem() == int(self.fw.params["MAV_GCS_SYSID"])

    def on_heartbeat(self, ep: int, msg) -> None:
        """A heartbeat from MAV_GCS_SYSID keeps the GCS failsafe away."""
        if self._from_gcs(msg):
            self.fw.gcs_heartbeat()

    def set_mode(self, base_mode: float, custom_mode: float) -> int:
        """Switch to ArduSub mode ``custom_mode``; base_mode must carry CUSTOM_MODE_ENABLED (else DENIED, as
        ArduSub)."""
        if not finite(base_mode, custom_mode):
            return MAV_RESULT.FAILED
        if not int(base_mode) & mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            return MAV_RESULT.DENIED
        if custom_mode != int(custom_mode) or not 0 <= custom_mode < 2**32:
            return MAV_RESULT.FAILED
        return self.fw.request_mode(int(custom_mode))

    def on_set_mode(self, ep: int, msg) -> None:
        """SET_MODE: no COMMAND_ACK (ArduSub 4.7 sends none: a refusal is said in a STATUSTEXT, a change shows
        in the heartbeat)."""
        if self.set_mode(msg.base_mode, msg.custom_mode) != MAV_RESULT.ACCEPTED:
            self.link.ignored()

    def on_request_data_stream(self, ep: int, msg) -> None:
        """REQUEST_DATA_STREAM sets the group's MAV1_ rate (Hz) and resets its messages' own intervals."""
        if msg.start_stop == 0:
            rate = 0.0
        elif msg.start_stop == 1:
            rate = float(msg.req_message_rate)
        else:
            return self.link.ignored()
        if msg.req_stream_id == mavlink.MAV_DATA_STREAM_ALL:
            groups = list(STREAM_GROUPS)
        elif msg.req_stream_id in DATA_STREAM_PARAMS:
            groups = [DATA_STREAM_PARAMS[msg.req_stream_id]]
        else:
            return self.link.ignored()
        params = self.fw.params
        for group in groups:
            d = params.definition(group)
            params.set(group, min(d.hi, max(d.lo, rate)))
            for mid in STREAM_GROUPS[group]:
                self.link.set_interval(mid, None)

    def on_manual_control(self, ep: int, msg) -> None:
        """MANUAL_CONTROL from the GCS: x forward, z throttle (500 neutral), s pitch (extension bit 0)."""
        if not self._from_gcs(msg):        # ArduSub takes sticks from its own GCS only
            return self.link.ignored()
        rc = self.link.state.rc
        x, up, pitch = self.joystick.manual_control(msg)     # buttons, pilot gain (ArduSub's joystick)
        rc[0], rc[2], rc[4] = _stick(pitch), _stick(up), _stick(x)
        self.fw.pilot_input(x, up, pitch)
        self.fw.gcs_heartbeat()            # ArduSub: pilot input counts as the GCS being there

    def on_rc_override(self, ep: int, msg) -> None:
        """RC_CHANNELS_OVERRIDE in ArduSub's order: 1 pitch, 3 throttle, 5 forward (65535: keep, 0: release);
        9–16 feed outputs whose SERVOn_FUNCTION is RCIN9–16 (0 / 65535: keep, 65534: release)."""
        if not self._from_gcs(msg):
            return self.link.ignored()
        rc = self.link.state.rc
        raw = [msg.chan1_raw, msg.chan2_raw, msg.chan3_raw, msg.chan4_raw, msg.chan5_raw, msg.chan6_raw,
               msg.chan7_raw, msg.chan8_raw]
        for i, v in enumerate(raw):
            if v == UINT16_MAX:
                continue
            rc[i] = RC_NEUTRAL if v == 0 else min(RC_NEUTRAL + RC_RANGE, max(RC_NEUTRAL - RC_RANGE, v))
        for ch in range(9, 17):       # MAVLink 2 extensions: 0 / UINT16_MAX ignore, UINT16_MAX - 1 releases
            v = getattr(msg, f"chan{ch}_raw", 0)
            if v == UINT16_MAX - 1:
                self.fw.rc_override_aux(ch, None)
            elif v not in (0, UINT16_MAX):
                self.fw.rc_override_aux(ch, int(v))
        norm = lambda ch: (rc[ch] - RC_NEUTRAL) / RC_RANGE   # noqa: E731
        self.joystick.touched()
        self.fw.pilot_input(norm(4), norm(2), norm(0))
        self.fw.gcs_heartbeat()

    def on_position_target(self, ep: int, msg) -> None:
        """SET_POSITION_TARGET_LOCAL_NED (GUIDED only): x and depth (m), LOCAL_NED or LOCAL_OFFSET_NED."""
        fw = self.fw
        if fw.mode != Mode.GUIDED:          # ArduSub ignores targets outside GUIDED
            return self.link.ignored()
        mask = msg.type_mask
        x = None if mask & mavlink.POSITION_TARGET_TYPEMASK_X_IGNORE else float(msg.x)
        depth = None if mask & mavlink.POSITION_TARGET_TYPEMASK_Z_IGNORE else float(msg.z)
        if msg.coordinate_frame == mavlink.MAV_FRAME_LOCAL_OFFSET_NED:
            snap = self.link.snapshot
            if snap is not None and snap.has_tick:
                x = None if x is None else x + snap.x_hat[0]
                depth = None if depth is None else depth + snap.x_hat[1]
        elif msg.coordinate_frame != mavlink.MAV_FRAME_LOCAL_NED:
            return self.link.ignored()
        if x is None and depth is None:     # velocity / acceleration / yaw only: not supported
            return self.link.ignored()
        if fw.set_target(x, depth, None) != MAV_RESULT.ACCEPTED:
            self.link.ignored()

    def on_position_target_global(self, ep: int, msg) -> None:
        """SET_POSITION_TARGET_GLOBAL_INT (GUIDED only): x from the latitude (degE7), depth = −altitude (m, AMSL:
        the sea surface is 0; or relative to home); longitude is not a DoF here."""
        frames = (mavlink.MAV_FRAME_GLOBAL_INT, mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                  mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT)
        snap = self.link.snapshot
        if self.fw.mode != Mode.GUIDED or msg.coordinate_frame not in frames or snap is None:
            return self.link.ignored()
        mask = msg.type_mask
        lat, alt = msg.lat_int * 1e-7, float(msg.alt)
        if msg.coordinate_frame in frames[2:]:
            alt += home_location(snap, self.link.state)[2]
        x = None if mask & mavlink.POSITION_TARGET_TYPEMASK_X_IGNORE else \
            math.radians(lat - snap.origin_lat) * EARTH_RADIUS_M
        depth = None if mask & mavlink.POSITION_TARGET_TYPEMASK_Z_IGNORE else -alt
        if not -90.0 <= lat <= 90.0 or (x is None and depth is None) or \
                self.fw.set_target(x, depth, None) != MAV_RESULT.ACCEPTED:
            self.link.ignored()

    def on_timesync(self, ep: int, msg) -> None:
        """TIMESYNC request (tc1 = 0): answered with the vehicle's time (ns); answers are not answered."""
        if msg.tc1 != 0:
            return
        self.link.queue(mavlink.MAVLink_timesync_message(max(1, self.link.state.now_ns), msg.ts1), ep)

    def on_autopilot_version_request(self, ep: int, msg) -> None:
        for m in self.link.build(ID["AUTOPILOT_VERSION"]):
            self.link.queue(m, ep)

    # ------------------------------------------------------------------ commands
    def on_command_long(self, ep: int, msg) -> None:
        self.command(ep, msg, (msg.param1, msg.param2, msg.param3, msg.param4, msg.param5, msg.param6,
                               msg.param7))

    def on_command_int(self, ep: int, msg) -> None:
        self.command(ep, msg, (msg.param1, msg.param2, msg.param3, msg.param4, float(msg.x), float(msg.y),
                               msg.z))

    def command(self, ep: int, msg, p: Params7) -> None:
        """Run one command; ACK it (UNSUPPORTED if unknown, FAILED if its handler raised), then its replies."""
        link = self.link
        handler = self.commands.get(msg.command)
        result: int
        if handler is None:
            result = MAV_RESULT.UNSUPPORTED
        else:
            try:
                result = handler(ep, msg, p)
            except Exception as exc:
                link.counters["handler_errors"] += 1
                link.last_error = f"command {msg.command}: {exc!r}"
                result = MAV_RESULT.FAILED
        link.ack(ep, msg, msg.command, int(result))
        for m in link.after:
            link.queue(m, ep)
        link.after.clear()

    def cmd_set_mode(self, ep: int, msg, p: Params7) -> int:
        """MAV_CMD_DO_SET_MODE: param1 base mode, param2 custom mode."""
        return self.set_mode(p[0], p[1])

    def cmd_arm(self, ep: int, msg, p: Params7) -> int:
        """MAV_CMD_COMPONENT_ARM_DISARM: param1 1 arm / 0 disarm; param2 21196 skips the pre-arm checks."""
        if p[0] == 1.0:
            return self.fw.request_arm(True, force=p[1] == FORCE_ARM_MAGIC)[0]
        if p[0] == 0.0:
            return self.fw.request_arm(False)[0]
        return MAV_RESULT.UNSUPPORTED

    def cmd_motor_test(self, ep: int, msg, p: Params7) -> int:
        """MAV_CMD_DO_MOTOR_TEST: motor (1-based), throttle type (PWM µs or % of 1100–1900), timeout (s ≤ 0.5)."""
        motor, kind, value, timeout = p[:4]
        if not finite(motor, kind, value, timeout) or motor != int(motor):
            return MAV_RESULT.FAILED
        if kind == mavlink.MOTOR_TEST_THROTTLE_PWM:
            pwm = int(round(value))
        elif kind == mavlink.MOTOR_TEST_THROTTLE_PERCENT:
            pwm = int(round(RC_NEUTRAL - RC_RANGE + 2 * RC_RANGE * min(100.0, max(0.0, value)) / 100.0))
        else:
            return MAV_RESULT.FAILED
        timeout = timeout if 0.0 < timeout < MOTOR_TEST_TIMEOUT_S else MOTOR_TEST_TIMEOUT_S
        if not -2**31 <= motor < 2**31:
            return MAV_RESULT.FAILED
        if not self.fw.armed:               # ArduSub's words, and its FAILED
            self.link.statustext(MAV_SEVERITY.WARNING, "Arm motors before testing motors.", ep)
            self.link.statustext(MAV_SEVERITY.WARNING, "motor test initialization failed!", ep)
            return MAV_RESULT.FAILED
        return self.fw.motor_test(int(motor), pwm, timeout)

    def cmd_set_message_interval(self, ep: int, msg, p: Params7) -> int:
        """MAV_CMD_SET_MESSAGE_INTERVAL: param1 message id, param2 interval (µs; −1 off, 0 default)."""
        mid, interval_us = p[0], p[1]
        if not finite(mid, interval_us) or mid != int(mid):
            return MAV_RESULT.FAILED
        mid = int(mid)
        if mid not in self.link.builders or mid == ID["AUTOPILOT_VERSION"]:
            self.link.statustext(MAV_SEVERITY.INFO, f"No ap_message for mavlink id ({mid})", ep)
            return MAV_RESULT.DENIED
        if interval_us == -1:
            self.link.set_interval(mid, -1)
        elif interval_us == 0:
            self.link.set_interval(mid, None)
        elif interval_us > 0:
            self.link.set_interval(mid, int(min(interval_us, 60e6) * 1000))
        else:
            return MAV_RESULT.FAILED
        return MAV_RESULT.ACCEPTED

    def cmd_get_message_interval(self, ep: int, msg, p: Params7) -> int:
        """MAV_CMD_GET_MESSAGE_INTERVAL: answered with MESSAGE_INTERVAL (µs; −1 off, 0 not streamed)."""
        if not is_integer_value(p[0]):
            return MAV_RESULT.FAILED
        mid = int(p[0])
        if mid in STREAMED or (mid in self.link.builders and mid != ID["AUTOPILOT_VERSION"]):
            interval = self.link.stream_interval(mid)
            us = -1 if interval is None else clip_int(interval / 1000, 1, 2**31 - 1)
        else:
            us = 0
        self.link.after.append(mavlink.MAVLink_message_interval_message(clip_int(mid, 0, UINT16_MAX), us))
        return MAV_RESULT.ACCEPTED

    def cmd_request_message(self, ep: int, msg, p: Params7) -> int:
        """MAV_CMD_REQUEST_MESSAGE: param1 message id, sent once after the ACK (also while its stream is off)."""
        if not is_integer_value(p[0]):
            return MAV_RESULT.FAILED
        mid = int(p[0])
        if mid not in self.link.builders:
            return MAV_RESULT.FAILED
        out = self.link.build(mid)
        if not out:
            return MAV_RESULT.TEMPORARILY_REJECTED     # nothing to report before the first tick
        self.link.after.extend(out)
        return MAV_RESULT.ACCEPTED

    def cmd_autopilot_capabilities(self, ep: int, msg, p: Params7) -> int:
        """MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES (param1 1): AUTOPILOT_VERSION after the ACK."""
        if p[0] != 1.0:
            return MAV_RESULT.FAILED
        self.link.after.extend(self.link.build(ID["AUTOPILOT_VERSION"]))
        return MAV_RESULT.ACCEPTED

    def cmd_banner(self, ep: int, msg, p: Params7) -> int:
        """MAV_CMD_DO_SEND_BANNER: ArduSub's banner, firmware and commit, board id, frame (STATUSTEXT × 3)."""
        for line in banner(int(self.fw.params["MAV_SYSID"])):
            self.link.statustext(MAV_SEVERITY.INFO, line, ep)
        return MAV_RESULT.ACCEPTED

    def cmd_get_home_position(self, ep: int, msg, p: Params7) -> int:
        """MAV_CMD_GET_HOME_POSITION: HOME_POSITION and GPS_GLOBAL_ORIGIN after the ACK (as ArduPilot)."""
        self.link.after.extend(self.link.build(ID["HOME_POSITION"]) + self.link.build(ID["GPS_GLOBAL_ORIGIN"]))
        return MAV_RESULT.ACCEPTED

    def cmd_do_set_home(self, ep: int, msg, p: Params7) -> int:
        """MAV_CMD_DO_SET_HOME: p1 = 1 (or lat = lon = 0): the current position; p1 = 0: p5 lat, p6 lon, p7 alt.

        As ArduPilot: FAILED for another p1, an invalid latitude/longitude, or no position estimate
        yet; HOME_POSITION follows the ACK. COMMAND_INT carries lat/lon in degE7.
        """
        scale = 1e-7 if msg.get_type() == "COMMAND_INT" else 1.0
        if not finite(*p[:7]):
            return MAV_RESULT.FAILED
        lat, lon, alt = p[4] * scale, p[5] * scale, p[6]
        if p[0] == 1.0 or (lat == 0.0 and lon == 0.0):
            snap = self.link.snapshot
            if snap is None or not snap.has_tick or not snap.ekf_converged or not finite(*snap.x_hat[:2]):
                return MAV_RESULT.FAILED
            lat = snap.origin_lat + math.degrees(snap.x_hat[0] / EARTH_RADIUS_M)
            lon, alt = snap.origin_lon, -snap.x_hat[1]
        elif p[0] != 0.0 or not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 180.0):
            return MAV_RESULT.FAILED
        self.link.state.home = (float(lat), float(lon), float(alt))
        self.link.after.extend(self.link.build(ID["HOME_POSITION"]))
        return MAV_RESULT.ACCEPTED
