"""Companion mode timing: the companion's control tick and its telemetry-to-command latency.

    python -m benchmarks.bench_companion        # writes benchmarks/results/companion.json

A 60 s ``wavekeep sim --companion`` (W1, C-PD+FF exact, both methods) in
lockstep: the companion's control-task compute time (p50/p99/max) and the wall
time from the arrival of a tick's ATTITUDE to the RC_CHANNELS_OVERRIDE it
causes (p50/p99). The vehicle applies that command at its next tick: one
50 ms tick of latency in vehicle time, which WK_OUT_DELAY compensates.
"""
from __future__ import annotations

import socket
import tempfile

from benchmarks.common import write
from sitl.harness.companion_launch import launch_companion
from sitl.harness.launcher import SimOptions
from sitl.harness.ports import free_port
from sitl.harness.spec import RunSpec


def run(method: str, duration: float = 60.0) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        opt = SimOptions(RunSpec(case="W1", controller="cpd_ff", duration=duration), out=tmp,
                         plant_port=free_port(), gcs_port=free_port(), zenoh_port=free_port(socket.SOCK_STREAM))
        r = launch_companion(opt, method, free_port())
    tick = r["control_tick"] or {}
    return {"companion_tick_compute_us": tick, "telemetry_to_command_ms": r["companion"]["telemetry_to_command_ms"],
            "speed_x_realtime": r["speed_x_realtime"], "rmse": r["rmse"]}


def main() -> None:
    figures = {m: run(m) for m in ("rc", "servo")}
    print(write("companion", figures))
    for m, f in figures.items():
        print(m, f["companion_tick_compute_us"], f["telemetry_to_command_ms"])


if __name__ == "__main__":
    main()
