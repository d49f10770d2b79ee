"""Figures of runs side by side and of the paper's nine-run reproduction (Walker et al. Figs. 4–7); one run's
``time_history.png`` is :mod:`.run_plot`'s.

Everything here uses matplotlib's object-oriented API (:class:`~matplotlib.figure.Figure`
behind a :class:`~matplotlib.backends.backend_agg.FigureCanvasAgg`), so it needs
no display and touches no global pyplot/backend state: safe in worker processes,
CI and alongside other matplotlib users.

Units on every axis: time s, wave elevation m, surge/heave error m (heave is
depth error, positive down), pitch error degrees, power W. Errors are truth (or
EKF estimate) minus the setpoint logged on the same tick.
"""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Literal

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from .metrics import DOF
from .results import TIMESERIES_COLUMNS, RunResult
from .spec import PAPER_CASES as CASES
from .spec import PAPER_VARIANTS

__all__ = ["LABELS", "REPRODUCE_FIGURES", "plot_compare", "plot_reproduce", "power_figure"]

DPI = 120
LABELS: tuple[str, ...] = tuple(v.label for v in PAPER_VARIANTS)   # C-PD, exact, 15 dB
CPD, FF_EXACT, FF_SNR = LABELS
REPRODUCE_FIGURES = (*(f"fig4_time_history_{c}.png" for c in CASES), *(f"fig5_forecast_{c}.png" for c in CASES),
                     "fig6_errors.png", "fig7_power.png")
"""What ``plot_reproduce`` writes: Figs. 4 and 5 for every sea state, then Figs. 6 and 7."""

_STYLE = {
    CPD: dict(color="tab:red", ls="-", lw=1.1),
    FF_EXACT: dict(color="tab:blue", ls="-", lw=1.1),
    FF_SNR: dict(color="tab:orange", ls="--", lw=1.0),
}
# (truth column, estimate column, setpoint column, scale to display units, y label)
_DOF_AXES = {
    "surge": ("x", "x_hat", "sp_x", 1.0, "surge error x (m)"),
    "heave": ("z", "z_hat", "sp_z", 1.0, "heave error z (m, +down)"),
    "pitch": ("theta", "theta_hat", "sp_theta", float(np.degrees(1.0)), "pitch error θ (deg)"),
}
_COL = {name: i for i, name in enumerate(TIMESERIES_COLUMNS)}


# ---------------------------------------------------------------------------- helpers

def _col(result: RunResult, name: str) -> np.ndarray:
    """One time-series column by name (units as logged: s, m, rad, N, ...)."""
    ts = np.asarray(result.timeseries)
    if ts.ndim != 2 or ts.shape[1] != len(TIMESERIES_COLUMNS):
        raise ValueError(f"timeseries must have shape (ticks, {len(TIMESERIES_COLUMNS)}), got {ts.shape}")
    return ts[:, _COL[name]]


def _error(result: RunResult, dof: str, estimate: bool = False) -> np.ndarray:
    """Truth (or EKF estimate) minus setpoint for one DoF, in display units (m, m, deg)."""
    truth, est, sp, scale, _ = _DOF_AXES[dof]
    return (_col(result, est if estimate else truth) - _col(result, sp)) * scale


def _preview_target(result: RunResult, dof: str) -> np.ndarray | None:
    """The saturation preview's target offset for surge or heave (m), or None where it never acted."""
    col = {"surge": "prv_x", "heave": "prv_z"}.get(dof)
    prv = None if col is None else _col(result, col)
    return prv if prv is not None and np.any(prv != 0.0) else None


def _window(t: np.ndarray, window: tuple[float, float]) -> np.ndarray:
    """Boolean mask of t (s) within ``window`` clipped to the data; all of t if they do not overlap."""
    lo, hi = max(window[0], t.min()), min(window[1], t.max())
    return (t >= lo) & (t <= hi) if hi > lo else np.ones_like(t, dtype=bool)


def _figure(nrows: int, ncols: int, size: tuple[float, float],
            sharex: bool | Literal["none", "all", "row", "col"] = False) -> tuple[Figure, np.ndarray]:
    """A headless Agg-backed figure (size in inches) and its axes as a 2-D array."""
    fig = Figure(figsize=size, layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(nrows, ncols, sharex=sharex, squeeze=False)
    return fig, axes


def _save(fig: Figure, path: str | Path) -> Path:
    """Write ``fig`` as a PNG at DPI and release it; returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=DPI, format="png")
    fig.clear()
    return path


def _select(runs: Sequence[RunResult], case: str, label: str) -> RunResult:
    """The one run of ``case`` whose label is ``label`` (before the ", ..." that names changed parameters:
    ``reproduce --set`` flies all nine so), else ValueError."""
    found = [r for r in runs if r.results.get("case") == case
             and str(r.results.get("label", "")).split(", ")[0] == label]
    if len(found) != 1:
        have = sorted(f"{r.results.get('case')} / {r.results.get('label')}" for r in runs)
        what = "no run" if not found else f"{len(found)} runs"
        raise ValueError(f"plot_reproduce: {what} for case {case!r}, label {label!r}; have {have}")
    return found[0]


def _zero_line(ax: Axes, label: str | None = None) -> None:
    ax.axhline(0.0, color="k", lw=0.8, ls=":", label=label)


# ---------------------------------------------------------------------------- runs side by side

def plot_compare(runs: Sequence[RunResult], names: Sequence[str], path: str | Path) -> Path:
    """Runs overlaid: surge, heave and pitch error against time (m, m, deg; top) and their
    histograms (share of ticks; bottom), one colour per run."""
    fig, axes = _figure(2, 3, (14.0, 7.5))
    colors = [f"C{i % 10}" for i in range(len(runs))]
    for run, name, color in zip(runs, names, colors, strict=True):
        t = _col(run, "t")
        for j, dof in enumerate(DOF):
            e = _error(run, dof)
            rms = float(np.sqrt(np.mean(e**2)))
            unit = "deg" if dof == "pitch" else "m"
            axes[0, j].plot(t, e, color=color, lw=0.7, alpha=0.8, label=f"{name} (RMSE {rms:.3g} {unit})")
            axes[1, j].hist(e, bins=60, density=True, histtype="step", color=color, lw=1.2, label=name)
    for j, dof in enumerate(DOF):
        unit = _DOF_AXES[dof][4]
        axes[0, j].set_ylabel(unit)
        axes[0, j].set_xlabel("time t (s)")
        axes[0, j].legend(fontsize=7, loc="upper right")
        axes[1, j].set_xlabel(unit)
        axes[1, j].set_ylabel(f"probability density (1/{'deg' if dof == 'pitch' else 'm'})")
        axes[1, j].legend(fontsize=7, loc="upper right")
        for ax in axes[:, j]:
            ax.grid(alpha=0.3)
    fig.suptitle("Compared runs: " + ", ".join(
        f"{n} = {r.results.get('case')} {r.results.get('label')} seed {r.results.get('seed')}"
        for n, r in zip(names, runs, strict=True)), fontsize=9)
    return _save(fig, path)


# ---------------------------------------------------------------------------- the paper's figures

def plot_time_history(runs: Sequence[RunResult], path: str | Path, case: str = "W3",
                      window: tuple[float, float] = (250.0, 400.0)) -> Path:
    """Fig. 4: wave elevation (m) then surge, heave (m) and pitch (deg) error of C-PD, C-PD+FF
    exact and C-PD+FF 15 dB overlaid, over ``window`` (s) clipped to the data."""
    sel = {label: _select(runs, case, label) for label in LABELS}
    fig, axes = _figure(4, 1, (10.0, 9.0), sharex=True)
    wave = sel[CPD]
    m = _window(_col(wave, "t"), window)
    axes[0, 0].plot(_col(wave, "t")[m], _col(wave, "wave_eta")[m], color="tab:blue", lw=1.0)
    axes[0, 0].set_ylabel("wave elevation η (m)")
    for label, run in sel.items():
        t = _col(run, "t")
        m = _window(t, window)
        for ax, dof in zip(axes[1:, 0], DOF, strict=False):
            ax.plot(t[m], _error(run, dof)[m], label=label, **_STYLE[label])
    for ax, dof in zip(axes[1:, 0], DOF, strict=False):
        _zero_line(ax)
        ax.set_ylabel(_DOF_AXES[dof][4])
    axes[1, 0].legend(loc="upper right", fontsize=8, ncols=3)
    axes[-1, 0].set_xlabel("time t (s)")
    for ax in axes[:, 0]:
        ax.grid(alpha=0.3)
    fig.suptitle(f"{case} time history: C-PD vs C-PD+FF")
    return _save(fig, path)


def _snr_db(truth: np.ndarray, forecast: np.ndarray) -> float:
    """10 log10(var(η) / var(η̂ − η)) in dB over the finite samples; nan if undefined."""
    ok = np.isfinite(truth) & np.isfinite(forecast)
    err = np.var(forecast[ok] - truth[ok]) if ok.any() else np.nan
    return float(10.0 * np.log10(np.var(truth[ok]) / err)) if ok.any() and err > 0 else float("nan")


def plot_forecast(runs: Sequence[RunResult], path: str | Path, case: str = "W3",
                  window: tuple[float, float] = (250.0, 310.0)) -> Path:
    """Fig. 5: the encountered wave (exact run's ``wave_eta``, m) against the 15 dB forecast's
    elevation (``forecast_eta`` of the 15 dB run, m) over ``window`` (s), and their difference.
    The legend gives the SNR realised over the whole 15 dB run (dB, from that run's own columns)."""
    exact, noisy = _select(runs, case, FF_EXACT), _select(runs, case, FF_SNR)
    fig, axes = _figure(2, 1, (10.0, 5.5), sharex=True)
    te, tn = _col(exact, "t"), _col(noisy, "t")
    me, mn = _window(te, window), _window(tn, window)
    eta, fc = _col(exact, "wave_eta"), _col(noisy, "forecast_eta")
    snr = _snr_db(_col(noisy, "wave_eta"), fc)
    axes[0, 0].plot(te[me], eta[me], color="k", lw=1.2, label="encountered wave η")
    axes[0, 0].plot(tn[mn], fc[mn], color="tab:orange", lw=1.0, ls="--",
                    label=f"{FF_SNR} forecast η̂ (elevation SNR {snr:.1f} dB, docs/results.md)")
    axes[0, 0].set_ylabel("elevation (m)")
    axes[0, 0].legend(loc="upper right", fontsize=8)
    if te.shape == tn.shape and np.allclose(te, tn):
        axes[1, 0].plot(te[me], (fc - eta)[me], color="tab:purple", lw=0.9)
    axes[1, 0].set_ylabel("η̂ − η (m)")
    axes[1, 0].set_xlabel("time t (s)")
    for ax in axes[:, 0]:
        ax.grid(alpha=0.3)
    fig.suptitle(f"{case}: encountered wave vs forecast")
    return _save(fig, path)


def _grouped_bars(ax: Axes, values: dict[str, list[float]], unit: str, fmt: str) -> None:
    """Bars grouped by case (x) with one bar per controller label; values[label][i] per CASES[i]."""
    x = np.arange(len(CASES))
    width = 0.8 / len(values)
    for i, (label, v) in enumerate(values.items()):
        bars = ax.bar(x + (i - (len(values) - 1) / 2) * width, v, width, label=label, color=_STYLE[label]["color"])
        ax.bar_label(bars, fmt=fmt, fontsize=6, padding=1)
    ax.set_xticks(x, CASES)
    ax.set_ylabel(unit)
    ax.margins(y=0.15)
    ax.grid(axis="y", alpha=0.3)


ANGLE_METRICS = ("rmse", "max_abs_error")
"""results.json metrics whose pitch entry is an angle (rad, shown in deg); power is W for every DoF."""


def _metric(runs: Sequence[RunResult], key: str, dof: str) -> dict[str, list[float]]:
    """results[key][dof] per label and case; a pitch angle (RMSE, max error) converted from rad to deg,
    any other metric (power, W) as it is."""
    scale = float(np.degrees(1.0)) if dof == "pitch" and key in ANGLE_METRICS else 1.0
    return {label: [_select(runs, c, label).results[key][dof] * scale for c in CASES] for label in LABELS}


def plot_errors(runs: Sequence[RunResult], path: str | Path) -> Path:
    """Fig. 6: RMSE (top row) and max |error| (bottom row) for surge (m), heave (m) and pitch (deg),
    grouped by case with one bar per controller."""
    fig, axes = _figure(2, 3, (12.0, 6.5))
    for row, (key, name) in enumerate((("rmse", "RMSE"), ("max_abs_error", "max |error|"))):
        for col, dof in enumerate(DOF):
            unit = "deg" if dof == "pitch" else "m"
            _grouped_bars(axes[row, col], _metric(runs, key, dof), f"{name} ({unit})",
                          "%.2f" if dof == "pitch" else "%.3f")
            axes[row, col].set_title(f"{dof} {name}")
    fig.legend(*axes[0, 0].get_legend_handles_labels(), loc="outside lower center", ncols=len(LABELS), fontsize=8)
    fig.suptitle("Station-keeping error per sea state and controller")
    return _save(fig, path)


def plot_power(runs: Sequence[RunResult], path: str | Path) -> Path:
    """Fig. 7: mean thruster power (W, the paper's T200 fit) per DoF and in total,
    grouped by case with one bar per controller."""
    return _save(power_figure(runs), path)


def power_figure(runs: Sequence[RunResult]) -> Figure:
    """Fig. 7 as a figure: axes surge, heave, pitch, total; on each, the bars of LABELS[i] are
    ``ax.containers[i]`` in CASES order, heights in W (the numbers of the reproduce table)."""
    fig, axes = _figure(1, 4, (14.0, 4.0))
    per = {dof: _metric(runs, "mean_power_w", dof) for dof in DOF}
    total = {label: list(np.sum([per[d][label] for d in DOF], axis=0)) for label in LABELS}
    for ax, (name, vals) in zip(axes[0], [*per.items(), ("total", total)], strict=False):
        _grouped_bars(ax, vals, "mean power (W)", "%.2f" if name == "pitch" else "%.0f")
        ax.set_title(f"{name}")
    fig.legend(*axes[0, 0].get_legend_handles_labels(), loc="outside lower center", ncols=len(LABELS), fontsize=8)
    fig.suptitle("Mean power per DoF and in total")   # (the legend below the bars: on an axis it hid one)
    return fig


def plot_reproduce(runs: Sequence[RunResult], out_dir: str | Path, window: tuple[float, float] = (250.0, 400.0),
                   forecast_window: tuple[float, float] = (250.0, 310.0)) -> list[Path]:
    """The paper's Figs. 4–7 from the nine runs (W1..W3 × C-PD, C-PD+FF exact, C-PD+FF 15 dB) into
    ``out_dir``; runs are picked by results["case"] and ["label"], so order does not matter and a
    missing (or duplicated) run raises ValueError before anything is written. Windows in s."""
    for c in CASES:
        for label in LABELS:
            _select(runs, c, label)
    out = Path(out_dir)
    return [*(plot_time_history(runs, out / f"fig4_time_history_{c}.png", c, window) for c in CASES),
            *(plot_forecast(runs, out / f"fig5_forecast_{c}.png", c, forecast_window) for c in CASES),
            plot_errors(runs, out / "fig6_errors.png"), plot_power(runs, out / "fig7_power.png")]
