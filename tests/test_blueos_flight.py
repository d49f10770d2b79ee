"""The extension's entry point, started as its container starts it, flying the ArduSub stand-in (Wavekeep's
firmware and plant, real time) through a stand-in of BlueOS's router (the UDP endpoint type it registers):
engage and release from the page's API, the pilot's mode change hands back, a refusal is said in STATUSTEXT;
a missing forecast link shows and never engages, and a forecast over real zenoh lets C-PD+FF engage."""
from __future__ import annotations

import json
import socket

import pytest
from blueos_rig import Extension, ForecastPublisher, RouterStandIn, StandIn

from sitl.harness.ports import free_port

pytestmark = pytest.mark.processes
STABILIZE = 0


@pytest.fixture
def world(tmp_path):
    router = RouterStandIn()
    vehicle = StandIn(tmp_path, router.vehicle_port)
    yield tmp_path, router, vehicle
    vehicle.close()
    router.close()


def _ready(s: dict) -> bool:
    return s["link"]["ok"] and s["headline"].startswith("ready")


def test_engage_and_release_from_the_page_and_the_pilot_takes_it_back(world):
    tmp, router, vehicle = world
    ext = Extension(tmp, f"udpout:127.0.0.1:{router.port}", "--register-endpoint", "none")
    try:
        ext.wait(_ready, 60, "the link")
        code, body = ext.call("POST", "v1/engage")
        assert code == 409 and "disarmed" in body["message"]                      # never engages disarmed
        assert router.said(lambda t: "WK: not engaged: the vehicle is disarmed" in t), router.texts
        vehicle.arm()
        ext.wait(lambda s: s["link"]["armed"], 10, "armed")
        assert ext.call("POST", "v1/engage") == (200, {"ok": True, "message": "engaged"})
        s = ext.wait(lambda s: s["control"]["errors"] is not None, 5, "errors")
        assert s["control"]["engaged"] and s["control"]["law"] == "C-PD"
        # a bad form value, and any change while engaged: refused with the reason, the control task flies on
        code, body = ext.call("PUT", "v1/settings", {"law": "pid"})
        assert code == 400 and "law 'pid'" in body["error"]
        code, body = ext.call("PUT", "v1/settings", {"method": "servo"})
        assert code == 400 and "release" in body["error"]
        ticks = ext.status()["process"]["ticks"]
        s = ext.wait(lambda s: s["process"]["ticks"] > ticks + 10, 5, "ticking")
        assert s["control"]["engaged"] and s["settings"]["method"] == "rc"
        assert ext.call("POST", "v1/release") == (200, {"ok": True, "message": "released"})
        s = ext.wait(lambda s: not s["control"]["engaged"], 5, "released")
        assert "WK: released overrides (released from the page)" in s["events"]
        assert ext.call("POST", "v1/engage")[0] == 200                            # the pilot engages again
        vehicle.mode(STABILIZE)                                                    # ... and takes over
        s = ext.wait(lambda s: not s["control"]["engaged"], 5, "mode change")
        assert "WK: released overrides (pilot selected STABILIZE)" in s["events"]
        code, body = ext.call("POST", "v1/engage")
        assert code == 409 and "select MANUAL" in body["message"]
        assert router.said(lambda t: t.startswith("WK: engaged (rc)")), router.texts
    finally:
        assert ext.stop() == 0, ext.log()
    assert "stopped after" in ext.log()


def test_a_missing_forecast_never_engages_and_a_forecast_over_zenoh_flies_the_feed_forward(world):
    tmp, router, vehicle = world
    endpoint = f"tcp/127.0.0.1:{free_port(socket.SOCK_STREAM)}"                   # nothing listens there yet
    (tmp / "data").mkdir()
    (tmp / "data" / "settings.json").write_text(json.dumps({"law": "cpd_ff", "forecast_endpoint": endpoint}))
    ext = Extension(tmp, f"udpout:127.0.0.1:{router.port}", "--register-endpoint", "none")
    publisher = None
    try:
        s = ext.wait(lambda s: s["link"]["phase"] in ("error", "running"), 60, "the session")
        assert not s["forecast"]["ok"] and not s["headline"].startswith("ready"), s
        vehicle.arm()
        code, body = ext.call("POST", "v1/engage")
        assert code == 409, body
        assert router.said(lambda t: t.startswith(("WK: companion stopped", "WK: no wave forecast"))), router.texts
        publisher = ForecastPublisher(endpoint)
        s = ext.wait(lambda s: s["forecast"]["ok"] and s["headline"].startswith("ready"), 60, "the forecast")
        assert s["forecast"]["age_s"] is not None and s["forecast"]["age_s"] < 2.0
        assert s["control"]["law"] == "C-PD+FF" and len(s["forecast"]["skill"]) == 3
        vehicle.mode(STABILIZE)                              # the session started armed: the pilot selects MANUAL
        ext.wait(lambda s: s["link"]["mode"] == "STABILIZE", 5, "STABILIZE seen")
        vehicle.mode(19)
        ext.wait(lambda s: s["link"]["mode"] == "MANUAL", 5, "MANUAL seen")
        assert ext.call("POST", "v1/engage") == (200, {"ok": True, "message": "engaged"})
        ext.wait(lambda s: s["forecast"]["ff_active"], 10, "the feed-forward")
    finally:
        assert ext.stop() == 0, ext.log()
        if publisher is not None:
            publisher.close()
