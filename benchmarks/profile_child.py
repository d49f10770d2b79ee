"""Run a module under cProfile with per-thread CPU time, every Python thread included (for ``profile_sim``).

    python -m benchmarks.profile_child OUT.prof -m MODULE [ARGS...]

Each thread gets its own profiler on ``time.thread_time`` (CPU, not wall: a
process waiting on a socket costs nothing here); their statistics are merged
into ``OUT.prof`` when the module returns or exits. Only the standard library
is imported before the module, so the profiled process starts as it would.
"""
from __future__ import annotations

import cProfile
import pstats
import runpy
import sys
import threading
import time


def main() -> None:
    out, flag, module, *rest = sys.argv[1:]
    if flag != "-m":
        raise SystemExit("usage: python -m benchmarks.profile_child OUT.prof -m MODULE [ARGS...]")
    sys.argv = [module, *rest]
    profiles: list[cProfile.Profile] = []

    def start_thread_profile(*_args) -> None:
        p = cProfile.Profile(time.thread_time)
        profiles.append(p)
        p.enable()                              # replaces this hook for the rest of the thread

    threading.setprofile(start_thread_profile)
    main_prof = cProfile.Profile(time.thread_time)
    main_prof.enable()
    try:
        runpy.run_module(module, run_name="__main__", alter_sys=True)
    except SystemExit:
        pass
    finally:
        main_prof.disable()
        stats = pstats.Stats(main_prof)
        for p in profiles:
            stats.add(p)
        stats.dump_stats(out)


if __name__ == "__main__":
    main()
