"""Issue #18's table and figure: how much of FF's gain survives each error of a real site.

    python -m benchmarks.sea_errors runs/sea_errors [--figure docs/figures/sea_errors_reduction.png]

Reads a ``configs/campaign/sea_errors.yaml`` campaign folder (``campaign.json`` for each variant's
baseline, the journal ``missions.jsonl`` for the rows, so a campaign still running can be read).
Per FF variant and sea state, against the C-PD flown in the same world (the variant's ``baseline``),
paired by seed:

* the mean RMSE reduction over the three DoF (%), with a percentile bootstrap 95 % interval over seeds;
* FF's and C-PD's mean RMSE per DoF, and whether FF's is larger in any DoF ("worse");
* the share of seeds won (mean reduction above 0).

Writes the document as JSON to ``benchmarks/results/sea_errors.json``, prints the table as Markdown
(for docs/sea-errors.md) and draws the reduction against each error's level. A row missing from a
partial campaign is reported with the seeds it has.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from benchmarks.common import campaign_rows
from sitl.harness.stats import bootstrap_ci

DOF = ("surge", "heave", "pitch")
ROWS: tuple[tuple[str, str, str, str], ...] = (
    # (variant, row label, error family for the figure, level on that family's axis)
    ("ff_exact", "exact forecast", "forecast", "exact"),
    ("ff_15db", "the paper's 15 dB (synthetic)", "forecast", "15 dB"),
    ("ff_dswp", "DSWP, noise-free buoy", "forecast", "DSWP"),
    ("ff_dswp_buoy10db", "DSWP, 10 dB buoy", "forecast", "DSWP 10 dB"),
    ("ff_dswp_s30_d0", "DSWP, spread s = 30, 0°", "spread", "s30 0°"),
    ("ff_dswp_s10_d0", "DSWP, spread s = 10, 0°", "spread", "s10 0°"),
    ("ff_dswp_s30_d20", "DSWP, spread s = 30, 20°", "spread", "s30 20°"),
    ("ff_dswp_s10_d20", "DSWP, spread s = 10, 20°", "spread", "s10 20°"),
    ("ff_am_p20", "added mass +20 %", "model", "M_A +20%"),
    ("ff_am_m20", "added mass −20 %", "model", "M_A −20%"),
    ("ff_drag_p20", "drag +20 %", "model", "D +20%"),
    ("ff_drag_m20", "drag −20 %", "model", "D −20%"),
    ("ff_current03", "0.3 m/s current", "model", "current"),
    ("ff_bar30", "Bar30 dynamic pressure, corrected (WK_BARO_WAVE 1)", "depth", "corrected"),
    ("ff_bar30_raw", "Bar30 dynamic pressure, uncorrected (faded by the skill)", "depth", "uncorrected"),
)


def _rmse(row: dict) -> np.ndarray:
    return np.array([float(row[f"rmse_{d}"]) for d in DOF])


def row_figures(rows: list[dict], variant: str, baseline: str, case: str, resamples: int = 10_000) -> dict | None:
    """One (variant, case): the paired reduction statistics, or None when no seed has both missions.
    ``rows`` are mission rows (a journal's, or ``missions.csv``'s with their values as text)."""
    by = {(r["variant"], int(r["seed"])): r for r in rows if r["case"] == case and r["status"] == "ok"}
    seeds = sorted(s for v, s in by if v == variant and (baseline, s) in by)
    if not seeds:
        return None
    ff = np.array([_rmse(by[(variant, s)]) for s in seeds])
    base = np.array([_rmse(by[(baseline, s)]) for s in seeds])
    red = 100.0 * (1.0 - ff / base).mean(axis=1)
    lo, hi = bootstrap_ci(red, resamples=resamples)
    ff_mean, base_mean = ff.mean(axis=0), base.mean(axis=0)
    return {"seeds": len(seeds), "reduction_pct_mean": float(red.mean()), "ci95_pct": [lo, hi],
            "reduction_pct_min": float(red.min()), "share_of_seeds_won": float(np.mean(red > 0)),
            "ff_rmse_mean": dict(zip(DOF, ff_mean.tolist(), strict=True)),
            "cpd_rmse_mean": dict(zip(DOF, base_mean.tolist(), strict=True)),
            "worse_in": [d for d, a, b in zip(DOF, ff_mean, base_mean, strict=True) if a > b]}


def sea_errors(folder: Path, resamples: int = 10_000) -> dict:
    """The table's document from a campaign folder."""
    camp = json.loads((folder / "campaign.json").read_text(encoding="utf-8"))
    baselines = {v["name"]: v.get("baseline") or camp["baseline"] for v in camp["variants"]}
    rows = campaign_rows(folder)
    table = []
    for variant, label, family, level in ROWS:
        if variant not in baselines:
            continue
        cases = {c: row_figures(rows, variant, baselines[variant], c, resamples) for c in camp["cases"]}
        table.append({"variant": variant, "label": label, "family": family, "level": level,
                      "baseline": baselines[variant], "cases": cases})
    worse = [f"{r['variant']} {c}: {', '.join(f['worse_in'])}" for r in table for c, f in r["cases"].items()
             if f is not None and f["worse_in"]]
    return {"campaign": camp["name"], "cases": camp["cases"], "rows": table,
            "ff_never_worse_in_mean_rmse": {"pass": not worse, "failures": worse}}


def markdown(doc: dict) -> str:
    """The table: one row per error, per sea state the mean reduction [95 % CI] and the seeds won."""
    cases = doc["cases"]
    head = "| error | " + " | ".join(f"{c}: mean reduction [95 % CI], won" for c in cases) + " | worse than C-PD in |"
    lines = [head, "|---|" + "---|" * (len(cases) + 1)]
    for r in doc["rows"]:
        cells, worse = [], []
        for c in cases:
            f = r["cases"][c]
            if f is None:
                cells.append("not run")
                continue
            lo, hi = f["ci95_pct"]
            n = "" if f["seeds"] >= 20 else f" ({f['seeds']} seeds)"
            won = 100 * f["share_of_seeds_won"]
            cells.append(f"{f['reduction_pct_mean']:.1f} % [{lo:.1f}, {hi:.1f}], {won:.0f} %{n}")
            worse += [f"{c} {d}" for d in f["worse_in"]]
        lines.append(f"| {r['label']} | " + " | ".join(cells) + f" | {', '.join(worse) or 'none'} |")
    return "\n".join(lines)


def figure(doc: dict, path: Path) -> None:
    """Mean reduction (with its interval) against each error's level, one panel per error family."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    families = [("forecast", "forecast source"), ("spread", "short-crested sea (DSWP)"),
                ("model", "model mismatch and current"), ("depth", "Bar30 dynamic pressure")]
    widths = [max(1, sum(r["family"] == f for r in doc["rows"])) for f, _ in families]
    fig, axes = plt.subplots(1, len(families), figsize=(15, 4.2), sharey=True, width_ratios=widths)
    offsets = np.linspace(-0.2, 0.2, len(doc["cases"]))
    for ax, (fam, title) in zip(axes, families, strict=True):
        rows = [r for r in doc["rows"] if r["family"] == fam]
        for off, case in zip(offsets, doc["cases"], strict=True):
            xs, ys, err = [], [], [[], []]
            for i, r in enumerate(rows):
                f = r["cases"][case]
                if f is None:
                    continue
                m, (lo, hi) = f["reduction_pct_mean"], f["ci95_pct"]
                xs.append(i + off)
                ys.append(m)
                err[0].append(m - lo)
                err[1].append(hi - m)
            ax.errorbar(xs, ys, yerr=err, fmt="o", capsize=3, label=case)
        ax.axhline(0.0, color="k", lw=0.8)
        ax.set_xticks(range(len(rows)), [r["level"] for r in rows], rotation=30, ha="right")
        ax.set_title(title)
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("FF's mean RMSE reduction vs C-PD (%)")
    axes[0].legend(title="sea state")
    fig.suptitle("How much of the feed-forward's gain survives each error (mean over seeds, bootstrap 95 % CI)")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("folder", type=Path, help="the sea_errors campaign's --out folder")
    ap.add_argument("--out", type=Path, default=Path(__file__).resolve().parent / "results" / "sea_errors.json")
    ap.add_argument("--figure", type=Path, default=None, help="also draw the figure here (PNG)")
    args = ap.parse_args(argv)
    doc = sea_errors(args.folder)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")
    if args.figure is not None:
        figure(doc, args.figure)
    print(markdown(doc))
    print("FF never worse than C-PD in mean RMSE:", "yes" if doc["ff_never_worse_in_mean_rmse"]["pass"]
          else "no: " + "; ".join(doc["ff_never_worse_in_mean_rmse"]["failures"]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
