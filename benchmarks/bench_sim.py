"""``wavekeep sim`` across processes: wall and CPU time of each process, before and after, in one sitting.

    python -m benchmarks.bench_sim --before /work/main [--repeat 3] [--duration 600]

Each run is a fresh ``python benchmarks/bench_sim.py --one OUT ...`` with ``TREE``
first on the path: it runs ``wavekeep sim --case W3 --controller cpd_ff`` through
the CLI and reports the whole command's wall time, the flight's wall time (arm →
the vehicle's clock at the end), and the CPU time (user + system) of the
launcher (the ground station) and of each child, from ``wait4`` when the
launcher stops it. The trees are interleaved run by run so they share the
machine's load. The floor is measured beside them: a bare UDP round trip on
loopback between two processes (a servo packet out, a state-sized reply back),
the least one lockstep tick across processes can cost.

Writes ``benchmarks/results/sim.json``. Read the ratios: on a shared machine the
absolute figures move with the load.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from statistics import median

ROOT = Path(__file__).resolve().parent.parent
PROCESSES = ("launcher", "firmware", "plant", "forecast")

_ECHO = """
import socket, sys
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
s.bind(("127.0.0.1", 0))
print(s.getsockname()[1], flush=True)
reply = b"x" * int(sys.argv[1])
while True:
    data, addr = s.recvfrom(2048)
    if data == b"stop":
        break
    s.sendto(reply, addr)
"""


def udp_round_trip(n: int = 5000, request: int = 40, reply: int = 600) -> dict:
    """Bare loopback UDP round trips to an echo process: ``request`` bytes out, ``reply`` back (µs)."""
    echo = subprocess.Popen([sys.executable, "-c", _ECHO, str(reply)], stdout=subprocess.PIPE, text=True)
    try:
        assert echo.stdout is not None
        port = int(echo.stdout.readline())
        s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        s.connect(("127.0.0.1", port))
        s.settimeout(1.0)
        msg = b"s" * request
        times = []
        for _ in range(n):
            t0 = time.perf_counter_ns()
            s.send(msg)
            s.recv(2048)
            times.append(time.perf_counter_ns() - t0)
        s.send(b"stop")
        s.close()
    finally:
        echo.wait(5)
    times.sort()
    return {"n": n, "request_bytes": request, "reply_bytes": reply, "p50_us": times[n // 2] / 1e3,
            "mean_us": sum(times) / n / 1e3, "p90_us": times[int(n * 0.9)] / 1e3}


def _one(duration: float, out: Path, extra: list[str]) -> dict:
    """One ``wavekeep sim`` in this process (the tree is whatever is first on the path); its figures."""
    from sitl.harness import launcher
    from sitl.harness.cli import main

    cpu: dict[str, float] = {}

    def stop(self, timeout: float = 10.0) -> int | None:
        """``Child.stop`` that reaps with ``wait4``, keeping the child's CPU time."""
        if self.proc.returncode is None:
            self.proc.send_signal(signal.SIGTERM)
            end = time.monotonic() + timeout
            while True:
                pid, status, ru = os.wait4(self.proc.pid, os.WNOHANG)
                if pid:
                    self.proc.returncode = os.waitstatus_to_exitcode(status)
                    cpu[self.name] = ru.ru_utime + ru.ru_stime
                    break
                if time.monotonic() > end:
                    os.killpg(self.proc.pid, signal.SIGKILL)
                end_wait = time.monotonic() + 0.005
                while time.monotonic() < end_wait:
                    time.sleep(0.001)
        self._log.close()
        return self.proc.returncode

    launcher.Child.stop = stop  # type: ignore[method-assign]
    t0 = time.perf_counter()
    status = main(["sim", "--case", "W3", "--controller", "cpd_ff", "--duration", str(duration),
                   "--out", str(out), "--force", *extra])
    wall = time.perf_counter() - t0
    me = resource.getrusage(resource.RUSAGE_SELF)
    cpu["launcher"] = me.ru_utime + me.ru_stime
    r = json.loads((out / "results.json").read_text())
    return {"status": status, "command_s": wall, "flight_s": r["wall_time_s"], "cpu_s": cpu,
            "rmse": r["rmse"], "ticks": int(round(duration * r["rate_hz"]))}


def _run(tree: Path, duration: float, tmp: Path, extra: list[str]) -> dict:
    """One fresh process of ``--one`` with ``tree`` first on the path; its figures (and its own wall)."""
    env = dict(os.environ, PYTHONPATH=str(tree))
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--one", str(tmp), "--duration",
                        str(duration), *extra], cwd=tree, env=env, capture_output=True, text=True, timeout=1800)
    wall = time.perf_counter() - t0
    if p.returncode != 0:
        raise RuntimeError(f"{tree}: exit {p.returncode}: {p.stderr[-2000:]}")
    figures = json.loads(p.stdout.rsplit("RESULT:", 1)[1])
    figures["process_s"] = wall
    return figures


def compare(before: Path | None, repeat: int, duration: float) -> dict:
    """Interleaved runs of each tree; medians and the after/before ratios."""
    trees: dict[str, tuple[Path, list[str]]] = {"after": (ROOT, []), "after_no_plots": (ROOT, ["--no-plots"])}
    if before is not None:
        trees = {"before": (before, []), **trees}
    samples: dict[str, list[dict]] = {k: [] for k in trees}
    with tempfile.TemporaryDirectory(prefix="wk-bench-sim-") as tmp:
        for i in range(repeat):
            for name, (tree, extra) in trees.items():
                samples[name].append(_run(tree, duration, Path(tmp) / f"{name}{i}", extra))
                s = samples[name][-1]
                print(f"{name} #{i}: command {s['command_s']:.1f} s, flight {s['flight_s']:.1f} s, CPU "
                      + ", ".join(f"{k} {v:.1f}" for k, v in sorted(s["cpu_s"].items())), flush=True)
    rtt = udp_round_trip()
    ticks = samples["after"][0]["ticks"]
    summary = {}
    for name, runs in samples.items():
        summary[name] = {
            "command_s": median(r["command_s"] for r in runs),
            "flight_s": median(r["flight_s"] for r in runs),
            "flight_us_per_tick": 1e6 * median(r["flight_s"] for r in runs) / ticks,
            "cpu_s": {p: median(r["cpu_s"].get(p, 0.0) for r in runs) for p in PROCESSES},
            "cpu_total_s": median(sum(r["cpu_s"].values()) for r in runs),
        }
    if before is not None:
        b, a = summary["before"], summary["after"]
        summary["ratio_before_over_after"] = {
            "command": b["command_s"] / a["command_s"], "flight": b["flight_s"] / a["flight_s"],
            "command_vs_after_no_plots": b["command_s"] / summary["after_no_plots"]["command_s"],
            "cpu_total": b["cpu_total_s"] / a["cpu_total_s"],
            **{f"cpu_{p}": b["cpu_s"][p] / a["cpu_s"][p] for p in PROCESSES if a["cpu_s"][p] > 0},
        }
    return {"command": f"wavekeep sim --case W3 --controller cpd_ff --duration {duration:g}",
            "before_tree": str(before) if before else None, "repeat": repeat, "ticks": ticks,
            "udp_round_trip": rtt, "flight_over_round_trip": summary["after"]["flight_us_per_tick"] / rtt["p50_us"],
            "summary": summary, "samples": samples}


def main(argv: list[str] | None = None) -> dict | None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--before", type=Path, default=None, help="a checkout of the old code, run interleaved")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--duration", type=float, default=600.0)
    ap.add_argument("--one", type=Path, default=None, help=argparse.SUPPRESS)
    args, extra = ap.parse_known_args(argv)
    if args.one is not None:
        print("RESULT:" + json.dumps(_one(args.duration, args.one, extra)))
        return None
    if extra:
        ap.error(f"unrecognised arguments: {' '.join(extra)}")
    from benchmarks.common import write  # here: a ``--one`` process imports only the tree it measures

    figures = compare(args.before, args.repeat, args.duration)
    path = write("sim", figures)
    print(json.dumps(figures["summary"], indent=2))
    print(f"UDP round trip p50 {figures['udp_round_trip']['p50_us']:.0f} µs; flight per tick / round trip: "
          f"{figures['flight_over_round_trip']:.1f}")
    print(f"wrote {path}")
    return figures


if __name__ == "__main__":
    main()
