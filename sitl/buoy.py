"""The up-wave wave buoy, and the errors of a real one (white noise, lost samples, a clock offset).

A :class:`WaveBuoy` records the sea's elevation ζ(x_b, t) (m, up positive) at
its position x_b (m, NED north, up-wave of the vehicle), sampled at
``sample_rate`` Hz on its own grid t_n = n/f_s. With :class:`BuoyErrors` the
record is the one a real buoy would send (docs/sea-errors.md):

* **White noise** at an SNR (dB) against the realised sea's linear variance
  m₀ = Σ A_i²/2: σ_n² = m₀ · 10^(−SNR/10), independent from sample to sample.
* **Dropouts**: each sample is lost (NaN) with probability p, independently.
* **Clock offset** δ (s) = buoy clock − vehicle clock: the sample stamped t on
  the buoy's clock was measured at vehicle time t − δ, so the stamped record is
  ζ(x_b, t − δ). DSWP takes the stamps as the vehicle's time, so every
  predicted component is off by a phase ω δ.

The noise and the losses of sample n are drawn from a stream of its own (the
seed, the stream tag and the block of 1024 samples that holds n), so a sample
reads the same in every overlapping window a forecaster asks for, whatever
the windows: records stay deterministic and consistent.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from .sea import Sea

__all__ = ["NO_BUOY_ERRORS", "BuoyErrors", "WaveBuoy"]

_BLOCK = 1024
_NOISE_TAG, _DROP_TAG = 0xB0, 0xD0


@dataclass(frozen=True)
class BuoyErrors:
    """A real buoy's measurement errors; the defaults are a perfect buoy.

    snr_db: elevation SNR (dB) of additive white noise, None for none;
    dropout: probability (0 ≤ p < 1) that a sample is lost; clock_offset: δ (s),
    buoy clock minus vehicle clock; seed: the noise and loss streams' seed.
    """

    snr_db: float | None = None
    dropout: float = 0.0
    clock_offset: float = 0.0
    seed: int = 0

    @property
    def active(self) -> bool:
        return self.snr_db is not None or self.dropout > 0.0 or self.clock_offset != 0.0


NO_BUOY_ERRORS = BuoyErrors()
"""A perfect buoy."""


def _block_draws(seed: int, tag: int, n: np.ndarray, draw) -> np.ndarray:
    """``draw(rng, 1024)`` per block of sample indices, read at indices n (any integers, any order)."""
    n = np.asarray(n, dtype=np.int64)
    out = np.empty(n.shape)
    blocks = n // _BLOCK
    for b in np.unique(blocks):      # a loop over 1024-sample blocks, never over wave components
        rng = np.random.default_rng([int(seed) % 2**63, tag, int(b) + 2**40])
        sel = blocks == b
        out[sel] = draw(rng, _BLOCK)[n[sel] - b * _BLOCK]
    return out


@dataclass(frozen=True)
class WaveBuoy:
    """A surface-following wave buoy at an up-wave position x (m): it records ζ(x, t), with ``errors``."""

    sea: Sea
    x: float
    sample_rate: float
    errors: BuoyErrors = NO_BUOY_ERRORS

    def sample_times(self, t0: float, t1: float) -> np.ndarray:
        """Sample instants k/fs within [t0, t1] on the buoy's own grid (s)."""
        dt = 1.0 / self.sample_rate
        k0, k1 = np.ceil(t0 / dt - 1e-9), np.floor(t1 / dt + 1e-9)
        return np.arange(k0, k1 + 1) * dt

    def measure(self, t: np.ndarray) -> np.ndarray:
        """What the buoy reports for the samples stamped t (s, buoy clock, on its grid): ζ(x, t − δ) plus
        noise, NaN for a lost sample. Without errors, exactly ζ(x, t)."""
        t = np.asarray(t, dtype=float)
        e = self.errors
        if not e.active:
            return self.sea.elevation(self.x, t)
        eta = self.sea.elevation(self.x, t - e.clock_offset)
        n = np.round(t * self.sample_rate).astype(np.int64)
        if e.snr_db is not None:
            sigma = np.sqrt(self.sea.components.m0() * 10.0 ** (-e.snr_db / 10.0))
            eta = eta + sigma * _block_draws(e.seed, _NOISE_TAG, n, lambda r, k: r.standard_normal(k))
        if e.dropout > 0.0:
            lost = _block_draws(e.seed, _DROP_TAG, n, lambda r, k: r.uniform(0.0, 1.0, k)) < e.dropout
            eta = np.where(lost, np.nan, eta)
        return eta

    def record(self, t0: float, t1: float, chunk: int = 4096) -> tuple[np.ndarray, np.ndarray]:
        """(t, ζ) sampled at the buoy's rate over [t0, t1] (buoy clock), with the buoy's errors."""
        t = self.sample_times(t0, t1)
        eta = np.concatenate([self.measure(t[i:i + chunk]) for i in range(0, t.size, chunk)]) \
            if t.size else np.zeros(0)
        return t, eta

    def newest_stamp(self, t_vehicle: float) -> float:
        """The stamp (s, buoy clock) of the newest sample measured by vehicle time ``t_vehicle``."""
        return float(np.floor((t_vehicle + self.errors.clock_offset) * self.sample_rate + 1e-9) / self.sample_rate)
