"""Mission time against a fixed yardstick: how many times faster than a naive script Wavekeep flies.

    python -m benchmarks.bench_mission_time [--repeat 3] [--duration 600] [--before OLD_TREE]

One process run, interleaved rep by rep so that every figure sees the same machine load: the naive
single-file mission (:mod:`benchmarks.naive_mission`: plain Python, RK4, 200 components, six strips,
C-PD, no estimator), then ``wavekeep run`` and ``wavekeep sim`` (the main job, as ``make run`` flies
it: W3, C-PD+FF, seed 103) of the same length, in this tree and, with ``--before``, in OLD_TREE too
(a checkout run with this interpreter and the tree first on the path). A ratio is the naive mission's
wall time over Wavekeep's, both medians over the repeats: above 1, Wavekeep is the faster. Two per
command: the mission's own loop (``results.json``'s ``wall_time_s``: the in-process loop for ``run``,
the flight from arming to the end for ``sim``) and the whole command (start-up, the run folder and, for
``sim``, every process's start and stop). Absolute times move with the machine's load; the ratios
much less. Writes ``benchmarks/results/mission_time.json``.
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path
from statistics import median

from benchmarks.bench_speed import CPU, ROOT, _proc, measure
from benchmarks.common import write

NAIVE = Path(__file__).resolve().with_name("naive_mission.py")


def naive(duration: float) -> dict:
    """One naive mission: its loop's wall time (s) and the whole process's."""
    wall, out = _proc(ROOT, [str(NAIVE), "--duration", str(duration)])
    return {"s": wall, "loop_s": json.loads(out)["wall_s"], "cpu_s": CPU["s"]}


def wavekeep(tree: Path, kind: str, duration: float, tmp: Path) -> dict:
    """One ``wavekeep run`` or ``sim`` of ``duration`` s in ``tree`` (bench_speed's measurement)."""
    m = measure(tree, kind, tmp, ["--duration", str(duration), "--seed", "103"])
    m["cpu_s"] = CPU["s"]
    return m


def ratios(samples: dict) -> dict:
    """Naive over Wavekeep, medians: per command, of the mission's loop and of the whole command."""
    nv = {k: median(s[k] for s in samples["naive"]) for k in ("loop_s", "s")}
    out = {}
    for label, by_kind in samples.items():
        if label == "naive":
            continue
        for kind, runs in by_kind.items():
            out[f"{label} {kind}"] = {
                "loop_ratio": nv["loop_s"] / median(r["loop_s"] for r in runs),
                "command_ratio": nv["s"] / median(r["s"] for r in runs),
                "loop_s": median(r["loop_s"] for r in runs), "command_s": median(r["s"] for r in runs),
                "cpu_s": median(r["cpu_s"] for r in runs)}
    return out


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--before", default=None, help="a checkout of the code to compare with (measured interleaved)")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--duration", type=float, default=600.0, help="mission length (s), the same for all")
    args = ap.parse_args(argv)
    trees = {"this tree": ROOT} if args.before is None else {"before": Path(args.before).resolve(), "this tree": ROOT}
    samples: dict = {"naive": [], **{label: {"run": [], "sim": []} for label in trees}}
    with tempfile.TemporaryDirectory() as tmp:
        for rep in range(args.repeat):
            samples["naive"].append(naive(args.duration))
            print(f"rep {rep}: naive {samples['naive'][-1]}", file=sys.stderr, flush=True)
            for label, tree in trees.items():
                for kind in ("run", "sim"):
                    samples[label][kind].append(wavekeep(tree, kind, args.duration, Path(tmp)))
                    print(f"rep {rep}: {label} {kind} {samples[label][kind][-1]}", file=sys.stderr, flush=True)
    figures = {"duration_s": args.duration, "repeat": args.repeat, "samples": samples, "ratios": ratios(samples),
               "trees": {label: str(tree) for label, tree in trees.items()}}
    path = write("mission_time", figures)
    print(f"naive mission: {median(s['loop_s'] for s in samples['naive']):.2f} s "
          f"({args.duration:g} s, median of {args.repeat})")
    print(f"{'':<16}{'mission ×':>10}{'command ×':>11}{'mission s':>11}{'command s':>11}{'CPU s':>8}")
    for name, r in figures["ratios"].items():
        print(f"{name:<16}{r['loop_ratio']:>10.2f}{r['command_ratio']:>11.2f}{r['loop_s']:>11.2f}"
              f"{r['command_s']:>11.2f}{r['cpu_s']:>8.2f}")
    print(f"wrote {path}")
    return figures


if __name__ == "__main__":
    main()
