"""Faults injected on the links (a real UDP relay): the vehicle keeps flying, and what was lost is counted."""
from __future__ import annotations

import contextlib
import socket
import struct
import time

import numpy as np
import pytest

from sitl.faultrelay import FaultRelay, Faults
from sitl.physics_server import PhysicsServer
from sitl.plant import Plant
from sitl.sea import Sea
from tests.test_json_sitl import build_json_firmware, take_off


def echo_server():
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    s.settimeout(0.05)
    return s


def exchange(relay: FaultRelay, server: socket.socket, payloads: list[bytes], wait: float = 0.3) -> list[bytes]:
    client = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    client.settimeout(0.05)
    for p in payloads:
        client.sendto(p, ("127.0.0.1", relay.port))
        time.sleep(0.002)
    got, end = [], time.monotonic() + wait
    while time.monotonic() < end:
        with contextlib.suppress(TimeoutError):
            got.append(server.recv(100))
    client.close()
    return got


@pytest.mark.parametrize("faults, check", [
    (Faults(), lambda got, sent: got == sent),
    (Faults(drop=1.0), lambda got, sent: got == []),
    (Faults(duplicate=1.0), lambda got, sent: got == [p for p in sent for _ in range(2)]),
    (Faults(drop=0.3), lambda got, sent: 0 < len(got) < len(sent) and set(got) <= set(sent)),
    (Faults(reorder=0.5), lambda got, sent: sorted(got) == sorted(sent) and got != sent),
])
def test_relay_injects_what_it_is_told(faults, check):
    server = echo_server()
    sent = [f"{i:03d}".encode() for i in range(40)]
    with FaultRelay(server.getsockname(), faults, seed=3) as relay:
        got = exchange(relay, server, sent)
    server.close()
    assert check(got, sent), got


def test_relay_delays():
    server = echo_server()
    with FaultRelay(server.getsockname(), Faults(delay_s=0.1), seed=1) as relay:
        client = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        t0 = time.monotonic()
        client.sendto(b"x", ("127.0.0.1", relay.port))
        server.settimeout(1.0)
        assert server.recv(10) == b"x"
        assert time.monotonic() - t0 >= 0.09
        client.close()
    server.close()


def test_firmware_keeps_flying_over_a_lossy_plant_link():
    """5 % drops, duplicates and reorders both ways plus 0–3 ms of delay between firmware and plant:
    every lost reply is a timeout (thrusters neutral for that tick), counted; the vehicle keeps station."""
    sea = Sea.load("W1")
    server = PhysicsServer(lambda: Plant.from_configs(sea), port=0).start()
    faults = Faults(drop=0.05, duplicate=0.05, reorder=0.05, delay_s=0.001, jitter_s=0.002)
    relay = FaultRelay(("127.0.0.1", server.port), faults, seed=7).start()
    hal, fw, setpoint = build_json_firmware(("127.0.0.1", relay.port), timeout_s=0.03)
    try:
        take_off(hal, fw, setpoint)
        errors = []
        for _ in range(400):                       # 20 s of vehicle time
            fw.scheduler.run_tick()
            if hal.state is not None:
                errors.append(np.abs(hal.state.eta - setpoint))
    finally:
        hal.close()
        relay.stop()
        server.stop()
    stats = fw.scheduler.stats()
    assert stats["tasks"]["control"]["errors"] == 0
    lost = relay.counters()
    assert lost["up"]["dropped"] + lost["down"]["dropped"] > 0
    assert hal.counters.timeouts > 0                         # lost replies were noticed …
    assert hal.counters.replies > 300                        # … and the link kept working
    assert server.counters.duplicates > 0 or server.counters.missed > 0
    assert any("Sensors lost" in text for _, text in fw.events) or hal.counters.silences > 0
    err = np.array(errors)
    assert err[:, 0].max() < 1.0 and err[:, 1].max() < 1.0 and err[:, 2].max() < np.radians(15)


def test_hal_survives_bad_replies_from_the_plant():
    """A fake physics server answers with NaN fields, missing fields, garbage and a timestamp
    that goes backwards: the HAL counts and ignores the bad ones (frames unhealthy → neutral)
    and carries the vehicle's time on through a physics reset."""
    import json
    import threading

    from firmware_py.hal.json_sitl import JSONSITLHAL
    from firmware_py.params.table import load_params

    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind(("127.0.0.1", 0))
    sock.settimeout(0.2)

    def state(t, count, **over):
        msg = {"timestamp": t, "imu": {"gyro": [0, 0, 0], "accel_body": [0, 0, -9.81]},
               "position": [0.0, 0.0, 5.0], "velocity": [0, 0, 0], "attitude": [0, 0, 0],
               "wavekeep": {"eta": [0.0, 5.0, 0.0], "nu": [0, 0, 0], "frame_count": count}}
        msg.update(over)
        return ("\n" + json.dumps(msg) + "\n").encode()

    script = [
        lambda c: state(0.0, c),                                          # hello
        lambda c: state(0.05, c),
        lambda c: state(float("nan"), c),                                 # NaN timestamp
        lambda c: state(0.15, c, wavekeep={"eta": [float("nan"), 5, 0], "nu": [0, 0, 0], "frame_count": c}),
        lambda c: b"\n{not json\n",
        lambda c: ("\n" + json.dumps({"timestamp": 0.25}) + "\n").encode(),   # fields missing
        lambda c: state(0.02, c),                                         # physics went back: a reset
        lambda c: state(0.07, c),
    ]
    stop = threading.Event()

    def serve():
        i = 0
        while not stop.is_set() and i < len(script):
            try:
                data, addr = sock.recvfrom(200)
            except TimeoutError:
                continue
            count = struct.unpack_from("<HHI", data)[2]
            sock.sendto(script[i](count), addr)
            i += 1
    th = threading.Thread(target=serve, daemon=True)
    th.start()
    hal = JSONSITLHAL(("127.0.0.1", sock.getsockname()[1]), load_params(), 0.05, 1, timeout_s=0.1)
    try:
        hal.start()
        frames = []
        for _ in range(len(script) - 1):
            hal.write_pwm(np.full(8, 1500))
            frames.append(hal.read_sensors())
    finally:
        stop.set()
        hal.close()
        sock.close()
    assert hal.counters.malformed >= 4
    assert frames[0].healthy and not frames[1].healthy                # the NaN reply is not a state
    assert hal.counters.physics_resets == 1
    assert frames[-1].healthy and frames[-1].t > frames[0].t        # vehicle time carried on
