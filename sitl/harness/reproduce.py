"""The paper's results table: W1–W3 × {C-PD, C-PD+FF exact forecast, C-PD+FF 15 dB forecast}.

The paper's table is flown in **the paper's world** (:data:`PAPER_WORLD`): the
plant applies the paper's wave load (Eq. 10/11, the added-mass force alone) and
the firmware's nominal model does the same (``WK_LOAD_MODEL`` 0), so the table
stays reproducible. The same nine missions are flown again in **the corrected
world** (the default: Froude–Krylov + added mass, docs/models.md) and that table
is given beside it.

Runs the missions as a small built-in campaign on the campaign engine
(:mod:`.campaign`: a loopback Dask LocalCluster, one worker per core, or an
existing cluster), prints the tables in the paper's terms (RMSE and maximum
error per DoF, reductions against C-PD in %, power) beside the paper's
published figures, and writes ``reproduce.json`` and the figures (the corrected
world's under ``corrected/``). With ``seeds=N`` (``wavekeep reproduce --seeds
N``) it runs the paper's grid in the paper's world over seeds 1..N as a campaign
and reports each reduction's mean with a 95 % bootstrap interval
(:func:`reproduce_seeds`).
"""
from __future__ import annotations

import json
import os
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from .campaign import CampaignReport, dask_client, execute_tasks, run_campaign
from .campaign_spec import CampaignSpec, CampaignTask, Variant
from .campaign_task import TaskOutcome
from .metrics import DOF
from .plots import plot_reproduce
from .results import TIMESERIES_COLUMNS, RunResult, write_results
from .spec import PAPER_CASES as CASES
from .spec import PAPER_VARIANTS

__all__ = ["PAPER", "PAPER_WORLD", "WORLDS", "format_reproduce", "format_reproduce_table", "paper_campaign",
           "paper_tasks", "reproduce", "reproduce_seeds", "summarise", "summary_statements"]

VARIANT_KEYS = {("cpd", None): "cpd", ("cpd_ff", None): "ff_exact", ("cpd_ff", 15.0): "ff_snr15"}

PAPER: dict[str, Any] = {
    "mean_rmse_reduction_pct": {"ff_exact": 48.0, "ff_snr15": 17.0},
    "mean_max_error_reduction_pct": {"ff_exact": 28.0},
    "w1_rmse_reduction_pct": {"surge": 47.5, "heave": 48.2, "pitch": 58.6},
    "max_error_reduction_pct_by_dof": {"surge": 22.0, "heave": 11.8, "pitch": 50.1},
    "note": "Walker et al. §V; the paper's sea states are measured Cefas spectra (realised Hs ≈ 2.3–2.6 m).",
}


PAPER_WORLD: dict[str, dict[str, Any]] = {"sea": {"wave_load": "paper", "dof": "planar"},
                                          "overrides": {"WK_LOAD_MODEL": 0.0}}
"""The paper's world: its planar vehicle (surge, heave, pitch: the sea config's ``dof``) and its wave load (Eq.
10/11: the added-mass force alone, no Froude–Krylov force) in the plant (``wave_load``) and in the firmware's
nominal model (``WK_LOAD_MODEL``)."""

WORLDS: dict[str, tuple[str, dict[str, dict[str, Any]]]] = {
    "paper": ("the paper's world: its wave load, Eq. 10/11 (added mass only), in the plant and the firmware's "
              "model (WK_LOAD_MODEL 0)", PAPER_WORLD),
    "corrected": ("the corrected world (the default): Froude-Krylov + added mass, (rho V + M_A) a, with the "
                  "pitch coupling, in the plant and the firmware's model", {"sea": {"dof": "planar"}, "overrides": {}}),
}
"""reproduce's two worlds: a caption and the RunSpec fields that make each."""


def reduction_pct(base: float, new: float) -> float:
    return 100.0 * (base - new) / base if base > 0 else float("nan")


def _count(names: list[str], holds: list[bool]) -> dict:
    """How many of ``names`` a statement holds for, which, and which not (computed, never assumed)."""
    return {"n": sum(holds), "of": len(names), "all": bool(names) and all(holds),
            "where": [n for n, h in zip(names, holds, strict=True) if h],
            "except": [n for n, h in zip(names, holds, strict=True) if not h]}


def summary_statements(summary: dict) -> list[str]:
    """The summary lines under the table, each computed from the rows and naming what it covers."""
    lines = []
    for k, name in (("ff_exact", "FF exact"), ("ff_snr15", "FF 15 dB")):
        r, p = summary["rmse_lowered"][k], summary["more_power"][k]
        lines.append(f"{name} lowers RMSE against C-PD in {r['n']} of {r['of']} (case, DoF) pairs"
                     + (f" (not in: {', '.join(r['except'])})" if r["except"] else "")
                     + f"; draws more power than C-PD in {p['n']} of {p['of']} cases"
                     + (f" (not in: {', '.join(p['except'])})" if p["except"] else ""))
    return lines


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
    rmse_red = out["rmse_reduction_pct"]
    out["mean_rmse_reduction_pct"] = {k: float(np.mean([v for c in CASES for v in rmse_red[k][c].values()]))
                                      for k in ("ff_exact", "ff_snr15")}
    out["mean_max_error_reduction_pct"] = {
        k: float(np.mean([v for c in CASES for v in out["max_error_reduction_pct"][k][c].values()]))
        for k in ("ff_exact", "ff_snr15")}
    for (c, k), r in by.items():
        out["total_power_w"].setdefault(c, {})[k] = float(sum(r["mean_power_w"][d] for d in DOF))
    power = out["total_power_w"]
    out["rmse_lowered"] = {k: _count([f"{c} {d}" for c in rmse_red[k] for d in rmse_red[k][c]],
                                     [rmse_red[k][c][d] > 0 for c in rmse_red[k] for d in rmse_red[k][c]])
                           for k in ("ff_exact", "ff_snr15")}
    out["more_power"] = {k: _count(list(power), [power[c][k] > power[c]["cpd"] for c in power])
                         for k in ("ff_exact", "ff_snr15")}
    out["ff_lowers_rmse_everywhere"] = out["rmse_lowered"]["ff_exact"]["all"]
    out["ff_draws_more_power"] = out["more_power"]["ff_exact"]["all"]
    out["worst_excursion"] = {
        f"{r['case']} {r['label']}": {"max_m": max(r["max_abs_error"]["surge"], r["max_abs_error"]["heave"]),
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
    paper_rmse, paper_max = PAPER["mean_rmse_reduction_pct"], PAPER["mean_max_error_reduction_pct"]
    n_pairs = summary["rmse_lowered"]["ff_exact"]["of"]
    lines.append(f"means over the {n_pairs} (case, DoF) pairs of {', '.join(summary['total_power_w'])} × "
                 f"{', '.join(DOF)}:")
    lines.append(f"mean RMSE reduction: exact forecast {m['ff_exact']:.1f} % (paper ≈ {paper_rmse['ff_exact']:.0f} %), "
                 f"15 dB forecast {m['ff_snr15']:.1f} % (paper ≈ {paper_rmse['ff_snr15']:.0f} %)")
    lines.append(f"mean max-error reduction: exact {mm['ff_exact']:.1f} % (paper ≈ {paper_max['ff_exact']:.0f} %), "
                 f"15 dB {mm['ff_snr15']:.1f} %")
    lines.extend(summary_statements(summary))
    return "\n".join(lines)


def paper_tasks(seed: int | None, duration: float | None, plots: bool, overrides: dict[str, float] | None = None,
                world: str = "paper") -> list[CampaignTask]:
    """The nine missions in one of :data:`WORLDS`; with ``plots`` each brings its time series back (Figs. 4
    and 5). The user's ``overrides`` go on top of the world's."""
    fields = WORLDS[world][1]
    params = {**fields["overrides"], **(overrides or {})}
    return [CampaignTask(f"{world}:{c}:{VARIANT_KEYS[(v.controller, v.snr_db)]}",
                         VARIANT_KEYS[(v.controller, v.snr_db)],
                         replace(v, case=c, seed=seed, duration=duration, overrides=params, sea=dict(fields["sea"])),
                         keep_timeseries=plots)
            for c in CASES for v in PAPER_VARIANTS]


def reproduce(out: str | Path, seed: int | None = None, duration: float | None = None, workers: int | None = None,
              plots: bool = True, progress=print, scheduler: str | None = None,
              overrides: dict[str, float] | None = None) -> dict:
    """Run the nine missions in each of :data:`WORLDS` on the campaign engine, write DIR/reproduce.json
    (+ figures), return the document: the paper's world's ``runs`` and ``summary``, and the corrected
    world's under ``corrected``.

    ``out`` is created only when the runs are done: a failed or interrupted reproduction leaves nothing."""
    out = Path(out)
    by_world = {w: paper_tasks(seed, duration, plots, overrides, w) for w in WORLDS}
    jobs = [t for ts in by_world.values() for t in ts]
    workers = workers or min(len(jobs), os.cpu_count() or 1)
    t0 = time.perf_counter()
    got: dict[str, TaskOutcome] = {}

    def collect(task: CampaignTask, outcome: TaskOutcome) -> None:
        got[task.mission_id] = outcome
        world = task.mission_id.split(":", 1)[0]
        progress(f"[{len(got)}/{len(jobs)}] {world} world, {task.spec.case} {task.spec.label}: {outcome.row['status']}")

    with dask_client(scheduler, workers, say=progress) as client:
        execute_tasks(client, jobs, collect)
    failed = [f"{k}: {o.row['error']}" for k, o in got.items() if o.results is None]
    if failed:
        raise RuntimeError("reproduce: missions failed: " + "; ".join(failed))
    wall = time.perf_counter() - t0
    empty = np.empty((0, len(TIMESERIES_COLUMNS)))
    runs: dict[str, list[RunResult]] = {}
    for world, tasks in by_world.items():
        runs[world] = []
        for t in tasks:
            outcome = got[t.mission_id]
            assert outcome.results is not None   # failures were raised above
            runs[world].append(RunResult(outcome.results, empty if outcome.timeseries is None else outcome.timeseries))
    results = {w: [r.results for r in rs] for w, rs in runs.items()}
    doc = {"world": WORLDS["paper"][0], "runs": results["paper"], "summary": summarise(results["paper"]),
           "corrected": {"world": WORLDS["corrected"][0], "runs": results["corrected"],
                         "summary": summarise(results["corrected"])},
           "paper": PAPER, "wall_time_s": wall}
    out.mkdir(parents=True, exist_ok=True)
    (out / "reproduce.json").write_text(json.dumps(doc, indent=2))
    if plots:
        for world, folder in (("paper", out), ("corrected", out / "corrected")):
            for t, run in zip(by_world[world], runs[world], strict=True):
                write_results(run, folder / "runs" / f"{t.spec.case}-{t.variant}")
            plot_reproduce(runs[world], folder)
    return doc


def format_reproduce(doc: dict) -> str:
    """Both worlds' tables, each under its caption: the paper's first (its figures are the paper's)."""
    return "\n\n".join(f"In {caption}:\n{format_reproduce_table(d['runs'], d['summary'])}"
                        for caption, d in ((doc["world"], doc), (doc["corrected"]["world"], doc["corrected"])))


def paper_campaign(seeds: int, duration: float | None = None) -> CampaignSpec:
    """The paper's grid over seeds 1..``seeds`` in the paper's world (:data:`PAPER_WORLD`): W1–W3 ×
    {C-PD, FF exact, FF 15 dB}, against C-PD."""
    variants = tuple(Variant(VARIANT_KEYS[(v.controller, v.snr_db)], v.controller, v.forecast, v.snr_db,
                             overrides=dict(PAPER_WORLD["overrides"]), sea=dict(PAPER_WORLD["sea"]))
                     for v in PAPER_VARIANTS)
    return CampaignSpec(f"reproduce_{seeds}_seeds", CASES, tuple(range(1, seeds + 1)), variants, "cpd", duration)


def reproduce_seeds(out: str | Path, seeds: int, duration: float | None = None, workers: int | None = None,
                    plots: bool = True, scheduler: str | None = None, stream=None) -> CampaignReport:
    """The paper's table over ``seeds`` seeds as a (resumable) campaign into ``out``: missions.parquet,
    summary.json with bootstrap CIs, and the campaign figures."""
    return run_campaign(paper_campaign(seeds, duration), out, scheduler=scheduler, workers=workers, plots=plots,
                        stream=stream)


def format_paper_comparison(summary: dict) -> str:
    """The headline reductions over seeds beside the paper's single-run figures."""
    o = summary["overall"]
    lines = [f"In {WORLDS['paper'][0]}:"]
    for key, name in (("ff_exact", "exact forecast"), ("ff_snr15", "15 dB forecast")):
        if key in o:
            lo, hi = o[key]["reduction_pct_ci95"]
            lines.append(f"mean RMSE reduction, {name}: {o[key]['reduction_pct_mean']:.1f} % "
                         f"(95 % CI {lo:.1f} to {hi:.1f} %, {o[key]['n_seeds']} seeds); "
                         f"paper ≈ {PAPER['mean_rmse_reduction_pct'][key]:.0f} % (one run)")
    return "\n".join(lines)
