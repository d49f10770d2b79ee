"""cProfile of every process of a short ``wavekeep sim``: where each tick's time goes across processes.

    python -m benchmarks.profile_sim [--case W3] [--controller cpd_ff] [--duration 120] [--top 30]

The firmware, the physics server and the forecast service each run under
:mod:`benchmarks.profile_child` (the launcher's child commands, prefixed: every
Python thread, on its own CPU time); the launcher (the ground station) is
profiled in this process, also on CPU time. Writes, per process, the top
functions by own and by cumulative time (µs per control tick) to
``benchmarks/results/profile_sim.json`` and prints the own-time tables. Times
are CPU time under the profiler (waiting on a socket is not counted), which
inflates Python-call-heavy code several-fold: read them as proportions. Compare
the firmware's ``run_tick`` share with ``python -m benchmarks.profile_mission``
(the same tick in process): the rest of each process is what crossing
processes costs.
"""
from __future__ import annotations

import argparse
import cProfile
import pstats
import tempfile
import time
from pathlib import Path

from benchmarks.common import write
from benchmarks.profile_mission import _rows
from sitl.harness import launcher
from sitl.harness.launcher import SimOptions, launch
from sitl.harness.spec import RunSpec

_CLI = ["-m", "sitl.harness.cli"]


class _ProfiledChild(launcher.Child):
    """A launcher child run under :mod:`benchmarks.profile_child` (``DIR/NAME.prof``, written when it exits)."""

    prof_dir: Path = Path(".")

    def __init__(self, name: str, argv: list[str], log: Path, env: dict):
        if argv[1:3] == _CLI:
            argv = [argv[0], "-m", "benchmarks.profile_child", str(self.prof_dir / f"{name}.prof"), *argv[1:]]
        super().__init__(name, argv, log, env)


def _process_figures(stats: pstats.Stats, ticks: int, top: int) -> dict:
    """One process's profile: total (s under the profiler), µs per tick, top functions."""
    total = stats.total_tt  # type: ignore[attr-defined]
    return {"total_s_under_profiler": round(total, 4), "us_per_tick": round(1e6 * total / ticks, 1),
            "by_own_time": _rows(stats, "tottime", top), "by_cumulative": _rows(stats, "cumtime", top)}


def profile(case: str = "W3", controller: str = "cpd_ff", duration: float = 120.0, top: int = 30,
            keep: Path | None = None) -> dict:
    """Fly one ``duration`` s mission across processes, each profiled; the figures per process.

    ``keep``: a folder to leave the run and each process's ``.prof`` in (default: a temporary one).
    """
    with tempfile.TemporaryDirectory(prefix="wk-profile-sim-") as tmp:
        out = Path(keep or tmp)
        out.mkdir(parents=True, exist_ok=True)
        _ProfiledChild.prof_dir = out
        opt = SimOptions(RunSpec(case, controller, duration=duration), out=str(out / "run"))
        saved = launcher.Child
        launcher.Child = _ProfiledChild  # type: ignore[misc]
        prof = cProfile.Profile(time.process_time)
        try:
            prof.enable()
            r = launch(opt, progress=False)
            prof.disable()
        finally:
            launcher.Child = saved  # type: ignore[misc]
        prof.dump_stats(str(out / "launcher.prof"))
        ticks = int(round(duration * r["rate_hz"]))
        processes = {}
        for p in sorted(out.glob("*.prof")):
            processes[p.stem] = _process_figures(pstats.Stats(str(p)), ticks, top)
    return {"case": case, "controller": controller, "duration_s": duration, "ticks": ticks,
            "wall_time_s_under_profiler": r["wall_time_s"], "processes": processes}


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--case", default="W3")
    ap.add_argument("--controller", default="cpd_ff")
    ap.add_argument("--duration", type=float, default=120.0)
    ap.add_argument("--top", type=int, default=30)
    ap.add_argument("--keep", type=Path, default=None, help="leave the run and the .prof files in this folder")
    args = ap.parse_args(argv)
    figures = profile(args.case, args.controller, args.duration, args.top, args.keep)
    path = write("profile_sim", figures)
    print(f"{figures['ticks']} ticks; µs per tick under the profiler, by process:")
    for name, p in figures["processes"].items():
        print(f"\n== {name}: {p['us_per_tick']:.0f} µs/tick ({p['total_s_under_profiler']:.2f} s)")
        print(f"{'own µs/tick':>12} {'cum µs/tick':>12} {'calls':>8}  function")
        for e in p["by_own_time"][:15]:
            print(f"{e['own_s'] * 1e6 / figures['ticks']:12.1f} {e['cum_s'] * 1e6 / figures['ticks']:12.1f} "
                  f"{e['calls']:8d}  {e['function']}")
    print(f"wrote {path}")
    return figures


if __name__ == "__main__":
    main()
