"""The simulated BlueROV2 Heavy: Fossen 3-DoF body, eight T200 thrusters, wave loads, RK4.

State: NED pose η = [x, z, θ], body velocities ν = [u, w, q] and the eight
thrusters' actual thrusts f (N). The thrusters follow their PWM
command through the T200 curve with a first-order lag (time constant t_m); the
body moves under paper Eq. 2 with τ = B_μ f, its damping and added-mass
Coriolis forces taken on the velocity relative to the water and the fluid's
inertia force — Froude–Krylov and added mass, (ρ∇ + M_A)·a, or the paper's
M_A·a alone when the sea config's ``wave_load`` is ``paper`` (see
:func:`~bridge.models.vehicle.hydrodynamic_load`).

Each control period is integrated with ``substeps`` classical RK4 steps; the
motor lag is solved exactly over the period (the PWM is held constant). The
flow at the body's strips is sampled at the RK4 stage times (t, t + h/2, t + h)
for the pose at the start of the step: within h ≤ 50 ms the vehicle moves
millimetres against wavelengths of metres, and one batched evaluation serves
all four stages.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

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
from bridge.schemas import apply_true_vehicle, load_mission_config, load_true_vehicle, load_vehicle_config

from .lateral import LateralModel, LateralParams
from .sea import Sea

__all__ = ["MAX_BODY_RATE", "MAX_BODY_SPEED", "START_POSES", "Plant", "PlantDiverged", "PlantState"]

MAX_BODY_SPEED = 20.0   # m/s: |u|, |w| beyond this is no ROV in any sea the schema admits (they stay below 8)
MAX_BODY_RATE = 20.0    # rad/s: |q| likewise (about 1150 °/s)


class PlantDiverged(RuntimeError):
    """The integration left the physical range (non-finite, or ν beyond :data:`MAX_BODY_SPEED` /
    :data:`MAX_BODY_RATE`): the step is too large for the sea, or the sea outside the model."""


START_POSES = ("station", "surface")
"""Where the vehicle starts: at the mission's station, or at rest at the still surface (depth 0), held there
until its thrusters first run: where a foreign autopilot boots and zeroes its depth (docs/json_sitl.md)."""


@dataclass
class PlantState:
    """Truth state of the simulated vehicle."""

    t: float = 0.0                                                     # s
    eta: np.ndarray = field(default_factory=lambda: np.zeros(3))       # [x (m), z depth (m), θ (rad)]
    nu: np.ndarray = field(default_factory=lambda: np.zeros(3))        # [u, w (m/s), q (rad/s)] body
    thrust: np.ndarray = field(default_factory=lambda: np.zeros(8))    # actual thrust per thruster (N)

    def copy(self) -> PlantState:
        return PlantState(self.t, self.eta.copy(), self.nu.copy(), self.thrust.copy())


class Plant:
    """The vehicle in the sea, advanced one control period at a time by :meth:`step`."""

    def __init__(self, vehicle: VehicleParams, sea: Sea, layout: ThrusterLayout, curve: T200Curve,
                 motor_time_constant: float, substeps: int = 1, strips: int = 6):
        if substeps < 1 or strips < 1:
            raise ValueError("substeps and strips must be >= 1")
        self.vehicle = vehicle.with_wave_load(sea.wave_load)   # the world's load model is the sea config's
        self.sea = sea
        self.layout = layout
        self.curve = curve
        self.t_m = float(motor_time_constant)
        self.substeps = int(substeps)
        self.strips = strip_nodes(vehicle.length, strips)
        self.B = layout.allocation_matrix()  # 3×8: thrusts → [X, Z, M]
        self.state = PlantState()
        self.tau_E = np.zeros(3)        # wave load at the end of the last step
        self.tau = np.zeros(3)          # thruster load at the end of the last step
        self.nu_dot = np.zeros(3)       # body acceleration at the end of the last step
        self.current_x = sea.current_x  # steady current's in-plane component (m/s, NED north)
        self.pressure_depth: float | None = None   # what a pressure sensor reads (m), with the sea's option
        self.sea_start = 0.0            # s of plant time at which the sea (waves, current) begins at its t = 0
        self.moored = False             # held at rest where it is until a thruster first gives thrust
        self.lateral: LateralModel | None = None   # sway, roll and yaw (a six-DoF autopilot's world)
        self._lag_key: float | None = None          # the dt the motor-lag factors below were computed for
        self._lags: list[np.ndarray] = []          # per substep: e^{−s/t_m} at its stage times (3, 1)
        self._lag_end = np.ones(1)                  # e^{−dt/t_m} (1, 1)

    @classmethod
    def from_configs(cls, sea: Sea, vehicle: str = "bluerov2_heavy", mission: str = "station_keeping",
                     true_vehicle: str | None = None, start: str = "station", sea_start: float = 0.0,
                     six_dof: bool = False) -> Plant:
        """The plant of the vehicle and mission configs; ``true_vehicle`` names a plant-only override
        (``configs/vehicle/true/``) that scales the vehicle's coefficients: the firmware keeps the nominal ones.

        For a foreign autopilot (docs/json_sitl.md): ``start`` "surface" (:data:`START_POSES`), the sea
        still until ``sea_start`` s, and ``six_dof`` for sway, roll and yaw (:mod:`sitl.lateral`)."""
        if start not in START_POSES:
            raise ValueError(f"start must be one of {', '.join(START_POSES)}, got {start!r}")
        if not (math.isfinite(sea_start) and sea_start >= 0.0):
            raise ValueError(f"sea_start must be a non-negative number of seconds, got {sea_start}")
        vcfg = load_vehicle_config(vehicle)
        if true_vehicle:
            vcfg = apply_true_vehicle(vcfg, load_true_vehicle(true_vehicle))
        mcfg = load_mission_config(mission)
        layout = ThrusterLayout.from_config(vcfg["thrusters"])
        params = VehicleParams.from_config(vcfg)
        plant = cls(params, sea, layout, T200Curve.from_config(vcfg["thrusters"]), vcfg["thrusters"]["time_constant"],
                    mcfg["plant"]["substeps"], mcfg["plant"]["strips"])
        plant.sea_start = float(sea_start)
        if six_dof:
            plant.lateral = LateralModel(LateralParams.from_config(vcfg, params.g), layout.wrench_matrix()[[1, 3, 5]])
        sp = mcfg["setpoint"]
        if start == "surface":
            plant.reset(eta=np.array([sp["x"], 0.0, sp["pitch"]]))
            plant.moored = True
        else:
            plant.reset(eta=np.array([sp["x"], sp["depth"], sp["pitch"]]))
        return plant

    def reset(self, eta=None, nu=None, t: float = 0.0) -> None:
        """Place the vehicle at pose η with velocity ν at time t, thrusters idle."""
        self.state = PlantState(float(t), np.zeros(3) if eta is None else np.array(eta, dtype=float),
                                np.zeros(3) if nu is None else np.array(nu, dtype=float), np.zeros(8))
        self.tau_E = self.wave_load(self.state.eta, self.state.nu, self.state.t)
        self.tau = np.zeros(3)
        self.nu_dot = np.zeros(3)
        if self.lateral is not None:
            self.lateral.reset()
        self._update_pressure()

    def _calm(self, t: float) -> bool:
        """Is the sea still at plant time t (before :attr:`sea_start`)?"""
        return t < self.sea_start

    def _update_pressure(self) -> None:
        """The depth a pressure sensor at the body origin reads, p/(ρ g) = z + Σ A K_p cos θ (m), when the
        sea's ``depth_sensor.dynamic_pressure`` is on; None (the sensor reads the true depth) otherwise."""
        if self.sea.dynamic_pressure:
            s = self.state
            head = 0.0 if self._calm(s.t) else self.sea.pressure_head(s.eta[0], s.eta[1], s.t - self.sea_start)
            self.pressure_depth = float(s.eta[1] + head)

    def wave_load(self, eta, nu, t) -> np.ndarray:
        """τ_E (relative-velocity form, the sea's load model) on the body at pose η moving with ν, at plant time t
        (s, or an array of T times: the result is then (T, 3)); zero while the sea is still (before
        :attr:`sea_start`)."""
        if np.ndim(t) == 0 and self._calm(float(t)):
            return np.zeros(3)
        tau = wave_load(self.vehicle, self.sea.components, eta, nu, np.asarray(t, dtype=float) - self.sea_start,
                        self.strips, self.current_x)
        if np.ndim(t) == 0:
            return tau
        return np.where((np.asarray(t) < self.sea_start)[:, None], 0.0, tau)

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
                self.state = PlantState(s.t + dt, s.eta, s.nu, s.thrust)
                return self.state
            self.moored = False
        h = dt / self.substeps
        stage = np.array([0.0, 0.5 * h, h])
        p = self.vehicle
        x = np.concatenate([s.eta, s.nu])
        t = s.t
        lags, lag_end = self._motor_lags(dt, stage)
        df = s.thrust - f_cmd
        calm = self._calm(t)
        flow = None
        # A thruster out of the water pushes nothing: near the surface the thrust fades as the buoyancy does
        wet = 1.0 if s.eta[1] >= 0.5 * p.height else submerged_fraction(p, float(s.eta[1]))
        for i in range(self.substeps):
            # motor_lag_stages(f_cmd, f₀, t_m, i h + stage): f_cmd + e^{−s/t_m} (f₀ − f_cmd), factors kept
            tau_thr = (f_cmd + lags[i] * df) @ self.B.T
            if wet != 1.0:
                tau_thr = tau_thr * wet
            if not calm:
                flow = body_flow(self.sea.components, x[:3], t - self.sea_start + stage, self.strips, self.current_x)
            x = rk4_step(p, x, h, tau_thr, flow)
            t = s.t + (i + 1) * h
        _check_physical(x, s.t, t)
        f = (f_cmd + lag_end * df)[0]
        if self.lateral is not None:
            self.lateral.step((float(x[2]), float(x[3]), float(x[4]), float(x[5])), s.thrust * wet, f * wet, dt)
        self.state = PlantState(t, x[:3], x[3:], f)
        self.tau = self.B @ f if wet == 1.0 else (self.B @ f) * wet
        u, w, q = x[3:].tolist()
        in_flow, still = hydrodynamic_load_terms(p, u, w, q, flow, 2), hydrodynamic_load_terms(p, u, w, q, None)
        self.tau_E = np.array([in_flow[0] - still[0], in_flow[1] - still[1], in_flow[2] - still[2]])
        self.nu_dot = state_rates_at(p, x, self.tau, flow, 2)[3:]
        self._update_pressure()
        return self.state

    def _motor_lags(self, dt: float, stage: np.ndarray) -> tuple[list[np.ndarray], np.ndarray]:
        """The motor-lag factors e^{−s/t_m} of :func:`motor_lag_stages` at each substep's stage times and at
        dt, as columns; computed again only when dt changes (the plant's step is fixed in a mission)."""
        if dt != self._lag_key:
            h = dt / self.substeps
            self._lags = [motor_lag_factors(self.t_m, i * h + stage) for i in range(self.substeps)]
            self._lag_end = motor_lag_factors(self.t_m, [dt])
            self._lag_key = dt
        return self._lags, self._lag_end

    def lateral_fields(self) -> tuple[float, ...] | None:
        """The out-of-plane motion for the JSON state (:func:`bridge.json_sitl.state_message`'s ``lateral``):
        (y, φ, ψ, v, p, r, v̇, ẏ), or None for a planar world."""
        if self.lateral is None:
            return None
        y, phi, psi, v, p, r = self.lateral.state.tolist()
        rates = self.lateral.rates
        return (y, phi, psi, v, p, r, float(rates[3]), float(rates[0]))

    def power_per_dof(self) -> np.ndarray:
        """Power (W) per DoF for the current thruster load, paper's T200 polynomial on |τ|."""
        return power_per_dof(self.tau)



def _check_physical(x: np.ndarray, t0: float, t1: float) -> None:
    """:class:`PlantDiverged` if the state [η, ν] reached at ``t1`` (s) from ``t0`` is not a vehicle's."""
    xs, z, th, u, w, q = x.tolist()
    # NaN fails every comparison, so a non-finite velocity is caught with the large ones
    if not (abs(u) <= MAX_BODY_SPEED and abs(w) <= MAX_BODY_SPEED and abs(q) <= MAX_BODY_RATE
            and math.isfinite(xs + z + th)):
        raise PlantDiverged(
            f"the simulation diverged between t = {t0:.2f} s and {t1:.2f} s: u {x[3]:.3g} m/s, w {x[4]:.3g} m/s, "
            f"q {x[5]:.3g} rad/s (limits {MAX_BODY_SPEED:g} m/s, {MAX_BODY_RATE:g} rad/s); the state before it "
            "is kept")
