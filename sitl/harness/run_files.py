"""The files a mission run leaves in its folder, whichever way it was flown (``run``, ``sim``, ``reproduce``).

Apart from :mod:`sitl.harness.run` so that the multi-process launcher writes them without
importing the in-process runner (the firmware, numba, scipy: ~0.7 s of its start-up).
"""
from __future__ import annotations

from pathlib import Path

from .results import RunResult, write_results

__all__ = ["write_run"]


def write_run(result: RunResult, out: str | Path, plots: bool = True) -> Path:
    """DIR/results.json, DIR/timeseries.csv and (optionally) DIR/time_history.png."""
    out = write_results(result, out)
    if plots:
        from .run_plot import plot_run  # matplotlib: imported only when a figure is drawn
        plot_run(result, out / "time_history.png")
    return out
