"""The pilot's joystick as ArduSub 4.7 reads it: gain, buttons, the pilot-input failsafe.

ArduSub turns each MANUAL_CONTROL into RC overrides of the pilot's channels
(``transform_manual_control_to_rc_override``): the sticks are scaled by the pilot
gain (``JS_GAIN_*``; the throttle also by ``JS_THR_GAIN``), and each button newly
pressed runs its ``BTNn_FUNCTION`` (``BTNn_SFUNCTION`` while a shift button is
held). This module does the same on the link's side of the firmware: what
reaches :meth:`Firmware.pilot_input` is already scaled.

Buttons that act here: shift (1), arm toggle / arm / disarm (2–4), the mode
buttons (5–13; modes are refused as by SET_MODE), gain toggle / up / down
(41–43), and the accessories' (:mod:`.accessories`: camera centre and tilt
21–23, video switch 25, lights 31–36). Others (trims, relays, servo buttons,
input hold, roll/pitch, custom) are accepted and do nothing.

**Pilot-input failsafe** (ArduSub's ``failsafe_pilot_input_check``): its clock
starts at boot. With ``FS_PILOT_INPUT`` ≠ 0 and no MANUAL_CONTROL or
RC_CHANNELS_OVERRIDE for ``FS_PILOT_TIMEOUT`` s of vehicle time it trips once:
"Lost manual control" (CRITICAL), the sticks go neutral, and with 2 the vehicle
disarms; the heartbeat says CRITICAL while it lasts. Pilot input clears it. So a
vehicle that never hears a joystick trips once, disarmed, FS_PILOT_TIMEOUT after
boot, and is not disarmed when it is armed later (ArduSub does the same).
"""
from __future__ import annotations

import math
from typing import TYPE_CHECKING

from ..modes import MAV_RESULT, MAV_SEVERITY
from .accessories import Accessories
from .wire import INT16_MAX, RC_NEUTRAL, RC_RANGE, UINT16_MAX, clip_int

if TYPE_CHECKING:
    from .port import LinkPort

__all__ = ["BUTTON_MODES", "Joystick"]

BUTTON_MODES = {5: 19, 6: 0, 7: 2, 8: 16, 9: 3, 10: 7, 11: 4, 12: 1, 13: 21}
"""Button function → ArduSub mode number (manual, stabilize, depth hold, poshold, auto, circle, guided, acro,
surftrak)."""


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
        self.last_input_t = 0.0           # vehicle time of the last pilot input: boot counts as one (ArduSub)
        self.heard = False                # a joystick or an RC override has been heard
        self.failsafe = False
        self.accessories = Accessories(p)
        self._t: float | None = None      # the last update's vehicle time (s)

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
        self.heard = True
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
        self.accessories.hold({int(p[f"BTN{i}_SFUNCTION" if shift else f"BTN{i}_FUNCTION"]) for i in pressed})

    def press(self, function: int) -> None:
        """One button function (ArduSub's JSButton numbers)."""
        fw = self.fw
        if function == 2:
            fw.request_arm(not fw.armed)
        elif function in (3, 4):
            fw.request_arm(function == 3)
        elif function in BUTTON_MODES:
            fw.request_mode(BUTTON_MODES[function])
        elif function in (41, 42, 43):
            self._gain(function)
        else:
            self.accessories.press(function)

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
        """The pilot-input failsafe, the camera mount and outputs 9–16, once per link tick (vehicle time t)."""
        if t is not None:
            self._check_failsafe(t)
            if self._t is not None:
                if t - self.last_input_t > self.fw.params["WK_PILOT_TMO"]:
                    self.accessories.hold(set())            # no fresh joystick input: nothing is held
                self.accessories.update(t - self._t)
            self._t = t
        st = self.link.state
        st.pilot_seen = self.heard
        st.pilot_fresh = t is not None and t - self.last_input_t < self.fw.params["FS_PILOT_TIMEOUT"]
        st.rc_in = self.rc_inputs(t)
        st.servo = self.accessories.outputs(st.rc, st.rc_in, st.servo)
        st.sub_info = self.accessories.sub_info(st.servo, self.gain)

    def rc_inputs(self, t: float | None) -> dict[int, int]:
        """RC inputs 9–16 as RC_CHANNELS_OVERRIDE set them, while within RC_OVERRIDE_TIME: channel → µs."""
        expiry = self.fw.params["RC_OVERRIDE_TIME"]
        now = t if t is not None else (self._t if self._t is not None else 0.0)
        return {ch: pwm for ch, (pwm, since) in self.fw.aux.rc_aux.items() if expiry < 0 or now - since <= expiry}

    def _check_failsafe(self, t: float) -> None:
        """ArduSub's pilot-input failsafe (the module docstring)."""
        p, fw = self.fw.params, self.fw
        action = int(p["FS_PILOT_INPUT"])
        if action == 0 or t < self.last_input_t + p["FS_PILOT_TIMEOUT"]:
            self.failsafe = fw.failsafe_pilot = False
            return
        if self.failsafe:
            return
        self.failsafe = fw.failsafe_pilot = True
        self.link.statustext(MAV_SEVERITY.CRITICAL, "Lost manual control")
        rc = self.link.state.rc
        rc[0:6] = [RC_NEUTRAL] * 6
        fw.pilot_input(0.0, 0.0, 0.0)
        if action == 2:
            fw.request_arm(False)

    def set_servo(self, channel: float, pwm: float) -> int:
        """MAV_CMD_DO_SET_SERVO: an output whose function is free (0, 1, RC pass-through) takes the PWM."""
        if not (math.isfinite(channel) and math.isfinite(pwm)) or channel != int(channel):
            return MAV_RESULT.FAILED
        ch = int(channel)
        if not 1 <= ch <= 16:
            return MAV_RESULT.FAILED
        st = self.link.state
        if ch <= 8 or not self.accessories.set_servo(ch, clip_int(pwm, 0, UINT16_MAX), st.rc, self.rc_inputs(None)):
            self.link.statustext(MAV_SEVERITY.INFO, f"ServoRelayEvent: Channel {ch} is already in use")
            return MAV_RESULT.FAILED
        # the outputs and readouts now, not a whole update: that would mark the pilot's input stale this tick
        st.servo = self.accessories.outputs(st.rc, st.rc_in, st.servo)
        st.sub_info = self.accessories.sub_info(st.servo, self.gain)
        return MAV_RESULT.ACCEPTED
