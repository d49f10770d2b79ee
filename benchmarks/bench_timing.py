"""Loop timing on the wall clock: start jitter of the 20 Hz loop over 60 s, idle, under a hostile-datagram fuzz,
and with both cores loaded, with and without SCHED_FIFO (where permitted).

    python -m benchmarks.bench_timing [--seconds 60]     # writes benchmarks/results/timing.json

"Fuzz" is a second process that answers the vehicle's first datagram from the ground station's port and then
sends it 500 datagrams a second, in turn random bytes, valid frames cut short, frames with a bad CRC and
valid-CRC messages with hostile fields (NaN and out-of-range parameters, unknown commands, extreme pilot
input): what the link must parse, count and survive without delaying the loop.

The loop is the real one: world + firmware (C-PD+FF over 200 components) + MAVLink
link in :class:`sitl.harness.live.LiveSim`, paced at real time by LockstepPacedClock,
whose wake-up errors are the start jitter. "Loaded" runs two busy processes,
one per core, for the duration (stopped at the end).
"""
from __future__ import annotations

import argparse
import multiprocessing as mp
import time

from benchmarks.common import write
from sitl.harness.ports import free_port as _free_port


def _burn(stop_at: float) -> None:
    x = 0
    while time.monotonic() < stop_at:
        x += 1




def _fuzz(port: int, stop_at: float, rate_hz: float = 500.0) -> None:
    """The hostile ground station of the module docstring, on ``port`` until ``stop_at`` (monotonic s)."""
    import os
    import random
    import socket
    os.environ["MAVLINK20"] = "1"
    from pymavlink.dialects.v20 import ardupilotmega as m
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", port))
    s.settimeout(30.0)
    _, vehicle = s.recvfrom(4096)
    mav = m.MAVLink(None, srcSystem=255, srcComponent=190)
    hostile = [msg.pack(mav) for msg in (
        m.MAVLink_param_set_message(1, 1, b"WK_KP_X", float("nan"), 9),
        m.MAVLink_param_set_message(1, 1, b"FS_GCS_TIMEOUT", 1e30, 9),
        m.MAVLink_command_long_message(1, 1, 65000, 0, *[float("inf")] * 7),
        m.MAVLink_manual_control_message(1, 32767, -32768, 32767, -32768, 65535),
        m.MAVLink_request_data_stream_message(1, 1, 255, 65535, 1),
        m.MAVLink_param_request_read_message(1, 1, b"\xff" * 16, -1))]
    rng = random.Random(1)
    k, t0 = 0, time.monotonic()
    while time.monotonic() < stop_at:
        frame = hostile[k % len(hostile)]
        data = (bytes(rng.getrandbits(8) for _ in range(rng.randint(1, 280))), frame[:rng.randint(1, len(frame) - 1)],
                frame[:-1] + bytes([frame[-1] ^ 0xFF]), frame)[k % 4]
        s.sendto(data, vehicle)
        k += 1
        delay = t0 + k / rate_hz - time.monotonic()
        if delay > 0:
            time.sleep(delay)


def one(seconds: float, loaded: bool, realtime: bool, fuzz: bool = False) -> dict:
    from sitl.harness.live import LiveSim
    from sitl.harness.spec import RunSpec

    burners = []
    ctx = mp.get_context("spawn")
    if loaded:
        burners = [ctx.Process(target=_burn, args=(time.monotonic() + seconds + 15,), daemon=True) for _ in range(2)]
    gcs = _free_port()
    if fuzz:
        burners.append(ctx.Process(target=_fuzz, args=(gcs, time.monotonic() + seconds + 15), daemon=True))
    for b in burners:
        b.start()
    try:
        with LiveSim(RunSpec("W3", "cpd_ff"), mavlink=[f"udpout:127.0.0.1:{gcs}"], speedup=1.0,
                     realtime=realtime) as sim:
            time.sleep(seconds)
            clock = sim.firmware.hal.clock
            stats = sim.firmware.scheduler.stats()
            out = {"loaded": loaded, "fuzz": fuzz, "scheduling": sim.scheduling, "seconds": seconds,
                   "link_rx_bad": sim.link.counters.get("rx_bad", 0), "link_rx": sim.link.counters.get("rx", 0),
                   "start_jitter": clock.wake_error.percentiles_us(), "late_slots": clock.late,
                   "max_lag_ms": clock.max_lag_ns / 1e6, "ticks": stats["ticks"],
                   "control_compute": stats["tasks"]["control"]["compute"]}
    finally:
        for b in burners:
            b.terminate()
            b.join(5)
    return out


def main(seconds: float = 60.0) -> dict:
    one(5.0, False, False)      # a first mission in the process loads its kernels: not part of any figure
    runs = [one(seconds, False, False), one(seconds, False, False, fuzz=True), one(seconds, True, False),
            one(seconds, True, True)]
    path = write("timing", {"runs": runs})
    print("20 Hz loop start jitter (µs)          p50      p99      max   late slots")
    for r in runs:
        j = r["start_jitter"]
        name = "loaded" if r["loaded"] else "fuzz" if r["fuzz"] else "idle"
        print(f"  {name:<7} {r['scheduling']:<28}{j['p50_us']:8.0f} {j['p99_us']:8.0f} "
              f"{j['max_us']:8.0f} {r['late_slots']:8d}")
    print(f"wrote {path}")
    return {"runs": runs}


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--seconds", type=float, default=60.0)
    main(ap.parse_args().seconds)
