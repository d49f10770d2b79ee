"""``wavekeep live`` reports only what happened: errors and power over the time the controller held station,
power from the thrusters' actual load, the time per mode, exactly --duration of simulated time, 130 on Ctrl-C.

Before: a flight never armed printed "C-PD+FF exact … P x 793 W, P z 2089 W" (the wrench the controller
asked for while the thrusters sat at 1500 µs), a flight of GUIDED, MANUAL and disarmed time carried one
label, ``--duration 30`` stopped after 582 ticks (the wall clock, start-up included), and Ctrl-C exited 0.
"""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

from firmware_py.modes import Mode
from sitl.harness.live import HISTORY_COLUMNS, LiveSim, live_summary
from sitl.harness.ports import free_port
from sitl.harness.spec import RunSpec

WAVEKEEP = [sys.executable, "-m", "sitl.harness.cli"]


def _row(t, held, armed, mode, ff=0.0, x=0.1, tau=(10.0, 20.0, 0.5)):
    return [t, x, 5.0, 0.0, 0.0, 5.0, 0.0, *tau, held, armed, float(mode), ff]


def test_the_summary_counts_only_the_time_held_on_station():
    rows = [_row(k * 0.05, 0, 0, Mode.MANUAL, tau=(0.0, 0.0, 0.0)) for k in range(100)]          # 5 s disarmed
    rows += [_row(5 + k * 0.05, 0, 1, Mode.MANUAL, x=3.0) for k in range(100)]                   # 5 s MANUAL, far off
    rows += [_row(10 + k * 0.05, 1, 1, Mode.GUIDED, ff=float(k < 50), x=0.2) for k in range(100)]   # 5 s held
    s = live_summary(rows, 20.0, "C-PD+FF exact")
    assert s["time_s"] == pytest.approx({"disarmed": 5.0, "MANUAL": 5.0, "GUIDED": 5.0})
    assert s["held_s"] == pytest.approx(5.0)
    assert s["label"] == "C-PD+FF exact in GUIDED, FF active 50 % of it"
    assert s["metrics"]["rmse"]["surge"] == pytest.approx(0.2)          # the MANUAL excursion is not in it
    assert len(HISTORY_COLUMNS) == len(rows[0])


def test_a_flight_never_armed_reports_no_metrics():
    sim = LiveSim(RunSpec("W1", "cpd_ff"), mavlink=[f"udpout:127.0.0.1:{free_port()}"], speedup=50.0, duration=30.0)
    with sim:
        assert sim.done.wait(60.0)
    s = sim.summary("C-PD+FF exact")
    assert sim.firmware.scheduler.stats()["ticks"] == 600 and len(sim.history) == 600
    assert s["metrics"] is None and s["held_s"] == 0.0 and s["time_s"] == pytest.approx({"disarmed": 30.0})
    h = np.array(sim.history)
    assert np.all(h[:, HISTORY_COLUMNS.index("tau_X"):HISTORY_COLUMNS.index("tau_M") + 1] == 0.0)   # thrusters idle


@pytest.mark.processes
def test_live_never_armed_prints_no_table_and_flies_600_ticks(tmp_path):
    out = subprocess.run([*WAVEKEEP, "live", "--duration", "30", "--speedup", "5", "--mavlink",
                          f"udpout:127.0.0.1:{free_port()}", "--log", str(tmp_path / "live.log")],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert "stopped after 600 ticks" in out.stdout
    assert "disarmed 30.0 s" in out.stdout and "held station (armed in GUIDED or POSHOLD) for 0.0 s" in out.stdout
    assert "RMSE" not in out.stdout and " W" not in out.stdout.split("held station")[-1]


@pytest.mark.processes
def test_ctrl_c_on_live_exits_130(tmp_path):
    proc = subprocess.Popen([*WAVEKEEP, "live", "--mavlink", f"udpout:127.0.0.1:{free_port()}", "--log",
                             str(tmp_path / "live.log")], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    end = time.monotonic() + 60
    while time.monotonic() < end and "Wavekeep live" not in proc.stdout.readline():
        pass
    time.sleep(1.0)
    proc.send_signal(signal.SIGINT)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert "stopped after" in out and "Traceback" not in err


@pytest.mark.processes
def test_live_without_rerun_flies_and_records_nothing(tmp_path):
    """Rerun is an optional extra: without it `live` (which records by default) flies its flight, says in one
    line that there is no recording, and exits 0, as `run` and `sim` do."""
    hide = tmp_path / "hide" / "rerun"
    hide.mkdir(parents=True)
    (hide / "__init__.py").write_text("raise ImportError('rerun hidden by the test')\n")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(hide.parent), os.environ.get("PYTHONPATH")]))}
    out = subprocess.run([*WAVEKEEP, "live", "--duration", "5", "--speedup", "10", "--mavlink",
                          f"udpout:127.0.0.1:{free_port()}", "--log", str(tmp_path / "live.log")],
                         capture_output=True, text=True, timeout=120, env=env)
    assert out.returncode == 0, out.stderr
    assert "no recording" in out.stdout + out.stderr and "pip install 'wavekeep[view]'" in out.stdout + out.stderr
    assert "stopped after 100 ticks" in out.stdout
    assert not (tmp_path / "live.rrd").exists()
