"""The parameter table: the one place a tunable lives (ArduPilot's AP_Param, in miniature).

Every gain, noise level and limit of the firmware is a named parameter of at
most 16 characters (MAVLink's PARAM_VALUE limit). :data:`PARAM_DEFS` defines
each one — name, range, units, meaning — and ``configs/firmware/params.yaml``
gives every default. Values are read and set at runtime through
:class:`ParameterTable`; a set outside the range, or NaN, is refused and the old
value kept, as ArduPilot's parameter protocol expects.

Simulated-sensor parameters carry ArduPilot's ``SIM_`` prefix: they describe
the SITL HAL's sensors, not the estimator's beliefs (``WK_EKF_R_*``).
"""
from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

from bridge.configfile import ConfigError, load_config, resolve_config

__all__ = ["PARAM_DEFS", "RCIN_PASSTHROUGH", "ParamDef", "ParameterTable", "load_params", "parse_assignment"]


INT_TYPE_RANGES: dict[str, tuple[int, int]] = {"INT8": (-128, 127), "INT16": (-32768, 32767),
                                               "INT32": (-2**31, 2**31 - 1)}
"""The storage types of integer parameters (AP_Int8/16/32) and what each holds."""
PARAM_TYPES = ("REAL32", *INT_TYPE_RANGES)


@dataclass(frozen=True)
class ParamDef:
    """Definition of one parameter: name (≤ 16 chars), inclusive range, units, meaning, storage type.

    ``ptype`` is the MAVLink parameter type (ArduPilot's AP_Float / AP_Int8 / AP_Int16 /
    AP_Int32): ``"REAL32"``, ``"INT8"``, ``"INT16"`` or ``"INT32"``. ``integer=True``
    without a ``ptype`` means INT32; an integer ``ptype`` makes the parameter integer.
    ``readonly``: a ground station may read it but not set it (ArduPilot's read-only
    parameters; the configuration file still sets it).
    """

    name: str
    lo: float
    hi: float
    units: str
    doc: str
    integer: bool = False
    ptype: str = ""
    readonly: bool = False
    allowed: frozenset[float] | None = None     # when set, only these values (e.g. a thruster output's functions)

    def __post_init__(self) -> None:
        if not (1 <= len(self.name) <= 16) or self.name.upper() != self.name:
            raise ValueError(f"parameter name {self.name!r} must be 1-16 upper-case characters")
        if not self.lo <= self.hi:
            raise ValueError(f"parameter {self.name}: empty range [{self.lo}, {self.hi}]")
        ptype = self.ptype or ("INT32" if self.integer else "REAL32")
        if ptype not in PARAM_TYPES:
            raise ValueError(f"parameter {self.name}: type {ptype!r} is not one of {', '.join(PARAM_TYPES)}")
        object.__setattr__(self, "ptype", ptype)
        object.__setattr__(self, "integer", ptype != "REAL32")
        if self.integer:
            lo, hi = INT_TYPE_RANGES[ptype]
            if not lo <= self.lo <= self.hi <= hi:
                raise ValueError(f"parameter {self.name}: range [{self.lo}, {self.hi}] does not fit {ptype}")

    def check(self, value: float) -> str | None:
        """Why ``value`` is not allowed, or None."""
        if isinstance(value, bool):
            value = float(value)
        if not isinstance(value, (int, float)) or not math.isfinite(value):
            return f"got {value!r}; allowed: a finite number in [{self.lo:g}, {self.hi:g}]"
        if self.integer and not float(value).is_integer():
            return f"got {value!r}; allowed: an integer in [{self.lo:g}, {self.hi:g}]"
        if not self.lo <= value <= self.hi:
            return f"got {value!r}; allowed: [{self.lo:g}, {self.hi:g}] {self.units}".rstrip()
        if self.allowed is not None and float(value) not in self.allowed:
            return f"got {value!r}; allowed: {', '.join(f'{v:g}' for v in sorted(self.allowed))}"
        return None


def _axes(prefix: str, lo: float, hi: float, units: tuple[str, str, str], doc: str) -> list[ParamDef]:
    """One parameter per DoF: _X surge, _Z heave, _P pitch."""
    return [ParamDef(f"{prefix}_{ax}", lo, hi, u, f"{doc} ({name})")
            for ax, name, u in zip("XZP", ("surge", "heave", "pitch"), units, strict=False)]


def _ardusub_defs() -> list[ParamDef]:
    """The ArduSub parameters QGroundControl's Sub pages read (docs/mavlink.md says which ones act)."""
    i8, i16, i32 = "INT8", "INT16", "INT32"
    defs = [
        ParamDef("FRAME_CONFIG", 0, 7, "", "frame: 2 = Vectored-6DOF (BlueROV2 Heavy)", ptype=i8, readonly=True),
        ParamDef("ARMING_CHECK", 0, 2**20, "", "pre-arm checks: 0 none, bit 0 all, 2 baro, 16 INS/AHRS", ptype=i32),
        ParamDef("FS_PILOT_INPUT", 0, 2, "", "pilot input failsafe: 0 off, 1 warn, 2 disarm", ptype=i8),
        ParamDef("FS_PILOT_TIMEOUT", 0.1, 3.0, "s", "pilot input failsafe timeout"),
        ParamDef("FS_LEAK_ENABLE", 0, 2, "", "leak failsafe: 0 off, 1 warn, 2 surface (no leak sensor here)",
                 ptype=i8, readonly=True),
        ParamDef("JS_GAIN_DEFAULT", 0.1, 1.0, "", "pilot gain at boot"),
        ParamDef("JS_GAIN_MAX", 0.2, 1.0, "", "largest pilot gain"),
        ParamDef("JS_GAIN_MIN", 0.1, 0.8, "", "smallest pilot gain"),
        ParamDef("JS_GAIN_STEPS", 1, 10, "", "pilot gain steps from min to max", ptype=i8),
        ParamDef("JS_THR_GAIN", 0.5, 4.0, "", "extra gain on the throttle stick"),
        ParamDef("JS_LIGHTS_STEP", 0, 400, "us", "lights brighter/dimmer button step", ptype=i16),
        ParamDef("JS_CAM_TILT_STEP", 0, 400, "us", "camera tilt button step", ptype=i16),
        ParamDef("BATT_MONITOR", 0, 30, "", "battery monitor: 4 analog voltage and current (Power Sense Module)",
                 ptype=i8, readonly=True),
        ParamDef("BATT_CAPACITY", 0, 2**20, "mAh", "battery capacity: remaining % is counted against it", ptype=i32),
        ParamDef("BATT_VOLT_MULT", 0.0, 100.0, "", "PSM voltage divider", readonly=True),
        ParamDef("BATT_AMP_PERVLT", 0.0, 200.0, "A/V", "PSM current sense", readonly=True),
        ParamDef("BATT_ARM_VOLT", 0.0, 100.0, "V", "minimum voltage to arm (0: no check)", readonly=True),
        ParamDef("BATT_LOW_VOLT", 0.0, 100.0, "V", "low battery voltage (failsafe not simulated)", readonly=True),
        ParamDef("BATT_CRT_VOLT", 0.0, 100.0, "V", "critical battery voltage", readonly=True),
        ParamDef("BATT_FS_LOW_ACT", 0, 5, "", "low battery action", ptype=i8, readonly=True),
        ParamDef("BATT_FS_CRT_ACT", 0, 5, "", "critical battery action", ptype=i8, readonly=True),
        ParamDef("MOT_PWM_MIN", 0, 2000, "us", "thruster PWM at full reverse", ptype=i16, readonly=True),
        ParamDef("MOT_PWM_MAX", 0, 2000, "us", "thruster PWM at full forward", ptype=i16, readonly=True),
        ParamDef("MOT_PWM_TYPE", 0, 8, "", "output type: 0 normal PWM", ptype=i8, readonly=True),
    ]
    for name in ("PITCH", "ROLL", "THROTTLE", "YAW", "FORWARD", "LATERAL"):
        defs.append(ParamDef(f"RCMAP_{name}", 1, 16, "", f"RC input channel of {name.lower()}", ptype=i8,
                             readonly=True))
    for b in range(16):
        defs.append(ParamDef(f"BTN{b}_FUNCTION", 0, 127, "", f"joystick button {b} function", ptype=i8))
        defs.append(ParamDef(f"BTN{b}_SFUNCTION", 0, 127, "", f"joystick button {b} function with shift", ptype=i8))
    for ch in range(1, 9):     # a thruster output: its motor, or RC input 9-16 passed through (companion servo mode)
        defs.append(ParamDef(f"SERVO{ch}_FUNCTION", -1, 200, "", f"output {ch} function (32+{ch}: motor {ch}, "
                             "59-66: RCIN9-16 pass-through)", ptype=i16,
                             allowed=frozenset({32.0 + ch, *(float(f) for f in RCIN_PASSTHROUGH)})))
    for ch in range(9, 17):
        defs.append(ParamDef(f"SERVO{ch}_FUNCTION", -1, 200, "", f"output {ch} function (33-40 motors, "
                             "51-66 RC input pass-through, 7 camera tilt)", ptype=i16))
    defs.append(ParamDef("RC_OVERRIDE_TIME", -1.0, 120.0, "s", "RC_CHANNELS_OVERRIDE expires after this "
                         "(-1 never); pass-through outputs go neutral"))
    return defs


RCIN_PASSTHROUGH = range(59, 67)
"""SERVOn_FUNCTION values RCIN9…RCIN16: the output passes RC input 9–16 through."""

ARDUSUB_DEFS: tuple[ParamDef, ...] = tuple(_ardusub_defs())
"""ArduSub's names, types and meanings; the values (ArduSub's defaults) are in configs/firmware/params.yaml."""


PARAM_DEFS: tuple[ParamDef, ...] = tuple([
    # Cascaded PD (paper Eq. 12): outer position loop → velocity demand, inner velocity loop → τ/τ_max
    *_axes("WK_PD_KP", 0.0, 20.0, ("1/s", "1/s", "1/s"), "position P gain: velocity demand per unit error"),
    *_axes("WK_PD_KD", 0.0, 20.0, ("", "", ""), "position D gain: velocity demand per unit error rate"),
    *_axes("WK_VEL_KP", 0.0, 20.0, ("s/m", "s/m", "s/rad"),
           "velocity P gain: normalised effort per unit velocity error"),
    *_axes("WK_VEL_MAX", 0.01, 5.0, ("m/s", "m/s", "rad/s"), "velocity demand limit"),
    *_axes("WK_TAU_MAX", 0.1, 1000.0, ("N", "N", "N m"), "maximum control effort τ_max"),
    ParamDef("WK_G_COMP", 0, 1, "", "compensate the nominal restoring forces g(eta) (1) or not (0)", ptype="INT8"),
    ParamDef("WK_FF_ENABLE", 0, 1, "", "feed-forward wave compensation on (1) or off (0)", ptype="INT8"),
    ParamDef("WK_DOB_ENABLE", 0, 1, "", "disturbance-observer feedback of the EKF's disturbance estimate on (1) "
             "or off (0); needs WK_EKF_MODE 1", ptype="INT8"),
    ParamDef("WK_DOB_GAIN", 0.0, 2.0, "", "scale on the estimated disturbance fed back (DOB)"),
    *_axes("WK_DOB_LIM", 0.0, 2.0, ("", "", ""), "DOB authority as a fraction of tau_max"),
    ParamDef("WK_FF_GAIN", 0.0, 2.0, "", "scale on the predicted wave load used as feed-forward"),
    ParamDef("WK_FF_MODE", 0, 2, "", "feed-forward law: 0 paper (nu = 0), 1 robust, "
             "2 wave part at the estimated velocity", integer=True),
    ParamDef("WK_LOAD_MODEL", 0, 1, "", "nominal wave-load model of the FF, estimator and preview: 1 complete "
             "(Froude-Krylov + added mass, with the pitch coupling), 0 the paper's (added mass only); read at boot",
             ptype="INT8"),
    ParamDef("WK_FF_VEL_TC", 0.0, 5.0, "s", "robust FF: low-pass time constant of the estimated velocity it uses"),
    *_axes("WK_FF_LIM", 0.0, 2.0, ("", "", ""), "robust FF: feed-forward authority as a fraction of tau_max"),
    ParamDef("WK_FF_MON_THR", 0.0, 2.0, "", "robust FF: predicted-observed load disagreement (fraction of "
             "tau_max) at which FF starts to fade; 0 disables the monitor"),
    ParamDef("WK_FF_MON_TC", 0.05, 20.0, "s", "robust FF: monitor filter time constant and weight recovery time"),
    ParamDef("WK_FF_TRUST_TC", 0.0, 600.0, "s", "robust FF: averaging time of the monitor's smallest weight; "
             "below 0.5 the forecast is set aside (FF, preview, EKF wave model) until above 0.75; 0 never"),
    ParamDef("WK_FF_SKILL_TC", 0.0, 600.0, "s", "robust FF: window of the forecast's skill (correlation of the "
             "predicted with the observed load per axis); 0 not measured"),
    ParamDef("WK_FF_SKILL_VTC", 0.2, 20.0, "s", "robust FF: time constant of the IMU/fix velocity filter the "
             "skill uses (read at boot)"),
    ParamDef("WK_FF_SKILL_LO", -1.0, 1.0, "", "robust FF: skill at or below which an axis' feed-forward is off"),
    ParamDef("WK_FF_SKILL_HI", -1.0, 1.0, "", "robust FF: skill from which an axis' feed-forward is whole "
             "(<= WK_FF_SKILL_LO: no skill fade)"),
    ParamDef("WK_FF_W_MIN", 0.0, 1.0, "", "robust FF: smallest weight the monitor fades an axis to"),
    ParamDef("WK_PRV_ENABLE", 0, 1, "", "robust FF: saturation preview (pre-position the target ahead of a "
             "forecast load beyond tau_max) on (1) or off (0)", ptype="INT8"),
    ParamDef("WK_PRV_HORIZON", 0.5, 20.0, "s", "saturation preview: how far ahead it simulates"),
    ParamDef("WK_PRV_DT", 0.02, 0.5, "s", "saturation preview: its simulation step"),
    ParamDef("WK_PRV_PERIOD", 0.05, 5.0, "s", "saturation preview: how often it re-plans"),
    ParamDef("WK_PRV_THR", 0.0, 5.0, "m", "saturation preview: predicted excursion above which it shifts the target"),
    ParamDef("WK_PRV_RATE", 0.01, 2.0, "m/s", "saturation preview: slew rate of the target shift"),
    ParamDef("WK_PRV_MAX_X", 0.0, 2.0, "m", "saturation preview: largest surge target shift"),
    ParamDef("WK_PRV_MAX_Z", 0.0, 2.0, "m", "saturation preview: largest heave target shift"),
    # The law (firmware_py/controllers) and the preview MPC (docs/mpc.md)
    ParamDef("WK_CTRL_LAW", 0, 1, "", "station-keeping law: 0 cascaded PD (with FF, DOB, preview as enabled), "
             "1 preview MPC (falls back to C-PD+FF); read at boot", ptype="INT8"),
    ParamDef("WK_MPC_N", 2, 80, "", "MPC: horizon steps (the control period first, then WK_MPC_DT each)",
             ptype="INT8"),
    ParamDef("WK_MPC_DT", 0.05, 1.0, "s", "MPC: horizon step after the first"),
    *_axes("WK_MPC_Q", 0.0, 1e6, ("1/(m^2 s)", "1/(m^2 s)", "1/(rad^2 s)"), "MPC: weight on the position error"),
    *_axes("WK_MPC_QV", 0.0, 1e6, ("s/m^2", "s/m^2", "s/rad^2"), "MPC: weight on the velocity"),
    ParamDef("WK_MPC_QT", 0.0, 100.0, "s", "MPC: extra weight on the horizon's last state, as seconds of "
             "its state weights"),
    *_axes("WK_MPC_R", 0.0, 1e4, ("1/s", "1/s", "1/s"), "MPC: weight on the normalised effort off trim"),
    *_axes("WK_MPC_RD", 0.0, 1e4, ("s", "s", "s"), "MPC: weight on the normalised effort's change"),
    ParamDef("WK_MPC_ITER", 1, 10000, "", "MPC: solver iteration budget per tick (beyond it: the FF fallback)",
             ptype="INT16"),
    ParamDef("WK_MPC_BUDGET", 0.01, 1000.0, "ms", "MPC: compute budget per tick on the wall clock (beyond it: "
             "the FF fallback); lockstep SITL counts iterations only"),
    ParamDef("WK_MPC_DIST", 0, 1, "", "MPC: the estimator's disturbance wrench in the prediction (1) or not (0)",
             ptype="INT8"),
    # Motors and mixer
    ParamDef("WK_THR_MAX", 1.0, 60.0, "N", "per-thruster thrust limit used by the allocation"),
    ParamDef("WK_THR_MIN", 0.0, 5.0, "N", "thrust commands smaller than this are sent as neutral PWM"),
    ParamDef("WK_MOT_TC", 0.001, 2.0, "s", "nominal first-order motor time constant"),
    ParamDef("WK_MOT_COMP", 0, 1, "", "motor-lag compensation (paper Eq. 13) on (1) or off (0)", ptype="INT8"),
    ParamDef("WK_MOT_LIM", 0, 1, "", "limit of the compensated command: 0 each thruster clipped at the PWM range, "
             "1 its wrench re-allocated pitch first within WK_THR_MAX (the rc companion)", ptype="INT8"),
    # Estimator
    ParamDef("WK_EKF_Q_POS", 0.0, 10.0, "m/s^0.5", "process noise density on x and z"),
    ParamDef("WK_EKF_Q_ANG", 0.0, 10.0, "rad/s^0.5", "process noise density on pitch"),
    ParamDef("WK_EKF_Q_VEL", 0.0, 100.0, "m/s^1.5", "process noise density on u and w (unmodelled forces)"),
    ParamDef("WK_EKF_Q_RATE", 0.0, 100.0, "rad/s^1.5", "process noise density on q"),
    ParamDef("WK_EKF_R_POS", 1e-4, 10.0, "m", "position fix noise (1 sigma) the estimator assumes"),
    ParamDef("WK_EKF_R_DEPTH", 1e-4, 10.0, "m", "depth noise (1 sigma) the estimator assumes"),
    ParamDef("WK_EKF_R_PITCH", 1e-5, 1.0, "rad", "pitch noise (1 sigma) the estimator assumes"),
    ParamDef("WK_EKF_R_GYRO", 1e-5, 1.0, "rad/s", "pitch-rate noise (1 sigma) the estimator assumes"),
    ParamDef("WK_EKF_MODE", 0, 1, "", "estimator: 0 the paper's (position, depth, pitch, gyro; 6 states), "
             "1 aided (+ DVL, accelerometer, 3 disturbance states); read at boot", ptype="INT8"),
    ParamDef("WK_EKF_Q_POS_A", 0.0, 10.0, "m/s^0.5", "aided mode: process noise density on x and z"),
    ParamDef("WK_EKF_Q_ANG_A", 0.0, 10.0, "rad/s^0.5", "aided mode: process noise density on pitch"),
    ParamDef("WK_EKF_Q_VEL_A", 0.0, 100.0, "m/s^1.5", "aided mode: process noise density on u and w"),
    ParamDef("WK_EKF_Q_RATE_A", 0.0, 100.0, "rad/s^1.5", "aided mode: process noise density on q"),
    *_axes("WK_EKF_QD", 0.0, 10000.0, ("N/s^0.5", "N/s^0.5", "N m/s^0.5"),
           "aided mode: process noise density of the disturbance force (random walk)"),
    ParamDef("WK_EKF_QD_ADPT", 0, 1, "", "aided mode: adapt the disturbance's process noise to the mean square "
             "change of its estimate (1) or keep WK_EKF_QD_* (0)", ptype="INT8"),
    ParamDef("WK_EKF_QD_TC", 0.1, 1000.0, "s", "aided mode: averaging time of the adaptive disturbance noise"),
    ParamDef("WK_EKF_QD_K", 0.1, 10.0, "", "aided mode: scale on the adapted disturbance noise density"),
    ParamDef("WK_EKF_D_TC", 0.0, 1000.0, "s", "aided mode: disturbance correlation time; 0 = random walk"),
    ParamDef("WK_EKF_ACC_TH", 0, 1, "", "aided mode: the accelerometer corrects pitch (1) or is a Schmidt "
             "'consider' measurement for it (0: zero gain on theta, its uncertainty kept in S)", ptype="INT8"),
    ParamDef("WK_EKF_QI_ADPT", 0, 1, "", "aided mode: scale the disturbance's process noise per axis by the "
             "normalised innovations of the accelerometer (X, Z) and gyro (M) (1) or not (0)", ptype="INT8"),
    ParamDef("WK_EKF_QI_TC", 0.05, 100.0, "s", "aided mode: time constant of the innovation-driven noise scale"),
    ParamDef("WK_EKF_QI_TC_TH", 0.05, 1000.0, "s", "aided mode: time constant of the pitch noise's "
             "innovation-driven scale (the pitch sensor's innovations)"),
    ParamDef("WK_EKF_QI_BLK", 1, 1000, "", "aided mode: ticks per block of pitch innovations for the pitch "
             "noise's scale", ptype="INT16"),
    ParamDef("WK_EKF_QI_INIT", 1.0, 1e6, "", "aided mode: the disturbance noise's innovation-driven scale at "
             "initialisation (the start-up transient)"),
    ParamDef("WK_EKF_QI_MAX", 1.0, 1e6, "", "aided mode: largest innovation-driven scale on the disturbance's "
             "noise variance"),
    ParamDef("WK_EKF_R_DVL", 1e-5, 1.0, "m/s", "DVL velocity noise (1 sigma) the estimator assumes"),
    ParamDef("WK_EKF_R_ACC", 1e-4, 10.0, "m/s^2", "accelerometer noise (1 sigma) the estimator assumes"),
    ParamDef("WK_BARO_WAVE", 0, 1, "", "subtract the forecast's linear dynamic pressure head at the estimated "
             "pose from the depth reading (1), as a pressure sensor at sea needs, or not (0)", ptype="INT8"),
    ParamDef("WK_EKF_GATE", 1.0, 100.0, "sigma", "innovation gate: reject a measurement beyond this many sigma"),
    ParamDef("WK_EKF_RST_T", 0.05, 60.0, "s", "reset a channel to its measurement after this long all-rejected"),
    ParamDef("WK_EKF_CONV", 1e-4, 10.0, "m", "converged when position 1-sigma is below this"),
    # Pilot, modes and failsafes (ArduSub names where ArduSub has the parameter)
    ParamDef("WK_PILOT_TMO", 0.1, 10.0, "s", "pilot input older than this is treated as neutral"),
    ParamDef("WK_OUT_DELAY", 0, 5, "", "ticks between a command and its effect (companion: 1); the EKF and "
             "the controller account for the commands in flight", ptype="INT8"),
    ParamDef("WK_CLIMB_RATE", 0.01, 2.0, "m/s", "ALT_HOLD depth-target rate at full throttle stick"),
    ParamDef("WK_SURF_RATE", 0.01, 2.0, "m/s", "SURFACE mode ascent rate of the depth target"),
    ParamDef("FS_GCS_ENABLE", 0, 4, "", "GCS failsafe: 0 off, 1 warn, 2 disarm, 3 depth hold, 4 surface", ptype="INT8"),
    ParamDef("FS_GCS_TIMEOUT", 0.1, 120.0, "s", "GCS heartbeat timeout"),
    ParamDef("FS_EKF_ACTION", 0, 4, "", "EKF failsafe: 0 off, 1 warn, 2 disarm, 3 depth hold, 4 surface", ptype="INT8"),
    ParamDef("FS_EKF_THRESH", 0.05, 100.0, "m",
             "EKF failsafe when the position 1-sigma exceeds this (or the state is not finite)"),
    ParamDef("SYSID_THISMAV", 1, 255, "", "this vehicle's MAVLink system id", ptype="INT16"),
    ParamDef("SYSID_MYGCS", 1, 255, "", "the ground station's MAVLink system id", ptype="INT16"),
    ParamDef("WK_ORIGIN_LAT", -90.0, 90.0, "deg", "latitude of the local NED origin (GLOBAL_POSITION_INT)"),
    ParamDef("WK_ORIGIN_LON", -180.0, 180.0, "deg", "longitude of the local NED origin"),
    # Telemetry stream rates (ArduPilot's SR0_*), Hz
    ParamDef("SR0_RAW_SENS", 0, 50, "Hz", "SCALED_PRESSURE, SCALED_PRESSURE2", ptype="INT16"),
    ParamDef("SR0_EXT_STAT", 0, 50, "Hz", "SYS_STATUS, MISSION_CURRENT, GPS_RAW_INT, NAMED_VALUE_FLOAT", ptype="INT16"),
    ParamDef("SR0_RC_CHAN", 0, 50, "Hz", "SERVO_OUTPUT_RAW, RC_CHANNELS", ptype="INT16"),
    ParamDef("SR0_POSITION", 0, 50, "Hz", "GLOBAL_POSITION_INT, LOCAL_POSITION_NED", ptype="INT16"),
    ParamDef("SR0_EXTRA1", 0, 50, "Hz", "ATTITUDE", ptype="INT16"),
    ParamDef("SR0_EXTRA2", 0, 50, "Hz", "VFR_HUD", ptype="INT16"),
    ParamDef("SR0_EXTRA3", 0, 50, "Hz", "SYSTEM_TIME", ptype="INT16"),
    ParamDef("SR0_PARAMS", 0, 50, "Hz", "PARAM_VALUE stream (ArduPilot paces the list by bandwidth)", ptype="INT16",
             readonly=True),
    *ARDUSUB_DEFS,
    # Simulated sensors (SITL HAL)
    ParamDef("SIM_JSON_TMO", 0.05, 5.0, "s", "JSON SITL HAL: plant silent this long → sensors unhealthy"),
    ParamDef("SIM_POS_RND", 0.0, 10.0, "m", "position fix noise (1 sigma), e.g. an acoustic positioning system"),
    ParamDef("SIM_POS_RATE", 0.1, 100.0, "Hz", "position fix rate"),
    ParamDef("SIM_DEPTH_RND", 0.0, 1.0, "m", "pressure-depth noise (1 sigma), Bar30-like"),
    ParamDef("SIM_DEPTH_RATE", 0.1, 100.0, "Hz", "pressure-depth (Bar30) output rate"),
    ParamDef("SIM_DVL_RATE", 0.0, 30.0, "Hz", "DVL ping rate with bottom lock; 0: no DVL fitted"),
    ParamDef("SIM_DVL_RND", 0.0, 1.0, "m/s", "DVL body-velocity noise per ping (1 sigma)"),
    ParamDef("SIM_DVL_ALT_MAX", 0.1, 1000.0, "m", "DVL bottom-lock altitude limit (A50: 50 m)"),
    ParamDef("SIM_DVL_ALT_MIN", 0.0, 10.0, "m", "DVL minimum altitude (A50: 0.05 m)"),
    ParamDef("SIM_DVL_DROP", 0.0, 1.0, "", "DVL: probability a ping within range is lost"),
    ParamDef("SIM_WATER_DEPTH", 0.1, 11000.0, "m", "water depth at the site (the harness sets the sea's)"),
    ParamDef("SIM_ACC_RND", 0.0, 10.0, "m/s^2", "accelerometer specific-force noise (1 sigma) per sample"),
    ParamDef("SIM_PITCH_RND", 0.0, 0.5, "rad", "AHRS pitch noise (1 sigma)"),
    ParamDef("SIM_GYRO_RND", 0.0, 0.5, "rad/s", "gyro pitch-rate noise (1 sigma)"),
    ParamDef("SIM_BATT_CAP_AH", 0.1, 100.0, "Ah", "simulated battery: the 4S pack's real capacity"),
    ParamDef("SIM_BATT_SOC", 0.0, 100.0, "%", "simulated battery: state of charge at boot"),
    ParamDef("SIM_BATT_HOTEL", 0.0, 500.0, "W", "simulated battery: electronics, camera and lights load"),
    ParamDef("SIM_BATT_RES", 0.0, 1.0, "Ohm", "simulated battery: the pack's internal resistance"),
])


def parse_assignment(text: str) -> tuple[str, float]:
    """``NAME=NUMBER`` (a command line's parameter override) as (name, value); ValueError otherwise."""
    name, sep, value = text.partition("=")
    try:
        if not sep or not name.strip():
            raise ValueError
        return name.strip(), float(value)
    except ValueError:
        raise ValueError(f"expected NAME=NUMBER, got {text!r}") from None


T = TypeVar("T")


class ParameterTable:
    """Named values with ranges; ArduPilot parameter semantics.

    ``table["WK_PD_KP_X"]`` reads, :meth:`set` writes with a range check.
    ``version`` increases on every accepted change; :meth:`derived` keeps a
    value computed from the table until it moves (the control task's modules
    read their gains, limits and noise that way rather than every tick).
    """

    def __init__(self, defs: Iterable[ParamDef], values: dict[str, float]):
        self._defs = {d.name: d for d in defs}
        self._order = list(self._defs)
        missing = [n for n in self._order if n not in values]
        if missing:
            raise KeyError(f"no value for parameter(s): {', '.join(missing)}")
        self._values: dict[str, float] = {}
        for name in self._order:
            why = self._defs[name].check(values[name])
            if why:
                raise ValueError(f"parameter {name}: {why}")
            self._values[name] = float(values[name])
        self.version = 0
        self._derived: dict[Callable[[ParameterTable], Any], tuple[int, Any]] = {}

    def __getitem__(self, name: str) -> float:
        return self._values[name]

    def get(self, name: str, default: float) -> float:
        """The parameter's value, or ``default`` if the table has no such parameter."""
        return self._values.get(name, default)

    def __contains__(self, name: str) -> bool:
        return name in self._values

    def __len__(self) -> int:
        return len(self._order)

    def names(self) -> list[str]:
        return list(self._order)

    def definition(self, name: str) -> ParamDef:
        return self._defs[name]

    def index_of(self, name: str) -> int:
        return self._order.index(name)

    def by_index(self, index: int) -> tuple[str, float]:
        name = self._order[index]
        return name, self._values[name]

    def set(self, name: str, value: float) -> str | None:
        """Set a parameter; returns None when accepted, else why not (the old value stays)."""
        d = self._defs.get(name)
        if d is None:
            return f"unknown parameter {name!r}"
        why = d.check(value)
        if why:
            return why
        if self._values[name] != float(value):
            self._values[name] = float(value)
            self.version += 1
        return None

    def derived(self, build: Callable[[ParameterTable], T]) -> T:
        """``build(self)``, computed again only after a parameter has changed (:attr:`version`).

        Kept per ``build`` (a function, or a bound method: one entry per owner), so each consumer reads
        the table once per change however often it asks.
        """
        entry = self._derived.get(build)
        if entry is None or entry[0] != self.version:
            entry = self._derived[build] = (self.version, build(self))
        return entry[1]

    def axes(self, prefix: str) -> tuple[float, float, float]:
        """The (surge, heave, pitch) triple of a per-DoF parameter family, e.g. ``axes("WK_PD_KP")``."""
        return (self._values[f"{prefix}_X"], self._values[f"{prefix}_Z"], self._values[f"{prefix}_P"])

    def as_dict(self) -> dict[str, float]:
        return dict(self._values)

    def copy(self) -> ParameterTable:
        return ParameterTable(self._defs.values(), self._values)


def load_params(name_or_path: str | Path = "params", overrides: dict[str, float] | None = None) -> ParameterTable:
    """Defaults from ``configs/firmware/params.yaml`` (or a path), validated against :data:`PARAM_DEFS`.

    Every parameter needs a value there; an unknown name, a missing one or a
    value out of range is a :class:`~bridge.configfile.ConfigError` naming the file and key.
    """
    from bridge.configfile import Field

    path = resolve_config(name_or_path, "firmware")
    schema = {d.name: Field("int" if d.integer else "float", lo=d.lo, hi=d.hi, doc=d.doc) for d in PARAM_DEFS}
    values = load_config(path, schema)
    table = ParameterTable(PARAM_DEFS, values)
    for name, value in (overrides or {}).items():
        why = table.set(name, value)
        if why:
            raise ConfigError(path, name, f"override {why}")
    return table


