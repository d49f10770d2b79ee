"""The firmware's failsafes, after ArduSub's: a silent ground station and a diverged estimator.

Each failsafe watches one thing and, when it trips, says so (STATUSTEXT) and
returns the action its parameter names; the firmware carries the action out
(:data:`FailsafeAction`: 1 warn, 2 disarm, 3 depth hold, 4 surface — the
numbers of ArduSub's ``FS_GCS_ENABLE`` and ``FS_EKF_ACTION``). Both clear by
themselves when the cause goes away.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from enum import IntEnum

from .estimator import PlanarEKF
from .modes import MAV_SEVERITY
from .params import ParameterTable

__all__ = ["EKFFailsafe", "FailsafeAction", "GCSFailsafe"]


class FailsafeAction(IntEnum):
    NONE = 0
    WARN = 1
    DISARM = 2
    DEPTH_HOLD = 3
    SURFACE = 4


Say = Callable[[int, str], None]


class GCSFailsafe:
    """FS_GCS_ENABLE: the ground station's heartbeat not heard for FS_GCS_TIMEOUT s while armed.

    Acts only once a GCS has been heard (as ArduSub), and once per loss.
    """

    def __init__(self, params: ParameterTable, say: Say):
        self.params, self.say = params, say
        self.active = False
        self.last_seen: float | None = None     # vehicle time (s) of the last GCS heartbeat

    def heard(self, t: float) -> None:
        """The GCS's heartbeat at vehicle time ``t`` (s); clears the failsafe."""
        self.last_seen = t
        if self.active:
            self.active = False
            self.say(MAV_SEVERITY.INFO, "GCS failsafe cleared")

    def check(self, t: float, armed: bool) -> FailsafeAction:
        """The action to take now (NONE unless the failsafe trips at this tick)."""
        action = FailsafeAction(int(self.params["FS_GCS_ENABLE"]))
        if (action == FailsafeAction.NONE or not armed or self.last_seen is None or self.active
                or t - self.last_seen <= self.params["FS_GCS_TIMEOUT"]):
            return FailsafeAction.NONE
        self.active = True
        self.say(MAV_SEVERITY.CRITICAL, "GCS failsafe")
        return action


class EKFFailsafe:
    """FS_EKF_ACTION: a non-finite estimate, or a position 1-σ beyond FS_EKF_THRESH (m).

    A non-finite estimate also restarts the estimator from the next sensor frame.
    """

    def __init__(self, params: ParameterTable, say: Say):
        self.params, self.say = params, say
        self.active = False

    def check(self, ekf: PlanarEKF, armed: bool) -> FailsafeAction:
        """The action to take now (NONE unless the failsafe trips at this tick while armed)."""
        if not ekf.initialised:
            return FailsafeAction.NONE
        # every tick: on Python floats, not 6-element arrays. σ = √var is finite exactly where the variance
        # is finite and not negative (√ of a negative is NaN); √ is correctly rounded in math and numpy alike
        var = ekf.P.diagonal().tolist()
        finite = all(map(math.isfinite, ekf.x.tolist()))
        bad = (not finite or not all(map(math.isfinite, var)) or min(var) < 0.0
               or max(math.sqrt(var[0]), math.sqrt(var[1])) > self.params["FS_EKF_THRESH"])
        if not bad:
            if self.active:
                self.active = False
                self.say(MAV_SEVERITY.INFO, "EKF failsafe cleared")
            return FailsafeAction.NONE
        if self.active:
            return FailsafeAction.NONE
        self.active = True
        action = FailsafeAction(int(self.params["FS_EKF_ACTION"]))
        if action == FailsafeAction.NONE:
            return action
        self.say(MAV_SEVERITY.CRITICAL, "EKF failsafe")
        if not finite:
            ekf.initialised = False          # start again from the next sensor frame
        return action if armed else FailsafeAction.NONE
