"""The shore side of the forecast link: ``wavekeep forecast --site moray --mode {oracle,dswp}``.

The service holds a liveliness token (``wavekeep/<site>/service/forecast``),
subscribes to the wave buoy's record (``wavekeep/<site>/buoy/elevation``,
published by the plant), and publishes a forecast (``wavekeep/<site>/forecast``)
``rate_hz`` times per second of the vehicle's clock; a queryable (``…/forecast/latest``) answers with the newest one.

Time: forecasts are stamped on the *vehicle's* clock. The buoy record carries
that clock (in SITL, the simulation's time), so the service's notion of "now"
is the newest buoy sample it has; until the first one arrives it publishes
nothing.

Modes:

* ``oracle`` — the simulated sea's own components (the paper's exact
  forecast), optionally with the paper's error injected once at ``snr_db``
  (:func:`~bridge.forecast.oracle_forecast`), valid from now − 1 s to
  now + ``horizon_s``;
* ``dswp`` — deterministic sea wave prediction from the buoy's record
  (:func:`~bridge.dswp.predict_from_buoy`), valid over the zone the group
  velocities allow.
"""
from __future__ import annotations

import contextlib
import threading
from dataclasses import replace

import numpy as np

from .buoy_codec import BuoyDecodeError, decode_buoy
from .forecast import Forecast
from .forecast_codec import encode_forecast
from .keys import buoy_key, forecast_key, forecast_latest_key, service_token_key

__all__ = ["ForecastService"]


class ForecastService:
    def __init__(self, session, site: str, mode: str, *, oracle: Forecast | None = None, x_vehicle: float = 0.0,
                 water_depth: float = 54.0, rate_hz: float = 1.0, horizon_s: float = 10.0,
                 dswp_window_s: float = 120.0, deep_water: bool = False):
        import zenoh

        if mode not in ("oracle", "dswp"):
            raise ValueError(f"mode must be 'oracle' or 'dswp', got {mode!r}")
        if mode == "oracle" and oracle is None:
            raise ValueError("oracle mode needs the sea's forecast")
        self.mode = mode
        self.oracle = oracle
        self.x_vehicle = float(x_vehicle)
        self.water_depth = float(water_depth)
        self.period = 1.0 / float(rate_hz)
        self.horizon = float(horizon_s)
        self.window = float(dswp_window_s)
        self.deep_water = deep_water
        self._token = session.liveliness().declare_token(service_token_key(site))
        self._pub = session.declare_publisher(forecast_key(site))
        self._buoy = session.declare_subscriber(buoy_key(site), zenoh.handlers.FifoChannel(256))
        self._queries = session.declare_queryable(forecast_latest_key(site), zenoh.handlers.FifoChannel(16))
        self._latest_key = forecast_latest_key(site)
        self.now: float | None = None          # newest buoy time (vehicle clock, s)
        self.buoy_x: float | None = None
        self._t = np.zeros(0)
        self._eta = np.zeros(0)
        self.seq = 0
        self.latest: bytes | None = None
        self.counters = {"buoy_records": 0, "buoy_rejected": 0, "published": 0, "queries": 0, "predict_failed": 0}
        self.last_error = ""
        self._next_publish = -float("inf")

    # ------------------------------------------------------------------ inputs
    def _take_buoy(self) -> None:
        while True:
            sample = self._buoy.try_recv()
            if sample is None:
                return
            try:
                rec = decode_buoy(sample.payload.to_bytes())
            except BuoyDecodeError:
                self.counters["buoy_rejected"] += 1
                continue
            self.counters["buoy_records"] += 1
            t = rec.t
            keep = t > (self._t[-1] if self._t.size else -np.inf)   # drop overlaps and replays
            self._t = np.concatenate([self._t, t[keep]])
            self._eta = np.concatenate([self._eta, rec.eta[keep]])
            cut = self._t > self._t[-1] - 2.0 * self.window
            self._t, self._eta = self._t[cut], self._eta[cut]
            self.buoy_x = rec.x
            self.now = float(self._t[-1])

    # ------------------------------------------------------------------ outputs
    def make_forecast(self) -> Forecast | None:
        if self.now is None:
            return None
        self.seq += 1
        if self.mode == "oracle":
            assert self.oracle is not None   # checked at construction
            return replace(self.oracle, valid_from=self.now - 1.0, valid_until=self.now + self.horizon, seq=self.seq)
        from .dswp import predict_from_buoy
        if self.buoy_x is None or self._t.size < 16 or self._t[-1] - self._t[0] < min(self.window, 30.0):
            return None
        sel = self._t >= self._t[-1] - self.window
        try:
            return predict_from_buoy(self._t[sel], self._eta[sel], self.buoy_x, self.x_vehicle, self.water_depth,
                                     window_s=self.window, deep_water=self.deep_water, oversample=2, seq=self.seq)
        except ValueError as exc:
            self.counters["predict_failed"] += 1
            self.last_error = str(exc)
            return None

    def step(self) -> None:
        """Take buoy data, publish when due, answer queries. Never blocks.

        Publishing is paced on the vehicle's clock (the buoy's time), every
        1/rate_hz seconds of it, so a simulation run faster than real time gets
        its forecasts as often, in its own time, as a real-time one.
        """
        self._take_buoy()
        if self.now is not None and self.now >= self._next_publish:
            self._next_publish = self.now + self.period
            f = self.make_forecast()
            if f is not None:
                self.latest = encode_forecast(f)
                self._pub.put(self.latest)
                self.counters["published"] += 1
        while True:
            q = self._queries.try_recv()
            if q is None:
                break
            self.counters["queries"] += 1
            if self.latest is not None:
                q.reply(self._latest_key, self.latest)

    def run(self, stop: threading.Event, tick_s: float = 0.02) -> None:
        while not stop.is_set():
            self.step()
            stop.wait(tick_s)

    def close(self) -> None:
        for h in (self._token, self._pub, self._buoy, self._queries):
            with contextlib.suppress(Exception):
                h.undeclare()
