"""Flight modes with ArduSub's numbers and meanings (docs/reference.md §3), mapped onto Wavekeep's controllers.

Which axes the automatic controller holds in each mode; the others take the
pilot's input straight to the mixer (scaled by τ_max):

=========  ==  ===========================================================
mode       #   surge / heave / pitch
=========  ==  ===========================================================
STABILIZE  0   pilot / pilot / held at the target pitch
ALT_HOLD   2   pilot / depth held (pilot's throttle moves it) / held
GUIDED     4   all held: the SET_POSITION_TARGET_LOCAL_NED target (+ FF)
SURFACE    9   pilot / rising to the surface / held
POSHOLD    16  all held at the pose where the mode was entered (+ FF)
MANUAL     19  pilot / pilot / pilot
=========  ==  ===========================================================
"""
from __future__ import annotations

from enum import IntEnum

__all__ = ["AUTO_AXES", "GUIDED_GROUP", "MAV_RESULT", "MAV_SEVERITY", "MAV_STATE", "MODE_NAMES", "Mode"]


class Mode(IntEnum):
    STABILIZE = 0
    ACRO = 1
    ALT_HOLD = 2
    AUTO = 3
    GUIDED = 4
    CIRCLE = 7
    SURFACE = 9
    POSHOLD = 16
    MANUAL = 19
    MOTOR_DETECT = 20
    SURFTRAK = 21


SUPPORTED = (Mode.STABILIZE, Mode.ALT_HOLD, Mode.GUIDED, Mode.SURFACE, Mode.POSHOLD, Mode.MANUAL)
MODE_NAMES = {int(m): m.name for m in Mode}

AUTO_AXES = {
    Mode.STABILIZE: (False, False, True),
    Mode.ALT_HOLD: (False, True, True),
    Mode.GUIDED: (True, True, True),
    Mode.SURFACE: (False, True, True),
    Mode.POSHOLD: (True, True, True),
    Mode.MANUAL: (False, False, False),
}
"""Per supported mode: does the automatic controller hold (surge, heave, pitch)?"""

GUIDED_GROUP = (Mode.AUTO, Mode.GUIDED, Mode.CIRCLE, Mode.POSHOLD)
"""Modes that set MAV_MODE_FLAG_GUIDED_ENABLED in the heartbeat, as ArduSub does."""


class MAV_RESULT(IntEnum):
    ACCEPTED = 0
    TEMPORARILY_REJECTED = 1
    DENIED = 2
    UNSUPPORTED = 3
    FAILED = 4


class MAV_STATE(IntEnum):
    BOOT = 1
    STANDBY = 3
    ACTIVE = 4
    CRITICAL = 5


class MAV_SEVERITY(IntEnum):
    EMERGENCY = 0
    ALERT = 1
    CRITICAL = 2
    ERROR = 3
    WARNING = 4
    NOTICE = 5
    INFO = 6
    DEBUG = 7
