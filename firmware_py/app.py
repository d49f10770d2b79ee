"""``wavekeep firmware``: the firmware as its own process, flying a vehicle through a networked HAL.

    wavekeep firmware --hal sitl:127.0.0.1:9002 --mavlink udpout:127.0.0.1:14550 [--speedup X]

Start-up, in order: parameters (``configs/firmware/params.yaml`` plus
``--set NAME=VALUE``), the HAL (waits for the plant's first state), the
MAVLink link, the forecast subscriber (zenoh, unless ``--no-forecast``); then
the first control tick (the estimator initialises), a garbage collection and
``gc.freeze()`` (docs/platform-notes.md: a full collection would cost more than a tick), and
the 20 Hz loop until SIGINT/SIGTERM, under SCHED_FIFO where the OS permits it
(paced runs; docs/platform-notes.md: start error p99 ≈ 15 µs even with both cores loaded).

``--hold-until-armed`` keeps simulated time still after the first tick until a
ground station has armed the vehicle, so a scripted start (the launcher's) is
the same at every speed-up: the mission's clock starts when the vehicle is
armed, as in the in-process runner.

Time: the loop runs in lockstep with the plant — each tick is one plant step —
as fast as the plant answers (``--speedup 0``), or, with ``--speedup X``, paced at X times real
time on the wall clock. With no ``--speedup``, a run given ``--mavlink`` explicitly (a person's
ground station on the other end) runs in real time (``--speedup 1``), and one without runs
unpaced; the launcher always says which it wants (:class:`~firmware_py.hal.scheduler.LockstepPacedClock`: a
slow tick makes the run fall behind, never skips a step).
"""
from __future__ import annotations

import argparse
import os
import signal
import sys
import threading
import time

from .params.table import parse_assignment

__all__ = ["main"]


def _parse_hal(text: str) -> tuple[str, int]:
    kind, _, rest = text.partition(":")
    host, _, port = rest.rpartition(":")
    if kind != "sitl" or not host or not port.isdigit():
        raise argparse.ArgumentTypeError(f"--hal must look like sitl:HOST:PORT, got {text!r}")
    return host, int(port)


def parse_set_arg(text: str) -> tuple[str, float]:
    """argparse type of ``--set NAME=NUMBER``."""
    try:
        return parse_assignment(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"--set {exc}") from None


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="wavekeep firmware", description=__doc__.split("\n")[0].replace("``", ""))
    p.add_argument("--hal", type=_parse_hal, default=("127.0.0.1", 9002), help="sitl:HOST:PORT of the physics server")
    p.add_argument("--mavlink", action="append", help="MAVLink endpoint (repeatable); default udpout:127.0.0.1:14550")
    p.add_argument("--speedup", type=float, default=None,
                   help="pace at X times real time; 0: lockstep, unpaced. Default: 1 (real time) when --mavlink "
                        "is given (a ground station is flying it), else 0")
    p.add_argument("--seed", type=int, default=0, help="run seed (sensor noise stream)")
    p.add_argument("--set", type=parse_set_arg, action="append", default=[], help="parameter override NAME=VALUE")
    p.add_argument("--params", default="params", help="parameter defaults (configs/firmware/NAME.yaml or a path)")
    p.add_argument("--vehicle", default="bluerov2_heavy")
    p.add_argument("--mission", default="station_keeping", help="the station the vehicle keeps (its setpoint)")
    p.add_argument("--network", default="network", help="zenoh network config (configs/network.yaml)")
    p.add_argument("--site", default=None)
    p.add_argument("--no-forecast", action="store_true", help="no zenoh forecast subscriber")
    p.add_argument("--signing-key", default=None, help="file with the 32-byte MAVLink 2 signing key")
    p.add_argument("--hal-wait", type=float, default=None, metavar="S",
                   help="wait up to S wall seconds for the plant's first state (default: the larger of 2 s and "
                        "4 x SIM_JSON_TMO); a launcher that starts the plant alongside gives it its start-up time")
    p.add_argument("--hold-until-armed", action="store_true",
                   help="keep simulated time still after the first tick until the vehicle is armed")
    p.add_argument("--realtime", choices=("auto", "on", "off"), default="auto",
                   help="SCHED_FIFO for the loop where the OS permits it (falls back quietly); "
                        "auto: on for paced runs (--speedup), off for unpaced lockstep")
    p.add_argument("--companion-lockstep", action="store_true",
                   help="SITL: wait each tick for a companion computer's answer (firmware_py/mavlink/lockstep.py)")
    p.add_argument("--log", default=None, help="write every tick (t + TICK_COLUMNS) to this CSV at exit, "
                   "and the scheduler's statistics beside it as JSON")
    return p


def _try_realtime() -> str:
    try:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(10))
        return "SCHED_FIFO"
    except (PermissionError, AttributeError, OSError):
        return "normal scheduling (SCHED_FIFO not permitted)"


def _write_log(path: str, rows: list[list[float]], stats: dict) -> None:
    import json
    from pathlib import Path

    import numpy as np

    from bridge.logfile import save_csv_whole

    from .firmware import TICK_COLUMNS
    # The statistics first: a reader that finds the tick log finds them too
    Path(path).with_suffix(".json").write_text(json.dumps(stats, indent=2, default=str))
    save_csv_whole(path, np.array(rows).reshape(-1, len(TICK_COLUMNS) + 1), ",".join(["t", *TICK_COLUMNS]))


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.speedup is None:
        args.speedup = 1.0 if args.mavlink else 0.0
    if args.speedup < 0:
        print("wavekeep firmware: --speedup must be >= 0", file=sys.stderr)
        return 2
    from bridge.configfile import ConfigError
    from bridge.forecast import derive_seeds
    from bridge.schemas import load_mission_config, load_vehicle_config

    from .firmware import Firmware
    from .hal.clocks import LockstepPacedClock
    from .hal.json_sitl import JSONSITLHAL
    from .hal.scheduler import Task, settle_for_loop
    from .mavlink import MavlinkLink, load_signing_key
    from .params.table import load_params

    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    try:
        params = load_params(args.params, dict(args.set))
        vcfg = load_vehicle_config(args.vehicle)
        mcfg = load_mission_config(args.mission)
        key = load_signing_key(args.signing_key) if args.signing_key else None
    except (ConfigError, ValueError, OSError) as exc:
        print(f"wavekeep firmware: {exc}", file=sys.stderr)
        return 2
    rate = mcfg["control_rate"]
    sensor_seed, _ = derive_seeds(args.seed)
    hal = JSONSITLHAL(args.hal, params, 1.0 / rate, sensor_seed, timeout_s=params["SIM_JSON_TMO"])
    fw = Firmware.from_configs(hal, params, vcfg, mcfg)
    rows: list[list[float]] = []
    if args.log:
        from .firmware import tick_row
        fw.on_tick = lambda r: rows.append([r.t, *tick_row(r)])
    link = MavlinkLink(fw, args.mavlink or ["udpout:127.0.0.1:14550"], signing_key=key,
                       lockstep=args.companion_lockstep)
    session, forecast_link = (None, None) if args.no_forecast else _open_forecast_link(args, fw)
    try:
        hal.start(args.hal_wait)   # after the forecast subscriber: the plant's first buoy record may make one
    except TimeoutError as exc:
        print(f"wavekeep firmware: {exc}", file=sys.stderr)
        if session is not None:
            session.close()
        return 3
    try:
        link.start()
        # First tick on simulated time: the estimator initialises from the plant's t = 0 state.
        if forecast_link is not None:
            fw.add_task(Task("forecast", rate, forecast_link.poll))
        fw.add_task(Task("gcs", rate, link.update))
        fw.scheduler.run_tick()
        want_rt = args.realtime == "on" or (args.realtime == "auto" and args.speedup)
        realtime = _try_realtime() if want_rt else "normal scheduling"
        settle_for_loop(realtime=bool(args.speedup))
        print(f"wavekeep firmware: ready, {'lockstep' if not args.speedup else f'{args.speedup:g}x real time'}, "
              f"{realtime}{', holding until armed' if args.hold_until_armed else ''}", flush=True)
        if args.hold_until_armed:
            _hold_until_armed(fw, link, forecast_link, stop)
        if args.speedup:
            # From here on, pace lockstep time against the wall clock from the next slot
            start = fw.scheduler.next_slot_ns()
            hal.clock = LockstepPacedClock(args.speedup, start_ns=start - fw.scheduler.period_ns)
            fw.rebuild_scheduler(t0_ns=start)
        fw.scheduler.run(stop=stop.is_set)
    finally:
        stats = {**fw.scheduler.stats(), "faults": fw.fault_counts(), "hal": dict(vars(hal.counters))}
        if isinstance(hal.clock, LockstepPacedClock):
            stats["paced"] = {"speedup": hal.clock.speedup, "late_slots": hal.clock.late,
                              "max_lag_ms": hal.clock.max_lag_ns / 1e6}
        for closable in (link, forecast_link, session, hal):
            _close(closable)
        if args.log:
            _write_log(args.log, rows, stats)
        print(f"wavekeep firmware: stopped after {stats['ticks']} ticks, {stats['overruns']} overruns; "
              f"link {link.counters}", flush=True)
    return 0


def _open_forecast_link(args, fw):
    """The vehicle's zenoh session and the forecast subscriber feeding the firmware's hand-off."""
    from bridge.zenoh_net import load_network_config, open_session

    from .forecast.link import ZenohForecastLink
    net = load_network_config(args.network)
    session = open_session(net, "vehicle")
    return session, ZenohForecastLink(session, args.site or net["site"], fw.forecast, fw.say)


def _close(thing) -> None:
    """Stop or close a link, session or HAL at exit (None: nothing to do)."""
    if thing is not None:
        (getattr(thing, "stop", None) or thing.close)()


def _hold_until_armed(fw, link, forecast_link, stop: threading.Event) -> None:
    """Hold simulated time still until a ground station arms the vehicle.

    The link's telemetry (heartbeat, streams) runs on wall time meanwhile, so a
    ground station can see and arm the vehicle; then the streams restart on the
    simulated clock and the forecast prediction is refreshed.
    """
    frozen = fw.scheduler.next_slot_ns() - fw.scheduler.period_ns
    wall0 = time.monotonic_ns()
    while not fw.armed and not stop.is_set():
        if forecast_link is not None:
            forecast_link.poll()
        link.update(frozen + time.monotonic_ns() - wall0)
        time.sleep(0.005)
    link.restart_streams(fw.scheduler.next_slot_ns())
    fw.refresh_prediction()


if __name__ == "__main__":
    sys.exit(main())
