"""The companion's safety rules found on the real ArduSub, checked without it (a recording link, real parts).

A non-finite estimate restarts the estimator and releases at once, with a
STATUSTEXT (it used to send 1500 µs forever while "engaged"); a companion that
finds itself stalled hands back rather than resume; ``servo`` hands back neutral
first, then the motors, then the inputs (ArduSub holds a released pass-through
output's PWM, and an output whose function changes until its 1 Hz loop); the
depth it fuses is a new barometer reading only, with the noise of the barometer
it reads; the stand-in keeps pass-through outputs live while disarmed and
re-assigns them at 1 Hz, as ArduSub.
"""
from __future__ import annotations

import argparse
import math
import time
from dataclasses import dataclass, field

import numpy as np
import pytest

from bridge.models.thrusters import T200Curve, ThrusterLayout
from bridge.models.vehicle import VehicleParams
from bridge.schemas import load_vehicle_config
from firmware_py.companion import commander as cmd
from firmware_py.companion.app import _depth_noise
from firmware_py.companion.autopilot import MANUAL, Sample, VehicleState
from firmware_py.companion.hal_mavlink import MAVLinkAutopilotHAL
from firmware_py.estimation.estimator import PlanarEKF
from firmware_py.hal.sensors import SensorFrame
from firmware_py.motors.aux_outputs import AuxOutputs
from firmware_py.params.table import load_params


@dataclass
class RecordingLink:
    """What a Commander and the HAL use of :class:`AutopilotLink`, recording what is sent."""

    state: VehicleState = field(default_factory=VehicleState)
    sent: list = field(default_factory=list)          # ("rc", channels) / ("param", name, value) / ("text", text)
    params: dict = field(default_factory=dict)
    on_mode_change: object = None

    def rc_override(self, channels):
        self.sent.append(("rc", list(channels)))

    def set_param(self, name, value):
        self.sent.append(("param", name, value))

    def statustext(self, severity, text):
        self.sent.append(("text", text))

    def read_param(self, name, timeout=3.0):
        return self.params.get(name)

    def fresh(self, kind, max_age_s):
        s = self.state.samples.get(kind)
        return s if s is not None and time.monotonic() - s.arrived <= max_age_s else None

    def attitude(self, t_ms=1000):
        self.state.samples["ATTITUDE"] = Sample((0.0, 0.0), t_ms, time.monotonic(), 1)


def _commander(method: str, fw=None):
    cfg = load_vehicle_config()
    link = RecordingLink()
    layout, curve = ThrusterLayout.from_config(cfg["thrusters"]), T200Curve.from_config(cfg["thrusters"])
    c = cmd.Commander(link, method, "none" if method == "servo" else "ardusub", curve, layout.allocation_matrix(),
                      (100.0, 100.0, 10.0), stale_s=0.5, log=lambda _t: None)
    c.fw = fw
    return c, link


class _Fw:
    """The parts of a Firmware the commander reads: a real estimator, the output fault count."""

    def __init__(self):
        params = load_params("params", {"WK_EKF_MODE": 0.0})
        self.ekf = PlanarEKF(VehicleParams.from_config(load_vehicle_config()), params, 0.05)
        self.ekf.initialise(SensorFrame(0.0, 0.0, 5.0, 0.0, 0.0))
        self.output_faults = 0
        self.setpoint = np.array([0.0, 5.0, 0.0])

    def request_arm(self, arm, force=False):
        return 0

    def request_mode(self, mode):
        if mode == 4 and not self.ekf.converged():           # as the firmware: GUIDED needs a position
            return 4
        self.mode = mode
        return 0


def _engaged(method: str):
    fw = _Fw()
    c, link = _commander(method, fw)
    link.attitude()
    link.state.armed, link.state.mode = True, MANUAL
    c.selected = True
    c.gate()
    assert c.engaged
    return c, link, fw


def _texts(link) -> list[str]:
    return [s[1] for s in link.sent if s[0] == "text"]


def test_a_non_finite_estimate_restarts_the_estimator_and_releases_at_once():
    c, link, fw = _engaged("servo")
    fw.ekf.kf.x[3, 0] = math.inf                             # surge velocity ran away (the real run: 1e37, then NaN)
    c.gate()
    assert not c.engaged and not fw.ekf.initialised and fw.ekf.restarts == 1
    assert "WK: released overrides (estimate not finite: re-initialised)" in _texts(link)
    c.output(np.full(8, 1500.0))                               # no more commands: it is released
    assert not [s for s in link.sent if s[0] == "rc" and s[1][8:16] not in ([1500] * 8, [cmd.RELEASE_HIGH] * 8)]
    link.attitude(2000)
    c.gate()
    assert not c.engaged                                       # and it waits for the pilot to select MANUAL again


def test_a_neutral_command_from_a_non_finite_one_also_releases():
    c, link, fw = _engaged("rc")
    fw.output_faults += 1                                      # the control task sent neutral for a NaN command
    c.output(np.full(8, 1500.0))
    assert not c.engaged and any("not finite" in t for t in _texts(link))


def test_the_estimator_starts_again_when_its_estimate_is_not_finite():
    fw = _Fw()
    fw.ekf.kf.P[0, 0] = math.nan
    fw.ekf.update(SensorFrame(0.05, 0.0, 5.0, 0.0, 0.0))
    assert not fw.ekf.initialised and fw.ekf.restarts == 1
    fw.ekf.update(SensorFrame(0.10, 0.1, 5.1, 0.0, 0.0))       # the next readings initialise it again
    assert fw.ekf.initialised and np.isfinite(fw.ekf.x).all() and fw.ekf.x[1] == pytest.approx(5.1)


def test_a_stalled_companion_hands_back_instead_of_resuming():
    c, link, _fw = _engaged("rc")
    c._last_gate -= 2.0                                        # as if frozen for 2 s, then woken with fresh telemetry
    link.attitude(9000)
    c.gate()
    assert not c.engaged and any("companion stalled 2.0 s" in t for t in _texts(link))


def test_servo_hands_back_neutral_first_then_the_motors_then_the_inputs():
    c, link, _fw = _engaged("servo")
    engage = [s for s in link.sent if s[0] != "text"]
    assert engage[0] == ("rc", [cmd.IGNORE] * 8 + [1500] * 8 + [0, 0])        # neutral before pass-through
    assert [s[2] for s in engage[1:9]] == list(cmd.PASSTHROUGH_FUNCTIONS)
    link.sent.clear()
    link.state.mode = 2                                        # the pilot selects ALT_HOLD
    c.on_mode_change(True, 2)
    assert [s[1][8:16] for s in link.sent if s[0] == "rc"] == [[1500] * 8] * 3
    assert not [s for s in link.sent if s[0] == "param"]       # not yet: the neutral must reach the outputs
    time.sleep(cmd.MOTORS_AFTER_S)
    c.gate()
    assert [s[2] for s in link.sent if s[0] == "param"][:8] == list(cmd.MOTOR_FUNCTIONS)
    assert not [s for s in link.sent if s[0] == "rc" and s[1][8] == cmd.RELEASE_HIGH]
    c._release_due = time.monotonic()                          # (RELEASE_AFTER_S later)
    c.gate()
    assert link.sent[-1] == ("rc", cmd.release_channels("servo"))


def test_rc_hands_back_neutral_then_released():
    c, link, _fw = _engaged("rc")
    link.sent.clear()
    c.on_mode_change(False, MANUAL)                            # disarmed
    rc = [s[1] for s in link.sent if s[0] == "rc"]
    assert rc[:3] == [cmd.neutral_channels("rc")] * 3 and rc[3:] == [cmd.release_channels("rc")] * 3
    assert "WK: released overrides (disarmed)" in _texts(link)


def _hal(link):
    c, _ = _commander("rc")
    clock = type("Clock", (), {"now_ns": lambda self: 0})()
    return MAVLinkAutopilotHAL(link, c, clock, 0.5, 101325.0, 1025.0)


def test_a_repeated_barometer_reading_is_no_new_depth():
    """ArduSub reads its barometer at 10 Hz and repeats it in a 20 Hz SCALED_PRESSURE2 stream."""
    link = RecordingLink()
    link.attitude()
    hal = _hal(link)
    link.state.samples["SCALED_PRESSURE2"] = Sample((1516.0,), 1000, time.monotonic(), 1)
    first = hal.read_sensors()
    link.state.samples["SCALED_PRESSURE2"] = Sample((1516.0,), 1050, time.monotonic(), 2)   # the same reading
    second = hal.read_sensors()
    link.state.samples["SCALED_PRESSURE2"] = Sample((1517.0,), 1100, time.monotonic(), 3)
    third = hal.read_sensors()
    assert first.depth == pytest.approx((151600 - 101325) / (1025 * 9.80665))
    assert math.isnan(second.depth) and second.healthy            # no new reading, but the sensor is there
    assert third.depth > first.depth


def test_the_accelerometer_is_read_from_raw_imu_once_a_sample():
    """RAW_IMU's accelerometer (mG, body FRD, gravity in it) is the aided estimator's specific force: [0, −g] at
    rest, a sample once (a repeated message is no new measurement), none without the stream."""
    link = RecordingLink()
    link.attitude()
    hal = _hal(link)
    none = hal.read_sensors()
    assert math.isnan(none.acc_x) and math.isnan(none.acc_z)
    link.state.samples["RAW_IMU"] = Sample((0.0, 0.0, -1000.0), -1, time.monotonic(), 1)
    rest = hal.read_sensors()
    assert rest.acc_x == 0.0 and rest.acc_z == pytest.approx(-9.80665)
    again = hal.read_sensors()
    assert math.isnan(again.acc_x) and math.isnan(again.acc_z)
    link.state.samples["RAW_IMU"] = Sample((102.0, 5.0, -950.0), -1, time.monotonic(), 2)
    moving = hal.read_sensors()
    assert moving.acc_x == pytest.approx(1.0002783) and moving.acc_z == pytest.approx(-9.3163175)


def test_depth_noise_follows_the_barometer_read():
    link = RecordingLink(params={"SIM_BAR2_RND": 0.2})
    assert _depth_noise(argparse.Namespace(depth_noise="auto"), link) == pytest.approx(0.2 / math.sqrt(3))
    assert _depth_noise(argparse.Namespace(depth_noise="auto"), RecordingLink()) is None     # a real Bar30
    assert _depth_noise(argparse.Namespace(depth_noise="0.05"), link) == 0.05


def test_stand_in_pass_through_ignores_arming_and_reassigns_at_one_hertz():
    """What ArduSub does: a pass-through output follows its override whether armed or not, until it is released
    or expires (RC_OVERRIDE_TIME); a new SERVOn_FUNCTION takes effect at the next whole second."""
    params = load_params("params")
    aux = AuxOutputs(params, 8)
    assert aux.passthrough(10.2) == {}                          # motors
    for n in range(1, 9):
        params.set(f"SERVO{n}_FUNCTION", 58 + n)
    aux.rc_override(9, 1804, 10.3)
    assert aux.passthrough(10.4) == {}                          # still motors until ArduSub's 1 Hz loop
    assert aux.passthrough(11.0)[0] == 1804                     # (the firmware asks it disarmed too)
    assert aux.passthrough(11.0 + params["RC_OVERRIDE_TIME"])[0] == 1500     # expired


def test_engaged_without_a_position_it_holds_every_axis_once_the_estimate_converges():
    """Its first frame had no position fix (σ_x 10 m): depth and pitch only, then GUIDED on the station it
    engaged at as soon as the estimate converges (it stayed in depth hold for a whole flight, drifting 10 m)."""
    fw = _Fw()
    fw.ekf.initialise(SensorFrame(0.0, math.nan, 5.0, 0.0, 0.0))
    c, link = _commander("servo", fw)
    link.attitude()
    link.state.armed, link.state.mode = True, MANUAL
    c.selected = True
    c.gate()
    assert c.engaged and c.depth_only and fw.mode == 2
    for k in range(1, 40):                                   # position fixes come in
        fw.ekf.update(SensorFrame(0.05 * k, 0.2, 5.0, 0.0, 0.0))
    fw.setpoint = np.array([0.2, 5.0, 0.0])                  # (GUIDED's entry takes the pose)
    c.gate()
    assert fw.mode == 4 and not c.depth_only and fw.setpoint.tolist() == [0.0, 5.0, 0.0]
    assert "WK: position estimate converged: holding every axis" in _texts(link)
