"""``time_history.png``: one run at a glance — the whole mission as envelopes, and a zoom on its story.

600 s at 20 Hz is 12 000 samples: drawn as lines they fill the panel with a solid block of ink.
The overview panels draw each signal as its envelope instead (the minimum and maximum in each of
about 120 bins, filled), which shows the amplitude and where it changes; the zoom panel, at full
rate, shows the detail of the run's story:

1. a pitch flip (|θ| past 90°), from just before it started;
2. else the largest EKF lapse (:func:`~sitl.harness.results.ekf_lapses`), estimate against truth;
3. else the largest error relative to its DoF's RMSE.

Units on every axis (m, deg, N, N m); forces and the moment on panels of their own. FF activity,
thruster saturation and EKF lapses are bars on a status strip rather than shading over the data,
and every legend sits outside the axes, to the right.
"""
from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from .metrics import DOF
from .plots import _DOF_AXES, _col, _error, _preview_target, _save, _zero_line
from .results import RunResult

__all__ = ["ENVELOPE_BINS", "plot_run", "story"]

ENVELOPE_BINS = 120
"""Bins of the overview's envelopes (5 s each for a 600 s mission: about one wave period)."""

FLIP_DEG = 90.0
"""A pitch beyond this (deg) is a flip: the run's story, whatever else happened."""

_HALF = 15.0   # s: the zoom's half width


def envelope(t: np.ndarray, y: np.ndarray, bins: int = ENVELOPE_BINS) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Bin centres (s) and the minimum and maximum of ``y`` over each of ``bins`` equal spans of ``t`` and its
    neighbours (the samples themselves when there are fewer than 2 per bin)."""
    n = t.size
    if n < 2 * bins:
        return t, y, y
    edges = np.linspace(0, n, bins + 1).astype(int)
    lo = np.minimum.reduceat(y, edges[:-1])
    hi = np.maximum.reduceat(y, edges[:-1])
    # over each bin and its two neighbours (15 s for 600 s): a bin shorter than a wave may miss its crest
    lo = np.minimum(lo, np.minimum(np.r_[lo[:1], lo[:-1]], np.r_[lo[1:], lo[-1:]]))
    hi = np.maximum(hi, np.maximum(np.r_[hi[:1], hi[:-1]], np.r_[hi[1:], hi[-1:]]))
    centres = 0.5 * (t[edges[:-1]] + t[np.minimum(edges[1:], n) - 1])
    return centres, lo, hi


def _band(ax: Axes, t: np.ndarray, y: np.ndarray, color: str, label: str, alpha: float = 0.45) -> None:
    tc, lo, hi = envelope(t, y)
    ax.fill_between(tc, lo, hi, color=color, alpha=alpha, lw=0, label=label)


def _outline(ax: Axes, t: np.ndarray, y: np.ndarray, color: str, label: str) -> None:
    tc, lo, hi = envelope(t, y)
    ax.plot(tc, lo, color=color, lw=0.7, label=label)
    ax.plot(tc, hi, color=color, lw=0.7)


EFFORT_BIN_S = 10.0
"""Window (s) of the commanded effort's RMS and peak lines: the wrench swings with every wave, so its
envelope is a solid block; how hard and how close to the limit the thrusters work is what reads."""


def _effort(ax: Axes, t: np.ndarray, y: np.ndarray, color: str, label: str) -> None:
    """RMS (solid) and peak |y| (dotted) of a commanded force or moment in windows of :data:`EFFORT_BIN_S`."""
    dt = float(np.median(np.diff(t))) if t.size > 1 else 1.0
    per = max(1, int(round(EFFORT_BIN_S / dt)))
    bins = max(1, t.size // per)
    edges = np.linspace(0, t.size, bins + 1).astype(int)
    centres = np.array([0.5 * (t[a] + t[b - 1]) for a, b in itertools.pairwise(edges)])
    rms = np.sqrt(np.add.reduceat(y * y, edges[:-1]) / np.diff(edges))
    peak = np.maximum.reduceat(np.abs(y), edges[:-1])
    ax.plot(centres, rms, color=color, lw=1.3, label=f"{label} RMS over {EFFORT_BIN_S:g} s")
    ax.plot(centres, peak, color=color, lw=0.9, ls=":", label=f"{label} peak |·| over {EFFORT_BIN_S:g} s")
    ax.set_ylim(0.0, max(ax.get_ylim()[1], 1.05 * float(np.max(peak, initial=0.0))))


def story(result: RunResult) -> tuple[str, str, float, tuple[float, float]]:
    """What the zoom shows: (kind, DoF, time of interest (s), window (s)); kind ``pitch flip``, ``EKF lapse``
    or ``largest error``."""
    t = _col(result, "t")
    span = (float(t[0]), float(t[-1]))

    def window(a: float, b: float) -> tuple[float, float]:
        return max(span[0], a), min(span[1], b)

    pitch = np.degrees(np.abs(_col(result, "theta")))
    if np.any(pitch > FLIP_DEG):
        k = int(np.argmax(pitch > FLIP_DEG))
        start = int(np.flatnonzero(pitch[:k + 1] < 10.0)[-1]) if np.any(pitch[:k + 1] < 10.0) else k
        return "pitch flip", "pitch", float(t[k]), window(float(t[start]) - 10.0, float(t[start]) + 2 * _HALF - 10.0)
    laps = (result.results.get("ekf") or {}).get("lapses") or []
    if laps:
        dof = {"x": "surge", "z": "heave", "theta": "pitch"}
        worst = max(laps, key=lambda d: d["max_error"] / max(d["sigma"], 1e-9))
        tk = worst["t_s"] + 0.5 * worst["duration_s"]
        return "EKF lapse", dof[worst["state"]], tk, window(tk - _HALF, tk + _HALF)
    best = ("surge", 0.0, -1.0)
    for d in DOF:
        e = np.abs(_error(result, d))
        rms = float(np.sqrt(np.mean(e**2))) or 1.0
        k = int(np.argmax(e))
        if e[k] / rms > best[2]:
            best = (d, float(t[k]), float(e[k] / rms))
    return "largest error", best[0], best[1], window(best[1] - _HALF, best[1] + _HALF)


def _status(ax: Axes, t: np.ndarray, rows: list[tuple[str, np.ndarray, str]]) -> None:
    """One row of bars per flag (label, mask, colour), with the share of ticks it held."""
    dt = float(np.median(np.diff(t))) if t.size > 1 else 1.0
    for i, (_label, mask, color) in enumerate(rows):
        on = np.flatnonzero(np.diff(np.r_[0, mask.astype(int), 0]))
        spans = [(t[a] - dt / 2, (b - a) * dt) for a, b in zip(on[::2], on[1::2], strict=True)]
        ax.broken_barh(spans, (i - 0.35, 0.7), color=color, lw=0)
    ax.set_yticks(range(len(rows)), [f"{label} ({100 * np.mean(m):.0f} %)" for label, m, _ in rows], fontsize=7)
    ax.set_ylim(-0.6, len(rows) - 0.4)
    ax.grid(axis="x", alpha=0.3)


def _legend(ax: Axes) -> None:
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="upper left", bbox_to_anchor=(1.005, 1.0), fontsize=7, frameon=False, borderaxespad=0.0)


def plot_run(result: RunResult, path: str | Path) -> Path:
    """Time history of one run as a PNG (see the module docstring): wave elevation (m), surge, heave (depth)
    and pitch error (m, m, deg; truth filled, EKF estimate dashed), the commanded forces (N) and moment
    (N m), the status strip, and the zoom on the run's story."""
    r = result.results
    t = _col(result, "t")
    kind, dof, tk, win = story(result)
    fig = Figure(figsize=(11.0, 14.0), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(8, 1, gridspec_kw={"height_ratios": [1, 1, 1, 1, 0.9, 0.9, 0.45, 1.6]})
    for ax in axes[1:7]:
        ax.sharex(axes[0])
    _band(axes[0], t, _col(result, "wave_eta"), "tab:blue", "wave η at the vehicle")
    fc = _col(result, "forecast_eta")
    if np.isfinite(fc).any():
        _outline(axes[0], t, fc, "tab:orange", "forecast η")
    axes[0].set_ylabel("elevation η (m)")
    for ax, d in zip(axes[1:4], DOF, strict=True):
        _band(ax, t, _error(result, d), "k", "truth", alpha=0.35)
        _outline(ax, t, _error(result, d, estimate=True), "tab:green", "EKF estimate")
        if (prv := _preview_target(result, d)) is not None:
            _outline(ax, t, prv, "tab:orange", "preview target")
        _zero_line(ax, "setpoint")
        ax.set_ylabel(_DOF_AXES[d][4])
    for name, color, what in (("tau_X", "tab:red", "surge τ_X"), ("tau_Z", "tab:green", "heave τ_Z")):
        _effort(axes[4], t, _col(result, name), color, what)
    axes[4].set_ylabel("commanded\nforce (N)")
    _effort(axes[5], t, _col(result, "tau_M"), "tab:purple", "pitch τ_M")
    axes[5].set_ylabel("commanded\nmoment (N m)")
    flags = [("FF active", _col(result, "ff_active") > 0.5, "tab:blue"),
             ("saturated", _col(result, "saturated") > 0.5, "tab:red")]
    laps = np.zeros(t.size, dtype=bool)
    for lap in (r.get("ekf") or {}).get("lapses") or []:
        laps |= (t >= lap["t_s"]) & (t < lap["t_s"] + lap["duration_s"])
    flags.append(("EKF lapse", laps, "tab:olive"))
    _status(axes[6], t, flags)
    axes[6].set_xlabel("time t (s)")
    for ax in axes[:6]:
        ax.axvspan(*win, fill=False, ec="0.4", ls=":", lw=0.8)
        ax.grid(alpha=0.3)
        ax.tick_params(labelbottom=False)
    for ax in axes[:6]:
        _legend(ax)
    _zoom(axes[7], result, kind, dof, tk, win)
    rm = r.get("rmse", {})
    fig.suptitle(f"{r.get('case', '?')} {r.get('label', '?')}, seed {r.get('seed', '?')} — RMSE "
                 f"surge {rm.get('surge', np.nan):.3f} m, heave {rm.get('heave', np.nan):.3f} m, "
                 f"pitch {np.degrees(rm.get('pitch', np.nan)):.2f}° (the dotted box is the zoom)")
    return _save(fig, path)


def _zoom(ax: Axes, result: RunResult, kind: str, dof: str, tk: float, win: tuple[float, float]) -> None:
    """The story at full rate: truth and EKF estimate of ``dof`` over ``win``, with the wave on a second axis."""
    t = _col(result, "t")
    m = (t >= win[0]) & (t <= win[1])
    ax.plot(t[m], _error(result, dof, estimate=True)[m], color="tab:green", lw=1.0, ls="--", label="EKF estimate")
    ax.plot(t[m], _error(result, dof)[m], color="k", lw=1.4, label="truth")
    if (prv := _preview_target(result, dof)) is not None:
        ax.plot(t[m], prv[m], color="tab:orange", lw=1.0, label="preview target (WK_PRV_*)")
    _zero_line(ax, "setpoint")
    sat = _col(result, "saturated")[m] > 0.5
    if np.any(sat):   # a rug along the bottom, not shading over the data
        ax.plot(t[m][sat], np.zeros(int(sat.sum())), "|", color="tab:red", ms=6,
                transform=ax.get_xaxis_transform(), label="saturated")
    ax.axvline(tk, color="tab:red", lw=0.8, ls=":")
    ax.set_ylabel(_DOF_AXES[dof][4])
    ax.set_xlabel("time t (s)")
    ax.grid(alpha=0.3)
    wave = ax.twinx()
    wave.plot(t[m], _col(result, "wave_eta")[m], color="tab:blue", lw=0.8, alpha=0.6, label="wave η (right axis)")
    wave.set_ylabel("wave η (m)", color="tab:blue")
    handles = ax.get_legend_handles_labels()
    more = wave.get_legend_handles_labels()
    ax.legend(handles[0] + more[0], handles[1] + more[1], loc="upper left", bbox_to_anchor=(1.07, 1.0), fontsize=7,
              frameon=False, borderaxespad=0.0)
    what = {"pitch flip": f"pitch flip: |θ| passes {FLIP_DEG:g}° at t = {tk:.1f} s",
            "EKF lapse": f"EKF lapse in {dof}: the estimate leaves the truth around t = {tk:.1f} s",
            "largest error": f"largest {dof} error (against its RMSE), t = {tk:.1f} s"}[kind]
    ax.set_title(f"zoom — {what}", fontsize=9)
