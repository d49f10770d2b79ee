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

from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from bridge.configfile import ConfigError, Field, apply_overrides, read_yaml, resolve_config, validate
from bridge.csvio import read_numeric_csv
from bridge.models.directional_sea import cos2s_directions
from bridge.models.vehicle import WAVE_LOAD_MODELS
from bridge.models.waves import (
    G,
    WaveComponents,
    elevation,
    elevation_xy,
    particle_acceleration,
    particle_kinematics,
    particle_velocity,
    pressure_head,
)

from .buoy import NO_BUOY_ERRORS, BuoyErrors, WaveBuoy
from .design_wave import constrained_newwave, newwave
from .sea_limits import max_hs

DOF_CHOICES = ("auto", "planar", "six")
"""The sea config's ``dof``: the paper's plane, all six DoF, or ``auto``: the plane for a sea in it, six otherwise."""
DEFAULT_DOF = "six"
"""What a sea config without ``dof`` flies: the six-DoF world; ``planar`` is the paper's named world (docs/models.md,
*The six-DoF plant*, says why)."""
WORLD_DOFS = ("planar", "six")
"""The worlds a plant flies (``auto`` resolved by :func:`resolve_dof`)."""


def resolve_dof(dof: str, components: WaveComponents, current: tuple[float, float]) -> str:
    """The world of a sea config's ``dof``: ``auto`` is ``six`` when the sea leaves the vehicle's x–z plane (its
    components have directions, or the current a cross-plane part) and ``planar`` otherwise."""
    if dof != "auto":
        return dof
    speed, direction = current
    crossing = speed != 0.0 and float(np.sin(np.radians(direction))) != 0.0
    return "six" if components.direction is not None or crossing else "planar"

__all__ = [
    "DEFAULT_DOF",
    "DOF_CHOICES",
    "SEA_SCHEMA",
    "WORLD_DOFS",
    "MeasuredSpectrum",
    "Sea",
    "WaveBuoy",
    "constrained_newwave",
    "cos2s_directions",
    "discretise_spectrum",
    "jonswap_spectrum",
    "load_sea_config",
    "newwave",
    "resolve_dof",
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


_KNOWN_NORMS = {3.3: 0.30498972193425744}
"""γ → :func:`_jonswap_norm_quad`'s result, to the bit (tests/test_sea.py checks it), for the γ of every
sea config: each process of ``wavekeep sim`` (the launcher, the plant, the forecast service) would
otherwise import ``scipy.integrate`` (0.3–0.7 s) at start-up for this one number."""


@lru_cache(maxsize=64)
def _jonswap_norm(gamma: float) -> float:
    """∫₀^∞ shape(x) dx, so the spectrum integrates exactly to Hs²/16 (:func:`_jonswap_norm_quad`)."""
    known = _KNOWN_NORMS.get(gamma)
    return known if known is not None else _jonswap_norm_quad(gamma)


def _jonswap_norm_quad(gamma: float) -> float:
    """∫₀^∞ shape(x) dx by adaptive quadrature.

    For γ = 1 (Pierson–Moskowitz) the integral is 1/5 analytically; the
    DNV closed-form factor (1 − 0.287 ln γ) approximates 0.2/∫ to about 1 %.
    """
    from scipy.integrate import quad  # imported on first use: ~0.3 s

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

    @property
    def hs(self) -> float:
        """Significant wave height 4 √m₀ (m) of the measured band."""
        return float(4.0 * np.sqrt(np.trapezoid(self.density, self.omega)))

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
    "name": Field("str", required=False, doc="default: the file's stem"),
    "spectrum": {
        "type": Field("choice", choices=("jonswap", "measured", "none")),   # none: still water
        "hs": Field("float", lo=0.0, hi=30.0, lo_open=True, required=False, doc="m"),
        "tp": Field("float", lo=1.0, hi=30.0, required=False, doc="s"),
        "gamma": Field("float", lo=1.0, hi=10.0, default=3.3),
        "csv": Field("str", required=False, doc="path to frequency (Hz), density (m^2/Hz) CSV"),
    },
    "water_depth": Field("float", lo=1.0, hi=1.0e4, default=54.0, doc="m"),
    "components": Field("int", lo=8, hi=4096, default=200),
    "omega_band": Field("floats", lo=0.05, hi=20.0, length=2, default=[0.5, 5.0], doc="× the peak frequency"),
    "second_order": Field("bool", default=True),
    "seed": Field("int", lo=0, hi=2**63 - 1, default=1),
    "buoy": {
        "x": Field("float", lo=-1.0e4, hi=1.0e4, default=-50.0),
        "sample_rate": Field("float", lo=0.1, hi=100.0, default=2.0),
        # A real buoy's errors (docs/sea-errors.md), all off by default
        "noise_snr_db": Field("float", lo=-20.0, hi=80.0, required=False, doc="dB of white noise; absent: none"),
        "dropout": Field("float", lo=0.0, hi=0.9, default=0.0, doc="probability that a sample is lost"),
        "clock_offset": Field("float", lo=-30.0, hi=30.0, default=0.0, doc="s, buoy clock minus vehicle clock"),
    },
    # A steady, depth-uniform current (docs/sea-errors.md): speed 0 = none
    "current": {
        "speed": Field("float", lo=0.0, hi=3.0, default=0.0, doc="m/s"),
        "direction": Field("float", lo=-180.0, hi=180.0, default=0.0,
                           doc="deg, towards which it flows, from north (+x, the vehicle's heading) towards east"),
    },
    # The waves' direction (docs/sea-errors.md): the mean direction of travel of a short-crested sea (cos-2s
    # spreading, exponent s) or, with s absent, the direction of a long-crested one
    "spreading": {
        "s": Field("float", lo=0.5, hi=200.0, required=False, doc="cos-2s spreading exponent; absent: long-crested"),
        "direction": Field("float", lo=-180.0, hi=180.0, default=0.0,
                           doc="deg, (mean) direction of travel from the vehicle's heading (north, +x) towards "
                               "starboard (east): 0 along the vehicle, 90 a beam sea, 180 against it"),
    },
    # The world's degrees of freedom (docs/models.md): "six" = surge, sway, heave, roll, pitch, yaw in the sea from
    # its direction; "planar" = the paper's surge, heave and pitch in the x–z plane (`wavekeep reproduce` flies it);
    # "auto" = planar for a sea in that plane (long-crested along x, no cross current), six otherwise
    "dof": Field("choice", choices=DOF_CHOICES, default=DEFAULT_DOF),
    # The fluid-inertia load the world applies (docs/models.md): "complete" = (ρ∇ + M_A)·a with the pitch
    # coupling (Froude–Krylov + added mass); "paper" = the paper's M_A·a alone, to reproduce its table
    "wave_load": Field("choice", choices=WAVE_LOAD_MODELS, default="complete"),
    # The depth sensor sees the waves' linear dynamic pressure (docs/sea-errors.md)
    "depth_sensor": {
        "dynamic_pressure": Field("bool", default=False),
    },
    # A design wave embedded in the random sea (constrained NewWave): absent = no focusing
    "focus": {
        "crest": Field("float", lo=0.0, hi=30.0, lo_open=True, required=False, doc="m, above the still surface"),
        "x": Field("float", lo=-1.0e4, hi=1.0e4, default=0.0, doc="m, earth x of the crest"),
        "t": Field("float", lo=0.0, hi=1.0e5, required=False, doc="s, time of the crest"),
    },
}

FOCUS_MAX_CREST_OVER_HS = 2.5
"""Largest focused crest allowed, as a multiple of Hs: beyond it the Stokes expansion (and the sea) breaks."""


def load_sea_config(name_or_path: str | Path, overrides: Mapping[str, Any] | None = None) -> dict:
    """Load and validate a sea config by name (``configs/sea/W1.yaml``) or path.

    ``overrides`` maps dotted keys (``buoy.noise_snr_db``, ``current.speed``) to values that replace
    the file's before validation, so a bad one is named like a bad key of the file.
    """
    path = resolve_config(name_or_path, "sea")
    cfg = validate(apply_overrides(read_yaml(path), overrides, path), SEA_SCHEMA, path)
    sp = cfg["spectrum"]
    if sp["type"] == "jonswap":
        for key in ("hs", "tp"):
            if sp[key] is None:
                raise ConfigError(path, f"spectrum.{key}", "required when spectrum.type is 'jonswap'")
        if sp["hs"] > max_hs(sp["tp"]):
            raise ConfigError(path, "spectrum.hs", f"got {sp['hs']!r}; allowed: (0, {max_hs(sp['tp']):.3g}] m at tp "
                              f"{sp['tp']:g} s (steeper seas break, and the model cannot fly them: docs/models.md)")
    elif sp["type"] == "measured":
        if not sp["csv"]:
            raise ConfigError(path, "spectrum.csv", "required when spectrum.type is 'measured'")
        csv_path = Path(sp["csv"])
        if not csv_path.is_absolute():
            csv_path = path.parent / csv_path
        if not csv_path.exists():
            raise ConfigError(path, "spectrum.csv", f"no such file: {csv_path}")
        sp["csv"] = str(csv_path)
        try:   # a bad spectrum file is a config error (one line, exit 2), found before anything runs
            measured = MeasuredSpectrum.from_csv(csv_path)
        except ValueError as exc:
            raise ConfigError(path, "spectrum.csv", str(exc)) from None
        hs, tp = measured.hs, 2.0 * np.pi / measured.omega_peak
        if hs > max_hs(tp):
            raise ConfigError(path, "spectrum.csv", f"Hs {hs:.3g} m at Tp {tp:.3g} s; allowed: Hs up to "
                              f"{max_hs(tp):.3g} m at that Tp (steeper seas break: docs/models.md)")
    lo, hi = cfg["omega_band"]
    if not lo < 1.0 < hi:
        raise ConfigError(path, "omega_band", f"got {cfg['omega_band']}; allowed: [lo, hi] with lo < 1 < hi")
    _check_focus(path, cfg)
    if cfg["spreading"]["s"] is not None and cfg["focus"]["crest"] is not None:
        raise ConfigError(path, "spreading.s", "a design wave (focus) is long-crested: give spreading or focus")
    if cfg["spreading"]["direction"] != 0.0 and cfg["focus"]["crest"] is not None:
        raise ConfigError(path, "spreading.direction", "a design wave (focus) travels along x: direction 0")
    cfg["source"] = str(path)
    cfg["name"] = cfg["name"] or path.stem
    return cfg


def _check_focus(path: Path, cfg: dict) -> None:
    """``focus`` is all or nothing (crest and t together) and its crest at most 2.5 Hs (jonswap)."""
    f = cfg["focus"]
    if (f["crest"] is None) != (f["t"] is None):
        key = "focus.t" if f["t"] is None else "focus.crest"
        raise ConfigError(path, key, "required when focus is given (focus: {crest: m, x: m, t: s})")
    hs = cfg["spectrum"]["hs"]
    if f["crest"] is not None and cfg["spectrum"]["type"] == "jonswap" and f["crest"] > FOCUS_MAX_CREST_OVER_HS * hs:
        raise ConfigError(path, "focus.crest", f"got {f['crest']!r}; allowed: (0, {FOCUS_MAX_CREST_OVER_HS * hs:g}] m "
                                               f"({FOCUS_MAX_CREST_OVER_HS:g} Hs)")


# ---------------------------------------------------------------------------- the sea

@dataclass(frozen=True)
class Sea:
    """A realised sea: long-crested, or short-crested with the config's ``spreading``, from any direction.

    ``components`` holds amplitude, ω, k (finite-depth dispersion) and phase, and, unless the sea is
    long-crested along north (+x), each component's direction of travel β (rad, from north towards
    east; single summation). ``mean_direction`` (rad) is the config's (mean) direction, on which the
    buoy sits up-wave. A planar world sees the x–z plane's share of the kinematics (docs/sea-errors.md),
    the six-DoF world all of it. ``spectrum`` is the density it was drawn from (for checks and plots).
    """

    name: str
    components: WaveComponents
    spectrum: Callable[[np.ndarray], np.ndarray]
    omega_peak: float
    hs_target: float
    seed: int
    buoy_x: float = -50.0
    buoy_rate: float = 2.0
    focus: tuple[float, float, float] | None = None     # (crest m, x m, t s) of an embedded NewWave
    buoy_errors: BuoyErrors = NO_BUOY_ERRORS            # the buoy's measurement errors (none by default)
    current: tuple[float, float] = (0.0, 0.0)           # steady current: speed (m/s), direction (deg from +x)
    dynamic_pressure: bool = False                      # the depth sensor sees the waves' dynamic pressure
    wave_load: str = "complete"                         # the world's load model (WAVE_LOAD_MODELS)
    dof: str = "planar"                                 # the world's degrees of freedom (WORLD_DOFS; auto resolved)
    mean_direction: float = 0.0                         # rad, the waves' (mean) direction of travel from north

    @classmethod
    def from_config(cls, cfg: dict, seed: int | None = None, g: float = G) -> Sea:
        """Build a sea from a validated sea config; ``seed`` overrides the config's."""
        sp = cfg["spectrum"]
        if sp["type"] == "none":
            still = cls.still_water(cfg["water_depth"], cfg["name"])
            return replace(still, dof="six" if cfg["dof"] == "six" else "planar")
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
        fc = cfg.get("focus") or {}
        focus = None
        if fc.get("crest") is not None:
            focus = (float(fc["crest"]), float(fc["x"]), float(fc["t"]))
            comps = constrained_newwave(comps, *focus)
        spread = cfg.get("spreading") or {}
        mean = float(np.radians(spread.get("direction", 0.0)))
        if spread.get("s") is not None:   # its own stream: the frequencies and phases stay the long-crested sea's
            beta = cos2s_directions(spread["s"], mean, comps.n, np.random.default_rng([seed, 0x5D]))
            comps = replace(comps, direction=beta)
        elif mean != 0.0:                 # long-crested from another direction; along north it stays None
            comps = replace(comps, direction=np.full(comps.n, mean))
        by = cfg["buoy"]
        errors = BuoyErrors(by["noise_snr_db"], by["dropout"], by["clock_offset"], seed)
        current = (cfg["current"]["speed"], cfg["current"]["direction"])
        return cls(cfg["name"], comps, spectrum, wp, hs_target, seed, by["x"], by["sample_rate"], focus, errors,
                   current, cfg["depth_sensor"]["dynamic_pressure"], cfg["wave_load"],
                   resolve_dof(cfg.get("dof", DEFAULT_DOF), comps, current), mean)

    @classmethod
    def load(cls, case: str | Path, seed: int | None = None, overrides: Mapping[str, Any] | None = None) -> Sea:
        """``Sea.load("W1")`` or ``Sea.load("path/to/sea.yaml")``; ``overrides`` as in :func:`load_sea_config`."""
        return cls.from_config(load_sea_config(case, overrides), seed)

    @classmethod
    def still_water(cls, depth: float = 54.0, name: str = "still") -> Sea:
        """No waves (hydrostatic checks; ``configs/sea/still.yaml``, where another autopilot's MAVLink is compared)."""
        z = np.zeros(0)
        return cls(name, WaveComponents(z, z, z, z, depth, False), lambda w: np.zeros_like(w), 1.0, 0.0, 0)

    @property
    def water_depth(self) -> float:
        return self.components.water_depth

    @property
    def current_x(self) -> float:
        """The current's in-plane component U_c cos ψ_c (m/s, NED north): what the planar world feels of it
        (the cross-plane part U_c sin ψ_c is left out there; the six-DoF world takes :attr:`current_ned`)."""
        speed, direction = self.current
        return 0.0 if speed == 0.0 else float(speed * np.cos(np.radians(direction)))

    @property
    def current_ned(self) -> np.ndarray:
        """The current as an NED vector (m/s): U_c (cos ψ_c, sin ψ_c, 0), depth-uniform and steady."""
        speed, direction = self.current
        if speed == 0.0:
            return np.zeros(3)
        return np.array([speed * np.cos(np.radians(direction)), speed * np.sin(np.radians(direction)), 0.0])

    def pressure_head(self, x, depth, t, y=0.0) -> np.ndarray:
        """Linear dynamic pressure head p_d/(ρ g) (m) at (x, y (m), depth (m), t (s)): Σ A_i K_p,i cos θ_i."""
        return pressure_head(self.components, x, depth, t, y)

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

    def elevation_on_mean_line(self, x, t) -> np.ndarray:
        """ζ (m, up) at the distance x (m) along the mean direction through the origin (the station), at t (s):
        where the buoy sits. Along north (mean direction 0) this is :meth:`elevation`."""
        if self.mean_direction == 0.0:
            return elevation(self.components, x, t)
        x = np.asarray(x, dtype=float)
        return elevation_xy(self.components, x * np.cos(self.mean_direction), x * np.sin(self.mean_direction), t)

    def buoy(self, x: float | None = None, sample_rate: float | None = None) -> WaveBuoy:
        """The sea's up-wave buoy (:mod:`sitl.buoy`), with the config's measurement errors: at the distance
        ``x`` (m; negative: up-wave) along the mean direction of travel through the station."""
        return WaveBuoy(_MeanLine(self), self.buoy_x if x is None else x,
                        self.buoy_rate if sample_rate is None else sample_rate, self.buoy_errors)


@dataclass(frozen=True)
class _MeanLine:
    """The sea seen along its mean direction (the buoy's line): ζ at a distance x along it (a buoy's surface)."""

    sea: Sea

    @property
    def components(self) -> WaveComponents:
        return self.sea.components

    def elevation(self, x, t) -> np.ndarray:
        return self.sea.elevation_on_mean_line(x, t)
