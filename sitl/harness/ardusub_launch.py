"""``wavekeep sim --autopilot ardusub:PATH``: the real ArduSub SITL flies in Wavekeep's world.

The processes: the plant (JSON SITL, for a foreign autopilot: the vehicle boots
at the surface and is held there until its thrusters run, sway/roll/yaw move,
the plant steps at its own rate under ArduSub's 1200 Hz frames, and the water
is still for ``sea_start_s`` while ArduSub boots and dives) and the ArduSub
binary (:class:`~sitl.harness.ardusub.ArduSubProcess`). The launcher is the
ground station: it waits until ArduSub accepts GUIDED (its EKF has a position),
sends the station as a position target, arms, and holds there; at the sea's
t = 0 it switches to the hold mode asked for (GUIDED, ALT_HOLD or POSHOLD) and
flies the mission's duration. Results come from the plant's truth alone, on
the sea's clock, so they sit beside a native run of the same seed sample for
sample: the same sea over the same [0, duration], the vehicle at rest on the
station at its start.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from sitl.sea import Sea

from .ardusub import ArduSubProcess, load_ardusub_config
from .children import LaunchError, check_port, interrupt_leaves_nothing
from .launcher import SimOptions, _GroundStation, mission_processes, prepare_run, start_world
from .metrics import station_keeping_metrics
from .progress import ProgressBar
from .results import COLUMN, TIMESERIES_COLUMNS, RunResult, elevation_along
from .run_files import write_run

__all__ = ["ARDUSUB_MODES", "autopilot_results", "launch_ardusub", "truth_timeseries", "world_args"]

ARDUSUB_MODES = {"guided": 4, "alt_hold": 2, "poshold": 16}
"""ArduSub's hold modes the launcher can fly (custom mode numbers)."""

RATE_HZ = 20.0
"""The truth log's rate and the time series' (the mission's control rate)."""


def world_args(cfg: dict) -> tuple[str, ...]:
    """``wavekeep plant``'s options for a foreign autopilot (docs/json_sitl.md)."""
    return ("--start", "surface", "--six-dof", "--physics-rate", f"{cfg['physics_rate_hz']:g}",
            "--log-rate", f"{RATE_HZ:g}")


def launch_ardusub(opt: SimOptions, binary: Path, mode: str = "guided", progress=None,
                   params: dict[str, float] | None = None) -> dict:
    """Fly one mission with ArduSub's own controllers; returns the results document (also in DIR).
    ``params``: ArduSub parameters to set too (``--ardusub-set``), after the config's."""
    if mode not in ARDUSUB_MODES:
        raise LaunchError(f"--ardusub-mode takes {', '.join(ARDUSUB_MODES)}, got {mode!r}", 2)
    with interrupt_leaves_nothing(Path(opt.out)):
        return _launch_ardusub(opt, binary, mode, progress, params)


def _launch_ardusub(opt: SimOptions, binary: Path, mode: str, progress, params: dict[str, float] | None) -> dict:
    cfg = load_ardusub_config()
    cfg["params"].update(params or {})
    sea, _mcfg, duration, setpoint, out = prepare_run(opt)
    check_port(opt.plant_port, "plant")
    check_port(opt.gcs_port, "GCS")
    sea_start = cfg["sea_start_s"]
    statuses: dict[str, int | None] = {}
    with mission_processes(opt, out, statuses) as (gcs, children):
        start_world(opt, sea.seed, duration, out, children, plant_args=world_args(cfg), sea_start=sea_start,
                    forecast=False)
        children.append(ArduSubProcess(binary, cfg, out / "ardusub", opt.plant_port, opt.gcs_port,
                                       speedup=opt.speedup))
        wall = fly_ardusub(gcs, cfg, setpoint, mode, duration, f"sim ArduSub {mode} {sea.name}", progress)
    log = truth_timeseries(out / "plant_truth.csv", sea, sea_start, duration, setpoint)
    results = autopilot_results(sea, duration, setpoint, log, f"ArduSub {mode.upper()}")
    results.update({"transport": "real ArduSub SITL (JSON SITL, MAVLink)", "autopilot": str(binary),
                    "ardusub_mode": mode, "ardusub_params": cfg["params"], "sea_start_s": sea_start,
                    "speedup": opt.speedup, "wall_time_s": wall,
                    "speed_x_realtime": (sea_start + duration) / wall if wall > 0 else None,
                    "processes": statuses})
    write_run(RunResult(results, log), out, plots=opt.plots)
    return results


def _wait_mode(gcs: _GroundStation, mode: int, timeout: float) -> None:
    """DO_SET_MODE until ArduSub accepts it (GUIDED is refused until its EKF has a position)."""
    mav = gcs.mavlink
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        gcs.conn.mav.command_long_send(1, 1, mav.MAV_CMD_DO_SET_MODE, 0, 1, mode, 0, 0, 0, 0, 0)
        try:
            ack = gcs.pump(lambda m: m.get_type() == "COMMAND_ACK" and m.command == mav.MAV_CMD_DO_SET_MODE,
                           "the mode's ACK", timeout=1.0)
        except LaunchError:
            continue
        if ack.result == mav.MAV_RESULT_ACCEPTED:
            return
        time.sleep(0.1)
    raise LaunchError(f"ArduSub did not accept mode {mode} within {timeout:g} s")


def set_param(gcs: _GroundStation, name: str, value: float, timeout: float = 5.0) -> None:
    """PARAM_SET until the PARAM_VALUE echo says ``value``."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        gcs.conn.mav.param_set_send(1, 1, name.encode(), float(value), gcs.mavlink.MAV_PARAM_TYPE_REAL32)
        try:
            echo = gcs.pump(lambda m: m.get_type() == "PARAM_VALUE" and m.param_id.rstrip("\x00") == name,
                            f"{name}'s PARAM_VALUE", timeout=1.0)
        except LaunchError:
            continue
        if abs(echo.param_value - value) <= 1e-6 * max(1.0, abs(value)):
            return
    raise LaunchError(f"ArduSub did not take {name} = {value:g}")


def send_station(gcs: _GroundStation, setpoint: np.ndarray) -> None:
    """The station as a GUIDED position target (local NED: x north, 0 east, depth down; three times: UDP)."""
    for _ in range(3):
        gcs.conn.mav.set_position_target_local_ned_send(0, 1, 1, gcs.mavlink.MAV_FRAME_LOCAL_NED,
                                                        0b0000_1111_1111_1000, float(setpoint[0]), 0.0,
                                                        float(setpoint[1]), 0, 0, 0, 0, 0, 0, 0, 0)


def boot(gcs: _GroundStation, cfg: dict) -> None:
    """Wait for ArduSub's heartbeat and set the config's parameters."""
    gcs.pump(lambda m: m.get_type() == "HEARTBEAT" and m.get_srcSystem() == 1, "ArduSub's heartbeat",
             timeout=cfg["boot_timeout_s"])
    for name, value in cfg["params"].items():
        set_param(gcs, name, value)


def fly_ardusub(gcs: _GroundStation, cfg: dict, setpoint: np.ndarray, mode: str, duration: float, title: str,
                progress) -> float:
    """Boot, GUIDED to the station, arm; at the sea's start the hold mode; to the end, disarm. Wall time (s)."""
    mav = gcs.mavlink
    t0 = time.monotonic()
    boot(gcs, cfg)
    _wait_mode(gcs, ARDUSUB_MODES["guided"], cfg["boot_timeout_s"])
    send_station(gcs, setpoint)
    gcs.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    sea_start = cfg["sea_start_s"]
    end_ms = int(round((sea_start + duration) * 1000)) + 200     # the truth log covers the last tick
    with ProgressBar(sea_start + duration, title, enabled=progress) as bar:
        dive(gcs, setpoint, sea_start, bar)
        if mode != "guided":
            _wait_mode(gcs, ARDUSUB_MODES[mode], 10.0)
        gcs._follow_clock(end_ms, bar, timeout=duration * 10 + 600)
    gcs.command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 0)
    return time.monotonic() - t0


def dive(gcs: _GroundStation, setpoint: np.ndarray, sea_start: float, bar, send: bool = True) -> None:
    """Until the sea begins, send the station again every second of the vehicle's clock (``send``: a target
    ArduSub dropped would leave it holding the surface; a companion flies the dive itself); at the sea's start
    it must be on station (its own depth within 0.5 m), or the run is refused with what to change."""
    depth = [float("nan")]

    def seen(m) -> bool:
        if m.get_type() == "GLOBAL_POSITION_INT":
            depth[0] = -m.relative_alt / 1000.0
        t_ms = getattr(m, "time_boot_ms", None) if m.get_type() in ("SYSTEM_TIME", "ATTITUDE") else None
        if t_ms is not None:
            bar.update(t_ms / 1000.0)
            return t_ms >= next_ms
        return False

    next_ms = 0
    while next_ms < sea_start * 1000:
        m = gcs.pump(seen, "ArduSub's clock", timeout=120.0)
        next_ms = min(int(round(sea_start * 1000)), int(m.time_boot_ms) + 1000)
        if send:
            send_station(gcs, setpoint)
    if not abs(depth[0] - setpoint[1]) <= 0.5:
        raise LaunchError(f"ArduSub was at {depth[0]:.2f} m, not on the station ({setpoint[1]:g} m), when the sea "
                          "began: give it longer (sea_start_s in configs/autopilot/ardusub.yaml)")


def truth_timeseries(path: Path, sea: Sea, sea_start: float, duration: float, setpoint: np.ndarray) -> np.ndarray:
    """The run's time series on the sea's clock from the plant's truth log alone (:data:`TIMESERIES_COLUMNS`).

    Row k (k = 1 … n) is the truth at sea time k/20 s; ``tau_*`` is the wrench the thrusters gave
    (the plant's, as no firmware tick log exists), the wave load the one at the end of the tick's
    period, the setpoint the station; the firmware's own columns are NaN.
    """
    truth = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    k_all = np.rint((truth[:, 0] - sea_start) * RATE_HZ).astype(int)
    by_k = {int(k): i for i, k in enumerate(k_all)}
    n = int(round(duration * RATE_HZ)) - 1
    missing = [k for k in range(1, n + 2) if k not in by_k]
    if missing:
        raise LaunchError(f"the plant's truth log misses {len(missing)} of the mission's {n} ticks")
    rows = np.array([by_k[k] for k in range(1, n + 1)])
    nxt = np.array([by_k[k + 1] for k in range(1, n + 1)])
    col = COLUMN
    log = np.full((n, len(TIMESERIES_COLUMNS)), np.nan)
    log[:, 0] = np.arange(1, n + 1) / RATE_HZ
    log[:, 1:7] = truth[rows, 1:7]
    log[:, col["sp_x"]:col["sp_theta"] + 1] = setpoint
    log[:, col["tau_X"]:col["tau_M"] + 1] = truth[rows, 11:14]
    log[:, col["tauE_X"]:col["tauE_M"] + 1] = truth[nxt, 7:10]
    log[:, col["y"]:col["psi"] + 1] = truth[rows, 14:17]        # the plant's y, φ, ψ (TRUTH_COLUMNS)
    log[:, col["ff_active"]] = 0.0
    log[:, col["saturated"]] = 0.0
    log[:, col["wave_eta"]] = elevation_along(sea.components, log[:, 1], log[:, 0])
    return log


def autopilot_results(sea: Sea, duration: float, setpoint: np.ndarray, log: np.ndarray, label: str) -> dict:
    """``results.json`` for a run flown by a foreign autopilot: the metrics from the truth (no firmware log)."""
    c = COLUMN
    metrics = station_keeping_metrics(log[:, 0], log[:, 1:4], setpoint, log[:, c["tau_X"]:c["tau_M"] + 1])
    return {"case": sea.name, "controller": None, "label": label, "seed": sea.seed, "duration_s": duration,
            "rate_hz": RATE_HZ, **metrics, "hs_target_m": sea.hs_target,
            "hs_realised_m": float(4.0 * np.std(elevation_along(sea.components, np.full(len(log), setpoint[0]),
                                                                log[:, 0]))),
            "tick_overruns": 0}

