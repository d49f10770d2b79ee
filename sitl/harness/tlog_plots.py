"""The figure of a tlog (``wavekeep tlog``): what the vehicle reported, on its own clock.

Panels, each with its unit: position (x north and depth, m), attitude (roll, pitch, deg), the
eight thruster outputs (µs; the band between the lowest and the highest, and the mean), the
feed-forward's predicted wave load where the vehicle is Wavekeep (NAMED_VALUE_FLOAT FF_X/Z/M, N and
N m), and the flight modes as shaded spans with the arming changes marked.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from .tlog import TlogData

__all__ = ["plot_tlog"]

_MODE_COLORS = ("#e8f0fb", "#fbeee0", "#e9f7e9", "#f6e6f4", "#f3f3df", "#e0f4f6")


def _mode_spans(data: TlogData, t_end: float) -> list[tuple[float, float, str]]:
    modes = [(e.t, e.text[len("mode "):]) for e in data.events if e.kind == "mode"]
    return [(t0, modes[i + 1][0] if i + 1 < len(modes) else t_end, name) for i, (t0, name) in enumerate(modes)]


def plot_tlog(cols: dict[str, np.ndarray], data: TlogData, path: str | Path) -> Path:
    """Draw ``path`` (PNG) from :func:`~sitl.harness.tlog_view.tlog_columns` and the tlog's events."""
    t = cols["t"]
    fig = Figure(figsize=(11.0, 10.0), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(4, 1, sharex=True)
    panels = [
        (axes[0], "position (m)", [("plots/tlog/position/x", "x north"), ("plots/tlog/position/z", "depth z (+down)")]),
        (axes[1], "attitude (deg)", [("plots/tlog/attitude/roll", "roll"), ("plots/tlog/attitude/pitch", "pitch")]),
        (axes[3], "predicted wave load (N, N m)", [("plots/tlog/named/FF_X", "FF X (N)"),
                                                   ("plots/tlog/named/FF_Z", "FF Z (N)"),
                                                   ("plots/tlog/named/FF_M", "FF M (N m)")]),
    ]
    for ax, unit, series in panels:
        drawn = [ax.plot(t, cols[name], lw=0.9, label=label) for name, label in series if name in cols]
        ax.set_ylabel(unit)
        if drawn:
            ax.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=8, frameon=False)
        else:
            ax.text(0.5, 0.5, "not in this log", transform=ax.transAxes, ha="center", va="center", color="0.5")
    servo = [cols[f"plots/tlog/servo/servo{i}"] for i in range(1, 9) if f"plots/tlog/servo/servo{i}" in cols]
    ax = axes[2]
    if servo:
        s = np.vstack(servo)
        ax.fill_between(t, np.nanmin(s, axis=0), np.nanmax(s, axis=0), color="tab:purple", alpha=0.25,
                        label="lowest to highest of the 8", lw=0)
        ax.plot(t, np.nanmean(s, axis=0), color="tab:purple", lw=0.8, label="mean")
        ax.axhline(1500.0, color="0.4", lw=0.6, ls=":")
        ax.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=8, frameon=False)
    ax.set_ylabel("thruster output (µs)")
    t_end = float(t[-1]) if t.size else 0.0
    names = sorted({name for *_, name in _mode_spans(data, t_end)})
    for t0, t1, name in _mode_spans(data, t_end):
        for a in axes:
            a.axvspan(t0, t1, color=_MODE_COLORS[names.index(name) % len(_MODE_COLORS)], lw=0, zorder=0)
        axes[0].annotate(name, (t0, 1.0), xycoords=("data", "axes fraction"), fontsize=7, va="bottom")
    for e in data.events:
        if e.kind in ("armed", "disarmed"):
            for a in axes:
                a.axvline(e.t, color="tab:red" if e.kind == "armed" else "0.3", lw=0.8, ls="--")
    axes[-1].set_xlabel("vehicle time (s)")
    fig.suptitle(f"{Path(data.path).name}: system {data.sysid}, {data.messages} messages", fontsize=10)
    fig.savefig(path, dpi=110)
    return Path(path)
