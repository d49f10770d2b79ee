"""``wavekeep sim`` (the SITL processes, launched and flown as a ground station) and ``forecast`` (shore side)."""
from __future__ import annotations

import argparse
import math
import socket
import sys
from pathlib import Path

from . import options as o
from . import view


def add_parsers(sub) -> None:
    p = sub.add_parser("forecast", help="the wave forecast service (shore side) on zenoh",
                       description="The wave forecast service (shore side) on zenoh, until Ctrl-C / SIGTERM.")
    o.add_common(p, vehicle=False)
    p.add_argument("--site", default=None, help="site name for the key expressions; default: configs/network.yaml's")
    p.add_argument("--forecast", choices=("oracle", "dswp"), default="oracle",
                   help="forecast source: oracle (the sea's own components) or dswp (from the up-wave buoy)")
    p.add_argument("--forecast-snr-db", type=o.snr_db, default=None,
                   help="oracle: inject the paper's error at this SNR (dB, in [-20, 80]); default: the exact forecast")
    # the old spellings, hidden
    p.add_argument("--mode", dest="forecast", choices=("oracle", "dswp"), default=argparse.SUPPRESS,
                   help=argparse.SUPPRESS)
    p.add_argument("--snr-db", dest="forecast_snr_db", type=o.snr_db, default=argparse.SUPPRESS,
                   help=argparse.SUPPRESS)
    p.add_argument("--rate", type=o.positive, default=2.0, help="forecasts per second of the vehicle's clock (Hz)")
    p.add_argument("--horizon", type=o.positive, default=10.0, help="oracle: validity after the newest buoy time (s)")
    p.add_argument("--deep-water", action="store_true", help="dswp: deep-water wavenumbers (the authors' choice)")
    p.add_argument("--network", default="network", help="network config: a name in configs/ or a path")
    p.add_argument("--sea-start", type=float, default=0.0, metavar="S",
                   help="the vehicle's clock (s) at the sea's t = 0: a plant run with --sea-start S")
    o.add_world(p, vehicle=False)
    p.set_defaults(func=cmd_forecast)

    p = sub.add_parser("sim", help="SITL: plant, forecast service and firmware as processes, flown over MAVLink",
                       description="The plant, the forecast service and the firmware as separate processes, flown "
                       "over MAVLink as a ground station would; writes results.json, timeseries.csv, "
                       "time_history.png, mission.tlog, each process's log and run.json.")
    o.add_common(p)
    o.add_controller(p, forecast_help="forecast service mode")
    p.add_argument("--speedup", type=o.positive, default=None,
                   help="simulated seconds per wall-clock second; default: as fast as the CPU allows")
    p.add_argument("--duration", type=o.duration, default=None, help="mission length (s); default: the mission's (600)")
    o.add_params(p)
    o.add_world(p)
    p.add_argument("--plant-port", type=o.port, default=None,
                   help=f"UDP port of the plant's JSON SITL server; default {SIM_PORTS['--plant-port'][0]}, "
                   "or a free one if that is taken")
    p.add_argument("--gcs-port", type=o.port, default=None,
                   help=f"UDP port the launcher (as GCS) listens on; default {SIM_PORTS['--gcs-port'][0]}, "
                   "or a free one if that is taken (e.g. by QGroundControl)")
    p.add_argument("--zenoh-port", type=o.port, default=None,
                   help=f"TCP port of the zenoh router; default {SIM_PORTS['--zenoh-port'][0]}, "
                   "or a free one if that is taken")
    p.add_argument("--companion", nargs="?", const="rc", choices=("rc", "servo"), default=None,
                   help="fly with `wavekeep companion` (method rc or servo) through the firmware as a stand-in "
                        "ArduSub (docs/companion.md)")
    p.add_argument("--companion-port", type=o.port, default=14770, help="UDP port of the companion's MAVLink")
    p.add_argument("--autopilot", default=None, metavar="ardusub:PATH",
                   help="fly the real ArduSub SITL binary at PATH instead of Wavekeep's firmware (its own hold, or "
                        "the companion's with --companion; docs/ardusub.md)")
    p.add_argument("--ardusub-mode", choices=("guided", "alt_hold", "poshold"), default="guided",
                   help="--autopilot without --companion: ArduSub's mode for the mission (after a GUIDED dive)")
    p.add_argument("--ardusub-set", action="append", default=None, metavar="NAME=VALUE",
                   help="--autopilot: an ArduSub parameter to set before arming (repeatable), e.g. "
                        "SIM_BAR2_RND=0.01 (a Bar30's noise, not SITL's 0.2 m)")
    p.add_argument("--no-plots", action="store_true", help="skip time_history.png")
    view.add_record_options(p, live=True)
    o.add_out(p, required=False, default=None,
              what="run folder; default: runs/sim-CASE-CONTROLLER, with the forecast error, seed and duration "
              "when given (e.g. runs/sim-W1-cpd_ff-60s)")
    p.set_defaults(func=cmd_sim)

    sub.add_parser("plant", help="the plant as an ArduPilot JSON SITL physics server (see wavekeep plant -h)",
                   add_help=False)
    sub.add_parser("firmware", help="the firmware as its own process (see wavekeep firmware -h)", add_help=False)
    sub.add_parser("companion", help="the control task on a companion computer beside a real ArduSub, over "
                   "MAVLink (see wavekeep companion -h, docs/companion.md)", add_help=False)


SIM_PORTS = {"--plant-port": (9002, socket.SOCK_DGRAM, "plant"), "--gcs-port": (14550, socket.SOCK_DGRAM, "GCS"),
             "--zenoh-port": (7447, socket.SOCK_STREAM, "zenoh")}
"""``wavekeep sim``'s loopback ports: option → (default, socket kind, what uses it)."""


def _given_ports(args: argparse.Namespace) -> dict[str, int | None]:
    """The port options as given (None where left out), by option name."""
    return {name: getattr(args, name[2:].replace("-", "_")) for name in SIM_PORTS}


def _sim_ports(args: argparse.Namespace) -> dict[str, int]:
    """The ports given, and for each left out its default, or a free port (said on stderr) if that is taken,
    by another program or by a port given for another process."""
    from ..ports import free_port, port_or_free

    given = _given_ports(args)
    used = {port for port in given.values() if port is not None}
    ports = {}
    for name, (default, kind, what) in SIM_PORTS.items():
        port = given[name]
        if port is None:
            port = port_or_free(default, kind)
            while port in used:
                port = free_port(kind)
            used.add(port)
            if port != default:
                print(f"wavekeep sim: port {default} ({what}) is taken; using {port} ({name})", file=sys.stderr)
        ports[name] = port
    return ports


def default_out(args: argparse.Namespace) -> str:
    """``sim``'s folder when no --out is given, named after the options that change the run: ``runs/sim-W1-cpd_ff``,
    then ``-15dB`` / ``-dswp``, ``-seed7``, ``-60s``, ``-companion-rc`` when given (so two different runs never share
    a folder); ``-ardusub-MODE`` (its own hold) or ``-ardusub`` (under the companion) with --autopilot."""
    parts = ["sim", Path(args.case).stem if args.case.endswith((".yaml", ".yml")) else args.case, args.controller]
    if args.forecast_snr_db is not None:
        parts.append(f"{args.forecast_snr_db:g}dB")
    if args.forecast != "oracle" and args.controller.startswith("cpd_ff"):
        parts.append(args.forecast)
    if args.seed is not None:
        parts.append(f"seed{args.seed}")
    if args.duration is not None:
        parts.append(f"{args.duration:g}s")
    if args.companion:
        parts.append(f"companion-{args.companion}")
    if args.autopilot:
        parts.append("ardusub" if args.companion else f"ardusub-{args.ardusub_mode}")
    return str(Path("runs") / "-".join(parts))


def cmd_sim(args: argparse.Namespace) -> int:
    """The plant, the forecast service and the firmware as processes; the launcher flies them as a GCS."""
    from ..launcher import LaunchError, SimOptions

    given = _given_ports(args)
    names = [name for name, port in given.items() if port is not None]
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            if given[a] == given[b]:
                raise o.UsageError(f"{a} and {b} are both {given[a]}: each process needs its own port")
    spec = o.run_spec(args)
    if set(spec.dswp) - {"deep_water"}:
        raise o.UsageError(f"--dswp-set {', '.join(sorted(set(spec.dswp) - {'deep_water'}))}: the forecast service "
                           "takes only deep_water; the other DSWP options are for `wavekeep run`")
    binary = None
    ardusub_params = _ardusub_params(args.ardusub_set, args.autopilot)
    if args.autopilot is not None:
        from ..ardusub import parse_autopilot
        try:
            binary = parse_autopilot(args.autopilot)
        except ValueError as exc:
            raise o.UsageError(str(exc)) from None
    if args.out is None:
        args.out = default_out(args)
    o.check_configs(args, spec)
    view.require_view(args)
    out = o.check_out(args.out, force=args.force)
    ports = _sim_ports(args)      # after every check: a refused command says one line, whatever holds the ports
    live = view.SimView(args, spec) if args.view else None
    try:
        opt = SimOptions(spec, speedup=args.speedup, out=str(out), plant_port=ports["--plant-port"],
                         gcs_port=ports["--gcs-port"], zenoh_port=ports["--zenoh-port"], plots=not args.no_plots,
                         downlink_tap=live.tap if live else None)
        try:
            r = _fly_sim(args, opt, binary, ardusub_params)
        except LaunchError as exc:
            print(f"wavekeep sim: {exc}", file=sys.stderr)
            return exc.status
        finally:
            if live:
                live.close()
        _report_sim(args, out, spec, r, live)
    finally:
        if live:
            live.stop()
    return 0


def _fly_sim(args: argparse.Namespace, opt, binary: Path | None, ardusub_params: dict[str, float]) -> dict:
    """The mission with what flies it: Wavekeep's firmware, the companion on the stand-in or on the real
    ArduSub, or the real ArduSub's own hold."""
    if args.companion and binary is not None:
        from ..ardusub_companion import launch_ardusub_companion
        return launch_ardusub_companion(opt, binary, args.companion, args.companion_port, progress=None,
                                        params=ardusub_params)
    if args.companion:
        from ..companion_launch import launch_companion
        return launch_companion(opt, args.companion, args.companion_port, progress=None)
    if binary is not None:
        from ..ardusub_launch import launch_ardusub
        return launch_ardusub(opt, binary, args.ardusub_mode, progress=None, params=ardusub_params)
    from ..launcher import launch
    return launch(opt, progress=None)


def _report_sim(args: argparse.Namespace, out, spec, r: dict, live) -> None:
    """What ``sim`` prints and writes after its mission: run.json, the table, the recording."""
    from ..metrics import format_six_dof, format_table
    from ..provenance import write_run_record
    from ..results import lapse_lines

    write_run_record(out, args.argv, spec, seed=r["seed"])
    print(f"{r['case']} {r['label']} across processes, seed {r['seed']}, {r['duration_s']:g} s: "
          f"{r['wall_time_s']:.1f} s wall ({r['speed_x_realtime']:.0f}x real time), {r['tick_overruns']} tick overruns")
    print(format_table({r["label"]: r}))
    if "six_dof" in r:
        print(format_six_dof(r["six_dof"]))
    for line in lapse_lines(r):
        print(line)
    print(f"wrote {out}: results.json, timeseries.csv" + ("" if args.no_plots else ", time_history.png")
          + ", mission.tlog, *.log, run.json")
    view.record(args, out, spec, r["seed"], grpc_url=live.server.grpc_url if live else None)
    if live:
        live.linger()


def _ardusub_params(items: list[str] | None, autopilot: str | None) -> dict[str, float]:
    """``--ardusub-set NAME=VALUE`` items as NAME → number (only with ``--autopilot``)."""
    if items and autopilot is None:
        raise o.UsageError("--ardusub-set applies only with --autopilot ardusub:PATH")
    from firmware_py.params.table import parse_assignment

    out: dict[str, float] = {}
    for item in items or []:
        try:
            name, value = parse_assignment(item)
        except ValueError as exc:
            raise o.UsageError(f"--ardusub-set {exc}") from None
        if not math.isfinite(value):
            raise o.UsageError(f"--ardusub-set {item}: expected NAME=NUMBER, a finite number")
        out[name.upper()] = value
    return out


def cmd_forecast(args: argparse.Namespace) -> int:
    """The forecast service (shore side) on zenoh, until Ctrl-C / SIGTERM."""
    import signal
    import threading
    from dataclasses import replace

    import numpy as np

    from bridge.forecast import derive_seeds, oracle_forecast
    from bridge.forecast_service import ForecastService
    from bridge.schemas import load_mission_config
    from bridge.zenoh_net import load_network_config, open_session
    from sitl.sea import Sea

    if args.forecast_snr_db is not None and args.forecast != "oracle":
        raise o.UsageError("--forecast-snr-db applies only to --forecast oracle")
    net = load_network_config(args.network)
    site = args.site or net["site"]
    sea = Sea.load(args.case, seed=args.seed, overrides=o.world_options(args)["sea"])
    oracle = None
    if args.forecast == "oracle":
        _, forecast_seed = derive_seeds(sea.seed)
        oracle = oracle_forecast(sea.components, args.forecast_snr_db, np.random.default_rng(forecast_seed))
        if args.sea_start:
            # phases referred to the sea's t = 0, which is the vehicle's sea_start: the same components, later
            oracle = replace(oracle, time_base=oracle.time_base + args.sea_start)
    x_vehicle = load_mission_config(args.mission)["setpoint"]["x"]
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    with open_session(net, "service") as session:
        svc = ForecastService(session, site, args.forecast, oracle=oracle, x_vehicle=x_vehicle,
                              water_depth=sea.water_depth, rate_hz=args.rate, horizon_s=args.horizon,
                              deep_water=args.deep_water)
        print(f"wavekeep forecast: ready, site {site}, mode {args.forecast}"
              + (f" ({args.forecast_snr_db:g} dB error)" if args.forecast_snr_db is not None else ""), flush=True)
        try:
            svc.run(stop)
        finally:
            svc.close()
    print(f"wavekeep forecast: stopped; {svc.counters}", flush=True)
    return 0
