"""What a new user reads and copies: the help, the vehicle template, reproduce's run.json, the dashboard."""
from __future__ import annotations

import re

import pytest

from sitl.harness.cli import build_parser, main


def test_help_lists_companion(capsys):
    assert main(["--help"]) == 0
    out = capsys.readouterr().out
    assert re.search(r"^\s+companion\s", out, re.M) and "wavekeep companion --autopilot" in out


@pytest.mark.parametrize("command", ["run", "sim", "live", "reproduce", "campaign", "sea", "openloop", "compare"])
def test_help_says_each_default_once(capsys, command):
    """It read 'default: the mission's (600) (default: None)'."""
    assert main([command, "-h"]) == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "(default: None)" not in out and "(default: False)" not in out
    for m in re.finditer(r"default[^()]*\([^)]*\) \(default:", out):
        raise AssertionError(m.group(0))


def test_the_vehicle_template_is_the_heavy_and_flies():
    from bridge.schemas import load_vehicle_config

    template, heavy = load_vehicle_config("template"), load_vehicle_config("bluerov2_heavy")
    assert {k: v for k, v in template.items() if k != "name"} == {k: v for k, v in heavy.items() if k != "name"}
    from sitl.harness.run import run_mission
    from sitl.harness.spec import RunSpec
    r = run_mission(RunSpec("W1", "cpd", duration=2.0, vehicle="template")).results
    ref = run_mission(RunSpec("W1", "cpd", duration=2.0)).results
    assert r["rmse"] == ref["rmse"]


def test_reproduces_run_json_holds_specs_configs_and_parameters():
    """docs/results.md promises spec, configs and parameters in every run.json; reproduce's had none."""
    from sitl.harness.provenance import run_record
    from sitl.harness.reproduce import paper_tasks

    doc = run_record(["reproduce"], [t.spec for t in paper_tasks(None, 60.0, False, {"WK_FF_GAIN": 0.9})])
    assert len(doc["specs"]) == 9 and {s["case"] for s in doc["specs"]} == {"W1", "W2", "W3"}
    assert set(doc["configs"]) == {"sea", "mission", "vehicle"} and set(doc["configs"]["sea"]) == {"W1", "W2", "W3"}
    assert doc["parameters"]["WK_FF_GAIN"] == 0.9 and doc["parameter_overrides"]["WK_FF_GAIN"] == 0.9


def test_the_dashboard_a_campaign_prints_is_served():
    """The campaign prints the Dask dashboard's address; distributed serves it only with bokeh."""
    import bokeh  # noqa: F401  (a dependency: pyproject.toml)

    from sitl.harness.campaign import _has_bokeh
    assert _has_bokeh()


def test_sim_without_out_names_its_folder_after_the_options():
    from sitl.harness.commands.processes import default_out

    args = build_parser().parse_args(["sim", "--case", "configs/sea/design/W2F.yaml", "--controller", "cpd_ff",
                                      "--forecast-snr-db", "15", "--seed", "4", "--duration", "60"])
    assert default_out(args) == "runs/sim-W2F-cpd_ff-15dB-seed4-60s"
