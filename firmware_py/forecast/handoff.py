"""The forecast hand-off: the newest valid forecast, for the control task, without ever blocking it.

Writers (an in-process feeder today, the zenoh subscriber later) call
:meth:`ForecastHandoff.offer` from any thread; the control task calls
:meth:`ForecastHandoff.current` once per tick. The slot holds one immutable
:class:`~bridge.forecast.Forecast`; replacing it is a single reference
assignment, atomic in CPython, so neither side takes a lock. The hand-off
also caches the forecast's kinematic components, rebuilt only when a new
forecast arrives.
"""
from __future__ import annotations

from dataclasses import dataclass

from bridge.forecast import Forecast
from bridge.models.waves import WaveComponents

__all__ = ["ActiveForecast", "ForecastHandoff"]


@dataclass(frozen=True)
class ActiveForecast:
    forecast: Forecast
    components: WaveComponents


class ForecastHandoff:
    def __init__(self) -> None:
        self._slot: Forecast | None = None
        self._active: ActiveForecast | None = None
        self.offered = 0

    def offer(self, forecast: Forecast) -> None:
        """Make ``forecast`` the newest (any thread)."""
        self._slot = forecast
        self.offered += 1

    def newest(self) -> Forecast | None:
        """The newest forecast offered, valid or not."""
        return self._slot

    def current(self, t: float) -> ActiveForecast | None:
        """The newest forecast if it is valid at vehicle time t (s), else None. Control-task side."""
        f = self._slot
        if f is None or not f.is_valid_at(t):
            return None
        active = self._active
        if active is None or active.forecast is not f:
            active = ActiveForecast(f, f.components())
            self._active = active
        return active
