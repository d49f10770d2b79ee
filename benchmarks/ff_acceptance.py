"""Issue #11's acceptance checks on a campaign's rows (variants ``cpd``, ``ff_exact``, ``ff_15db``).

    python -m benchmarks.ff_acceptance runs/robust_ff_30_seeds/missions.csv [--out results.json]

Per (case, seed), against C-PD on the same seed:
* no FF mission (a variant named ``ff…``) reaches 20° of pitch error;
* FF exact's maximum error is at most C-PD's + 2° in pitch and + 0.1 m in surge and heave;
* FF exact's mean RMSE reduction (over DoF and seeds) is at least 50 % in each case;
* FF 15 dB's mean RMSE reduction is above 0 in each case and in at least 90 % of (case, seed) pairs.
Means come with a seeded percentile bootstrap 95 % interval over seeds.
"""
from __future__ import annotations

import argparse
import csv
import json
import math
from pathlib import Path

import numpy as np

DOF = ("surge", "heave", "pitch")


def _bootstrap_ci(x: np.ndarray, resamples: int = 10_000, seed: int = 0) -> list[float]:
    rng = np.random.default_rng(seed)
    means = x[rng.integers(0, x.size, size=(resamples, x.size))].mean(axis=1)
    return [float(v) for v in np.percentile(means, [2.5, 97.5])]


def acceptance(rows: list[dict[str, str]]) -> dict:
    """The checks, and per case and variant the figures they rest on."""
    by = {(r["case"], int(r["seed"]), r["variant"]): r for r in rows if r["status"] == "ok"}
    cases = sorted({c for c, _, _ in by})
    seeds = sorted({s for _, s, _ in by})
    val = lambda c, s, v, key: float(by[(c, s, v)][key])  # noqa: E731
    pitch_deg = lambda c, s, v: math.degrees(val(c, s, v, "max_abs_error_pitch"))  # noqa: E731
    over_20 = [f"{c} seed {s} {v}: {pitch_deg(c, s, v):.1f}°" for (c, s, v) in sorted(by)
               if v.startswith("ff") and pitch_deg(c, s, v) >= 20.0]
    worse = []
    for c in cases:
        for s in seeds:
            if (c, s, "ff_exact") not in by or (c, s, "cpd") not in by:
                continue
            if pitch_deg(c, s, "ff_exact") > pitch_deg(c, s, "cpd") + 2.0:
                worse.append(f"{c} seed {s} pitch {pitch_deg(c, s, 'ff_exact'):.2f}° vs {pitch_deg(c, s, 'cpd'):.2f}°")
            for d in ("surge", "heave"):
                ff, cpd = val(c, s, "ff_exact", f"max_abs_error_{d}"), val(c, s, "cpd", f"max_abs_error_{d}")
                if ff > cpd + 0.1:
                    worse.append(f"{c} seed {s} {d} {ff:.3f} m vs {cpd:.3f} m")
    figures: dict = {}
    for v in ("ff_exact", "ff_15db"):
        figures[v] = {}
        every = []
        for c in cases:
            red = np.array([np.mean([100.0 * (1.0 - val(c, s, v, f"rmse_{d}") / val(c, s, "cpd", f"rmse_{d}"))
                                     for d in DOF]) for s in seeds if (c, s, v) in by and (c, s, "cpd") in by])
            if red.size == 0:
                continue
            every.extend(red.tolist())
            figures[v][c] = {"seeds": int(red.size), "mean_rmse_reduction_pct": float(red.mean()),
                             "ci95_pct": _bootstrap_ci(red), "min_pct": float(red.min()),
                             "share_of_seeds_won": float(np.mean(red > 0)),
                             "worst_max_pitch_deg": max(pitch_deg(c, s, v) for s in seeds if (c, s, v) in by)}
        figures[v]["share_of_pairs_won"] = float(np.mean(np.array(every) > 0)) if every else float("nan")
    checks = {
        "no_ff_mission_over_20deg_pitch": {"pass": not over_20, "failures": over_20},
        "ff_exact_max_error_within_cpd_margin": {"pass": not worse, "failures": worse},
        "ff_exact_mean_reduction_at_least_50pct_per_case": {
            "pass": all(f["mean_rmse_reduction_pct"] >= 50.0 for c, f in figures["ff_exact"].items() if c in cases)},
        "ff_15db_mean_reduction_above_0_per_case": {
            "pass": all(f["mean_rmse_reduction_pct"] > 0.0 for c, f in figures["ff_15db"].items() if c in cases)},
        "ff_15db_wins_in_90pct_of_pairs": {"pass": figures["ff_15db"]["share_of_pairs_won"] >= 0.9},
    }
    return {"missions": len(by), "cases": cases, "seeds": len(seeds), "checks": checks, "figures": figures}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("missions_csv", help="a campaign's missions.csv")
    ap.add_argument("--out", default=None, help="also write the document as JSON here")
    args = ap.parse_args(argv)
    with open(args.missions_csv, newline="", encoding="utf-8") as fh:
        doc = acceptance(list(csv.DictReader(fh)))
    text = json.dumps(doc, indent=1)
    if args.out:
        Path(args.out).write_text(text + "\n", encoding="utf-8")
    print(text)
    return 0 if all(c["pass"] for c in doc["checks"].values()) else 1


if __name__ == "__main__":
    raise SystemExit(main())
