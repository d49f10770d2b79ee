"""Plant cost: one step versus wave components × strips, and 600 s open-loop runs.

    python -m benchmarks.bench_plant        # writes benchmarks/results/plant.json
"""
from __future__ import annotations

import time

import numpy as np

from benchmarks.common import percentiles_us, timed, write
from bridge.models.vehicle import strip_nodes
from sitl.plant import Plant
from sitl.sea import Sea, load_sea_config


def step_cost(components: int, strips: int, repeat: int = 2000) -> dict:
    cfg = load_sea_config("W3")
    cfg["components"] = components
    cfg["dof"] = "planar"          # strips along the length: the planar world's (the six-DoF one: bench_plant6)
    plant = Plant.from_configs(Sea.from_config(cfg))
    plant.strips = strip_nodes(plant.vehicle.length, strips)
    pwm = np.full(8, 1500.0)
    for _ in range(50):
        plant.step(pwm, 0.05)
    return {"components": components, "strips": strips, **percentiles_us(timed(lambda: plant.step(pwm, 0.05), repeat))}


def open_loop_run(case: str, duration: float = 600.0) -> dict:
    sea = Sea.still_water() if case == "still" else Sea.load(case)
    plant = Plant.from_configs(sea)
    pwm = np.full(8, 1500.0)
    n = int(duration * 20)
    t0 = time.perf_counter()
    for _ in range(n):
        plant.step(pwm, 0.05)
    wall = time.perf_counter() - t0
    return {"case": case, "sim_s": duration, "wall_s": wall, "x_realtime": duration / wall}


def main() -> dict:
    figures = {
        "step": [step_cost(n, s) for n in (100, 200, 400) for s in (1, 3, 6)],
        "open_loop_600s": [open_loop_run("still"), open_loop_run("W3")],
    }
    path = write("plant", figures)
    print("plant step (µs)        p50      p99      max")
    for r in figures["step"]:
        print(f"  N={r['components']:>3} strips={r['strips']}  "
              f"{r['p50_us']:8.1f} {r['p99_us']:8.1f} {r['max_us']:8.1f}")
    for r in figures["open_loop_600s"]:
        print(f"600 s open loop, {r['case']:>5}: {r['wall_s']:.2f} s wall ({r['x_realtime']:.0f}x real time)")
    print(f"wrote {path}")
    return figures


if __name__ == "__main__":
    main()
