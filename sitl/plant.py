"""The simulated BlueROV2 Heavy: Fossen 3-DoF body, eight T200 thrusters, wave loads, RK4.

State: NED pose η = [x, z, θ], body velocities ν = [u, w, q] and the eight
thrusters' actual thrusts f (N). The thrusters follow their PWM
command through the T200 curve with a first-order lag (time constant t_m); the
body moves under paper Eq. 2 with τ = B_μ f and the wave load τ_E of Eq. 11.

Each control period is integrated with ``substeps`` classical RK4 steps; the
motor lag is solved exactly over the period (the PWM is held constant). The
wave load is sampled at the RK4 stage times (t, t + h/2, t + h) for the pose at
the start of the step: within h ≤ 50 ms the vehicle moves millimetres against
wavelengths of metres, and one batched evaluation replaces four.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from firmware_py.config import load_mission_config, load_vehicle_config
from firmware_py.physics.thrusters import T200Curve, ThrusterLayout, power_per_dof
from firmware_py.physics.vehicle import VehicleParams, nu_dot, state_rates, strip_nodes, wave_load

from .sea import Sea

__all__ = ["PlantState", "Plant"]


@dataclass
class PlantState:
    """Truth state of the simulated vehicle."""

    t: float = 0.0                                                     # s
    eta: np.ndarray = field(default_factory=lambda: np.zeros(3))       # [x (m), z depth (m), θ (rad)]
    nu: np.ndarray = field(default_factory=lambda: np.zeros(3))        # [u, w (m/s), q (rad/s)] body
    thrust: np.ndarray = field(default_factory=lambda: np.zeros(8))    # actual thrust per thruster (N)

    def copy(self) -> "PlantState":
        return PlantState(self.t, self.eta.copy(), self.nu.copy(), self.thrust.copy())


class Plant:
    """The vehicle in the sea, advanced one control period at a time by :meth:`step`."""

    def __init__(self, vehicle: VehicleParams, sea: Sea, layout: ThrusterLayout, curve: T200Curve,
                 motor_time_constant: float, substeps: int = 1, strips: int = 6):
        if substeps < 1 or strips < 1:
            raise ValueError("substeps and strips must be >= 1")
        self.vehicle = vehicle
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

    @classmethod
    def from_configs(cls, sea: Sea, vehicle: str = "bluerov2_heavy", mission: str = "station_keeping") -> "Plant":
        vcfg = load_vehicle_config(vehicle)
        mcfg = load_mission_config(mission)
        plant = cls(VehicleParams.from_config(vcfg), sea, ThrusterLayout.from_config(vcfg["thrusters"]),
                    T200Curve.from_config(vcfg["thrusters"]), vcfg["thrusters"]["time_constant"],
                    mcfg["plant"]["substeps"], mcfg["plant"]["strips"])
        sp = mcfg["setpoint"]
        plant.reset(eta=np.array([sp["x"], sp["depth"], sp["pitch"]]))
        return plant

    def reset(self, eta=None, nu=None, t: float = 0.0) -> None:
        """Place the vehicle at pose η with velocity ν at time t, thrusters idle."""
        self.state = PlantState(float(t), np.zeros(3) if eta is None else np.array(eta, dtype=float),
                                np.zeros(3) if nu is None else np.array(nu, dtype=float), np.zeros(8))
        self.tau_E = self.wave_load(self.state.eta, self.state.t)
        self.tau = np.zeros(3)
        self.nu_dot = np.zeros(3)

    def wave_load(self, eta, t) -> np.ndarray:
        """τ_E (paper Eq. 11) at pose(s) η and time(s) t."""
        return wave_load(self.vehicle, self.sea.components, eta, t, self.strips)

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
        if not np.all(np.isfinite(pwm)):
            raise ValueError("PWM values must be finite")
        if not dt > 0:
            raise ValueError(f"dt must be positive, got {dt}")
        f_cmd = self.curve.thrust(pwm)
        s = self.state
        eta, nu, f0, t = s.eta, s.nu, s.thrust, s.t
        h = dt / self.substeps
        stage = np.array([0.0, 0.5 * h, h])
        tau_cmd, tau_gap = self.B @ f_cmd, self.B @ (f0 - f_cmd)
        p = self.vehicle
        x = np.concatenate([eta, nu])
        for i in range(self.substeps):
            lag = np.exp(-(i * h + stage) / self.t_m)
            tau0, tau_half, tau1 = tau_cmd + np.outer(lag, tau_gap) + self.wave_load(x[:3], t + stage)
            k1 = state_rates(p, x, tau0)
            k2 = state_rates(p, x + (0.5 * h) * k1, tau_half)
            k3 = state_rates(p, x + (0.5 * h) * k2, tau_half)
            k4 = state_rates(p, x + h * k3, tau1)
            x = x + (h / 6.0) * (k1 + 2.0 * (k2 + k3) + k4)
            t = s.t + (i + 1) * h
        eta, nu = x[:3], x[3:]
        f = f_cmd + (f0 - f_cmd) * np.exp(-dt / self.t_m)
        self.state = PlantState(t, eta, nu, f)
        self.tau = self.B @ f
        self.tau_E = tau1 - self.tau
        self.nu_dot = nu_dot(p, eta, nu, tau1)
        return self.state

    def power_per_dof(self) -> np.ndarray:
        """Power (W) per DoF for the current thruster load, paper's T200 polynomial on |τ|."""
        return power_per_dof(self.tau)

    def pwm_for_wrench(self, tau) -> np.ndarray:
        """Open-loop helper: PWM that would produce the planar wrench τ by pseudo-inverse allocation."""
        return self.curve.pwm(np.linalg.pinv(self.B) @ np.asarray(tau, dtype=float))
