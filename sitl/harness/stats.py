"""Claims across seeds: paired reductions against a baseline, their bootstrap intervals, worst cases and win shares.

For a case, a variant and a DoF, each seed s flown by both the variant and the
baseline gives a paired RMSE reduction r_s = 100 (RMSE_base,s − RMSE_var,s) /
RMSE_base,s (%). The summary reports the mean and standard deviation of r_s, a
95 % bootstrap confidence interval of the mean (percentile method: resample the
seeds with replacement B times, seeded, take the 2.5th and 97.5th percentiles
of the resampled means), the worst case (the largest max |error| over the seeds,
for the variant and the baseline) and the share of seeds where the variant's
RMSE is below the baseline's. ``overall`` does the same for each variant's
reduction averaged over every case and DoF of a seed (the paper's headline
"mean RMSE reduction"), over the seeds flown in every case.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from .metrics import DOF

__all__ = ["bootstrap_ci", "format_summary_table", "reduction_stats", "summarise_campaign"]


def bootstrap_ci(values: Sequence[float], resamples: int = 10_000, seed: int = 0,
                 level: float = 0.95) -> tuple[float, float]:
    """Percentile bootstrap interval of the mean of ``values`` (nan, nan for no values).

    ``resamples`` means of ``len(values)`` draws with replacement, from
    ``numpy.random.default_rng(seed)``; the interval is their ((1 − level)/2,
    (1 + level)/2) quantiles. One value gives a zero-width interval.
    """
    x = np.asarray(values, dtype=float)
    if x.size == 0:
        return float("nan"), float("nan")
    rng = np.random.default_rng(seed)
    means = np.empty(resamples)
    chunk = max(1, 2_000_000 // max(x.size, 1))          # bound the (chunk × n) index memory
    for i in range(0, resamples, chunk):
        k = min(chunk, resamples - i)
        means[i:i + k] = x[rng.integers(0, x.size, size=(k, x.size))].mean(axis=1)
    a = (1.0 - level) / 2.0
    lo, hi = np.quantile(means, [a, 1.0 - a])
    return float(lo), float(hi)


def _reduction(base: np.ndarray, new: np.ndarray) -> np.ndarray:
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(base > 0, 100.0 * (base - new) / base, np.nan)


def reduction_stats(base_rmse: Sequence[float], rmse: Sequence[float], base_max: Sequence[float],
                    max_err: Sequence[float], resamples: int, seed: int) -> dict[str, Any]:
    """Statistics of one (case, variant, DoF) from per-seed arrays paired by seed (see the module)."""
    b, v = np.asarray(base_rmse, float), np.asarray(rmse, float)
    r = _reduction(b, v)
    r = r[np.isfinite(r)]
    lo, hi = bootstrap_ci(r, resamples, seed)
    return {
        "n_seeds": int(v.size),
        "rmse_mean": float(np.mean(v)) if v.size else float("nan"),
        "rmse_std": float(np.std(v, ddof=1)) if v.size > 1 else float("nan"),
        "baseline_rmse_mean": float(np.mean(b)) if b.size else float("nan"),
        "reduction_pct_mean": float(np.mean(r)) if r.size else float("nan"),
        "reduction_pct_std": float(np.std(r, ddof=1)) if r.size > 1 else float("nan"),
        "reduction_pct_ci95": [lo, hi],
        "max_error_worst": float(np.max(max_err)) if len(max_err) else float("nan"),
        "baseline_max_error_worst": float(np.max(base_max)) if len(base_max) else float("nan"),
        "win_share": float(np.mean(v < b)) if v.size else float("nan"),
    }


def _index(rows: Sequence[dict[str, Any]]) -> dict[tuple[str, str, int], dict[str, Any]]:
    return {(r["case"], r["variant"], r["seed"]): r for r in rows if r.get("status") == "ok"}


def summarise_campaign(rows: Sequence[dict[str, Any]], cases: Sequence[str], variants: Sequence[str],
                       baseline: str, resamples: int = 10_000, seed: int = 0,
                       baselines: Mapping[str, str] | None = None) -> dict[str, Any]:
    """Per (case, variant, DoF) statistics against ``baseline``, and each other variant's ``overall`` reduction.

    ``baselines`` gives a variant a baseline of its own (a C-PD flown in the same perturbed world,
    for an error that changes the plant and not only the forecast); the others use ``baseline``.

    ``rows`` are campaign rows (``case``, ``variant``, ``seed``, ``status``, ``rmse_<dof>``,
    ``max_abs_error_<dof>``); only ``ok`` rows count, paired by seed with the baseline's.
    """
    idx = _index(rows)
    seeds = sorted({s for (_, _, s) in idx})
    groups: list[dict[str, Any]] = []
    per_seed: dict[str, dict[int, list[float]]] = {v: {} for v in variants}
    variants = [v for v in variants if v != baseline]
    own = dict(baselines or {})
    for case in cases:
        for var in variants:
            base = own.get(var, baseline)
            paired = [s for s in seeds if (case, var, s) in idx and (case, base, s) in idx]
            for dof in DOF:
                b = [idx[(case, base, s)] for s in paired]
                v = [idx[(case, var, s)] for s in paired]
                st = reduction_stats([r[f"rmse_{dof}"] for r in b], [r[f"rmse_{dof}"] for r in v],
                                     [r[f"max_abs_error_{dof}"] for r in b], [r[f"max_abs_error_{dof}"] for r in v],
                                     resamples, seed)
                groups.append({"case": case, "variant": var, "dof": dof, **st, **({"baseline": base} if own else {})})
                for s, rb, rv in zip(paired, b, v, strict=True):
                    per_seed[var].setdefault(s, []).append(
                        float(_reduction(np.array([rb[f"rmse_{dof}"]]), np.array([rv[f"rmse_{dof}"]]))[0]))
    overall = {}
    full = len(cases) * len(DOF)
    for var in variants:
        means = [float(np.mean(v)) for v in per_seed[var].values() if len(v) == full and np.all(np.isfinite(v))]
        lo, hi = bootstrap_ci(means, resamples, seed)
        overall[var] = {"n_seeds": len(means), "reduction_pct_mean": float(np.mean(means)) if means else float("nan"),
                        "reduction_pct_std": float(np.std(means, ddof=1)) if len(means) > 1 else float("nan"),
                        "reduction_pct_ci95": [lo, hi],
                        "win_share": float(np.mean(np.asarray(means) > 0)) if means else float("nan")}
    return {"baseline": baseline, "bootstrap": {"resamples": resamples, "seed": seed, "level": 0.95,
                                                "method": "percentile, seeds resampled with replacement"},
            "groups": groups, "overall": overall}


def _fmt(x: float, spec: str) -> str:
    return "—" if x is None or not np.isfinite(x) else format(x, spec)


def _short(case: str) -> str:
    """A sea state's name for a table column (a YAML path's stem)."""
    name = case.rsplit("/", 1)[-1]
    return name.rsplit(".", 1)[0] if name.endswith((".yaml", ".yml")) else name


def format_summary_table(summary: dict[str, Any]) -> str:
    """The summary as text: one line per (case, variant, DoF); pitch in degrees."""
    head = (f"{'case':<6}{'variant':<16}{'DoF':<7}{'n':>4}{'RMSE':>9}{'reduction %':>13}{'± sd':>7}"
            f"{'95 % CI':>17}{'worst max':>11}{'(base)':>9}{'wins':>6}")
    lines = [f"RMSE reduction against {summary['baseline']!r} (bootstrap {summary['bootstrap']['resamples']} "
             f"resamples, seed {summary['bootstrap']['seed']}); pitch in degrees", head, "-" * len(head)]
    for g in summary["groups"]:
        k = float(np.degrees(1.0)) if g["dof"] == "pitch" else 1.0
        lo, hi = g["reduction_pct_ci95"]
        lines.append(f"{_short(g['case']):<6}{g['variant'][:15]:<16}{g['dof']:<7}{g['n_seeds']:>4}"
                     f"{_fmt(g['rmse_mean'] * k, '.3f'):>9}{_fmt(g['reduction_pct_mean'], '.1f'):>13}"
                     f"{_fmt(g['reduction_pct_std'], '.1f'):>7}"
                     f"{'[' + _fmt(lo, '.1f') + ', ' + _fmt(hi, '.1f') + ']':>17}"
                     f"{_fmt(g['max_error_worst'] * k, '.3f'):>11}{_fmt(g['baseline_max_error_worst'] * k, '.3f'):>9}"
                     f"{_fmt(100 * g['win_share'], '.0f') + '%':>6}")
    lines.append("")
    for var, o in summary["overall"].items():
        lo, hi = o["reduction_pct_ci95"]
        lines.append(f"{var}: mean RMSE reduction over cases and DoFs {_fmt(o['reduction_pct_mean'], '.1f')} % "
                     f"[{_fmt(lo, '.1f')}, {_fmt(hi, '.1f')}] over {o['n_seeds']} seeds; "
                     f"better than the baseline on {_fmt(100 * o['win_share'], '.0f')} % of seeds")
    return "\n".join(lines)
