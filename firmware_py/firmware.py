"""The Wavekeep firmware: the 20 Hz station-keeping control task and what it is made of.

    read sensors (HAL) → EKF predict/update → C-PD (+ FF from the forecast) →
    allocation, motor-lag compensation, PWM (mixer) → write PWM (HAL)

In a six-DoF world (the sensors give sway, roll and heading) the estimate and the hold
cover the lateral-directional plane too (:mod:`~firmware_py.lateral_plane`) and the
mixer allocates all six DoF.

ArduPilot's split: the scheduler runs the task on an absolute time grid; the
estimator, controller and mixer are separate modules; every tunable is in the
parameter table. The feed-forward is the negated wave load predicted by the
same model the plant uses (:func:`~bridge.models.vehicle.hydrodynamic_load`)
with nominal parameters and the forecast's flow at the estimated pose and
velocity; the same predicted flow drives the estimator's prediction.
"""
from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from dataclasses import replace

import numpy as np

from bridge.models.body6 import Flow6
from bridge.models.rigid_body6 import RigidBody6Params
from bridge.models.thrusters import T200Curve, ThrusterLayout
from bridge.models.vehicle import BodyFlow, VehicleParams, body_flow, rk4_step, strip_nodes
from bridge.models.vehicle6_config import rigid_body6_from_vehicle

from .control.cascaded_pd import ControlOutput
from .control.depth_correction import DepthCorrection
from .control.feedforward import FadeNotices, FeedForwardOutput, WaveFeedForward, skill_weighted_flow
from .control.laws import ControlInput, ControllerEnv, build_controller
from .estimation.estimator import PlanarEKF
from .failsafe import EKFFailsafe, FailsafeAction, GCSFailsafe
from .forecast.handoff import ForecastHandoff
from .hal.base import HAL
from .hal.scheduler import Scheduler, Task
from .hal.sensors import SensorFrame
from .lateral_plane import LateralPlane, LateralRecord
from .logger.tick_columns import TICK_COLUMNS
from .modes import FLIGHT_MODES, MAV_RESULT, MAV_SEVERITY, MAV_STATE, FlightMode, Mode, PilotInput, mode_refusal
from .motors.aux_outputs import AuxOutputs
from .motors.mixer import MixerOutput, MotorMixer
from .params.table import ParameterTable
from .telemetry_snapshot import TelemetrySnapshot
from .tick_record import Prediction, TickRecord, tick_row

__all__ = ["LOAD_MODELS", "TICK_COLUMNS", "Firmware", "Prediction", "TickRecord", "tick_row"]

LOAD_MODELS = {0: "paper", 1: "complete"}
"""``WK_LOAD_MODEL`` values: the nominal model's fluid-inertia load (one of
:data:`~bridge.models.vehicle.WAVE_LOAD_MODELS`)."""


class Firmware:
    """The vehicle's control software, bound to a HAL.

    Boots disarmed in MANUAL, as ArduSub does. The GCS link (or a test, or
    the in-process runner) drives it through :meth:`request_mode`,
    :meth:`request_arm`, :meth:`set_target`, :meth:`pilot_input`,
    :meth:`motor_test` and :meth:`gcs_heartbeat`; it reports through
    :attr:`last`, :meth:`system_status` and the :attr:`events` queue
    (STATUSTEXT). Those calls may come from another thread: each stores plain
    values the next tick picks up.
    """

    def __init__(self, hal: HAL, params: ParameterTable, vehicle: VehicleParams, layout: ThrusterLayout,
                 curve: T200Curve, setpoint, loop_rate_hz: float = 20.0, strips: int = 3,
                 forecast: ForecastHandoff | None = None, on_tick: Callable[[TickRecord], None] | None = None,
                 body6: RigidBody6Params | None = None, lateral_target=(0.0, 0.0)):
        self.hal = hal
        self.params = params
        vehicle = vehicle.with_wave_load(LOAD_MODELS[int(params["WK_LOAD_MODEL"])])   # read at boot
        self.vehicle = vehicle
        self.h = 1.0 / loop_rate_hz
        self.strips = strip_nodes(vehicle.length, strips)
        self.setpoint = np.asarray(setpoint, dtype=float)   # the current target [x, z, θ]
        self.forecast = forecast if forecast is not None else ForecastHandoff()
        self.ekf = PlanarEKF(vehicle, params, self.h)
        self.mixer = MotorMixer(layout, curve, params, self.h)
        self.feedforward = WaveFeedForward(vehicle, params, self.h)
        # the station-keeping law (WK_CTRL_LAW, read at boot): a strategy behind one interface
        self.controller = build_controller(ControllerEnv(params, vehicle, layout, self.strips, self.h, self.say,
                                                         not getattr(hal.clock, "simulated", True)))
        self.depth_correction = DepthCorrection(params)
        # sway, roll and heading, once the sensors read them (a six-DoF world)
        self.lateral = LateralPlane(params, self.h, body6, vehicle.wave_load_model, strips, lateral_target)
        self.ff_notices = FadeNotices(self.say)
        self.aux = AuxOutputs(params, layout.n)     # RC pass-through and motor test
        self.on_tick = on_tick
        self.last: TickRecord | None = None
        self.mode = Mode.MANUAL
        self.armed = False
        self.pilot = PilotInput()
        self.events: deque[tuple[int, str]] = deque(maxlen=64)
        self.notes: deque[tuple[int, str]] = deque(maxlen=64)   # for logs only: what ArduSub does not say
        self.gcs_failsafe = GCSFailsafe(params, self.say, self.note)
        self.ekf_failsafe = EKFFailsafe(params, self.say)
        self.failsafe_pilot = False      # the GCS link's pilot-input failsafe has tripped (the heartbeat says so)
        self.output_faults = 0           # non-finite commands replaced by neutral
        self.sensors_healthy = False
        self.depth_offset = 0.0          # m, subtracted from the pressure depth (baro calibration at the surface)
        self._pending: Prediction | None = None
        self._in_flight: deque[Prediction] = deque()   # commands sent, not yet acting (WK_OUT_DELAY)
        self._stage_offsets = np.array([0.0, 0.5 * self.h, self.h])
        self._now = 0.0
        self._depth_t = -math.inf        # vehicle time of the last depth reading
        self._ff_was_active = False
        self.loop_rate_hz = loop_rate_hz
        self.tasks = [Task("control", loop_rate_hz, self.control_task)]
        self.scheduler = Scheduler(hal.clock, loop_rate_hz, self.tasks)

    @classmethod
    def from_configs(cls, hal: HAL, params: ParameterTable, vehicle_cfg: dict, mission_cfg: dict,
                     **kw) -> Firmware:
        """The firmware for a vehicle config (``configs/vehicle``) and a mission config (``configs/mission``)."""
        thrusters = vehicle_cfg["thrusters"]
        sp = mission_cfg["setpoint"]
        kw.setdefault("body6", rigid_body6_from_vehicle(vehicle_cfg) if "lateral" in vehicle_cfg else None)
        kw.setdefault("lateral_target", (sp.get("y", 0.0), sp.get("heading", 0.0)))
        return cls(hal, params, VehicleParams.from_config(vehicle_cfg), ThrusterLayout.from_config(thrusters),
                   T200Curve.from_config(thrusters), [sp["x"], sp["depth"], sp["pitch"]],
                   mission_cfg["control_rate"], mission_cfg["plant"]["strips"], **kw)

    @property
    def flight_mode(self) -> FlightMode:
        """The current mode's behaviour (:data:`~firmware_py.modes.FLIGHT_MODES`)."""
        return FLIGHT_MODES[self.mode]

    @property
    def failsafe_gcs(self) -> bool:
        return self.gcs_failsafe.active

    @property
    def failsafe_ekf(self) -> bool:
        return self.ekf_failsafe.active

    def rebuild_scheduler(self, t0_ns: int | None = None) -> None:
        """A fresh scheduler on the HAL's (possibly new) clock, its grid starting at ``t0_ns``."""
        self.scheduler = Scheduler(self.hal.clock, self.loop_rate_hz, self.tasks)
        if t0_ns is not None:
            self.scheduler.start(t0_ns)

    def refresh_prediction(self) -> None:
        """Re-take the forecast's flow for the pending estimator prediction from the newest forecast.

        Between ticks (a start held until arming) a forecast may arrive after the last
        tick looked; this makes the next prediction use it, so a networked start and an
        in-process start predict the same way.
        """
        if self._pending is not None:
            t = self._pending.t
            flow, _ = self.predicted_flow(t)
            flow6 = self.lateral.flow(self.forecast.current(t) if flow is not None else None, self.ekf.x, t)
            self._pending = replace(self._pending, flow=flow, flow6=flow6)

    def add_task(self, task: Task) -> None:
        """Add a task (GCS link, SITL world...) after the control task; only before the loop starts."""
        if self.scheduler.t0_ns is not None:
            raise RuntimeError("tasks can only be added before the scheduler starts")
        self.tasks.append(task)
        self.scheduler = Scheduler(self.hal.clock, self.loop_rate_hz, self.tasks)

    # ------------------------------------------------------------------ commands (any thread)
    def say(self, severity: int, text: str) -> None:
        """Queue a STATUSTEXT."""
        self.events.append((int(severity), text[:50]))

    def note(self, severity: int, text: str) -> None:
        """Queue an event for the run's log only (a mode change, a failsafe's trip: ArduSub says neither)."""
        self.notes.append((int(severity), text))

    def request_mode(self, mode: int) -> MAV_RESULT:
        """Switch flight mode as ArduSub does: a refused mode is said in its words and the mode kept."""
        why = mode_refusal(mode, self.mode, self.ekf.converged(), self.ekf.initialised and self.sensors_healthy)
        if why:
            self.say(MAV_SEVERITY.WARNING, why)
            return MAV_RESULT.FAILED
        if int(mode) != self.mode:
            self._enter(Mode(int(mode)))
        return MAV_RESULT.ACCEPTED

    def _enter(self, m: Mode) -> None:
        pose = self.ekf.x if self.ekf.initialised else self.setpoint
        self.setpoint = FLIGHT_MODES[m].enter(self.mode, pose, self.setpoint)
        if FLIGHT_MODES[m].holds_where_entered:
            self.lateral.hold_where_entered()
        self.mode = m
        self.controller.reset()
        self.lateral.reset()
        self.note(MAV_SEVERITY.INFO, f"Mode {m.name}")
        if FLIGHT_MODES[m].entry_text:          # ArduSub announces no mode change, but a few modes speak
            self.say(MAV_SEVERITY.INFO, FLIGHT_MODES[m].entry_text)

    def prearm_failure(self, ekf_converged: bool | None = None) -> str | None:
        """Why the vehicle may not arm, or None: the checks ARMING_CHECK selects, in ArduPilot's bits (1 all,
        2 baro: the depth sensor, 16 INS: IMU and estimate, 256 battery: its monitor has read; 64 RC and
        128 board voltage always pass here: the pilot is on MAVLink, the board is simulated).

        ``ekf_converged``: the estimator's :meth:`~firmware_py.estimation.estimator.PlanarEKF.converged` when the caller
        has just asked it (the telemetry snapshot, every link tick); None asks it here."""
        checks = int(self.params.get("ARMING_CHECK", 448))
        every = checks & 1
        if (every or checks & 256) and self.last is None and not self.ekf.initialised:
            return "Battery 1 unhealthy"        # the simulated monitor reads with the first tick
        if (every or checks & 2) and not self.sensors_healthy:
            return "Barometer not healthy"
        if every or checks & 16:
            converged = self.ekf.converged() if ekf_converged is None else ekf_converged
            if not (converged and self.sensors_healthy):
                return "AHRS not healthy"
        return None

    def request_arm(self, arm: bool, force: bool = False) -> tuple[MAV_RESULT, str]:
        """Arm (after the pre-arm checks, unless forced) or disarm, said in ArduSub's words."""
        if not arm:
            if self.armed:
                self.armed = False
                self.aux.test = None
                self.say(MAV_SEVERITY.INFO, "Disarming motors")
            return MAV_RESULT.ACCEPTED, ""
        if self.armed:
            return MAV_RESULT.ACCEPTED, ""
        why = None if force else self.prearm_failure()
        if why:
            self.say(MAV_SEVERITY.CRITICAL, f"Arm: {why}")
            return MAV_RESULT.FAILED, why
        self.armed = True
        self.controller.reset()
        self.lateral.reset()
        self.say(MAV_SEVERITY.INFO, "Arming motors")
        return MAV_RESULT.ACCEPTED, ""

    def set_target(self, x: float | None, depth: float | None, pitch: float | None = None) -> MAV_RESULT:
        """A GUIDED target (NED x, depth in m, pitch in rad; None keeps that coordinate)."""
        if self.mode != Mode.GUIDED:
            return MAV_RESULT.DENIED
        sp = self.setpoint.copy()
        for i, v in enumerate((x, depth, pitch)):
            if v is not None:
                if not math.isfinite(v):
                    return MAV_RESULT.DENIED
                sp[i] = v
        self.setpoint = sp
        return MAV_RESULT.ACCEPTED

    def pilot_input(self, surge: float, up: float, pitch: float) -> None:
        """Normalised stick demands in [−1, 1] (clipped); timestamped with the vehicle clock."""
        clip = lambda v: 0.0 if not math.isfinite(v) else min(1.0, max(-1.0, v))  # noqa: E731
        self.pilot = PilotInput(clip(surge), clip(up), clip(pitch), self._now)

    def rc_override_aux(self, channel: int, pwm: int | None) -> None:
        """RC input ``channel`` (9–16) overridden to ``pwm`` µs, or released (None); stamped with the vehicle clock."""
        self.aux.rc_override(channel, pwm, self._now)

    def motor_test(self, motor: int, pwm: int, timeout_s: float) -> MAV_RESULT:
        """Spin one motor (1-based) at a PWM for up to ``timeout_s`` (≤ 0.5 s: the GCS re-sends it); armed only."""
        return self.aux.start_test(motor, pwm, timeout_s, self._now, self.armed)

    def gcs_heartbeat(self) -> None:
        """The GCS (sysid MAV_GCS_SYSID) was heard."""
        self.gcs_failsafe.heard(self._now)

    def telemetry_snapshot(self) -> TelemetrySnapshot:
        """What a ground station is told, taken now (once per GCS tick, from the scheduler thread)."""
        return TelemetrySnapshot.from_firmware(self)

    def fault_counts(self) -> dict[str, int]:
        """Faults survived: forecasts that evaluated to non-finite loads, non-finite commands sent neutral,
        ticks the law flew its fallback, and estimates that stopped being finite (the estimator started again)."""
        return {"feedforward": self.feedforward.faults, "output": self.output_faults,
                "law_fallbacks": self.controller.fallbacks,
                "estimator": self.ekf.restarts + self.lateral.restarts}

    def system_status(self) -> MAV_STATE:
        if self.last is None and not self.ekf.initialised:
            return MAV_STATE.BOOT
        if self.failsafe_gcs or self.failsafe_ekf or self.failsafe_pilot:      # any failsafe, as ArduSub
            return MAV_STATE.CRITICAL
        return MAV_STATE.ACTIVE if self.armed else MAV_STATE.STANDBY

    # ------------------------------------------------------------------ the control task
    def predicted_flow(self, t: float) -> tuple[BodyFlow | None, int]:
        """The forecast's flow at the strips, at the estimated pose, at t, t + h/2, t + h — or None."""
        if not self.params["WK_FF_ENABLE"] or not self.ekf.initialised:
            return None, -1
        active = self.forecast.current(t)
        if active is None:
            return None, -1
        return body_flow(active.components, self.ekf.x[:3], t + self._stage_offsets, self.strips), active.forecast.seq

    def _failsafe_action(self, action: FailsafeAction) -> None:
        """Carry out a failsafe's action (WARN: already said)."""
        if action == FailsafeAction.DISARM:
            self.request_arm(False)
        elif action == FailsafeAction.DEPTH_HOLD:
            self._enter(Mode.ALT_HOLD)
        elif action == FailsafeAction.SURFACE:
            self._enter(Mode.SURFACE)

    def _applied_thrust(self) -> np.ndarray | None:
        """The mean thruster wrench the mixer expected over the last period (Simpson over its 3 stages), or None."""
        if self._pending is None:
            return None
        st = np.asarray(self._pending.tau_stages, dtype=float)
        return (st[0] + 4.0 * st[1] + st[2]) / 6.0

    def _pilot_wrench(self, t: float) -> np.ndarray:
        """Pilot demand as a wrench [X, Z, M] (N, N, N m): forward, up (−Z in FRD), pitch up."""
        p = self.pilot
        if t - p.t > self.params["WK_PILOT_TMO"]:
            return np.zeros(3)
        return np.array(self.params.axes("WK_TAU_MAX")) * np.array([p.surge, -p.up, p.pitch])

    def control_task(self, slot_ns: int) -> None:
        """One 20 Hz tick: sensors → estimate → feed-forward → mode target → C-PD → mixer → PWM."""
        t = slot_ns * 1e-9
        self._now = t
        frame = self.hal.read_sensors()
        if self.depth_offset:
            frame = replace(frame, depth=frame.depth - self.depth_offset)
        frame = self.depth_correction.apply(frame, self.forecast, self.ekf, t)   # WK_BARO_WAVE
        self._estimate(frame, t)
        if not self.ekf.initialised or not self.sensors_healthy:
            # No estimate, or the vehicle's sensors (in SITL: the plant) went silent: neutral
            self._output(self.mixer.neutral(), None, t)
            return
        delay = int(self.params["WK_OUT_DELAY"])
        flow, seq = self.predicted_flow(t)
        ahead_flow = flow if not delay else self.predicted_flow(t + delay * self.h)[0]
        ff_active, ff_flow, ff = self._feedforward(ahead_flow, frame)
        trusted = not self.feedforward.distrusted
        if ff_flow is None or not trusted:   # a forecast that cannot be evaluated, or that the monitor has
            flow = None                      # set aside, is no forecast for the estimator either
        elif flow is not None:
            flow = skill_weighted_flow(flow, self.feedforward.skill_weight)
        self.flight_mode.update_target(self.setpoint, self.pilot, t, self.params, self.h)
        d_hat = self.ekf.disturbance
        control = self.controller.update(ControlInput(
            t, t + delay * self.h, self.h, self.ekf.x, self._ahead(t), self.setpoint, ff,
            self.forecast.current(t) if ff_active else None, trusted, d_hat, self.mixer.wrench()))
        # the lateral plane's feed-forward and prediction use the forecast when the vertical plane's do, and as
        # far as its skill in heave goes (lateral_plane.weighted_flow6)
        active = self.forecast.current(t) if flow is not None else None
        lateral = self.lateral.control(self.ekf.x, float(self.setpoint[0]), active if ff_active else None,
                                       t + delay * self.h, float(self.feedforward.skill_weight[1]))
        mix = self._mix(control, t, lateral)
        self._output(mix, flow, t, self.lateral.flow(active, self.ekf.x, t, float(self.feedforward.skill_weight[1])))
        self.last = TickRecord(t, frame, self.ekf.x.copy(), self.ekf.sigma(), self.setpoint.copy(), control, mix,
                               ff.tau_e_hat, ff_active, seq, ff.weight, d_hat, self.ekf.nis_total,
                               control.target_offset, ff.skill, control.solve, lateral)
        if self.on_tick is not None:
            self.on_tick(self.last)

    def _estimate(self, frame: SensorFrame, t: float) -> None:
        """Sensor health, the EKF's predict (last tick's hand-off) and update, and the failsafes."""
        if math.isfinite(frame.depth):
            self._depth_t = t
        # depth may come slower than the loop (SIM_DEPTH_RATE): healthy while it is under 0.5 s old
        healthy = bool(frame.healthy and math.isfinite(frame.pitch) and math.isfinite(frame.pitch_rate)
                       and t - self._depth_t <= 0.5)
        if healthy != self.sensors_healthy and self.ekf.initialised:
            self.say(MAV_SEVERITY.INFO if healthy else MAV_SEVERITY.CRITICAL,
                     "Sensors back" if healthy else "Sensors lost: thrusters neutral")
        self.sensors_healthy = healthy
        if self._pending is not None:
            # the lateral plane's prediction holds the vertical plane at its estimate at the period's start
            self.lateral.predict(frame, self.ekf.x, self._pending.tau6_stages, self._pending.flow6)
            self.ekf.predict(self._pending.tau_stages, self._pending.flow)
        self.ekf.update(frame)
        self.lateral.update(frame)
        self._failsafe_action(self.ekf_failsafe.check(self.ekf, self.armed, t))
        self._failsafe_action(self.gcs_failsafe.check(t, self.armed))

    def _feedforward(self, flow: BodyFlow | None, frame: SensorFrame) -> tuple[bool, BodyFlow | None,
                                                                                FeedForwardOutput]:
        """The FF wrench: on when a forecast is in use, the vehicle is armed and the mode holds every axis
        (``frame``, this tick's sensors, for the forecast's skill)."""
        ff_active = flow is not None and self.armed and all(self.flight_mode.holds)
        if ff_active != self._ff_was_active:
            self.say(MAV_SEVERITY.INFO, "Wave feed-forward on" if ff_active else "Wave feed-forward off")
            self._ff_was_active = ff_active
        ff = self.feedforward.update(flow if ff_active else None, self.ekf.x, self._applied_thrust(), frame)
        self.ff_notices.update(self.feedforward.distrusted, ff.weight)
        if ff_active and not ff.active:
            # A forecast that cannot be evaluated here (e.g. at a diverged pose) is no forecast
            ff_active, flow = False, None
        return ff_active, flow, ff

    def _mix(self, control: ControlOutput, t: float, lateral: LateralRecord | None = None) -> MixerOutput:
        """The thruster outputs: neutral disarmed (but RCIN pass-through), a motor test, or the held axes'
        control + the pilot's (with the lateral plane: all six DoF, its axes held as the mode holds surge and
        pitch: sway with surge, roll and heading with pitch; zero otherwise)."""
        if not self.armed:
            return self._disarmed_output(t)
        if (test := self.aux.test_pwm(t)) is not None:
            return self.mixer.output(test)
        holds = self.flight_mode.holds
        tau = control.tau.copy() if all(holds) else np.where(holds, control.tau, self._pilot_wrench(t))
        if lateral is not None:
            held = np.array([holds[0], holds[2], holds[2]])
            tl = np.where(held, lateral.tau, 0.0)
            tau = np.array([tau[0], tl[0], tau[1], tl[1], tau[2], tl[2]])
        passthrough = self.aux.passthrough(t)
        if passthrough:
            # Outputs set to RCIN9-16 take the companion's PWM; the motor model follows what is sent
            f_hat = self.mixer.f_hat
            mix = self.mixer.mix(np.where(np.isfinite(tau), tau, 0.0))
            self.mixer.f_hat = f_hat
            return self._passed_through(mix.pwm, passthrough)
        if np.isfinite(tau).all():
            return self.mixer.mix(tau)
        # never send a non-finite command to the thrusters
        self.output_faults += 1
        self.controller.reset()
        return self.mixer.neutral()

    def _disarmed_output(self, t: float) -> MixerOutput:
        """Disarmed: the motors neutral; an output set to RCIN9-16 still passes its input through until the
        override is released or expires (RC_OVERRIDE_TIME), as ArduSub's pass-through ignores arming."""
        passthrough = self.aux.passthrough(t)
        if not passthrough:
            return self.mixer.neutral()
        return self._passed_through(self.mixer.neutral().pwm, passthrough)

    def _passed_through(self, pwm: np.ndarray, passthrough: dict[int, int]) -> MixerOutput:
        """These PWM values (µs) with the pass-through outputs' inputs in place of theirs, sent."""
        pwm = pwm.copy()
        for i, v in passthrough.items():
            pwm[i] = v
        return self.mixer.output(pwm)

    def _ahead(self, t: float) -> np.ndarray:
        """The state the command will meet: the estimate propagated over the commands still in flight
        (``WK_OUT_DELAY`` ticks: a companion's commands act one tick after its telemetry), else the estimate."""
        x = self.ekf.x
        for i, p in enumerate(self._in_flight):
            flow = self.predicted_flow(t + i * self.h)[0] if p.flow is not None else None
            x = rk4_step(self.vehicle, x, self.h, p.tau_stages + self.ekf.disturbance, flow)
        return x

    def _output(self, mix: MixerOutput, flow: BodyFlow | None, t: float, flow6: Flow6 | None = None) -> None:
        """Write the PWM, and hand the next tick's prediction what this one commanded (or, with
        ``WK_OUT_DELAY`` d, what tick k − d commanded: the command acting over the coming period)."""
        self.hal.write_pwm(mix.pwm)
        delay = int(self.params["WK_OUT_DELAY"])
        tau6 = mix.tau6_stages if self.lateral.estimating else None
        if not delay:
            self._in_flight.clear()
            self._pending = Prediction(mix.tau_stages, flow, t, tau6, flow6)
            return
        self._in_flight.append(Prediction(mix.tau_stages, flow, t, tau6, flow6))
        acting = self._in_flight.popleft() if len(self._in_flight) > delay else None
        stages = ((np.zeros((3, 3)), None if tau6 is None else np.zeros((3, 6))) if acting is None
                  else (acting.tau_stages, acting.tau6_stages))
        self._pending = Prediction(stages[0], flow, t, stages[1], flow6)
