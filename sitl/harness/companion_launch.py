"""``wavekeep sim --companion``: the companion flying a stand-in ArduSub, all in lockstep.

The processes: the plant (JSON SITL), the forecast service (C-PD+FF), the
Wavekeep firmware as "ArduSub" (its own control off: MANUAL, WK_FF_ENABLE=0, no
forecast; ``--companion-lockstep``; for ``servo`` the companion switches SERVO1-8_FUNCTION to RCIN9-16)
and ``wavekeep companion`` (``--lockstep``), which talks to the stand-in over
its own MAVLink endpoint. The launcher is the pilot's ground station: it arms
the vehicle in MANUAL, and the companion engages. The time series joins the
plant's truth with the *companion's* tick log (its estimate, setpoint and
commands). Same seed, same result.

Pointing the companion at real ArduSub SITL (``sim_vehicle.py -v ArduSub
--model JSON`` in ``wavekeep plant``) is the same companion command without
``--lockstep`` (``docs/companion.md``).
"""
from __future__ import annotations

import contextlib
import json
import socket
import time
from pathlib import Path

import numpy as np

from bridge.forecast import derive_seeds, oracle_forecast

from .launcher import (
    Child,
    LaunchError,
    SimOptions,
    _GroundStation,
    _merge_logs,
    check_port,
    interrupt_leaves_nothing,
    prepare_run,
    start_world,
    stop_children,
    wait_ready,
)
from .results import RunResult, mission_results
from .run import write_run

__all__ = ["METHODS", "companion_argv", "launch_companion", "stand_in_args"]

METHODS = ("rc", "servo")


def stand_in_args(method: str) -> list[str]:
    """The stand-in ArduSub's settings for a method: its own control off; the aided EKF (IMU and DVL, as
    ArduSub's EKF3, not a thrust model that cannot see the waves the companion's FF balances); rc: sticks to
    PWM without motor-lag compensation, as ArduSub's mixer (the companion compensates)."""
    args = ["--set", "WK_FF_ENABLE=0", "--set", "FS_GCS_ENABLE=0", "--set", "WK_EKF_MODE=1", "--no-forecast",
            "--companion-lockstep"]
    if method == "rc":        # ArduSub's mixer turns sticks into PWM without motor-lag compensation
        args += ["--set", "WK_MOT_COMP=0"]
    # servo: the outputs boot as motors, as ArduSub's; the companion switches them to RCIN9-16 while it flies
    return args


def launch_companion(opt: SimOptions, method: str = "rc", companion_port: int = 14770, progress=None) -> dict:
    """Run one mission with the companion flying the stand-in (the real ArduSub SITL:
    :mod:`~sitl.harness.ardusub_companion`); returns the results document (also in DIR)."""
    if method not in METHODS:
        raise LaunchError(f"--companion takes {' or '.join(METHODS)}, got {method!r}", 2)
    with interrupt_leaves_nothing(Path(opt.out)):
        return _launch_companion(opt, method, companion_port, progress)


def _launch_companion(opt: SimOptions, method: str, companion_port: int, progress) -> dict:
    spec = opt.spec
    sea, mcfg, duration, setpoint, out = prepare_run(opt)
    for port, what in ((opt.plant_port, "plant"), (opt.gcs_port, "GCS"), (companion_port, "companion")):
        check_port(port, what)
    if spec.ff:
        check_port(opt.zenoh_port, "zenoh", socket.SOCK_STREAM)
    children: list[Child] = []
    flown = False
    try:
        _start(opt, method, companion_port, sea.seed, duration, out, children)
        wall = _fly(opt, duration, f"sim --companion {method} {sea.name} {spec.label}", out, children, progress)
        flown = True
    finally:
        statuses = stop_children(children, opt.stop_timeout_s, interrupted=not flown)
    rate = mcfg["control_rate"]
    truth = np.loadtxt(out / "plant_truth.csv", delimiter=",", skiprows=1, ndmin=2)
    ticks = np.loadtxt(out / "companion_ticks.csv", delimiter=",", skiprows=1, ndmin=2)
    forecast = None
    if spec.forecast_source == "oracle":
        forecast = oracle_forecast(sea.components, spec.snr_db, np.random.default_rng(derive_seeds(sea.seed)[1]))
    log = _merge_logs(truth, ticks, int(round(duration * rate)) - 1, sea, forecast)
    stats: dict = {}
    with contextlib.suppress(OSError):
        stats = json.loads((out / "companion_ticks.json").read_text())
    results = mission_results(sea, spec, duration, rate, setpoint, log, stats)
    results.update({"transport": f"companion ({method}) over MAVLink to a stand-in ArduSub (JSON SITL, zenoh)",
                    "companion": {"method": method, "telemetry_to_command_ms": stats.get("telemetry_to_command_ms"),
                                  "link": stats.get("link"), "events": stats.get("events")},
                    "speedup": opt.speedup, "wall_time_s": wall,
                    "speed_x_realtime": duration / wall if wall > 0 else None, "processes": statuses})
    write_run(RunResult(results, log), out, plots=opt.plots)
    return results


def _start(opt: SimOptions, method: str, companion_port: int, seed: int, duration: float, out: Path,
           children: list[Child]) -> None:
    spec = opt.spec
    cli, configs, env, netcfg = start_world(opt, seed, duration, out, children)
    ardusub = [*cli, "firmware", "--hal", f"sitl:127.0.0.1:{opt.plant_port}", "--seed", str(seed), *configs,
               "--mavlink", f"udpout:127.0.0.1:{opt.gcs_port}", "--mavlink", f"udpout:127.0.0.1:{companion_port}",
               "--hold-until-armed", "--log", str(out / "firmware_ticks.csv"), "--speedup", str(opt.speedup or 0),
               *stand_in_args(method), *[a for s in opt.extra_params for a in ("--set", s)]]
    children.append(Child("ardusub", ardusub, out / "ardusub.log", env))
    wait_ready(children, opt.ready_timeout_s)
    children.append(Child("companion", companion_argv(cli, configs, spec, method, companion_port, netcfg, out,
                                                       lockstep=True), out / "companion.log", env))
    wait_ready(children, opt.ready_timeout_s)


def companion_argv(cli: list[str], configs: list[str], spec, method: str, port: int, netcfg: Path, out: Path,
                   lockstep: bool) -> list[str]:
    """``wavekeep companion``'s command line for a run: the method, the forecast (C-PD+FF), the overrides."""
    companion = [*cli, "companion", "--autopilot", f"udpin:127.0.0.1:{port}", *(["--lockstep"] if lockstep else []),
                 "--method", method, *configs, "--log", str(out / "companion_ticks.csv")]
    if spec.ff:
        companion += ["--forecast", "zenoh", "--network", str(netcfg)]
    for name, value in {**spec.implied_params(), **spec.overrides}.items():   # the law (WK_CTRL_LAW) included
        companion += ["--set", f"{name}={value!r}"]
    return companion


def _fly(opt: SimOptions, duration: float, title: str, out: Path, children: list[Child], progress) -> float:
    """The pilot: arm in MANUAL (the boot mode), let the companion fly to the end of the mission, disarm."""
    gcs = _GroundStation(opt.gcs_port, out / "mission.tlog", children, opt.downlink_tap)
    try:
        gcs.pump(lambda m: m.get_type() == "HEARTBEAT" and m.get_srcSystem() == 1, "the vehicle's heartbeat")
        time.sleep(0.2)
        return gcs.fly_armed(duration, title, progress)
    finally:
        gcs.close()
