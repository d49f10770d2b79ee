"""The robust-FF claims in the corrected world (Froude–Krylov + added mass) beside the paper's world.

    wavekeep campaign configs/campaign/corrected_world_20_seeds.yaml --out runs/corrected_world
    python -m benchmarks.corrected_world runs/corrected_world/missions.csv [--out benchmarks/results/...json]

From the campaign's rows: :func:`benchmarks.ff_acceptance.acceptance` for each world (no tip, the worst
case against C-PD, the mean reduction, the 15 dB wins, with saturation share and power), the mean RMSE
and worst maximum error per case, variant and DoF, and the share of saturated ticks against the paper's
world. Then, flown here (seed 1, 600 s, C-PD, per case and world), the RMS of the true wave load τ_E on
the vehicle: how much harder the corrected sea pushes.
"""
from __future__ import annotations

import argparse
import csv
import json
import math
from pathlib import Path

import numpy as np

from benchmarks.ff_acceptance import DOF, acceptance

WORLDS = {"corrected": "", "paper": "_paper"}


def rmse_table(rows: list[dict[str, str]]) -> dict:
    """Per world, case and variant: the mean RMSE and the worst maximum error per DoF (m, m, deg) over seeds."""
    out: dict = {}
    for world, sfx in WORLDS.items():
        for v in ("cpd", "ff_exact", "ff_15db"):
            sel = [r for r in rows if r["status"] == "ok" and r["variant"] == v + sfx]
            for case in sorted({r["case"] for r in sel}):
                rs = [r for r in sel if r["case"] == case]
                conv = lambda d, x: math.degrees(x) if d == "pitch" else x  # noqa: E731
                out.setdefault(world, {}).setdefault(case, {})[v] = {
                    "seeds": len(rs),
                    "rmse_mean": {d: conv(d, float(np.mean([float(r[f"rmse_{d}"]) for r in rs]))) for d in DOF},
                    "max_error_worst": {d: conv(d, max(float(r[f"max_abs_error_{d}"]) for r in rs)) for d in DOF},
                    "saturated_fraction_mean": float(np.mean([float(r["saturated_fraction"]) for r in rs])),
                }
    return out


def wave_load_rms(duration: float = 600.0) -> dict:
    """RMS of the true wave load τ_E (N, N, N m) on the C-PD vehicle, seed 1, per case and world."""
    from sitl.harness.reproduce import WORLDS as REPRO_WORLDS
    from sitl.harness.results import COLUMN
    from sitl.harness.run import run_mission
    from sitl.harness.spec import PAPER_CASES, RunSpec

    out: dict = {}
    for case in PAPER_CASES:
        for world, (_, fields) in REPRO_WORLDS.items():
            spec = RunSpec(case=case, controller="cpd", seed=1, duration=duration, sea=fields["sea"],
                           overrides=fields["overrides"])
            log = run_mission(spec).timeseries
            out.setdefault(case, {})[world] = {a: float(np.sqrt(np.mean(log[:, COLUMN[f"tauE_{a}"]] ** 2)))
                                               for a in ("X", "Z", "M")}
        out[case]["ratio"] = {a: out[case]["corrected"][a] / out[case]["paper"][a] for a in ("X", "Z", "M")}
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("missions_csv")
    ap.add_argument("--out", default="benchmarks/results/corrected_world_20_seeds.json")
    ap.add_argument("--no-loads", action="store_true", help="skip flying the six wave-load missions")
    args = ap.parse_args(argv)
    with open(args.missions_csv, newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    doc = {"campaign": "configs/campaign/corrected_world_20_seeds.yaml",
           "acceptance": {world: acceptance(rows, sfx) for world, sfx in WORLDS.items()},
           "table": rmse_table(rows)}
    if not args.no_loads:
        doc["wave_load_rms"] = wave_load_rms()
    Path(args.out).write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")
    for world, acc in doc["acceptance"].items():
        print(world, {k: c["pass"] for k, c in acc["checks"].items()})
    return 0 if all(c["pass"] for acc in doc["acceptance"].values() for c in acc["checks"].values()) else 1


if __name__ == "__main__":
    raise SystemExit(main())
