"""The rc method's command chain without processes: the thrust the companion's motor model expects is the
thrust the stand-in ArduSub's mixer and the motors deliver, also while heave saturates.

The chain: the companion's mixer (its parameters: ``companion_overrides``) → sticks
(:meth:`Commander.channels`) → the stand-in's pilot wrench (a full stick is ``WK_TAU_MAX_*``,
``Firmware._pilot_wrench``) → the stand-in's mixer (its parameters: ``stand_in_args``) → the T200
curve → first-order motors (the vehicle's time constant, as the plant has them).
"""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from bridge.models.thrusters import T200Curve, ThrusterLayout, motor_lag_stages
from bridge.schemas import load_vehicle_config
from firmware_py.companion.app import companion_overrides
from firmware_py.companion.commander import Commander
from firmware_py.motors.mixer import MotorMixer
from firmware_py.params.table import load_params
from sitl.harness.companion_launch import stand_in_args

H = 0.05
STAGES = np.array([0.0, 0.5 * H, H])


@pytest.fixture(scope="module")
def vehicle():
    cfg = load_vehicle_config("bluerov2_heavy")["thrusters"]
    return ThrusterLayout.from_config(cfg), T200Curve.from_config(cfg), float(cfg["time_constant"])


def _stand_in_overrides(method: str) -> dict[str, float]:
    args = stand_in_args(method)
    sets = [args[i + 1] for i, a in enumerate(args) if a == "--set"]
    return {name: float(value) for name, value in (s.split("=") for s in sets)}


def _wave_like_demands(n: int = 1200) -> np.ndarray:
    """A chattering C-PD-like demand [X, Z, M] whose heave often asks for more than the 140 N the verticals have."""
    rng = np.random.default_rng(7)
    t = np.arange(n) * H
    slow = np.c_[60 * np.sin(0.9 * t), 170 * np.sin(0.7 * t + 1.0), 6 * np.sin(1.1 * t)]
    return slow + rng.normal(0.0, 1.0, (n, 3)) * np.array([40.0, 60.0, 5.0])


def _rc_chain(vehicle, companion: dict[str, float], stand_in: dict[str, float]):
    """Per period: the wrench the companion's mixer expects (mean over the period) and the one delivered;
    and the fraction of periods with a thruster at the limit."""
    layout, curve, t_m = vehicle
    cp, sp = load_params(overrides=companion), load_params(overrides=stand_in)
    ours, theirs = MotorMixer(layout, curve, cp, H), MotorMixer(layout, curve, sp, H)
    commander = Commander(SimpleNamespace(), "rc", "wavekeep", curve, layout.allocation_matrix(),
                          sp.axes("WK_TAU_MAX"))
    tau_max = np.array(sp.axes("WK_TAU_MAX"))
    simpson = np.array([1.0, 4.0, 1.0]) / 6.0
    f_motor = np.zeros(layout.n)
    expected, delivered, at_limit = [], [], 0
    for tau in _wave_like_demands():
        mix = ours.mix(tau)
        at_limit += bool(np.abs(mix.thrust_cmd).max() > cp["WK_THR_MAX"] - 0.5)
        ch = np.array(commander.channels(mix.pwm), dtype=float)
        pitch, up, forward = (ch[[0, 2, 4]] - 1500.0) / 400.0
        pwm = theirs.mix(tau_max * np.array([forward, -up, pitch])).pwm
        stages = motor_lag_stages(curve.thrust(pwm), f_motor, t_m, STAGES)
        f_motor = stages[-1]
        expected.append(simpson @ mix.tau_stages)
        delivered.append(simpson @ stages @ layout.allocation_matrix().T)
    return np.array(expected), np.array(delivered), at_limit / len(expected)


def test_rc_companion_expects_the_thrust_the_autopilot_delivers_under_heave_saturation(vehicle):
    expected, delivered, at_limit = _rc_chain(vehicle, companion_overrides("rc", True), _stand_in_overrides("rc"))
    err = delivered - expected
    assert at_limit > 0.3                                       # the thrusters really worked at their limit
    # pitch moment: within 0.1 N m everywhere (the RC channel's 1 µs is 0.04 N m), so the EKF and the
    # Smith predictor see the moment that acts. Before (the stand-in compensating the motor lag of the
    # sticks and clipping thruster by thruster, the companion expecting instant motors) the error here
    # was 2.8 N m RMS, 12 N m at worst
    assert np.abs(err[:, 2]).max() < 0.1
    assert np.all(np.sqrt(np.mean(err ** 2, axis=0)) < [0.5, 0.5, 0.01])     # X (N), Z (N), M (N m)


def test_compensated_command_is_reallocated_pitch_first_within_the_thrust_limit(vehicle):
    layout, curve, _ = vehicle
    B = layout.allocation_matrix()
    params = load_params(overrides={"WK_MOT_LIM": 1})
    mixer = MotorMixer(layout, curve, params, H)
    mixer.mix(np.array([0.0, -120.0, -6.0]))                      # thrusters heading one way...
    out = mixer.mix(np.array([0.0, 130.0, 8.0]))                  # ...then a reversal: a boost far past 35 N
    assert np.all(np.abs(out.thrust_cmd) <= params["WK_THR_MAX"] + 0.2)   # (+ the PWM's 1 µs)
    # the boost toward the moment is kept: more than the demand's 8 N m, heave takes what is left
    assert (B @ out.thrust_cmd)[2] > 8.0
    clipped = MotorMixer(layout, curve, load_params(overrides={"WK_MOT_LIM": 0}), H)
    clipped.mix(np.array([0.0, -120.0, -6.0]))
    per_thruster = clipped.mix(np.array([0.0, 130.0, 8.0]))
    assert np.abs(per_thruster.thrust_cmd).max() > params["WK_THR_MAX"] + 1.0   # the PWM range, not 35 N
