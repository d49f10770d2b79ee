"""The parameter table: the one place a tunable lives (ArduPilot's AP_Param, in miniature).

Every gain, noise level and limit of the firmware is a named parameter of at
most 16 characters (MAVLink's PARAM_VALUE limit). :data:`PARAM_DEFS` defines
each one — name, range, units, meaning — and ``configs/firmware/params.yaml``
gives every default. Values are read and set at runtime through
:class:`ParameterTable`; a set outside the range, or NaN, is refused and the old
value kept, as ArduPilot's parameter protocol expects.

Simulated-sensor parameters carry ArduPilot's ``SIM_`` prefix: they describe
the SITL HAL's sensors, not the estimator's beliefs (``WK_EKF_R_*``). ArduSub's
parameters are :mod:`firmware_py.params.ardusub`'s: the ones that act here in
:data:`PARAM_DEFS` (defaults in ``params.yaml``), and the rest of ArduSub 4.7's
table appended read-only with ArduSub's defaults (:func:`load_params`).
"""
from __future__ import annotations

from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any, TypeVar

from bridge.configfile import ConfigError, load_config, resolve_config

from .ardusub import ARDUSUB_DEFS, RCIN_PASSTHROUGH, reference_defs
from .definitions import INT_TYPE_RANGES, ParamDef

__all__ = ["INT_TYPE_RANGES", "PARAM_DEFS", "RCIN_PASSTHROUGH", "ParamDef", "ParameterTable", "load_params",
           "parse_assignment"]


def _axes(prefix: str, lo: float, hi: float, units: tuple[str, str, str], doc: str) -> list[ParamDef]:
    """One parameter per DoF: _X surge, _Z heave, _P pitch."""
    return [ParamDef(f"{prefix}_{ax}", lo, hi, u, f"{doc} ({name})")
            for ax, name, u in zip("XZP", ("surge", "heave", "pitch"), units, strict=False)]


LATERAL_AXES = ("Y", "R", "H")
"""The suffixes of a lateral-directional parameter family: sway, roll, heading (yaw)."""


def _lateral_axes(prefix: str, lo: float, hi: float, units: tuple[str, str, str], doc: str) -> list[ParamDef]:
    """One parameter per lateral-directional DoF: _Y sway, _R roll, _H heading."""
    return [ParamDef(f"{prefix}_{ax}", lo, hi, u, f"{doc} ({name})")
            for ax, name, u in zip(LATERAL_AXES, ("sway", "roll", "heading"), units, strict=True)]


PARAM_DEFS: tuple[ParamDef, ...] = tuple([
    # Cascaded PD (paper Eq. 12): outer position loop → velocity demand, inner velocity loop → τ/τ_max
    *_axes("WK_PD_KP", 0.0, 20.0, ("1/s", "1/s", "1/s"), "position P gain: velocity demand per unit error"),
    *_axes("WK_PD_KD", 0.0, 20.0, ("", "", ""), "position D gain: velocity demand per unit error rate"),
    *_axes("WK_VEL_KP", 0.0, 20.0, ("s/m", "s/m", "s/rad"),
           "velocity P gain: normalised effort per unit velocity error"),
    *_axes("WK_VEL_MAX", 0.01, 5.0, ("m/s", "m/s", "rad/s"), "velocity demand limit"),
    *_axes("WK_TAU_MAX", 0.1, 1000.0, ("N", "N", "N m"), "maximum control effort τ_max"),
    # The lateral-directional plane (six-DoF world): the same cascade on sway, roll and heading
    ParamDef("WK_LAT_HOLD", 0, 1, "", "hold sway, roll and heading too (1) when the sensors give them (a six-DoF "
             "vehicle), or leave them to the vehicle (0)", ptype="INT8"),
    *_lateral_axes("WK_PD_KP", 0.0, 20.0, ("1/s", "1/s", "1/s"), "position P gain: velocity demand per unit error"),
    *_lateral_axes("WK_PD_KD", 0.0, 20.0, ("", "", ""), "position D gain: velocity demand per unit error rate"),
    *_lateral_axes("WK_VEL_KP", 0.0, 20.0, ("s/m", "s/rad", "s/rad"),
                   "velocity P gain: normalised effort per unit velocity error"),
    *_lateral_axes("WK_VEL_MAX", 0.01, 5.0, ("m/s", "rad/s", "rad/s"), "velocity demand limit"),
    *_lateral_axes("WK_TAU_MAX", 0.1, 1000.0, ("N", "N m", "N m"), "maximum control effort τ_max"),
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
    # The law (firmware_py/control) and the preview MPC (docs/mpc.md)
    ParamDef("WK_CTRL_LAW", 0, 1, "", "station-keeping law: 0 cascaded PD (with FF, DOB, preview as enabled), "
             "1 preview MPC (falls back to C-PD+FF); read at boot", ptype="INT8"),
    ParamDef("WK_MPC_N", 2, 80, "", "MPC: horizon steps (the control period first, then WK_MPC_DT each)",
             ptype="INT8"),
    ParamDef("WK_MPC_DT", 0.02, 0.15, "s", "MPC: horizon step after the first (the RK4 step of its prediction)"),
    ParamDef("WK_MPC_BLK", 1, 40, "", "MPC: steps each optimised demand is held over, after the first step "
             "(move blocking)", ptype="INT8"),
    *_axes("WK_MPC_Q", 0.0, 1e6, ("1/(m^2 s)", "1/(m^2 s)", "1/(rad^2 s)"), "MPC: weight on the position error"),
    *_axes("WK_MPC_QV", 0.0, 1e6, ("s/m^2", "s/m^2", "s/rad^2"), "MPC: weight on the velocity"),
    ParamDef("WK_MPC_QP_K", 1.0, 1000.0, "", "MPC: the pitch weight's factor over the horizon's first "
             "WK_MPC_QP_T s (attitude first in the near term, as the mixer's pitch priority)"),
    ParamDef("WK_MPC_QP_T", 0.0, 10.0, "s", "MPC: how far ahead the pitch weight carries WK_MPC_QP_K"),
    ParamDef("WK_MPC_QT", 0.0, 100.0, "s", "MPC: extra weight on the horizon's last state, as seconds of "
             "its state weights"),
    *_axes("WK_MPC_R", 0.0, 1e4, ("1/s", "1/s", "1/s"), "MPC: weight on the normalised effort off trim"),
    *_axes("WK_MPC_RD", 0.0, 1e4, ("s", "s", "s"), "MPC: weight on the normalised effort's change"),
    ParamDef("WK_MPC_ITER", 1, 10000, "", "MPC: solver iteration budget per tick (beyond it: the FF fallback)",
             ptype="INT16"),
    ParamDef("WK_MPC_BUDGET", 0.01, 1000.0, "ms", "MPC: compute budget per tick on the wall clock (beyond it: "
             "the FF fallback); lockstep SITL counts iterations only"),
    ParamDef("WK_MPC_VEL_TC", 0.0, 5.0, "s", "MPC: low-pass time constant on the estimated surge and heave "
             "velocity its horizon starts from; 0 none"),
    ParamDef("WK_MPC_SQP", 1, 10, "", "MPC: QPs per tick, each linearised about the last one's plan (1: one "
             "real-time iteration; more: the nonlinear MPC solved further)", ptype="INT8"),
    ParamDef("WK_MPC_EMAX", 0.01, 10.0, "m", "MPC: largest surge and heave error its plan is asked to correct "
             "(the target is moved nearer; as C-PD's WK_VEL_MAX bounds its pace)"),
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
    ParamDef("WK_EKF_R_GYRO", 1e-5, 1.0, "rad/s", "pitch-rate noise (1 sigma) the estimator assumes (and roll and "
             "yaw rates')"),
    ParamDef("WK_EKF_R_YAW", 1e-5, 1.0, "rad", "heading noise (1 sigma) the estimator assumes"),
    ParamDef("WK_EKF_QL_VEL", 0.0, 100.0, "m/s^1.5", "lateral plane: process noise density on v (the sway force "
             "the model does not predict)"),
    ParamDef("WK_EKF_QL_RATE", 0.0, 100.0, "rad/s^1.5", "lateral plane: process noise density on p and r"),
    ParamDef("WK_EKF_QL_VEL_S", 0.0, 100.0, "m/s^1.5", "lateral plane without a forecast in its model: process "
             "noise density on v (the sea's whole sway force unpredicted)"),
    ParamDef("WK_EKF_QL_RATE_S", 0.0, 100.0, "rad/s^1.5", "lateral plane without a forecast in its model: process "
             "noise density on p and r"),
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
    ParamDef("WK_EKF_SD_BAD", 0.05, 100.0, "m", "position 1-sigma that the EKF's test ratios (EKF_STATUS_REPORT's "
             "variances) count as 1; FS_EKF_THRESH is a fraction of it"),
    ParamDef("WK_ORIGIN_LAT", -90.0, 90.0, "deg", "latitude of the local NED origin (GLOBAL_POSITION_INT)"),
    ParamDef("WK_ORIGIN_LON", -180.0, 180.0, "deg", "longitude of the local NED origin"),
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
    ParamDef("SIM_PITCH_RND", 0.0, 0.5, "rad", "AHRS pitch (and roll) noise (1 sigma)"),
    ParamDef("SIM_GYRO_RND", 0.0, 0.5, "rad/s", "gyro rate noise (1 sigma), each axis"),
    ParamDef("SIM_YAW_RND", 0.0, 0.5, "rad", "AHRS heading noise (1 sigma)"),
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
        self._index = {name: i for i, name in enumerate(self._order)}
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
        return self._index[name]

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

    def lateral_axes(self, prefix: str) -> tuple[float, float, float]:
        """The (sway, roll, heading) triple of a lateral-directional family, e.g. ``lateral_axes("WK_PD_KP")``."""
        v = self._values
        return (v[f"{prefix}_Y"], v[f"{prefix}_R"], v[f"{prefix}_H"])

    def as_dict(self) -> dict[str, float]:
        return dict(self._values)

    def copy(self) -> ParameterTable:
        return ParameterTable(self._defs.values(), self._values)


def load_params(name_or_path: str | Path = "params", overrides: dict[str, float] | None = None) -> ParameterTable:
    """Defaults from ``configs/firmware/params.yaml`` (or a path), validated against :data:`PARAM_DEFS`, then
    the rest of ArduSub's table (``configs/firmware/ardusub_params.csv``), read-only with ArduSub's defaults.

    Every parameter of :data:`PARAM_DEFS` needs a value there; an unknown name, a missing one or a
    value out of range is a :class:`~bridge.configfile.ConfigError` naming the file and key.
    """
    from bridge.configfile import Field

    path = resolve_config(name_or_path, "firmware")
    schema = {d.name: Field("int" if d.integer else "float", lo=d.lo, hi=d.hi, doc=d.doc) for d in PARAM_DEFS}
    values = load_config(path, schema)
    extra, extra_values = reference_defs({d.name for d in PARAM_DEFS})
    table = ParameterTable((*PARAM_DEFS, *extra), {**values, **extra_values})
    for name, value in (overrides or {}).items():
        why = table.set(name, value)
        if why:
            raise ConfigError(path, name, f"override {why}")
    return table
