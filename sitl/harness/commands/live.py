"""``wavekeep live`` (the vehicle flying on the wall clock, for a ground station) and ``thrust`` (a client for it)."""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from . import options as o
from . import view

DEFAULT_GCS = "udpout:127.0.0.1:14550"


def add_parsers(sub) -> None:
    p = sub.add_parser("live", help="fly the vehicle live in one process with its MAVLink link (for a GCS)",
                       description="Fly the vehicle live in one process with its MAVLink link, until Ctrl-C or "
                       "--duration; prints the firmware's mode, arming and failsafe events as they happen and the "
                       "results table at the end.")
    o.add_common(p)
    o.add_controller(p)
    p.add_argument("--mavlink", action="append", default=None, metavar="ENDPOINT",
                   help=f"MAVLink endpoint (repeatable): udpout:HOST:PORT, udpin:HOST:PORT, tcp:..., tcpin:...; "
                   f"default {DEFAULT_GCS}")
    p.add_argument("--speedup", type=o.positive, default=1.0, help="simulated seconds per wall-clock second")
    p.add_argument("--duration", type=o.duration, default=None,
                   help="stop after this much simulated time (s); default: until Ctrl-C")
    p.add_argument("--signing-key", default=None, help="file with a 32-byte MAVLink 2 signing key")
    p.add_argument("--log", default=None, metavar="FILE",
                   help="where to write the events and the results table (default: runs/live-<UTC time>.log)")
    view.add_record_options(p, live=True)
    p.set_defaults(func=cmd_live)

    p = sub.add_parser("thrust", help="stream thrust demands to a vehicle at 20 Hz (bench tests)",
                       description="Stream thrust demands (MANUAL_CONTROL sticks) to a vehicle over MAVLink at "
                       "20 Hz: a pattern on one axis, or a CSV profile.")
    p.add_argument("--mavlink", default="udpin:127.0.0.1:14550",
                   help="where to meet the vehicle (ground-station side endpoint)")
    p.add_argument("--csv", default=None, help="CSV of t (s), surge, heave, pitch demands (in --units)")
    p.add_argument("--pattern", choices=("zero", "step", "square", "sine", "sweep"), default="step",
                   help="demand pattern on --axis (without --csv)")
    p.add_argument("--axis", choices=("surge", "heave", "pitch"), default="surge", help="axis the pattern drives")
    p.add_argument("--amplitude", type=float, default=0.2,
                   help="pattern amplitude: stick in [-1, 1] (normalised) or N / N m (si)")
    p.add_argument("--period", type=o.positive, default=4.0, help="pattern period (s), for square and sine")
    p.add_argument("--duration", type=o.duration, default=10.0, help="pattern length (s)")
    p.add_argument("--units", choices=("normalised", "si"), default="normalised",
                   help="normalised sticks in [-1, 1], or N / N m scaled by the vehicle's WK_TAU_MAX_*")
    p.add_argument("--arm", action="store_true", help="switch the vehicle to MANUAL and arm it first")
    p.set_defaults(func=cmd_live_thrust)


def cmd_live(args: argparse.Namespace) -> int:
    """The vehicle flying live in one process, with its MAVLink link, until Ctrl-C or --duration."""
    from ..live import LiveSim

    endpoints = [o.endpoint(e, bind=True) for e in (args.mavlink or [DEFAULT_GCS])]
    spec = o.run_spec(args)
    key = None
    if args.signing_key:
        from firmware_py.mavlink import load_signing_key
        try:
            key = load_signing_key(args.signing_key)
        except (OSError, ValueError) as exc:
            raise o.UsageError(f"--signing-key {args.signing_key}: {exc}") from None
    o.check_configs(args, spec)     # a bad config is refused before the log is created
    log_path = Path(args.log or f"runs/live-{time.strftime('%Y%m%d-%H%M%S', time.gmtime())}.log")
    try:
        log_path.parent.mkdir(parents=True, exist_ok=True)
        log = log_path.open("a", encoding="utf-8")
    except OSError as exc:
        raise o.UsageError(f"--log {log_path}: cannot write ({exc.strerror})") from None
    t0 = time.monotonic()

    def say(line: str) -> None:
        print(line, flush=True)
        log.write(line + "\n")
        log.flush()

    view.require_view(args)
    recorder: list = []    # the live recording, once the vehicle is built (events before it are not drawn)

    def event(severity: int, text: str) -> None:
        say(f"[{time.monotonic() - t0:7.1f} s] {text}")
        if recorder:
            recorder[0].event(sim.setup.plant.state.t, severity, text)

    server = None
    try:
        sim = LiveSim(spec, mavlink=endpoints, speedup=args.speedup, signing_key=key, on_event=event,
                      duration=args.duration)
        if args.view or not args.no_record:
            server = view.live_recording(args, sim, spec, log_path, recorder, say)
        say(f"Wavekeep live: {args.case}, {spec.label}, MAVLink on {', '.join(endpoints)}, speed-up "
            f"{args.speedup:g}. Disarmed in MANUAL; arm and pick a mode from your ground station. Ctrl-C stops. "
            f"Log: {log_path}")
        interrupted = _fly(sim, spec.label, say)
    finally:
        if recorder:
            recorder[0].close()
            if not args.no_record:
                say(f"wrote {log_path.with_suffix('.rrd')}: the 3-D view of the flight "
                    f"(wavekeep view {log_path.with_suffix('.rrd')})")
        if server is not None:
            server.stop()
        log.close()
    return 130 if interrupted else 0


def _fly(sim, label: str, say) -> bool:
    """Run ``sim`` until Ctrl-C or its duration (simulated time); then report the ticks, the time per mode and,
    over the time the controller held station, the results table through ``say``. True if Ctrl-C stopped it."""
    from ..live import MIN_HELD_S
    from ..metrics import format_table

    interrupted = False
    with sim:
        try:
            while not sim.done.wait(0.2):
                pass
        except KeyboardInterrupt:
            interrupted = True
            print("stopping (Ctrl-C)", file=sys.stderr)
    stats = sim.firmware.scheduler.stats()
    say(f"stopped after {stats['ticks']} ticks ({stats['overruns']} overruns)" + (" on Ctrl-C" if interrupted else ""))
    s = sim.summary(label)
    say(f"flown {s['flown_s']:.1f} s: " + ", ".join(f"{m} {t:.1f} s" for m, t in s["time_s"].items()))
    if s["metrics"] is None:
        say(f"held station (armed in GUIDED or POSHOLD) for {s['held_s']:.1f} s, under {MIN_HELD_S:g} s: "
            "no errors or power to report")
    else:
        say(f"over the {s['held_s']:.1f} s the controller held station (errors against its target, power from "
            "the thrusters' actual load):")
        say(format_table({s["label"]: s["metrics"]}))
    return interrupted


def cmd_live_thrust(args: argparse.Namespace) -> int:
    """Stream thrust demands to a vehicle over MAVLink at 20 Hz."""
    from ..thrust import csv_profile, pattern_profile, stream_thrust

    o.endpoint(args.mavlink, bind=True)
    if args.units == "normalised" and not -1.0 <= args.amplitude <= 1.0:
        raise o.UsageError(f"--amplitude {args.amplitude:g}: sticks are in [-1, 1] with --units normalised "
                           "(use --units si for N / N m)")
    if args.csv:
        if not Path(args.csv).is_file():
            raise o.UsageError(f"--csv {args.csv}: no such file")
        try:
            profile = csv_profile(args.csv)
        except ValueError as exc:
            raise o.UsageError(f"--csv {exc}") from None
        if args.units == "normalised" and abs(profile.demand).max(initial=0.0) > 1.0:
            raise o.UsageError(f"--csv {args.csv}: demands beyond [-1, 1] with --units normalised")
    else:
        profile = pattern_profile(args.pattern, args.axis, args.amplitude, args.duration, args.period)
    out = stream_thrust(args.mavlink, profile, units=args.units, arm=args.arm)
    print(f"sent {out['messages']} messages in {out['ticks']} ticks over {out['duration_s']:.1f} s"
)
    return 0
