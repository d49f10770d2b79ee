"""The pilot's joystick as ArduSub reads it: gain, buttons, the pilot-input failsafe, and outputs 9–16.

ArduSub turns each MANUAL_CONTROL into RC overrides in its joystick code
(``transform_manual_control_to_rc_override``): the sticks are scaled by the
pilot gain (``JS_GAIN_*``; the throttle also by ``JS_THR_GAIN``), and each
button newly pressed runs its ``BTNn_FUNCTION`` (``BTNn_SFUNCTION`` while a
shift button is held). This module does the same on the link's side of the
firmware: what reaches :meth:`Firmware.pilot_input` is already scaled.

Buttons that act here: shift (1), arm toggle / arm / disarm (2–4), the mode
buttons (5–13; modes Wavekeep does not fly are refused as by SET_MODE), camera
centre / tilt up / down (21–23, RC channel 8), lights 1 and 2 cycle / brighter
/ dimmer (31–36, RC channels 9, 10), video switch (25, channel 11), gain toggle
/ up / down (41–43). Others (trims, relays, servo buttons, input hold, custom)
are accepted and do nothing.

Outputs 9–16 (SERVO_OUTPUT_RAW servo9–16) follow their ``SERVOn_FUNCTION``:
51–66 pass RC input 1–16 through, 1 passes the same-numbered channel, 7 is the
camera tilt (channel 8); MAV_CMD_DO_SET_SERVO sets an output whose function is
0, 1 or a pass-through, and it holds until that input changes (ArduPilot's
``ignore_small_rcin_changes``).
"""
from __future__ import annotations

import math
from typing import TYPE_CHECKING

from ..modes import MAV_RESULT, MAV_SEVERITY
from .wire import INT16_MAX, RC_NEUTRAL, RC_RANGE, UINT16_MAX, clip_int

if TYPE_CHECKING:
    from .port import LinkPort

__all__ = ["BUTTON_MODES", "Joystick"]

BUTTON_MODES = {5: 19, 6: 0, 7: 2, 8: 16, 9: 3, 10: 7, 11: 4, 12: 1, 13: 21}
"""Button function → ArduSub mode number (manual, stabilize, depth hold, poshold, auto, circle, guided, acro,
surftrak)."""
CAM, LIGHTS1, LIGHTS2, VIDEO = 7, 8, 9, 10          # indexes in LinkState.rc (RC channels 8-11)
PWM_LO, PWM_HI = RC_NEUTRAL - RC_RANGE, RC_NEUTRAL + RC_RANGE
SERVO_FREE = {0, 1, *range(51, 67)}                 # functions DO_SET_SERVO may drive
_AUX_FUNCTION_PARAMS = tuple((ch, f"SERVO{ch}_FUNCTION") for ch in range(9, 17))   # read when the table or the RC moved


class Joystick:
    """Pilot input state of one link (runs in the link's update, the scheduler thread)."""

    def __init__(self, link: LinkPort):
        self.link = link
        self.fw = link.fw
        p = self.fw.params
        lo, hi, steps = p["JS_GAIN_MIN"], p["JS_GAIN_MAX"], int(p["JS_GAIN_STEPS"])
        if steps == 1 or lo - 0.01 < p["JS_GAIN_DEFAULT"] < hi + 0.01:
            gain = min(hi, max(lo, p["JS_GAIN_DEFAULT"]))
        else:
            gain = lo + (steps // 2 - 1) * (hi - lo) / (steps - 1)
        self.gain = min(1.0, max(0.1, gain))
        self.buttons_prev = 0
        self.last_input_t: float | None = None
        self.failsafe = False
        self._lights_up = [True, True]
        self._servo_src: dict[int, tuple[int, int]] = {}
        self._servo_key: tuple | None = None   # (table id, version, RC channels) the outputs were last set from

    # ------------------------------------------------------------------ MANUAL_CONTROL
    def manual_control(self, msg) -> tuple[float, float, float]:
        """Buttons, then the sticks scaled by the gain: (forward, up, pitch) in [−1, 1]."""
        buttons = int(msg.buttons) | (int(getattr(msg, "buttons2", 0) or 0) << 16)
        self.buttons(buttons & 0xFFFF)
        p = self.fw.params
        rc = self.link.state.rc
        x = 0.0 if msg.x == INT16_MAX else msg.x / 1000.0 * self.gain
        up = 0.0 if msg.z == INT16_MAX else (msg.z - 500) / 500.0 * self.gain * p["JS_THR_GAIN"]
        pitch = (rc[0] - RC_NEUTRAL) / RC_RANGE
        if getattr(msg, "enabled_extensions", 0) & 1 and msg.s != INT16_MAX:
            pitch = msg.s / 1000.0 * self.gain
        self.touched()
        return tuple(min(1.0, max(-1.0, v)) for v in (x, up, pitch))   # type: ignore[return-value]

    def touched(self) -> None:
        """Pilot input arrived now (MANUAL_CONTROL or RC_CHANNELS_OVERRIDE): the failsafe's clock restarts."""
        snap = self.link.snapshot
        self.last_input_t = snap.t if snap is not None and snap.t is not None else self.link.state.now_ns * 1e-9

    def buttons(self, buttons: int) -> None:
        """Run the function of each button pressed since the last message (shift: the S functions)."""
        p = self.fw.params
        pressed = [i for i in range(16) if buttons >> i & 1]
        shift = any(int(p[f"BTN{i}_FUNCTION"]) == 1 for i in pressed)
        new = [i for i in pressed if not self.buttons_prev >> i & 1]
        self.buttons_prev = buttons
        for i in new:
            self.press(int(p[f"BTN{i}_SFUNCTION" if shift else f"BTN{i}_FUNCTION"]))

    def press(self, function: int) -> None:
        """One button function (ArduSub's JSButton numbers)."""
        fw, rc, p = self.fw, self.link.state.rc, self.fw.params
        if function == 2:
            fw.request_arm(not fw.armed)
        elif function in (3, 4):
            fw.request_arm(function == 3)
        elif function in BUTTON_MODES:
            fw.request_mode(BUTTON_MODES[function])
        elif function == 21:
            rc[CAM] = RC_NEUTRAL
        elif function in (22, 23):
            step = p["JS_CAM_TILT_STEP"] * (-1 if function == 22 else 1)
            rc[CAM] = clip_int(rc[CAM] + step, PWM_LO, PWM_HI, RC_NEUTRAL)
        elif function == 25:
            rc[VIDEO] = PWM_LO if rc[VIDEO] > PWM_LO else PWM_HI
            self.link.statustext(MAV_SEVERITY.INFO, f"Video Toggle: Source {1 if rc[VIDEO] == PWM_LO else 2}")
        elif 31 <= function <= 36:
            self._lights(function)
        elif function in (41, 42, 43):
            self._gain(function)

    def _lights(self, function: int) -> None:
        rc, step = self.link.state.rc, self.fw.params["JS_LIGHTS_STEP"]
        which = 0 if function <= 33 else 1
        ch = (LIGHTS1, LIGHTS2)[which]
        kind = (function - 31) % 3                   # 0 cycle, 1 brighter, 2 dimmer
        up = self._lights_up[which] if kind == 0 else kind == 1
        rc[ch] = clip_int(rc[ch] + (step if up else -step), PWM_LO, PWM_HI, PWM_LO)
        if kind == 0 and rc[ch] in (PWM_LO, PWM_HI):
            self._lights_up[which] = not self._lights_up[which]

    def _gain(self, function: int) -> None:
        p = self.fw.params
        if function == 41:
            self.gain = 1.0 if self.gain < 1.0 else 0.5
            self.link.statustext(MAV_SEVERITY.INFO, f"#Gain: {self.gain * 100:2.0f}%")
            return
        lo, hi, steps = p["JS_GAIN_MIN"], max(p["JS_GAIN_MIN"], p["JS_GAIN_MAX"]), int(p["JS_GAIN_STEPS"])
        if steps == 1:
            gain = p["JS_GAIN_DEFAULT"]
        else:
            gain = self.gain + (hi - lo) / (steps - 1) * (1 if function == 42 else -1)
        self.gain = min(hi, max(lo, gain))
        self.link.statustext(MAV_SEVERITY.INFO, f"#Gain is {self.gain * 100:2.0f}%")

    # ------------------------------------------------------------------ each update
    def update(self, t: float | None) -> None:
        """The pilot-input failsafe (FS_PILOT_INPUT) and the outputs' pass-throughs, once per link tick."""
        if t is not None:
            self._check_failsafe(t)
        self._refresh_servos()

    def _check_failsafe(self, t: float) -> None:
        """ArduSub's pilot-input failsafe: no MANUAL_CONTROL for FS_PILOT_TIMEOUT while armed.

        "Lost manual control", the sticks go neutral, and with FS_PILOT_INPUT 2 the vehicle disarms.
        It watches only once a pilot has been heard (a vehicle flown by a GCS alone never trips it).
        """
        p, fw = self.fw.params, self.fw
        action = int(p["FS_PILOT_INPUT"])
        if (action == 0 or not fw.armed or self.last_input_t is None
                or t - self.last_input_t < p["FS_PILOT_TIMEOUT"]):
            self.failsafe = False
            return
        if self.failsafe:
            return
        self.failsafe = True
        self.link.statustext(MAV_SEVERITY.CRITICAL, "Lost manual control")
        rc = self.link.state.rc
        rc[0:6] = [RC_NEUTRAL] * 6
        fw.pilot_input(0.0, 0.0, 0.0)
        if action == 2:
            fw.request_arm(False)

    def _source(self, ch: int, function: int) -> int | None:
        rc = self.link.state.rc
        if function == 7:
            return rc[CAM]
        if 51 <= function <= 66:
            i = function - 51
        elif function == 1:
            i = ch - 1
        else:
            return None
        return rc[i] if i < len(rc) else None

    def _refresh_servos(self) -> None:
        p, servo = self.fw.params, self.link.state.servo
        # The outputs follow only their SERVOn_FUNCTION and the RC channels: while neither moved, a pass
        # would change nothing (each source is as last applied), so it is skipped. A table without a
        # version is read every time.
        version = getattr(p, "version", None)
        key = None if version is None else (id(p), version, tuple(self.link.state.rc))
        if key is not None and key == self._servo_key:
            return
        for ch, name in _AUX_FUNCTION_PARAMS:
            function = int(p[name])
            value = self._source(ch, function)
            if value is None:
                self._servo_src.pop(ch, None)
                continue
            if self._servo_src.get(ch) != (function, value):
                self._servo_src[ch] = (function, value)
                servo[ch - 9] = value
        self._servo_key = key

    def set_servo(self, channel: float, pwm: float) -> int:
        """MAV_CMD_DO_SET_SERVO: an output whose function is free (0, 1, RC pass-through) takes the PWM."""
        if not (math.isfinite(channel) and math.isfinite(pwm)) or channel != int(channel):
            return MAV_RESULT.FAILED
        ch = int(channel)
        if not 1 <= ch <= 16:
            return MAV_RESULT.FAILED
        if int(self.fw.params[f"SERVO{ch}_FUNCTION"]) not in SERVO_FREE or ch <= 8:
            self.link.statustext(MAV_SEVERITY.INFO, f"ServoRelayEvent: Channel {ch} is already in use")
            return MAV_RESULT.FAILED
        self._refresh_servos()
        self.link.state.servo[ch - 9] = clip_int(pwm, 0, UINT16_MAX)
        return MAV_RESULT.ACCEPTED
