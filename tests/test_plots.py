"""The figures: written, valid PNGs, and runs picked by case/label rather than position."""
from __future__ import annotations

import random
import re
from pathlib import Path

import numpy as np
import pytest

from sitl.harness.plots import LABELS, REPRODUCE_FIGURES, plot_reproduce
from sitl.harness.run import TIMESERIES_COLUMNS, RunResult, run_mission, write_run
from sitl.harness.run_plot import plot_run
from sitl.harness.spec import RunSpec

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
CASES = ("W1", "W2", "W3")


def synthetic_run(case: str, label: str, duration: float = 20.0, rate: float = 20.0, seed: int = 0) -> RunResult:
    """A RunResult with the right columns and results keys, made of sinusoids (no simulation)."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration, 1.0 / rate)
    ts = np.zeros((t.size, len(TIMESERIES_COLUMNS)))
    col = {c: i for i, c in enumerate(TIMESERIES_COLUMNS)}
    eta = np.sin(0.6 * t) + 0.3 * np.sin(1.1 * t + 1.0)
    ts[:, col["t"]] = t
    ts[:, col["wave_eta"]] = eta
    ts[:, col["forecast_eta"]] = np.nan if label == "C-PD" else eta + 0.1 * rng.standard_normal(t.size)
    ts[:, col["sp_z"]] = 5.0
    axes = (("x", "x_hat", "sp_x", 0.3), ("z", "z_hat", "sp_z", 0.2), ("theta", "theta_hat", "sp_theta", 0.05))
    for truth, est, sp, a in axes:
        ts[:, col[truth]] = ts[:, col[sp]] + a * np.sin(0.6 * t + a)
        ts[:, col[est]] = ts[:, col[truth]] + 0.01 * a * rng.standard_normal(t.size)
    dofs = ("surge", "heave", "pitch")
    results = {
        "case": case, "label": label, "seed": seed,
        "rmse": dict(zip(dofs, rng.uniform(0.05, 0.5, 3).tolist(), strict=False)),
        "max_abs_error": dict(zip(dofs, rng.uniform(0.5, 2.0, 3).tolist(), strict=False)),
        "mean_power_w": dict(zip(dofs, rng.uniform(10.0, 500.0, 3).tolist(), strict=False)),
    }
    return RunResult(results, ts)


@pytest.fixture(scope="module")
def nine_runs() -> list[RunResult]:
    return [synthetic_run(c, label, seed=i) for i, (c, label) in enumerate((c, lab) for c in CASES for lab in LABELS)]


def assert_png(path: Path, min_bytes: int = 10_000) -> None:
    assert path.is_file(), path
    data = path.read_bytes()
    assert data[:8] == PNG_MAGIC, f"{path} is not a PNG"
    assert len(data) > min_bytes, f"{path} is suspiciously small ({len(data)} bytes)"


def test_labels_match_the_reproduction():
    assert LABELS == ("C-PD", "C-PD+FF exact", "C-PD+FF 15 dB")


def test_plot_run_writes_a_png(tmp_path):
    out = plot_run(synthetic_run("W3", "C-PD+FF 15 dB"), tmp_path / "sub" / "time_history.png")
    assert out == tmp_path / "sub" / "time_history.png"
    assert_png(out)


def test_plot_run_without_forecast(tmp_path):
    assert_png(plot_run(synthetic_run("W1", "C-PD"), tmp_path / "cpd.png"))


def test_plot_run_rejects_wrong_columns(tmp_path):
    bad = RunResult({"case": "W1", "label": "C-PD"}, np.zeros((10, 5)))
    with pytest.raises(ValueError, match="timeseries"):
        plot_run(bad, tmp_path / "bad.png")


def test_plot_reproduce_writes_figs_4_and_5_per_case_and_6_and_7(tmp_path, nine_runs):
    shuffled = nine_runs[:]
    random.Random(1).shuffle(shuffled)           # selection is by case/label, not by position
    paths = plot_reproduce(shuffled, tmp_path)
    assert [p.name for p in paths] == list(REPRODUCE_FIGURES)
    for p in paths:
        assert p.parent == tmp_path
        assert_png(p)


def test_plot_reproduce_window_outside_the_data_falls_back(tmp_path, nine_runs):
    # the runs last 20 s; the default Fig. 4 window (250–400 s) does not overlap them
    paths = plot_reproduce(nine_runs, tmp_path, window=(250.0, 400.0), forecast_window=(5.0, 10.0))
    assert all(p.is_file() for p in paths)


@pytest.mark.parametrize("missing", [0, 5, 8])
def test_plot_reproduce_missing_run_raises(tmp_path, nine_runs, missing):
    runs = nine_runs[:missing] + nine_runs[missing + 1:]
    gone = nine_runs[missing].results
    with pytest.raises(ValueError, match=f"{re.escape(gone['case'])}.*{re.escape(gone['label'])}"):
        plot_reproduce(runs, tmp_path)
    assert not list(tmp_path.glob("*.png")), "nothing should be written when a run is missing"


def test_plot_reproduce_duplicate_run_raises(tmp_path, nine_runs):
    with pytest.raises(ValueError):
        plot_reproduce([*nine_runs, nine_runs[0]], tmp_path)


def test_write_run_plots_a_real_short_mission(tmp_path):
    result = run_mission(RunSpec("W1", "cpd_ff", 15.0, duration=2.0))
    out = write_run(result, tmp_path / "run")
    assert_png(out / "time_history.png")


def test_fig7_bars_equal_the_power_in_the_table(nine_runs):
    """Issue #17: pitch power was multiplied by 57.3 (the rad→deg scale of the error metrics)."""
    from sitl.harness.plots import power_figure

    fig = power_figure(nine_runs)
    axes = fig.axes[:4]
    for ax, dof in zip(axes, ("surge", "heave", "pitch", "total"), strict=True):
        for container, label in zip(ax.containers, LABELS, strict=True):
            heights = [bar.get_height() for bar in container]
            for c, h in zip(CASES, heights, strict=True):
                run = next(r for r in nine_runs if r.results["case"] == c and r.results["label"] == label)
                p = run.results["mean_power_w"]
                want = sum(p.values()) if dof == "total" else p[dof]
                assert h == pytest.approx(want), (dof, c, label)
