"""Every command's bad input: one line ``wavekeep CMD: …`` on stderr, exit 2, and no new file anywhere.

The sweep covers run, sim, live, campaign, reproduce, compare, sea and openloop, each called as the
command line calls it (``sitl.harness.cli.main``) in an empty working folder. Among the inputs: a sea
steeper than any real sea (``spectrum: {type: jonswap, hs: 25, tp: 8}``, which used to pass the schema
and blow the state up to 1e30 in 0.15 s) and campaign overrides with a typo or out of range (which used
to pass and fail a third of the missions, exit 0).
"""
from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from sitl.harness.cli import main

STEEP = "spectrum: {type: jonswap, hs: 25, tp: 8}\n"
GOOD_SPEC = """name: t
cases: [W1]
seeds: [1]
duration: 2
baseline: cpd
variants:
  - {name: cpd, controller: cpd}
  - {name: ff, controller: cpd_ff, forecast: oracle, overrides: OVERRIDES}
"""

BAD = {
    "run": [["--case", "NOPE", "--out", "o"], ["--duration", "-1", "--out", "o"], ["--seed", "x", "--out", "o"],
            ["--set", "WK_FF_GAN=1", "--out", "o"], ["--set", "WK_FF_GAIN=8", "--out", "o"],
            ["--case", "steep.yaml", "--out", "o"], ["--sea-set", "spectrum.hs=25", "--out", "o"],
            ["--out", "afile"], ["--controller", "pid", "--out", "o"]],
    "sim": [["--case", "NOPE"], ["--plant-port", "0"], ["--set", "WK_FF_GAN=1"], ["--case", "steep.yaml"],
            ["--plant-port", "5000", "--gcs-port", "5000"], ["--out", "afile"], ["--speedup", "-2"]],
    "live": [["--mavlink", "bogus"], ["--case", "NOPE"], ["--speedup", "-1"], ["--signing-key", "missing.key"],
             ["--set", "WK_FF_GAIN=8"], ["--case", "steep.yaml"]],
    "campaign": [["missing.yaml", "--out", "c"], ["typo.yaml", "--out", "c"], ["range.yaml", "--out", "c"],
                 ["steep_campaign.yaml", "--out", "c"], ["good.yaml", "--out", "afile"]],
    "reproduce": [["--seed", "-1", "--out", "o"], ["--set", "WK_FF_GAN=1", "--out", "o"],
                  ["--duration", "0", "--out", "o"], ["--out", "afile"]],
    "compare": [["nowhere"], ["empty_dir"], ["empty_dir", "--out", "afile"]],
    "sea": [["--case", "NOPE"], ["--duration", "0.1"], ["--out", "empty_dir"], ["--case", "steep.yaml"]],
    "openloop": [["--case", "NOPE", "--out", "o"], ["--duration", "-5", "--out", "o"],
                 ["--case", "steep.yaml", "--out", "o"], ["--out", "afile"]],
}


@pytest.fixture
def workdir(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "steep.yaml").write_text(STEEP)
    (tmp_path / "afile").write_text("not a folder\n")
    (tmp_path / "empty_dir").mkdir()
    (tmp_path / "typo.yaml").write_text(GOOD_SPEC.replace("OVERRIDES", "{WK_FF_GAN: 0.8}"))
    (tmp_path / "range.yaml").write_text(GOOD_SPEC.replace("OVERRIDES", "{WK_FF_GAIN: 8}"))
    (tmp_path / "good.yaml").write_text(GOOD_SPEC.replace("OVERRIDES", "{WK_FF_GAIN: 0.8}"))
    (tmp_path / "steep_campaign.yaml").write_text(GOOD_SPEC.replace("OVERRIDES", "{}").replace("[W1]",
                                                                                             "[steep.yaml]"))
    return tmp_path


def _tree(root: Path) -> set[str]:
    return {str(p.relative_to(root)) for p in root.rglob("*")}


@pytest.mark.parametrize("command,argv", [(c, a) for c, inputs in BAD.items() for a in inputs],
                         ids=[f"{c}:{' '.join(a)}" for c, inputs in BAD.items() for a in inputs])
def test_bad_input_is_one_line_exit_2_and_writes_nothing(workdir, capsys, command, argv):
    before = _tree(workdir)
    code = main([command, *argv])
    err = capsys.readouterr().err
    assert code == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"wavekeep {command}: "), err
    assert _tree(workdir) == before
    assert "Traceback" not in err


def test_campaign_overrides_are_named_by_their_dotted_key(workdir, capsys):
    assert main(["campaign", "typo.yaml", "--out", "c"]) == 2
    err = capsys.readouterr().err
    assert "variants[1].overrides.WK_FF_GAN" in err and "unknown parameter" in err
    assert main(["campaign", "range.yaml", "--out", "c"]) == 2
    assert "variants[1].overrides.WK_FF_GAIN" in capsys.readouterr().err


def test_the_label_names_the_law_and_the_changed_parameters(tmp_path, capsys):
    """``--set WK_FF_MODE=0`` is the paper's law: the table and results.json say so (they said 'C-PD+FF exact')."""
    assert main(["run", "--case", "W1", "--duration", "2", "--set", "WK_FF_MODE=0", "--set", "WK_FF_GAIN=0.8",
                 "--out", str(tmp_path / "r"), "--no-plots"]) == 0
    res = json.loads((tmp_path / "r" / "results.json").read_text())
    assert res["label"] == "C-PD+FF exact, paper law, WK_FF_GAIN=0.8"
    assert res["ff_law"] == "paper" and res["estimator"] == "paper"
    assert res["changed_parameters"] == {"WK_FF_GAIN": 0.8, "WK_FF_MODE": 0.0}
    assert "C-PD+FF exact, paper law, WK_FF_GAIN=0.8" in capsys.readouterr().out
    assert main(["run", "--case", "W1", "--duration", "2", "--out", str(tmp_path / "d"), "--no-plots"]) == 0
    d = json.loads((tmp_path / "d" / "results.json").read_text())
    assert d["label"] == "C-PD+FF exact" and d["ff_law"] == "robust"


def test_a_diverging_world_stops_the_run_keeps_its_series_and_exits_1(tmp_path, capsys, monkeypatch):
    """A state leaving the physical range stops the run with a clear error (it printed RMSE nan, exit 0)."""
    import numpy as np

    import sitl.plant
    monkeypatch.setattr(sitl.plant, "MAX_BODY_SPEED", 0.3)      # W1 moves the vehicle faster than this, in time
    out = tmp_path / "r"
    assert main(["run", "--case", "W1", "--controller", "cpd", "--duration", "60", "--out", str(out),
                 "--no-plots"]) == 1
    err = capsys.readouterr().err
    assert err.startswith("wavekeep run: the simulation diverged between t = ") and "wrote" in err
    res = json.loads((out / "results.json").read_text())
    ts = np.loadtxt(out / "timeseries.csv", delimiter=",", skiprows=1, ndmin=2)
    assert res["status"] == "diverged" and 1 < len(ts) < 60 * 20 - 1
    assert np.all(np.isfinite(ts[:, 1:7])) and res["duration_s"] == pytest.approx(len(ts) / 20.0)


def test_make_run_args_choose_the_folder():
    """``make run ARGS="--case W1 --duration 60"`` writes runs/sim-W1-cpd_ff-60s (it overwrote the W3 run)."""
    import subprocess

    from sitl.harness.cli import build_parser
    from sitl.harness.commands.processes import default_out

    root = Path(__file__).resolve().parents[1]
    dry = subprocess.run(["make", "-s", "-n", "-W", "pyproject.toml", "run", "ARGS=--case W1 --duration 60"],
                         cwd=root, capture_output=True, text=True, timeout=60, env=dict(os.environ, MAKEFLAGS=""))
    line = next(ln for ln in dry.stdout.splitlines() if " sim " in ln)
    argv = line.split("wavekeep ", 1)[1].split()
    assert "--out" not in argv
    assert default_out(build_parser().parse_args(argv)) == "runs/sim-W1-cpd_ff-60s"
    assert default_out(build_parser().parse_args(argv[:-4])) == "runs/sim-W3-cpd_ff"
