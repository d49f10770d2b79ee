"""The BlueOS extension's cost, to size its container's limits (the permissions label's CpuQuota and Memory).

    python -m benchmarks.bench_blueos        # writes benchmarks/results/blueos.json (about 4 min)

The extension's entry point (``python -m blueos.main``, web server and companion in one process) flies the
ArduSub stand-in (Wavekeep's firmware and plant, real time) through a router stand-in, engaged from its API,
for each law (C-PD; C-PD+FF and the preview MPC on a forecast over zenoh), as the image runs it
(``WAVEKEEP_NUMBA=0``: no numba in the image) and with numba. The page's poll (twice a second) runs
throughout. Per law: CPU per control tick while engaged (its share of a core at 20 Hz) and the process's
peak resident memory. Uses the tests' rig (tests/blueos_rig.py).
"""
from __future__ import annotations

import json
import os
import sys
import tempfile
import time
from pathlib import Path

from benchmarks.common import write

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
from blueos_rig import Extension, ForecastPublisher, RouterStandIn, StandIn

LOOP_HZ = 20.0
HOLD_S = 45.0


def run(law: str, numba: str) -> dict:
    os.environ["WAVEKEEP_NUMBA"] = numba          # the extension's environment (the rig copies os.environ)
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        router, publisher = RouterStandIn(), ForecastPublisher()
        vehicle = StandIn(tmp, router.vehicle_port)
        (tmp / "data").mkdir()
        (tmp / "data" / "settings.json").write_text(json.dumps({"law": law, "forecast_endpoint": publisher.endpoint}))
        ext = Extension(tmp, f"udpout:127.0.0.1:{router.port}", "--register-endpoint", "none")
        try:
            ext.wait(lambda s: s["headline"].startswith("ready"), 120, "ready")
            vehicle.arm()
            ext.wait(lambda s: s["link"]["armed"], 10, "armed")
            code, body = ext.call("POST", "v1/engage")
            assert code == 200, body
            time.sleep(5.0)                       # past the first ticks' one-off costs
            a = ext.status()["process"]
            end = time.monotonic() + HOLD_S
            while time.monotonic() < end:
                s = ext.status()
                time.sleep(0.5)
            b = s["process"]
            assert s["control"]["engaged"], s["events"]
        finally:
            ext.stop()
            vehicle.close()
            router.close()
            publisher.close()
    per_tick = (b["cpu_s"] - a["cpu_s"]) / (b["ticks"] - a["ticks"])
    return {"law": law, "numba": numba != "0", "ticks": b["ticks"] - a["ticks"], "cpu_ms_per_tick": per_tick * 1e3,
            "core_share_at_20hz": per_tick * LOOP_HZ, "rss_mb": b["rss_mb"], "rss_peak_mb": b["rss_peak_mb"]}


def main() -> None:
    rows = [run(law, numba) for numba in ("0", "1") for law in ("cpd", "cpd_ff", "mpc")]
    print(write("blueos", {"runs": rows, "hold_s": HOLD_S}))
    for r in rows:
        print(r)


if __name__ == "__main__":
    main()
