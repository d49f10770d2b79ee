"""The ``wavekeep`` command line.

    wavekeep run       --case W3 --controller cpd_ff --out runs/W3   # one station-keeping mission
    wavekeep reproduce --out runs/reproduce                          # the paper's nine runs and figures
    wavekeep campaign  configs/campaign/smoke.yaml --out runs/smoke  # a grid of missions on Dask, with CIs
    wavekeep live      --case W3 --mavlink udpout:127.0.0.1:14550    # fly it from a ground station
    wavekeep thrust    --pattern sine --axis heave --arm             # stream thrust demands over MAVLink
    wavekeep sea       --case W1 --duration 1800 --out sea.csv       # the realised sea at the vehicle
    wavekeep openloop  --case W3 --out runs/openloop-W3              # the passive vehicle in the sea

Every ``--case`` takes a name from ``configs/sea/`` or a path to a sea YAML file.
Errors in inputs (bad config, unknown case) print one clear line and exit with 2.
"""
from __future__ import annotations

import argparse
import csv
import json
import sys
import time
from pathlib import Path

import numpy as np

from bridge.configfile import ConfigError

from .spec import RunSpec

__all__ = ["main"]


def _positive(text: str) -> float:
    v = float(text)
    if not (v > 0 and np.isfinite(v)):
        raise argparse.ArgumentTypeError(f"must be a positive number, got {text}")
    return v


def _add_common(p: argparse.ArgumentParser) -> None:
    p.add_argument("--case", default="W3", help="sea state: a name in configs/sea/ (W1, W2, W3) or a YAML path")
    p.add_argument("--seed", type=int, default=None, help="override the sea config's seed")
    p.add_argument("--mission", default="station_keeping", help="mission config name or path")
    p.add_argument("--vehicle", default="bluerov2_heavy", help="vehicle config name or path")


def cmd_sea(args) -> int:
    """Write t, eta, u, w at the vehicle's station (x from the mission, depth from the mission)."""
    from bridge.models.waves import particle_kinematics_grid
    from bridge.schemas import load_mission_config
    from sitl.sea import Sea

    sea = Sea.load(args.case, seed=args.seed)
    mission = load_mission_config(args.mission)
    x = mission["setpoint"]["x"] if args.x is None else args.x
    depth = mission["setpoint"]["depth"] if args.depth is None else args.depth
    rate = mission["control_rate"] if args.rate is None else args.rate
    n = int(round(args.duration * rate)) + 1
    t = np.arange(n) / rate
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    with open(out, "w", newline="") as fh:
        fh.write(f"# wavekeep sea: case={sea.name} seed={sea.seed} x={x} m depth={depth} m "
                 f"Hs_target={sea.hs_target:.3f} m Hs_components={sea.hs():.3f} m components={sea.components.n}\n")
        w = csv.writer(fh)
        w.writerow(["t", "eta", "u", "w"])
        for i in range(0, n, 2048):
            tt = t[i:i + 2048]
            eta = sea.elevation(x, tt)
            u, wv, _, _ = particle_kinematics_grid(sea.components, [x], [depth], tt)
            for row in zip(tt, eta, u[:, 0], wv[:, 0], strict=False):
                w.writerow([f"{row[0]:.4f}", f"{row[1]:.6f}", f"{row[2]:.6f}", f"{row[3]:.6f}"])
    print(f"wrote {out}: {n} samples at {rate:g} Hz, Hs(components) {sea.hs():.3f} m "
          f"(target {sea.hs_target:.3f} m), 4*std(eta) over the record is the realised value to check")
    return 0


def cmd_openloop(args) -> int:
    """The passive vehicle (all thrusters at 1500 µs) released at the setpoint in the sea."""
    from bridge.schemas import load_mission_config
    from sitl.plant import Plant
    from sitl.sea import Sea

    from .metrics import format_table, station_keeping_metrics
    from .progress import ProgressBar

    sea = Sea.load(args.case, seed=args.seed)
    mission = load_mission_config(args.mission)
    plant = Plant.from_configs(sea, args.vehicle, args.mission)
    sp = mission["setpoint"]
    setpoint = np.array([sp["x"], sp["depth"], sp["pitch"]])
    rate = mission["control_rate"]
    duration = mission["duration"] if args.duration is None else args.duration
    n = int(round(duration * rate))
    dt = 1.0 / rate
    pwm = np.full(8, plant.curve.pwm_neutral)
    log = np.empty((n + 1, 11))

    def record(i):
        s = plant.state
        log[i] = [s.t, *s.eta, *s.nu, *plant.tau_E, sea.elevation(s.eta[0], s.t)]

    record(0)
    wall0 = time.perf_counter()
    with ProgressBar(n, f"openloop {sea.name}") as bar:
        for i in range(1, n + 1):
            plant.step(pwm, dt)
            record(i)
            bar.update(i)
    wall = time.perf_counter() - wall0
    metrics = station_keeping_metrics(log[:, 0], log[:, 1:4], setpoint, np.zeros((n + 1, 3)))
    results = {
        "kind": "openloop", "case": sea.name, "seed": sea.seed, "controller": "none",
        "duration_s": duration, "rate_hz": rate, "hs_target_m": sea.hs_target, "hs_components_m": sea.hs(),
        "setpoint": setpoint.tolist(), **metrics,
        "wall_time_s": wall, "speed_x_realtime": duration / wall if wall > 0 else None,
    }
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "results.json").write_text(json.dumps(results, indent=2))
    header = "t,x,z,theta,u,w,q,X_E,Z_E,M_E,wave_elevation"
    np.savetxt(out / "timeseries.csv", log, delimiter=",", header=header, comments="", fmt="%.6f")
    print(f"Open loop (thrusters neutral) in {sea.name}, seed {sea.seed}, {duration:g} s at {rate:g} Hz: "
          f"{wall:.2f} s wall ({results['speed_x_realtime']:.0f}x real time)")
    print(format_table({f"{sea.name} passive": metrics}))
    print(f"wrote {out / 'results.json'} and {out / 'timeseries.csv'}")
    return 0


class UsageError(Exception):
    """A bad combination of command-line options: reported in one line, exit status 2."""


def run_spec(args) -> RunSpec:
    """The :class:`RunSpec` that a run command's options describe."""
    try:
        return RunSpec(case=args.case, controller=args.controller, snr_db=args.forecast_snr_db, seed=args.seed,
                       duration=getattr(args, "duration", None), mission=args.mission, vehicle=args.vehicle,
                       forecast=getattr(args, "forecast", "oracle"))
    except ValueError as exc:
        raise UsageError(str(exc)) from None


def cmd_run(args) -> int:
    """One station-keeping mission in-process: prints the results, writes the run folder."""
    from .metrics import format_table
    from .run import run_mission, write_run

    result = run_mission(run_spec(args), progress=True)
    r = result.results
    out = write_run(result, args.out, plots=not args.no_plots)
    print(f"{r['case']} {r['label']}, seed {r['seed']}, {r['duration_s']:g} s at {r['rate_hz']:g} Hz: "
          f"{r['wall_time_s']:.1f} s wall ({r['speed_x_realtime']:.0f}x real time), "
          f"{r['tick_overruns']} tick overruns, control tick p99 {r['control_tick']['p99_us']:.0f} µs")
    print(format_table({r["label"]: r}))
    print(f"wrote {out}/results.json, timeseries.csv" + ("" if args.no_plots else ", time_history.png"))
    return 0


def cmd_reproduce(args) -> int:
    """The paper's nine runs, the table in its terms, reproduce.json and the figures."""
    from .reproduce import format_reproduce_table, reproduce

    if args.seeds is not None:
        return _reproduce_seeds(args)
    doc = reproduce(args.out, seed=args.seed, duration=args.duration, workers=args.workers,
                    plots=not args.no_plots, progress=lambda m: print(m, file=sys.stderr), scheduler=args.scheduler)
    print(format_reproduce_table(doc["runs"], doc["summary"]))
    print(f"{len(doc['runs'])} runs in {doc['wall_time_s']:.1f} s; wrote {Path(args.out) / 'reproduce.json'}")
    return 0


def cmd_campaign(args) -> int:
    """A grid of missions (sea states x seeds x variants) on Dask: rows, statistics across seeds, figures."""
    import signal

    from .campaign import report_text, run_campaign
    from .campaign_spec import load_campaign_spec

    spec = load_campaign_spec(args.spec)
    # Ctrl-C stops the campaign (a shell starts background jobs with SIGINT ignored; a campaign wants it)
    signal.signal(signal.SIGINT, signal.default_int_handler)
    if args.workers is not None and args.workers < 1:
        raise UsageError(f"--workers must be at least 1, got {args.workers}")
    report = run_campaign(spec, args.out, scheduler=args.scheduler, workers=args.workers,
                          retry_failed=args.retry_failed, plots=not args.no_plots, log_interval=args.log_interval)
    print(report_text(report))
    return 0


def _reproduce_seeds(args) -> int:
    """``reproduce --seeds N``: the paper's grid over seeds 1..N, with bootstrap CIs (a resumable campaign)."""
    from .campaign import report_text
    from .reproduce import format_paper_comparison, reproduce_seeds

    if args.seeds < 1 or args.seed is not None:
        raise UsageError("--seeds N needs N >= 1 and no --seed (the seeds are 1..N)")
    report = reproduce_seeds(args.out, args.seeds, duration=args.duration, workers=args.workers,
                             plots=not args.no_plots, scheduler=args.scheduler)
    print(report_text(report))
    print(format_paper_comparison(report.summary))
    return 0


def cmd_live(args) -> int:
    """The vehicle flying live in one process, with its MAVLink link, until Ctrl-C or --duration."""
    from .live import LiveSim

    key = None
    if args.signing_key:
        from firmware_py.mavlink import load_signing_key
        key = load_signing_key(args.signing_key)
    sim = LiveSim(run_spec(args),
                  mavlink=args.mavlink or ["udpout:127.0.0.1:14550"], speedup=args.speedup, signing_key=key)
    endpoints = ", ".join(args.mavlink or ["udpout:127.0.0.1:14550"])
    print(f"Wavekeep live: {args.case}, {args.controller}, MAVLink on {endpoints}, speed-up {args.speedup:g}. "
          "Disarmed in MANUAL; arm and pick a mode from your ground station. Ctrl-C stops.")
    with sim:
        t0 = time.monotonic()
        try:
            while args.duration is None or time.monotonic() - t0 < args.duration / args.speedup:
                time.sleep(0.2)
        except KeyboardInterrupt:
            pass
    stats = sim.firmware.scheduler.stats()
    print(f"stopped: {stats['ticks']} ticks, {stats['overruns']} overruns; link counters {sim.link.counters}")
    return 0


def cmd_thrust(args) -> int:
    """Stream thrust demands to a vehicle over MAVLink at 20 Hz."""
    from .thrust import csv_profile, pattern_profile, stream_thrust

    profile = csv_profile(args.csv) if args.csv else pattern_profile(args.pattern, args.axis, args.amplitude,
                                                                      args.duration, args.period)
    out = stream_thrust(args.mavlink, profile, units=args.units, arm=args.arm)
    print(f"sent {out['messages']} messages in {out['ticks']} ticks over {out['duration_s']:.1f} s")
    return 0


def cmd_forecast(args) -> int:
    """The forecast service (shore side) on zenoh, until Ctrl-C / SIGTERM."""
    import signal
    import threading

    from bridge.forecast import derive_seeds, oracle_forecast
    from bridge.forecast_service import ForecastService
    from bridge.schemas import load_mission_config
    from bridge.zenoh_net import load_network_config, open_session
    from sitl.sea import Sea

    net = load_network_config(args.network)
    site = args.site or net["site"]
    sea = Sea.load(args.case, seed=args.seed)
    oracle = None
    if args.mode == "oracle":
        _, forecast_seed = derive_seeds(sea.seed)
        oracle = oracle_forecast(sea.components, args.snr_db, np.random.default_rng(forecast_seed))
    x_vehicle = load_mission_config(args.mission)["setpoint"]["x"]
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    with open_session(net, "service") as session:
        svc = ForecastService(session, site, args.mode, oracle=oracle, x_vehicle=x_vehicle,
                              water_depth=sea.water_depth, rate_hz=args.rate, horizon_s=args.horizon,
                              deep_water=args.deep_water)
        print(f"wavekeep forecast: ready, site {site}, mode {args.mode}"
              + (f" ({args.snr_db:g} dB error)" if args.snr_db is not None else ""), flush=True)
        try:
            svc.run(stop)
        finally:
            svc.close()
    print(f"wavekeep forecast: stopped; {svc.counters}", flush=True)
    return 0


def _add_campaign_parser(sub) -> None:
    """``wavekeep campaign SPEC --out DIR [--scheduler tcp://HOST:PORT] [--workers N] ...``."""
    p = sub.add_parser("campaign", help="run a grid of missions on Dask (resumable) and compare variants across seeds")
    p.add_argument("spec", help="campaign YAML file (see configs/campaign/ and docs/campaigns.md)")
    p.add_argument("--out", required=True, help="campaign folder; a rerun into it skips missions already done")
    p.add_argument("--scheduler", default=None, help="tcp://HOST:8786 of an existing Dask cluster; "
                   "default: a local cluster on 127.0.0.1")
    p.add_argument("--workers", type=int, default=None, help="local cluster: worker processes (default one per core)")
    p.add_argument("--retry-failed", action="store_true", help="rerun missions recorded as failed")
    p.add_argument("--no-plots", action="store_true", help="skip the figures")
    p.add_argument("--log-interval", type=_positive, default=10.0,
                   help="seconds between progress lines when stderr is not a terminal")
    p.set_defaults(func=cmd_campaign)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="wavekeep", description=__doc__.split("\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    _add_mission_parsers(sub)
    _add_campaign_parser(sub)
    _add_live_parsers(sub)
    _add_process_parsers(sub)
    _add_world_parsers(sub)
    return parser


def _add_mission_parsers(sub) -> None:
    """``run`` and ``reproduce``: in-process missions."""
    p = sub.add_parser("run", help="fly one station-keeping mission in-process and report it")
    _add_common(p)
    p.add_argument("--controller", choices=("cpd", "cpd_ff"), default="cpd_ff")
    p.add_argument("--forecast-snr-db", type=float, default=None,
                   help="inject the paper's forecast error at this SNR (dB); default: the exact forecast")
    p.add_argument("--duration", type=_positive, default=None, help="seconds; default the mission's (600)")
    p.add_argument("--forecast", choices=("oracle", "dswp"), default="oracle",
                   help="the sea's own components, or predicted from the up-wave buoy (DSWP)")
    p.add_argument("--no-plots", action="store_true", help="skip the PNG")
    p.add_argument("--out", required=True, help="run folder")
    p.set_defaults(func=cmd_run)

    p = sub.add_parser("reproduce", help="the paper's table: W1-W3 x {C-PD, FF exact, FF 15 dB}")
    p.add_argument("--seed", type=int, default=None, help="override every sea config's seed")
    p.add_argument("--duration", type=_positive, default=None, help="seconds per run; default 600")
    p.add_argument("--seeds", type=int, default=None,
                   help="run the grid over seeds 1..N and report means with 95 %% bootstrap CIs (a campaign)")
    p.add_argument("--workers", type=int, default=None, help="parallel processes; default one per core")
    p.add_argument("--scheduler", default=None, help="tcp://HOST:8786 of an existing Dask cluster")
    p.add_argument("--no-plots", action="store_true", help="skip the figures")
    p.add_argument("--out", required=True, help="folder for reproduce.json and the figures")
    p.set_defaults(func=cmd_reproduce)


def _add_live_parsers(sub) -> None:
    """``live`` and ``thrust``: a vehicle flying on the wall clock, and a client that drives it."""
    p = sub.add_parser("live", help="fly the vehicle live in one process with its MAVLink link (for a GCS)")
    _add_common(p)
    p.add_argument("--controller", choices=("cpd", "cpd_ff"), default="cpd_ff")
    p.add_argument("--forecast-snr-db", type=float, default=None)
    p.add_argument("--mavlink", action="append", help="endpoint (repeatable): udpout:HOST:PORT, udpin:..., tcp:...; "
                   "default udpout:127.0.0.1:14550")
    p.add_argument("--speedup", type=_positive, default=1.0, help="simulated time per wall-clock second")
    p.add_argument("--duration", type=_positive, default=None, help="stop after this much simulated time (s)")
    p.add_argument("--signing-key", default=None, help="file with a 32-byte MAVLink 2 signing key")
    p.set_defaults(func=cmd_live)

    p = sub.add_parser("thrust", help="stream thrust demands to a vehicle at 20 Hz (bench tests)")
    p.add_argument("--mavlink", default="udpin:127.0.0.1:14550", help="where to meet the vehicle (GCS side)")
    p.add_argument("--csv", default=None, help="CSV of t, surge, heave, pitch demands")
    p.add_argument("--pattern", choices=("zero", "step", "square", "sine", "sweep"), default="step")
    p.add_argument("--axis", choices=("surge", "heave", "pitch"), default="surge")
    p.add_argument("--amplitude", type=float, default=0.2)
    p.add_argument("--period", type=_positive, default=4.0, help="s, for square and sine")
    p.add_argument("--duration", type=_positive, default=10.0, help="s, for patterns")
    p.add_argument("--units", choices=("normalised", "si"), default="normalised",
                   help="normalised sticks in [-1, 1], or N / N m scaled by the vehicle's WK_TAU_MAX_*")
    p.add_argument("--arm", action="store_true", help="switch the vehicle to MANUAL and arm it first")
    p.set_defaults(func=cmd_thrust)


def _add_process_parsers(sub) -> None:
    """``forecast``, ``sim``, ``plant``, ``firmware``: the SITL processes and their launcher."""
    p = sub.add_parser("forecast", help="the wave forecast service (shore side) on zenoh")
    _add_common(p)
    p.add_argument("--site", default=None, help="site name for the key expressions (default: configs/network.yaml)")
    p.add_argument("--mode", choices=("oracle", "dswp"), default="oracle")
    p.add_argument("--snr-db", type=float, default=None, help="oracle: inject the paper's error at this SNR")
    p.add_argument("--rate", type=_positive, default=2.0, help="forecasts per second of the vehicle's clock")
    p.add_argument("--horizon", type=_positive, default=10.0, help="oracle: validity after the newest buoy time (s)")
    p.add_argument("--deep-water", action="store_true", help="dswp: deep-water wavenumbers (the authors' choice)")
    p.add_argument("--network", default="network", help="network config name or path")
    p.set_defaults(func=cmd_forecast)

    p = sub.add_parser("sim", help="SITL: plant, forecast service and firmware as processes, flown over MAVLink")
    _add_common(p)
    p.add_argument("--controller", choices=("cpd", "cpd_ff"), default="cpd_ff")
    p.add_argument("--forecast-snr-db", type=float, default=None)
    p.add_argument("--forecast", choices=("oracle", "dswp"), default="oracle", help="forecast service mode")
    p.add_argument("--speedup", type=_positive, default=None,
                   help="X times real time; default: as fast as the CPU allows")
    p.add_argument("--duration", type=_positive, default=None, help="seconds; default the mission's (600)")
    p.add_argument("--plant-port", type=int, default=9002)
    p.add_argument("--gcs-port", type=int, default=14550)
    p.add_argument("--zenoh-port", type=int, default=7447)
    p.add_argument("--companion", nargs="?", const="rc", choices=("rc", "servo"), default=None,
                   help="fly with `wavekeep companion` (method rc or servo) through the firmware as a stand-in "
                        "ArduSub (docs/companion.md)")
    p.add_argument("--companion-port", type=int, default=14770)
    p.add_argument("--out", default="runs/sim", help="run folder")
    p.set_defaults(func=cmd_sim)

    p = sub.add_parser("plant", help="the plant as an ArduPilot JSON SITL physics server (see wavekeep plant -h)")
    p = sub.add_parser("firmware", help="the firmware as its own process (see wavekeep firmware -h)")


def _add_world_parsers(sub) -> None:
    """``sea`` and ``openloop``: the world alone."""
    p = sub.add_parser("sea", help="write the realised sea (t, eta, u, w) at the vehicle to CSV")
    _add_common(p)
    p.add_argument("--duration", type=_positive, default=600.0, help="record length (s)")
    p.add_argument("--rate", type=_positive, default=None, help="sample rate (Hz); default the control rate")
    p.add_argument("--x", type=float, default=None, help="north position (m); default the mission setpoint")
    p.add_argument("--depth", type=float, default=None, help="depth (m); default the mission setpoint")
    p.add_argument("--out", required=True, help="CSV file to write")
    p.set_defaults(func=cmd_sea)

    p = sub.add_parser("openloop", help="release the unpowered vehicle at the setpoint and report its drift")
    _add_common(p)
    p.add_argument("--duration", type=_positive, default=None, help="seconds; default the mission's")
    p.add_argument("--out", required=True, help="run folder for results.json and timeseries.csv")
    p.set_defaults(func=cmd_openloop)


def cmd_sim(args) -> int:
    """The plant, the forecast service and the firmware as processes; the launcher flies them as a GCS."""
    from .launcher import LaunchError, SimOptions, launch
    from .metrics import format_table

    opt = SimOptions(run_spec(args), speedup=args.speedup, out=args.out, plant_port=args.plant_port,
                     gcs_port=args.gcs_port, zenoh_port=args.zenoh_port)
    try:
        if args.companion:
            from .companion_launch import launch_companion
            r = launch_companion(opt, args.companion, args.companion_port, progress=None)
        else:
            r = launch(opt, progress=None)
    except LaunchError as exc:
        print(f"wavekeep sim: {exc}", file=sys.stderr)
        return exc.status
    print(f"{r['case']} {r['label']} across processes, seed {r['seed']}, {r['duration_s']:g} s: "
          f"{r['wall_time_s']:.1f} s wall ({r['speed_x_realtime']:.0f}x real time), {r['tick_overruns']} tick overruns")
    print(format_table({r["label"]: r}))
    print(f"wrote {args.out}: results.json, timeseries.csv, time_history.png, mission.tlog, *.log")
    return 0


DELEGATED = {"plant": "sitl.physics_server", "firmware": "firmware_py.app", "companion": "firmware_py.companion.app"}
"""Subcommands that are programs of their own (separate processes in ``wavekeep sim``)."""


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv and argv[0] in DELEGATED:
        import importlib
        return importlib.import_module(DELEGATED[argv[0]]).main(argv[1:])
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except ConfigError as exc:
        print(f"wavekeep: config error: {exc}", file=sys.stderr)
        return 2
    except UsageError as exc:
        print(f"wavekeep {args.command}: {exc}", file=sys.stderr)
        return 2
    except (TimeoutError, ValueError, RuntimeError) as exc:
        print(f"wavekeep {args.command}: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("wavekeep: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
