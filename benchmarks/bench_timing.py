"""Loop timing on the wall clock: start jitter of the 20 Hz loop over 60 s, idle and with both cores loaded,
with and without SCHED_FIFO (where permitted).

    python -m benchmarks.bench_timing [--seconds 60]     # writes benchmarks/results/timing.json

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




def one(seconds: float, loaded: bool, realtime: bool) -> dict:
    from sitl.harness.live import LiveSim
    from sitl.harness.spec import RunSpec

    burners = []
    if loaded:
        ctx = mp.get_context("spawn")
        burners = [ctx.Process(target=_burn, args=(time.monotonic() + seconds + 15,), daemon=True) for _ in range(2)]
        for b in burners:
            b.start()
    try:
        with LiveSim(RunSpec("W3", "cpd_ff"), mavlink=[f"udpout:127.0.0.1:{_free_port()}"], speedup=1.0,
                     realtime=realtime) as sim:
            time.sleep(seconds)
            clock = sim.firmware.hal.clock
            stats = sim.firmware.scheduler.stats()
            out = {"loaded": loaded, "scheduling": sim.scheduling, "seconds": seconds,
                   "start_jitter": clock.wake_error.percentiles_us(), "late_slots": clock.late,
                   "max_lag_ms": clock.max_lag_ns / 1e6, "ticks": stats["ticks"],
                   "control_compute": stats["tasks"]["control"]["compute"]}
    finally:
        for b in burners:
            b.terminate()
            b.join(5)
    return out


def main(seconds: float = 60.0) -> dict:
    runs = [one(seconds, False, False), one(seconds, True, False), one(seconds, True, True)]
    path = write("timing", {"runs": runs})
    print("20 Hz loop start jitter (µs)          p50      p99      max   late slots")
    for r in runs:
        j = r["start_jitter"]
        print(f"  {'loaded' if r['loaded'] else 'idle':<7} {r['scheduling']:<28}{j['p50_us']:8.0f} {j['p99_us']:8.0f} "
              f"{j['max_us']:8.0f} {r['late_slots']:8d}")
    print(f"wrote {path}")
    return {"runs": runs}


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--seconds", type=float, default=60.0)
    main(ap.parse_args().seconds)
