"""``wavekeep compare DIR DIR...``: runs side by side — the RMSE table, time histories and error histograms."""
from __future__ import annotations

import argparse
import json
from pathlib import Path

from . import options as o


def add_parsers(sub) -> None:
    p = sub.add_parser("compare", help="overlay run folders: RMSE table, time histories, error histograms",
                       description="Compare run folders (of wavekeep run or sim): print their RMSE / max error / "
                       "power table side by side and write compare.png (errors over time, overlaid; histograms).")
    p.add_argument("runs", nargs="+", metavar="DIR", help="run folders with results.json and timeseries.csv")
    p.add_argument("--out", default="runs/compare", help="folder for compare.png")
    p.add_argument("--force", action="store_true", help="overwrite compare.png in a non-empty --out")
    p.set_defaults(func=cmd_compare)


def load_run(folder: str | Path):
    """A run folder's :class:`~sitl.harness.results.RunResult` (UsageError naming what is missing)."""
    import numpy as np

    from ..results import TIMESERIES_COLUMNS, RunResult

    d = Path(folder)
    res, ts = d / "results.json", d / "timeseries.csv"
    if not res.is_file() or not ts.is_file():
        raise o.UsageError(f"{folder}: not a run folder (needs results.json and timeseries.csv)")
    with open(ts) as fh:
        header = fh.readline().strip().split(",")
    planar = TIMESERIES_COLUMNS[:-3]    # a run from before the six-DoF world: its y, φ, ψ were zero
    if tuple(header) not in (TIMESERIES_COLUMNS, planar):
        raise o.UsageError(f"{folder}: timeseries.csv is not a station-keeping run's (wavekeep run / sim)")
    log = np.loadtxt(ts, delimiter=",", skiprows=1, ndmin=2)
    if tuple(header) == planar:
        log = np.hstack([log, np.zeros((log.shape[0], 3))])
    return RunResult(json.loads(res.read_text()), log)


def cmd_compare(args: argparse.Namespace) -> int:
    from ..metrics import format_table
    from ..plots import plot_compare

    runs = [load_run(d) for d in args.runs]
    out = o.check_out(args.out, force=args.force)
    names = [f"{Path(d).name}" for d in args.runs]
    if len(set(names)) < len(names):
        names = [str(d) for d in args.runs]
    print(format_table({n: r.results for n, r in zip(names, runs, strict=True)}))
    for n, r in zip(names, runs, strict=True):
        res = r.results
        print(f"  {n}: {res.get('case')} {res.get('label')}, seed {res.get('seed')}, {res.get('duration_s')} s")
    path = plot_compare(runs, names, out / "compare.png")
    print(f"wrote {path}")
    return 0
