"""Figures of a campaign: distributions across seeds, not single runs.

* ``box_rmse.png`` / ``box_max_error.png``: one panel per DoF, boxes per variant grouped by case;
* ``cdf_max_pitch.png``: the empirical CDF of the max |pitch error| (deg) per case and variant;
* ``reduction_vs_sea.png``: mean RMSE reduction (%) with its 95 % bootstrap interval against
  the sea state's Hs (m) and Tp (s) — only when the grid spans more than one of either.

Same headless object-oriented matplotlib as :mod:`.plots`. Surge and heave in m, pitch in degrees.
"""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from sitl.sea import load_sea_config

from .campaign_spec import CampaignSpec
from .metrics import DOF
from .plots import _figure, _save

__all__ = ["CAMPAIGN_FIGURES", "case_name", "plot_campaign", "sea_parameters"]

CAMPAIGN_FIGURES = ("box_rmse.png", "box_max_error.png", "cdf_max_pitch.png", "reduction_vs_sea.png")
_UNIT = {"surge": ("m", 1.0), "heave": ("m", 1.0), "pitch": ("deg", float(np.degrees(1.0)))}
_LS = ("-", "--", ":", "-.")


def case_name(case: str) -> str:
    """A sea state's short name (a YAML path's stem)."""
    p = Path(case)
    return p.stem if p.suffix in (".yaml", ".yml") else case


def sea_parameters(case: str) -> tuple[float, float]:
    """(Hs in m, Tp in s) from a sea config; nan for what a measured spectrum does not state."""
    sp = load_sea_config(case)["spectrum"]
    return float(sp.get("hs") or np.nan), float(sp.get("tp") or np.nan)


def _values(rows: Sequence[dict[str, Any]], case: str, variant: str, col: str) -> np.ndarray:
    return np.array([r[col] for r in rows if r.get("status") == "ok" and r["case"] == case
                     and r["variant"] == variant and r.get(col) is not None], dtype=float)


def _colors(n: int) -> list:
    from matplotlib import colormaps
    cmap = colormaps["tab10"]
    return [cmap(i % 10) for i in range(n)]


def plot_box(rows: Sequence[dict[str, Any]], spec: CampaignSpec, metric: str, title: str, path: Path) -> Path:
    """Box plots of ``metric_<dof>`` across seeds: one panel per DoF, per case a group of variant boxes."""
    variants = [v.name for v in spec.variants]
    colors = _colors(len(variants))
    fig, axes = _figure(1, 3, (14.0, 4.5))
    width = 0.8 / len(variants)
    for ax, dof in zip(axes[0], DOF, strict=True):
        unit, k = _UNIT[dof]
        for j, var in enumerate(variants):
            data = [_values(rows, c, var, f"{metric}_{dof}") * k for c in spec.cases]
            pos = np.arange(len(spec.cases)) + (j - (len(variants) - 1) / 2) * width
            keep = [i for i, d in enumerate(data) if d.size]
            if not keep:
                continue
            bp = ax.boxplot([data[i] for i in keep], positions=pos[keep], widths=width * 0.9, patch_artist=True,
                            manage_ticks=False, flierprops=dict(markersize=3),
                            medianprops=dict(color="k"))
            for box in bp["boxes"]:
                box.set(facecolor=colors[j], alpha=0.6)
            ax.plot([], [], color=colors[j], lw=6, alpha=0.6, label=var)
        ax.set_xticks(np.arange(len(spec.cases)), [case_name(c) for c in spec.cases])
        ax.set_ylabel(f"{dof} {title} ({unit})")
        ax.set_title(dof)
        ax.grid(axis="y", alpha=0.3)
    axes[0, 0].legend(fontsize=8, loc="upper left")
    fig.suptitle(f"{spec.name}: {title} across {len(spec.seeds)} seeds")
    return _save(fig, path)


def ecdf(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The empirical CDF as steps (``where="post"``): from 0 at the smallest value (it is 0 below it, not 1/N)
    up to 1 at the largest."""
    x = np.sort(np.asarray(values, dtype=float))
    return np.r_[x[:1], x], np.r_[0.0, np.arange(1, x.size + 1) / x.size]


def plot_cdf_max_pitch(rows: Sequence[dict[str, Any]], spec: CampaignSpec, path: Path) -> Path:
    """Empirical CDF of the max |pitch error| (deg) over seeds, a line per (case, variant)."""
    fig, axes = _figure(1, 1, (8.0, 5.0))
    ax = axes[0, 0]
    colors = _colors(len(spec.variants))
    for i, case in enumerate(spec.cases):
        for j, v in enumerate(spec.variants):
            x = _values(rows, case, v.name, "max_abs_error_pitch") * _UNIT["pitch"][1]
            if x.size:
                ax.step(*ecdf(x), where="post", color=colors[j], ls=_LS[i % len(_LS)],
                        label=f"{case_name(case)} {v.name} (n = {x.size})")
    ax.set_xlabel("max |pitch error| over the mission (deg)")
    ax.set_ylabel("share of seeds ≤ x")
    ax.set_ylim(-0.02, 1.02)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncols=max(1, len(spec.cases)))
    fig.suptitle(f"{spec.name}: CDF of the worst pitch error")
    return _save(fig, path)


def plot_reduction_vs_sea(summary: dict[str, Any], spec: CampaignSpec, path: Path) -> Path | None:
    """Mean RMSE reduction (%) and its 95 % CI against Hs (m) and Tp (s); None when the grid spans neither."""
    sea = {c: sea_parameters(c) for c in spec.cases}
    spans = [(i, name) for i, name in ((0, "Hs (m)"), (1, "Tp (s)"))
             if len({sea[c][i] for c in spec.cases if np.isfinite(sea[c][i])}) > 1]
    if not spans:
        return None
    others = [v.name for v in spec.variants if v.name != spec.baseline]
    colors = _colors(len(spec.variants))
    fig, axes = _figure(len(DOF), len(spans), (5.5 * len(spans), 8.0), sharex="col")
    for col, (i, label) in enumerate(spans):
        for row, dof in enumerate(DOF):
            ax = axes[row, col]
            for j, var in enumerate(others):
                g = [x for x in summary["groups"] if x["variant"] == var and x["dof"] == dof
                     and np.isfinite(sea[x["case"]][i])]
                g.sort(key=lambda x: sea[x["case"]][i])
                xs = np.array([sea[x["case"]][i] for x in g])
                m = np.array([x["reduction_pct_mean"] for x in g])
                lo = np.array([x["reduction_pct_ci95"][0] for x in g])
                hi = np.array([x["reduction_pct_ci95"][1] for x in g])
                # markers only: two or three sea states are separate points, not a trend to draw a line through
                ax.errorbar(xs, m, yerr=[m - lo, hi - m], color=colors[j], marker="o", ls="none", capsize=3,
                            label=var)
            ax.axhline(0.0, color="k", lw=0.8, ls=":")
            ax.set_ylabel(f"{dof} RMSE reduction (%)")
            ax.grid(alpha=0.3)
        axes[-1, col].set_xlabel(label)
    axes[0, 0].legend(fontsize=8)
    fig.suptitle(f"{spec.name}: RMSE reduction against {spec.baseline} (mean, 95 % bootstrap CI)")
    return _save(fig, path)


def plot_campaign(rows: Sequence[dict[str, Any]], summary: dict[str, Any], spec: CampaignSpec,
                  out: str | Path) -> list[Path]:
    """Every campaign figure into ``out`` (see the module); returns the paths written."""
    out = Path(out)
    paths = [plot_box(rows, spec, "rmse", "RMSE", out / CAMPAIGN_FIGURES[0]),
             plot_box(rows, spec, "max_abs_error", "max |error|", out / CAMPAIGN_FIGURES[1]),
             plot_cdf_max_pitch(rows, spec, out / CAMPAIGN_FIGURES[2])]
    extra = plot_reduction_vs_sea(summary, spec, out / CAMPAIGN_FIGURES[3])
    return paths + ([extra] if extra is not None else [])
