"""Soak: a long mission at full speed with every fault injector on (a benchmark, not CI).

    python -m benchmarks.bench_soak [--sim-seconds 3600]    # writes benchmarks/results/soak.json

The world (JSON SITL physics server) and the firmware (JSON SITL HAL, MAVLink
link) are wired through fault-injecting relays:

* firmware ↔ plant: 2 % drops, duplicates and reorders each way, 0–2 ms delay;
* firmware ↔ ground station: the same, plus garbage bytes and valid-CRC
  messages with hostile fields sent by an attacker endpoint every second;
* the forecast hand-off: a corrupt payload offered through the decoder every 5 s.

The ground station (pymavlink) arms the vehicle in GUIDED on the station,
writes every message it receives to a .tlog, and at the end the .tlog is read
back with pymavlink's log reader. Reported: crashes (task errors; must be 0),
ticks missed, messages rejected per surface, the .tlog's completeness, and the
vehicle's excursions.
"""
from __future__ import annotations

import argparse
import os
import struct
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from benchmarks.common import write
from sitl.harness.ports import free_port as _free_port


def main(sim_seconds: float = 3600.0, case: str = "W3") -> dict:
    os.environ["MAVLINK20"] = "1"
    from pymavlink import mavutil

    from bridge.forecast import derive_seeds, oracle_forecast
    from bridge.forecast_codec import ForecastDecodeError, decode_forecast, encode_forecast
    from bridge.schemas import load_mission_config, load_vehicle_config
    from firmware_py.firmware import Firmware
    from firmware_py.hal.json_sitl import JSONSITLHAL
    from firmware_py.hal.scheduler import Task
    from firmware_py.mavlink import MavlinkLink
    from firmware_py.modes import Mode
    from firmware_py.params.table import load_params
    from sitl.faultrelay import FaultRelay, Faults
    from sitl.physics_server import PhysicsServer
    from sitl.plant import Plant
    from sitl.sea import Sea

    sea = Sea.load(case)
    mcfg, vcfg = load_mission_config("station_keeping"), load_vehicle_config("bluerov2_heavy")
    params = load_params(overrides={"FS_GCS_ENABLE": 0, "SIM_JSON_TMO": 0.05})
    rate = mcfg["control_rate"]
    sp = mcfg["setpoint"]
    setpoint = np.array([sp["x"], sp["depth"], sp["pitch"]])
    faults = Faults(drop=0.02, duplicate=0.02, reorder=0.02, delay_s=0.0, jitter_s=0.002)

    server = PhysicsServer(lambda: Plant.from_configs(sea), port=0).start()
    plant_relay = FaultRelay(("127.0.0.1", server.port), faults, seed=11).start()
    gcs_port = _free_port()
    gcs_relay = FaultRelay(("127.0.0.1", gcs_port), faults, seed=12).start()
    sensor_seed, forecast_seed = derive_seeds(sea.seed)
    hal = JSONSITLHAL(("127.0.0.1", plant_relay.port), params, 1.0 / rate, sensor_seed, timeout_s=0.05)
    fw = Firmware.from_configs(hal, params, vcfg, mcfg)
    good = encode_forecast(oracle_forecast(sea.components, None, np.random.default_rng(forecast_seed)))
    fw.forecast.offer(decode_forecast(good))
    link = MavlinkLink(fw, [f"udpout:127.0.0.1:{gcs_relay.port}"])
    fw.add_task(Task("gcs", rate, link.update))
    forecast_rejected = {"n": 0}

    def forecast_attack(slot_ns: int) -> None:            # every 5 s of vehicle time: a corrupt forecast
        if (slot_ns // 50_000_000) % 100:
            return
        bad = bytearray(good)
        first_amplitude = 61 + good[60]                   # after the header and the source name
        bad[first_amplitude:first_amplitude + 8] = struct.pack("<d", float("nan"))
        try:
            fw.forecast.offer(decode_forecast(bytes(bad)))
        except ForecastDecodeError:
            forecast_rejected["n"] += 1
    fw.add_task(Task("attack", rate, forecast_attack))

    tmp = Path(tempfile.mkdtemp(prefix="wavekeep-soak-"))
    tlog_path = tmp / "soak.tlog"
    gcs = mavutil.mavlink_connection(f"udpin:127.0.0.1:{gcs_port}", source_system=255, dialect="ardupilotmega")
    stop = threading.Event()
    received = {"n": 0}

    def ground_station() -> None:
        with open(tlog_path, "wb") as tlog:
            last_attack = 0.0
            while not stop.is_set():
                m = gcs.recv_match(blocking=True, timeout=0.05)
                if m is not None and m.get_type() != "BAD_DATA":
                    tlog.write(struct.pack(">Q", int(time.time() * 1e6) & ~3) + m.get_msgbuf())
                    received["n"] += 1
                now = time.monotonic()
                if now - last_attack > 1.0:       # garbage and hostile fields at the vehicle's link
                    last_attack = now
                    if received["n"] > 0:
                        gcs.write(os.urandom(64))
                        gcs.mav.manual_control_send(1, 32767, -32768, 32767, -32768, 0)
                        gcs.mav.param_set_send(1, 1, b"WK_PD_KP_X", float("nan"),
                                               mavutil.mavlink.MAV_PARAM_TYPE_REAL32)
    gcs_thread = threading.Thread(target=ground_station, daemon=True)

    wall0 = time.monotonic()
    hal.start()
    link.start()
    gcs_thread.start()
    fw.scheduler.run_tick()
    fw.request_mode(Mode.GUIDED)
    fw.set_target(*setpoint)
    fw.request_arm(True)
    n = int(sim_seconds * rate)
    max_dev = np.zeros(3)
    for _ in range(n):
        fw.scheduler.run_tick()
        s = hal.state
        if s is not None:
            max_dev = np.maximum(max_dev, np.abs(s.eta - setpoint))
    wall = time.monotonic() - wall0
    time.sleep(0.5)
    stop.set()
    gcs_thread.join(5)
    link.stop()
    hal.close()
    gcs_relay.stop()
    plant_relay.stop()
    server.stop()
    gcs.close()

    # Read the .tlog back with pymavlink's log reader
    log = mavutil.mavlink_connection(str(tlog_path), dialect="ardupilotmega")
    in_log, kinds = 0, set()
    while True:
        m = log.recv_match()
        if m is None:
            break
        in_log += 1
        kinds.add(m.get_type())
    stats = fw.scheduler.stats()
    figures = {
        "sim_seconds": sim_seconds, "wall_seconds": wall, "case": case,
        "crashes": sum(t.get("errors", 0) for t in stats["tasks"].values()),
        "ticks": stats["ticks"], "overruns": stats["overruns"], "skipped_slots": stats["skipped_slots"],
        "plant_link": {"hal": hal.counters.__dict__ if hasattr(hal.counters, "__dict__") else str(hal.counters),
                       "server": server.counters.as_dict(), "relay": plant_relay.counters()},
        "gcs_link": {"link": dict(link.counters), "relay": gcs_relay.counters()},
        "forecast_rejected": forecast_rejected["n"],
        "ekf_rejected": dict(fw.ekf.rejected), "ekf_resets": dict(fw.ekf.resets),
        "tlog": {"received": received["n"], "read_back": in_log, "complete": in_log == received["n"],
                 "message_types": sorted(kinds)},
        "max_excursion": {"x_m": float(max_dev[0]), "depth_m": float(max_dev[1]),
                          "pitch_deg": float(np.degrees(max_dev[2]))},
        "armed_at_end": fw.armed, "mode_at_end": int(fw.mode),
    }
    path = write("soak", figures)
    print(f"soak: {sim_seconds:g} s of {case} in {wall:.0f} s wall; crashes {figures['crashes']}; "
          f"ticks {figures['ticks']} (overruns {figures['overruns']})")
    print(f"  plant link: {figures['plant_link']['server']}; relay {figures['plant_link']['relay']}")
    print(f"  GCS link: {figures['gcs_link']['link']}")
    print(f"  forecasts rejected {forecast_rejected['n']}; EKF rejected {figures['ekf_rejected']}")
    print(f"  tlog: {in_log} of {received['n']} messages read back; max excursion {figures['max_excursion']}")
    print(f"wrote {path}")
    return figures


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--sim-seconds", type=float, default=3600.0)
    ap.add_argument("--case", default="W3")
    a = ap.parse_args()
    main(a.sim_seconds, a.case)
