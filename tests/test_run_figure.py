"""time_history.png tells the run's story (a pitch flip over a bigger heave error), EKF lapses are found and
printed, and the overview draws envelopes, not 12 000-sample lines. Checked against synthetic series whose
story is known; the figures themselves were looked at (W2F paper law, W1 C-PD, W3 C-PD+FF)."""
from __future__ import annotations

import numpy as np
from test_plots import assert_png, synthetic_run

from sitl.harness.results import COLUMN, ekf_lapses, lapse_lines
from sitl.harness.run_plot import envelope, plot_run, story


def _flip_run():
    run = synthetic_run("W2F", "C-PD+FF exact, paper law", duration=120.0)
    ts, t = run.timeseries, run.timeseries[:, 0]
    ts[:, COLUMN["z"]] += 3.0 * np.exp(-((t - 30.0) / 2.0) ** 2)                # the largest heave error, at 30 s
    ts[:, COLUMN["theta"]] -= np.radians(330.0) * np.clip((t - 60.0) / 8.0, 0.0, 1.0) * (t < 75.0)   # a flip
    ts[:, COLUMN["theta_hat"]] = ts[:, COLUMN["theta"]]
    return run


def test_the_zoom_picks_a_pitch_flip_over_a_larger_heave_error(tmp_path):
    run = _flip_run()
    kind, dof, tk, (lo, hi) = story(run)
    assert (kind, dof) == ("pitch flip", "pitch")
    assert 60.0 < tk < 64.0 and lo < 60.0 < tk < hi      # from before it started, through the crossing
    assert_png(plot_run(run, tmp_path / "flip.png"))


def _lapse_run():
    run = synthetic_run("W1", "C-PD", duration=60.0)
    ts, t = run.timeseries, run.timeseries[:, 0]
    for s in ("x", "z", "theta"):
        ts[:, COLUMN[f"sigma_{s}"]] = 0.03 if s != "theta" else 0.003
    lapse = (t >= 20.0) & (t < 21.0)
    ts[lapse, COLUMN["x"]] += np.linspace(0.0, 1.2, lapse.sum())      # the truth climbs to 1.2 m …
    ts[lapse, COLUMN["x_hat"]] = ts[lapse, COLUMN["sp_x"]]             # … while the estimate stays at 0
    return run


def test_an_ekf_lapse_is_found_printed_and_zoomed_on(tmp_path):
    run = _lapse_run()
    laps = ekf_lapses(run.timeseries, 20.0)
    assert len(laps) == 1 and laps[0]["state"] == "x" and 20.0 <= laps[0]["t_s"] < 20.5
    assert laps[0]["max_error"] > 1.0 and laps[0]["sigma"] == 0.03
    lines = lapse_lines({"ekf": {"lapses": laps}})
    assert lines[0].startswith("EKF lapses: 1 span") and "x estimate off by up to 1.29 m (its σ 0.03 m)" in lines[1]
    run.results["ekf"] = {"lapses": laps}
    kind, dof, tk, _ = story(run)
    assert (kind, dof) == ("EKF lapse", "surge") and 20.0 < tk < 21.0
    assert_png(plot_run(run, tmp_path / "lapse.png"))
    assert ekf_lapses(synthetic_run("W1", "C-PD", duration=60.0).timeseries, 20.0) == []   # σ 0: floors only


def test_the_overview_draws_envelopes():
    t = np.arange(12000) * 0.05
    y = np.sin(2 * np.pi * t / 7.0) * (1 + (t > 300))
    tc, lo, hi = envelope(t, y)
    assert tc.size == 120 and np.all(lo <= hi)
    assert np.allclose(hi[tc < 290], 1.0, atol=0.01) and np.allclose(hi[tc > 310], 2.0, atol=0.02)


def test_the_campaign_cdf_starts_at_zero():
    from sitl.harness.campaign_plots import ecdf

    x, y = ecdf(np.array([0.3, 0.1, 0.2, 0.4]))
    assert y[0] == 0.0 and x[0] == x[1] == 0.1 and y[-1] == 1.0 and np.all(np.diff(y) > 0)
