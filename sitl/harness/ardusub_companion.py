"""``wavekeep sim --companion rc|servo --autopilot ardusub:PATH``: the companion flies the real ArduSub SITL.

The processes: the plant as :mod:`~sitl.harness.ardusub_launch` serves a
foreign autopilot (surface boot, six DoF, its own physics rate, still water
until the sea starts), the forecast service (C-PD+FF, on the same sea clock),
the ArduSub binary with a second MAVLink link (SERIAL1) to the companion, and
``wavekeep companion`` on it, ticking on ArduSub's ATTITUDE (no lockstep: real
ArduSub has none). The launcher is the pilot: once ArduSub has a position
estimate (it accepts GUIDED) it selects MANUAL and arms; the companion sees
that, engages, dives to the station in the still water and holds it through
the mission; the pilot disarms at the end. ArduSub runs in real time unless
``--speedup`` says otherwise: the companion's link latency is wall time, so a
speed-up stretches it in the vehicle's time. Results come from the plant's
truth on the sea's clock, with the companion's ticks joined to it.
"""
from __future__ import annotations

import contextlib
import json
import socket
from pathlib import Path

import numpy as np

from .ardusub import ArduSubProcess, load_ardusub_config
from .ardusub_launch import (
    ARDUSUB_MODES,
    RATE_HZ,
    _wait_mode,
    autopilot_results,
    boot,
    dive,
    truth_timeseries,
    world_args,
)
from .children import Child, LaunchError, check_port, interrupt_leaves_nothing, wait_ready
from .companion_launch import METHODS, companion_argv
from .launcher import SimOptions, _GroundStation, mission_processes, prepare_run, start_world
from .progress import ProgressBar
from .results import COLUMN, RunResult
from .run_files import write_run

__all__ = ["MANUAL", "join_ticks", "launch_ardusub_companion"]

MANUAL = 19
SITL_STALE_S = 2.0
"""The companion's ``--stale`` (wall s) here: a loaded two-core machine starves it for 0.5 s now and then."""


def launch_ardusub_companion(opt: SimOptions, binary: Path, method: str, companion_port: int,
                             progress=None, params: dict[str, float] | None = None) -> dict:
    """One mission with ``wavekeep companion`` flying the real ArduSub; the results document (also in DIR).
    ``params``: ArduSub parameters to set too (``--ardusub-set``), after the config's."""
    if method not in METHODS:
        raise LaunchError(f"--companion takes {' or '.join(METHODS)}, got {method!r}", 2)
    with interrupt_leaves_nothing(Path(opt.out)):
        return _launch(opt, binary, method, companion_port, progress, params)


def _launch(opt: SimOptions, binary: Path, method: str, companion_port: int, progress,
            params: dict[str, float] | None) -> dict:
    spec = opt.spec
    cfg = load_ardusub_config()
    cfg["params"].update(params or {})
    sea, _mcfg, duration, setpoint, out = prepare_run(opt)
    for port, what in ((opt.plant_port, "plant"), (opt.gcs_port, "GCS"), (companion_port, "companion")):
        check_port(port, what)
    if spec.ff:
        check_port(opt.zenoh_port, "zenoh", socket.SOCK_STREAM)
    sea_start = cfg["sea_start_s"]
    speedup = 1.0 if opt.speedup is None else opt.speedup
    statuses: dict[str, int | None] = {}
    with mission_processes(opt, out, statuses) as (gcs, children):
        cli, configs, env, netcfg = start_world(opt, sea.seed, duration, out, children, plant_args=world_args(cfg),
                                                sea_start=sea_start)
        children.append(ArduSubProcess(binary, cfg, out / "ardusub", opt.plant_port, opt.gcs_port, companion_port,
                                       speedup=speedup))
        boot(gcs, cfg)
        # the outputs at 50 Hz in mission.tlog: when each command reaches the thrusters (docs/companion.md, Latency)
        gcs.conn.mav.command_long_send(1, 1, gcs.mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 0,
                                       gcs.mavlink.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW, 20_000, 0, 0, 0, 0, 0)
        # --stale 2: on a shared SITL machine the companion is starved of the CPU for half a second now and then,
        # and would hand back (a vehicle keeps 0.5 s: docs/companion.md)
        children.append(Child("companion", [*companion_argv(cli, configs, spec, method, companion_port, netcfg, out,
                                                             lockstep=False), "--stale", f"{SITL_STALE_S:g}"],
                               out / "companion.log", env))
        wait_ready(children, opt.ready_timeout_s)
        wall = _fly(gcs, cfg, setpoint, duration, f"sim --companion {method} ArduSub {sea.name} {spec.label}",
                    progress)
    log = truth_timeseries(out / "plant_truth.csv", sea, sea_start, duration, setpoint)
    ticks = np.loadtxt(out / "companion_ticks.csv", delimiter=",", skiprows=1, ndmin=2)
    join_ticks(log, ticks, sea_start)
    stats: dict = {}
    with contextlib.suppress(OSError):
        stats = json.loads((out / "companion_ticks.json").read_text())
    results = autopilot_results(sea, duration, setpoint, log, spec.label)
    results.update({"controller": spec.controller, "transport": f"companion ({method}) over MAVLink to the real "
                    "ArduSub SITL (JSON SITL, zenoh)", "autopilot": str(binary),
                    "companion": {"method": method, "telemetry_to_command_ms": stats.get("telemetry_to_command_ms"),
                                  "link": stats.get("link"), "events": stats.get("events"),
                                  "faults": stats.get("faults")},
                    "ff_active_fraction": float(np.nanmean(log[:, COLUMN["ff_active"]])),
                    "ardusub_params": cfg["params"], "sea_start_s": sea_start, "speedup": speedup, "wall_time_s": wall,
                    "speed_x_realtime": (sea_start + duration) / wall if wall > 0 else None, "processes": statuses})
    write_run(RunResult(results, log), out, plots=opt.plots)
    return results


def _fly(gcs: _GroundStation, cfg: dict, setpoint: np.ndarray, duration: float, title: str, progress) -> float:
    """The pilot: wait for ArduSub's position estimate, MANUAL, arm; the companion dives before the sea
    begins and holds the mission's duration; disarm. The wall time (s)."""
    import time

    mav = gcs.mavlink
    t0 = time.monotonic()
    _wait_mode(gcs, ARDUSUB_MODES["guided"], cfg["boot_timeout_s"])     # accepted once the EKF has a position
    _wait_mode(gcs, MANUAL, 10.0)
    gcs.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    sea_start = cfg["sea_start_s"]
    end_s = sea_start + duration
    with ProgressBar(end_s, title, enabled=progress) as bar:
        dive(gcs, setpoint, sea_start, bar, send=False)
        gcs._follow_clock(int(round(end_s * 1000)) + 200, bar, timeout=duration * 10 + 600)
    gcs.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 0)
    return time.monotonic() - t0


def join_ticks(log: np.ndarray, ticks: np.ndarray, sea_start: float) -> None:
    """Fill the firmware columns of a truth time series (sea time) from the companion's ticks (the autopilot's
    clock, which the plant's lockstep keeps on the plant's): each row takes the tick nearest its instant,
    within half a period; rows without one keep NaN."""
    if ticks.size == 0:
        return
    t_rows = log[:, 0] + sea_start
    i = np.clip(np.searchsorted(ticks[:, 0], t_rows), 1, len(ticks) - 1)
    near = np.where(np.abs(ticks[i - 1, 0] - t_rows) <= np.abs(ticks[i, 0] - t_rows), i - 1, i)
    ok = np.abs(ticks[near, 0] - t_rows) <= 0.5 / RATE_HZ
    first = COLUMN["x_hat"]
    tau_cols = slice(COLUMN["tau_X"], COLUMN["tau_M"] + 1)
    tau_truth = log[:, tau_cols].copy()
    log[ok, first:first + ticks.shape[1] - 1] = ticks[near[ok], 1:]
    log[:, tau_cols] = tau_truth       # power from the wrench the thrusters gave, as for ArduSub's own hold
