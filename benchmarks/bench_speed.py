"""Whole-process speed of the ``wavekeep`` commands (issue #13), before and after, in one sitting.

    python -m benchmarks.bench_speed                          # this tree only
    python -m benchmarks.bench_speed --before /tmp/base       # and a checkout of the old code, interleaved
    python -m benchmarks.bench_speed --repeat 5 --only run import

Each figure is the median of ``--repeat`` runs of a fresh process
(``python -m sitl.harness.cli ...`` with the tree first on the path), the
trees interleaved run by run so both see the same machine load. Writes
``benchmarks/results/speed.json``:

* ``import_s``: ``python -c "import sitl.harness.cli"``; ``help_heavy``: the
  heavy packages (scipy, matplotlib, zenoh, dask, numba, filterpy) that
  ``wavekeep --help`` leaves in ``sys.modules`` (none, is the aim);
* ``run_s``: ``wavekeep run --case W3 --controller cpd_ff --no-plots`` (600 s),
  and the control tick p50/p99 (µs) it reports; ``run_plots_s`` with its figure;
* ``sim_s``: ``wavekeep sim`` of the same mission (processes, UDP, MAVLink, zenoh);
* ``reproduce_s``: ``wavekeep reproduce --no-plots`` (nine 600 s missions).

Aims: run ≤ 1.2 s, sim ≤ 6 s, reproduce ≤ 8 s, import ≤ 0.4 s, tick p99 ≤ 250 µs.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from statistics import median

from benchmarks.common import write

ROOT = Path(__file__).resolve().parent.parent
HEAVY = ("scipy", "matplotlib", "zenoh", "dask", "numba", "filterpy", "pyarrow")
KINDS = ("import", "help", "run", "run_plots", "sim", "reproduce")


def _free_port() -> int:
    """A TCP/UDP port nobody on this host is using now (s)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


CPU: dict[str, float] = {}
"""CPU time (user + system, s) of the last :func:`_proc` and its children: less sensitive than wall time
to other people's load on a shared machine."""


def _proc(tree: Path, argv: list[str], timeout: float = 900.0) -> tuple[float, str]:
    """Run ``python argv`` in ``tree``; returns (wall s, stdout). Raises on a non-zero exit."""
    env = dict(os.environ, PYTHONPATH=str(tree))
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, *argv], cwd=tree, env=env, capture_output=True, text=True, timeout=timeout)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    CPU["s"] = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    if p.returncode != 0:
        raise RuntimeError(f"{argv} in {tree} exited {p.returncode}: {p.stderr[-2000:]}")
    return wall, p.stdout


def measure(tree: Path, kind: str, tmp: Path, extra: list[str] | None = None) -> dict:
    """One measurement of ``kind`` (see the module docstring) in ``tree``; ``extra``: more mission options."""
    cli = ["-m", "sitl.harness.cli"]
    mission = ["--case", "W3", "--controller", "cpd_ff", *(extra or [])]
    if kind == "import":
        return {"s": _proc(tree, ["-c", "import sitl.harness.cli"])[0]}
    if kind == "help":
        code = ("import sys\nfrom sitl.harness.cli import build_parser\n"
                "try:\n    build_parser().parse_args(['--help'])\nexcept SystemExit:\n    pass\n"
                f"print('HEAVY:' + ','.join(sorted({{m.split('.')[0] for m in sys.modules}} & set({HEAVY!r}))))")
        wall, out = _proc(tree, ["-c", code])
        return {"s": wall, "heavy": out.rsplit("HEAVY:", 1)[-1].strip()}
    if kind in ("run", "run_plots"):
        out = tmp / f"{kind}-{time.monotonic_ns()}"
        plots = [] if kind == "run_plots" else ["--no-plots"]
        wall, _ = _proc(tree, [*cli, "run", *mission, "--out", str(out), *plots])
        r = json.loads((out / "results.json").read_text())
        return {"s": wall, "loop_s": r["wall_time_s"], "p50_us": r["control_tick"]["p50_us"],
                "p99_us": r["control_tick"]["p99_us"]}
    if kind == "sim":
        out = tmp / f"sim-{time.monotonic_ns()}"
        ports = ["--plant-port", str(_free_port()), "--gcs-port", str(_free_port()), "--zenoh-port", str(_free_port())]
        wall, _ = _proc(tree, [*cli, "sim", *mission, *ports, "--out", str(out)])
        r = json.loads((out / "results.json").read_text())
        return {"s": wall, "loop_s": r["wall_time_s"]}
    if kind == "reproduce":
        wall, _ = _proc(tree, [*cli, "reproduce", "--no-plots", "--out", str(tmp / f"rep-{time.monotonic_ns()}")])
        return {"s": wall}
    raise ValueError(kind)


def _summary(samples: list[dict]) -> dict:
    """Medians of every numeric field over the repeats, and the raw wall times (s)."""
    out: dict = {"n": len(samples), "walls_s": [round(s["s"], 3) for s in samples]}
    for key in samples[0]:
        vals = [s[key] for s in samples]
        out[key] = median(vals) if isinstance(vals[0], float) else vals[-1]
    return out


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--before", default=None, help="a checkout of the code to compare with (measured interleaved)")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--only", nargs="*", default=list(KINDS), choices=KINDS)
    ap.add_argument("--reproduce-repeat", type=int, default=1, help="repeats for reproduce (slow before)")
    args = ap.parse_args(argv)
    trees = {"after": ROOT} if args.before is None else {"before": Path(args.before).resolve(), "after": ROOT}
    samples: dict = {label: {k: [] for k in args.only} for label in trees}
    with tempfile.TemporaryDirectory() as tmp:
        for kind in args.only:
            reps = args.reproduce_repeat if kind == "reproduce" else args.repeat
            for _ in range(reps):
                for label, tree in trees.items():
                    m = measure(tree, kind, Path(tmp))
                    m["cpu_s"] = CPU.get("s", float("nan"))
                    samples[label][kind].append(m)
                    print(f"{kind:<10} {label:<7} {m['s']:7.2f} s  {m}", file=sys.stderr, flush=True)
    figures = {label: {k: _summary(v) for k, v in by.items() if v} for label, by in samples.items()}
    path = write("speed", figures)
    print(f"{'figure':<28}" + "".join(f"{label:>12}" for label in trees))
    for kind in args.only:
        keys = [("s", "s"), ("cpu_s", "cpu s")]
        if kind.startswith("run"):
            keys += [("p50_us", "tick p50 µs"), ("p99_us", "tick p99 µs"), ("loop_s", "loop s")]
        for key, name in keys:
            row = [figures[label][kind].get(key) for label in trees]
            print(f"{kind + ' ' + name:<28}" + "".join(f"{v:>12.3f}" if isinstance(v, float) else f"{v!s:>12}"
                                                         for v in row))
        if kind == "help":
            print(f"{'help heavy modules':<28}" + "".join(f"{figures[lb]['help']['heavy'] or '-':>12}"
                                                         for lb in trees))
    print(f"wrote {path}")
    return figures


if __name__ == "__main__":
    main()
