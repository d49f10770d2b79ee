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
from typing import Protocol

import numpy as np

from bridge.models.waves import WaveComponents

__all__ = ["NO_BUOY_ERRORS", "BuoyErrors", "BuoyTape", "WaveBuoy"]

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


class SeaSurface(Protocol):
    """What a buoy needs of the sea (:class:`sitl.sea.Sea` is one): its components and its elevation."""

    @property
    def components(self) -> WaveComponents:
        """The realised sea's wave components."""
        ...

    def elevation(self, x: float, t: np.ndarray) -> np.ndarray:
        """ζ(x, t), m up."""
        ...


@dataclass(frozen=True)
class WaveBuoy:
    """A surface-following wave buoy at an up-wave position x (m): it records ζ(x, t), with ``errors``."""

    sea: SeaSurface
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


class BuoyTape:
    """A buoy's record measured once per sample, for a forecaster whose window slides forward.

    :meth:`record` returns what :meth:`WaveBuoy.record` returns, but each sample is measured once,
    in blocks of ``block`` samples aligned on the buoy's grid (sample n = round(t f_s) in block
    n // ``block``), and kept until a window starts after its block: a forecast update every
    0.5 s over a 120 s window costs a slice instead of the sea's 200 components at 240 samples.
    The noise and losses are the buoy's own (drawn per sample index). The elevation of a sample is
    the same sum as :meth:`WaveBuoy.measure`'s; BLAS may group a matrix-vector product's rows
    differently for another array shape, so it can differ from a window measured whole in the
    last bit (≤ 1e-15 m), never more.
    """

    def __init__(self, buoy: WaveBuoy, block: int = 256):
        self.buoy = buoy
        self.block = int(block)
        self._dt = 1.0 / buoy.sample_rate
        self._blocks: dict[int, np.ndarray] = {}

    def _samples(self, n0: int, n1: int) -> np.ndarray:
        """The measured samples n0 … n1 (inclusive, buoy grid indices)."""
        b0, b1 = n0 // self.block, n1 // self.block
        for b in [b for b in self._blocks if b < b0]:
            del self._blocks[b]               # windows only slide forward: older blocks are done
        for b in range(b0, b1 + 1):
            if b not in self._blocks:
                self._blocks[b] = self.buoy.measure(np.arange(b * self.block, (b + 1) * self.block) * self._dt)
        tape = self._blocks[b0] if b0 == b1 else np.concatenate([self._blocks[b] for b in range(b0, b1 + 1)])
        start = n0 - b0 * self.block
        return tape[start:start + n1 - n0 + 1]

    def record(self, t0: float, t1: float) -> tuple[np.ndarray, np.ndarray]:
        """(t, ζ) over [t0, t1] (s, buoy clock), as :meth:`WaveBuoy.record`; the arrays are new."""
        n0 = int(np.ceil(t0 / self._dt - 1e-9))
        n1 = int(np.floor(t1 / self._dt + 1e-9))
        if n1 < n0:
            return np.zeros(0), np.zeros(0)
        return np.arange(n0, n1 + 1) * self._dt, self._samples(n0, n1).copy()
