"""The six-DoF claims per wave direction, from a campaign's rows (``configs/campaign/directions.yaml``).

    python -m benchmarks.directional_summary runs/directions/missions.csv [--out F.json]

Variants are named ``{cpd,ff,mpc}_d{DIRECTION}_{lc,s10}``: the law, the relative wave direction (deg) and the
spreading (long-crested, or cos-2s with s = 10). For each direction and spreading, over every (case, seed):

* **FF against C-PD, the MPC against FF**, paired by case and seed. A pair's reduction is the mean over the
  DoF *the sea loads* of 100 (1 − RMSE / RMSE_baseline), where a DoF is loaded when the baseline's RMSE is
  above the noise the held vehicle shows in a sea that does not load it (2 cm in y, 0.2° in roll and yaw;
  x, z and pitch always): in a head sea y, roll and yaw are the loops' answer to sensor noise, and no law
  reduces noise. The mean over all six DoF is reported beside it. Mean, seeded percentile bootstrap
  95 % interval, worst pair and the share of pairs won.
* **Safety:** the worst roll and pitch of any mission (deg); the mean share of ticks saturated.

The checks are the issue's: FF's loaded-DoF reduction ≥ 40 % against C-PD in every direction and spreading,
the MPC's ≥ 25 % against FF, no mission past 20° in roll or pitch, no mission failed.
"""
from __future__ import annotations

import argparse
import json
import math
import re
from collections import defaultdict
from pathlib import Path

import numpy as np

from benchmarks.common import emit_checks
from sitl.harness.stats import bootstrap_ci

DOFS = ("x", "y", "z", "roll", "pitch", "yaw")
NOISE_FLOOR = {"y": 0.02, "roll": math.radians(0.2), "yaw": math.radians(0.2)}
"""Baseline RMSE at or below which a DoF is noise, not a load (m, rad; the planar limit's bounds)."""
VARIANT = re.compile(r"^(cpd|ff|mpc)_d(-?\d+)_(lc|s\d+)$")
BASELINE = {"ff": "cpd", "mpc": "ff"}


def read_missions(path: str | Path) -> list[dict]:
    """A campaign's rows: ``missions.csv`` (strings) or ``missions.jsonl`` (typed)."""
    p = Path(path)
    if p.suffix == ".jsonl":
        return [json.loads(line) for line in p.read_text(encoding="utf-8").splitlines() if line.strip()]
    import csv

    with open(p, newline="", encoding="utf-8") as fh:
        return list(csv.DictReader(fh))


def _num(row: dict, key: str) -> float:
    v = row.get(key)
    try:
        return float(v) if v not in (None, "") else math.nan
    except (TypeError, ValueError):
        return math.nan


def pair_reduction(base: dict, row: dict) -> tuple[float, float]:
    """(mean over the loaded DoF, mean over all six) of 100 (1 − RMSE / RMSE_base) for one (case, seed)."""
    loaded, every = [], []
    for d in DOFS:
        b, v = _num(base, f"six_dof_rmse_{d}"), _num(row, f"six_dof_rmse_{d}")
        r = 100.0 * (1.0 - v / b) if b > 0 else math.nan
        every.append(r)
        if b > NOISE_FLOOR.get(d, 0.0):
            loaded.append(r)
    return float(np.mean(loaded)) if loaded else math.nan, float(np.mean(every))


def _stats(values: list[float], resamples: int = 10_000) -> dict:
    v = [x for x in values if math.isfinite(x)]
    lo, hi = bootstrap_ci(v, resamples, 0)
    return {"n": len(v), "mean_pct": float(np.mean(v)) if v else math.nan, "ci95_pct": [lo, hi],
            "worst_pct": float(np.min(v)) if v else math.nan,
            "share_won": float(np.mean(np.asarray(v) > 0.0)) if v else math.nan}


def summarise(rows: list[dict]) -> dict:
    """Per (direction, spreading): the reductions, the worst attitude, saturation; and the checks."""
    by: dict[tuple[str, str, str], dict[tuple[str, str], dict]] = defaultdict(dict)
    failed = []
    for r in rows:
        m = VARIANT.match(str(r.get("variant", "")))
        if not m:
            continue
        if r.get("status") != "ok":
            failed.append(r.get("mission_id"))
            continue
        law, direction, spread = m.groups()
        by[(direction, spread, law)][(str(r["case"]), str(r["seed"]))] = r
    out: dict[str, dict] = {}
    worst_att = 0.0
    for direction, spread in sorted({(d, s) for d, s, _ in by}, key=lambda k: (int(k[0]), k[1])):
        entry: dict = {}
        for law, base in BASELINE.items():
            rows_v, rows_b = by.get((direction, spread, law), {}), by.get((direction, spread, base), {})
            pairs = [pair_reduction(rows_b[k], rows_v[k]) for k in sorted(rows_v) if k in rows_b]
            entry[f"{law}_vs_{base}"] = {"loaded_dof": _stats([p[0] for p in pairs]),
                                         "all_dof_mean_pct": float(np.nanmean([p[1] for p in pairs]))
                                         if pairs else math.nan}
        for law in ("cpd", "ff", "mpc"):
            rs = list(by.get((direction, spread, law), {}).values())
            att = [max(_num(r, "six_dof_max_abs_error_roll"), _num(r, "six_dof_max_abs_error_pitch")) for r in rs]
            worst = math.degrees(max(att)) if att else math.nan
            worst_att = max(worst_att, worst) if math.isfinite(worst) else worst_att
            entry[law] = {"missions": len(rs), "worst_roll_or_pitch_deg": worst,
                          "saturated_fraction_mean": float(np.mean([_num(r, "saturated_fraction") for r in rs]))
                          if rs else math.nan,
                          "rmse_mean": {d: float(np.mean([_num(r, f"six_dof_rmse_{d}") for r in rs])) if rs
                                        else math.nan for d in DOFS}}
        out[f"{direction}_{spread}"] = entry
    ff = [e["ff_vs_cpd"]["loaded_dof"]["mean_pct"] for e in out.values()]
    mpc = [e["mpc_vs_ff"]["loaded_dof"]["mean_pct"] for e in out.values()]
    checks = {
        "ff_40pct_every_direction": {"pass": bool(ff) and min(ff) >= 40.0, "min_pct": min(ff) if ff else None},
        "mpc_25pct_every_direction": {"pass": bool(mpc) and min(mpc) >= 25.0, "min_pct": min(mpc) if mpc else None},
        "attitude_within_20deg": {"pass": worst_att <= 20.0, "worst_deg": worst_att},
        "no_mission_failed": {"pass": not failed, "failed": failed},
    }
    return {"directions": out, "checks": checks}


def table(doc: dict) -> str:
    """The per-direction summary as a text table."""
    lines = [f"{'dir':>5} {'spread':>6} | {'FF vs C-PD %':>13} {'CI95':>13} {'worst':>6} | "
             f"{'MPC vs FF %':>12} {'CI95':>13} {'worst':>6} | {'max att °':>9} C-PD/FF/MPC | sat FF"]
    for key, e in doc["directions"].items():
        d, s = key.split("_")
        f, m = e["ff_vs_cpd"]["loaded_dof"], e["mpc_vs_ff"]["loaded_dof"]
        ci = lambda c: f"[{c[0]:.1f}, {c[1]:.1f}]"   # noqa: E731
        att = "/".join(f"{e[law]['worst_roll_or_pitch_deg']:.1f}" for law in ("cpd", "ff", "mpc"))
        lines.append(f"{d:>5} {s:>6} | {f['mean_pct']:>13.1f} {ci(f['ci95_pct']):>13} {f['worst_pct']:>6.1f} | "
                     f"{m['mean_pct']:>12.1f} {ci(m['ci95_pct']):>13} {m['worst_pct']:>6.1f} | {att:>21} | "
                     f"{e['ff']['saturated_fraction_mean']:.2f}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("missions", help="the campaign's missions.csv or missions.jsonl")
    ap.add_argument("--out", help="write the summary JSON here")
    args = ap.parse_args(argv)
    doc = summarise(read_missions(args.missions))
    print(table(doc))
    return emit_checks(doc, args.out)


if __name__ == "__main__":
    raise SystemExit(main())
