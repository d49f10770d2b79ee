"""Outputs the control law does not drive: ArduSub's RC pass-through and the motor test.

* **RC pass-through.** An output whose ``SERVOn_FUNCTION`` is RCIN9–16 takes
  the PWM the GCS or a companion sends on that RC input (RC_CHANNELS_OVERRIDE),
  clamped to 1100–1900 µs; a released input, or one not refreshed within
  ``RC_OVERRIDE_TIME`` s (negative: never expires), gives neutral (ArduSub: 0 µs, no
  pulse; the same zero thrust). A changed ``SERVOn_FUNCTION`` takes effect on the next
  whole second of vehicle time, as ArduSub re-assigns its outputs in its 1 Hz loop; and
  pass-through ignores arming, as ArduSub's does.
* **Motor test** (MAV_CMD_DO_MOTOR_TEST): one motor at a PWM, the others
  neutral, armed only, for at most 0.5 s — the GCS re-sends it to go on.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bridge.models.thrusters import NEUTRAL_PWM_US

from ..modes import MAV_RESULT
from ..params.table import RCIN_PASSTHROUGH, ParameterTable

__all__ = ["AuxOutputs", "MotorTest"]


@dataclass
class MotorTest:
    motor: int                   # 0-based
    pwm: int
    until: float                 # vehicle time (s)


class AuxOutputs:
    """The pass-through inputs and the running motor test of a vehicle with ``n`` outputs."""

    def __init__(self, params: ParameterTable, n: int):
        self.params = params
        self.n = n
        self.rc_aux: dict[int, tuple[int, float]] = {}   # RC input 9-16 overrides: channel → (µs, vehicle time)
        self.test: MotorTest | None = None
        self._assigned: tuple[tuple[int, int], ...] | None = None   # the functions in force (1 Hz re-assignment)
        self._assigned_s = -1                                        # the whole second they were read in

    def rc_override(self, channel: int, pwm: int | None, now: float) -> None:
        """RC input ``channel`` (9–16) overridden to ``pwm`` µs at vehicle time ``now``, or released (None)."""
        if pwm is None:
            self.rc_aux.pop(channel, None)
        else:
            self.rc_aux[channel] = (int(pwm), now)

    def passthrough(self, t: float) -> dict[int, int]:
        """Outputs set to RCIN9–16 at vehicle time t: output index → µs."""
        out: dict[int, int] = {}
        expiry = self.params["RC_OVERRIDE_TIME"]
        second = math.floor(t)
        if self._assigned is None or second != self._assigned_s:
            self._assigned, self._assigned_s = self._functions(), second
        for i, function in self._assigned:
            pwm, since = self.rc_aux.get(function - 50, (NEUTRAL_PWM_US, -math.inf))
            fresh = expiry < 0 or t - since <= expiry
            out[i] = min(1900, max(1100, pwm)) if fresh else NEUTRAL_PWM_US
        return out

    def _functions(self) -> tuple[tuple[int, int], ...]:
        """(output index, SERVOn_FUNCTION) of the outputs set to RCIN9–16, read from the parameter table
        again only when it has changed (its ``version``): the control task asks every tick."""
        return self.params.derived(self._read_functions)

    def _read_functions(self, p: ParameterTable) -> tuple[tuple[int, int], ...]:
        functions = (int(p[f"SERVO{i + 1}_FUNCTION"]) for i in range(self.n))
        return tuple((i, f) for i, f in enumerate(functions) if f in RCIN_PASSTHROUGH)

    def start_test(self, motor: int, pwm: int, timeout_s: float, now: float, armed: bool) -> MAV_RESULT:
        """Spin one motor (1-based) at a PWM for up to ``timeout_s`` (≤ 0.5 s) from vehicle time ``now``."""
        if not armed or not 1 <= motor <= self.n or not 1100 <= pwm <= 1900:
            return MAV_RESULT.DENIED
        self.test = MotorTest(motor - 1, int(pwm), now + min(max(timeout_s, 0.0), 0.5))
        return MAV_RESULT.ACCEPTED

    def test_pwm(self, t: float) -> np.ndarray | None:
        """The outputs of the motor test running at vehicle time t, or None (an expired test ends)."""
        if self.test is None or t > self.test.until:
            self.test = None
            return None
        pwm = np.full(self.n, NEUTRAL_PWM_US, dtype=np.int64)
        pwm[self.test.motor] = self.test.pwm
        return pwm
