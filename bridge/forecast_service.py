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

__all__ = ["ForecastService", "append_record"]


def append_record(t: np.ndarray, eta: np.ndarray, rec_t: np.ndarray, rec_eta: np.ndarray,
                  dt: float) -> tuple[np.ndarray, np.ndarray]:
    """The held record (t, η) with a newly received one appended: overlaps and replays dropped, and
    samples the buoy lost (a jump of more than one step dt (s) on its grid) filled in as NaN, so the
    record stays on its uniform grid and DSWP fits around the gap (``allow_gaps``)."""
    keep = rec_t > (t[-1] if t.size else -np.inf)
    rec_t, rec_eta = rec_t[keep], rec_eta[keep]
    if t.size and rec_t.size:
        missing = int(round((rec_t[0] - t[-1]) / dt)) - 1
        if missing > 0:
            rec_t = np.concatenate([t[-1] + dt * np.arange(1, missing + 1), rec_t])
            rec_eta = np.concatenate([np.full(missing, np.nan), rec_eta])
    return np.concatenate([t, rec_t]), np.concatenate([eta, rec_eta])


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
    def _take_buoy(self, payload: bytes) -> bool:
        """Append one buoy record to the held one; False if it was rejected."""
        try:
            rec = decode_buoy(payload)
        except BuoyDecodeError:
            self.counters["buoy_rejected"] += 1
            return False
        self.counters["buoy_records"] += 1
        self._t, self._eta = append_record(self._t, self._eta, rec.t, rec.eta, rec.dt)
        cut = self._t > self._t[-1] - 2.0 * self.window
        self._t, self._eta = self._t[cut], self._eta[cut]
        self.buoy_x = rec.x
        self.now = float(self._t[-1])
        return True

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
                                     window_s=self.window, deep_water=self.deep_water, oversample=2, seq=self.seq,
                                     allow_gaps=True)
        except ValueError as exc:
            self.counters["predict_failed"] += 1
            self.last_error = str(exc)
            return None

    def step(self) -> bool:
        """Take buoy data, publish when due, answer queries. Never blocks; True if a buoy record came.

        Publishing is paced on the vehicle's clock (the buoy's time), every
        1/rate_hz seconds of it, so a simulation run faster than real time gets
        its forecasts as often, in its own time, as a real-time one: each record
        is taken on its own and followed by the forecast it makes due, however
        many records a step finds queued (a mission flown at full speed sends
        them faster than one step of :meth:`run` apart).
        """
        took = False
        while (sample := self._buoy.try_recv()) is not None:
            if self._take_buoy(sample.payload.to_bytes()):
                took = True
                self._publish_if_due()
        while True:
            q = self._queries.try_recv()
            if q is None:
                break
            self.counters["queries"] += 1
            if self.latest is not None:
                q.reply(self._latest_key, self.latest)
        return took

    def _publish_if_due(self) -> None:
        """Publish a forecast if 1/rate_hz of the vehicle's clock has passed since the last one."""
        if self.now is not None and self.now >= self._next_publish:
            self._next_publish = self.now + self.period
            f = self.make_forecast()
            if f is not None:
                self.latest = encode_forecast(f)
                self._pub.put(self.latest)
                self.counters["published"] += 1

    def run(self, stop: threading.Event, tick_s: float = 0.02, busy_tick_s: float = 0.002) -> None:
        """Step until ``stop``: every ``tick_s`` (wall s) when idle, every ``busy_tick_s`` while records
        arrive (a vehicle at full speed sends one every few ms; the idle rate would delay each forecast
        by up to ``tick_s`` of wall time, seconds of its clock)."""
        while not stop.is_set():
            stop.wait(busy_tick_s if self.step() else tick_s)

    def close(self) -> None:
        for h in (self._token, self._pub, self._buoy, self._queries):
            with contextlib.suppress(Exception):
                h.undeclare()
