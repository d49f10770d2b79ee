"""``wavekeep live`` (issue #17): mode, arming and failsafe events are printed as they happen, written
to the log, and the flight ends with the results table. A real process, a real pymavlink ground station."""
from __future__ import annotations

import queue
import subprocess
import sys
import threading
import time

import pytest

from sitl.harness.ports import free_port
from tests.mavlink_gcs import GroundStation, mavlink

pytestmark = pytest.mark.processes


def _lines(proc: subprocess.Popen) -> queue.Queue:
    """Each stdout line as it comes, with its arrival time."""
    q: queue.Queue = queue.Queue()

    def pump() -> None:
        assert proc.stdout is not None
        for line in proc.stdout:
            q.put((time.monotonic(), line.rstrip("\n")))
        q.put((time.monotonic(), None))
    threading.Thread(target=pump, daemon=True).start()
    return q


_SEEN: list[tuple[float, str]] = []      # lines read while waiting for another


def _expect(q: queue.Queue, text: str, timeout: float = 20.0) -> float:
    """Wait for a stdout line containing ``text`` (or take one already read); its arrival time."""
    for i, (t, line) in enumerate(_SEEN):
        if text in line:
            del _SEEN[i]
            return t
    end = time.monotonic() + timeout
    while (left := end - time.monotonic()) > 0:
        try:
            t, line = q.get(timeout=left)
        except queue.Empty:
            break
        if line is None:
            break
        if text in line:
            return t
        _SEEN.append((t, line))
    raise AssertionError(f"no line with {text!r} within {timeout} s")


def test_live_prints_events_as_they_happen_logs_them_and_ends_with_the_table(tmp_path):
    port = free_port()
    log = tmp_path / "live.log"
    proc = subprocess.Popen([sys.executable, "-m", "sitl.harness.cli", "live", "--case", "W1", "--duration", "40",
                             "--speedup", "2", "--mavlink", f"udpout:127.0.0.1:{port}", "--log", str(log)],
                            stdout=subprocess.PIPE, stderr=(tmp_path / "stderr").open("w"), text=True)
    gcs = GroundStation(f"udpin:127.0.0.1:{port}")
    try:
        q = _lines(proc)
        _expect(q, "Wavekeep live")
        gcs.heartbeats(True)
        assert gcs.heartbeat(timeout=20.0) is not None
        ack = gcs.command(mavlink.MAV_CMD_DO_SET_MODE, 1, 4, timeout=10.0)           # GUIDED: holds station
        assert ack is not None and ack.result == 0
        t_mode = _expect(q, "Mode GUIDED")
        # This ground station has no joystick: as ArduSub's, the pilot-input failsafe trips once,
        # FS_PILOT_TIMEOUT (3 s) after boot; armed after that, the vehicle flies on without sticks
        _expect(q, "Lost manual control")
        ack = gcs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1, timeout=10.0)
        assert ack is not None and ack.result == 0
        t_arm = _expect(q, "Arming motors")                      # ArduSub's words
        time.sleep(2.5)                                          # heard (a heartbeat at 1 Hz), so the failsafe is armed
        gcs.heartbeats(False)                                    # the GCS goes silent: failsafe
        t_fs = _expect(q, "GCS failsafe")
        assert t_mode <= t_arm < t_fs
        still_running = proc.poll() is None
        proc.wait(timeout=60.0)
        out = []
        while (line := q.get(timeout=10.0)[1]) is not None:
            out.append(line)
    finally:
        gcs.close()
        if proc.poll() is None:
            proc.kill()
    assert still_running                # the events came while the flight went on, not at its end
    assert proc.returncode == 0, (tmp_path / "stderr").read_text()
    assert any("stopped after" in line for line in out) and any("RMSE" in line for line in out)
    text = log.read_text()
    assert any("the controller held station" in line for line in out)
    for word in ("Mode GUIDED", "Arming motors", "GCS failsafe", "Disarming motors", "RMSE"):
        assert word in text, word
