"""The aided estimator's consistency figures for docs/estimator.md (issue #19).

    python -m benchmarks.estimator_consistency --campaign runs/estimator --out docs/figures

1. ``estimator_nees_time.png``: one mission per controller (W1, seed 1): each state's NEES
   e²/σ² and the joint NIS per dof over time, as 10 s moving means, with the [0.5, 2] band.
2. ``estimator_nees_seeds.png``: from a campaign's ``missions.parquet`` (configs/campaign/estimator.yaml):
   every mission's mean NEES per state, and its share of errors within 2σ, by sea state and variant.
"""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

STATES = ("x", "z", "theta", "u", "w", "q")
WINDOW = 200    # ticks: 10 s at 20 Hz


def _moving_mean(v: np.ndarray, n: int = WINDOW) -> np.ndarray:
    c = np.cumsum(np.insert(v, 0, 0.0))
    out = np.full(v.size, np.nan)
    out[n - 1:] = (c[n:] - c[:-n]) / n
    return out


def time_figure(out: Path, duration: float = 300.0) -> Path:
    """NEES per state and NIS per dof over one W1 mission per controller (C-PD, FF exact)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from sitl.harness.results import COLUMN
    from sitl.harness.run import run_mission
    from sitl.harness.spec import RunSpec

    fig, axes = plt.subplots(2, 2, figsize=(11, 6), sharex=True)
    for col, controller in enumerate(("cpd", "cpd_ff")):
        ts = run_mission(RunSpec("W1", controller, seed=1, duration=duration)).timeseries
        k = ts[:, 0] > 5.0
        t = ts[k, 0]
        err = ts[k, COLUMN["x_hat"]:COLUMN["q_hat"] + 1] - ts[k, 1:7]
        sig = ts[k][:, [COLUMN[f"sigma_{s}"] for s in STATES]]
        ax = axes[0, col]
        for i, s in enumerate(STATES):
            ax.plot(t, _moving_mean((err[:, i] / sig[:, i]) ** 2), lw=0.9, label=s)
        ax.axhspan(0.5, 2.0, color="0.9", zorder=0)
        ax.set_yscale("log")
        ax.set_ylabel("NEES (10 s mean)")
        ax.set_title(f"W1 seed 1, {'C-PD' if controller == 'cpd' else 'C-PD+FF exact'}")
        ax.legend(ncol=6, fontsize=7)
        nis = _moving_mean(ts[k, COLUMN["nis"]]) / _moving_mean(ts[k, COLUMN["nis_dof"]])
        axes[1, col].plot(t, nis, color="k", lw=0.9)
        axes[1, col].axhspan(0.5, 2.0, color="0.9", zorder=0)
        axes[1, col].set_ylabel("joint NIS / dof (10 s)")
        axes[1, col].set_xlabel("t (s)")
    fig.tight_layout()
    path = out / "estimator_nees_time.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def seeds_figure(campaign: Path, out: Path) -> Path:
    """Mean NEES and 2σ share per mission, by state, sea state and variant, from a campaign's rows."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import pandas as pd

    df = pd.read_parquet(campaign / "missions.parquet")
    df = df[(df["status"] == "ok") & df["variant"].isin(["cpd", "cpd_dob", "ff_exact", "ff_dob_exact",
                                                         "ff_15db", "ff_dob_15db"])]
    variants = list(dict.fromkeys(df["variant"]))
    cases = sorted(df["case"].unique())
    fig, axes = plt.subplots(2, len(cases), figsize=(4.2 * len(cases), 6.5), sharey="row")
    axes = np.atleast_2d(axes).reshape(2, len(cases))
    for j, case in enumerate(cases):
        d = df[df["case"] == case]
        for row, (prefix, band) in enumerate((("ekf_nees_", (0.5, 2.0)), ("ekf_within_2sigma_", (0.95, 1.0)))):
            ax = axes[row, j]
            for vi, v in enumerate(variants):
                dv = d[d["variant"] == v]
                for si, s in enumerate(STATES):
                    xs = si + (vi - (len(variants) - 1) / 2) * 0.12
                    ax.plot(np.full(len(dv), xs), dv[prefix + s], "o", ms=3, color=f"C{vi}",
                            label=v if si == 0 else None)
            ax.axhspan(*band, color="0.9", zorder=0)
            ax.set_xticks(range(len(STATES)), STATES)
            ax.set_title(case if row == 0 else "")
            ax.set_ylabel("mean NEES per mission" if row == 0 else "share within 2σ")
    axes[0, 0].legend(fontsize=7)
    fig.tight_layout()
    path = out / "estimator_nees_seeds.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--campaign", type=Path, default=None, help="a finished estimator campaign's folder")
    p.add_argument("--out", type=Path, default=Path("docs/figures"))
    p.add_argument("--duration", type=float, default=300.0, help="the time figure's missions (s)")
    a = p.parse_args(argv)
    a.out.mkdir(parents=True, exist_ok=True)
    print(time_figure(a.out, a.duration))
    if a.campaign is not None:
        print(seeds_figure(a.campaign, a.out))


if __name__ == "__main__":
    main()
