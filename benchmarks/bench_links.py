"""Link latencies: MAVLink COMMAND_LONG → COMMAND_ACK round trip, control tick with full telemetry,
and zenoh forecast publish → available to the control task.

    python -m benchmarks.bench_links        # writes benchmarks/results/links.json
"""
from __future__ import annotations

import os
import socket
import time

import numpy as np

from benchmarks.common import percentiles_us, write
from sitl.harness.ports import free_port as _free_port


def mavlink_round_trip(n: int = 200) -> dict:
    os.environ["MAVLINK20"] = "1"
    from pymavlink import mavutil

    from sitl.harness.live import LiveSim
    from sitl.harness.spec import RunSpec

    port = _free_port()
    gcs = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=255, dialect="ardupilotmega")
    rtt = []
    with LiveSim(RunSpec("W3", "cpd_ff"), mavlink=[f"udpout:127.0.0.1:{port}"], speedup=1.0) as sim:
        gcs.wait_heartbeat(timeout=20)
        # All streams at their defaults: full telemetry while we measure
        for _ in range(n):
            t0 = time.perf_counter()
            gcs.mav.command_long_send(1, 1, mavutil.mavlink.MAV_CMD_REQUEST_MESSAGE, 0,
                                      mavutil.mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION, 0, 0, 0, 0, 0, 0)
            while True:
                m = gcs.recv_match(type="COMMAND_ACK", blocking=True, timeout=2.0)
                if m is None or m.command == mavutil.mavlink.MAV_CMD_REQUEST_MESSAGE:
                    break
            if m is not None:
                rtt.append(time.perf_counter() - t0)
            time.sleep(0.013)   # spread the requests over the tick phase
        stats = sim.firmware.scheduler.stats()
    gcs.close()
    return {"command_ack_rtt": percentiles_us(rtt), "lost": n - len(rtt),
            "tick_with_telemetry": {k: stats["tasks"][k]["compute"] for k in ("control", "gcs")},
            "overruns": stats["overruns"], "ticks": stats["ticks"]}


def zenoh_latency(n: int = 200) -> dict:
    import zenoh

    from bridge.forecast import oracle_forecast
    from bridge.forecast_codec import encode_forecast
    from bridge.keys import forecast_key
    from bridge.zenoh_net import load_network_config, zenoh_config
    from firmware_py.forecast.handoff import ForecastHandoff
    from firmware_py.forecast.link import ZenohForecastLink
    from sitl.sea import Sea

    net = load_network_config()
    ep = f"tcp/127.0.0.1:{_free_port(socket.SOCK_STREAM)}"
    comps = Sea.load("W3").components
    transport, at_20hz = [], []
    with zenoh.open(zenoh_config(net, listen=[ep])) as shore, zenoh.open(zenoh_config(net, connect=[ep])) as vehicle:
        handoff = ForecastHandoff()
        link = ZenohForecastLink(vehicle, "bench", handoff)
        pub = shore.declare_publisher(forecast_key("bench"))
        time.sleep(0.3)
        for i in range(n):
            payload = encode_forecast(oracle_forecast(comps, None, None, valid_until=1e6 + i, seq=i + 1))
            t0 = time.perf_counter()
            pub.put(payload)
            while handoff.newest() is None or handoff.newest().seq != i + 1:
                link.poll()
                if time.perf_counter() - t0 > 1.0:
                    break
            transport.append(time.perf_counter() - t0)
            # A 20 Hz control task polls at a uniformly random phase: add the wait for its next poll
            at_20hz.append(transport[-1] + np.random.default_rng(i).uniform(0.0, 0.05))
            time.sleep(0.02)
        link.close()
    return {"payload_bytes": len(payload), "publish_to_handoff": percentiles_us(transport),
            "publish_to_control_task_20hz": percentiles_us(at_20hz)}


def main() -> dict:
    figures = {"mavlink": mavlink_round_trip(), "zenoh": zenoh_latency()}
    path = write("links", figures)
    m, z = figures["mavlink"], figures["zenoh"]
    print(f"COMMAND_LONG → ACK round trip: p50 {m['command_ack_rtt']['p50_us'] / 1e3:.1f} ms, "
          f"p99 {m['command_ack_rtt']['p99_us'] / 1e3:.1f} ms ({m['lost']} lost)")
    for k, v in m["tick_with_telemetry"].items():
        print(f"  {k} task with full telemetry: p50 {v['p50_us']:.0f} µs, p99 {v['p99_us']:.0f} µs")
    print(f"zenoh forecast ({z['payload_bytes']} B) publish → hand-off: "
          f"p50 {z['publish_to_handoff']['p50_us']:.0f} µs, "
          f"p99 {z['publish_to_handoff']['p99_us']:.0f} µs; → a 20 Hz control task: "
          f"p50 {z['publish_to_control_task_20hz']['p50_us'] / 1e3:.1f} ms, "
          f"p99 {z['publish_to_control_task_20hz']['p99_us'] / 1e3:.1f} ms")
    print(f"wrote {path}")
    return figures


if __name__ == "__main__":
    main()
