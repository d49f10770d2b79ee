"""The aided estimator's consistency figures for docs/estimator.md (issue #19).

    python -m benchmarks.estimator_consistency --campaign runs/estimator --out docs/figures

1. ``estimator_nees_time.png``: one mission per controller (W1, seed 1): each state's NEES
   e²/σ² and the joint NIS per dof over time, as 10 s moving means, with the [0.5, 2] band.
2. ``estimator_nees_seeds.png``: from a campaign's ``missions.jsonl`` (configs/campaign/estimator.yaml):
   every mission's mean NEES per state, and its share of errors within 2σ, by sea state and variant.
3. With ``--states``: per sea state and variant, each state's mean NEES, mean and worst share within 2σ, NIS.
4. With ``--table``: the campaign's table (markdown) per sea state and variant: mean RMSE over the three
   DoF normalised by C-PD's per DoF, worst maximum error, total power (bootstrap 95 % intervals over
   seeds), and the estimator's acceptance figures (velocity error ratio, NEES range, 2σ share).
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
        ts = run_mission(RunSpec("W1", controller, seed=1, duration=duration,
                                 overrides={"WK_EKF_MODE": 1})).timeseries
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


def _rows(campaign: Path) -> list[dict]:
    """The campaign's finished missions (:func:`benchmarks.common.campaign_rows`)."""
    from benchmarks.common import campaign_rows

    return campaign_rows(campaign)


def _col(rows: list[dict], key: str) -> np.ndarray:
    return np.array([r[key] for r in rows], dtype=float)


def seeds_figure(campaign: Path, out: Path) -> Path:
    """Mean NEES and 2σ share per mission, by state, sea state and variant, from a campaign's rows."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    shown = ("cpd", "cpd_dob", "ff_exact", "ff_dob_exact", "ff_15db", "ff_dob_15db")
    rows = [r for r in _rows(campaign) if r["variant"] in shown]
    variants = [v for v in shown if any(r["variant"] == v for r in rows)]
    cases = sorted({r["case"] for r in rows})
    fig, axes = plt.subplots(2, len(cases), figsize=(4.2 * len(cases), 6.5), sharey="row")
    axes = np.atleast_2d(axes).reshape(2, len(cases))
    for j, case in enumerate(cases):
        for row, (prefix, band) in enumerate((("ekf_nees_", (0.5, 2.0)), ("ekf_within_2sigma_", (0.95, 1.0)))):
            ax = axes[row, j]
            for vi, v in enumerate(variants):
                dv = [r for r in rows if r["case"] == case and r["variant"] == v]
                for si, s in enumerate(STATES):
                    xs = si + (vi - (len(variants) - 1) / 2) * 0.12
                    ax.plot(np.full(len(dv), xs), _col(dv, prefix + s), "o", ms=3, color=f"C{vi}",
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


def _ci(values, seed: int = 0) -> str:
    from sitl.harness.stats import bootstrap_ci

    v = np.asarray(values, dtype=float)
    lo, hi = bootstrap_ci(v, resamples=5000, seed=seed)
    return f"{v.mean():.3g} [{lo:.3g}, {hi:.3g}]"


def campaign_table(campaign: Path) -> str:
    """The markdown table of docs/estimator.md from a campaign's rows (see the module docstring)."""
    rows = _rows(campaign)
    dofs = ("surge", "heave", "pitch")
    head = ("| case | variant | n | RMSE / C-PD's (mean of 3 DoF) | worst max error x, z (m), θ (°) | power (W) "
            "| vel. err / true u, w (max) | NEES min–max (all states, seeds) | min share within 2σ |")
    lines = [head, "|" + "---|" * 9]
    for case in sorted({r["case"] for r in rows}):
        base = {r["seed"]: r for r in rows if r["case"] == case and r["variant"] == "cpd"}
        for v in dict.fromkeys(r["variant"] for r in rows if r["case"] == case):
            dv = sorted((r for r in rows if r["case"] == case and r["variant"] == v and r["seed"] in base),
                        key=lambda r: r["seed"])
            norm = [np.mean([r[f"rmse_{k}"] / base[r["seed"]][f"rmse_{k}"] for k in dofs]) for r in dv]
            power = [sum(r[f"mean_power_w_{k}"] for k in dofs) for r in dv]
            worst = (f"{_col(dv, 'max_abs_error_surge').max():.2f}, {_col(dv, 'max_abs_error_heave').max():.2f}, "
                     f"{np.degrees(_col(dv, 'max_abs_error_pitch').max()):.1f}")
            vel = max(_col(dv, "ekf_vel_error_ratio_u").max(), _col(dv, "ekf_vel_error_ratio_w").max())
            nees = np.array([_col(dv, f"ekf_nees_{s}") for s in STATES])
            within = np.array([_col(dv, f"ekf_within_2sigma_{s}") for s in STATES])
            lines.append(f"| {case} | {v} | {len(dv)} | {_ci(norm)} | {worst} | {_ci(power)} | {vel:.3f} "
                         f"| {nees.min():.2f}–{nees.max():.2f} | {within.min():.3f} |")
    return "\n".join(lines)


def states_table(campaign: Path) -> str:
    """Per sea state and variant, over seeds: each state's mean NEES, the mean and the worst mission's share
    of errors within 2σ, and the joint NIS per dof — the consistency columns of docs/estimator.md."""
    rows = _rows(campaign)
    head = (f"{'case':4s} {'variant':14s} {'n':>2s} " + " ".join(f"{s:>6s}" for s in STATES) + " | "
            + " ".join(f"{s:>6s}" for s in STATES) + " | " + " ".join(f"{s:>6s}" for s in STATES) + " | NIS/dof")
    lines = ["mean NEES | mean share within 2σ | worst mission's share within 2σ", head]
    for case in sorted({r["case"] for r in rows}):
        for v in sorted({r["variant"] for r in rows if r["case"] == case}):
            dv = [r for r in rows if r["case"] == case and r["variant"] == v]
            nees = [_col(dv, f"ekf_nees_{s}").mean() for s in STATES]
            within = np.array([_col(dv, f"ekf_within_2sigma_{s}") for s in STATES])
            nis = _col(dv, "ekf_nis_per_dof").mean()
            lines.append(f"{case:4s} {v:14s} {len(dv):2d} " + " ".join(f"{x:6.2f}" for x in nees) + " | "
                         + " ".join(f"{x:6.3f}" for x in within.mean(axis=1)) + " | "
                         + " ".join(f"{x:6.3f}" for x in within.min(axis=1)) + f" | {nis:.2f}")
    return "\n".join(lines)


TODAY = {"cpd": "cpd", "cpd_dob": "cpd", "ff_exact": "ff_exact", "ff_dob_exact": "ff_exact",
         "ff_15db": "ff_15db", "ff_dob_15db": "ff_15db"}
"""Each variant of the estimator campaign → the variant, flown with the paper's estimator, it is compared with."""


def versus_table(campaign: Path, today: Path) -> str:
    """Power and RMSE of each variant against the same controller with the paper's estimator ("today"),
    paired by (case, seed) over the seeds both campaigns flew: mean RMSE per DoF, total power, and the
    paired power change in % with its bootstrap 95 % interval."""
    rows, old = _rows(campaign), {(r["case"], r["variant"], r["seed"]): r for r in _rows(today)}
    dofs = ("surge", "heave", "pitch")
    lines = ["| case | variant | vs today's | n | RMSE x, z (m), θ (°): today → now | power (W): today → now "
             "| power change (%) |", "|" + "---|" * 7]
    for case in sorted({r["case"] for r in rows}):
        for v in dict.fromkeys(r["variant"] for r in rows if r["case"] == case):
            mine = [r for r in rows if r["case"] == case and r["variant"] == v
                    and (case, TODAY.get(v), r["seed"]) in old]
            pairs = sorted(((old[(case, TODAY[v], r["seed"])], r) for r in mine), key=lambda p: p[1]["seed"])
            if not pairs:
                continue
            then, now = [p[0] for p in pairs], [p[1] for p in pairs]
            rm = [(_col(then, f"rmse_{k}").mean(), _col(now, f"rmse_{k}").mean()) for k in dofs]
            rm[2] = (np.degrees(rm[2][0]), np.degrees(rm[2][1]))
            pw = [sum(_col(group, f"mean_power_w_{k}") for k in dofs) for group in (then, now)]
            change = 100.0 * (pw[1] / pw[0] - 1.0)
            lines.append(f"| {case} | {v} | {TODAY[v]} | {len(pairs)} | "
                         + ", ".join(f"{a:.3f} → {b:.3f}" for a, b in rm)
                         + f" | {pw[0].mean():.0f} → {pw[1].mean():.0f} | {_ci(change)} |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--campaign", type=Path, default=None, help="a finished estimator campaign's folder")
    p.add_argument("--out", type=Path, default=Path("docs/figures"))
    p.add_argument("--duration", type=float, default=300.0, help="the time figure's missions (s)")
    p.add_argument("--table", action="store_true", help="only print the campaign's table (needs --campaign)")
    p.add_argument("--states", action="store_true", help="only print the per-state consistency (needs --campaign)")
    p.add_argument("--versus", type=Path, default=None,
                   help="only print power and RMSE against this campaign's cpd/ff_exact/ff_15db flown with the "
                   "paper's estimator (e.g. configs/campaign/robust_ff_30_seeds.yaml's folder; needs --campaign)")
    a = p.parse_args(argv)
    if a.versus is not None and a.campaign is not None:
        print(versus_table(a.campaign, a.versus))
        return
    if a.table and a.campaign is not None:
        print(campaign_table(a.campaign))
        return
    if a.states and a.campaign is not None:
        print(states_table(a.campaign))
        return
    a.out.mkdir(parents=True, exist_ok=True)
    print(time_figure(a.out, a.duration))
    if a.campaign is not None:
        print(seeds_figure(a.campaign, a.out))


if __name__ == "__main__":
    main()
