"""Issue #11's acceptance checks on a campaign's rows (variants ``cpd``, ``ff_exact``, ``ff_15db``).

    python -m benchmarks.ff_acceptance runs/robust_ff_30_seeds/missions.csv [--out results.json] [--suffix S]

``--suffix S`` checks the variants ``cpd S``, ``ff_exact S`` and ``ff_15db S`` of a campaign that flies the
same grid twice (``configs/campaign/corrected_world_20_seeds.yaml``: ``_paper`` is the paper's world).
Each variant's figures also give its mean share of saturated ticks and its mean power per case.

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


def acceptance(rows: list[dict[str, str]], suffix: str = "") -> dict:
    """The checks, and per case and variant the figures they rest on (variants named ``cpd{suffix}`` etc.)."""
    names = {f"{v}{suffix}": v for v in ("cpd", "ff_exact", "ff_15db")}
    by = {(r["case"], int(r["seed"]), names[r["variant"]]): r for r in rows
          if r["status"] == "ok" and r["variant"] in names}
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
    figures: dict = {"cpd": {c: _usage(by, c, seeds, "cpd") for c in cases}}
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
                             "worst_max_pitch_deg": max(pitch_deg(c, s, v) for s in seeds if (c, s, v) in by),
                             **_usage(by, c, seeds, v)}
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


def _usage(by: dict, case: str, seeds: list[int], variant: str) -> dict:
    """A variant's mean share of saturated ticks and mean total power (W, surge + heave + pitch) over seeds."""
    rows = [by[(case, s, variant)] for s in seeds if (case, s, variant) in by]
    sat = [float(r["saturated_fraction"]) for r in rows if r.get("saturated_fraction", "") != ""]
    power = [sum(float(r[f"mean_power_w_{d}"]) for d in DOF) for r in rows]
    return {"saturated_fraction_mean": float(np.mean(sat)) if sat else float("nan"),
            "mean_power_w": float(np.mean(power)) if power else float("nan")}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("missions_csv", help="a campaign's missions.csv")
    ap.add_argument("--out", default=None, help="also write the document as JSON here")
    ap.add_argument("--suffix", default="", help="check the variants cpd SUFFIX, ff_exact SUFFIX, ff_15db SUFFIX")
    args = ap.parse_args(argv)
    with open(args.missions_csv, newline="", encoding="utf-8") as fh:
        doc = acceptance(list(csv.DictReader(fh)), args.suffix)
    text = json.dumps(doc, indent=1)
    if args.out:
        Path(args.out).write_text(text + "\n", encoding="utf-8")
    print(text)
    return 0 if all(c["pass"] for c in doc["checks"].values()) else 1


if __name__ == "__main__":
    raise SystemExit(main())
