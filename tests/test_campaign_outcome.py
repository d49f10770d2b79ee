"""A campaign says how it ended: failed missions exit 1 with a last line saying how many and where their
errors are (it exited 0, the table showing "—"); Ctrl-C prints "N of M done; rerun the same command to
resume" and exits 130."""
from __future__ import annotations

import re
import signal
import subprocess
import sys
import time

import pytest

pytestmark = pytest.mark.processes

WAVEKEEP = [sys.executable, "-m", "sitl.harness.cli"]

SPEC = """name: t
cases: [W1]
seeds: SEEDS
duration: DURATION
baseline: cpd
variants:
  - {name: cpd, controller: cpd}
  - {name: strict, controller: cpd, overrides: {WK_EKF_CONV: 0.001}}
"""
# WK_EKF_CONV 1 mm: below the estimator's first position sigma (2 cm), so the pre-arm check refuses to arm:
# a mission that fails inside the run, not at the spec's validation (the value is in the parameter's range)


def test_a_campaign_with_failed_missions_exits_1_and_says_where(tmp_path):
    (tmp_path / "spec.yaml").write_text(SPEC.replace("SEEDS", "[1, 2]").replace("DURATION", "2"))
    out = subprocess.run([*WAVEKEEP, "campaign", "spec.yaml", "--out", "c", "--workers", "1", "--no-plots"],
                         cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert out.returncode == 1, out.stderr
    last = out.stderr.strip().splitlines()[-1]
    assert last.startswith("2 of 4 missions failed") and "c/missions.csv" in last, out.stderr
    assert "EKF not converged" in out.stderr


def test_ctrl_c_on_a_campaign_says_how_far_it_got(tmp_path):
    (tmp_path / "spec.yaml").write_text(SPEC.replace("SEEDS", "{from: 1, to: 20}").replace("DURATION", "120")
                                        .replace("  - {name: strict, controller: cpd, overrides: {WK_EKF_CONV: "
                                                 "0.001}}\n", ""))
    proc = subprocess.Popen([*WAVEKEEP, "campaign", "spec.yaml", "--out", "c", "--workers", "1", "--no-plots",
                             "--log-interval", "0.5"], cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, start_new_session=True)
    assert proc.stderr is not None
    seen = []
    end = time.monotonic() + 120
    while time.monotonic() < end:
        line = proc.stderr.readline()
        seen.append(line)
        if not line or re.search(r"campaign: [1-9]\d*/20", line):
            break
    proc.send_signal(signal.SIGINT)
    _, rest = proc.communicate(timeout=60)
    err = "".join(seen) + rest
    assert proc.returncode == 130, err
    assert err.strip().splitlines()[-1].endswith("of 20 done; rerun the same command to resume"), err
    assert "Traceback" not in err
