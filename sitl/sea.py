"""The simulated sea: spectra, their discretisation into components, and a wave buoy.

A :class:`Sea` is a set of :class:`~bridge.models.waves.WaveComponents`
drawn from a spectrum with seeded random phases; its kinematics come from the
shared module :mod:`bridge.models.waves` (paper Eqs. 5, 9, 10).

Spectra are one-sided, in m²·s/rad over ω in rad/s. The JONSWAP form is the
physically consistent one of docs/reference.md §1 (Γ with its minus sign, scaled to the
stated Hs); the buoy-style measured spectrum is read from a CSV of frequency
(Hz) and density (m²/Hz).
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np
from scipy.integrate import quad

from bridge.configfile import ConfigError, Field, load_config, resolve_config
from bridge.csvio import read_numeric_csv
from bridge.models.waves import (
    G,
    WaveComponents,
    elevation,
    particle_acceleration,
    particle_kinematics,
    particle_velocity,
)

__all__ = [
    "SEA_SCHEMA",
    "MeasuredSpectrum",
    "Sea",
    "WaveBuoy",
    "discretise_spectrum",
    "jonswap_spectrum",
    "load_sea_config",
]


def _jonswap_shape(x: np.ndarray, gamma: float) -> np.ndarray:
    """Unscaled JONSWAP shape in x = ω/ω_p: x⁻⁵ exp(−1.25 x⁻⁴) γ^Γ."""
    x = np.asarray(x, dtype=float)
    out = np.zeros_like(x)
    pos = x > 0
    xp = x[pos]
    sigma = np.where(xp <= 1.0, 0.07, 0.09)
    Gamma = np.exp(-((xp - 1.0) ** 2) / (2.0 * sigma**2))
    out[pos] = xp**-5 * np.exp(-1.25 * xp**-4) * gamma**Gamma
    return out


@lru_cache(maxsize=64)
def _jonswap_norm(gamma: float) -> float:
    """∫₀^∞ shape(x) dx, so the spectrum integrates exactly to Hs²/16.

    For γ = 1 (Pierson–Moskowitz) the integral is 1/5 analytically; the
    DNV closed-form factor (1 − 0.287 ln γ) approximates 0.2/∫ to about 1 %.
    """
    f = lambda x: float(_jonswap_shape(np.array([x]), gamma)[0])  # noqa: E731
    a, _ = quad(f, 0.2, 1.0, limit=200, points=[1.0])
    b, _ = quad(f, 1.0, 3.0, limit=200)
    c, _ = quad(f, 3.0, np.inf, limit=200)
    return a + b + c


def jonswap_spectrum(omega, hs: float, tp: float, gamma: float = 3.3) -> np.ndarray:
    """JONSWAP spectral density S(ω) (m²·s/rad) for ω (rad/s), scaled to Hs.

    S(ω) = C(γ) (5/16) Hs² ω_p⁴ ω⁻⁵ exp(−1.25 (ω_p/ω)⁴) γ^Γ,
    Γ = exp(−(ω − ω_p)² / (2 σ² ω_p²)), σ = 0.07 (ω ≤ ω_p) or 0.09, ω_p = 2π/Tp.
    C(γ) is chosen so that ∫ S dω = Hs²/16 exactly (DNV-RP-C205's
    1 − 0.287 ln γ is its closed-form approximation). ω ≤ 0 gives 0.
    """
    if not (hs > 0 and tp > 0 and gamma >= 1.0):
        raise ValueError(f"need hs > 0, tp > 0, gamma >= 1; got hs={hs}, tp={tp}, gamma={gamma}")
    omega = np.asarray(omega, dtype=float)
    wp = 2.0 * np.pi / tp
    scale = (0.2 / _jonswap_norm(float(gamma))) * (5.0 / 16.0) * hs**2 / wp
    return scale * _jonswap_shape(omega / wp, gamma)


class MeasuredSpectrum:
    """A buoy spectrum from a CSV of frequency (Hz) and density (m²/Hz).

    Called with ω (rad/s) it returns S(ω) = S(f)/(2π) (m²·s/rad), linearly
    interpolated and zero outside the measured band. The first row may be a header.
    """

    def __init__(self, freq_hz, density_m2_per_hz, source: str = "<array>"):
        f = np.asarray(freq_hz, dtype=float)
        s = np.asarray(density_m2_per_hz, dtype=float)
        if f.ndim != 1 or f.shape != s.shape or f.size < 3:
            raise ValueError(f"{source}: need at least 3 (frequency, density) rows")
        if not (np.all(np.isfinite(f)) and np.all(np.isfinite(s))):
            raise ValueError(f"{source}: non-finite value in spectrum")
        if np.any(f <= 0) or np.any(np.diff(f) <= 0):
            raise ValueError(f"{source}: frequencies must be positive and strictly increasing")
        if np.any(s < 0):
            raise ValueError(f"{source}: spectral density must be non-negative")
        self.omega = 2.0 * np.pi * f
        self.density = s / (2.0 * np.pi)
        self.source = source

    @classmethod
    def from_csv(cls, path: str | Path) -> MeasuredSpectrum:
        arr = read_numeric_csv(path, ("frequency_hz", "density_m2_per_hz"))
        return cls(arr[:, 0], arr[:, 1], source=str(path))

    @property
    def omega_peak(self) -> float:
        return float(self.omega[np.argmax(self.density)])

    def __call__(self, omega) -> np.ndarray:
        return np.interp(omega, self.omega, self.density, left=0.0, right=0.0)


def discretise_spectrum(spectrum: Callable[[np.ndarray], np.ndarray], omega_lo: float, omega_hi: float,
                        n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Split [ω_lo, ω_hi] into n equal bins and draw one frequency in each.

    Returns (ω_i, A_i) with A_i = √(2 S(ω_i) Δω) (docs/reference.md §2). Each frequency
    is drawn uniformly from its whole bin. Equal spacing would repeat exactly
    every 2π/Δω s; jitter over only part of the bin still leaves a partial
    repeat there (expected correlation 2/π for the middle half), while jitter
    over the whole bin makes the phase shifts at that lag uniform, so the
    record decorrelates.
    """
    if n < 1 or not 0 < omega_lo < omega_hi:
        raise ValueError(f"need n >= 1 and 0 < omega_lo < omega_hi; got {n}, {omega_lo}, {omega_hi}")
    d_omega = (omega_hi - omega_lo) / n
    centres = omega_lo + (np.arange(n) + 0.5) * d_omega
    omega = centres + rng.uniform(-0.5, 0.5, n) * d_omega
    amplitude = np.sqrt(2.0 * spectrum(omega) * d_omega)
    return omega, amplitude


# ---------------------------------------------------------------------------- config

SEA_SCHEMA = {
    "name": Field("str"),
    "spectrum": {
        "type": Field("choice", choices=("jonswap", "measured")),
        "hs": Field("float", lo=0.0, hi=30.0, lo_open=True, required=False, doc="m"),
        "tp": Field("float", lo=1.0, hi=30.0, required=False, doc="s"),
        "gamma": Field("float", lo=1.0, hi=10.0, default=3.3),
        "csv": Field("str", required=False, doc="path to frequency (Hz), density (m^2/Hz) CSV"),
    },
    "water_depth": Field("float", lo=1.0, hi=1.0e4),
    "components": Field("int", lo=8, hi=4096),
    "omega_band": Field("floats", lo=0.05, hi=20.0, length=2),
    "second_order": Field("bool", default=True),
    "seed": Field("int", lo=0, hi=2**63 - 1),
    "buoy": {
        "x": Field("float", lo=-1.0e4, hi=1.0e4, default=-50.0),
        "sample_rate": Field("float", lo=0.1, hi=100.0, default=2.0),
    },
}


def load_sea_config(name_or_path: str | Path) -> dict:
    """Load and validate a sea config by name (``configs/sea/W1.yaml``) or path."""
    path = resolve_config(name_or_path, "sea")
    cfg = load_config(path, SEA_SCHEMA)
    sp = cfg["spectrum"]
    if sp["type"] == "jonswap":
        for key in ("hs", "tp"):
            if sp[key] is None:
                raise ConfigError(path, f"spectrum.{key}", "required when spectrum.type is 'jonswap'")
    else:
        if not sp["csv"]:
            raise ConfigError(path, "spectrum.csv", "required when spectrum.type is 'measured'")
        csv_path = Path(sp["csv"])
        if not csv_path.is_absolute():
            csv_path = path.parent / csv_path
        if not csv_path.exists():
            raise ConfigError(path, "spectrum.csv", f"no such file: {csv_path}")
        sp["csv"] = str(csv_path)
    lo, hi = cfg["omega_band"]
    if not lo < 1.0 < hi:
        raise ConfigError(path, "omega_band", f"got {cfg['omega_band']}; allowed: [lo, hi] with lo < 1 < hi")
    cfg["source"] = str(path)
    return cfg


# ---------------------------------------------------------------------------- the sea

@dataclass(frozen=True)
class Sea:
    """A realised, long-crested sea travelling in +x.

    ``components`` holds amplitude, ω, k (finite-depth dispersion) and phase.
    ``spectrum`` is the density it was drawn from (for checks and plots).
    """

    name: str
    components: WaveComponents
    spectrum: Callable[[np.ndarray], np.ndarray]
    omega_peak: float
    hs_target: float
    seed: int
    buoy_x: float = -50.0
    buoy_rate: float = 2.0

    @classmethod
    def from_config(cls, cfg: dict, seed: int | None = None, g: float = G) -> Sea:
        """Build a sea from a validated sea config; ``seed`` overrides the config's."""
        sp = cfg["spectrum"]
        if sp["type"] == "jonswap":
            hs, tp, gamma = sp["hs"], sp["tp"], sp["gamma"]
            spectrum = lambda w: jonswap_spectrum(w, hs, tp, gamma)  # noqa: E731
            wp = 2.0 * np.pi / tp
        else:
            spectrum = MeasuredSpectrum.from_csv(sp["csv"])
            wp = spectrum.omega_peak
        seed = cfg["seed"] if seed is None else int(seed)
        rng = np.random.default_rng(seed)
        lo, hi = cfg["omega_band"]
        omega, amp = discretise_spectrum(spectrum, lo * wp, hi * wp, cfg["components"], rng)
        phase = rng.uniform(0.0, 2.0 * np.pi, omega.size)
        comps = WaveComponents.from_spectrum_lines(amp, omega, phase, cfg["water_depth"], cfg["second_order"], g)
        hs_target = sp["hs"] if sp["type"] == "jonswap" else comps.hs()
        return cls(cfg["name"], comps, spectrum, wp, hs_target, seed, cfg["buoy"]["x"], cfg["buoy"]["sample_rate"])

    @classmethod
    def load(cls, case: str | Path, seed: int | None = None) -> Sea:
        """``Sea.load("W1")`` or ``Sea.load("path/to/sea.yaml")``."""
        return cls.from_config(load_sea_config(case), seed)

    @classmethod
    def still_water(cls, depth: float = 54.0) -> Sea:
        """No waves (for hydrostatic checks)."""
        z = np.zeros(0)
        return cls("still", WaveComponents(z, z, z, z, depth, False), lambda w: np.zeros_like(w), 1.0, 0.0, 0)

    @property
    def water_depth(self) -> float:
        return self.components.water_depth

    def hs(self) -> float:
        """Significant wave height 4√m0 of the realised linear components (m)."""
        return self.components.hs()

    def elevation(self, x, t) -> np.ndarray:
        """ζ(x, t) (m, up positive), paper Eq. 5."""
        return elevation(self.components, x, t)

    def particle_velocity(self, x, depth, t):
        """(u, w) (m/s, NED: w positive down) at (x, depth, t), paper Eqs. 9–10."""
        return particle_velocity(self.components, x, depth, t)

    def particle_acceleration(self, x, depth, t):
        """(u̇, ẇ) local acceleration (m/s², NED) at (x, depth, t)."""
        return particle_acceleration(self.components, x, depth, t)

    def particle_kinematics(self, x, depth, t):
        """(u, w, u̇, ẇ) at (x, depth, t) in one pass."""
        return particle_kinematics(self.components, x, depth, t)

    def buoy(self, x: float | None = None, sample_rate: float | None = None) -> WaveBuoy:
        return WaveBuoy(self, self.buoy_x if x is None else x, self.buoy_rate if sample_rate is None else sample_rate)


@dataclass(frozen=True)
class WaveBuoy:
    """A surface-following wave buoy at an up-wave position: it records ζ(x_b, t)."""

    sea: Sea
    x: float
    sample_rate: float

    def sample_times(self, t0: float, t1: float) -> np.ndarray:
        """Sample instants k/fs within [t0, t1] on the buoy's own grid (s)."""
        dt = 1.0 / self.sample_rate
        k0, k1 = np.ceil(t0 / dt - 1e-9), np.floor(t1 / dt + 1e-9)
        return np.arange(k0, k1 + 1) * dt

    def record(self, t0: float, t1: float, chunk: int = 4096) -> tuple[np.ndarray, np.ndarray]:
        """(t, ζ) sampled at the buoy's rate over [t0, t1]."""
        t = self.sample_times(t0, t1)
        eta = np.concatenate([self.sea.elevation(self.x, t[i:i + chunk]) for i in range(0, t.size, chunk)]) \
            if t.size else np.zeros(0)
        return t, eta
