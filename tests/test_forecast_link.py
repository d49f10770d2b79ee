"""The forecast over zenoh: codec against bad input, real loopback sessions, liveliness."""
from __future__ import annotations

import contextlib
import json
import socket
import struct
import time

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from bridge.forecast import oracle_forecast
from bridge.forecast_codec import MAX_PAYLOAD, ForecastDecodeError, decode_forecast, encode_forecast
from bridge.keys import check_site, forecast_key, service_token_key
from bridge.zenoh_net import load_network_config, zenoh_config
from firmware_py.forecast.handoff import ForecastHandoff
from firmware_py.forecast.link import ZenohForecastLink
from sitl.harness.ports import free_port
from sitl.sea import Sea


@pytest.fixture(scope="module")
def forecast():
    return oracle_forecast(Sea.load("W1").components, None, None, valid_from=0.0, valid_until=60.0, seq=3)


def test_codec_round_trip_is_exact(forecast):
    g = decode_forecast(encode_forecast(forecast))
    for name in ("amplitude", "omega", "k", "phase"):
        np.testing.assert_array_equal(getattr(g, name), getattr(forecast, name))
    assert (g.seq, g.source, g.second_order, g.valid_until, g.water_depth) == (3, "oracle", True, 60.0, 54.0)


def test_a_forecast_of_a_sea_with_directions_carries_them_as_version_2(forecast):
    """The oracle of a sea from another direction (here spread about 60°) names each component's direction; it
    goes as version 2 and comes back exact, and its kinematics are the sea's; one along north stays version 1."""
    sea = Sea.load("W1", overrides={"spreading.s": 10.0, "spreading.direction": 60.0})
    f = oracle_forecast(sea.components, None, None, valid_until=60.0)
    payload = encode_forecast(f)
    version = lambda b: struct.unpack_from("<H", b, 4)[0]  # noqa: E731
    assert version(payload) == 2 and version(encode_forecast(forecast)) == 1
    g = decode_forecast(payload)
    np.testing.assert_array_equal(g.direction, sea.components.direction)
    assert decode_forecast(encode_forecast(forecast)).direction is None
    np.testing.assert_array_equal(g.components().direction, sea.components.direction)
    np.testing.assert_allclose(g.components().phase, sea.components.phase, atol=1e-12)
    with pytest.raises(ForecastDecodeError) as info:        # version 2 without its direction flag
        decode_forecast(corrupt(payload, 6, "<H", 1))
    assert info.value.reason == "bad_version"
    with pytest.raises(ForecastDecodeError) as info:
        decode_forecast(payload[:-8] + struct.pack("<d", float("nan")))
    assert info.value.reason == "bad_direction"


def corrupt(payload: bytes, offset: int, fmt: str, value) -> bytes:
    b = bytearray(payload)
    struct.pack_into(fmt, b, offset, value)
    return bytes(b)


@pytest.mark.parametrize("mutate, reason", [
    (lambda b: b[:10], "truncated"),
    (lambda b: b[:-1], "bad_length"),
    (lambda b: b"WKBY" + b[4:], "bad_magic"),          # a buoy record's magic on the forecast key
    (lambda b: corrupt(b, 4, "<H", 2), "bad_version"),
    (lambda b: corrupt(b, 16, "<I", 0), "bad_count"),
    (lambda b: corrupt(b, 20, "<d", float("nan")), "non_finite"),
    (lambda b: corrupt(b, 52, "<d", -5.0), "bad_validity"),
    (lambda b: corrupt(b, 61 + 6, "<d", float("inf")), "non_finite"),       # first amplitude
    (lambda b: corrupt(b, 61 + 6, "<d", 500.0), "absurd_amplitude"),
    (lambda b: corrupt(b, 61 + 6 + 8 * 200, "<d", -1.0), "bad_frequency"),  # first ω
    (lambda b: corrupt(b, 61 + 6 + 16 * 200, "<d", 5.0), "off_dispersion"),  # first k
    (lambda b: b + bytes(MAX_PAYLOAD), "oversized"),
])
def test_decoder_rejects_bad_payloads_with_a_reason(forecast, mutate, reason):
    with pytest.raises(ForecastDecodeError) as info:
        decode_forecast(mutate(encode_forecast(forecast)))
    assert info.value.reason == reason


@settings(max_examples=300, suppress_health_check=[HealthCheck.too_slow], deadline=None)
@given(st.binary(max_size=2048))
def test_decoder_never_crashes_on_garbage(data):
    with contextlib.suppress(ForecastDecodeError):
        decode_forecast(data)


@settings(max_examples=200, deadline=None)
@given(st.integers(min_value=0, max_value=6000), st.binary(min_size=1, max_size=8))
def test_decoder_survives_any_byte_flip(offset, junk):
    f = oracle_forecast(Sea.load("W1").components, None, None, valid_until=10.0)
    b = bytearray(encode_forecast(f))
    i = offset % len(b)
    b[i:i + len(junk)] = junk
    try:
        g = decode_forecast(bytes(b))
    except ForecastDecodeError:
        return
    assert np.all(np.isfinite(g.amplitude)) and g.valid_from <= g.valid_until


def test_site_names_cannot_change_the_key():
    assert forecast_key("moray") == "wavekeep/moray/forecast"
    for bad in ("a/b", "*", "**", "x$y", ""):
        with pytest.raises(ValueError):
            check_site(bad)




@pytest.fixture
def sessions():
    import zenoh
    net = load_network_config()
    ep = f"tcp/127.0.0.1:{free_port(socket.SOCK_STREAM)}"
    service = zenoh.open(zenoh_config(net, listen=[ep]))
    vehicle = zenoh.open(zenoh_config(net, connect=[ep]))
    try:
        yield service, vehicle
    finally:
        vehicle.close()
        service.close()


def wait_for(cond, timeout=3.0, poll=None):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if poll:
            poll()
        if cond():
            return True
        time.sleep(0.01)
    return False


def test_forecast_reaches_the_handoff_and_garbage_does_not(sessions, forecast):
    service, vehicle = sessions
    handoff = ForecastHandoff()
    said = []
    link = ZenohForecastLink(vehicle, "moray", handoff, say=lambda sev, text: said.append(text))
    pub = service.declare_publisher(forecast_key("moray"))
    time.sleep(0.2)                       # declarations propagate asynchronously (docs/platform-notes.md)
    bad = [b"garbage", b"", encode_forecast(forecast)[:-3], bytes(MAX_PAYLOAD + 10)]
    for payload in bad:
        pub.put(payload)
        assert wait_for(lambda payload=payload: link.received >= bad.index(payload) + 1, poll=link.poll)
    assert handoff.newest() is None and sum(link.rejected.values()) == len(bad)
    pub.put(encode_forecast(forecast))
    assert wait_for(lambda: handoff.newest() is not None, poll=link.poll)
    assert handoff.current(30.0).forecast.seq == 3
    assert handoff.current(61.0) is None  # stale after its validity
    link.close()


def test_a_forecast_that_expires_sooner_than_the_one_held_is_refused_as_superseded(sessions):
    """docs/forecast.md: a late or reordered forecast that expires before the held one never replaces it
    (the feed-forward keeps the longer window); one that expires as late or later does."""
    service, vehicle = sessions
    handoff = ForecastHandoff()
    link = ZenohForecastLink(vehicle, "moray", handoff)
    pub = service.declare_publisher(forecast_key("moray"))
    time.sleep(0.2)                       # declarations propagate asynchronously (docs/platform-notes.md)
    sea = Sea.load("W1").components
    # (seq, valid_until, taken): each is published once the previous one has been received
    steps = [(3, 60.0, True), (4, 30.0, False), (5, 59.5, False), (6, 60.0, True), (7, 90.0, True)]
    for n, (seq, until, _) in enumerate(steps, start=1):
        pub.put(encode_forecast(oracle_forecast(sea, None, None, valid_from=0.0, valid_until=until, seq=seq)))
        assert wait_for(lambda n=n: link.received >= n, poll=link.poll), (seq, link.counters())
        held = max(s for s, _, taken in steps[:n] if taken)
        assert handoff.newest().seq == held, (seq, link.counters())
        assert handoff.current(45.0).forecast.seq == held     # the FF keeps running on the held one
    assert link.rejected == {"superseded": 2} and link.accepted == 3
    link.close()


def test_liveliness_of_the_service_is_reported(sessions):
    service, vehicle = sessions
    said = []
    link = ZenohForecastLink(vehicle, "moray", ForecastHandoff(), say=lambda sev, text: said.append(text))
    token = service.liveliness().declare_token(service_token_key("moray"))
    assert wait_for(lambda: link.service_alive, poll=link.poll)
    token.undeclare()
    assert wait_for(lambda: not link.service_alive, poll=link.poll)
    assert said == ["Forecast service up", "Forecast service lost"]
    link.close()


def test_poll_never_blocks(sessions):
    _, vehicle = sessions
    link = ZenohForecastLink(vehicle, "moray", ForecastHandoff())
    t0 = time.perf_counter()
    for _ in range(1000):
        link.poll()
    assert (time.perf_counter() - t0) / 1000 < 2e-3
    link.close()


def test_network_config_defaults_to_loopback():
    net = load_network_config()
    eps = net["zenoh"]["service_listen"] + net["zenoh"]["connect"]
    assert eps and all("127.0.0.1" in e for e in eps)
    assert net["zenoh"]["multicast_scouting"] is False
    cfg = zenoh_config(net, listen=["tcp/127.0.0.1:1"])
    assert json.loads(cfg.get_json("scouting/multicast/enabled")) is False


def test_service_oracle_forecasts_follow_the_buoy_clock_and_die_with_the_service(sessions):
    """Plant-side buoy → service (oracle) → vehicle subscriber; the service going away is
    reported, and its last forecast stops being valid at the end of its window."""
    from bridge.forecast_service import ForecastService
    from sitl.buoy_publisher import BuoyPublisher

    service_session, vehicle = sessions
    sea = Sea.load("W2")
    exact = oracle_forecast(sea.components, None, None)
    svc = ForecastService(service_session, "moray", "oracle", oracle=exact, rate_hz=50.0, horizon_s=2.0)
    buoy = BuoyPublisher(vehicle, "moray", sea, publish_every_s=0.5)
    handoff = ForecastHandoff()
    said = []
    link = ZenohForecastLink(vehicle, "moray", handoff, say=lambda s, text: said.append(text))
    time.sleep(0.2)
    t = 0.0
    for _ in range(60):                         # 3 s of simulated time in 50 ms steps
        t += 0.05
        buoy.advance(t)
        svc.step()
        link.poll()
        time.sleep(0.005)
    assert wait_for(lambda: handoff.newest() is not None, poll=lambda: (svc.step(), link.poll()))
    f = handoff.newest()
    assert f.valid_until == pytest.approx(svc.now + 2.0) and svc.now <= t + 1e-9
    np.testing.assert_array_equal(f.phase, exact.phase)
    assert handoff.current(svc.now) is not None
    # The service dies: liveliness is lost, and after its window the forecast is stale
    svc.close()
    assert wait_for(lambda: not link.service_alive, poll=link.poll)
    assert "Forecast service lost" in said
    assert handoff.current(f.valid_until + 0.05) is None
    buoy.close()
    link.close()


class _Queue:
    """A zenoh handler's receiver, or a publisher, without zenoh: what was put, taken in order."""

    def __init__(self, items=()):
        self.items = list(items)

    def try_recv(self):
        return self.items.pop(0) if self.items else None

    def put(self, payload: bytes) -> None:
        self.items.append(payload)

    def undeclare(self) -> None:
        pass


class _Sample:
    def __init__(self, payload: bytes):
        self.payload = self
        self._bytes = payload

    def to_bytes(self) -> bytes:
        return self._bytes


def test_a_forecast_for_every_period_however_many_buoy_records_a_step_finds(forecast):
    """A mission at full speed sends buoy records faster than the service's poll: each record is taken
    on its own and followed by the forecast it makes due, as in a real-time run (one a period)."""
    from types import SimpleNamespace

    from bridge.buoy_codec import BuoyRecord, encode_buoy
    from bridge.forecast_service import ForecastService

    buoy, pub = _Queue(), _Queue()
    session = SimpleNamespace(liveliness=lambda: SimpleNamespace(declare_token=lambda key: _Queue()),
                              declare_publisher=lambda key: pub, declare_queryable=lambda key, handler: _Queue(),
                              declare_subscriber=lambda key, handler: buoy)
    svc = ForecastService(session, "moray", "oracle", oracle=forecast, rate_hz=2.0, horizon_s=10.0)
    dt = 0.25
    for i in range(6):                          # six 0.5 s records, all queued before one step
        eta = np.full(2, 0.1 * i)
        buoy.items.append(_Sample(encode_buoy(BuoyRecord(-200.0, dt, 0.5 * i, eta, i + 1))))
    assert svc.step() is True and svc.step() is False
    assert svc.counters["buoy_records"] == 6 and svc.counters["published"] == 6
    assert [decode_forecast(p).valid_until for p in pub.items] == [0.25 + 0.5 * i + 10.0 for i in range(6)]
