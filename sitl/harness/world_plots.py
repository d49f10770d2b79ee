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
    """The unpowered vehicle: wave elevation (m), surge drift from the setpoint (m), depth (m, positive down,
    the surface marked), pitch (deg), and the wave loads: forces (N) and moment (N m), against time (s)."""
    c = {name: i for i, name in enumerate(columns)}
    t = log[:, c["t"]]
    fig, axes = _figure(6, 1, (10.0, 12.0), sharex=True)
    ax = axes[0, 0]
    ax.plot(t, log[:, c["wave_eta"]], color="tab:blue", lw=0.9)
    ax.set_ylabel("wave η at\nthe vehicle (m)")
    ax = axes[1, 0]
    ax.plot(t, log[:, c["x"]] - setpoint[0], color="k", lw=0.9)
    ax.set_ylabel("surge drift\nx − x_sp (m)")
    ax = axes[2, 0]
    ax.plot(t, log[:, c["z"]], color="k", lw=0.9, label="depth")
    ax.axhline(setpoint[1], color="k", lw=0.8, ls=":", label=f"released at {setpoint[1]:g} m")
    ax.axhline(0.0, color="tab:blue", lw=1.4, label="surface (depth 0)")
    lo, hi = ax.get_ylim()
    ax.set_ylim(max(hi, setpoint[1] + 0.5), min(lo, -0.5))    # inverted: deeper is lower, the surface in view
    ax.set_ylabel("depth z\n(m, +down)")
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.005, 1.0), frameon=False)
    ax = axes[3, 0]
    ax.plot(t, np.degrees(log[:, c["theta"]] - setpoint[2]), color="k", lw=0.9)
    ax.set_ylabel("pitch θ (deg)")
    ax = axes[4, 0]
    ax.plot(t, log[:, c["tauE_X"]], color="tab:red", lw=0.8, label="surge force τ_E,X")
    ax.plot(t, log[:, c["tauE_Z"]], color="tab:green", lw=0.8, label="heave force τ_E,Z")
    ax.set_ylabel("wave force (N)")
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.005, 1.0), frameon=False)
    ax = axes[5, 0]
    ax.plot(t, log[:, c["tauE_M"]], color="tab:purple", lw=0.8, label="pitch moment τ_E,M")
    ax.set_ylabel("wave moment\n(N m)")
    ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.005, 1.0), frameon=False)
    ax.set_xlabel("time t (s)")
    for a in axes[:, 0]:
        a.grid(alpha=0.3)
    fig.suptitle(f"Open loop in {results['case']}, seed {results['seed']}: the unpowered vehicle released "
                 "at the setpoint")
    return _save(fig, path)
