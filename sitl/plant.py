"""The simulated BlueROV2 Heavy: Fossen's rigid body, eight T200 thrusters, wave loads, RK4.

State: NED pose η = [x, y, z, φ, θ, ψ], body velocities ν = [u, v, w, p, q, r] and the eight
thrusters' actual thrusts f (N). The thrusters follow their PWM command through the T200 curve with a
first-order lag (time constant t_m); the body moves under Fossen's equations with τ = B f (the layout's
6 × 8 wrench matrix), its damping and added-mass Coriolis forces taken on the velocity relative to the
water and the fluid's inertia force — Froude–Krylov and added mass, (ρ∇ + M_A)·a, or the paper's M_A·a
alone when the sea config's ``wave_load`` is ``paper``.

The world's degrees of freedom are the sea config's ``dof`` (:data:`~sitl.sea.DOF_CHOICES`; ``auto``, the
default, is the planar world for a sea in the vehicle's plane and the six-DoF world otherwise):

* ``six``: all six DoF (:mod:`bridge.models.body6`: :mod:`bridge.models.motion6` and
  :mod:`bridge.models.strip_load6` on 3 × 3 strips over the length and the beam, compiled), in the
  sea from its direction;
* ``planar``: the paper's surge, heave and pitch (:mod:`bridge.models.vehicle`), y, φ, ψ, v, p, r held
  at zero and the sea's x–z share felt.

:attr:`PlantState.eta` and :attr:`PlantState.nu` are the planar part [x, z, θ], [u, w, q] in both, which
is what the planar firmware reads; ``eta6`` and ``nu6`` the whole state.

Each control period is integrated with ``substeps`` classical RK4 steps; the
motor lag is solved exactly over the period (the PWM is held constant). The
flow at the body's strips is sampled at the RK4 stage times (t, t + h/2, t + h)
for the pose at the start of the step: within h ≤ 50 ms the vehicle moves
millimetres against wavelengths of metres, and one batched evaluation serves
all four stages.
"""
from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from bridge.models.body6 import Body6
from bridge.models.motion6 import PLANAR_DOFS, specific_force6, to_lateral
from bridge.models.thrusters import T200Curve, ThrusterLayout, motor_lag_factors, power_per_dof
from bridge.models.vehicle import (
    VehicleParams,
    body_flow,
    hydrodynamic_load_terms,
    rk4_step,
    state_rates_at,
    strip_nodes,
    submerged_fraction,
    wave_load,
)
from bridge.models.vehicle6_config import rigid_body6_from_vehicle
from bridge.schemas import apply_true_vehicle, load_mission_config, load_true_vehicle, load_vehicle_config

from .sea import WORLD_DOFS, Sea

__all__ = ["MAX_BODY_RATE", "MAX_BODY_SPEED", "START_POSES", "Plant", "PlantDiverged", "PlantState"]

MAX_BODY_SPEED = 20.0   # m/s: |u|, |v|, |w| beyond this is no ROV in any sea the schema admits (they stay below 8)
MAX_BODY_RATE = 20.0    # rad/s: |p|, |q|, |r| likewise (about 1150 °/s)
STRIPS_ACROSS = 3
"""Gauss–Legendre strips across the beam in the six-DoF world (the mission's ``plant.strips`` along the length):
3 × 3 give every DoF's load within 1e-3 of its rms against 12 × 12 (docs/models.md)."""
_P = np.array(PLANAR_DOFS)


class PlantDiverged(RuntimeError):
    """The integration left the physical range (non-finite, or ν beyond :data:`MAX_BODY_SPEED` /
    :data:`MAX_BODY_RATE`): the step is too large for the sea, or the sea outside the model."""


START_POSES = ("station", "surface")
"""Where the vehicle starts: at the mission's station, or at rest at the still surface (depth 0), held there
until its thrusters first run: where a foreign autopilot boots and zeroes its depth (docs/json_sitl.md)."""


def _six(v) -> np.ndarray:
    """A pose or velocity as six DoF: a planar [x, z, θ] (or [u, w, q]) placed at (0, 2, 4)."""
    v = np.asarray(v, dtype=float)
    if v.shape == (6,):
        return v.copy()
    if v.shape != (3,):
        raise ValueError(f"expected a planar (3) or six-DoF (6) vector, got shape {v.shape}")
    out = np.zeros(6)
    out[_P] = v
    return out


@dataclass
class PlantState:
    """Truth state of the simulated vehicle: the whole six-DoF motion and its planar part."""

    t: float = 0.0                                                     # s
    eta: np.ndarray = field(default_factory=lambda: np.zeros(3))       # [x (m), z depth (m), θ (rad)]
    nu: np.ndarray = field(default_factory=lambda: np.zeros(3))        # [u, w (m/s), q (rad/s)] body
    thrust: np.ndarray = field(default_factory=lambda: np.zeros(8))    # actual thrust per thruster (N)
    eta6: np.ndarray = field(default_factory=lambda: np.zeros(6))      # [x, y, z (m, NED), φ, θ, ψ (rad)]
    nu6: np.ndarray = field(default_factory=lambda: np.zeros(6))       # [u, v, w (m/s), p, q, r (rad/s)] body

    @classmethod
    def of(cls, t: float, eta6: np.ndarray, nu6: np.ndarray, thrust: np.ndarray) -> PlantState:
        """The state of a six-DoF pose and velocity, with its planar part."""
        return cls(float(t), eta6[_P], nu6[_P], thrust, eta6, nu6)

    def copy(self) -> PlantState:
        return PlantState(self.t, self.eta.copy(), self.nu.copy(), self.thrust.copy(), self.eta6.copy(),
                          self.nu6.copy())


class Plant:
    """The vehicle in the sea, advanced one control period at a time by :meth:`step`.

    ``body6`` is the six-DoF body (the sea's ``dof`` "six"), or None for the planar world; ``vehicle`` is the
    planar model either way (its parameters are the six-DoF body's vertical-plane limit)."""

    def __init__(self, vehicle: VehicleParams, sea: Sea, layout: ThrusterLayout, curve: T200Curve,
                 motor_time_constant: float, substeps: int = 1, strips: int = 6, body6: Body6 | None = None):
        if substeps < 1 or strips < 1:
            raise ValueError("substeps and strips must be >= 1")
        self.vehicle = vehicle.with_wave_load(sea.wave_load)   # the world's load model is the sea config's
        self.sea = sea
        self.layout = layout
        self.curve = curve
        self.t_m = float(motor_time_constant)
        self.substeps = int(substeps)
        self.strips = strip_nodes(vehicle.length, strips)
        self.body6 = body6
        self.B6 = layout.wrench_matrix()     # 6×8: thrusts → [X, Y, Z, K, M, N]
        self.B = layout.allocation_matrix()  # 3×8: thrusts → [X, Z, M]
        self.state = PlantState()
        self.tau_E6 = np.zeros(6)       # six-DoF world: wave load at the end of the last step
        self.tau6 = np.zeros(6)         # six-DoF world: thruster load at the end of the last step
        self.nu_dot6 = np.zeros(6)      # six-DoF world: body acceleration at the end of the last step
        self.tau_E = np.zeros(3)        # either world: the planar parts [X, Z, M], [u̇, ẇ, q̇]
        self.tau = np.zeros(3)
        self.nu_dot = np.zeros(3)
        self.current_x = sea.current_x  # steady current's in-plane component (m/s, NED north): the planar world's
        self.current_ned = sea.current_ned   # and as an NED vector (m/s): the six-DoF world's
        self.pressure_depth: float | None = None   # what a pressure sensor reads (m), with the sea's option
        self.sea_start = 0.0            # s of plant time at which the sea (waves, current) begins at its t = 0
        self.moored = False             # held at rest where it is until a thruster first gives thrust
        self._lag_key: float | None = None          # the dt the motor-lag factors below were computed for
        self._lags: list[np.ndarray] = []          # per substep: e^{−s/t_m} at its stage times (3, 1)
        self._lag_end = np.ones(1)                  # e^{−dt/t_m} (1, 1)

    @property
    def dof(self) -> str:
        """The world's degrees of freedom: "six" or "planar" (:data:`~sitl.sea.WORLD_DOFS`)."""
        return "planar" if self.body6 is None else "six"

    @classmethod
    def from_configs(cls, sea: Sea, vehicle: str = "bluerov2_heavy", mission: str = "station_keeping",
                     true_vehicle: str | None = None, start: str = "station", sea_start: float = 0.0,
                     dof: str | None = None) -> Plant:
        """The plant of the vehicle and mission configs; ``true_vehicle`` names a plant-only override
        (``configs/vehicle/true/``) that scales the vehicle's coefficients: the firmware keeps the nominal ones.
        ``dof`` overrides the sea config's (``six`` for an autopilot that flies all six DoF).

        For a foreign autopilot (docs/json_sitl.md): ``start`` "surface" (:data:`START_POSES`) and the sea
        still until ``sea_start`` s."""
        if start not in START_POSES:
            raise ValueError(f"start must be one of {', '.join(START_POSES)}, got {start!r}")
        if not (math.isfinite(sea_start) and sea_start >= 0.0):
            raise ValueError(f"sea_start must be a non-negative number of seconds, got {sea_start}")
        dof = sea.dof if dof is None else dof
        if dof not in WORLD_DOFS:
            raise ValueError(f"dof must be one of {', '.join(WORLD_DOFS)}, got {dof!r}")
        vcfg = load_vehicle_config(vehicle)
        if true_vehicle:
            vcfg = apply_true_vehicle(vcfg, load_true_vehicle(true_vehicle))
        mcfg = load_mission_config(mission)
        layout = ThrusterLayout.from_config(vcfg["thrusters"])
        params = VehicleParams.from_config(vcfg)
        body6 = None
        if dof == "six":
            rb = replace(rigid_body6_from_vehicle(vcfg), wave_load_model=sea.wave_load, g=params.g)
            body6 = Body6(rb, mcfg["plant"]["strips"], STRIPS_ACROSS)
        plant = cls(params, sea, layout, T200Curve.from_config(vcfg["thrusters"]), vcfg["thrusters"]["time_constant"],
                    mcfg["plant"]["substeps"], mcfg["plant"]["strips"], body6)
        plant.sea_start = float(sea_start)
        sp = mcfg["setpoint"]
        if start == "surface":
            plant.reset(eta=np.array([sp["x"], 0.0, sp["pitch"]]))
            plant.moored = True
        else:
            plant.reset(eta=np.array([sp["x"], sp["depth"], sp["pitch"]]))
        return plant

    def reset(self, eta=None, nu=None, t: float = 0.0) -> None:
        """Place the vehicle at pose η with velocity ν at time t, thrusters idle: η, ν planar ([x, z, θ],
        [u, w, q]; the other DoF zero) or six-DoF ([x, y, z, φ, θ, ψ], [u, v, w, p, q, r])."""
        eta6 = np.zeros(6) if eta is None else _six(eta)
        nu6 = np.zeros(6) if nu is None else _six(nu)
        if self.body6 is None and (eta6[[1, 3, 5]].any() or nu6[[1, 3, 5]].any()):
            raise ValueError("the planar world has no sway, roll or yaw: give a planar pose and velocity")
        self.state = PlantState.of(float(t), eta6, nu6, np.zeros(8))
        self.tau_E6 = self.wave_load(eta6, nu6, self.state.t) if self.body6 is not None else \
            _six(self.wave_load(self.state.eta, self.state.nu, self.state.t))
        self.tau_E = self.tau_E6[_P]
        self.tau6, self.tau, self.nu_dot6, self.nu_dot = np.zeros(6), np.zeros(3), np.zeros(6), np.zeros(3)
        self._update_pressure()

    def _calm(self, t: float) -> bool:
        """Is the sea still at plant time t (before :attr:`sea_start`)?"""
        return t < self.sea_start

    def _update_pressure(self) -> None:
        """The depth a pressure sensor at the body origin reads, p/(ρ g) = z + Σ A K_p cos θ (m), when the
        sea's ``depth_sensor.dynamic_pressure`` is on; None (the sensor reads the true depth) otherwise."""
        if self.sea.dynamic_pressure:
            s = self.state
            x, y, z = s.eta6[:3].tolist()
            head = 0.0 if self._calm(s.t) else self.sea.pressure_head(x, z, s.t - self.sea_start, y)
            self.pressure_depth = float(z + head)

    def wave_load(self, eta, nu, t) -> np.ndarray:
        """τ_E (relative-velocity form, the sea's load model) on the body at pose η moving with ν, at plant time t
        (s, or an array of T times: the result is then (T, n)); zero while the sea is still (before
        :attr:`sea_start`). Planar η, ν give [X, Z, M] from the planar model; six-DoF ones (the six-DoF
        world) [X, Y, Z, K, M, N] from the six-DoF body."""
        six = np.shape(eta) == (6,)
        if six and self.body6 is None:
            raise ValueError("a six-DoF pose needs the six-DoF world (the sea config's dof: six)")
        n = 6 if six else 3
        if np.ndim(t) == 0 and self._calm(float(t)):
            return np.zeros(n)
        tt = np.atleast_1d(np.asarray(t, dtype=float))
        if six:
            assert self.body6 is not None
            eta6, nu6 = np.asarray(eta, dtype=float), np.asarray(nu, dtype=float)
            flow = self.body6.flow(self.sea.components, eta6, tt - self.sea_start, self.current_ned)
            still = self.body6.load(nu6, None)
            tau = np.array([self.body6.load(nu6, flow, i) - still for i in range(tt.size)])
        else:
            tau = wave_load(self.vehicle, self.sea.components, eta, nu, tt - self.sea_start, self.strips,
                            self.current_x)
        tau = np.where((tt < self.sea_start)[:, None], 0.0, np.reshape(tau, (tt.size, n)))
        return tau if np.ndim(t) else tau[0]

    def step(self, pwm, dt: float) -> PlantState:
        """Hold the eight PWM commands (µs) for dt seconds and advance the world.

        PWM is clipped to the ESC range and mapped through the T200 curve to the
        thrust each motor settles to, f_cmd. Under a held command the first-order
        lag has the exact solution f(s) = f_cmd + (f₀ − f_cmd) e^{−s/t_m}, so the
        thruster load at every RK4 stage is known in closed form and only
        [η, ν] are integrated. Returns the new state (also in ``self.state``).
        """
        pwm = np.asarray(pwm, dtype=float)
        if pwm.shape != (8,):
            raise ValueError(f"expected 8 PWM values, got shape {pwm.shape}")
        if not np.isfinite(pwm).all():
            raise ValueError("PWM values must be finite")
        if not dt > 0:
            raise ValueError(f"dt must be positive, got {dt}")
        f_cmd = self.curve.thrust(pwm)
        s = self.state
        if self.moored:
            if not f_cmd.any():     # held where it is (at the surface) until a thruster runs
                self.state = PlantState(s.t + dt, s.eta, s.nu, s.thrust, s.eta6, s.nu6)
                return self.state
            self.moored = False
        # A thruster out of the water pushes nothing: near the surface the thrust fades as the buoyancy does
        z = float(s.eta6[2])
        wet = 1.0 if z >= 0.5 * self.vehicle.height else submerged_fraction(self.vehicle, z)
        (self._step_planar if self.body6 is None else self._step_six)(f_cmd, dt, wet)
        self._update_pressure()
        return self.state

    def _integrate(self, x: np.ndarray, f_cmd: np.ndarray, dt: float, wet: float, B: np.ndarray,
                   flow_at: Callable, rk4: Callable) -> tuple[np.ndarray, float, np.ndarray, Any]:
        """Integrate x = [η; ν] over dt under the held command: ``substeps`` RK4 steps (``rk4(x, h, τ (3, n), flow)``)
        with the thrusters' load B f at the stage times and the flow ``flow_at(x, sea times)`` for the pose at each
        step's start. Returns x, the time reached, the thrusts at its end and the last step's flow."""
        s = self.state
        h = dt / self.substeps
        stage = np.array([0.0, 0.5 * h, h])
        t = s.t
        lags, lag_end = self._motor_lags(dt, stage)
        df = s.thrust - f_cmd
        calm = self._calm(t)
        flow = None
        for i in range(self.substeps):
            # motor_lag_stages(f_cmd, f₀, t_m, i h + stage): f_cmd + e^{−s/t_m} (f₀ − f_cmd), factors kept
            tau_thr = (f_cmd + lags[i] * df) @ B.T
            if wet != 1.0:
                tau_thr = tau_thr * wet
            if not calm:
                flow = flow_at(x, t - self.sea_start + stage)
            x = rk4(x, h, tau_thr, flow)
            t = s.t + (i + 1) * h
        n = x.size // 2
        _check_physical(x[:n], x[n:], s.t, t)
        return x, t, (f_cmd + lag_end * df)[0], flow

    def _step_planar(self, f_cmd: np.ndarray, dt: float, wet: float) -> None:
        """The planar world's step (the paper's surge, heave, pitch)."""
        p, s = self.vehicle, self.state
        x, t, f, flow = self._integrate(
            np.concatenate([s.eta, s.nu]), f_cmd, dt, wet, self.B,
            lambda x, tt: body_flow(self.sea.components, x[:3], tt, self.strips, self.current_x),
            lambda x, h, tau, flow: rk4_step(p, x, h, tau, flow))
        self.state = PlantState(t, x[:3], x[3:], f, _six(x[:3]), _six(x[3:]))
        tau = self.B @ f if wet == 1.0 else (self.B @ f) * wet
        u, w, q = x[3:].tolist()
        in_flow, still = hydrodynamic_load_terms(p, u, w, q, flow, 2), hydrodynamic_load_terms(p, u, w, q, None)
        self.tau_E = np.array([in_flow[0] - still[0], in_flow[1] - still[1], in_flow[2] - still[2]])
        self.tau = tau
        self.nu_dot = state_rates_at(p, x, tau, flow, 2)[3:]

    def _step_six(self, f_cmd: np.ndarray, dt: float, wet: float) -> None:
        """The six-DoF world's step: the same thrusters and lag through the 6 × 8 wrench matrix, the body in
        all six DoF in the sea from its direction."""
        body, s = self.body6, self.state
        assert body is not None
        x, t, f, flow = self._integrate(
            np.concatenate([s.eta6, s.nu6]), f_cmd, dt, wet, self.B6,
            lambda x, tt: body.flow(self.sea.components, x[:6], tt, self.current_ned), body.rk4)
        self.state = PlantState.of(t, x[:6], x[6:], f)
        self.tau6 = (self.B6 @ f) * wet
        nu = x[6:]
        self.tau_E6 = body.load(nu, flow, 2) - body.load(nu, None)
        self.nu_dot6 = body.rates(x, self.tau6, flow, 2)[6:]
        self.tau_E, self.tau, self.nu_dot = self.tau_E6[_P], self.tau6[_P], self.nu_dot6[_P]

    def _motor_lags(self, dt: float, stage: np.ndarray) -> tuple[list[np.ndarray], np.ndarray]:
        """The motor-lag factors e^{−s/t_m} of :func:`motor_lag_stages` at each substep's stage times and at
        dt, as columns; computed again only when dt changes (the plant's step is fixed in a mission)."""
        if dt != self._lag_key:
            h = dt / self.substeps
            self._lags = [motor_lag_factors(self.t_m, i * h + stage) for i in range(self.substeps)]
            self._lag_end = motor_lag_factors(self.t_m, [dt])
            self._lag_key = dt
        return self._lags, self._lag_end

    def six_state(self) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """(η, ν, ν̇) of the six-DoF world for the JSON state (:func:`bridge.json_sitl.state_message`'s ``six``),
        or None for the planar world (whose other DoF are zero)."""
        if self.body6 is None:
            return None
        return self.state.eta6, self.state.nu6, self.nu_dot6

    def lateral_state(self) -> np.ndarray | None:
        """The six-DoF world's lateral-directional truth [y, φ, ψ, v, p, r] (m, rad, m/s, rad/s); None when planar
        (a planar world has no lateral motion for a sensor to read)."""
        if self.body6 is None:
            return None
        s = self.state
        return to_lateral(np.concatenate([s.eta6, s.nu6]))

    def specific_force6(self) -> list[float] | None:
        """The six-DoF world's accelerometer truth [f_x, f_y, f_z] (m/s², body FRD, :func:`specific_force6`, as the
        JSON SITL state's ``imu.accel_body``); None when planar."""
        if self.body6 is None:
            return None
        s = self.state
        return specific_force6(s.eta6, s.nu6, self.nu_dot6, float(self.vehicle.g))

    def power_per_dof(self) -> np.ndarray:
        """Power (W) per DoF for the current thruster load, paper's T200 polynomial on |τ|."""
        return power_per_dof(self.tau)


def _check_physical(eta: np.ndarray, nu: np.ndarray, t0: float, t1: float) -> None:
    """:class:`PlantDiverged` if the pose η and body velocity ν (planar or six-DoF) reached at ``t1`` (s) from ``t0``
    are not a vehicle's: non-finite, or a speed beyond :data:`MAX_BODY_SPEED` or a rate beyond :data:`MAX_BODY_RATE`."""
    n = nu.size // 2
    speeds, rates = nu[:n].tolist(), nu[n:].tolist()
    # NaN fails every comparison, so a non-finite velocity is caught with the large ones
    if all(abs(v) <= MAX_BODY_SPEED for v in speeds) and all(abs(v) <= MAX_BODY_RATE for v in rates) \
            and math.isfinite(float(np.sum(eta))):
        return
    names = ("u", "w", "q") if n == 1 else ("u", "v", "w", "p", "q", "r")
    values = ", ".join(f"{k} {v:.3g}" for k, v in zip(names, nu.tolist(), strict=True))
    raise PlantDiverged(
        f"the simulation diverged between t = {t0:.2f} s and {t1:.2f} s: {values} (limits {MAX_BODY_SPEED:g} m/s, "
        f"{MAX_BODY_RATE:g} rad/s); the state before it is kept")
