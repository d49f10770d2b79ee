"""``wavekeep run``, ``reproduce`` and ``campaign``: missions flown in-process (one, the paper's nine, a grid)."""
from __future__ import annotations

import argparse
import contextlib
import signal
import sys
from pathlib import Path

from . import options as o
from . import view


def add_parsers(sub) -> None:
    p = sub.add_parser("run", help="fly one station-keeping mission in-process and report it",
                       description="Fly one station-keeping mission in-process; print RMSE, max error and power "
                       "per DoF; write results.json, timeseries.csv, time_history.png and run.json.")
    o.add_common(p)
    o.add_controller(p)
    p.add_argument("--duration", type=o.duration, default=None, help="mission length (s); default: the mission's (600)")
    o.add_params(p)
    o.add_world(p)
    p.add_argument("--no-plots", action="store_true", help="skip time_history.png")
    view.add_record_options(p)
    o.add_out(p)
    p.set_defaults(func=cmd_run)

    p = sub.add_parser("reproduce", help="the paper's table: W1-W3 x {C-PD, FF exact, FF 15 dB}",
                       description="The paper's nine runs (W1-W3 x C-PD, C-PD+FF exact, C-PD+FF 15 dB) on a local "
                       "Dask cluster: the table beside the paper's figures, reproduce.json, Figs. 4-7, run.json.")
    p.add_argument("--seed", type=o.seed, default=None,
                   help="sea realisation for every case, integer in [0, 2^63 - 1]; default: each sea config's")
    p.add_argument("--duration", type=o.duration, default=None, help="mission length (s); default: the mission's (600)")
    p.add_argument("--seeds", type=o.count, default=None,
                   help="run the grid over seeds 1..N and report means with 95 %% bootstrap CIs (a resumable campaign)")
    p.add_argument("--workers", type=o.count, default=None, help="parallel worker processes; default: one per core")
    p.add_argument("--scheduler", default=None, help="tcp://HOST:8786 of an existing Dask cluster; default: local")
    o.add_params(p)
    p.add_argument("--no-plots", action="store_true", help="skip the figures")
    o.add_out(p, what="folder for reproduce.json, the figures and run.json")
    p.set_defaults(func=cmd_reproduce)

    p = sub.add_parser("campaign", help="run a grid of missions on Dask (resumable) and compare variants across seeds")
    p.add_argument("spec", help="campaign YAML file (see configs/campaign/ and docs/campaigns.md)")
    p.add_argument("--out", required=True, help="campaign folder; a rerun into it skips missions already done")
    p.add_argument("--scheduler", default=None, help="tcp://HOST:8786 of an existing Dask cluster; default: local")
    p.add_argument("--workers", type=o.count, default=None,
                   help="local cluster worker processes; default: one per core")
    p.add_argument("--retry-failed", action="store_true", help="rerun missions recorded as failed")
    p.add_argument("--no-plots", action="store_true", help="skip the figures")
    p.add_argument("--log-interval", type=o.positive, default=10.0,
                   help="seconds between progress lines when stderr is not a terminal")
    p.set_defaults(func=cmd_campaign)


def cmd_run(args: argparse.Namespace) -> int:
    """One station-keeping mission in-process: prints the results, writes the run folder."""
    from ..metrics import format_six_dof, format_table
    from ..provenance import write_run_record
    from ..results import lapse_lines
    from ..run import MissionDiverged, run_mission, write_run

    spec = o.run_spec(args)
    out = o.check_out(args.out, force=args.force)
    try:
        result = run_mission(spec, progress=True)
    except MissionDiverged as exc:
        if exc.result is not None:   # kept for diagnosis: the time series up to the last physical state
            write_run(exc.result, out, plots=not args.no_plots)
            write_run_record(out, args.argv, spec, seed=exc.result.results["seed"])
        print(f"wavekeep run: {exc}" + (f"; wrote {out}" if exc.result is not None else ""), file=sys.stderr)
        return 1
    r = result.results
    write_run(result, out, plots=not args.no_plots)
    write_run_record(out, args.argv, spec, seed=r["seed"])
    print(f"{r['case']} {r['label']}, seed {r['seed']}, {r['duration_s']:g} s at {r['rate_hz']:g} Hz: "
          f"{r['wall_time_s']:.1f} s wall ({r['speed_x_realtime']:.0f}x real time), "
          f"{r['tick_overruns']} tick overruns, control tick p99 {r['control_tick']['p99_us']:.0f} µs")
    print(format_table({r["label"]: r}))
    if "six_dof" in r:
        print(format_six_dof(r["six_dof"]))
    for line in lapse_lines(r):
        print(line)
    print(f"wrote {out}: results.json, timeseries.csv, run.json" + ("" if args.no_plots else ", time_history.png"))
    view.record(args, out, spec, r["seed"], result)
    return 0


def _sigint_raises() -> None:
    """Ctrl-C raises KeyboardInterrupt (a shell starts background jobs with SIGINT ignored; a long run wants it)."""
    signal.signal(signal.SIGINT, signal.default_int_handler)


def cmd_reproduce(args: argparse.Namespace) -> int:
    """The paper's nine runs, the table in its terms, reproduce.json and the figures."""
    if args.seeds is not None:
        return _reproduce_seeds(args)
    from ..provenance import write_run_record
    from ..reproduce import format_reproduce, reproduce

    o.check_duration(args.duration, "station_keeping")
    overrides = o.overrides(args)
    out = o.check_out(args.out, force=args.force)
    _sigint_raises()
    try:
        doc = reproduce(out, seed=args.seed, duration=args.duration, workers=args.workers, plots=not args.no_plots,
                        progress=lambda m: print(m, file=sys.stderr, flush=True), scheduler=args.scheduler,
                        overrides=overrides)
    except KeyboardInterrupt:
        print(f"wavekeep reproduce: interrupted; stopped the cluster, wrote nothing to {out}", file=sys.stderr)
        return 130
    from ..reproduce import WORLDS, paper_tasks
    specs = [t.spec for w in WORLDS for t in paper_tasks(args.seed, args.duration, False, overrides, w)]
    write_run_record(out, args.argv, specs, seed=args.seed, duration_s=args.duration)
    print(format_reproduce(doc))
    n_runs = len(doc["runs"]) + len(doc["corrected"]["runs"])
    print(f"{n_runs} runs in {doc['wall_time_s']:.1f} s; wrote {Path(out) / 'reproduce.json'}, run.json"
          + ("" if args.no_plots else " and the figures"))
    return 0


def _reproduce_seeds(args: argparse.Namespace) -> int:
    """``reproduce --seeds N``: the paper's grid over seeds 1..N, with bootstrap CIs (a resumable campaign)."""
    from ..campaign import report_text
    from ..reproduce import format_paper_comparison, reproduce_seeds

    if args.seed is not None:
        raise o.UsageError("--seeds N runs seeds 1..N: give no --seed with it")
    if args.params or args.set:
        raise o.UsageError("--params/--set are not supported with --seeds (a campaign); use a campaign YAML")
    o.check_out(args.out, kind="campaign")   # a campaign folder resumes: its files are kept
    _sigint_raises()
    with _campaign_interrupt("reproduce"):
        report = reproduce_seeds(args.out, args.seeds, duration=args.duration, workers=args.workers,
                                 plots=not args.no_plots, scheduler=args.scheduler)
    print(report_text(report))
    print(format_paper_comparison(report.summary))
    return _campaign_status(report)


@contextlib.contextmanager
def _campaign_interrupt(command: str):
    """Ctrl-C during a campaign: say how far it got and how to resume, exit 130 (via SystemExit)."""
    from ..campaign import CampaignInterrupted

    try:
        yield
    except CampaignInterrupted as exc:
        print(f"wavekeep {command}: interrupted; {exc}", file=sys.stderr)
        raise SystemExit(130) from None


def _campaign_status(report) -> int:
    """0 if every mission flew; else 1, the errors and, as the last line, how many failed and where."""
    from ..campaign import failure_text

    text = failure_text(report)
    if text is None:
        return 0
    print(text, file=sys.stderr)
    return 1


def cmd_campaign(args: argparse.Namespace) -> int:
    """A grid of missions (sea states x seeds x variants) on Dask: rows, statistics across seeds, figures."""
    from ..campaign import report_text, run_campaign
    from ..campaign_spec import load_campaign_spec

    spec = load_campaign_spec(args.spec)
    o.check_out(args.out, kind="campaign")
    _sigint_raises()
    with _campaign_interrupt("campaign"):
        report = run_campaign(spec, args.out, scheduler=args.scheduler, workers=args.workers,
                              retry_failed=args.retry_failed, plots=not args.no_plots, log_interval=args.log_interval)
    print(report_text(report))
    return _campaign_status(report)
