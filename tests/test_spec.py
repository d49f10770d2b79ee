"""RunSpec: one description of a run's options, refused early when it does not make sense."""
from __future__ import annotations

import math
import re

import pytest

from sitl.harness.run import run_mission
from sitl.harness.spec import RunSpec


@pytest.mark.parametrize("kw, words", [
    ({"controller": "nmpc"}, "controller must be one of cpd, cpd_ff"),
    ({"forecast": "buoy"}, "forecast must be one of oracle, dswp"),
    ({"controller": "cpd", "snr_db": 15.0}, "applies only to C-PD+FF with the oracle forecast"),
    ({"forecast": "dswp", "snr_db": 15.0}, "applies only to C-PD+FF with the oracle forecast"),
    ({"snr_db": math.nan}, "finite number of dB"),
    ({"snr_db": -100.0}, "finite number of dB"),
    ({"seed": -1}, "seed must be in"),
    ({"seed": 10**23}, "seed must be in"),
    ({"duration": 0.0}, "duration must be a positive number"),
    ({"duration": math.inf}, "duration must be a positive number"),
])
def test_a_bad_combination_is_refused_with_its_reason(kw, words):
    with pytest.raises(ValueError, match=re.escape(words)):
        RunSpec(**kw)


def test_labels_name_the_forecast_source():
    assert RunSpec(controller="cpd").label == "C-PD"
    assert RunSpec().label == "C-PD+FF exact"
    assert RunSpec(snr_db=15.0).label == "C-PD+FF 15 dB"
    assert RunSpec(forecast="dswp").label == "C-PD+FF DSWP"
    assert RunSpec(controller="cpd", forecast="dswp").forecast_source is None


def test_a_dswp_run_says_so_in_its_results():
    r = run_mission(RunSpec("W1", "cpd_ff", forecast="dswp", duration=3.0)).results
    assert (r["label"], r["forecast"], r["forecast_snr_db"]) == ("C-PD+FF DSWP", "dswp", None)
    r = run_mission(RunSpec("W1", "cpd_ff", snr_db=15.0, duration=1.0)).results
    assert (r["label"], r["forecast"], r["forecast_snr_db"]) == ("C-PD+FF 15 dB", "oracle", 15.0)


def test_parameter_overrides_reach_the_firmware():
    from sitl.harness.run import build_mission
    m = build_mission(RunSpec("W1", "cpd", overrides={"WK_PD_KP_X": 0.7}))
    assert m.firmware.params["WK_PD_KP_X"] == 0.7 and m.firmware.params["WK_FF_ENABLE"] == 0


def test_a_refused_parameter_override_is_an_error_not_ignored():
    from sitl.harness.run import build_mission
    with pytest.raises(ValueError, match="WK_FF_GAIN"):
        build_mission(RunSpec("W1", "cpd", overrides={"WK_FF_GAIN": 1e6}))
    with pytest.raises(ValueError, match="unknown parameter 'WK_NOPE'"):
        build_mission(RunSpec("W1", "cpd", overrides={"WK_NOPE": 1.0}))
