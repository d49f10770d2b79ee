"""Issue #17: a run folder records how to rerun it; --params/--set reach the firmware; compare; progress."""
from __future__ import annotations

import io
import json

import pytest

from sitl.harness.cli import main
from sitl.harness.progress import ProgressBar


@pytest.fixture(scope="module")
def two_runs(tmp_path_factory):
    d = tmp_path_factory.mktemp("runs")
    p = d / "gains.yaml"
    p.write_text("WK_PD_KP_X: 1.5\n")
    assert main(["run", "--duration", "3", "--controller", "cpd", "--no-plots", "--out", str(d / "a")]) == 0
    assert main(["run", "--duration", "3", "--params", str(p), "--set", "WK_PD_KP_Z=1.4", "--out", str(d / "b")]) == 0
    return d


def test_run_json_says_how_to_rerun(two_runs):
    doc = json.loads((two_runs / "b" / "run.json").read_text())
    assert doc["command"].startswith("wavekeep run --duration 3 --params")
    assert doc["parameter_overrides"] == {"WK_PD_KP_X": 1.5, "WK_PD_KP_Z": 1.4}
    assert doc["parameters"]["WK_PD_KP_X"] == 1.5 and doc["parameters"]["WK_PD_KP_Z"] == 1.4
    assert doc["seed"] == json.loads((two_runs / "b" / "results.json").read_text())["seed"]
    assert doc["configs"]["sea"]["name"] == "W3" and "control_rate" in doc["configs"]["mission"]
    assert doc["version"] and "git_commit" in doc


def test_compare_overlays_runs(two_runs, capsys):
    assert main(["compare", str(two_runs / "a"), str(two_runs / "b"), "--out", str(two_runs / "cmp")]) == 0
    out = capsys.readouterr().out
    assert "a " in out and "b " in out and "RMSE" in out
    assert (two_runs / "cmp" / "compare.png").stat().st_size > 10_000


def test_compare_refuses_a_non_run(tmp_path, capsys):
    assert main(["compare", str(tmp_path), "--out", str(tmp_path / "c")]) == 2
    assert "not a run folder" in capsys.readouterr().err


def test_progress_logs_lines_off_a_terminal_and_never_a_false_100():
    s = io.StringIO()
    with ProgressBar(10, "job", stream=s, interval=0.0) as bar:
        bar.update(5)
        bar.update(10)
    assert "job: 5/10 (50 %)" in s.getvalue() and "job: 10/10 (100 %)" in s.getvalue()
    s = io.StringIO()
    with pytest.raises(KeyboardInterrupt), ProgressBar(10, "job", stream=s, interval=0.0) as bar:
        bar.update(4)
        raise KeyboardInterrupt
    assert "(40 %)" in s.getvalue() and "100 %" not in s.getvalue()
