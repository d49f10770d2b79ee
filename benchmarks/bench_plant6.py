"""The six-DoF world's cost: one plant step against the planar world's, compiled and on the numpy reference.

    python -m benchmarks.bench_plant6        # writes benchmarks/results/plant6.json

W3 with 200 components, one ``Plant.step`` at 20 Hz (the flow at the strips, the RK4 step, the loads after it):
the planar world (3 strips), the six-DoF world (3 × 3 strips) in the head sea and in a sea spread by s = 10
about 45°, and the six-DoF world on the numpy reference (``Body6(compiled=False)``).
"""
from __future__ import annotations

import numpy as np

from benchmarks.common import percentiles_us, timed, write
from bridge.models.body6 import Body6
from sitl.plant import Plant
from sitl.sea import Sea


def step_cost(label: str, overrides: dict, repeat: int = 3000, reference: bool = False) -> dict:
    plant = Plant.from_configs(Sea.load("W3", overrides=overrides))
    if reference and plant.body6 is not None:
        plant.body6 = Body6(plant.body6.params, plant.body6.n_x, plant.body6.n_y, compiled=False)
        repeat = 300
    pwm = np.full(8, 1500.0)
    pwm[4:] = 1540.0
    for _ in range(50):
        plant.step(pwm, 0.05)
    return {"world": label, "sea": overrides, **percentiles_us(timed(lambda: plant.step(pwm, 0.05), repeat))}


def main() -> dict:
    rows = [step_cost("planar", {"dof": "planar"}), step_cost("six, head sea", {"dof": "six"}),
            step_cost("six, s = 10 about 45°", {"dof": "six", "spreading.s": 10.0, "spreading.direction": 45.0}),
            step_cost("six, numpy reference", {"dof": "six"}, reference=True)]
    planar = rows[0]["p50_us"]
    for r in rows:
        r["p50_over_planar"] = r["p50_us"] / planar
    path = write("plant6", {"step": rows})
    print("plant step, W3, 200 components (µs)   p50      p99   × planar")
    for r in rows:
        print(f"  {r['world']:<30} {r['p50_us']:8.1f} {r['p99_us']:8.1f} {r['p50_over_planar']:8.2f}")
    print(f"wrote {path}")
    return {"step": rows}


if __name__ == "__main__":
    main()
