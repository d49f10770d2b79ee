"""Figures of the world alone: the realised sea against its target spectrum, and the open-loop drift.

Headless (Agg, object-oriented matplotlib, as :mod:`.plots`). Units: time s, elevation m,
frequency Hz, spectral density m²/Hz, position error m, pitch deg, wave load N and N m.
"""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .plots import _figure, _save

__all__ = ["plot_openloop", "plot_sea", "welch_psd"]


def welch_psd(eta: np.ndarray, rate: float) -> tuple[np.ndarray, np.ndarray]:
    """One-sided Welch PSD of the elevation (Hz, m²/Hz): Hann segments of ≤ 256 s, half overlap."""
    from scipy.signal import welch

    nper = int(min(eta.size, max(16, round(256.0 * rate))))
    return welch(eta - np.mean(eta), fs=rate, nperseg=nper)


def plot_sea(sea: Any, t: np.ndarray, eta: np.ndarray, path: str | Path) -> Path:
    """Top: the elevation record η(t) (m). Bottom: its Welch PSD against the target spectrum
    S(f) = 2π S(ω) (m²/Hz), with Hs of each."""
    rate = 1.0 / float(t[1] - t[0])
    f, pxx = welch_psd(eta, rate)
    fig, axes = _figure(2, 1, (10.0, 7.0))
    ax = axes[0, 0]
    ax.plot(t, eta, color="tab:blue", lw=0.6)
    ax.set_xlabel("time t (s)")
    ax.set_ylabel("elevation η (m, up)")
    ax.grid(alpha=0.3)
    ax = axes[1, 0]
    fpos = f[f > 0]
    target = 2.0 * np.pi * np.asarray(sea.spectrum(2.0 * np.pi * fpos), dtype=float)
    ax.plot(fpos, pxx[f > 0], color="tab:blue", lw=1.0,
            label=f"realised (Welch), Hs = 4·std(η) = {4 * np.std(eta):.2f} m")
    ax.plot(fpos, target, color="k", lw=1.2, ls="--", label=f"target spectrum, Hs = {sea.hs_target:.2f} m")
    ax.set_xlim(0.0, min(float(f.max()), 4.0 * sea.omega_peak / (2.0 * np.pi)))
    ax.set_xlabel("frequency f (Hz)")
    ax.set_ylabel("PSD (m²/Hz)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.suptitle(f"Sea {sea.name}, seed {sea.seed}: {t[-1]:g} s at {rate:g} Hz")
    return _save(fig, path)


def plot_openloop(log: np.ndarray, columns: Sequence[str], setpoint: np.ndarray, results: dict,
                  path: str | Path) -> Path:
    """The unpowered vehicle: wave elevation (m), surge and heave drift from the setpoint (m),
    pitch (deg) and the wave loads (N, N m), against time (s)."""
    c = {name: i for i, name in enumerate(columns)}
    t = log[:, c["t"]]
    fig, axes = _figure(5, 1, (10.0, 10.0), sharex=True)
    rows = [("wave_eta", 1.0, 0.0, "wave η at vehicle (m)"), ("x", 1.0, setpoint[0], "surge drift x (m)"),
            ("z", 1.0, setpoint[1], "heave drift z (m, +down)"), ("theta", float(np.degrees(1.0)), setpoint[2],
                                                                   "pitch θ (deg)")]
    for ax, (name, scale, sp, label) in zip(axes[:4, 0], rows, strict=True):
        ax.plot(t, (log[:, c[name]] - sp) * scale, color="k" if name != "wave_eta" else "tab:blue", lw=0.9)
        ax.set_ylabel(label)
    ax = axes[4, 0]
    for name, color in (("tauE_X", "tab:red"), ("tauE_Z", "tab:green")):
        ax.plot(t, log[:, c[name]], color=color, lw=0.8, label=f"{name} (N)")
    ax.plot(t, log[:, c["tauE_M"]], color="tab:purple", lw=0.8, label="tauE_M (N m)")
    ax.set_ylabel("wave load")
    ax.legend(fontsize=8, ncols=3, loc="upper right")
    ax.set_xlabel("time t (s)")
    for a in axes[:, 0]:
        a.grid(alpha=0.3)
    fig.suptitle(f"Open loop in {results['case']}, seed {results['seed']}: the unpowered vehicle released "
                 "at the setpoint")
    return _save(fig, path)
