"""What the 3-D view costs: the control tick's p99 with and without the recording and with the live view,
in-process (``run``; ``live``'s LiveSim) and across processes (``sim``), and a 600 s recording's size.

    python -m benchmarks.bench_view [--live-s 60] [--sim-s 60]      # results/view.json

The control tick's compute p99 is the scheduler's own figure (results.json ``control_tick``; the
scheduler's stats for LiveSim). ``run`` and ``sim`` write the recording after the mission (so the tick
cannot see it: the figures say so); ``live`` and ``sim --view`` feed it while the mission flies.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from benchmarks.common import write


def _run_600(tmp: Path) -> dict:
    from sitl.harness.commands.view import record
    from sitl.harness.run import run_mission
    from sitl.harness.spec import RunSpec

    spec = RunSpec(case="W3", duration=600.0)
    result = run_mission(spec)
    out = tmp / "run600"
    out.mkdir()
    t0 = time.perf_counter()
    record(argparse.Namespace(no_record=False), out, spec, result.results["seed"], result)
    wall = time.perf_counter() - t0
    return {"mission_s": 600.0, "tick_p99_us": result.results["control_tick"]["p99_us"],
            "recording_write_s": wall, "recording_mb": (out / "recording.rrd").stat().st_size / 1e6}


def _live(seconds: float, mode: str, tmp: Path, speedup: float = 5.0) -> dict:
    """LiveSim for ``seconds`` of simulated time: no recording, to a file, or to a file and the live view."""
    from firmware_py.firmware import tick_row
    from firmware_py.logger.tick_columns import TICK_COLUMNS
    from sitl.harness.live import LiveSim
    from sitl.harness.live_view import LiveRecorder, ViewServer
    from sitl.harness.ports import free_port
    from sitl.harness.spec import RunSpec
    from sitl.harness.view_layout import SceneGeometry

    sim = LiveSim(RunSpec(case="W3"), mavlink=[f"udpout:127.0.0.1:{free_port()}"], speedup=speedup)
    server = rec = None
    if mode != "off":
        import socket
        server = ViewServer(web_port=free_port(socket.SOCK_STREAM)).start() if mode == "view" else None
        m = sim.setup
        g = SceneGeometry.from_configs("bluerov2_heavy", m.sea.components, 0.0, forecast=m.forecast.components())
        rec = LiveRecorder(("t", "x", "z", "theta", "u", "w", "q", *TICK_COLUMNS), g, rrd=tmp / f"live-{mode}.rrd",
                           grpc_url=server.grpc_url if server else None)
        sim.on_slot = lambda s, r: rec.push([s.t, *s.eta, *s.nu, *tick_row(r)])
    try:
        with sim:
            time.sleep(seconds / speedup)
    finally:
        if rec is not None:
            rec.close()
        if server is not None:
            server.stop()
    c = sim.firmware.scheduler.stats()["tasks"]["control"]["compute"]
    return {"mode": mode, "sim_s": seconds, "speedup": speedup, "ticks": c["n"], "tick_p50_us": c["p50_us"],
            "tick_p99_us": c["p99_us"]}


def _sim(seconds: float, mode: str, tmp: Path) -> dict:
    out = tmp / f"sim-{mode}"
    extra = {"off": ["--no-record"], "record": [], "view": ["--view", "--view-linger", "0.1"]}[mode]
    argv = [sys.executable, "-m", "sitl.harness.cli", "sim", "--case", "W3", "--duration", str(seconds),
            "--no-plots", "--out", str(out), *extra]
    t0 = time.perf_counter()
    done = subprocess.run(argv, capture_output=True, text=True, timeout=seconds * 10 + 300)
    wall = time.perf_counter() - t0
    if done.returncode != 0:
        raise RuntimeError(f"sim {mode} failed: {done.stderr[-800:]}")
    r = json.loads((out / "results.json").read_text())
    rrd = out / "recording.rrd"
    return {"mode": mode, "sim_s": seconds, "wall_s": wall, "tick_p99_us": r["control_tick"]["p99_us"],
            "tick_p50_us": r["control_tick"]["p50_us"],
            "recording_mb": rrd.stat().st_size / 1e6 if rrd.exists() else None}


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--live-s", type=float, default=60.0, help="simulated seconds of each LiveSim run")
    ap.add_argument("--sim-s", type=float, default=60.0, help="simulated seconds of each sim run")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        tmp_p = Path(tmp)
        figures = {"run_600s": _run_600(tmp_p),
                   "live": [_live(args.live_s, mode, tmp_p) for mode in ("off", "record", "view")],
                   "sim": [_sim(args.sim_s, mode, tmp_p) for mode in ("off", "record", "view")]}
    for group in ("live", "sim"):
        base = figures[group][0]["tick_p99_us"]
        for row in figures[group]:
            row["p99_vs_off"] = row["tick_p99_us"] / base if base else None
    figures["wall_s"] = time.perf_counter() - t0
    path = write("view", figures)
    print(json.dumps(figures, indent=1))
    print(f"wrote {path}")
    return figures


if __name__ == "__main__":
    main(sys.argv[1:])
