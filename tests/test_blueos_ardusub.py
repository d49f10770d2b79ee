"""A full flight on the real ArduSub SITL (``WAVEKEEP_ARDUSUB``) in Wavekeep's world: the extension's entry
point, started as its container starts it, registers its router endpoint with BlueOS (a real HTTP stand-in
of the ArduPilot manager), reaches ArduSub through that endpoint type (a UDP server of a router stand-in,
which relays ArduSub's SERIAL1 link), is engaged from the page's API, dives to the station and holds it, and
hands back on the pilot's disarm. Its CPU per control tick and its memory are measured on the way and checked
against the container's limits (the permissions label). Skips without the binary."""
from __future__ import annotations

import json
import math

import pytest
from ardusub_sitl import GUIDED, MANUAL, STALE_S, SubRig, ardusub_binary
from blueos_rig import BlueOSStub, Extension, RouterStandIn
from test_blueos_package import labels

pytestmark = pytest.mark.processes
LOOP_HZ = 20.0
SPEEDUP = 3.0
"""ArduSub's SIM_SPEEDUP while the companion flies: its link runs on the wall clock (tests/ardusub_sitl.py)."""


def test_the_extension_flies_the_real_ardusub_engaged_from_the_page_and_hands_back_on_disarm(tmp_path):
    binary = ardusub_binary()
    rig = SubRig(tmp_path, binary, speedup=8.0)
    router, blueos = RouterStandIn(vehicle_port=rig.companion_port), BlueOSStub()
    ext = None
    try:
        rig.mode(GUIDED)                                   # accepted once ArduSub's EKF has a position
        rig.mode(MANUAL)
        rig.gcs.set_param("SIM_SPEEDUP", SPEEDUP)
        ext = Extension(tmp_path, f"udpout:127.0.0.1:{router.port}", "--register-endpoint", blueos.url,
                        "--stale", f"{STALE_S:g}")
        s = ext.wait(lambda s: s["link"]["ok"] and s["headline"].startswith("ready"), 120, "the link")
        assert [(e["connection_type"], e["argument"]) for e in blueos.endpoints] == [("udpin", router.port)]
        assert "registered" in s["link"]["router_endpoint"]
        rig.arm()
        ext.wait(lambda s: s["link"]["armed"] and s["link"]["mode"] == "MANUAL", 10, "armed")
        assert ext.call("POST", "v1/engage") == (200, {"ok": True, "message": "engaged"})
        start = ext.status()["process"]
        assert rig.wait_truth(lambda t: abs(t.eta[1] - 5.0) < 0.3, 40.0), rig.truth.eta        # dives to the station
        rig.run_for(5.0)                                                                          # and holds it
        s = ext.status()
        assert s["control"]["engaged"] and not any("released" in e for e in s["events"]), s["events"]
        assert abs(rig.truth.eta[1] - 5.0) < 0.5 and abs(math.degrees(rig.truth.eta[2])) < 15.0, rig.truth.eta
        _check_within_limits(start, s["process"])
        rig.arm(False)                                                                            # the pilot
        s = ext.wait(lambda s: not s["control"]["engaged"], 5, "the hand-back")
        assert "WK: released overrides (disarmed)" in s["events"]
        assert router.said(lambda t: t.startswith("WK: engaged (rc)")), router.texts
        assert router.said(lambda t: t == "WK: released overrides (disarmed)"), router.texts
    finally:
        if ext is not None:
            assert ext.stop() == 0, ext.log()
        router.close()
        blueos.close()
        rig.close()


def _check_within_limits(start: dict, end: dict) -> None:
    """CPU per tick (at the loop rate: the share of a core in real time) and memory, against the image's limits."""
    host = json.loads(labels()["permissions"])["HostConfig"]
    ticks = end["ticks"] - start["ticks"]
    per_tick = (end["cpu_s"] - start["cpu_s"]) / ticks
    share = per_tick * LOOP_HZ
    print(f"\nextension on ArduSub: {ticks} ticks, {per_tick * 1e3:.2f} ms CPU a tick = {share:.1%} of a core at "
          f"{LOOP_HZ:g} Hz; RSS {end['rss_mb']:.0f} MB")
    assert ticks > 100
    assert share < 0.5 * host["CpuQuota"] / host["CpuPeriod"], share
    assert end["rss_mb"] * 2**20 < 0.6 * host["Memory"], end["rss_mb"]
