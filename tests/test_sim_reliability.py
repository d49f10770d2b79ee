"""``wavekeep sim`` on a busy machine and under Ctrl-C: every tick logged, never a half-written folder.

On a loaded 2-core machine the firmware's and the plant's logs (written as each process exits,
about 2 s of CSV idle) once took longer than the launcher's 10 s grace: the child was killed
mid-write and the run failed with "the logs cover 11808 of the mission's 11999 ticks". Now the
logs appear whole or not at all, the launcher waits for them, and a child that still has to be
killed is named as the failure.
"""
from __future__ import annotations

import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from sitl.harness.children import Child, LaunchError, stop_children
from sitl.harness.launcher import SimOptions, launch
from sitl.harness.ports import free_port
from sitl.harness.spec import RunSpec

pytestmark = pytest.mark.processes

SLOW_WRITER = """
import signal, sys, time
def stop(*_):
    time.sleep({delay})            # a log that takes long to write on a busy machine
    open(sys.argv[1], "w").write("complete\\n")
    sys.exit(0)
signal.signal(signal.SIGTERM, stop)
print("ready", flush=True)
while True:
    time.sleep(0.05)
"""


def _slow_child(tmp_path: Path, delay: float) -> tuple[Child, Path]:
    log = tmp_path / "ticks.csv"
    child = Child("firmware", [sys.executable, "-c", SLOW_WRITER.format(delay=delay), str(log)],
                   tmp_path / "child.log", env={})
    end = time.monotonic() + 30
    while not child.ready() and time.monotonic() < end:
        time.sleep(0.05)
    return child, log


def test_a_child_still_writing_its_log_is_waited_for(tmp_path):
    """12 s to finish after SIGTERM (longer than the old 10 s grace): the launcher waits; the log is whole."""
    child, log = _slow_child(tmp_path, 12.0)
    statuses = stop_children([child], timeout=120.0)
    assert statuses == {"firmware": 0} and not child.killed
    assert log.read_text() == "complete\n"


def test_a_child_killed_before_its_log_is_written_is_the_failure_named(tmp_path):
    child, log = _slow_child(tmp_path, 30.0)
    with pytest.raises(LaunchError, match="firmware did not finish writing its log within 1 s"):
        stop_children([child], timeout=1.0)
    assert child.killed and not log.exists()


def test_a_log_is_written_whole_or_not_at_all(tmp_path):
    from bridge.logfile import save_csv_whole

    rows = np.arange(12.0).reshape(4, 3)
    save_csv_whole(tmp_path / "a.csv", rows, "p,q,r")
    assert np.array_equal(np.loadtxt(tmp_path / "a.csv", delimiter=",", skiprows=1), rows)
    with pytest.raises(ValueError):
        save_csv_whole(tmp_path / "b.csv", [[1.0, 2.0], [3.0]], "p,q")   # fails mid-write
    assert list(tmp_path.iterdir()) == [tmp_path / "a.csv"]            # no partial file, no temporary


def _burners(n: int, seconds: float) -> list[subprocess.Popen]:
    """``n`` CPU-bound processes that stop by themselves after ``seconds``."""
    code = f"import time\nend = time.monotonic() + {seconds}\nwhile time.monotonic() < end: pass"
    return [subprocess.Popen([sys.executable, "-c", code]) for _ in range(n)]


def test_sim_on_a_loaded_machine_logs_every_tick(tmp_path):
    """Two CPU-bound processes beside ``sim``'s three: the mission completes with every tick logged."""
    burners = _burners(2, 240.0)
    try:
        opt = SimOptions(RunSpec("W1", "cpd_ff", duration=60.0), out=str(tmp_path / "sim"), plant_port=free_port(),
                         gcs_port=free_port(), zenoh_port=free_port(socket.SOCK_STREAM), plots=False)
        r = launch(opt)
    finally:
        for b in burners:
            b.kill()
            b.wait()
    out = Path(opt.out)
    ticks = np.loadtxt(out / "timeseries.csv", delimiter=",", skiprows=1, ndmin=2)
    assert ticks.shape[0] == 60 * 20 - 1 and np.all(np.isfinite(ticks[:, :7]))
    assert np.allclose(np.diff(ticks[:, 0]), 0.05)
    assert r["processes"] == {"firmware": 0, "plant": 0, "forecast": 0}


def test_ctrl_c_on_sim_exits_130_and_leaves_no_folder(tmp_path):
    """Ctrl-C mid-flight: exit 130, the folder it created is gone, so the same command runs again."""
    argv = [sys.executable, "-m", "sitl.harness.cli", "sim", "--controller", "cpd", "--duration", "600",
            "--speedup", "1", "--out", "r", "--plant-port", str(free_port()), "--gcs-port", str(free_port())]
    proc = subprocess.Popen(argv, cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    log = tmp_path / "r" / "firmware.log"
    end = time.monotonic() + 60
    while time.monotonic() < end and not (log.exists() and "ready" in log.read_text()):
        time.sleep(0.1)
    time.sleep(2.0)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert "interrupted" in err and "Traceback" not in err
    assert not (tmp_path / "r").exists()
