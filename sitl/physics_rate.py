"""The plant at its own physics rate under an autopilot that sends servo frames faster.

ArduSub's SITL steps its JSON physics at ``SIM_RATE_HZ`` (1200 Hz), one servo
frame per step. Integrating the sea and the vehicle 1200 times a simulated
second costs more than the autopilot itself (a plant step is ~0.1 ms here), so
the server can step the plant at its own rate instead: every n = frame_rate /
physics_rate frames (rounded, at least 1) it samples the newest frame's PWM,
holds it for n frames (a zero-order hold at the physics rate, as an ESC
that takes a new pulse every 1/physics_rate s) and advances the world n/frame_rate
seconds at once; the replies to the n − 1 frames in between are the state
interpolated linearly between the two steps. Within one 5 ms step (200 Hz) a
linear interpolation of position misses the true path by a·h²/8, micrometres:
far below any sensor the autopilot simulates. n = 1 (the default, and any
autopilot that sends no faster than the physics rate) is the plain lockstep of
``docs/json_sitl.md``, bit for bit.
"""
from __future__ import annotations

import math

import numpy as np

from bridge.json_sitl import state_message

__all__ = ["PhysicsHold", "plant_state_message"]


def plant_state_message(plant, frame_count: int | None = None) -> dict:
    """The JSON SITL state of a plant (:func:`bridge.json_sitl.state_message`), ν̇ from ``plant.nu_dot``."""
    s = plant.state
    return state_message(s.t, s.eta, s.nu, plant.nu_dot, s.thrust, float(plant.vehicle.g), frame_count,
                         plant.pressure_depth, plant.six_state())


def _snapshot(plant) -> np.ndarray:
    """Everything a reply holds, as one vector: t, η, ν, ν̇, thrusts, pressure depth (NaN: none), and a six-DoF
    world's η, ν, ν̇ (six each)."""
    s = plant.state
    pd = math.nan if plant.pressure_depth is None else plant.pressure_depth
    six = plant.six_state()
    return np.array([s.t, *s.eta, *s.nu, *plant.nu_dot, *s.thrust, pd, *(np.concatenate(six) if six else ())],
                    dtype=float)


def _message(v: np.ndarray, n_thrust: int, g: float, frame_count: int) -> dict:
    """The state message of a :func:`_snapshot` vector."""
    k = 10 + n_thrust
    pd = float(v[k])
    rest = v[k + 1:]
    six = (rest[:6], rest[6:12], rest[12:18]) if rest.size else None
    return state_message(float(v[0]), v[1:4], v[4:7], v[7:10], v[10:k], g, frame_count,
                         None if math.isnan(pd) else pd, six)


class PhysicsHold:
    """Steps a plant once every ``n`` servo frames and answers the frames in between by interpolation."""

    def __init__(self, physics_rate_hz: float | None = None):
        if physics_rate_hz is not None and not (math.isfinite(physics_rate_hz) and physics_rate_hz > 0):
            raise ValueError(f"physics rate must be a positive number of Hz, got {physics_rate_hz}")
        self.physics_rate_hz = physics_rate_hz
        self.n = 1
        self._phase = 0
        self._from: np.ndarray | None = None
        self._to: np.ndarray | None = None

    def start(self, frame_rate: int) -> None:
        """A new session at ``frame_rate`` (Hz): how many frames one plant step holds."""
        rate = self.physics_rate_hz
        self.n = 1 if rate is None else max(1, round(frame_rate / rate))
        self._phase = 0

    def frame(self, plant, pwm: np.ndarray, frame_rate: int) -> bool:
        """Advance one frame under ``pwm``; True when the plant was stepped."""
        if self.n == 1:
            plant.step(pwm, 1.0 / frame_rate)
            return True
        stepped = self._phase == 0
        if stepped:
            self._from = _snapshot(plant)
            plant.step(pwm, self.n / frame_rate)
            self._to = _snapshot(plant)
        self._phase = (self._phase + 1) % self.n
        return stepped

    def message(self, plant, frame_count: int) -> dict:
        """The state for the frame just advanced: the plant's own, or interpolated within a held step."""
        if self._phase == 0 or self._from is None or self._to is None:
            return plant_state_message(plant, frame_count)
        a, b = self._from, self._to
        v = a + (b - a) * (self._phase / self.n)
        return _message(v, plant.state.thrust.size, float(plant.vehicle.g), frame_count)
