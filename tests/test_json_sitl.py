"""ArduPilot JSON SITL: the physics server and the firmware's UDP HAL, over real loopback UDP."""
from __future__ import annotations

import json
import os
import signal
import socket
import struct
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from bridge.forecast import derive_seeds, oracle_forecast
from bridge.json_sitl import MAGIC_16, MAGIC_32, decode_state
from bridge.schemas import load_mission_config, load_vehicle_config
from firmware_py.firmware import Firmware
from firmware_py.hal.clocks import WallClock
from firmware_py.hal.json_sitl import JSONSITLHAL
from firmware_py.modes import Mode
from firmware_py.params.table import load_params
from sitl.harness.run import TIMESERIES_COLUMNS, run_mission
from sitl.harness.spec import RunSpec
from sitl.physics_server import PhysicsServer, PortInUseError
from sitl.plant import Plant
from sitl.sea import Sea

ROOT = Path(__file__).resolve().parents[1]
RATE = 20
H = 1.0 / RATE


@pytest.fixture(scope="module")
def sea_w1():
    """W1 in the paper's plane: these tests check the wire format against the planar state's closed forms (a
    six-DoF world's replies: tests/test_plant6.py and tests/test_six_dof_firmware.py)."""
    return Sea.load("W1", overrides={"dof": "planar"})


@pytest.fixture
def server(sea_w1):
    srv = PhysicsServer(lambda: Plant.from_configs(sea_w1), port=0)
    srv.start()
    yield srv
    srv.stop()


@pytest.fixture
def client(server):
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.settimeout(2.0)
    sock.connect(("127.0.0.1", server.port))
    yield sock
    sock.close()


def servo(count, pwm=None, rate=RATE, channels=16, magic=None):
    pwm = list(pwm or [1500] * 8)
    pwm = pwm + [0] * (channels - len(pwm))
    magic = magic if magic is not None else (MAGIC_16 if channels == 16 else MAGIC_32)
    return struct.pack(f"<HHI{channels}H", magic, rate, count, *pwm)


def exchange(sock, pkt) -> dict:
    sock.send(pkt)
    raw = sock.recv(65536)
    assert raw.startswith(b"\n") and raw.endswith(b"\n") and raw.count(b"\n") == 2
    return json.loads(raw)


def no_reply(sock, wait=0.15) -> bool:
    sock.settimeout(wait)
    try:
        sock.recv(65536)
    except TimeoutError:
        return True
    finally:
        sock.settimeout(2.0)
    return False


# ---------------------------------------------------------------------------- protocol
def test_hello_reply_has_arducopter_fields_and_rest_accel(client, server):
    msg = exchange(client, servo(0))
    assert msg["timestamp"] == 0.0
    for key in ("position", "velocity", "attitude"):
        assert len(msg[key]) == 3
    assert len(msg["imu"]["gyro"]) == 3
    np.testing.assert_allclose(msg["imu"]["accel_body"], [0.0, 0.0, -9.81], atol=1e-12)
    np.testing.assert_allclose(msg["position"], [0.0, 0.0, 5.0])    # station: x 0, 5 m deep
    wk = msg["wavekeep"]
    assert wk["eta"] == [0.0, 5.0, 0.0] and wk["nu"] == [0.0, 0.0, 0.0] and len(wk["thrust"]) == 8
    assert wk["frame_count"] == 0
    assert server.counters.steps == 0 and server.counters.replies == 1


def test_steps_hold_pwm_for_one_frame_and_report_consistent_state(client, server):
    exchange(client, servo(0))
    for k in range(1, 4):
        msg = exchange(client, servo(k, [1600, 1400, 1500, 1500, 1550, 1450, 1500, 1500]))
        assert msg["timestamp"] == pytest.approx(k * H, abs=1e-12)
    s = server.snapshot()
    wk = msg["wavekeep"]
    assert wk["eta"] == s.eta.tolist() and wk["nu"] == s.nu.tolist() and wk["thrust"] == s.thrust.tolist()
    _x, _z, th = s.eta
    u, w, q = s.nu
    du, dw, _ = server.plant.nu_dot
    g = server.plant.vehicle.g
    np.testing.assert_allclose(msg["imu"]["accel_body"],
                               [du + q * w + g * np.sin(th), 0.0, dw - q * u - g * np.cos(th)], rtol=1e-12)
    np.testing.assert_allclose(msg["velocity"], [u * np.cos(th) + w * np.sin(th), 0.0,
                                                 -u * np.sin(th) + w * np.cos(th)], rtol=1e-12)
    assert msg["attitude"] == [0.0, th, 0.0] and msg["imu"]["gyro"] == [0.0, q, 0.0]
    # the thrusters were driven: channel 1 at 1600 µs pushes its thruster positive
    assert s.thrust[0] > 0 and s.thrust[1] < 0


def test_frame_count_backwards_restarts_the_world(client, server):
    exchange(client, servo(0))
    for k in (1, 2, 3):
        exchange(client, servo(k))
    first_plant = server.plant
    msg = exchange(client, servo(1))
    assert msg["timestamp"] == 0.0 and server.counters.restarts == 1
    assert server.plant is not first_plant
    assert exchange(client, servo(2))["timestamp"] == pytest.approx(H)


def test_frame_rate_change_restarts_the_world(client, server):
    exchange(client, servo(0))
    exchange(client, servo(1))
    assert exchange(client, servo(2, rate=50))["timestamp"] == 0.0
    assert exchange(client, servo(3, rate=50))["timestamp"] == pytest.approx(0.02)
    assert server.counters.restarts == 1


def test_duplicate_resends_the_same_reply_without_stepping(client, server):
    exchange(client, servo(0))
    client.send(servo(1))
    a = client.recv(65536)
    client.send(servo(1, [1900] * 8))          # a retransmission; its PWM is not applied again
    b = client.recv(65536)
    assert a == b
    assert server.counters.duplicates == 1 and server.counters.steps == 1


def test_gap_counts_missed_frames_and_catches_up(client, server):
    """Lockstep time is frame_count / frame_rate: a gap of lost frames is stepped through."""
    exchange(client, servo(0))
    exchange(client, servo(1))
    msg = exchange(client, servo(5))
    assert msg["timestamp"] == pytest.approx(5 * H)
    assert server.counters.missed == 3 and server.counters.steps == 5


def test_32_channel_packets(client, server):
    assert exchange(client, servo(0, channels=32))["timestamp"] == 0.0
    msg = exchange(client, servo(1, [1700] * 8 + [1234] * 24, channels=32))
    assert msg["timestamp"] == pytest.approx(H) and server.counters.malformed == 0


def test_zero_pwm_means_neutral(sea_w1):
    replies = []
    for pwm in ([0] * 8, [1500] * 8):
        with PhysicsServer(lambda: Plant.from_configs(sea_w1), port=0) as srv:
            sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            sock.settimeout(2.0)
            sock.connect(("127.0.0.1", srv.port))
            exchange(sock, servo(0))
            replies.append(exchange(sock, servo(1, pwm)))
            sock.close()
    assert replies[0] == replies[1]


def test_malformed_packets_are_dropped_and_counted(client, server):
    exchange(client, servo(0))
    exchange(client, servo(1))
    before = server.snapshot()
    bad = [
        servo(2)[:-2],                              # short
        servo(2) + b"\x00",                          # long
        servo(2, magic=12345),                       # wrong magic
        servo(2, channels=16, magic=MAGIC_32),       # 32-channel magic on a 16-channel packet
        servo(2, rate=0),                            # zero frame rate
        servo(2, rate=60000),                        # absurd frame rate
        servo(2, [1500] * 7 + [3000]),               # thruster PWM out of range
        b"",
    ]
    for pkt in bad:
        client.send(pkt)
    assert no_reply(client)
    after = server.snapshot()
    assert after.t == before.t and np.array_equal(after.eta, before.eta) and np.array_equal(after.nu, before.nu)
    assert server.counters.malformed == len(bad) and server.counters.steps == 1
    # the session carries on where it was
    assert exchange(client, servo(2))["timestamp"] == pytest.approx(2 * H)
    assert server.counters.restarts == 0


def test_reply_is_readable_by_ardupilots_parser(client):
    """SIM_JSON.cpp finds keys by substring and reads vectors right after '"key":'."""
    exchange(client, servo(0))
    client.send(servo(1))
    line = client.recv(65536).strip()
    text = line.decode()
    assert b" " not in line                      # compact: '"gyro":[' as sscanf("[%f, ...") needs
    for key in ("timestamp", "gyro", "accel_body", "position", "attitude", "velocity"):
        assert text.count(f'"{key}"') == 1
        assert text.index(f'"{key}"') < text.index('"wavekeep"')
    for absent in ("quaternion", "rng_", "airspeed", "windvane", "no_time_sync", "no_lockstep", "NaN"):
        assert absent not in text


def test_port_in_use_is_a_clear_error(server, sea_w1):
    with pytest.raises(PortInUseError, match=f"port {server.port} is in use"):
        PhysicsServer(lambda: Plant.from_configs(sea_w1), port=server.port)


def test_parse_state_without_wavekeep_fields(client):
    exchange(client, servo(0))
    for k in range(1, 6):
        client.send(servo(k, [1700, 1300, 1500, 1500, 1650, 1350, 1500, 1500]))
        raw = client.recv(65536)
    msg = json.loads(raw)
    exact = decode_state(raw)
    del msg["wavekeep"]
    derived = decode_state(json.dumps(msg))
    assert derived.timestamp == exact.timestamp and derived.thrust is None and derived.frame_count is None
    np.testing.assert_allclose(derived.eta, exact.eta, atol=1e-12)
    np.testing.assert_allclose(derived.nu, exact.nu, atol=1e-12)


# ---------------------------------------------------------------------------- firmware over UDP
def build_json_firmware(address, case="W1", controller="cpd_ff", timeout_s=None, speedup=None, sea_set=None):
    """sitl.harness.run.build_mission, with the JSON SITL HAL in place of the in-process one."""
    sea = Sea.load(case, overrides=sea_set)
    mcfg, vcfg = load_mission_config("station_keeping"), load_vehicle_config("bluerov2_heavy")
    params = load_params().copy()
    params.set("WK_FF_ENABLE", 1 if controller == "cpd_ff" else 0)
    rate = mcfg["control_rate"]
    sp = mcfg["setpoint"]
    setpoint = np.array([sp["x"], sp["depth"], sp["pitch"]])
    sensor_seed, forecast_seed = derive_seeds(sea.seed)
    hal = JSONSITLHAL(address, params, 1.0 / rate, sensor_seed, timeout_s=timeout_s, speedup=speedup)
    fw = Firmware.from_configs(hal, params, vcfg, mcfg)
    if controller == "cpd_ff":
        fw.forecast.offer(oracle_forecast(sea.components, None, np.random.default_rng(forecast_seed)))
    return hal, fw, setpoint


def take_off(hal, fw, setpoint):
    """run_mission's start: hello, the first tick (EKF initialised), GUIDED, target, arm."""
    hal.start()
    fw.scheduler.run_tick()
    assert fw.request_mode(Mode.GUIDED) == 0
    fw.set_target(*setpoint)
    result, why = fw.request_arm(True)
    assert result == 0, why


@pytest.mark.parametrize("sea_set", [{}, {"depth_sensor.dynamic_pressure": True},
                                     {"dof": "six", "spreading.direction": 45.0}],
                         ids=["nominal", "bar30_dynamic", "six_dof_oblique"])
def test_mission_over_json_sitl_is_identical_to_in_process(sea_set):
    """Lockstep over UDP equals the in-process mission, also when the depth sensor reads the waves'
    dynamic pressure (sent in ``wavekeep.pressure_depth``), and in an oblique sea in six DoF, where the
    firmware holds the lateral plane on ``wavekeep.lateral`` and the six-DoF accelerometer."""
    duration = 10.0
    ref = run_mission(RunSpec("W1", "cpd_ff", duration=duration, sea=sea_set)).timeseries
    sea = Sea.load("W1", overrides=sea_set)
    server = PhysicsServer(lambda: Plant.from_configs(sea), port=0)
    server.start()
    try:
        _fly_and_compare(server, duration, ref, sea_set)
    finally:
        server.stop()


def _fly_and_compare(server, duration, ref, sea_set=None):
    hal, fw, setpoint = build_json_firmware(("127.0.0.1", server.port), sea_set=sea_set)
    try:
        take_off(hal, fw, setpoint)
        n = int(round(duration * RATE)) - 1
        rows = []
        for _ in range(n):
            s = hal.state
            fw.scheduler.run_tick()
            rows.append([s.t, *s.eta, *s.nu, *fw.last.mix.pwm])
    finally:
        hal.close()
    got = np.array(rows)
    col = {c: i for i, c in enumerate(TIMESERIES_COLUMNS)}
    truth = [col[c] for c in ("t", "x", "z", "theta", "u", "w", "q")]
    pwm = [col[f"pwm{i}"] for i in range(1, 9)]
    assert got.shape[0] == ref.shape[0]
    assert np.max(np.abs(got[:, :7] - ref[:, truth])) <= 1e-9
    assert np.array_equal(got[:, 7:], ref[:, pwm])
    assert np.any(ref[:, pwm] != 1500)                       # the thrusters did work
    # lockstep: one step per tick, hello not stepped, nothing lost
    c = server.counters
    assert c.steps == n + 1 and c.malformed == c.missed == c.duplicates == c.restarts == 0
    assert hal.counters.timeouts == 0 and hal.counters.stale == 0
    assert fw.scheduler.overruns == 0 and fw.scheduler.skipped_slots == 0
    assert server.snapshot().t == pytest.approx(duration, abs=1e-9)


def test_paced_run_on_a_lockstep_paced_clock(server):
    """--speedup: the firmware paces on the wall clock; the grid starts at the hello's time (0)."""
    ticks = 20
    ref = run_mission(RunSpec("W1", "cpd_ff", duration=ticks * H, sea={"dof": "planar"})).timeseries  # the server's
    hal, fw, setpoint = build_json_firmware(("127.0.0.1", server.port), speedup=5.0)
    try:
        hal.start()
        time.sleep(0.05)                                   # the clock waits for the loop's first slot
        fw.scheduler.run_tick()
        assert fw.scheduler.t0_ns == 0
        fw.request_mode(Mode.GUIDED)
        fw.set_target(*setpoint)
        assert fw.request_arm(True)[0] == 0
        w0 = time.monotonic()
        pwm = []
        for _ in range(ticks - 1):
            fw.scheduler.run_tick()
            pwm.append(fw.last.mix.pwm.copy())
        wall = time.monotonic() - w0
    finally:
        hal.close()
    assert wall >= (ticks - 2) * H / 5.0 * 0.9            # paced, not free-running
    if fw.scheduler.skipped_slots == 0:                    # a loaded machine may skip a slot
        col = [TIMESERIES_COLUMNS.index(f"pwm{i}") for i in range(1, 9)]
        assert np.array_equal(np.array(pwm), ref[:, col])
        assert hal.state.t == pytest.approx(ticks * H)


def test_a_real_clock_swapped_in_is_not_moved_by_replies(server):
    """A launcher may start in lockstep and swap in a real clock: replies must not make the HAL sleep."""
    hal = JSONSITLHAL(("127.0.0.1", server.port), load_params(), H, 1)
    try:
        hal.start()
        hal.clock = WallClock()
        w0 = time.monotonic()
        for _ in range(4):
            hal.write_pwm(np.full(8, 1500))
            assert hal.read_sensors().healthy
        assert time.monotonic() - w0 < 0.15           # not 4 × 50 ms of sleeping to the replies' times
        assert hal.state.t == pytest.approx(4 * H)
    finally:
        hal.close()


def test_start_times_out_without_a_plant():
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind(("127.0.0.1", 0))          # a port that never answers
    port = sock.getsockname()[1]
    hal = JSONSITLHAL(("127.0.0.1", port), load_params(), H, 1, timeout_s=0.05)
    try:
        with pytest.raises(TimeoutError, match=f"127.0.0.1:{port}"):
            hal.start(timeout_s=0.2)
    finally:
        hal.close()
        sock.close()


def test_silent_plant_goes_neutral_and_recovers_on_restart(sea_w1):
    factory = lambda: Plant.from_configs(sea_w1)  # noqa: E731
    srv = PhysicsServer(factory, port=0).start()
    port = srv.port
    hal, fw, setpoint = build_json_firmware(("127.0.0.1", port), timeout_s=0.2)
    try:
        take_off(hal, fw, setpoint)
        for _ in range(20):
            fw.scheduler.run_tick()
        assert fw.sensors_healthy and np.any(hal.last_pwm != 1500)
        t_before = hal.state.t
        srv.stop()                                         # the plant goes silent

        w0 = time.monotonic()
        fw.scheduler.run_tick()                            # its PWM goes unanswered (0.2 s)
        fw.scheduler.run_tick()                            # sees the silence: neutral
        assert time.monotonic() - w0 < 0.2 + 0.2 + 0.5
        assert not fw.sensors_healthy and hal.silent
        assert np.all(hal.last_pwm == 1500)
        for _ in range(3):
            fw.scheduler.run_tick()
            assert not fw.sensors_healthy and np.all(hal.last_pwm == 1500)
        assert hal.counters.timeouts >= 4 and hal.counters.silences == 1
        assert fw.armed

        srv = PhysicsServer(factory, port=port).start()    # a new world on the same port
        for _ in range(3):
            fw.scheduler.run_tick()
        assert fw.sensors_healthy and not hal.silent
        assert hal.counters.physics_resets == 1
        assert hal.state.timestamp < 1.0 and hal.state.t > t_before   # vehicle time carried on
        for _ in range(20):
            fw.scheduler.run_tick()
        assert fw.sensors_healthy and np.any(hal.last_pwm != 1500)
        assert abs(hal.state.eta[1] - setpoint[1]) < 0.5
        assert srv.counters.steps >= 20
    finally:
        hal.close()
        srv.stop()


class DroppingServer(PhysicsServer):
    """Loses the packets whose frame_count is in ``drop``."""

    def __init__(self, *a, drop=(), **kw):
        super().__init__(*a, **kw)
        self.drop = set(drop)

    def handle(self, data, addr):
        if len(data) == 40 and struct.unpack_from("<I", data, 4)[0] in self.drop:
            self.counters.packets += 1
            return None
        return super().handle(data, addr)


def test_dropped_packets_make_frames_unhealthy_then_recover(sea_w1):
    srv = DroppingServer(lambda: Plant.from_configs(sea_w1), port=0, drop=range(12, 15)).start()
    hal, fw, setpoint = build_json_firmware(("127.0.0.1", srv.port), timeout_s=0.1)
    try:
        take_off(hal, fw, setpoint)                          # frame 1
        healthy = []
        for _ in range(20):                                  # frames 2..21
            fw.scheduler.run_tick()
            healthy.append(fw.sensors_healthy)
        # frames 12-14 get no answer: the ticks after them (reading frames 12-14's state) are unhealthy
        assert healthy == [True] * 11 + [False] * 3 + [True] * 6
        assert hal.counters.timeouts == 3 and hal.counters.physics_resets == 0
        assert srv.counters.missed == 3 and srv.counters.restarts == 0
        assert hal.state.t == pytest.approx(21 * H)          # 21 frames: the world kept frame time
    finally:
        hal.close()
        srv.stop()


# ---------------------------------------------------------------------------- command line
@pytest.mark.processes
def test_main_serves_until_sigterm():
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen([sys.executable, "-c", "import sys; from sitl.physics_server import main; "
                             "sys.exit(main(sys.argv[1:]))", "--case", "W1", "--port", "0"],
                            cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        line = proc.stdout.readline()
        assert line.startswith("wavekeep plant: ready on udp 127.0.0.1:"), line + proc.stderr.read()
        port = int(line.split(":")[2].split()[0])
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        sock.settimeout(5.0)
        sock.connect(("127.0.0.1", port))
        assert exchange(sock, servo(0))["timestamp"] == 0.0
        assert exchange(sock, servo(1))["timestamp"] == pytest.approx(H)
        sock.close()
        proc.send_signal(signal.SIGTERM)
        out, err = proc.communicate(timeout=10)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0, err
    assert "replies=2" in out and "steps=1" in out


def test_state_line_round_trips_floats_exactly():
    """encode_state → decode_state gives back every float bit for bit (orjson or json alike)."""
    from bridge.json_sitl import encode_state, state_message

    rng = np.random.default_rng(5)
    for _ in range(500):
        v = rng.normal(0, 10.0 ** rng.integers(-12, 6), 17)
        line = encode_state(state_message(float(abs(v[0])), v[1:4], v[4:7], v[7:10], v[9:17], 9.81, 3))
        r = decode_state(line)
        assert r.timestamp == float(abs(v[0])) and np.array_equal(r.eta, v[1:4]) and np.array_equal(r.nu, v[4:7])
        assert np.array_equal(r.thrust, v[9:17]) and r.frame_count == 3 and r.pressure_depth is None
    msg = state_message(1.0, np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(8), 9.81, pressure_depth=5.123456789)
    assert decode_state(encode_state(msg)).pressure_depth == 5.123456789
    msg["wavekeep"]["pressure_depth"] = "deep"
    with pytest.raises(ValueError):
        decode_state(encode_state(msg))
