"""The vehicle's end of the forecast link: zenoh in, the :class:`ForecastHandoff` out.

:meth:`ZenohForecastLink.poll` runs as a scheduler task. It never blocks: the
forecast subscriber keeps only the newest sample (``RingChannel(1)``, docs/platform-notes.md)
and the liveliness subscriber a short FIFO; both are read with ``try_recv``.
Every payload goes through :func:`~bridge.forecast_codec.decode_forecast`; a
rejected one is counted by reason and never reaches the control task. The
service's liveliness token appearing or vanishing is reported as a STATUSTEXT.
A vehicle that joins after the last publication catches up by asking the
service's queryable (``…/forecast/latest``) for its newest forecast.
Whether the feed-forward runs is decided by the forecast's own validity window
(:meth:`ForecastHandoff.current`): when the service dies, FF goes off as soon as
the last forecast it sent expires.
"""
from __future__ import annotations

import contextlib
import time
from collections import Counter
from collections.abc import Callable

from bridge.forecast_codec import ForecastDecodeError, decode_forecast
from bridge.keys import forecast_key, forecast_latest_key, service_token_key

from ..modes import MAV_SEVERITY
from .handoff import ForecastHandoff

__all__ = ["ZenohForecastLink"]


class ZenohForecastLink:
    def __init__(self, session, site: str, handoff: ForecastHandoff,
                 say: Callable[[int, str], None] = lambda severity, text: None):
        import zenoh

        self.handoff = handoff
        self.say = say
        self._session = session
        self._latest_key = forecast_latest_key(site)
        self._replies = None
        self._last_query = -float("inf")
        self._sub = session.declare_subscriber(forecast_key(site), zenoh.handlers.RingChannel(1))
        self._live = session.liveliness().declare_subscriber(service_token_key(site), history=True,
                                                             handler=zenoh.handlers.FifoChannel(16))
        self.received = 0
        self.accepted = 0
        self.rejected: Counter[str] = Counter()
        self.service_alive = False

    def _ask_latest(self) -> None:
        """Ask the service's queryable for its newest forecast (a late joiner's catch-up); at most once a second."""
        import zenoh

        now = time.monotonic()
        if now - self._last_query < 1.0:
            return
        self._last_query = now
        try:
            self._replies = self._session.get(self._latest_key, handler=zenoh.handlers.FifoChannel(4), timeout=1.0)
        except Exception:
            self._replies = None

    def _take(self, payload: bytes) -> None:
        self.received += 1
        try:
            forecast = decode_forecast(payload)
        except ForecastDecodeError as exc:
            self.rejected[exc.reason] += 1
            return
        current = self.handoff.newest()
        if current is not None and forecast.valid_until < current.valid_until:
            self.rejected["superseded"] += 1      # older than what the vehicle already has
            return
        self.accepted += 1
        self.handoff.offer(forecast)

    def poll(self, _slot_ns: int = 0) -> None:
        """Take the newest forecast and any liveliness change; never blocks."""
        while True:
            change = self._live.try_recv()
            if change is None:
                break
            alive = str(change.kind).endswith("PUT")
            if alive != self.service_alive:
                self.service_alive = alive
                self.say(MAV_SEVERITY.INFO if alive else MAV_SEVERITY.WARNING,
                         "Forecast service up" if alive else "Forecast service lost")
        sample = self._sub.try_recv()
        if sample is not None:
            self._take(sample.payload.to_bytes())
        if self.handoff.newest() is None and self.service_alive:
            self._ask_latest()
        if self._replies is not None:
            try:
                reply = self._replies.try_recv()
            except Exception:
                self._replies, reply = None, None
            if reply is not None and reply.ok is not None:
                self._take(reply.ok.payload.to_bytes())

    def counters(self) -> dict:
        return {"received": self.received, "accepted": self.accepted, "rejected": dict(self.rejected),
                "service_alive": self.service_alive}

    def close(self) -> None:
        for h in (self._sub, self._live):
            with contextlib.suppress(Exception):
                h.undeclare()
