"""``wavekeep sim``: the plant, the forecast service and the firmware as separate processes, flown over MAVLink.

Like ``sim_vehicle.py`` for ArduPilot: the launcher starts

* the physics server (``wavekeep plant``: the sea and the vehicle, ArduPilot's
  JSON SITL protocol on UDP, the wave buoy on zenoh),
* the forecast service (``wavekeep forecast``, zenoh; C-PD+FF only),
* the firmware (``wavekeep firmware``: JSON SITL HAL, MAVLink, forecast subscriber),

waits until each says it is ready, and then acts as a ground station over
MAVLink: waits for the heartbeat (and, for C-PD+FF, for a valid forecast),
switches to GUIDED on the mission's station, arms, and follows the mission
until the vehicle's clock reaches its end. The firmware holds simulated time
after its first tick until it is armed, so the mission is the same at every
speed-up and matches ``wavekeep run`` for the same seed.

Results: ``DIR/results.json`` (the ``wavekeep run`` schema), ``timeseries.csv``,
``mission.tlog`` (every MAVLink message the GCS saw), the figure, and each
process's log. Ctrl-C, or any child dying, stops every process; the exit status
says what happened (0 done, 1 a child failed, 2 bad arguments or ports in use,
130 interrupted).
"""
from __future__ import annotations

import contextlib
import json
import os
import select
import socket
import struct
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bridge.forecast import derive_seeds, oracle_forecast
from bridge.schemas import load_mission_config, load_vehicle_config
from firmware_py.modes import Mode
from sitl.sea import Sea

from .blas import ONE_BLAS_THREAD
from .children import Child, LaunchError, check_port, interrupt_leaves_nothing, stop_children, wait_ready
from .frame_clock import Frame, read_frames
from .progress import ProgressBar
from .results import COLUMN, TIMESERIES_COLUMNS, RunResult, elevation_along, mission_results
from .run_files import write_run
from .spec import RunSpec

__all__ = ["LaunchError", "SimOptions", "launch"]


@dataclass
class SimOptions:
    """How to launch a run: the mission (a :class:`RunSpec`), pacing, the run folder and the loopback ports."""

    spec: RunSpec = field(default_factory=RunSpec)
    speedup: float | None = None
    out: str = "runs/sim"
    plant_port: int = 9002
    gcs_port: int = 14550
    zenoh_port: int = 7447
    ready_timeout_s: float = 60.0
    stop_timeout_s: float = 120.0  # wall s a child may take to write its log and exit once told to stop
    extra_params: list[str] = field(default_factory=list)
    plots: bool = True            # draw time_history.png (matplotlib: about a second)
    downlink_tap: Callable[[bytes], None] | None = None   # each MAVLink frame the GCS hears (the live view)


def prepare_run(opt: SimOptions) -> tuple[Sea, dict, float, np.ndarray, Path]:
    """Validate the run's configs before anything starts: the sea, the mission config, its duration (s),
    the station [x, depth, θ], and the run folder (created)."""
    spec = opt.spec
    sea = Sea.load(spec.case, seed=spec.seed)
    mcfg = load_mission_config(spec.mission)
    load_vehicle_config(spec.vehicle)
    duration = mcfg["duration"] if spec.duration is None else float(spec.duration)
    sp = mcfg["setpoint"]
    out = Path(opt.out)
    out.mkdir(parents=True, exist_ok=True)
    return sea, mcfg, duration, np.array([sp["x"], sp["depth"], sp["pitch"]]), out


def launch(opt: SimOptions, progress=None) -> dict:
    """Run one mission across processes; returns the results document (also written to DIR)."""
    with interrupt_leaves_nothing(Path(opt.out)):
        return _launch(opt, progress)


def _launch(opt: SimOptions, progress) -> dict:
    spec = opt.spec
    sea, mcfg, duration, setpoint, out = prepare_run(opt)
    check_port(opt.plant_port, "plant")
    check_port(opt.gcs_port, "GCS")
    if spec.ff:
        check_port(opt.zenoh_port, "zenoh", socket.SOCK_STREAM)
    statuses: dict[str, int | None] = {}
    with mission_processes(opt, out, statuses) as (gcs, children):
        _start_processes(opt, sea.seed, duration, out, children, sea.water_depth)
        wall = _fly(opt, gcs, setpoint, duration, f"sim {sea.name} {spec.label}", progress)
    rate = mcfg["control_rate"]
    log = _merge_logs_of(opt, sea, duration, rate, out)
    fw_stats = {}
    with contextlib.suppress(OSError):
        fw_stats = json.loads((out / "firmware_ticks.json").read_text())
    _check_lockstep(opt, fw_stats)
    results = mission_results(sea, spec, duration, rate, setpoint, log, fw_stats)
    results.update({
        "transport": "multi-process (JSON SITL, MAVLink, zenoh)",
        "speedup": opt.speedup, "wall_time_s": wall,
        "speed_x_realtime": duration / wall if wall > 0 else None,
        "processes": statuses,
    })
    write_run(RunResult(results, log), out, plots=opt.plots)
    return results


@contextlib.contextmanager
def mission_processes(opt: SimOptions, out: Path, statuses: dict[str, int | None]):
    """The ground station (its tlog ``mission.tlog``) and the list the mission's child processes go in,
    yielded. However the block ends, the link closes and the children stop, the last started first, their exit
    statuses put in ``statuses``; after a flight that ended normally a child that failed is the run's
    failure (:func:`~.children.stop_children`).

    The ground station listens before any vehicle starts: its first heartbeat (1 Hz) and streams wait in
    the socket instead of being lost, so the flight need not wait a second for the next one."""
    children: list = []
    gcs = None
    flown = False
    try:
        gcs = _GroundStation(opt.gcs_port, out / "mission.tlog", children, opt.downlink_tap)
        yield gcs, children
        flown = True
    finally:
        if gcs is not None:
            gcs.close()
        statuses.update(stop_children(children, opt.stop_timeout_s, interrupted=not flown))


def _check_lockstep(opt: SimOptions, fw_stats: dict) -> None:
    """An unpaced run is the in-process run only if the plant answered every servo frame in time: a reply
    later than ``SIM_JSON_TMO`` makes the firmware fly that tick blind. Said, never passed off as the run."""
    late = (fw_stats.get("hal") or {}).get("timeouts", 0)
    if not opt.speedup and late:
        raise LaunchError(f"the plant's reply to {late} servo frame(s) came later than SIM_JSON_TMO, so the firmware "
                          "flew those ticks without sensors: the run is not the lockstep one (raise SIM_JSON_TMO)")


def start_world(opt: SimOptions, seed: int, duration: float, out: Path, children: list[Child],
                wait_plant: bool = True, plant_args: tuple[str, ...] = (), sea_start: float = 0.0,
                forecast: bool | None = None) -> tuple[list[str], list[str], dict[str, str], Path]:
    """The forecast service (C-PD+FF only) and the plant, each waited for until ready (the plant only if
    ``wait_plant``: a caller may start the vehicle alongside it and wait for both). ``plant_args`` are
    more ``wavekeep plant`` options; ``sea_start`` (s) the vehicle's clock at the sea's t = 0 (both);
    ``forecast`` starts the forecast service or not (None: for C-PD+FF).

    Returns what the vehicle's processes are started with: the CLI prefix, the
    mission/vehicle options, the environment and the zenoh network config.
    """
    spec = opt.spec
    # One BLAS thread per process: three processes already share the cores
    env = dict(os.environ, PYTHONUNBUFFERED="1", **ONE_BLAS_THREAD)
    netcfg = out / "network.yaml"
    netcfg.write_text(json.dumps({"site": "sim", "zenoh": {
        "mode": "peer", "service_listen": [f"tcp/127.0.0.1:{opt.zenoh_port}"],
        "connect": [f"tcp/127.0.0.1:{opt.zenoh_port}"], "multicast_scouting": False,
        "gossip_scouting": True, "scouting_delay_ms": 0}}))
    cli = [sys.executable, "-m", "sitl.harness.cli"]
    configs = ["--mission", spec.mission, "--vehicle", spec.vehicle]
    # The world's errors (docs/sea-errors.md): the sea's keys reach the plant (and its buoy) and the forecast
    sea_set = [a for k, v in spec.sea.items() for a in ("--sea-set", f"{k}={json.dumps(v)}")]
    if spec.ff if forecast is None else forecast:
        fc = [*cli, "forecast", "--case", spec.case, "--seed", str(seed), "--forecast", spec.forecast,
              "--network", str(netcfg), "--horizon", str(sea_start + duration + 60.0), *sea_set]
        if sea_start:
            fc += ["--sea-start", repr(sea_start)]
        if spec.dswp.get("deep_water"):
            fc.append("--deep-water")
        if spec.snr_db is not None:
            fc += ["--forecast-snr-db", str(spec.snr_db)]
        children.append(Child("forecast", fc, out / "forecast.log", env))
        wait_ready(children, opt.ready_timeout_s)
    plant = [*cli, "plant", "--case", spec.case, "--seed", str(seed), "--port", str(opt.plant_port), *configs,
             "--log", str(out / "plant_truth.csv"), *sea_set, *plant_args]
    if sea_start:
        plant += ["--sea-start", repr(sea_start)]
    if spec.true_vehicle:
        plant += ["--true-vehicle", spec.true_vehicle]
    if spec.ff if forecast is None else forecast:
        plant += ["--buoy-network", str(netcfg)]
    children.append(Child("plant", plant, out / "plant.log", env))
    if wait_plant:
        wait_ready(children, opt.ready_timeout_s)
    return cli, configs, env, netcfg


def _start_processes(opt: SimOptions, seed: int, duration: float, out: Path, children: list[Child],
                     water_depth: float) -> None:
    """The world (:func:`start_world`) and the firmware, waited for until ready (told the site's
    ``water_depth`` (m) for its DVL model).

    The firmware starts as soon as the forecast service is up, while the plant is still starting:
    the two interpreters' start-ups (imports, configs; about a second each) overlap, and the
    firmware's HAL says hello until the plant answers (``--hal-wait``).
    """
    spec = opt.spec
    cli, configs, env, netcfg = start_world(opt, seed, duration, out, children, wait_plant=False)
    firmware = [*cli, "firmware", "--hal", f"sitl:127.0.0.1:{opt.plant_port}", "--hal-wait", f"{opt.ready_timeout_s:g}",
                "--mavlink", f"udpout:127.0.0.1:{opt.gcs_port}", "--seed", str(seed), *configs,
                "--hold-until-armed", "--log", str(out / "firmware_ticks.csv"), "--network", str(netcfg)]
    firmware += ["--speedup", str(opt.speedup or 0)]      # explicit: 0 is unpaced (the default with --mavlink is 1)
    firmware += [a for name, value in spec.implied_params().items() for a in ("--set", f"{name}={value!r}")]
    firmware += ["--set", f"SIM_WATER_DEPTH={water_depth!r}"]
    # The launcher's heartbeats run on the wall clock; the firmware's failsafe timer on simulated
    # time. At a speed-up the two disagree, so the scripted mission runs without the GCS failsafe
    # (a result must not depend on how fast the machine is).
    firmware += ["--set", "FS_GCS_ENABLE=0"]
    # It flies without a joystick and arms as soon as the vehicle boots (its clock held until then): the
    # pilot-input failsafe, whose clock starts at boot, would disarm it FS_PILOT_TIMEOUT later, as ArduSub's would.
    firmware += ["--set", "FS_PILOT_INPUT=0"]
    if not opt.speedup:
        # Unpaced, time is the plant's: a plant slow to answer (a busy machine) is not a silent one, so
        # the firmware waits as long as the parameter allows (the user's --set still wins)
        firmware += ["--set", f"SIM_JSON_TMO={LOCKSTEP_REPLY_WAIT_S!r}"]
    if not spec.ff:
        firmware += ["--no-forecast"]
    for name, value in spec.overrides.items():
        firmware += ["--set", f"{name}={value!r}"]
    for s in opt.extra_params:
        firmware += ["--set", s]
    children.append(Child("firmware", firmware, out / "firmware.log", env))
    wait_ready(children, opt.ready_timeout_s)


LOCKSTEP_REPLY_WAIT_S = 5.0   # s: SIM_JSON_TMO for an unpaced run (the parameter's upper limit)

_SYSTEM_TIME, _ATTITUDE = 2, 30            # MAVLink message ids
_CLOCK_IDS = (_SYSTEM_TIME, _ATTITUDE)      # the messages whose time_boot_ms ends the mission
_TLOG_STAMP = struct.Struct(">Q")           # .tlog: big-endian µs before each frame
_BATCH_S = 0.005                            # s: the flight loop's wait for more datagrams once woken (~40
#                                             at full speed, well within the socket's default buffer)


class _GroundStation:
    """The launcher's side of the MAVLink link: heartbeats, commands with their acks, and the .tlog."""

    def __init__(self, port: int, tlog: Path, children: list[Child], tap: Callable[[bytes], None] | None = None):
        os.environ["MAVLINK20"] = "1"
        from pymavlink import mavutil
        self.mavlink = mavutil.mavlink
        self.conn = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=255,
                                               source_component=190, dialect="ardupilotmega")
        # .tlog: what MAVProxy and QGroundControl write — a big-endian µs timestamp before each frame.
        # (pymavlink's setup_logfile does not log on UDP links, so the launcher writes it.) Both
        # directions, stamped in vehicle time: the epoch SYSTEM_TIME gives (Unix µs at vehicle time 0)
        # plus the latest time_boot_ms heard, so an unpaced run's log replays on its own clock.
        self.tlog = open(tlog, "wb")  # noqa: SIM115 — closed in close()
        self.children = children
        self._last_hb = 0.0
        self._epoch_us: int | None = None            # Unix µs at vehicle time 0, from SYSTEM_TIME
        self._vehicle_us = 0
        self._stamp = 0
        self.tap = tap                                # called with each frame logged (one append: the live view)
        self.conn.mav.set_send_callback(lambda msg: self._log(msg))

    def _log(self, m) -> None:
        """Append one pymavlink message to the .tlog (:meth:`_log_frame`)."""
        t_ms = getattr(m, "time_boot_ms", None)
        self._log_frame(m.get_msgId(), m.get_srcSystem(), t_ms if isinstance(t_ms, int) else None,
                        getattr(m, "time_unix_usec", None), m.get_msgbuf())

    def _log_frame(self, msg_id: int, src: int, t_ms: int | None, unix_us: int | None, buf: bytes) -> None:
        """Append one frame to the .tlog, stamped in vehicle time (never going backwards)."""
        if msg_id == _SYSTEM_TIME and unix_us and t_ms is not None:
            self._epoch_us = int(unix_us) - int(t_ms) * 1000
        if t_ms is not None and src != 255:
            self._vehicle_us = t_ms * 1000
        if self._epoch_us is None:
            # Until a SYSTEM_TIME says, the wall clock at the first frame logged (the station listens
            # before the vehicle starts: its own start-up time is no part of the vehicle's log)
            self._epoch_us = int(time.time() * 1e6)
        self._stamp = max(self._stamp, self._epoch_us + self._vehicle_us)
        self.tlog.write(_TLOG_STAMP.pack(self._stamp & ~3) + buf)
        if self.tap is not None:
            self.tap(buf)

    def _keep_alive(self) -> None:
        """Heartbeat every 0.5 s; a LaunchError if a child has died."""
        if time.monotonic() - self._last_hb > 0.5:
            self.conn.mav.heartbeat_send(self.mavlink.MAV_TYPE_GCS, self.mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            self._last_hb = time.monotonic()
        for c in self.children:
            if not c.alive():
                raise LaunchError(f"{c.name} died (status {c.proc.returncode}):\n{c.tail()}")

    def pump(self, until, what: str, timeout: float = 30.0):
        """Read messages until ``until(msg)`` is true; heartbeat and watch the children meanwhile."""
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            self._keep_alive()
            m = self.conn.recv_match(blocking=True, timeout=0.05)
            if m is None or m.get_type() == "BAD_DATA":
                continue
            self._log(m)
            if until(m):
                return m
        raise LaunchError(f"timed out waiting for {what}")

    def command(self, cmd: int, *params: float) -> None:
        p = list(params) + [0.0] * (7 - len(params))
        self.conn.mav.command_long_send(1, 1, cmd, 0, *p)
        ack = self.pump(lambda m: m.get_type() == "COMMAND_ACK" and m.command == cmd, f"COMMAND_ACK {cmd}")
        if ack.result != 0:
            raise LaunchError(f"the vehicle refused command {cmd} (MAV_RESULT {ack.result})")

    def fly_armed(self, duration: float, title: str, progress) -> float:
        """Arm, follow the vehicle's clock to ``duration`` s (progress shown), disarm; the wall time it took."""
        self.command(self.mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
        t_wall0 = time.monotonic()
        end_ms = int(round(duration * 1000))
        with ProgressBar(duration, title, enabled=progress) as bar:
            self._follow_clock(end_ms, bar, timeout=duration * 10 + 600)
        wall = time.monotonic() - t_wall0
        self.command(self.mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0)
        return wall

    def _follow_clock(self, end_ms: int, bar, timeout: float) -> None:
        """Log the downlink until SYSTEM_TIME or ATTITUDE says the vehicle's clock reached ``end_ms``.

        The flight's hot loop: each datagram's frames are read by :func:`~.frame_clock.read_frames`
        (checked, not decoded), pymavlink only for what that does not take; children and
        heartbeats are seen to every 50 ms of wall time rather than every message. Woken by a
        datagram, the station lets ``_BATCH_S`` more queue before it reads them all: one wake-up
        for tens of messages instead of one each, on cores the vehicle's processes need.
        """
        conn, deadline, next_check = self.conn, time.monotonic() + timeout, 0.0
        conn.port.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 20)   # room for a batch (capped by the OS)
        readable = select.poll()
        readable.register(conn.port, select.POLLIN)
        pending = list(iter(lambda: conn.mav.parse_char(b""), None))   # what pymavlink had buffered
        while True:
            now = time.monotonic()
            if now >= next_check:
                if now > deadline:
                    raise LaunchError("timed out waiting for the end of the mission")
                self._keep_alive()
                next_check = now + 0.05
            if not pending and not readable.poll(50):
                continue
            time.sleep(_BATCH_S)
            while True:
                if pending:
                    clocks = [self._log_message(m) for m in pending]
                    pending = []
                else:
                    data = conn.recv()          # pymavlink's raw read (keeps its peer bookkeeping)
                    if not data:
                        break
                    frames = read_frames(data)
                    if frames is None:
                        clocks = [self._log_message(m) for m in conn.mav.parse_buffer(data) or ()]
                    else:
                        clocks = [self._log_raw(f) for f in frames]
                for t_ms in clocks:
                    if t_ms is not None:
                        bar.update(t_ms / 1000.0)
                        if t_ms >= end_ms:
                            return

    def _log_raw(self, f: Frame) -> int | None:
        """Log a checked frame; its time_boot_ms if it is a SYSTEM_TIME or ATTITUDE (the mission's clock)."""
        self._log_frame(f.msg_id, f.src_system, f.time_boot_ms, f.time_unix_usec, f.buf)
        return f.time_boot_ms if f.msg_id in _CLOCK_IDS else None

    def _log_message(self, m) -> int | None:
        """:meth:`_log_raw` for a message pymavlink parsed (bad data is neither logged nor read)."""
        if m.get_type() == "BAD_DATA":
            return None
        self._log(m)
        return int(m.time_boot_ms) if m.get_msgId() in _CLOCK_IDS else None

    def close(self) -> None:
        self.conn.close()
        self.tlog.close()


def _fly(opt: SimOptions, gcs: _GroundStation, setpoint: np.ndarray, duration: float, title: str,
         progress) -> float:
    """Fly the mission as a ground station: GUIDED on the station, arm, follow to the end; the wall time."""
    mav = gcs.mavlink
    gcs.pump(lambda m: m.get_type() == "HEARTBEAT" and m.get_srcSystem() == 1, "the vehicle's heartbeat")
    if opt.spec.ff:
        gcs.pump(lambda m: m.get_type() == "NAMED_VALUE_FLOAT" and m.name.rstrip("\x00") == "FF_AGE"
                 and m.value >= 0, "a valid forecast on the vehicle", timeout=60.0)
    gcs.command(mav.MAV_CMD_DO_SET_MODE, 1, int(Mode.GUIDED))
    gcs.conn.mav.set_position_target_local_ned_send(0, 1, 1, mav.MAV_FRAME_LOCAL_NED, 0b0000_1111_1111_1000,
                                                    setpoint[0], 0.0, setpoint[1], 0, 0, 0, 0, 0, 0, 0, 0)
    time.sleep(0.2)
    return gcs.fly_armed(duration, title, progress)


def _merge_logs_of(opt: SimOptions, sea: Sea, duration: float, rate: float, out: Path) -> np.ndarray:
    """The run's time series from the plant's truth log and the firmware's tick log in DIR."""
    truth = np.loadtxt(out / "plant_truth.csv", delimiter=",", skiprows=1, ndmin=2)
    ticks = np.loadtxt(out / "firmware_ticks.csv", delimiter=",", skiprows=1, ndmin=2)
    n = int(round(duration * rate)) - 1
    forecast = None
    if opt.spec.forecast_source == "oracle":   # (DSWP forecasts live in the forecast service; not logged here)
        _, forecast_seed = derive_seeds(sea.seed)
        forecast = oracle_forecast(sea.components, opt.spec.snr_db, np.random.default_rng(forecast_seed))
    return _merge_logs(truth, ticks, n, sea, forecast)


def _merge_logs(truth: np.ndarray, ticks: np.ndarray, n: int, sea, forecast) -> np.ndarray:
    """Join the plant's truth log and the firmware's tick log into the ``wavekeep run`` time series.

    Row k (k = 1 … n) holds the truth at t_k, what the firmware's tick k saw and did
    (:data:`~firmware_py.firmware.TICK_COLUMNS`), and the wave load at the end of that
    tick's period — as :func:`sitl.harness.run.run_mission` logs it.
    """
    col = COLUMN
    h = truth[1, 0] - truth[0, 0]
    by_tick = {int(k): i for i, k in enumerate(np.rint(ticks[:, 0] / h))}
    rows = [k for k in range(1, n + 1) if k in by_tick and k + 1 < truth.shape[0]]
    if len(rows) < n:
        raise LaunchError(f"the logs cover {len(rows)} of the mission's {n} ticks")
    ks = np.array(rows)
    log = np.empty((n, len(TIMESERIES_COLUMNS)))
    log[:, 0:7] = truth[ks, 0:7]
    log[:, 7:7 + ticks.shape[1] - 1] = ticks[[by_tick[k] for k in rows], 1:]
    log[:, col["tauE_X"]:col["tauE_M"] + 1] = truth[ks + 1, 7:10]
    log[:, col["y"]:col["psi"] + 1] = truth[ks, 14:17]          # the plant's y, φ, ψ (TRUTH_COLUMNS)
    log[:, col["wave_eta"]] = elevation_along(sea.components, log[:, 1], log[:, 0])
    log[:, col["forecast_eta"]] = (elevation_along(forecast.components(), log[:, 1], log[:, 0])
                                   if forecast is not None else np.nan)
    return log
