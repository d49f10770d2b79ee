"""cProfile of one in-process mission: where a tick's time goes.

    python -m benchmarks.profile_mission [--case W3] [--controller cpd_ff] [--duration 120] [--top 40]

Writes the top functions (by cumulative and by own time) as JSON to
``benchmarks/results/profile.json`` and prints the own-time table. Times are
under the profiler (cProfile inflates Python-call-heavy code several-fold),
so read them as proportions, not as the mission's speed.
"""
from __future__ import annotations

import argparse
import cProfile
import pstats

from benchmarks.common import write
from sitl.harness.run import run_mission
from sitl.harness.spec import RunSpec


def _rows(stats: pstats.Stats, key: str, top: int) -> list[dict]:
    """The ``top`` functions by ``key`` ('tottime' or 'cumtime'): name, calls, own and cumulative s."""
    entries = []
    for (file, line, name), (_, ncalls, tottime, cumtime, _) in stats.stats.items():  # type: ignore[attr-defined]
        entries.append({"function": f"{file}:{line}({name})", "calls": ncalls,
                        "own_s": round(tottime, 6), "cum_s": round(cumtime, 6)})
    field = "own_s" if key == "tottime" else "cum_s"
    return sorted(entries, key=lambda e: e[field], reverse=True)[:top]


def profile(case: str = "W3", controller: str = "cpd_ff", duration: float = 120.0, top: int = 40) -> dict:
    """Profile one mission (duration s of simulated time); the figures as a dict."""
    prof = cProfile.Profile()
    prof.enable()
    r = run_mission(RunSpec(case, controller, duration=duration)).results
    prof.disable()
    stats = pstats.Stats(prof)
    ticks = int(round(duration * r["rate_hz"]))
    return {"case": case, "controller": controller, "duration_s": duration, "ticks": ticks,
            "total_s_under_profiler": stats.total_tt,  # type: ignore[attr-defined]
            "by_own_time": _rows(stats, "tottime", top), "by_cumulative": _rows(stats, "cumtime", top)}


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--case", default="W3")
    ap.add_argument("--controller", default="cpd_ff")
    ap.add_argument("--duration", type=float, default=120.0)
    ap.add_argument("--top", type=int, default=40)
    args = ap.parse_args(argv)
    figures = profile(args.case, args.controller, args.duration, args.top)
    path = write("profile", figures)
    per_tick = 1e6 / figures["ticks"]
    print(f"{figures['ticks']} ticks, {figures['total_s_under_profiler']:.2f} s under the profiler")
    print(f"{'own µs/tick':>12} {'cum µs/tick':>12} {'calls':>8}  function")
    for e in figures["by_own_time"][:25]:
        print(f"{e['own_s'] * per_tick:12.1f} {e['cum_s'] * per_tick:12.1f} {e['calls']:8d}  {e['function']}")
    print(f"wrote {path}")
    return figures


if __name__ == "__main__":
    main()
