"""The plant's wave buoy on zenoh: the elevation record at the up-wave buoy, published as simulated time passes.

Call :meth:`BuoyPublisher.advance` with the simulation time after each plant
step; every ``publish_every_s`` of simulated time the samples taken since the
last message (on the buoy's own sample grid) go out on
``wavekeep/<site>/buoy/elevation`` (:mod:`bridge.buoy_codec`).

The buoy's errors (the sea config's ``buoy`` section, docs/sea-errors.md) are the in-process
ones: the samples carry its noise and its clock's stamps, a sample is sent once it has been
measured on the vehicle's clock, and a lost sample is simply not sent (a record holds only
contiguous samples, so a gap splits a message in two; the service marks the gap as lost).
"""
from __future__ import annotations

import contextlib

import numpy as np

from bridge.buoy_codec import BuoyRecord, encode_buoy
from bridge.keys import buoy_key

from .sea import Sea

__all__ = ["BuoyPublisher"]


def _contiguous(present: np.ndarray) -> list[slice]:
    """The runs of consecutive True in ``present``, as slices."""
    if present.all():
        return [slice(0, present.size)]
    edges = np.flatnonzero(np.diff(np.concatenate([[0], present.astype(np.int8), [0]])))
    return [slice(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)]


class BuoyPublisher:
    def __init__(self, session, site: str, sea: Sea, publish_every_s: float = 0.5, history_s: float = 300.0,
                 clock_offset_s: float = 0.0):
        self.buoy = sea.buoy()
        # The vehicle's clock at the sea's t = 0 (a plant whose sea starts late, ``--sea-start``): the samples
        # are measured on the sea's time and stamped on the vehicle's
        self.clock_offset = float(clock_offset_s)
        self.dt = 1.0 / self.buoy.sample_rate
        self.every = float(publish_every_s)
        self.history = int(round(history_s / self.dt))
        self._pub = session.declare_publisher(buoy_key(site))
        # The buoy has been recording before the mission starts: the first message carries
        # ``history_s`` of record before t = 0, so a predictor can forecast from the start.
        self._next_sample = -self.history  # index of the next sample on the buoy grid
        self._last_publish_t = -np.inf
        self.seq = 0
        self.published = 0

    def reset(self) -> None:
        self._next_sample = -self.history
        self._last_publish_t = -np.inf

    def advance(self, t: float) -> None:
        """Publish the samples up to simulated time t (s) if a message is due."""
        if t - self._last_publish_t < self.every and self._last_publish_t > -np.inf:
            return
        last = int(np.floor(t / self.dt + 1e-9)) if not self.buoy.errors.active else \
            int(round(self.buoy.newest_stamp(t) / self.dt))
        if last < self._next_sample:
            return
        times = np.arange(self._next_sample, last + 1) * self.dt
        eta = self.buoy.measure(times)
        for run in _contiguous(np.isfinite(eta)):
            self.seq += 1
            t0 = float(times[run][0]) + self.clock_offset
            self._pub.put(encode_buoy(BuoyRecord(self.buoy.x, self.dt, t0, eta[run], self.seq)))
        self._next_sample = last + 1
        self._last_publish_t = t
        self.published += 1

    def close(self) -> None:
        with contextlib.suppress(Exception):
            self._pub.undeclare()
