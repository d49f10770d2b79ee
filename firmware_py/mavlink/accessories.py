"""What a BlueROV2 carries beside its thrusters, as ArduSub 4.7 drives it: the camera mount, two lights, the
video switch, and outputs 9–16; and the Sub-panel readouts QGroundControl shows (NAMED_VALUE_FLOAT).

* **Camera mount** (``MNT1_*``, a servo tilt): its pitch starts level (0°) and moves at ``MNT1_RC_RATE``
  (deg/s) while a tilt-up or tilt-down button is held; centre sets it level. An output whose
  ``SERVOn_FUNCTION`` is 7 (mount tilt) sends it: ``MNT1_PITCH_MIN…MAX`` over the output's
  ``SERVOn_MIN…MAX`` (µs, truncated as ArduPilot's integer PWM).
* **Lights 1 and 2** (outputs with function 181, 182): off is 1100 µs, each brighter / dimmer press one
  of ``JS_LIGHTS_STEPS`` steps up to 1900 µs; a cycle press goes up to full, then down to off. An
  output sends 0 until its light is first changed (as ArduPilot's unset output).
* **Video switch** (function 183): 1900 / 1100 µs, toggled.
* **Outputs 9–16** follow their function: 51–58 pass RC input 1–8 through, 59–66 RC input 9–16 (an
  RC_CHANNELS_OVERRIDE, while within ``RC_OVERRIDE_TIME``; 0 before one), 1 the same-numbered input;
  MAV_CMD_DO_SET_SERVO sets one whose function is 0, 1 or a pass-through, held until its source changes
  (ArduPilot's ``ignore_small_rcin_changes``).
* **NAMED_VALUE_FLOAT** (ArduSub's ``send_info``): ``CamTilt`` 1 − (n/2 + ½) of the mount-tilt output's
  normalised position n ∈ [−1, 1] (ArduPilot's ``get_output_norm``: about the output's trim; 0 with no such
  output), ``CamPan`` the same of a mount-pan output (none here: 0.5), ``TetherTrn`` the tether's whole
  turns (yaw is not a degree of freedom here: 0), ``Lights1`` / ``Lights2`` n/2 + ½ of the lights
  outputs, ``PilotGain``, ``InputHold`` and ``RollPitch`` (0: input hold and the roll/pitch stick mode do
  nothing here), ``RFTarget`` the surface-tracking target (m; −0.01: none, no rangefinder).
"""
from __future__ import annotations

import math

from ..params.table import ParameterTable

__all__ = ["FUNCTION", "PWM_HI", "PWM_LO", "SUB_INFO", "Accessories"]

PWM_LO, PWM_HI, PWM_MID = 1100, 1900, 1500
FUNCTION = {"mount_tilt": 7, "mount_pan": 8, "lights1": 181, "lights2": 182, "video": 183}
"""SERVOn_FUNCTION numbers of ArduPilot's (SRV_Channel's k_mount_tilt, k_lights1...)."""
SERVO_FREE = {0, 1, *range(51, 67)}                 # functions DO_SET_SERVO may drive
SUB_INFO = ("CamTilt", "CamPan", "TetherTrn", "Lights1", "Lights2", "PilotGain", "InputHold", "RollPitch",
            "RFTarget")
"""ArduSub's NAMED_VALUE_FLOAT names, in its order."""


def _functions(p: ParameterTable) -> tuple[tuple[int, int], ...]:
    """(output 9–16, SERVOn_FUNCTION): read again only when the table changes."""
    return tuple((ch, int(p[f"SERVO{ch}_FUNCTION"])) for ch in range(9, 17))


class Accessories:
    """The mount, lights, video switch and outputs 9–16 of one vehicle (the link's update thread)."""

    def __init__(self, params: ParameterTable):
        self.params = params
        self.tilt_deg = 0.0                          # the mount's pitch (deg), level at boot
        self.tilt_rate = 0                           # +1 / −1 while tilt up / down is held
        self.lights: list[int | None] = [None, None]  # µs, None until first changed
        self._lights_up = [True, True]
        self.video: int | None = None
        self._set: dict[int, tuple[int, int | None, int]] = {}   # DO_SET_SERVO: ch → (function, source, µs)

    # ------------------------------------------------------------------ buttons
    def press(self, function: int) -> None:
        """A newly pressed button's function (ArduSub's JSButton numbers 21, 25, 31–36); others are ignored."""
        if function == 21:
            self.tilt_deg = 0.0
        elif function == 25:
            self.video = PWM_HI if self.video != PWM_HI else PWM_LO
        elif 31 <= function <= 36:
            which, kind = (function - 31) // 3, (function - 31) % 3      # 0 cycle, 1 brighter, 2 dimmer
            step = (PWM_HI - PWM_LO) / max(1.0, self.params["JS_LIGHTS_STEPS"])
            light = self.lights[which]
            now = PWM_LO if light is None else light
            up = self._lights_up[which] if kind == 0 else kind == 1
            new = int(min(PWM_HI, max(PWM_LO, now + (step if up else -step))))
            if kind == 0 and new in (PWM_LO, PWM_HI):
                self._lights_up[which] = not self._lights_up[which]
            self.lights[which] = new

    def hold(self, functions: set[int]) -> None:
        """The functions of the buttons held now: tilt up (22) / down (23) move the mount while held."""
        self.tilt_rate = (22 in functions) - (23 in functions)

    def update(self, dt: float) -> None:
        """Move the mount for ``dt`` s of vehicle time."""
        if self.tilt_rate and dt > 0.0:
            p = self.params
            lo, hi = sorted((p["MNT1_PITCH_MIN"], p["MNT1_PITCH_MAX"]))
            self.tilt_deg = min(hi, max(lo, self.tilt_deg + self.tilt_rate * p["MNT1_RC_RATE"] * dt))

    # ------------------------------------------------------------------ outputs
    def _range(self, ch: int) -> tuple[float, float, float]:
        p = self.params
        return (p.get(f"SERVO{ch}_MIN", PWM_LO), p.get(f"SERVO{ch}_TRIM", PWM_MID), p.get(f"SERVO{ch}_MAX", PWM_HI))

    def _source(self, ch: int, function: int, rc: list[int], rc_in: dict[int, int]) -> int | None:
        """What output ``ch`` (9–16) sends for its function, or None (a function that drives nothing here)."""
        if function == FUNCTION["mount_tilt"]:
            p = self.params
            lo, _trim, hi = self._range(ch)
            span = p["MNT1_PITCH_MAX"] - p["MNT1_PITCH_MIN"]
            frac = (self.tilt_deg - p["MNT1_PITCH_MIN"]) / span if span else 0.5
            return int(lo + min(1.0, max(0.0, frac)) * (hi - lo))
        if function in (FUNCTION["lights1"], FUNCTION["lights2"]):
            light = self.lights[function - FUNCTION["lights1"]]
            return 0 if light is None else light
        if function == FUNCTION["video"]:
            return 0 if self.video is None else self.video
        if 51 <= function <= 58:
            return rc[function - 51] if function - 51 < len(rc) else 0
        if 59 <= function <= 66 or function == 1:
            return rc_in.get(function - 50 if function != 1 else ch, 0)
        return None

    def outputs(self, rc: list[int], rc_in: dict[int, int], previous: list[int]) -> list[int]:
        """Outputs 9–16 (µs; 0 never set) from the pilot's channels ``rc`` (1–8) and RC inputs 9–16 ``rc_in``."""
        out = list(previous)
        for ch, function in self.params.derived(_functions):
            source = self._source(ch, function, rc, rc_in)
            held = self._set.get(ch)
            if held is not None and held[:2] == (function, source):
                out[ch - 9] = held[2]               # DO_SET_SERVO holds until its source changes
                continue
            self._set.pop(ch, None)
            if source is not None:
                out[ch - 9] = source
        return out

    def set_servo(self, ch: int, pwm: int, rc: list[int], rc_in: dict[int, int]) -> bool:
        """MAV_CMD_DO_SET_SERVO of output ``ch`` (9–16): False if its function is not a free one."""
        function = int(self.params[f"SERVO{ch}_FUNCTION"])
        if function not in SERVO_FREE:
            return False
        self._set[ch] = (function, self._source(ch, function, rc, rc_in), int(pwm))
        return True

    def norm(self, function: int, outputs: list[int]) -> float:
        """ArduPilot's ``get_output_norm``: the first output with ``function``, −1…1 about its trim; 0 if none."""
        for ch, f in self.params.derived(_functions):
            if f == function:
                lo, trim, hi = self._range(ch)
                pwm = outputs[ch - 9]
                n = (pwm - trim) / (hi - trim) if pwm >= trim else (pwm - trim) / (trim - lo)
                if self.params.get(f"SERVO{ch}_REVERSED", 0.0):
                    n = -n
                return n if math.isfinite(n) else 0.0
        return 0.0

    def sub_info(self, outputs: list[int], gain: float) -> tuple[tuple[str, float], ...]:
        """ArduSub's Sub-panel NAMED_VALUE_FLOATs (:data:`SUB_INFO`), in its order."""
        tilt = 1.0 - (self.norm(FUNCTION["mount_tilt"], outputs) / 2.0 + 0.5)
        pan = 1.0 - (self.norm(FUNCTION["mount_pan"], outputs) / 2.0 + 0.5)
        light = [self.norm(FUNCTION[k], outputs) / 2.0 + 0.5 for k in ("lights1", "lights2")]
        return tuple(zip(SUB_INFO, (tilt, pan, 0.0, light[0], light[1], float(gain), 0.0, 0.0, -0.01),
                         strict=True))
