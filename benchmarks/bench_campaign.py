"""Campaign throughput on this machine: missions per hour with 1 and 2 Dask workers, and the scaling efficiency.

    python -m benchmarks.bench_campaign [--duration 60] [--seeds 4]   # writes benchmarks/results/campaign.json

The same grid (W1–W3 × {C-PD, FF exact, FF 15 dB} × seeds 1..N, missions of
``--duration`` s) runs as a fresh campaign on a loopback LocalCluster of 1, then
2 workers (one thread each). Reported per worker count: the campaign's wall
time including cluster start (s), missions per hour over that wall time and
over the steady state (first to last mission finished), and the mean mission
time on a worker (s). Efficiency = rate(2) / (2 × rate(1)), on the steady-state
rates. From the per-mission time, the wall time of the paper's 270-mission
campaign (600 s missions) on 2 workers is extrapolated: 270 × (per-mission time
on 2 workers, scaled to 600 s: a mission's cost grows linearly with its
duration) / 2. Other load on the machine shows in ``machine.load_avg``.
"""
from __future__ import annotations

import argparse
import io
import tempfile

import numpy as np

from benchmarks.common import write
from sitl.harness.campaign import run_campaign
from sitl.harness.reproduce import paper_campaign


def one(workers: int, seeds: int, duration: float) -> dict:
    """Run the grid on ``workers`` local workers; its timings."""
    spec = paper_campaign(seeds, duration)
    with tempfile.TemporaryDirectory() as tmp:
        report = run_campaign(spec, tmp, workers=workers, plots=False, stream=io.StringIO())
    rows = report.rows
    assert report.failed == 0 and len(rows) == len(spec.tasks()), "benchmark missions failed"
    finished = np.sort([r["finished_at"] for r in rows])
    first_start = min(r["finished_at"] - r["task_wall_s"] for r in rows)
    steady = finished[-1] - first_start
    return {"workers": workers, "missions": len(rows), "mission_duration_s": duration,
            "wall_s": report.wall_s, "missions_per_hour": 3600.0 * len(rows) / report.wall_s,
            "steady_s": float(steady), "missions_per_hour_steady": 3600.0 * len(rows) / float(steady),
            "mean_task_s": float(np.mean([r["task_wall_s"] for r in rows])),
            "workers_used": sorted({str(r["worker"]) for r in rows})}


def main(duration: float = 60.0, seeds: int = 4) -> dict:
    runs = {str(w): one(w, seeds, duration) for w in (1, 2)}
    eff = runs["2"]["missions_per_hour_steady"] / (2.0 * runs["1"]["missions_per_hour_steady"])
    per_600 = runs["2"]["mean_task_s"] * 600.0 / duration
    paper_h = 270 * per_600 / 2.0 / 3600.0      # two workers side by side, each at the measured per-mission time
    figures = {"runs": runs, "scaling_efficiency_2_workers": eff,
               "estimated_600s_mission_task_s": per_600, "estimated_paper_270_campaign_h_2_workers": paper_h}
    path = write("campaign", figures)
    print(f"campaign throughput, {runs['1']['missions']} missions of {duration:g} s each")
    for w, r in runs.items():
        print(f"  {w} worker(s): {r['wall_s']:.1f} s wall (with cluster start) = {r['missions_per_hour']:.0f} "
              f"missions/h; steady {r['missions_per_hour_steady']:.0f} missions/h; {r['mean_task_s']:.2f} s/mission")
    print(f"  scaling efficiency with 2 workers: {100 * eff:.0f} %")
    print(f"  paper campaign (270 x 600 s) on 2 workers: ≈ {paper_h:.2f} h "
          f"({per_600:.1f} s per 600 s mission)")
    print(f"wrote {path}")
    return figures


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--duration", type=float, default=60.0, help="simulated seconds per mission")
    ap.add_argument("--seeds", type=int, default=4, help="seeds per (case, variant): 9 x seeds missions")
    a = ap.parse_args()
    main(a.duration, a.seeds)
