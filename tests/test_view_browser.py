"""``wavekeep sim --view`` in a real browser (Debian's Chromium, headless), and the tlog it leaves converted
and checked against the run's truth; ``wavekeep tlog`` on the same log."""
from __future__ import annotations

import os
import queue
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

pytest.importorskip("rerun", reason="the view extra (pip install 'wavekeep[view]') is not installed")

from test_view import read_rrd

from sitl.harness.cli import main
from sitl.harness.ports import free_port
from sitl.harness.view_sources import read_timeseries

pytestmark = pytest.mark.processes

CHROMIUM = shutil.which("chromium")
# As the machine's notes have it for headless Chromium as root on a closed network
FLAGS = ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run", "--disable-background-networking",
         "--disable-component-update", "--disable-sync", "--enable-unsafe-swiftshader"]


@pytest.fixture(scope="module")
def sim_view(tmp_path_factory):
    """``wavekeep sim --view`` flying a 20 s mission at twice real time; the view kept up 240 s after it."""
    out = tmp_path_factory.mktemp("simview") / "run"
    web = free_port(socket.SOCK_STREAM)
    argv = [sys.executable, "-m", "sitl.harness.cli", "sim", "--case", "W1", "--duration", "20", "--speedup", "2",
            "--no-plots", "--view", "--view-port", str(web), "--view-linger", "240", "--out", str(out),
            "--plant-port", str(free_port()), "--gcs-port", str(free_port()),
            "--zenoh-port", str(free_port(socket.SOCK_STREAM))]
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            env=dict(os.environ, PYTHONUNBUFFERED="1"))
    lines: queue.Queue[str] = queue.Queue()
    log: list[str] = []

    def read() -> None:
        for line in proc.stdout:
            log.append(line)
            lines.put(line)
    threading.Thread(target=read, daemon=True).start()
    url = None
    end = time.monotonic() + 120
    while url is None and time.monotonic() < end and proc.poll() is None:
        try:
            line = lines.get(timeout=1.0)
        except queue.Empty:
            continue
        if "live view is at " in line:
            url = line.split("live view is at ")[1].split()[0]
    yield {"proc": proc, "url": url, "out": out, "log": log, "web": web}
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(60)
        except subprocess.TimeoutExpired:
            proc.kill()


def _finish(sim_view) -> None:
    """End the view's linger (Ctrl-C) once the mission has written its folder; the run exits 0."""
    proc = sim_view["proc"]
    end = time.monotonic() + 180
    while not (sim_view["out"] / "recording.rrd").exists() and proc.poll() is None and time.monotonic() < end:
        time.sleep(0.5)
    if proc.poll() is None:
        time.sleep(1.0)
        proc.send_signal(signal.SIGINT)
    assert proc.wait(60) == 0, "".join(sim_view["log"])


@pytest.mark.skipif(CHROMIUM is None, reason="Debian's chromium is not installed (make installs it where apt may)")
def test_sim_view_renders_the_viewer_in_headless_chromium(sim_view, tmp_path):
    sync_api = pytest.importorskip("playwright.sync_api", reason="playwright (the browser driver) is not installed")
    from PIL import Image

    assert sim_view["url"], "".join(sim_view["log"])
    assert sim_view["url"].startswith(f"http://127.0.0.1:{sim_view['web']}/")
    shot = tmp_path / "view.png"
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=FLAGS, headless=True)
        try:
            page = browser.new_page(viewport={"width": 1600, "height": 1000})
            page.goto(sim_view["url"], timeout=120_000)
            page.wait_for_selector("canvas", timeout=180_000)
            page.wait_for_function("() => !document.body.innerText.includes('Loading')", timeout=180_000)
            time.sleep(8.0)                        # the data streaming in, the plots drawn
            page.screenshot(path=str(shot))
            title, text = page.title(), page.inner_text("body")
        finally:
            browser.close()
    assert title == "Rerun Viewer"
    assert "error" not in text.lower(), text
    img = np.asarray(Image.open(shot).convert("RGB")).reshape(-1, 3)
    colours, counts = np.unique(img, axis=0, return_counts=True)
    assert len(colours) > 500, f"{len(colours)} colours: a blank page?"
    assert counts.max() / img.shape[0] < 0.8, "one colour covers most of the page: a blank page?"
    _finish(sim_view)


def test_the_sim_tlog_converts_and_its_attitude_is_the_runs(sim_view, tmp_path, capsys):
    _finish(sim_view)
    out = sim_view["out"]
    assert main(["view", str(out / "mission.tlog"), "--out", str(tmp_path / "tlog.rrd")]) == 0
    rec = read_rrd(tmp_path / "tlog.rrd")
    pitch = rec["/plots/tlog/attitude/pitch"]
    t = np.array(pitch["t"]) / 1e9
    p = np.radians([row[0] for row in pitch["Scalars:scalars"]])
    ts = read_timeseries(out / "timeseries.csv")
    k = np.searchsorted(ts["t"], t - 1e-4)
    ok = (k < ts["t"].size) & (np.abs(ts["t"][np.minimum(k, ts["t"].size - 1)] - t) < 1e-3)
    assert ok.sum() > 150, f"only {ok.sum()} ATTITUDE samples on the run's ticks"
    k = k[ok]
    # ATTITUDE is the firmware's estimate at that tick (float32 on the wire) ...
    np.testing.assert_allclose(p[ok], ts["theta_hat"][k], atol=2e-6)
    # ... which is the truth to within the EKF's own 3σ
    assert np.mean(np.abs(p[ok] - ts["theta"][k]) <= 3 * ts["sigma_theta"][k]) > 0.95
    assert np.sqrt(np.mean((p[ok] - ts["theta"][k]) ** 2)) < np.radians(0.5)
    assert "/world/vehicle/estimate" in rec and "/world/vehicle/estimate/thrusters" in rec
    texts = [row[0] for row in rec["/events"]["TextLog:text"]]
    assert "mode GUIDED" in texts and "armed" in texts

    # wavekeep tlog: the same reader, a CSV and the figure
    assert main(["tlog", str(out / "mission.tlog"), "--out", str(tmp_path / "tl")]) == 0
    rows = (tmp_path / "tl" / "tlog.csv").read_text().splitlines()
    header = rows[0].split(",")
    assert header[:3] == ["t", "mode", "armed"] and "attitude.pitch" in header and "servo.servo8" in header
    assert len(rows) - 1 == len(t)
    assert (tmp_path / "tl" / "tlog.png").stat().st_size > 20_000
    assert "GUIDED" in capsys.readouterr().out
