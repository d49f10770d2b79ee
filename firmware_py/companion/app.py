"""``wavekeep companion``: the Wavekeep control task on a companion computer, flying through ArduSub.

    wavekeep companion --autopilot udpin:127.0.0.1:14770 [--forecast zenoh] [--method rc|servo]

On a BlueROV2 the autopilot endpoint is BlueOS's MAVLink router (add a UDP
client endpoint to this computer's port, e.g. ``udpin:0.0.0.0:14770``); the
default binds loopback only. Start-up: the autopilot's identity (a Sub running
ArduPilot at ``--target-system``, FRAME_CONFIG 2 — the Heavy), the method's
parameters (servo: SERVO1-8_FUNCTION = RCIN9-16), the stream rates
(SET_MESSAGE_INTERVAL: ATTITUDE, SCALED_PRESSURE2, LOCAL_POSITION_NED and
HEARTBEAT at the loop rate), the clock (TIMESYNC; or the stand-in's lockstep
markers with ``--lockstep``), the forecast; then "ready" and the 20 Hz loop
until SIGINT/SIGTERM, which releases the overrides. Exit status 3: the vehicle
was refused. See ``docs/companion.md``.
"""
from __future__ import annotations

import argparse
import json
import math
import signal
import sys
import threading
import time
from pathlib import Path

from ..app import parse_set_arg

__all__ = ["build_parser", "check_vehicle", "companion_overrides", "main", "run"]

STREAMS = ("ATTITUDE", "SCALED_PRESSURE2", "LOCAL_POSITION_NED", "RAW_IMU", "HEARTBEAT")


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="wavekeep companion", description=__doc__.split("\n")[0].replace("``", ""))
    p.add_argument("--autopilot", default="udpin:127.0.0.1:14770",
                   help="MAVLink endpoint of the autopilot (a real vehicle: the BlueOS router's, e.g. "
                        "udpin:0.0.0.0:14770)")
    p.add_argument("--method", choices=("rc", "servo"), default="rc")
    p.add_argument("--forecast", choices=("none", "zenoh"), default="none",
                   help="zenoh: the wave feed-forward from the forecast service; none: C-PD only")
    p.add_argument("--stick-model", choices=("auto", "ardusub", "wavekeep"), default="auto",
                   help="rc: how the autopilot turns sticks into thrust (auto: wavekeep if it has WK_TAU_MAX_X)")
    p.add_argument("--target-system", type=int, default=1)
    p.add_argument("--sysid", type=int, default=255, help="our system id: the autopilot's MAV_GCS_SYSID")
    p.add_argument("--compid", type=int, default=191, help="our component id (MAV_COMP_ID_ONBOARD_COMPUTER)")
    p.add_argument("--lockstep", action="store_true", help="SITL: tick on the stand-in's LOCKSTEP markers")
    p.add_argument("--clock", choices=("telemetry", "timesync"), default="telemetry",
                   help="telemetry: a tick starts when the autopilot's ATTITUDE for it arrives (the freshest "
                        "telemetry, on the autopilot's clock at any SITL speed-up); timesync: the local clock on "
                        "the autopilot's via TIMESYNC, in real time (docs/companion.md, Latency)")
    p.add_argument("--depth-noise", default="auto", metavar="M",
                   help="σ of the depth the companion reads (m); auto: SITL's SIM_BAR2_RND where the autopilot "
                        "has it (uniform noise: RND/√3), else WK_EKF_R_DEPTH (a Bar30)")
    p.add_argument("--stale", type=float, default=0.5, help="s without ATTITUDE before the overrides are released")
    p.add_argument("--surface-pressure", type=float, default=101325.0, help="Pa at the surface (depth zero)")
    p.add_argument("--water-density", type=float, default=1025.0, help="kg/m³")
    p.add_argument("--set", type=parse_set_arg, action="append", default=[], help="parameter override NAME=VALUE")
    p.add_argument("--params", default="params")
    p.add_argument("--vehicle", default="bluerov2_heavy")
    p.add_argument("--mission", default="station_keeping", help="the station (its setpoint) and the loop rate")
    p.add_argument("--network", default="network")
    p.add_argument("--site", default=None)
    p.add_argument("--identity-timeout", type=float, default=10.0)
    p.add_argument("--log", default=None, help="tick log CSV (t + TICK_COLUMNS) and statistics JSON beside it")
    return p


def check_vehicle(link, method: str, timeout: float = 10.0) -> None:
    """Refuse a vehicle that is not a BlueROV2 Heavy on ArduSub, or whose outputs the method cannot use."""
    from .autopilot import VehicleIdentityError
    from .commander import MOTOR_FUNCTIONS, PASSTHROUGH_FUNCTIONS, set_output_functions
    link.wait_vehicle(timeout)
    frame = link.read_param("FRAME_CONFIG")
    if frame is None or int(frame) != 2:
        raise VehicleIdentityError(f"FRAME_CONFIG is {frame}: this companion flies a BlueROV2 Heavy "
                                   "(2, Vectored-6DOF)")
    if method == "servo":
        functions = [link.read_param(f"SERVO{n}_FUNCTION") for n in range(1, 9)]
        for n, f in enumerate(functions, 1):
            if f is None or int(f) not in (MOTOR_FUNCTIONS[n - 1], PASSTHROUGH_FUNCTIONS[n - 1]):
                raise VehicleIdentityError(f"servo method: SERVO{n}_FUNCTION is {f}, must be {32 + n} (motor {n}) "
                                           f"or {58 + n} (RCIN{8 + n}); see docs/companion.md")
        if any(int(f) != m for f, m in zip(functions, MOTOR_FUNCTIONS, strict=True)):
            # left as pass-through (an earlier companion that died engaged): the pilot's thrusters first
            set_output_functions(link, MOTOR_FUNCTIONS)
            print("wavekeep companion: SERVO1-8_FUNCTION were pass-through: restored to motors 1-8", flush=True)


def _stick_model(args, link, params) -> tuple[str, tuple[float, float, float]]:
    names = ("WK_TAU_MAX_X", "WK_TAU_MAX_Z", "WK_TAU_MAX_P")
    if args.method == "servo":
        return "none", params.axes("WK_TAU_MAX")
    if args.stick_model in ("auto", "wavekeep"):
        vals = [link.read_param(n, 2.0) for n in names]
        if all(v is not None for v in vals):
            return "wavekeep", tuple(vals)
        if args.stick_model == "wavekeep":
            raise RuntimeError("--stick-model wavekeep: the autopilot has no WK_TAU_MAX_* parameters")
    return "ardusub", params.axes("WK_TAU_MAX")


def _request_streams(link, rate: float) -> None:
    from .autopilot import mavlink
    for name in STREAMS:
        result = link.set_message_interval(getattr(mavlink, f"MAVLINK_MSG_ID_{name}"), rate)
        if result != 0:
            print(f"wavekeep companion: {name} at {rate:g} Hz: MAV_RESULT {result}", flush=True)


def _timesync_offset(link, tries: int = 5) -> int:
    """Autopilot clock − local monotonic clock (ns) from TIMESYNC; the best of a few round trips."""
    best: tuple[int, int] | None = None
    for _ in range(tries):
        link.state.rtt_ns = None
        link.timesync()
        end = time.monotonic() + 0.5
        while link.state.rtt_ns is None and time.monotonic() < end:
            link.pump(0.02)
        if link.state.rtt_ns is not None and (best is None or link.state.rtt_ns < best[0]):
            best = (link.state.rtt_ns, link.state.offset_ns or 0)
    if best is None:
        att = link.state.samples.get("ATTITUDE")
        if att is None:
            raise RuntimeError("no TIMESYNC answer and no ATTITUDE: cannot find the autopilot's clock")
        return att.t_ms * 1_000_000 - int(att.arrived * 1e9)
    return best[1]


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    from .autopilot import AutopilotLink, VehicleIdentityError
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    link = AutopilotLink(args.autopilot, args.target_system, args.sysid, args.compid)
    try:
        check_vehicle(link, args.method, args.identity_timeout)
    except VehicleIdentityError as exc:
        print(f"wavekeep companion: refused: {exc}", file=sys.stderr, flush=True)
        link.statustext(3, "WK: companion refused this vehicle")
        link.close()
        return 3
    try:
        return run(args, link, stop)
    finally:
        link.close()


def companion_overrides(method: str, ff: bool) -> dict[str, float]:
    """The parameters the companion runs with, whatever the parameter file says."""
    # WK_EKF_MODE 0: the autopilot's telemetry carries no DVL or raw accelerometer stream for the aided EKF.
    # WK_OUT_DELAY 1: the stand-in applies a command at its next tick; real ArduSub within ~8 ms of the
    # telemetry's stamp, but that telemetry is itself ~26 ms behind the vehicle: ~0.7 tick (docs/companion.md)
    overrides = {"WK_FF_ENABLE": 1.0 if ff else 0.0, "FS_GCS_ENABLE": 0.0, "WK_OUT_DELAY": 1.0,
                 "FS_EKF_ACTION": 0.0, "WK_EKF_MODE": 0.0}
    if method == "rc":
        # ArduSub's mixer does not compensate motor lag: the companion does, and keeps the boosted command
        # within what the sticks reach (±WK_THR_MAX a thruster), pitch first, so the autopilot never clips it
        overrides["WK_MOT_LIM"] = 1.0
    return overrides


def _build(args, link, stop):
    """Parameters, commander, clock, HAL and the Firmware (the same control task as on the vehicle)."""
    from bridge.models.thrusters import T200Curve, ThrusterLayout
    from bridge.schemas import load_mission_config, load_vehicle_config

    from ..firmware import Firmware
    from ..params.table import load_params
    from .commander import Commander
    from .hal_mavlink import AutopilotClock, LockstepMarkerClock, MAVLinkAutopilotHAL, TelemetryClock, attitude_stamp
    depth_noise = _depth_noise(args, link)
    fixed = {**companion_overrides(args.method, args.forecast == "zenoh"), **dict(args.set)}
    params = load_params(args.params, fixed)
    if depth_noise is not None and "WK_EKF_R_DEPTH" not in dict(args.set):
        params.set("WK_EKF_R_DEPTH", max(depth_noise, params["WK_EKF_R_DEPTH"]))
    vcfg, mcfg = load_vehicle_config(args.vehicle), load_mission_config(args.mission)
    layout, curve = ThrusterLayout.from_config(vcfg["thrusters"]), T200Curve.from_config(vcfg["thrusters"])
    model, tau_max = _stick_model(args, link, params)
    commander = Commander(link, args.method, model, curve, layout.allocation_matrix(), tau_max, args.stale)
    rate = mcfg["control_rate"]
    _request_streams(link, rate)
    if args.lockstep:
        clock = LockstepMarkerClock(link, commander.watchdog, stop.is_set)
    elif args.clock == "telemetry":
        clock = TelemetryClock(link, commander.watchdog, stop.is_set, attitude_stamp(link), 500_000_000 // int(rate))
    else:
        clock = AutopilotClock(link, commander.watchdog, _timesync_offset(link))
    hal = MAVLinkAutopilotHAL(link, commander, clock, args.stale, args.surface_pressure, args.water_density)
    fw = Firmware.from_configs(hal, params, vcfg, mcfg)
    commander.fw = fw
    timing = ("lockstep" if args.lockstep else "ticks on the autopilot's ATTITUDE" if args.clock == "telemetry"
              else "real time (TIMESYNC offset %.3f s)" % (clock.offset_ns * 1e-9))
    print(f"wavekeep companion: {args.method} method, stick model {model}, {timing}, "
          f"WK_OUT_DELAY {params['WK_OUT_DELAY']:g}, depth σ {params['WK_EKF_R_DEPTH']:g} m", flush=True)
    return fw, commander, clock, rate


def _depth_noise(args, link) -> float | None:
    """σ (m) of the depth reading the companion fuses (``--depth-noise``), or None to keep WK_EKF_R_DEPTH."""
    if args.depth_noise != "auto":
        try:
            sigma = float(args.depth_noise)
        except ValueError:
            raise SystemExit(f"wavekeep companion: --depth-noise {args.depth_noise}: not a number") from None
        if not (math.isfinite(sigma) and sigma > 0):
            raise SystemExit(f"wavekeep companion: --depth-noise {args.depth_noise}: must be positive")
        return sigma
    rnd = link.read_param("SIM_BAR2_RND", 2.0)      # SITL only: SCALED_PRESSURE2's noise, uniform in ±RND m
    return None if rnd is None or rnd <= 0 else rnd / math.sqrt(3.0)


def run(args, link, stop, attach=None) -> int:
    """Fly until ``stop`` is set: build the control task on ``link`` (a vehicle :func:`check_vehicle` accepted),
    wait for the first forecast (``--forecast zenoh``), then the 20 Hz loop; release on the way out.

    ``attach(fw, commander)``, when given, is called once both are built (before the forecast wait) and returns
    the tasks (``Task``) to run each tick just before the commander's gate: how a host (the BlueOS extension)
    watches and steers the companion from the scheduler's own thread."""
    from ..firmware import tick_row
    from ..hal.scheduler import Task, settle_for_loop
    from .hal_mavlink import AutopilotClock
    fw, commander, clock, rate = _build(args, link, stop)
    extra = list(attach(fw, commander)) if attach is not None else []
    rows: list[list[float]] = []
    if args.log:
        fw.on_tick = lambda r: rows.append([r.t, *tick_row(r)])
    session = forecast_link = None
    if args.forecast == "zenoh":
        session, forecast_link = _open_forecast(args, fw)
        _wait_forecast(fw, forecast_link, link, stop)
    last_hb = [0.0]

    def after(_slot_ns: int) -> None:
        if args.lockstep:
            link.lockstep_answer(link.state.marker_ms)
        if time.monotonic() - last_hb[0] >= 1.0:
            last_hb[0] = time.monotonic()
            link.heartbeat()
    fw.tasks.insert(0, Task("gate", rate, commander.gate))
    fw.tasks[0:0] = extra
    if forecast_link is not None:
        fw.tasks.insert(0, Task("forecast", rate, forecast_link.poll))
    fw.tasks.append(Task("companion", rate, after))
    settle_for_loop(realtime=not args.lockstep)     # beside a real autopilot, on its real-time clock
    print("wavekeep companion: ready", flush=True)
    try:
        if not isinstance(clock, AutopilotClock):
            clock.sleep_until(0)      # the first marker (the stand-in's first tick) or ATTITUDE
            while clock.stamp_ms() < 0 and not stop.is_set():
                link.pump(0.05)
        fw.rebuild_scheduler(t0_ns=clock.now_ns())
        fw.scheduler.run(stop=stop.is_set)
    finally:
        commander.release("companion exiting")
        _close(forecast_link, session)
        _write_stats(args, fw, commander, link, rows)
    return 0


FORECAST_WAIT_SAY_S = 10.0
"""s of wall time between the STATUSTEXTs that say the companion is still waiting for its first forecast."""


def _wait_forecast(fw, forecast_link, link, stop) -> None:
    """Until the first forecast arrives (or ``stop``): nothing engages meanwhile, and the pilot's ground station
    is told why every :data:`FORECAST_WAIT_SAY_S` (a forecast link that never comes is a missing link)."""
    said = -math.inf
    while fw.forecast.newest() is None and not stop.is_set():
        if time.monotonic() - said >= FORECAST_WAIT_SAY_S:
            said = time.monotonic()
            link.statustext(4, "WK: no wave forecast yet: not engaging")
            print("wavekeep companion: waiting for the wave forecast", flush=True)
        forecast_link.poll()
        link.pump(0.05)


def _open_forecast(args, fw):
    from bridge.zenoh_net import load_network_config, open_session

    from ..forecast.link import ZenohForecastLink
    net = load_network_config(args.network)
    session = open_session(net, "vehicle")
    return session, ZenohForecastLink(session, args.site or net["site"], fw.forecast, fw.say)


def _close(*things) -> None:
    for thing in things:
        if thing is not None:
            (getattr(thing, "stop", None) or thing.close)()


def _write_stats(args, fw, commander, link, rows) -> None:
    import numpy as np
    lat = np.array(commander.latency_s) * 1e3
    stats = {**fw.scheduler.stats(), "faults": fw.fault_counts(), "link": link.counters,
             "telemetry_to_command_ms": ({"p50": float(np.percentile(lat, 50)), "p99": float(np.percentile(lat, 99)),
                                          "n": int(lat.size)} if lat.size else None),
             "events": [text for _t, text in commander.events]}
    print(f"wavekeep companion: stopped after {stats['ticks']} ticks; {stats['telemetry_to_command_ms']}", flush=True)
    if args.log:
        from bridge.logfile import save_csv_whole

        from ..firmware import TICK_COLUMNS
        Path(args.log).with_suffix(".json").write_text(json.dumps(stats, indent=2, default=str))
        save_csv_whole(args.log, np.array(rows).reshape(-1, len(TICK_COLUMNS) + 1), ",".join(["t", *TICK_COLUMNS]))
        # per command: the ATTITUDE time it answered (ms, the autopilot's clock) and the wall latency (ms)
        sent = np.array(commander.sent, dtype=float).reshape(len(commander.answered_ms), -1)
        header = ",".join(["attitude_ms", "latency_ms"] + [f"ch{i}" for i in range(sent.shape[1])])
        save_csv_whole(Path(args.log).with_suffix(".commands.csv"), np.c_[commander.answered_ms, lat, sent], header,
                       fmt="%.6g")


if __name__ == "__main__":
    sys.exit(main())
