"""What the companion sends the autopilot, and when it may: the two command methods and the safety rules.

Methods (``docs/companion.md``):

* ``rc`` — RC_CHANNELS_OVERRIDE of ArduSub's pilot channels 1 (pitch),
  3 (throttle), 5 (forward) in MANUAL; ArduSub's mixer drives the thrusters.
  The wrench Wavekeep's controller wants is recovered from its mixer's thrusts
  (τ = B f; the mixer compensates the motor lag, which ArduSub's does not, and
  keeps the boosted command within ±``WK_THR_MAX`` a thruster, pitch first —
  ``WK_MOT_LIM`` 1 — so the autopilot's mixer never has to clip a stick) and
  turned into sticks with the autopilot's stick model:
  ``wavekeep`` (the stand-in: a full stick is ``WK_TAU_MAX_*``, read from the
  vehicle) or ``ardusub`` (Motors6DOF: each motor's output is linear in PWM,
  1500 + 400 · Σ factor · stick, so the sticks are the least-squares fit of the
  motor factors to the mixer's PWM). RC_CHANNELS_OVERRIDE is not scaled by
  ArduSub's pilot gain (JS_GAIN applies to MANUAL_CONTROL only).
* ``servo`` — outputs 1–8 set to RCIN9–16 pass-through (SERVOn_FUNCTION = 58 + n):
  the companion's own mixer and T200 inverse, overriding channels 9–16. The
  outputs are ArduSub's motors (33–40) whenever the companion is not flying:
  it switches them to pass-through when it engages and back to the motors when
  it releases, so the mode the pilot selects has thrusters (ArduSub's own modes
  drive only outputs set to motors).

Safety: the companion never arms and never changes mode. It engages only when
it has seen the pilot arm the vehicle in MANUAL (or select MANUAL while armed)
(and, with ``permit_required``, in a tick its host allowed: the BlueOS page's Engage),
and releases — at once, from the message that told it, so within one tick — on
any mode change or disarm, on stale telemetry (``stale_s`` of wall time without
ATTITUDE), when it has itself stood still that long (frozen, then resumed), on
an estimate that is no longer finite (the estimator starts again from the next
readings), and on exit. Releasing is the protocol's: 0 on channels 1–8, 65534
(UINT16_MAX − 1) on 9–16; 65535 (and 0 on 9–18) leaves a channel alone.
Every engagement and release is said in a STATUSTEXT. Overrides also expire in
the autopilot after RC_OVERRIDE_TIME, so a killed companion stops commanding.
"""
from __future__ import annotations

import math
import time
from typing import Any

import numpy as np

from .autopilot import MANUAL, SUB_MODES, AutopilotLink

__all__ = ["ARDUSUB_FACTORS", "MOTOR_FUNCTIONS", "PASSTHROUGH_FUNCTIONS", "Commander", "neutral_channels",
           "release_channels",
           "set_output_functions"]

IGNORE, RELEASE_LOW, RELEASE_HIGH = 65535, 0, 65534
ALT_HOLD, GUIDED = 2, 4                         # the companion's own modes (firmware_py.modes.Mode)
MOTORS_AFTER_S = 0.1
"""servo: s of wall time between the neutral override and handing the outputs back to the motors (two ticks:
ArduSub has put the neutral on its outputs by then)."""
RELEASE_AFTER_S = 1.5
"""servo: s of wall time between handing the outputs back to the motors and releasing the inputs (ArduSub
re-assigns outputs in its 1 Hz loop; a neutral override outlives a companion that exits by RC_OVERRIDE_TIME)."""
MOTOR_FUNCTIONS = tuple(range(33, 41))          # SERVO1-8_FUNCTION: motors 1-8 (ArduSub's own mixer)
PASSTHROUGH_FUNCTIONS = tuple(range(59, 67))    # SERVO1-8_FUNCTION: RCIN9-16 (the companion's PWM)

ARDUSUB_FACTORS = np.array([
    # pitch, throttle, forward (docs/reference.md §3, BlueROV2 Heavy, motors 1-8)
    [0, 0, -1], [0, 0, -1], [0, 0, 1], [0, 0, 1], [-1, -1, 0], [-1, -1, 0], [1, -1, 0], [1, -1, 0]], dtype=float)


def set_output_functions(link: AutopilotLink, functions: tuple[int, ...]) -> None:
    """SERVO1-8_FUNCTION as given (PARAM_SET, twice: UDP); ArduSub re-assigns its outputs at once."""
    for _ in range(2):
        for n, f in enumerate(functions, 1):
            link.set_param(f"SERVO{n}_FUNCTION", float(f))


def neutral_channels(method: str) -> list[int]:
    """The RC_CHANNELS_OVERRIDE that centres the channels a method uses (no thrust), before releasing them."""
    if method == "rc":
        return [1500, IGNORE, 1500, IGNORE, 1500, IGNORE, IGNORE, IGNORE] + [0] * 10
    return [IGNORE] * 8 + [1500] * 8 + [0, 0]


def release_channels(method: str) -> list[int]:
    """The RC_CHANNELS_OVERRIDE that hands the channels a method uses back to the pilot."""
    if method == "rc":
        return [RELEASE_LOW, IGNORE, RELEASE_LOW, IGNORE, RELEASE_LOW, IGNORE, IGNORE, IGNORE] + [0] * 10
    return [IGNORE] * 8 + [RELEASE_HIGH] * 8 + [0, 0]


class Commander:
    """Engagement state and the command path (scheduler thread only)."""

    def __init__(self, link: AutopilotLink, method: str, stick_model: str, curve, allocation: np.ndarray,
                 tau_max: tuple[float, float, float], stale_s: float = 0.5, log=print):
        if method not in ("rc", "servo"):
            raise ValueError(f"method must be rc or servo, got {method!r}")
        self.link, self.method, self.stick_model = link, method, stick_model
        self.curve, self.B = curve, np.asarray(allocation, dtype=float)
        self.tau_max = np.asarray(tau_max, dtype=float)
        self.factors_pinv = np.linalg.pinv(ARDUSUB_FACTORS)
        self.stale_s = float(stale_s)
        self.log = log
        self.engaged = False
        self.selected = False           # the pilot armed / selected MANUAL since the companion last released
        self.sent_any = False
        self.fw: Any = None             # the companion's Firmware (set once built)
        self.events: list[tuple[float, str]] = []
        self.latency_s: list[float] = []      # wall s from the ATTITUDE's arrival to the command sent
        self.answered_ms: list[int] = []      # that ATTITUDE's time_boot_ms, per command
        self.sent: list[list[int]] = []       # the channels it set (servo: 9-16; rc: 1, 3, 5)
        self.depth_only = False         # engaged before its estimate had a position: depth and pitch only
        self._station = np.zeros(3)     # the station it engaged at [x, depth, θ]
        self._resets = 0                # the estimator's restarts seen (a non-finite estimate)
        self._faults = 0                # non-finite commands the control task replaced by neutral
        self._last_gate = time.monotonic()   # wall time of the last gate (a tick about to run)
        self._motors_due: float | None = None     # servo, released: when to restore the motors (wall s)
        self._release_due: float | None = None    # then when to release the neutral-held inputs (wall s)
        # A host that must say yes first (the BlueOS extension's Engage): with permit_required, the gate engages
        # only in a tick where permitted is True (the host sets it for one tick, from the scheduler's thread)
        self.permit_required = False
        self.permitted = False
        link.on_mode_change = self.on_mode_change

    # ------------------------------------------------------------------ safety
    def on_mode_change(self, armed: bool, mode: int | None) -> None:
        """Every HEARTBEAT that changes arming or mode: release at once unless it is still armed in MANUAL."""
        if armed and mode == MANUAL:
            self.selected = True
            self.say(6, "WK: MANUAL armed by pilot: " + ("engage it from the page" if self.permit_required
                                                           else "engaging"))
        elif self.engaged or self.selected:
            why = "disarmed" if not armed else f"pilot selected {SUB_MODES.get(mode or 0, mode)}"
            self.selected = False
            self.release(why)

    def gate(self, _slot_ns: int = 0) -> None:
        """Before each control tick: engage when allowed, release on stale telemetry."""
        st = self.link.state
        fresh = self.link.fresh("ATTITUDE", self.stale_s) is not None
        now = time.monotonic()
        gap, self._last_gate = now - self._last_gate, now
        if not self.engaged:
            self._hand_back(now)
        if self.fw is not None and self._diverged():
            self.selected = False
            self.release("estimate not finite: re-initialised")
        elif self.engaged and gap > self.stale_s:
            # The companion itself stood still (frozen, suspended, starved of CPU): what it knew is old and the
            # autopilot may already have dropped its overrides. It hands back rather than resume.
            self.selected = False
            self.release(f"companion stalled {gap:.1f} s")
        elif self.engaged and self.depth_only and self.fw is not None and self.fw.ekf.converged():
            self._hold_every_axis()
        elif self.engaged and not fresh:
            self.selected = False
            self.release(f"stale telemetry, ATTITUDE {self._attitude_age():.1f} s old")
        elif (not self.engaged and self.selected and fresh and st.armed and st.mode == MANUAL
              and (self.permitted or not self.permit_required)):
            self._engage()

    def _hold_every_axis(self) -> None:
        """Engaged holding depth and pitch only (its estimate had no position yet, e.g. no fix in its first
        frame): once the estimate has converged, every axis on the station it engaged at (the feed-forward
        needs them all). Before, it stayed in depth hold for the whole flight and the vehicle drifted."""
        fw = self.fw
        if fw.request_mode(GUIDED) == 0:
            fw.setpoint = self._station.copy()
            self.depth_only = False
            self.say(6, "WK: position estimate converged: holding every axis")

    def _hand_back(self, now: float) -> None:
        """servo, after a release: the motor functions once the neutral is out, then (except at exit: the
        neutral override expires by itself) the inputs."""
        if self._motors_due is not None and now >= self._motors_due:
            set_output_functions(self.link, MOTOR_FUNCTIONS)
            self._motors_due = None
            self._release_due = None if now == math.inf else now + RELEASE_AFTER_S
        elif self._release_due is not None and now >= self._release_due:
            for _ in range(3):
                self.link.rc_override(release_channels(self.method))
            self._release_due = None

    def _attitude_age(self) -> float:
        """Wall s since the newest ATTITUDE arrived (inf before the first)."""
        s = self.link.state.samples.get("ATTITUDE")
        return math.inf if s is None else time.monotonic() - s.arrived

    def _diverged(self) -> bool:
        """Has the estimate (or a command from it) stopped being finite since the last look? The estimator
        restarts itself from the next readings; the pilot gets the vehicle back meanwhile."""
        fw = self.fw
        ekf = fw.ekf
        if ekf.initialised and not (np.isfinite(ekf.x).all() and np.isfinite(ekf.P).all()):
            ekf.initialised = False        # a prediction diverged: initialise again from the next readings
            ekf.restarts += 1
        resets, faults = ekf.restarts, fw.output_faults
        changed = resets != self._resets or faults != self._faults
        self._resets, self._faults = resets, faults
        return changed

    def watchdog(self) -> None:
        """Called while waiting for telemetry: stale telemetry releases without waiting for a tick (and a
        hand-back in progress goes on: no tick may come)."""
        if not self.engaged:
            self._hand_back(time.monotonic())
        if self.engaged and self.link.fresh("ATTITUDE", self.stale_s) is None:
            self.selected = False
            self.release(f"stale telemetry, ATTITUDE {self._attitude_age():.1f} s old")

    def _engage(self) -> None:
        fw = self.fw
        if fw is None or not fw.ekf.initialised:
            return
        station = fw.setpoint.copy()
        self._motors_due = self._release_due = None
        if self.method == "servo":
            # the pass-through inputs hold neutral before the outputs switch to them (no gap of 0 µs)
            self.link.rc_override([IGNORE] * 8 + [1500] * 8 + [0, 0])
            set_output_functions(self.link, PASSTHROUGH_FUNCTIONS)
        fw.request_arm(True, force=True)
        self.depth_only = fw.request_mode(GUIDED) != 0     # GUIDED: every axis held
        if self.depth_only:
            fw.request_mode(ALT_HOLD)                      # no position estimate yet: depth and pitch
        fw.setpoint = station
        self._station = station
        self.engaged = True
        self.say(6, f"WK: engaged ({self.method}), station x {station[0]:.1f} d {station[1]:.1f}")

    def release(self, why: str) -> None:
        """Hand every channel this method uses back (three times: UDP) and stop commanding."""
        if not (self.engaged or self.sent_any):
            return
        # Neutral first: on ArduSub 4.7 a pass-through output whose input is released keeps the PWM it had
        # (measured: 1804/1137 µs held until the output became a motor again, up to a second later)
        for _ in range(3):
            self.link.rc_override(neutral_channels(self.method))
        if self.method == "servo":
            # then the motors again (the pilot's mode has thrusters), once the neutral is on the outputs: an
            # output whose function changes holds its PWM until ArduSub's 1 Hz loop re-assigns it; the inputs
            # are released after that (:meth:`_hand_back`, from the next ticks' gate)
            self._motors_due = time.monotonic() + MOTORS_AFTER_S
            if why == "companion exiting":          # no next tick: wait here
                time.sleep(MOTORS_AFTER_S)
                self._hand_back(math.inf)
        else:
            for _ in range(3):
                self.link.rc_override(release_channels(self.method))
        was = self.engaged
        self.engaged, self.sent_any = False, False
        if self.fw is not None:
            self.fw.request_arm(False)
        self.say(4 if was else 6, f"WK: released overrides ({why})")

    def say(self, severity: int, text: str) -> None:
        self.events.append((time.monotonic(), text))
        self.log(text)
        self.link.statustext(severity, text)

    # ------------------------------------------------------------------ commands
    def output(self, pwm: np.ndarray) -> None:
        """The HAL's write_pwm: send the mixer's output the chosen way, only while engaged."""
        if not self.engaged:
            return
        if self.fw is not None and self._diverged():   # the tick just replaced a non-finite command
            self.selected = False
            self.release("estimate not finite: re-initialised")
            return
        channels = self.channels(np.asarray(pwm, dtype=float))
        self.link.rc_override(channels)
        self.sent_any = True
        att = self.link.state.samples.get("ATTITUDE")
        if att is not None:
            self.latency_s.append(time.monotonic() - att.arrived)
            self.answered_ms.append(att.t_ms)     # the telemetry this command answers (the autopilot's clock)
            self.sent.append(channels[8:16] if self.method == "servo" else [channels[i] for i in (0, 2, 4)])

    def channels(self, pwm: np.ndarray) -> list[int]:
        """The RC_CHANNELS_OVERRIDE channel values (18) for the mixer's eight PWMs."""
        if self.method == "servo":
            return [IGNORE] * 8 + [int(v) for v in np.clip(np.rint(pwm), 1100, 1900)] + [0, 0]
        pitch, throttle, forward = self.sticks(pwm)
        ch = [IGNORE] * 8 + [0] * 10
        for i, s in ((0, pitch), (2, throttle), (4, forward)):
            ch[i] = int(np.rint(1500 + 400 * min(1.0, max(-1.0, s))))
        return ch

    def sticks(self, pwm: np.ndarray) -> tuple[float, float, float]:
        """(pitch, throttle, forward) sticks in [−1, 1] that make the autopilot give what the mixer wanted."""
        if self.stick_model == "ardusub":
            s = self.factors_pinv @ ((pwm - 1500.0) / 400.0)
            return float(s[0]), float(s[1]), float(s[2])
        tau = self.B @ self.curve.thrust(pwm)               # [X, Z, M]: Z down (FRD); the throttle is up
        s = tau / self.tau_max
        return float(s[2]), float(-s[1]), float(s[0])
