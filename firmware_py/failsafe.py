"""The firmware's failsafes, as ArduSub 4.7 runs them: a silent ground station and a bad estimator.

Each failsafe watches one thing and, when it trips, says so (STATUSTEXT, ArduSub's
words and severities) and returns the action its parameter names; the firmware
carries the action out (:data:`FailsafeAction`: 1 warn, 2 disarm, 3 depth hold,
4 surface — ``FS_GCS_ENABLE``'s numbers; ``FS_EKF_ACTION`` has 0 off, 1 warn,
2 disarm). Both clear by themselves when the cause goes away. (The pilot-input
failsafe is the GCS link's: :mod:`firmware_py.mavlink.pilot`.)
"""
from __future__ import annotations

import math
from collections.abc import Callable
from enum import IntEnum

from .estimation.estimator import PlanarEKF
from .modes import MAV_SEVERITY
from .params.table import ParameterTable

__all__ = ["EKF_BAD_S", "GCS_WARN_PERIOD_S", "EKFFailsafe", "FailsafeAction", "GCSFailsafe"]

GCS_WARN_PERIOD_S = 30.0       # ArduSub repeats "MYGCS: N, heartbeat lost" this often while the GCS is silent
EKF_BAD_S = 2.0                # ArduSub: the estimate must be bad this long before the EKF failsafe trips
EKF_WARN_PERIOD_S = 20.0       # and says "EKF bad" at most this often


class FailsafeAction(IntEnum):
    NONE = 0
    WARN = 1
    DISARM = 2
    DEPTH_HOLD = 3
    SURFACE = 4


Say = Callable[[int, str], None]


class GCSFailsafe:
    """FS_GCS_ENABLE: the ground station's heartbeat not heard for FS_GCS_TIMEOUT s (ArduSub's ``failsafe_gcs_check``).

    Only once a GCS has been heard. While it is silent: "MYGCS: <MAV_GCS_SYSID>, heartbeat lost" (WARNING)
    every 30 s of vehicle time (counted from boot, as ArduSub's), armed or not; the action once, when armed.
    A heartbeat after the action: "GCS Failsafe Cleared" (WARNING).
    """

    def __init__(self, params: ParameterTable, say: Say, note: Say | None = None):
        self.params, self.say, self.note = params, say, note   # note: the run's log only (ArduSub says nothing)
        self.active = False
        self.last_seen: float | None = None     # vehicle time (s) of the last GCS heartbeat
        self.last_warn = 0.0                    # vehicle time (s) of the last "heartbeat lost"

    def heard(self, t: float) -> None:
        """The GCS's heartbeat at vehicle time ``t`` (s); clears the failsafe."""
        self.last_seen = t
        if self.active:
            self.active = False
            self.say(MAV_SEVERITY.WARNING, "GCS Failsafe Cleared")

    def check(self, t: float, armed: bool) -> FailsafeAction:
        """The action to take now (NONE unless the failsafe trips at this tick)."""
        action = FailsafeAction(int(self.params["FS_GCS_ENABLE"]))
        silent = self.last_seen is not None and t - self.last_seen >= self.params["FS_GCS_TIMEOUT"]
        if action == FailsafeAction.NONE or not silent:
            return FailsafeAction.NONE
        if t - self.last_warn > GCS_WARN_PERIOD_S:
            self.last_warn = t
            self.say(MAV_SEVERITY.WARNING, f"MYGCS: {int(self.params['MAV_GCS_SYSID'])}, heartbeat lost")
        if self.active or not armed:
            return FailsafeAction.NONE
        self.active = True
        if self.note is not None:
            self.note(MAV_SEVERITY.CRITICAL, "GCS failsafe")
        return action


class EKFFailsafe:
    """FS_EKF_ACTION (ArduSub's ``failsafe_ekf_check``): the estimator's velocity test ratio (EKF_STATUS_REPORT's:
    the position 1-σ over WK_EKF_SD_BAD, m) at or above FS_EKF_THRESH for 2 s, or a non-finite estimate.

    Then "EKF bad" (WARNING, at most every 20 s) and, with FS_EKF_ACTION 2, the vehicle disarms; 0 turns the
    check off. A non-finite estimate also restarts the estimator from the next sensor frame, whatever the action.
    """

    def __init__(self, params: ParameterTable, say: Say):
        self.params, self.say = params, say
        self.active = False
        self._good_t: float | None = None        # vehicle time the estimate was last good
        self._warned_t = -math.inf

    def check(self, ekf: PlanarEKF, armed: bool, t: float) -> FailsafeAction:
        """The action to take at vehicle time ``t`` (NONE unless the failsafe trips now while armed)."""
        if not ekf.initialised:
            return FailsafeAction.NONE
        # every tick: on Python floats, not 6-element arrays. σ = √var is finite exactly where the variance
        # is finite and not negative (√ of a negative is NaN); √ is correctly rounded in math and numpy alike
        var = ekf.P.diagonal().tolist()
        finite = all(map(math.isfinite, ekf.x.tolist()))
        if not finite:
            ekf.initialised = False              # start again from the next sensor frame
        action = int(self.params["FS_EKF_ACTION"])
        bad = (not finite or not all(map(math.isfinite, var)) or min(var) < 0.0
               or math.sqrt(var[0]) / self.params["WK_EKF_SD_BAD"] >= self.params["FS_EKF_THRESH"])
        if action == 0 or not bad:
            self._good_t, self.active = t, False
            return FailsafeAction.NONE
        if self._good_t is None:
            self._good_t = t
        if t < self._good_t + EKF_BAD_S or self.active:
            return FailsafeAction.NONE
        self.active = True
        if t > self._warned_t + EKF_WARN_PERIOD_S:
            self._warned_t = t
            self.say(MAV_SEVERITY.WARNING, "EKF bad")
        return FailsafeAction.DISARM if action == 2 and armed else FailsafeAction.NONE
