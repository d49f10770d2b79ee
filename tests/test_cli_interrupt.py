"""Issue #17: Ctrl-C stops at once, says so, exits 130, never shows 100 % and leaves no half-written folder."""
from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

WAVEKEEP = [sys.executable, "-m", "sitl.harness.cli"]


def interrupt(argv: list[str], ready: str, cwd: Path, timeout: float = 120.0) -> tuple[int, str, float]:
    """Start ``wavekeep argv``, wait for ``ready`` on stderr, send SIGINT; (exit status, stderr, seconds to stop)."""
    proc = subprocess.Popen([*WAVEKEEP, *argv], stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True,
                            cwd=cwd, start_new_session=True)
    seen = []
    deadline = time.monotonic() + timeout
    assert proc.stderr is not None
    while time.monotonic() < deadline:
        line = proc.stderr.readline()
        if not line:
            break
        seen.append(line)
        if ready in line:
            break
    time.sleep(1.0)
    t0 = time.monotonic()
    proc.send_signal(signal.SIGINT)
    try:
        _, rest = proc.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        proc.kill()
        raise
    return proc.returncode, "".join(seen) + rest, time.monotonic() - t0


@pytest.mark.processes
def test_ctrl_c_on_run_exits_130_without_100_percent(tmp_path):
    code, err, _ = interrupt(["run", "--duration", "3000", "--out", "r"], "wavekeep", tmp_path, timeout=5)
    assert code == 130, err
    assert "interrupted" in err and "Traceback" not in err
    assert "(100 %)" not in err
    assert not (tmp_path / "r").exists()


@pytest.mark.processes
def test_ctrl_c_on_reproduce_stops_at_once(tmp_path):
    code, err, took = interrupt(["reproduce", "--duration", "600", "--workers", "1", "--out", "r"],
                                "local cluster", tmp_path)
    assert code == 130, err
    assert "interrupted" in err and "Traceback" not in err, err
    assert took < 30, took
    assert not (tmp_path / "r").exists()
