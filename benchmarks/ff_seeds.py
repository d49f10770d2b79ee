"""The feed-forward across seeds: C-PD against the paper's and the robust FF, exact and 15 dB forecasts.

    python -m benchmarks.ff_seeds --cases W1 W2 W3 --seeds 1-30 --duration 600 --workers 2 \\
        --out benchmarks/results/ff_seeds.json

Runs C-PD, FF exact and FF 15 dB — each with the paper's law (``WK_FF_MODE`` 0)
and the robust one (1) — per (case, seed) in a process pool, then reports per
case and variant: the mean RMSE reduction against C-PD (mean over the three
DoF, then over seeds) with a bootstrap 95 % confidence interval over seeds,
the worst maximum pitch error, the share of seeds where FF lowers the mean
RMSE, and the acceptance checks of docs/feedforward.md. Results are written
after every run and reused by a rerun with ``--resume``, so a long campaign
can be extended seed by seed.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numpy as np

from benchmarks.common import machine

__all__ = ["VARIANTS", "acceptance", "parse_seeds", "summarise"]

VARIANTS: dict[str, tuple[str, float | None, dict[str, float]]] = {
    "cpd": ("cpd", None, {}),
    "ff_exact_paper": ("cpd_ff", None, {"WK_FF_MODE": 0}),
    "ff_exact_robust": ("cpd_ff", None, {"WK_FF_MODE": 1}),
    "ff_15db_paper": ("cpd_ff", 15.0, {"WK_FF_MODE": 0}),
    "ff_15db_robust": ("cpd_ff", 15.0, {"WK_FF_MODE": 1}),
    # Alternatives measured on the way (not run unless asked for with --variants)
    "ff_exact_wavepart": ("cpd_ff", None, {"WK_FF_MODE": 2}),
    "ff_15db_wavepart": ("cpd_ff", 15.0, {"WK_FF_MODE": 2}),
    "ff_exact_nomon": ("cpd_ff", None, {"WK_FF_MODE": 1, "WK_FF_MON_THR": 0.0}),
    "ff_15db_nomon": ("cpd_ff", 15.0, {"WK_FF_MODE": 1, "WK_FF_MON_THR": 0.0}),
    "ff_exact_nolim": ("cpd_ff", None, {"WK_FF_MODE": 1, "WK_FF_MON_THR": 0.0, "WK_FF_LIM_X": 2.0,
                                         "WK_FF_LIM_Z": 2.0, "WK_FF_LIM_P": 2.0}),
}
"""name → (controller, forecast SNR in dB or None for exact, parameter overrides)."""

DEFAULT_VARIANTS = ("cpd", "ff_exact_paper", "ff_exact_robust", "ff_15db_paper", "ff_15db_robust")

DOF = ("surge", "heave", "pitch")
PITCH_LIMIT_DEG = 20.0
MAX_MARGIN = {"surge": 0.1, "heave": 0.1, "pitch": math.radians(2.0)}     # m, m, rad


def parse_seeds(items: list[str]) -> list[int]:
    """``["1-8", "12"]`` or ``["1-8,12"]`` → [1, …, 8, 12] (sorted, unique)."""
    out: set[int] = set()
    for item in items:
        for part in item.split(","):
            if "-" in part:
                a, b = part.split("-", 1)
                out.update(range(int(a), int(b) + 1))
            elif part:
                out.add(int(part))
    return sorted(out)


def _run(job: tuple[str, int, float, str]) -> dict:
    from sitl.harness.run import run_mission
    from sitl.harness.spec import RunSpec
    case, seed, duration, variant = job
    controller, snr, overrides = VARIANTS[variant]
    r = run_mission(RunSpec(case, controller, snr, seed=seed, duration=duration, overrides=overrides)).results
    return {"case": case, "seed": seed, "variant": variant, "duration": duration, "rmse": r["rmse"],
            "max_abs_error": r["max_abs_error"], "mean_power_w": r["mean_power_w"]}


def _reduction(base: dict, new: dict, key: str = "rmse") -> float:
    """Mean over the DoF of the reduction (%) of ``key`` against C-PD."""
    return float(np.mean([100.0 * (base[key][d] - new[key][d]) / base[key][d] for d in DOF]))


def _bootstrap_ci(x: np.ndarray, n: int = 4000, seed: int = 0) -> tuple[float, float]:
    """95 % percentile-bootstrap interval of the mean of x (resampling seeds; fixed RNG: same data, same CI)."""
    if x.size < 2:
        return float("nan"), float("nan")
    rng = np.random.default_rng(seed)
    means = x[rng.integers(0, x.size, (n, x.size))].mean(axis=1)
    return float(np.percentile(means, 2.5)), float(np.percentile(means, 97.5))


def _index(runs: list[dict]) -> dict[tuple[str, int, str], dict]:
    return {(r["case"], r["seed"], r["variant"]): r for r in runs}


def summarise(runs: list[dict]) -> dict:
    """Per case and FF variant: mean RMSE reduction vs C-PD with its CI, worst max pitch, seeds won."""
    by = _index(runs)
    out: dict = {}
    for case in sorted({r["case"] for r in runs}):
        out[case] = {}
        for v in VARIANTS:
            seeds = sorted(s for (c, s, vv) in by if c == case and vv == v and (c, s, "cpd") in by)
            if not seeds:
                continue
            red = np.array([_reduction(by[(case, s, "cpd")], by[(case, s, v)]) for s in seeds])
            pitch = [math.degrees(by[(case, s, v)]["max_abs_error"]["pitch"]) for s in seeds]
            lo, hi = _bootstrap_ci(red)
            out[case][v] = {"seeds": seeds, "mean_rmse_reduction_pct": float(red.mean()), "ci95_pct": [lo, hi],
                            "per_seed_rmse_reduction_pct": red.tolist(), "worst_max_pitch_deg": max(pitch),
                            "worst_max_pitch_seed": seeds[int(np.argmax(pitch))],
                            "share_won": float(np.mean(red > 0.0))}
    return out


def acceptance(runs: list[dict], law: str) -> dict:
    """The acceptance checks for one FF law (``paper`` or ``robust``), each with its failures."""
    by = _index(runs)
    exact, noisy = f"ff_exact_{law}", f"ff_15db_{law}"
    pairs = sorted({(c, s) for (c, s, v) in by if v == "cpd"})
    over = [f"{c} s{s} {v}: {math.degrees(by[(c, s, v)]['max_abs_error']['pitch']):.1f}°"
            for c, s in pairs for v in (exact, noisy)
            if (c, s, v) in by and math.degrees(by[(c, s, v)]["max_abs_error"]["pitch"]) > PITCH_LIMIT_DEG]
    worse = []
    for c, s in pairs:
        if (c, s, exact) not in by:
            continue
        base, ff = by[(c, s, "cpd")]["max_abs_error"], by[(c, s, exact)]["max_abs_error"]
        bad = [d for d in DOF if ff[d] > base[d] + MAX_MARGIN[d]]
        if bad:
            shown = lambda v, d: math.degrees(v) if d == "pitch" else v  # noqa: E731
            worse.append(f"{c} s{s}: " + ", ".join(f"{d} {shown(ff[d], d):.2f} vs {shown(base[d], d):.2f}"
                                                   for d in bad))
    summ = summarise(runs)
    exact_low = {c: v[exact]["mean_rmse_reduction_pct"] for c, v in summ.items()
                 if exact in v and v[exact]["mean_rmse_reduction_pct"] < 50.0}
    noisy_neg = {c: v[noisy]["mean_rmse_reduction_pct"] for c, v in summ.items()
                 if noisy in v and v[noisy]["mean_rmse_reduction_pct"] <= 0.0}
    noisy_red = [_reduction(by[(c, s, "cpd")], by[(c, s, noisy)]) for c, s in pairs if (c, s, noisy) in by]
    share = float(np.mean(np.array(noisy_red) > 0.0)) if noisy_red else float("nan")
    return {
        "no_ff_mission_over_20deg_pitch": {"pass": not over, "failures": over},
        "ff_exact_max_error_within_cpd_margin": {"pass": not worse, "failures": worse},
        "ff_exact_mean_rmse_reduction_ge_50pct_per_case": {"pass": not exact_low, "failures": exact_low},
        "ff_15db_mean_rmse_reduction_gt_0_per_case": {"pass": not noisy_neg, "failures": noisy_neg},
        "ff_15db_reduction_gt_0_in_90pct_of_runs": {"pass": bool(share >= 0.9), "share": share},
    }


def format_report(runs: list[dict]) -> str:
    summ = summarise(runs)
    lines = [f"{'case':<5}{'variant':<17}{'n':>3}{'mean RMSE red.':>16}{'95 % CI':>18}{'worst θ (°)':>13}{'won':>6}"]
    for case, vs in summ.items():
        for v, s in vs.items():
            if v == "cpd":
                lines.append(f"{case:<5}{v:<17}{len(s['seeds']):>3}{'':>16}{'':>18}{s['worst_max_pitch_deg']:>13.1f}")
                continue
            lo, hi = s["ci95_pct"]
            lines.append(f"{case:<5}{v:<17}{len(s['seeds']):>3}{s['mean_rmse_reduction_pct']:>15.1f}%"
                         f"{f'[{lo:.1f}, {hi:.1f}]':>18}{s['worst_max_pitch_deg']:>13.1f}{100 * s['share_won']:>5.0f}%")
    for law in ("paper", "robust"):
        lines.append(f"\nacceptance, {law} FF:")
        for name, chk in acceptance(runs, law).items():
            detail = chk.get("failures", chk.get("share"))
            lines.append(f"  {'PASS' if chk['pass'] else 'FAIL'}  {name}" + ("" if chk["pass"] else f": {detail}"))
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", nargs="+", default=["W1", "W2", "W3"])
    ap.add_argument("--seeds", nargs="+", default=["1-8"], help="e.g. 1-30, or 5,6 1-8")
    ap.add_argument("--duration", type=float, default=600.0, help="s per mission")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--variants", nargs="+", default=list(DEFAULT_VARIANTS), choices=list(VARIANTS),
                    help="cpd is always run (the reference)")
    ap.add_argument("--out", default="benchmarks/results/ff_seeds.json")
    ap.add_argument("--resume", action="store_true", help="keep the runs already in --out (same duration)")
    a = ap.parse_args(argv)
    out = Path(a.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    runs: list[dict] = []
    if a.resume and out.exists():
        runs = [r for r in json.loads(out.read_text())["runs"] if r["duration"] == a.duration]
    done = {(r["case"], r["seed"], r["variant"]) for r in runs}
    variants = ["cpd", *[v for v in a.variants if v != "cpd"]]
    jobs = [(c, s, a.duration, v) for s in parse_seeds(a.seeds) for c in a.cases for v in variants
            if (c, s, v) not in done]
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    t0 = time.perf_counter()

    def save() -> None:
        runs.sort(key=lambda r: (r["case"], r["seed"], list(VARIANTS).index(r["variant"])))
        doc = {"machine": machine(), "duration_s": a.duration, "variants": {k: list(v) for k, v in VARIANTS.items()},
               "runs": runs, "summary": summarise(runs),
               "acceptance": {law: acceptance(runs, law) for law in ("paper", "robust")},
               "wall_time_s": time.perf_counter() - t0}
        out.write_text(json.dumps(doc, indent=1))

    import multiprocessing as mp
    with ProcessPoolExecutor(max_workers=a.workers, mp_context=mp.get_context("spawn")) as pool:
        futures = [pool.submit(_run, j) for j in jobs]
        for i, f in enumerate(as_completed(futures)):
            r = f.result()
            runs.append(r)
            save()
            print(f"[{i + 1}/{len(jobs)}] {r['case']} seed {r['seed']} {r['variant']}: max pitch "
                  f"{math.degrees(r['max_abs_error']['pitch']):.1f}°", file=sys.stderr, flush=True)
    save()
    print(format_report(runs))
    return 0


if __name__ == "__main__":
    sys.exit(main())
