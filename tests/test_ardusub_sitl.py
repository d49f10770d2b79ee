"""The real ArduSub SITL in Wavekeep's world, and Wavekeep's companion flying it (``WAVEKEEP_ARDUSUB``).

One boot for the module (:class:`ardusub_sitl.SubRig`, the tests run in order on
the same vehicle): ArduSub's own depth and holds first, then the companion on its
second link. Each test guards one of the failures first seen when the real
binary flew here:

1. depth: a vehicle that boots at depth reads depth 0 there; the plant starts it
   at the surface (home altitude 0), and ArduSub's depth then follows the truth;
2. heading: a planar world never turns, so ArduSub's heading, roll and lateral
   holds wind up; the plant moves in sway, roll and yaw;
3. the companion's estimator: its depth noise is the barometer it reads;
4. hand-back in ``servo``: the pilot's mode has motors again;
5. a disarm or a frozen companion: what ArduSub does with pass-through outputs;
6. latency: telemetry to command, and to ArduSub's outputs.
"""
from __future__ import annotations

import math
import os
import signal
import time

import numpy as np
import pytest
from ardusub_sitl import (
    ALT_HOLD,
    GUIDED,
    MANUAL,
    STALE_S,
    SubRig,
    ardusub_binary,
    depth_of,
    motor_axes,
    servo_pwm,
)

pytestmark = pytest.mark.processes


@pytest.fixture(scope="module")
def sub(tmp_path_factory):
    binary = ardusub_binary()
    rig = SubRig(tmp_path_factory.mktemp("ardusub"), binary, speedup=8.0)
    yield rig
    rig.close()


def test_depth_is_zero_at_the_surface_and_follows_the_plant_down(sub):
    """ArduSub zeroes depth at boot: the vehicle boots at the surface, so its depth is the truth's."""
    assert sub.truth.eta[1] == 0.0                              # held at the surface while it boots
    m = sub.gcs.wait_type("GLOBAL_POSITION_INT", timeout=10)
    assert abs(depth_of(m)) < 0.15, depth_of(m)
    sub.mode(GUIDED)                                            # once its EKF has a position
    sub.arm()
    sub.goto_station(5.0)                                      # after arming: ArduSub drops a target sent before
    assert sub.wait_truth(lambda s: abs(s.eta[1] - 5.0) < 0.15, 60.0), sub.truth.eta
    msgs = sub.run_for(3.0)
    depths = [depth_of(m) for m in msgs if m.get_type() == "GLOBAL_POSITION_INT"]
    assert depths and abs(np.mean(depths) - sub.truth.eta[1]) < 0.1, (np.mean(depths), sub.truth.eta)


def test_heading_roll_and_sway_holds_do_not_wind_up(sub):
    """Holding station for 30 s, ArduSub's yaw, lateral and roll commands stay small (a planar plant that never
    turns let them creep past 50 µs in 20 s and on without bound)."""
    msgs = sub.run_for(30.0)
    out = sub.outputs(msgs)
    late = out[out[:, 0] > out[-1, 0] - 10.0, 1:]
    axes = [motor_axes(p) for p in late]
    # µs: the mean command over the last 10 s (planar, 40 s after arming: yaw −18, lateral −73, roll −22, growing)
    for axis, bound in (("yaw", 8.0), ("lateral", 25.0), ("roll", 8.0)):
        mean = float(np.mean([a[axis] for a in axes]))
        assert abs(mean) < bound, (axis, mean)
    psi = sub.server.plant.state.eta6[5]
    assert abs(math.degrees(psi)) < 5.0                            # and the heading is held


def test_companion_depth_noise_follows_the_barometer_it_reads(sub):
    """SITL's SCALED_PRESSURE2 has SIM_BAR2_RND of uniform noise: the companion's estimator takes RND/√3, not
    a Bar30's centimetre (which let its estimate diverge within a minute)."""
    sub.arm(False)
    sub.mode(MANUAL)
    sub.gcs.set_param("SIM_SPEEDUP", 3.0)                      # the companion's link runs on the wall clock
    rnd = sub.gcs.param("SIM_BAR2_RND").param_value
    sub.companion("servo")
    assert f"depth σ {rnd / math.sqrt(3):g} m" in sub.companion_log(), sub.companion_log()
    sub.arm()
    assert sub.wait_log("WK: engaged (servo)", 10.0), sub.companion_log()
    assert sub.wait_truth(lambda s: abs(s.eta[1] - 5.0) < 0.3, 40.0), sub.truth.eta
    sub.run_for(5.0)
    assert "not finite" not in sub.companion_log() and "released" not in sub.companion_log()
    assert abs(sub.truth.eta[1] - 5.0) < 0.5 and abs(math.degrees(sub.truth.eta[2])) < 15.0, sub.truth.eta


def test_servo_hand_back_gives_the_pilot_motors(sub):
    """The pilot selects ALT_HOLD: the companion releases (its pass-through outputs stop at once: 0 µs) and puts
    SERVO1-8_FUNCTION back to the motors, which ArduSub re-assigns in its 1 Hz loop: within about a second
    ALT_HOLD drives every thruster (pass-through left them at 0 µs for good, the vehicle rising) and holds."""
    since = sub.gcs.mark()
    sub.run_for(0.5)
    z0 = sub.truth.eta[1]
    sub.mode(ALT_HOLD)
    assert sub.wait_log("released overrides (pilot selected ALT_HOLD)", 2.0), sub.companion_log()
    sub.run_for(5.0)
    assert [int(sub.gcs.param(f"SERVO{n}_FUNCTION").param_value) for n in range(1, 9)] == list(range(33, 41))
    t_mode = _first_heartbeat_time(sub.gcs.log[since:], lambda m: m.custom_mode == ALT_HOLD)
    out = sub.outputs(sub.gcs.log[since:])
    last = out[out[:, 0] < t_mode][-1:, 1:]
    after = out[out[:, 0] > t_mode + 0.1, 1:]
    stuck = (np.abs(after - last).max(axis=1) < 0.5) & (after > 0).all(axis=1)
    assert not stuck.any(), after[:5]                  # never the companion's last command after a tick
    driven = out[out[:, 0] > t_mode + 1.2, 1:]
    assert driven.size and (driven > 1000).all(), driven[:3]
    assert abs(sub.truth.eta[1] - z0) < 0.5, (z0, sub.truth.eta)


def _first_heartbeat_time(msgs, pred) -> float:
    """The vehicle's clock (s) at the first HEARTBEAT of ArduSub matching ``pred``, from the SYSTEM_TIME before it."""
    t = None
    for m in msgs:
        if m.get_type() == "SYSTEM_TIME":
            t = m.time_boot_ms / 1000.0
        elif m.get_type() == "HEARTBEAT" and m.get_srcSystem() == 1 and pred(m) and t is not None:
            return t
    raise AssertionError("no such heartbeat")


def test_disarm_puts_the_outputs_to_neutral_at_once(sub):
    """ArduSub's pass-through ignores disarming (it keeps the companion's last PWM up to RC_OVERRIDE_TIME): the
    companion releases on the disarm, so within a tick or so no thruster gets thrust (0 µs, then the disarmed
    motors' 1500 once the functions are back)."""
    sub.mode(MANUAL)                                           # armed in MANUAL again: the companion engages
    assert sub.wait_count("WK: engaged", 2, 5.0), sub.companion_log()
    sub.run_for(2.0)
    since = sub.gcs.mark()
    sub.arm(False)
    msgs = sub.run_for(2.5)
    t_disarm = _first_heartbeat_time(sub.gcs.log[since:], lambda m: not m.base_mode & 128)
    out = sub.outputs(msgs)
    idle = ((out[:, 1:] == 0) | (out[:, 1:] == 1500)).all(axis=1)
    thrusting = out[~idle & (out[:, 0] > t_disarm), 0]
    assert thrusting.size == 0 or thrusting[-1] - t_disarm < 0.25, (t_disarm, thrusting[-3:])
    assert (out[-1, 1:] == 1500).all(), out[-1]
    assert "released overrides (disarmed)" in sub.companion_log()


def test_frozen_companion_outputs_expire_and_it_hands_back_when_it_resumes(sub):
    """A frozen companion: ArduSub keeps its last pass-through PWM for RC_OVERRIDE_TIME, then 0 µs (no pulse:
    the thrusters stop); when the companion runs again it hands back (motors restored) instead of resuming."""
    sub.arm()
    assert sub.wait_count("WK: engaged", 3, 5.0), sub.companion_log()
    sub.run_for(2.0)
    expiry = sub.gcs.param("RC_OVERRIDE_TIME").param_value
    released = sub.companion_log().count("WK: released overrides (")
    os.killpg(sub.companion_proc.pid, signal.SIGSTOP)
    try:
        t_stop, wall_stop = sub.now(), time.monotonic()
        msgs = sub.run_for(expiry + 1.5)
        time.sleep(max(0.0, wall_stop + STALE_S + 0.5 - time.monotonic()))   # frozen longer than its --stale
    finally:
        os.killpg(sub.companion_proc.pid, signal.SIGCONT)
    out = sub.outputs(msgs)
    live = out[(out[:, 1:] != 0).any(axis=1)]
    assert live.size and live[-1, 0] - t_stop < expiry + 0.3, (t_stop, live[-1])
    assert (out[-1, 1:] == 0).all(), out[-1]                          # expired: no pulse
    # on waking it finds its telemetry (or itself) seconds old: it hands back, whichever it notices first
    assert sub.wait_count("WK: released overrides (", released + 1, 3.0), sub.companion_log()
    assert sub.companion_log().rsplit("WK: ", 1)[-1].startswith(
        ("released overrides (companion stalled", "released overrides (stale telemetry")), sub.companion_log()
    sub.run_for(1.5)                                           # ArduSub re-assigns the outputs at 1 Hz
    assert int(sub.gcs.param("SERVO1_FUNCTION").param_value) == 33
    assert (np.array(servo_pwm(sub.gcs.wait_type("SERVO_OUTPUT_RAW", timeout=5))) > 1000).all()


def test_companion_commands_reach_ardusub_outputs_within_a_tick(sub):
    """Ticking on ArduSub's ATTITUDE, the companion answers in milliseconds of wall time, and each command is on
    ArduSub's outputs (servo: exact to the µs) well within the 50 ms period after the telemetry's stamp."""
    sub.companion_proc.send_signal(signal.SIGTERM)                  # it writes its logs as it exits
    assert sub.companion_proc.wait(20) == 0
    commands = np.loadtxt(sub.tmp / "companion_ticks.commands.csv", delimiter=",", skiprows=1, ndmin=2)
    assert np.median(commands[:, 1]) < 15.0, np.percentile(commands[:, 1], [50, 99])     # wall ms
    out = sub.outputs(sub.gcs.log)
    lags = first_seen(commands, out)
    assert len(lags) > 50, len(lags)
    assert np.median(lags) < 0.040, np.percentile(lags, [10, 50, 90])


def first_seen(commands: np.ndarray, out: np.ndarray) -> np.ndarray:
    """Per command (attitude_ms, latency, channels 9-16), the delay (s, the vehicle's clock) from the ATTITUDE it
    answered to the first 50 Hz SERVO_OUTPUT_RAW showing exactly its PWM (commands whose PWM recurs are left
    out: which one the outputs show is ambiguous)."""
    pwm = commands[:, 2:10]
    lags = []
    for k in range(len(commands)):
        if (np.abs(pwm - pwm[k]).max(axis=1) < 0.5).sum() != 1:
            continue
        shown = out[(np.abs(out[:, 1:] - pwm[k]).max(axis=1) < 0.5), 0]
        if shown.size:
            lags.append(shown[0] - commands[k, 0] / 1000.0)
    return np.array(lags)


def test_wavekeep_sim_flies_the_real_ardusub_in_one_command(tmp_path):
    """``wavekeep sim --autopilot ardusub:PATH``: boot at the surface, GUIDED dive in still water, the sea from its
    t = 0 for the mission; results from the plant's truth on the sea's clock."""
    import json
    import subprocess
    import sys

    binary = ardusub_binary()
    out = tmp_path / "run"
    done = subprocess.run([sys.executable, "-m", "sitl.harness.cli", "sim", "--autopilot", f"ardusub:{binary}",
                           "--case", "W1", "--duration", "10", "--out", str(out), "--no-plots"],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    r = json.loads((out / "results.json").read_text())
    assert r["label"] == "ArduSub GUIDED" and r["sea_start_s"] > 0 and r["duration_s"] == 10
    assert r["rmse"]["heave"] < 0.5 and r["rmse"]["surge"] < 0.5 and r["max_abs_error"]["pitch"] < math.radians(20)
    ts = np.loadtxt(out / "timeseries.csv", delimiter=",", skiprows=1, ndmin=2)
    assert ts.shape[0] == 199 and ts[0, 0] == pytest.approx(0.05)      # the sea's clock, 20 Hz
    assert "ArduSub GUIDED" in done.stdout
