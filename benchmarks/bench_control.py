"""Control tick cost and mission speed.

    python -m benchmarks.bench_control        # writes benchmarks/results/control.json

* one control tick (sensors → EKF → C-PD+FF over all wave components →
  allocation → PWM), p50/p99/max in µs, from the scheduler's own compute-time
  statistics over a 600 s W3 mission (the in-process plant runs outside the
  task, see ``InProcessSITLHAL.step_world``);
* in-process mission speed as a multiple of real time;
* ``wavekeep reproduce`` wall time (nine 600 s missions, one process per core).
Aims (issue #3): tick p99 under 1 ms; reproduce under 30 s on the 2-core machine.
"""
from __future__ import annotations

import tempfile
import time

from benchmarks.common import write
from sitl.harness.reproduce import reproduce
from sitl.harness.run import run_mission
from sitl.harness.spec import RunSpec


def main(with_reproduce: bool = True) -> dict:
    figures: dict = {"control_tick": {}, "mission": {}}
    for controller in ("cpd", "cpd_ff"):
        r = run_mission(RunSpec("W3", controller, duration=600.0)).results
        figures["control_tick"][controller] = r["control_tick"]
        figures["mission"][controller] = {"sim_s": r["duration_s"], "wall_s": r["wall_time_s"],
                                          "x_realtime": r["speed_x_realtime"], "tick_overruns": r["tick_overruns"]}
    if with_reproduce:
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.perf_counter()
            reproduce(tmp, plots=False, progress=lambda m: None)
            figures["reproduce_wall_s"] = time.perf_counter() - t0
    path = write("control", figures)
    print("control tick (µs)       p50      p99      max")
    for k, v in figures["control_tick"].items():
        print(f"  {k:<8}         {v['p50_us']:8.1f} {v['p99_us']:8.1f} {v['max_us']:8.1f}")
    for k, v in figures["mission"].items():
        print(f"600 s W3 {k:<7} in-process: {v['wall_s']:.1f} s wall ({v['x_realtime']:.0f}x real time)")
    if with_reproduce:
        print(f"wavekeep reproduce (9 x 600 s): {figures['reproduce_wall_s']:.1f} s wall")
    print(f"wrote {path}")
    return figures


if __name__ == "__main__":
    main()
