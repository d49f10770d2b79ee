"""wavekeep sim: plant, forecast service and firmware as real processes, flown over MAVLink."""
from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from sitl.harness.launcher import LaunchError, SimOptions, launch
from sitl.harness.ports import free_port
from sitl.harness.run import run_mission, write_run
from sitl.harness.spec import RunSpec

pytestmark = pytest.mark.processes   # starts the plant, firmware and forecast as processes


def options(tmp_path, speedup=None, **spec) -> SimOptions:
    return SimOptions(RunSpec(**spec), speedup=speedup, out=str(tmp_path / "sim"), plant_port=free_port(),
                      gcs_port=free_port(), zenoh_port=free_port(socket.SOCK_STREAM))


def test_multi_process_run_equals_the_in_process_run(tmp_path):
    """Same seed → the same time series and results, through JSON SITL, MAVLink and zenoh."""
    opt = options(tmp_path, case="W1", controller="cpd_ff", snr_db=15.0, duration=8.0)
    sim = launch(opt)
    ref = run_mission(RunSpec("W1", "cpd_ff", 15.0, duration=8.0))
    for key in ("rmse", "max_abs_error", "mean_power_w", "energy_j"):
        for dof, v in ref.results[key].items():
            assert sim[key][dof] == pytest.approx(v, abs=1e-9), (key, dof)
    write_run(ref, tmp_path / "ref", plots=False)
    assert (Path(opt.out) / "timeseries.csv").read_text() == (tmp_path / "ref" / "timeseries.csv").read_text()
    out = Path(opt.out)
    for name in ("results.json", "mission.tlog", "plant.log", "firmware.log", "forecast.log", "time_history.png"):
        assert (out / name).stat().st_size > 0, name
    assert json.loads((out / "results.json").read_text())["processes"] == {"firmware": 0, "plant": 0, "forecast": 0}


def test_the_tlog_is_readable_by_mavlogdump(tmp_path):
    opt = options(tmp_path, case="W3", controller="cpd", duration=3.0, speedup=4.0)
    launch(opt)
    dump = Path(sys.executable).with_name("mavlogdump.py")
    out = subprocess.run([sys.executable, str(dump), "--types", "HEARTBEAT", str(Path(opt.out) / "mission.tlog")],
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 0 and "type : 12" in out.stdout and "base_mode : 217" in out.stdout


def test_a_port_in_use_is_a_clear_error(tmp_path):
    opt = options(tmp_path, controller="cpd", duration=2.0)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", opt.plant_port))
        with pytest.raises(LaunchError) as info:
            launch(opt)
    assert info.value.status == 2 and str(opt.plant_port) in str(info.value)


def start_sim_process(tmp_path) -> subprocess.Popen:
    """``wavekeep sim`` (C-PD, a 600 s mission at real time) as a process, once its firmware is ready."""
    opt = options(tmp_path, controller="cpd", duration=600.0, speedup=1.0)
    cmd = [sys.executable, "-m", "sitl.harness.cli", "sim", "--controller", "cpd", "--duration", "600",
           "--speedup", "1",
           "--out", opt.out, "--plant-port", str(opt.plant_port), "--gcs-port", str(opt.gcs_port),
           "--zenoh-port", str(opt.zenoh_port)]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    log = Path(opt.out) / "firmware.log"
    end = time.monotonic() + 60
    while time.monotonic() < end and not (log.exists() and "ready" in log.read_text()):
        time.sleep(0.1)
    return proc


def _children_of(pid: int) -> list[int]:
    out = subprocess.run(["ps", "-o", "pid=", "--ppid", str(pid)], capture_output=True, text=True)
    return [int(p) for p in out.stdout.split()]


@pytest.mark.parametrize("victim", ["plant", "firmware"])
def test_a_dying_child_stops_everything_and_leaves_no_orphan(tmp_path, victim):
    """Kill the plant or the firmware mid-mission: the launcher exits 1, naming it, and every process is gone."""
    proc = start_sim_process(tmp_path)
    try:
        time.sleep(2.0)
        kids = _children_of(proc.pid)
        assert len(kids) == 2            # plant and firmware (no forecast service for C-PD)
        pid = min(kids) if victim == "plant" else max(kids)      # the plant is started first
        os.kill(pid, signal.SIGKILL)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 1 and victim in err
    time.sleep(0.5)
    for pid in kids:
        assert not Path(f"/proc/{pid}").exists() or "zombie" in Path(f"/proc/{pid}/status").read_text()


def test_ctrl_c_stops_every_process(tmp_path):
    proc = start_sim_process(tmp_path)
    time.sleep(1.0)
    kids = _children_of(proc.pid)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    time.sleep(0.5)
    for pid in kids:
        assert not Path(f"/proc/{pid}").exists() or "zombie" in Path(f"/proc/{pid}/status").read_text()


def test_real_time_mission_keeps_20_hz_on_the_wall_clock_and_the_same_result(tmp_path):
    """--speedup 1: a 4 s mission takes about 4 s of wall time at 20 Hz, falls behind the wall clock
    on few slots, never skips one (lockstep), and gives the in-process result exactly."""
    opt = options(tmp_path, case="W3", controller="cpd", duration=4.0, speedup=1.0)
    r = launch(opt)
    assert 3.6 < r["wall_time_s"] < 6.0          # loose: a loaded 2-core machine, plus the GCS's polling
    stats = json.loads((Path(opt.out) / "firmware_ticks.json").read_text())
    assert stats["loop_rate_hz"] == 20.0 and stats["paced"]["speedup"] == 1.0
    assert stats["paced"]["late_slots"] <= 0.1 * stats["ticks"]
    ticks = np.loadtxt(Path(opt.out) / "firmware_ticks.csv", delimiter=",", skiprows=1)
    assert np.allclose(np.diff(ticks[:, 0]), 0.05)  # every slot ran, on the grid
    write_run(run_mission(RunSpec("W3", "cpd", duration=4.0)), tmp_path / "ref", plots=False)
    assert (Path(opt.out) / "timeseries.csv").read_text() == (tmp_path / "ref" / "timeseries.csv").read_text()
    # An outside observer: the plant's wall-clock time of each servo packet (a step), from the
    # first step after the start hold. Mean period 50 ms within 1 %, no cumulative drift, and
    # the firmware's own account of lateness agrees with the gaps the observer saw.
    truth = np.loadtxt(Path(opt.out) / "plant_truth.csv", delimiter=",", skiprows=1)
    wall = truth[2:, 10]
    gaps = np.diff(wall)
    assert np.mean(gaps) == pytest.approx(0.05, rel=0.01)
    drift = (wall[-1] - wall[0]) - 0.05 * (wall.size - 1)
    assert abs(drift) < 0.025                      # half a period over the whole run
    lag_s = stats["paced"]["max_lag_ms"] / 1e3
    assert gaps.max() < 0.05 + lag_s + 0.015       # no gap the firmware did not account for


def test_sim_honours_the_mission_and_vehicle_configs(tmp_path):
    """The plant and the firmware get the run's --mission and --vehicle, not the defaults."""
    mission = tmp_path / "deep_station.yaml"
    text = (Path(__file__).resolve().parents[1] / "configs" / "mission" / "station_keeping.yaml").read_text()
    mission.write_text(text.replace("depth: 5.0", "depth: 8.0").replace("name: station_keeping", "name: deep"))
    opt = options(tmp_path, case="W1", controller="cpd", duration=2.0, mission=str(mission))
    sim = launch(opt)
    ref = run_mission(RunSpec("W1", "cpd", duration=2.0, mission=str(mission)))
    ts = np.loadtxt(Path(opt.out) / "timeseries.csv", delimiter=",", skiprows=1)
    header = (Path(opt.out) / "timeseries.csv").read_text().splitlines()[0].split(",")
    assert np.all(ts[:, header.index("sp_z")] == 8.0)          # the firmware's station
    assert abs(ts[0, header.index("z")] - 8.0) < 0.05          # the plant released the vehicle there
    for dof, v in ref.results["rmse"].items():
        assert sim["rmse"][dof] == pytest.approx(v, abs=1e-9), dof


def test_sim_takes_the_world_errors_and_equals_run(tmp_path):
    """A sea's errors (current, spreading, the Bar30's dynamic pressure) and a true vehicle reach the plant and
    the forecast service: the networked run equals the in-process one. (DSWP over the network is not
    deterministic: its forecasts reach the vehicle when zenoh delivers them, docs/forecast.md.)"""
    world = {"sea": {"current": {"speed": 0.3, "direction": 0}, "depth_sensor.dynamic_pressure": True,
                     "spreading": {"s": 10, "direction": 20}}, "true_vehicle": "drag_plus20"}
    spec = {"case": "W1", "controller": "cpd_ff", "duration": 4.0, "overrides": {"WK_BARO_WAVE": 1}}
    sim = launch(options(tmp_path, **spec, **world))
    ref = run_mission(RunSpec(**spec, **world))
    nominal = run_mission(RunSpec(**spec))
    for dof, v in ref.results["rmse"].items():
        assert sim["rmse"][dof] == pytest.approx(v, abs=1e-9), dof
    assert sim["rmse"] != pytest.approx(nominal.results["rmse"], abs=1e-6)   # the errors acted


def test_sim_flies_the_mpc_and_equals_run(tmp_path):
    """The preview MPC across processes (its law read at boot from the parameter the launcher sets): the same
    mission as in-process, every column of the time series but the solver's wall-clock compute time."""
    from sitl.harness.results import COLUMN

    spec = {"case": "W1", "controller": "mpc", "duration": 4.0}
    opt = options(tmp_path, **spec)
    sim = launch(opt)
    ref = run_mission(RunSpec(**spec))
    for dof, v in ref.results["rmse"].items():
        assert sim["rmse"][dof] == pytest.approx(v, abs=1e-9), dof
    got = np.genfromtxt(Path(opt.out) / "timeseries.csv", delimiter=",", skip_header=1)
    keep = [i for name, i in COLUMN.items() if name != "ctrl_ms"]
    np.testing.assert_allclose(got[:, keep], ref.timeseries[:, keep], rtol=1e-5, atol=1e-6)  # the CSV's 6 digits
    assert sim["solver"]["law"] == "mpc" and sim["solver"]["solved"] == sim["solver"]["ticks"]


def test_the_tlog_is_in_vehicle_time_and_holds_both_directions(tmp_path):
    """A GCS .tlog: each frame stamped with the vehicle's clock (a 6 s mission spans 6 s, however fast it
    ran), the vehicle's messages and the ground station's own commands and heartbeats."""
    from pymavlink import mavutil
    opt = options(tmp_path, case="W1", controller="cpd", duration=6.0)
    r = launch(opt)
    log = mavutil.mavlink_connection(str(Path(opt.out) / "mission.tlog"))
    stamps, senders = [], {}
    while (m := log.recv_match()) is not None:
        if m.get_type() == "BAD_DATA":
            continue
        stamps.append(m._timestamp)
        senders[m.get_srcSystem()] = senders.get(m.get_srcSystem(), 0) + 1
    assert r["wall_time_s"] < 6.0                       # unpaced: faster than real time ...
    assert 5.5 < stamps[-1] - stamps[0] < 6.5            # ... yet the log spans the mission's 6 s
    assert np.all(np.diff(stamps) >= 0)
    assert senders.get(1, 0) > 100 and senders.get(255, 0) >= 3   # downlink and uplink
