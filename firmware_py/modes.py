"""Flight modes with ArduSub's numbers and meanings (docs/reference.md §3), mapped onto Wavekeep's controllers.

Which axes the automatic controller holds in each mode; the others take the
pilot's input straight to the mixer (scaled by τ_max):

=========  ==  ===========================================================
mode       #   surge / heave / pitch
=========  ==  ===========================================================
STABILIZE  0   pilot / pilot / held at the target pitch
ACRO       1   pilot / pilot / held; the pitch stick moves the target at a rate
ALT_HOLD   2   pilot / depth held (pilot's throttle moves it) / held
GUIDED     4   all held: the SET_POSITION_TARGET_LOCAL_NED target (+ FF)
SURFACE    9   pilot / rising to the surface / held
POSHOLD    16  all held at the pose where the mode was entered (+ FF)
MANUAL     19  pilot / pilot / pilot
SURFTRAK   21  as ALT_HOLD: it tracks the seabed only with a rangefinder, and there is none
=========  ==  ===========================================================

AUTO, CIRCLE and MOTOR_DETECT are refused as ArduSub refuses a mode whose
start fails ("Flight mode change failed NAME"): a mission is not flown here, a
circle needs the sway this planar vehicle has not got, and the thrusters'
directions are fixed by the vehicle's configuration (:func:`mode_refusal`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum

import numpy as np

from .params.table import ParameterTable

__all__ = ["AUTO_AXES", "FLIGHT_MODES", "GUIDED_GROUP", "MAV_RESULT", "MAV_SEVERITY", "MAV_STATE", "MODE_NAMES",
           "REQUIRES_ALTITUDE", "REQUIRES_POSITION", "FlightMode", "Mode", "PilotInput", "mode_refusal"]


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


MODE_NAMES = {int(m): m.name for m in Mode}


@dataclass
class PilotInput:
    """The pilot's stick demands, normalised to [−1, 1]: forward (surge), up (heave), pitch up."""

    surge: float = 0.0
    up: float = 0.0
    pitch: float = 0.0
    t: float = -math.inf          # vehicle time of the last input (s)


class FlightMode:
    """One flight mode, as ArduSub's ``Mode`` classes: the axes it holds, its target on entry, how it moves.

    ``holds`` says whether the automatic controller holds (surge, heave, pitch);
    the other axes take the pilot's sticks straight to the mixer. Targets are
    [x, depth, θ] (NED m, m, rad).
    """

    number: Mode
    holds: tuple[bool, bool, bool]
    entry_text = ""
    """What ArduSub says when it enters the mode (most say nothing)."""
    holds_where_entered = False
    """The mode's target is the pose where it was entered (the lateral plane's sway and heading too)."""

    def enter(self, previous: Mode, pose: np.ndarray, target: np.ndarray) -> np.ndarray:
        """The target on entering the mode from ``previous``, with the vehicle at ``pose`` [x, z, θ]."""
        return target

    def update_target(self, target: np.ndarray, pilot: PilotInput, t: float, params: ParameterTable,
                      h: float) -> None:
        """Move the target in place for one control period of ``h`` s (most modes hold it still)."""


class _HoldWhereEntered(FlightMode):
    holds_where_entered = True

    def enter(self, previous: Mode, pose: np.ndarray, target: np.ndarray) -> np.ndarray:
        return np.array([pose[0], pose[1], 0.0])   # hold where the mode was entered, level (ArduSub)


class Manual(FlightMode):
    number, holds = Mode.MANUAL, (False, False, False)


class Stabilize(_HoldWhereEntered):
    number, holds = Mode.STABILIZE, (False, False, True)


class PosHold(_HoldWhereEntered):
    number, holds = Mode.POSHOLD, (True, True, True)


class AltHold(_HoldWhereEntered):
    """Depth held; the throttle stick moves the depth target at up to WK_CLIMB_RATE."""

    number, holds = Mode.ALT_HOLD, (False, True, True)

    def update_target(self, target: np.ndarray, pilot: PilotInput, t: float, params: ParameterTable,
                      h: float) -> None:
        if t - pilot.t <= params["WK_PILOT_TMO"]:
            up = pilot.up if abs(pilot.up) > 0.05 else 0.0
            target[1] = max(0.0, target[1] - up * params["WK_CLIMB_RATE"] * h)


class Acro(_HoldWhereEntered):
    """The pitch stick commands a pitch rate (ArduSub's ACRO_RP_P: rate = stick × ANGLE_MAX × ACRO_RP_P);
    centred, the pitch is held. The target stays within ±ANGLE_MAX (ArduSub's "limited" ACRO trainer)."""

    number, holds = Mode.ACRO, (False, False, True)

    def update_target(self, target: np.ndarray, pilot: PilotInput, t: float, params: ParameterTable,
                      h: float) -> None:
        if t - pilot.t <= params["WK_PILOT_TMO"]:
            limit = math.radians(params["ANGLE_MAX"] / 100.0)
            rate = pilot.pitch * limit * params["ACRO_RP_P"]
            target[2] = min(limit, max(-limit, target[2] + rate * h))


class SurfTrak(AltHold):
    """ArduSub's surface tracking, without a rangefinder: it holds depth as ALT_HOLD (and says it waits)."""

    number = Mode.SURFTRAK
    entry_text = "waiting for a rangefinder reading"


class Surface(_HoldWhereEntered):
    """The depth target rises to the surface at WK_SURF_RATE."""

    number, holds = Mode.SURFACE, (False, True, True)

    def update_target(self, target: np.ndarray, pilot: PilotInput, t: float, params: ParameterTable,
                      h: float) -> None:
        target[1] = max(0.0, target[1] - params["WK_SURF_RATE"] * h)


class Guided(FlightMode):
    """All axes held at the ground station's target (SET_POSITION_TARGET_LOCAL_NED); here on entry."""

    number, holds = Mode.GUIDED, (True, True, True)

    def enter(self, previous: Mode, pose: np.ndarray, target: np.ndarray) -> np.ndarray:
        return target if previous == Mode.GUIDED else np.array([pose[0], pose[1], 0.0])


FLIGHT_MODES: dict[Mode, FlightMode] = {m.number: m for m in
                                        (Stabilize(), Acro(), AltHold(), Guided(), Surface(), PosHold(), Manual(),
                                         SurfTrak())}
"""The supported modes. Adding a mode is a class above and an entry here."""

REQUIRES_POSITION = (Mode.AUTO, Mode.GUIDED, Mode.CIRCLE, Mode.POSHOLD)
"""ArduSub's modes that need a position estimate (its ``requires_GPS``)."""
REQUIRES_ALTITUDE = (Mode.ALT_HOLD, Mode.SURFTRAK, Mode.SURFACE, *REQUIRES_POSITION)
"""Modes that need a depth estimate (ArduSub's ``requires_altitude``)."""


def mode_refusal(number: int, current: Mode, position_ok: bool, altitude_ok: bool) -> str | None:
    """Why a switch to mode ``number`` from ``current`` is refused, in ArduSub's words (WARNING); None if it is not.

    In ArduSub's order: an unknown number, a mode that needs a position estimate without one, a depth-holding
    mode entered from one that does not without a depth estimate, and a mode whose start fails (here: one
    Wavekeep does not fly). The current mode is never refused.
    """
    try:
        m = Mode(int(number))
    except ValueError:
        return f"No such mode {int(number)}"
    if m == current:
        return None
    if m in REQUIRES_POSITION and not position_ok:
        return f"Mode change failed: {m.name} requires position"
    if m in REQUIRES_ALTITUDE and current not in REQUIRES_ALTITUDE and not altitude_ok:
        return f"Mode change failed: {m.name} need alt estimate"
    if m not in FLIGHT_MODES:
        return f"Flight mode change failed {m.name}"
    return None

SUPPORTED = tuple(FLIGHT_MODES)

AUTO_AXES = {number: mode.holds for number, mode in FLIGHT_MODES.items()}
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
