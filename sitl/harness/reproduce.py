"""The paper's results table: W1–W3 × {C-PD, C-PD+FF exact forecast, C-PD+FF 15 dB forecast}.

Runs the nine in-process missions (in parallel, one process per core), prints
the table in the paper's terms (RMSE and maximum error per DoF, reductions
against C-PD in %, power) beside the paper's published figures, and writes
``reproduce.json`` and the figures.
"""
from __future__ import annotations

import json
import os
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from pathlib import Path

import numpy as np

from .metrics import DOF
from .plots import plot_reproduce
from .results import RunResult
from .run import run_mission
from .spec import PAPER_CASES as CASES
from .spec import PAPER_VARIANTS, RunSpec

__all__ = ["PAPER", "format_reproduce_table", "reproduce", "summarise"]

VARIANT_KEYS = {("cpd", None): "cpd", ("cpd_ff", None): "ff_exact", ("cpd_ff", 15.0): "ff_snr15"}

PAPER = {
    "mean_rmse_reduction_pct": {"ff_exact": 48.0, "ff_snr15": 17.0},
    "mean_max_error_reduction_pct": {"ff_exact": 28.0},
    "w1_rmse_reduction_pct": {"surge": 47.5, "heave": 48.2, "pitch": 58.6},
    "max_error_reduction_pct_by_dof": {"surge": 22.0, "heave": 11.8, "pitch": 50.1},
    "note": "Walker et al. §V; the paper's sea states are measured Cefas spectra (realised Hs ≈ 2.3–2.6 m).",
}


def _one(spec: RunSpec) -> RunResult:
    return run_mission(spec)


def reduction_pct(base: float, new: float) -> float:
    return 100.0 * (base - new) / base if base > 0 else float("nan")


def summarise(results: list[dict]) -> dict:
    """Reductions against C-PD per case and DoF, their means, and power, from the nine results."""
    by = {(r["case"], VARIANT_KEYS[(r["controller"], r["forecast_snr_db"])]): r for r in results}
    out: dict = {"rmse_reduction_pct": {}, "max_error_reduction_pct": {}, "total_power_w": {}}
    for key in ("ff_exact", "ff_snr15"):
        rr = {c: {d: reduction_pct(by[(c, "cpd")]["rmse"][d], by[(c, key)]["rmse"][d]) for d in DOF} for c in CASES}
        mr = {c: {d: reduction_pct(by[(c, "cpd")]["max_abs_error"][d], by[(c, key)]["max_abs_error"][d])
                  for d in DOF} for c in CASES}
        out["rmse_reduction_pct"][key] = rr
        out["max_error_reduction_pct"][key] = mr
    out["mean_rmse_reduction_pct"] = {k: float(np.mean([v for c in CASES for v in out["rmse_reduction_pct"][k][c].values()]))
                                      for k in ("ff_exact", "ff_snr15")}
    out["mean_max_error_reduction_pct"] = {
        k: float(np.mean([v for c in CASES for v in out["max_error_reduction_pct"][k][c].values()]))
        for k in ("ff_exact", "ff_snr15")}
    for (c, k), r in by.items():
        out["total_power_w"].setdefault(c, {})[k] = float(sum(r["mean_power_w"][d] for d in DOF))
    out["ff_lowers_rmse_everywhere"] = all(v > 0 for c in CASES for v in out["rmse_reduction_pct"]["ff_exact"][c].values())
    out["ff_draws_more_power"] = all(out["total_power_w"][c]["ff_exact"] > out["total_power_w"][c]["cpd"] for c in CASES)
    out["worst_excursion"] = {f"{r['case']} {r['label']}": {"max_m": max(r["max_abs_error"]["surge"], r["max_abs_error"]["heave"]),
                                                            "max_pitch_deg": float(np.degrees(r["max_abs_error"]["pitch"]))}
                              for r in results}
    return out


def format_reproduce_table(results: list[dict], summary: dict) -> str:
    by = {(r["case"], VARIANT_KEYS[(r["controller"], r["forecast_snr_db"])]): r for r in results}
    head = (f"{'case':<5}{'controller':<17}{'RMSE x (m)':>11}{'z (m)':>8}{'θ (°)':>8}"
            f"{'max x (m)':>11}{'z (m)':>8}{'θ (°)':>8}{'power (W)':>11}")
    lines = [head, "-" * len(head)]
    names = {"cpd": "C-PD", "ff_exact": "C-PD+FF exact", "ff_snr15": "C-PD+FF 15 dB"}
    for c in CASES:
        for k in ("cpd", "ff_exact", "ff_snr15"):
            r = by[(c, k)]
            rm, mx = r["rmse"], r["max_abs_error"]
            lines.append(f"{c:<5}{names[k]:<17}{rm['surge']:>11.3f}{rm['heave']:>8.3f}{np.degrees(rm['pitch']):>8.2f}"
                         f"{mx['surge']:>11.3f}{mx['heave']:>8.3f}{np.degrees(mx['pitch']):>8.2f}"
                         f"{summary['total_power_w'][c][k]:>11.1f}")
        for k in ("ff_exact", "ff_snr15"):
            rr, mr = summary["rmse_reduction_pct"][k][c], summary["max_error_reduction_pct"][k][c]
            lines.append(f"{'':<5}{'  reduction ' + ('exact' if k == 'ff_exact' else '15 dB'):<17}"
                         f"{rr['surge']:>10.1f}%{rr['heave']:>7.1f}%{rr['pitch']:>7.1f}%"
                         f"{mr['surge']:>10.1f}%{mr['heave']:>7.1f}%{mr['pitch']:>7.1f}%")
    m, mm = summary["mean_rmse_reduction_pct"], summary["mean_max_error_reduction_pct"]
    lines.append("")
    lines.append(f"mean RMSE reduction: exact forecast {m['ff_exact']:.1f} % (paper ≈ {PAPER['mean_rmse_reduction_pct']['ff_exact']:.0f} %), "
                 f"15 dB forecast {m['ff_snr15']:.1f} % (paper ≈ {PAPER['mean_rmse_reduction_pct']['ff_snr15']:.0f} %)")
    lines.append(f"mean max-error reduction: exact {mm['ff_exact']:.1f} % (paper ≈ {PAPER['mean_max_error_reduction_pct']['ff_exact']:.0f} %), "
                 f"15 dB {mm['ff_snr15']:.1f} %")
    lines.append(f"FF lowers RMSE in all nine (case, DoF) pairs: {'yes' if summary['ff_lowers_rmse_everywhere'] else 'no'}; "
                 f"FF draws more power than C-PD in every case: {'yes' if summary['ff_draws_more_power'] else 'no'}")
    return "\n".join(lines)


def reproduce(out: str | Path, seed: int | None = None, duration: float | None = None, workers: int | None = None,
              plots: bool = True, progress=print) -> dict:
    """Run the nine missions, write DIR/reproduce.json (+ figures), return the document."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    jobs = [replace(v, case=c, seed=seed, duration=duration) for c in CASES for v in PAPER_VARIANTS]
    workers = workers or min(len(jobs), os.cpu_count() or 1)
    t0 = time.perf_counter()
    runs: list[RunResult] = []
    if workers > 1:
        import multiprocessing as mp
        # One BLAS thread per worker: the workers already fill the cores
        os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
        os.environ.setdefault("OMP_NUM_THREADS", "1")
        with ProcessPoolExecutor(max_workers=workers, mp_context=mp.get_context("spawn")) as pool:
            for i, r in enumerate(pool.map(_one, jobs)):
                runs.append(r)
                progress(f"[{i + 1}/{len(jobs)}] {r.results['case']} {r.results['label']}: done")
    else:
        for i, job in enumerate(jobs):
            runs.append(_one(job))
            progress(f"[{i + 1}/{len(jobs)}] {job.case} {runs[-1].results['label']}: done")
    wall = time.perf_counter() - t0
    results = [r.results for r in runs]
    summary = summarise(results)
    doc = {"runs": results, "summary": summary, "paper": PAPER, "wall_time_s": wall}
    (out / "reproduce.json").write_text(json.dumps(doc, indent=2))
    if plots:
        plot_reproduce(runs, out)
    return doc
