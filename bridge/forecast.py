"""The wave forecast: what a shore or buoy service tells the vehicle about the coming waves.

A :class:`Forecast` is a set of regular components (amplitude, ω, k, phase)
referred to a reference position x_ref and a time base t_b on the *vehicle's*
clock: the elevation it predicts is

    ζ(x, t) = Σ A_i cos(k_i (x − x_ref) − ω_i (t − t_b) + φ_i)  (+ Stokes 2nd order)

and it is valid for t in [valid_from, valid_until]. This module is the contract;
the wire codec and the zenoh transport build on it.

:func:`inject_spectral_noise` reproduces the paper's forecast error (§V-B):
white Gaussian noise at a given SNR added to the amplitude and phase vectors,
with the noise power measured from each vector (MATLAB's ``awgn(x, snr, 'measured')``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bridge.models.waves import WaveComponents

__all__ = ["Forecast", "derive_seeds", "inject_spectral_noise", "oracle_forecast"]


@dataclass(frozen=True)
class Forecast:
    """Predicted wave components, their reference position and time base, and a validity window."""

    amplitude: np.ndarray      # m
    omega: np.ndarray          # rad/s
    k: np.ndarray              # rad/m
    phase: np.ndarray          # rad, at x = x_ref, t = time_base
    water_depth: float         # m
    x_ref: float               # m (NED north)
    time_base: float           # s, vehicle clock
    valid_from: float          # s, vehicle clock
    valid_until: float         # s, vehicle clock
    second_order: bool = True
    source: str = "oracle"
    seq: int = 0
    direction: np.ndarray | None = None   # rad, each component's direction of travel from north towards east;
    #                                       None: all along north (x), the long-crested head sea

    @property
    def kx(self) -> np.ndarray:
        """k cos β (rad/m): the wavenumber along north, the phase's x-rate."""
        return self.k if self.direction is None else self.k * np.cos(self.direction)

    def is_valid_at(self, t: float) -> bool:
        return self.valid_from <= t <= self.valid_until

    def components(self) -> WaveComponents:
        """Components on the absolute frame (x = 0, t = 0) used by the shared kinematics."""
        phase = self.phase - self.kx * self.x_ref + self.omega * self.time_base
        return WaveComponents(np.asarray(self.amplitude, float), np.asarray(self.omega, float),
                              np.asarray(self.k, float), np.mod(phase, 2.0 * np.pi), float(self.water_depth),
                              bool(self.second_order),
                              None if self.direction is None else np.asarray(self.direction, float))


def derive_seeds(seed: int) -> tuple[int, int]:
    """Independent streams for the sensor noise and the forecast error, derived from a run's seed.

    Every process of a run (in-process runner, firmware, forecast service)
    derives them the same way, so the same seed gives the same run.
    """
    sensor, forecast = np.random.SeedSequence(seed).spawn(2)
    return int(sensor.generate_state(1)[0]), int(forecast.generate_state(1)[0])


def inject_spectral_noise(values: np.ndarray, snr_db: float, rng: np.random.Generator) -> np.ndarray:
    """``values`` plus white Gaussian noise whose power is mean(values²) / 10^(snr_db/10)."""
    values = np.asarray(values, dtype=float)
    power = float(np.mean(values**2))
    sigma = np.sqrt(power / 10.0 ** (snr_db / 10.0))
    return values + rng.normal(0.0, sigma, values.shape)


def oracle_forecast(truth: WaveComponents, snr_db: float | None, rng: np.random.Generator | None,
                    valid_from: float = 0.0, valid_until: float = float("inf"), seq: int = 0,
                    x_ref: float = 0.0, time_base: float = 0.0) -> Forecast:
    """A forecast made of the sea's own components, optionally with the paper's error injected; in a sea from
    another direction than north (or a spread one) it carries each component's direction.

    With ``snr_db`` set, noise is added to the amplitudes (negative results are
    clipped to zero) and to the phases as drawn in [0, 2π) — the paper's
    SNR₁₅ case. The wavenumbers stay on the dispersion relation.
    """
    amp, phase = truth.amplitude, truth.phase
    if snr_db is not None:
        if rng is None:
            raise ValueError("a noisy oracle forecast needs a random generator")
        amp = np.maximum(inject_spectral_noise(amp, snr_db, rng), 0.0)
        phase = inject_spectral_noise(phase, snr_db, rng)
    # Refer the phases to (x_ref, time_base): θ = k(x − x_ref) − ω(t − t_b) + φ
    phase_ref = np.mod(phase + truth.kx * x_ref - truth.omega * time_base, 2.0 * np.pi)
    direction = None if truth.direction is None else np.asarray(truth.direction, dtype=float).copy()
    return Forecast(amp.copy(), truth.omega.copy(), truth.k.copy(), phase_ref, truth.water_depth, x_ref,
                    time_base, valid_from, valid_until, truth.second_order,
                    "oracle" if snr_db is None else f"oracle_snr{snr_db:g}db", seq, direction)
