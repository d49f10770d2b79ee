"""CPU time of in-process missions, and where a tick goes: the DSWP update, the firmware, the plant.

    python -m benchmarks.bench_mission_cpu [--duration 600] [--reps 1] [--before OLD_TREE]

For each forecast (oracle, dswp; W2 C-PD+FF, seed 1) it flies one mission and reports the
mission's CPU time (``time.process_time``: less sensitive than wall time to a shared machine's
load), the CPU ms of a DSWP forecast update and the CPU µs per tick of ``run_tick`` and
``step_world``. ``--before OLD_TREE`` runs the same measurement with OLD_TREE's own
``.venv/bin/python`` in a fresh process, interleaved run by run with this tree, and reports
the ratios. BLAS runs on one thread, as in a campaign worker. Writes ``results/mission_cpu.json``.
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ENV = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


def measure(forecast: str, duration: float) -> dict:
    """One W2 C-PD+FF mission flown as ``run_mission`` flies it, timed piece by piece (CPU s)."""
    from firmware_py.modes import Mode
    from sitl.harness.run import build_mission
    from sitl.harness.spec import RunSpec

    c0 = time.process_time()
    m = build_mission(RunSpec("W2", "cpd_ff", duration=duration, forecast=forecast, seed=1))
    fw, hal = m.firmware, m.hal
    fw.scheduler.run_tick()
    hal.step_world()
    fw.request_mode(Mode.GUIDED)
    fw.set_target(*m.setpoint)
    fw.request_arm(True)
    fw.refresh_prediction()
    n = int(round(m.duration_s * m.rate_hz)) - 1
    clock, feed, firm, plant = time.process_time, 0.0, 0.0, 0.0
    for _ in range(n):
        t0 = clock()
        if m.feeder is not None:
            m.feeder.advance(m.plant.state.t)
        t1 = clock()
        fw.scheduler.run_tick()
        t2 = clock()
        hal.step_world()
        t3 = clock()
        feed, firm, plant = feed + t1 - t0, firm + t2 - t1, plant + t3 - t2
    updates = m.feeder.seq if m.feeder is not None else 0
    return {"mission_cpu_s": clock() - c0, "dswp_update_ms": feed / updates * 1e3 if updates else None,
            "firmware_tick_us": firm / n * 1e6, "plant_tick_us": plant / n * 1e6}


def _child(tree: Path | None, forecast: str, duration: float) -> dict:
    """:func:`measure` in a fresh process of ``tree``'s interpreter (None: this tree's). The script runs
    by its path, so ``sitl`` and ``firmware_py`` are the ones that interpreter has installed."""
    python = str(tree / ".venv" / "bin" / "python") if tree else sys.executable
    env = {**os.environ, **ENV, "PYTHONDONTWRITEBYTECODE": "1"}
    if tree:   # the old tree's compiled kernels go to a cache of their own, not into its tree
        env["NUMBA_CACHE_DIR"] = str(Path("/tmp") / f"numba-cache-{tree.name}")
    out = subprocess.run([python, __file__, "--child", forecast, "--duration", str(duration)],
                         capture_output=True, text=True, check=True, env=env, cwd="/tmp")
    return json.loads(out.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--duration", type=float, default=600.0)
    ap.add_argument("--reps", type=int, default=1)
    ap.add_argument("--before", type=Path, default=None, help="an older tree with its own .venv")
    ap.add_argument("--child", choices=("oracle", "dswp"), help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:                         # one measurement, after a short warm-up mission
        measure(args.child, 5.0)
        print(json.dumps(measure(args.child, args.duration)))
        return {}
    figures: dict = {"duration_s": args.duration, "case": "W2", "controller": "cpd_ff", "seed": 1}
    for forecast in ("oracle", "dswp"):
        runs: dict[str, list[dict]] = {"after": [], "before": []}
        for _ in range(args.reps):
            if args.before:
                runs["before"].append(_child(args.before.resolve(), forecast, args.duration))
            runs["after"].append(_child(None, forecast, args.duration))
        row = {}
        for which, rs in runs.items():
            if rs:
                row[which] = {k: (None if rs[0][k] is None else float(np.median([r[k] for r in rs])))
                              for k in rs[0]}
        figures[forecast] = row
        print(forecast, json.dumps(row))
    from benchmarks.common import write

    path = write("mission_cpu", figures)
    print(f"wrote {path}")
    return figures


if __name__ == "__main__":
    main()
