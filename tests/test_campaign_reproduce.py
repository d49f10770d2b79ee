"""``wavekeep reproduce`` on the campaign engine: the nine-run table and figures, and ``--seeds N`` with CIs."""
from __future__ import annotations

import json

import pytest

from sitl.harness.cli import main
from sitl.harness.plots import REPRODUCE_FIGURES
from sitl.harness.reproduce import reproduce
from sitl.harness.run import run_mission
from sitl.harness.spec import RunSpec

pytestmark = pytest.mark.processes


def test_reproduce_keeps_its_schema_and_figures(tmp_path):
    doc = reproduce(tmp_path, seed=5, duration=2.0, workers=2, progress=lambda m: None)
    assert set(doc) == {"world", "runs", "summary", "corrected", "paper", "wall_time_s"}
    for d, world in ((doc, ", paper's world"), (doc["corrected"], "")):
        assert [(r["case"], r["label"]) for r in d["runs"]] == [
            (c, lab + world) for c in ("W1", "W2", "W3") for lab in ("C-PD", "C-PD+FF exact", "C-PD+FF 15 dB")]
    # the paper's table is flown in the paper's world (its load in the plant and the firmware), the other not
    assert "paper's world" in doc["world"] and "corrected" in doc["corrected"]["world"]
    assert doc["runs"][0]["rmse"] != doc["corrected"]["runs"][0]["rmse"]
    for name in REPRODUCE_FIGURES:
        assert (tmp_path / "corrected" / name).stat().st_size > 10_000
    assert json.loads((tmp_path / "reproduce.json").read_text())["summary"] == json.loads(json.dumps(doc["summary"]))
    for name in REPRODUCE_FIGURES:
        assert (tmp_path / name).stat().st_size > 10_000
    # every run's results and time series, as `wavekeep run` writes them (so `wavekeep compare` reads them)
    for c in ("W1", "W2", "W3"):
        for v in ("cpd", "ff_exact", "ff_snr15"):
            run_dir = tmp_path / "runs" / f"{c}-{v}"
            assert json.loads((run_dir / "results.json").read_text())["case"] == c
            assert len((run_dir / "timeseries.csv").read_text().splitlines()) > 30   # header + about 2 s at 20 Hz
    # a run through the engine is the in-process run, in either world (both planar: the paper's vehicle)
    want = run_mission(RunSpec(case="W2", controller="cpd_ff", snr_db=15.0, seed=5, duration=2.0,
                               sea={"wave_load": "paper", "dof": "planar"}, overrides={"WK_LOAD_MODEL": 0})).results
    assert doc["runs"][5]["rmse"] == want["rmse"] and doc["runs"][5]["max_abs_error"] == want["max_abs_error"]
    want = run_mission(RunSpec(case="W2", controller="cpd_ff", snr_db=15.0, seed=5, duration=2.0,
                               sea={"dof": "planar"})).results     # reproduce flies the planar world
    assert doc["corrected"]["runs"][5]["rmse"] == want["rmse"]


def test_reproduce_over_seeds_reports_intervals(tmp_path, capsys):
    assert main(["reproduce", "--seeds", "2", "--duration", "2", "--workers", "2", "--no-plots",
                 "--out", str(tmp_path)]) == 0
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["done"] == 18 and summary["failed"] == 0 and summary["baseline"] == "cpd"
    assert {g["variant"] for g in summary["groups"]} == {"ff_exact", "ff_snr15"}
    o = summary["overall"]["ff_exact"]
    assert o["n_seeds"] == 2 and o["reduction_pct_ci95"][0] <= o["reduction_pct_mean"] <= o["reduction_pct_ci95"][1]
    out = capsys.readouterr().out
    assert "95 % CI" in out and "paper ≈ 48 %" in out
