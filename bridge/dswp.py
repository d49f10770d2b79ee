"""Deterministic sea wave prediction (DSWP) from an up-wave buoy record.

The authors' later work (docs/reference.md §1 last bullet, §7 last bullet) predicts the
waves at the vehicle from a probe 50 m up-wave: FFT of the probe record →
regular components → propagate them down-wave with the dispersion relation.
:func:`predict_from_buoy` does that and returns a :class:`~bridge.forecast.Forecast`
that the feed-forward evaluates like any other (``Forecast.components()``).

Model
-----
Waves travel towards +x (phase θ = k x − ω t + ε, :mod:`bridge.models.waves`).
The buoy at x_b records ζ_b(t_n), n = 0 … N−1, uniformly sampled with step Δt,
t_0 … t_e (t_e the newest sample used, the *time base* t_b = t_e). The fit is

    ζ_b(t) ≈ Σ_i A_i cos(−ω_i (t − t_b) + φ_i),

and, each component being a free linear wave, the prediction anywhere down-wave is

    ζ(x, t) = Σ_i A_i cos(k_i (x − x_b) − ω_i (t − t_b) + φ_i),

which is exactly the :class:`Forecast` convention with x_ref = x_b and
time_base = t_b, so the forecast's phases are the buoy phases unchanged.

Fitting choices
---------------
* **Frequencies**: the DFT bins f_j = j / (N Δt) of the newest ``window_s``
  seconds (``numpy.fft.rfft``). Bins with f_min ≤ f_j ≤ f_max (and below the
  Nyquist bin, whose phase is undetermined) whose amplitude is at least
  ``rel_threshold`` × the largest in-band amplitude are kept — the authors'
  rule (5 % of the largest, 0.05–0.5 Hz).
* **Taper** (``taper="none"``, the default): a rectangular window. It is the
  one that keeps amplitudes unbiased for what DSWP needs: a component on a bin
  comes out with its exact amplitude and phase, Parseval holds (the energy of a
  random sea is unbiased), and the kept components are the orthogonal
  projection of the record, so they reproduce it in the window. A Hann taper
  corrected by its coherent gain is unbiased only for an isolated on-bin
  sinusoid: it smears each line over three bins (±1 bins at half amplitude),
  overstates a random sea's energy by its ENBW (1.5×), and, worst for a
  *forecast*, weights the newest samples — the ones the forecast horizon
  depends on — towards zero. ``taper="hann"`` is offered only to *select* the
  bins (its sidelobes fall fast, so the 5 % rule keeps spectral peaks rather
  than the 1/f leakage skirts of a strong off-bin line); amplitudes and phases
  are then always refitted on the untapered record (next point). Measured on
  the linear W1 sea it is worse than the rectangular selection (NRMSE 0.13
  vs 0.09 over the zone), because the dropped skirts are part of the record.
* **Least-squares refinement** (always on): amplitudes and phases at the kept
  frequencies are the least-squares fit (Cholesky on the normal equations, or
  SVD when they are ill-conditioned: ``_least_squares``) of the *untapered* record on
  columns cos ω_i(t − t_b), sin ω_i(t − t_b) plus a constant and a linear
  trend (buoy offset, tide, sensor drift). On the DFT grid the wave columns
  are mutually orthogonal, so for the rectangular taper this is the
  rectangular DFT itself (no leakage bias introduced by the fit), minus the
  part of the record explained by the trend; after a Hann selection it removes
  the taper's amplitude/phase bias. A signal that lies in the model's span
  (on-bin lines) is recovered exactly.
* **Oversampled, regularised fit** (``oversample > 1``, opt-in): each kept bin
  is replaced by ``oversample`` frequencies spaced Δf/oversample across it, and
  the fit is ridge-regularised, min ‖η − M c‖² + λ N ‖c_waves‖², λ = ``ridge``
  (the columns are no longer orthogonal and may outnumber the samples).
  All components on the DFT grid repeat with the record period T, so the plain
  fit continues the buoy signal past t_e with the record's *start*; the
  band-limited propagation kernel's tails carry that wrap-around jump into the
  end of the predictable zone — the part the feed-forward uses. The
  oversampled model is not T-periodic and continues the record smoothly;
  it also represents lines between bins. Measured on linear W1/W3 seas it
  roughly halves the error between t_e and valid_until, at the price of
  ``oversample`` × more components and a slightly biased (shrunk) fit, so it
  is not the default (the default reproduces the authors' FFT method and is
  exact for on-bin lines).
* **Propagation**: k_i from the finite-depth dispersion relation
  ω² = g k tanh k d (:func:`~bridge.models.waves.wavenumber`), or the
  deep-water k = ω²/g with ``deep_water=True`` — the authors' deliberate
  mismatch with their finite-depth truth, kept to reproduce it.
* **Linear**: the forecast has ``second_order=False``. The record already holds
  the sea's Stokes bound harmonics; they are fitted as if they were free waves
  (so at most they are propagated with a slightly wrong speed). Marking the
  forecast second-order would add the bound terms a second time.

Validity window (predictable zone)
----------------------------------
Linear waves carry their information at the group velocity
c_g(ω) = dω/dk = (c/2) (1 + 2kd / sinh 2kd), c = ω/k (deep water: c_g = g/(2ω)
= c/2; shallow: c_g → c = √(g d)). c_g falls monotonically with ω, so over the
kept band [ω_lo, ω_hi]: c_g,max = c_g(ω_lo) (longest waves, fastest groups),
c_g,min = c_g(ω_hi) (the code takes the max/min over all kept components).

The wave energy that reaches the vehicle, a distance D = x_v − x_b > 0
down-wave, at time t in the band c_g passed the buoy at t − D/c_g. The record
covers [t_0, t_e] (T = t_e − t_0), so the prediction at t is deterministic for
*every* component in the band only if t − D/c_g ∈ [t_0, t_e] for all
c_g ∈ [c_g,min, c_g,max]:

* t − D/c_g ≤ t_e for all c_g  ⇔  t ≤ t_e + D/c_g,max  — the fastest groups
  are the first to bring energy the buoy has not yet recorded, so the window
  closes D/c_g,max after the newest sample;
* t − D/c_g ≥ t_0 for all c_g  ⇔  t ≥ t_0 + D/c_g,min = t_e − T + D/c_g,min —
  the slowest groups are the last to have left the record's start.

    valid_from = t_e − T + D / c_g(ω_hi),   valid_until = t_e + D / c_g(ω_lo)

(the long-crested "predictable zone" of DSWP, Morris, Zienkiewicz & Belmont 1998).
The zone is non-empty only if T > D/c_g,min − D/c_g,max: a shorter record is
rejected. The group velocities are always the finite-depth ones at the given
``water_depth``, also with ``deep_water=True``: the window is a statement about
when the information physically reaches the vehicle, and the deep-water
c_g = g/(2ω) would *under*-estimate the fastest groups at 54 m (10 s waves:
7.8 vs 8.4 m/s) and so over-state the horizon. The window is for the position
``x_vehicle`` (further down-wave the zone shifts later). valid_from may lie before the time of
prediction: that part is a deterministic hindcast. Energy outside the kept band
(below the threshold or outside [f_min, f_max]) is not covered by this bound.
"""
from __future__ import annotations

import numpy as np

from bridge.forecast import Forecast
from bridge.models.waves import G, wavenumber

__all__ = ["TAPERS", "group_velocity", "predict_from_buoy", "predictable_zone"]

TAPERS = ("none", "hann")
"""Bin-selection tapers accepted by :func:`predict_from_buoy`."""

_UNIFORM_RTOL = 1e-3   # allowed relative deviation of a sampling interval from the median
_MIN_SAMPLES = 16
_CHOLESKY_MAX_COND = 1e6   # normal equations only below this κ₁(MᵀM): error ≈ κ ε ≤ 1e-10
MIN_PRESENT = 0.5
"""Least share of a window's samples that must be present (not lost) for a prediction."""


def group_velocity(omega, water_depth: float, *, deep_water: bool = False, g: float = G) -> np.ndarray:
    """Group velocity c_g = dω/dk (m/s) of linear gravity waves at ω (rad/s).

    Finite depth: c_g = (c/2)(1 + 2kd / sinh 2kd) with k from ω² = g k tanh kd;
    ``deep_water=True``: c_g = g / (2ω). The ratio 2kd/sinh 2kd is computed as
    4kd e^{−2kd} / (1 − e^{−4kd}) so that large kd cannot overflow.
    """
    omega = np.asarray(omega, dtype=float)
    if deep_water:
        if np.any(omega <= 0) or not np.all(np.isfinite(omega)):
            raise ValueError("angular frequencies must be positive and finite")
        return g / (2.0 * omega)
    k = wavenumber(omega, water_depth, g)
    kd2 = 2.0 * k * water_depth
    e = np.exp(-kd2)
    ratio = 2.0 * kd2 * e / (1.0 - e * e)
    return 0.5 * (omega / k) * (1.0 + ratio)


def predictable_zone(t_end: float, record_length: float, distance: float,
                     cg_min: float, cg_max: float) -> tuple[float, float]:
    """The times at which a record ending at ``t_end`` predicts deterministically ``distance`` down-wave.

    Returns (t_end − T + D/c_g,min, t_end + D/c_g,max); see the module docstring.
    Raises ValueError when the zone is empty (record shorter than D/c_g,min − D/c_g,max).
    """
    if not (distance > 0 and 0 < cg_min <= cg_max and record_length > 0):
        raise ValueError(f"need distance > 0, 0 < cg_min <= cg_max and record_length > 0; got D={distance}, "
                         f"cg_min={cg_min}, cg_max={cg_max}, T={record_length}")
    lo = t_end - record_length + distance / cg_min
    hi = t_end + distance / cg_max
    if not lo < hi:
        need = distance / cg_min - distance / cg_max
        raise ValueError(f"record too short for deterministic prediction {distance:g} m down-wave: "
                         f"{record_length:g} s recorded, need more than D/cg_min - D/cg_max = {need:.2f} s "
                         f"for group velocities {cg_min:.3f}..{cg_max:.3f} m/s")
    return float(lo), float(hi)


def _check_record(t, eta, now, allow_gaps: bool = False):
    t = np.asarray(t, dtype=float)
    eta = np.asarray(eta, dtype=float)
    if t.ndim != 1 or eta.shape != t.shape:
        raise ValueError(f"t and eta must be 1-D arrays of the same length; got shapes {t.shape} and {eta.shape}")
    if not np.all(np.isfinite(t)):
        raise ValueError("buoy record: time stamps contain NaN or inf")
    if np.any(np.isinf(eta)) or (not allow_gaps and not np.all(np.isfinite(eta))):
        bad = int(np.count_nonzero(~np.isfinite(eta)))
        raise ValueError(f"buoy record: elevation contains {bad} NaN/inf sample(s); fill or drop the gap first "
                         "(or allow_gaps=True for lost samples as NaN)")
    if now is not None:
        if not np.isfinite(now):
            raise ValueError(f"now must be finite, got {now!r}")
        keep = t <= now + 1e-9 * max(1.0, abs(now))
        t, eta = t[keep], eta[keep]
    if t.size < _MIN_SAMPLES:
        raise ValueError(f"buoy record too short: {t.size} sample(s)"
                         + (" at or before now" if now is not None else "") + f", need at least {_MIN_SAMPLES}")
    dt_all = np.diff(t)
    if np.any(dt_all <= 0):
        raise ValueError("buoy record: time stamps must be strictly increasing")
    dt = float(np.median(dt_all))
    worst = float(np.max(np.abs(dt_all - dt)))
    if worst > _UNIFORM_RTOL * dt:
        raise ValueError(f"buoy record is not uniformly sampled: intervals deviate by up to {worst:.3g} s "
                         f"from the median {dt:.6g} s (tolerance {_UNIFORM_RTOL:g} relative); resample first")
    return t, eta, dt


def _check_arguments(x_buoy, x_vehicle, water_depth, window_s, f_min, f_max, rel_threshold, g, taper,
                     oversample, ridge) -> None:
    """ValueError naming the first argument of :func:`predict_from_buoy` that is out of its range."""
    for name, val in (("x_buoy", x_buoy), ("x_vehicle", x_vehicle), ("water_depth", water_depth),
                      ("window_s", window_s), ("f_min", f_min), ("f_max", f_max),
                      ("rel_threshold", rel_threshold), ("g", g)):
        if not np.isfinite(val):
            raise ValueError(f"{name} must be finite, got {val!r}")
    distance = float(x_vehicle) - float(x_buoy)
    if distance <= 0:
        raise ValueError(f"the vehicle must be down-wave of the buoy (waves travel towards +x): "
                         f"x_vehicle - x_buoy = {distance:g} m, need > 0")
    if water_depth <= 0:
        raise ValueError(f"water_depth must be positive, got {water_depth!r}")
    if g <= 0:
        raise ValueError(f"g must be positive, got {g!r}")
    if window_s <= 0:
        raise ValueError(f"window_s must be positive, got {window_s!r}")
    if not 0 < f_min < f_max:
        raise ValueError(f"need 0 < f_min < f_max, got f_min={f_min}, f_max={f_max}")
    if not 0 < rel_threshold <= 1:
        raise ValueError(f"rel_threshold must be in (0, 1], got {rel_threshold!r}")
    if taper not in TAPERS:
        raise ValueError(f"unknown taper {taper!r}; choose one of {TAPERS}")
    if isinstance(oversample, bool) or int(oversample) != oversample or not 1 <= oversample <= 16:
        raise ValueError(f"oversample must be an integer in 1..16, got {oversample!r}")
    if oversample > 1 and not (np.isfinite(ridge) and ridge > 0):
        raise ValueError(f"ridge must be positive and finite when oversample > 1, got {ridge!r}")



def _fill_gaps(eta: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    """Lost samples (NaN) of a uniform record: (η with the gaps linearly interpolated, the mask of the
    samples present), or (η, None) when none is lost. The filled record serves only to select the DFT
    bins; the fit uses the present samples alone, so a gap adds no invented data to the components."""
    ok = np.isfinite(eta)
    if ok.all():
        return eta, None
    if ok.sum() < max(_MIN_SAMPLES, MIN_PRESENT * eta.size):
        raise ValueError(f"buoy record: {eta.size - int(ok.sum())} of {eta.size} samples lost; need at least "
                         f"{MIN_PRESENT:.0%} of the window present")
    idx = np.arange(eta.size)
    return np.interp(idx, idx[ok], eta[ok]), ok


def _select_frequencies(eta: np.ndarray, n: int, dt: float, f_min: float, f_max: float, rel_threshold: float,
                        taper: str, oversample: int) -> np.ndarray:
    """Angular frequencies (rad/s) of the record's strong in-band DFT bins (oversampled when asked)."""
    freqs = np.fft.rfftfreq(n, dt)
    in_band = (freqs >= f_min * (1 - 1e-12)) & (freqs <= f_max * (1 + 1e-12))
    in_band[0] = False
    if n % 2 == 0:
        in_band[-1] = False                        # Nyquist bin: no phase information
    if not np.any(in_band):
        raise ValueError(f"empty band: no frequency bin of a {n * dt:g} s record at {1 / dt:g} Hz "
                         f"(resolution {1 / (n * dt):.4g} Hz, Nyquist {0.5 / dt:g} Hz) lies in "
                         f"[{f_min:g}, {f_max:g}] Hz")
    w = np.ones(n) if taper == "none" else np.hanning(n)
    spec = np.fft.rfft((eta - eta.mean()) * w)
    amp_sel = 2.0 * np.abs(spec) / np.sum(w)       # coherent-gain corrected single-sided amplitude
    peak = float(np.max(amp_sel[in_band]))
    if not peak > 0:
        raise ValueError(f"no wave energy in [{f_min:g}, {f_max:g}] Hz in the buoy record")
    keep = in_band & (amp_sel >= rel_threshold * peak)
    f_kept = freqs[keep]
    if oversample > 1:
        # Δf/oversample steps across each kept bin [f_j − Δf/2, f_j + Δf/2); shared points merged
        df = freqs[1]
        offsets = (np.arange(oversample) - oversample // 2) * (df / oversample)
        idx = np.unique(np.round((f_kept[:, None] + offsets).ravel() / (df / oversample)).astype(np.int64))
        f_kept = idx[idx > 0] * (df / oversample)
    return 2.0 * np.pi * f_kept



def _least_squares(cols: np.ndarray, eta: np.ndarray, penalty: float) -> np.ndarray:
    """c minimising ‖η − M c‖² + penalty ‖c_waves‖² (M = ``cols``; the penalty spares the constant and trend).

    Solved by Cholesky on the normal equations (MᵀM + penalty P) c = Mᵀη, about 4× cheaper than the
    SVD of ``numpy.linalg.lstsq`` on these small dense systems, when they are well conditioned: their
    wave columns are near-orthogonal DFT bins (κ(MᵀM) ≈ 40), or ridge-regularised when oversampled
    (κ ≈ 1e4), so the solution agrees with the SVD's to ≈ κ ε ≈ 1e-12 relative. A Gram matrix whose
    estimated condition number exceeds :data:`_CHOLESKY_MAX_COND` (many lost samples, a tiny ridge)
    falls back to the SVD fit of the stacked system [M; √penalty P] c = [η; 0], as before.
    """
    from scipy.linalg.lapack import dpocon, dpotrf, dpotrs

    gram = cols.T @ cols
    if penalty:
        waves = np.arange(2, gram.shape[0])
        gram[waves, waves] += penalty
    norm1 = float(np.max(np.sum(np.abs(gram), axis=0)))
    upper, info = dpotrf(gram, lower=0, overwrite_a=1)       # MᵀM + penalty P = Uᵀ U
    if info == 0:
        rcond, info = dpocon(upper, norm1)                   # 1 / κ₁, estimated in O(n²)
        if info == 0 and rcond * _CHOLESKY_MAX_COND >= 1.0:
            coef, info = dpotrs(upper, cols.T @ eta)
            if info == 0:
                return coef
    return _svd_least_squares(cols, eta, penalty)


def _svd_least_squares(cols: np.ndarray, eta: np.ndarray, penalty: float) -> np.ndarray:
    """numpy's SVD least squares of the fit, of the ridge-stacked system [M; √penalty P] when penalised:
    the fallback of :func:`_least_squares` for an ill-conditioned system (and the former fit)."""
    if not penalty:
        return np.linalg.lstsq(cols, eta, rcond=None)[0]
    m2 = cols.shape[1] - 2
    pen = np.zeros((m2, cols.shape[1]))
    pen[:, 2:] = np.sqrt(penalty) * np.eye(m2)
    return np.linalg.lstsq(np.vstack([cols, pen]), np.concatenate([eta, np.zeros(m2)]), rcond=None)[0]


def _fit_components(tau: np.ndarray, eta: np.ndarray, omega: np.ndarray, n: int, dt: float, taper: str,
                   oversample: int, ridge: float, rel_threshold: float, present: np.ndarray | None = None):
    """(ω, A, φ) of the least-squares (or ridge) fit of the record to cos/sin at ``omega``, τ = t − t_b;
    ``present``: the mask of the samples not lost (None: all), the only rows fitted."""
    # Columns: constant, linear trend, then cos ω τ and sin ω τ for every kept frequency.
    arg = np.multiply.outer(tau, omega)
    cols = np.hstack([np.ones((n, 1)), (tau / (n * dt))[:, None], np.cos(arg), np.sin(arg)])
    if present is not None:
        cols, eta, n = cols[present], eta[present], int(np.count_nonzero(present))
    coef = _least_squares(cols, eta, ridge * n if oversample > 1 else 0.0)
    m = omega.size
    a, b = coef[2:2 + m], coef[2 + m:]
    amplitude = np.hypot(a, b)
    phase = np.mod(np.arctan2(b, a), 2.0 * np.pi)  # A cos(ωτ − φ) = A cos(−ωτ + φ)

    if taper != "none" and oversample == 1:
        # The Hann selection keeps the ±1 neighbours of each line; drop what the refit finds empty.
        sig = amplitude >= rel_threshold * float(np.max(amplitude))
        omega, amplitude, phase = omega[sig], amplitude[sig], phase[sig]

    return omega, amplitude, phase


def predict_from_buoy(t, eta, x_buoy: float, x_vehicle: float, water_depth: float, *,
                      window_s: float = 300.0, f_min: float = 0.05, f_max: float = 0.5,
                      rel_threshold: float = 0.05, deep_water: bool = False, taper: str = "none",
                      oversample: int = 1, ridge: float = 1e-3, g: float = G, now: float | None = None,
                      source: str = "dswp", seq: int = 0, horizon_s: float | None = None,
                      allow_gaps: bool = False) -> Forecast:
    """Linear deterministic wave prediction at ``x_vehicle`` from the buoy record (t, eta) at ``x_buoy``.

    Parameters
    ----------
    t, eta : buoy sample times (s, vehicle clock, uniform, increasing) and elevations (m, up).
    x_buoy, x_vehicle : positions along the wave direction (m); D = x_vehicle − x_buoy must be > 0.
    water_depth : d (m), for the dispersion relation (and the forecast's kinematics).
    window_s : use the newest ``window_s`` seconds (round(window_s/Δt) samples; all if fewer). The
        default 300 s gives 1/300 Hz resolution, far above the minimum D/c_g,min − D/c_g,max
        (≈ 29 s for 50 m over 0.05–0.5 Hz at 54 m).
    f_min, f_max : band of bins considered (Hz).
    rel_threshold : keep bins with amplitude ≥ rel_threshold × the largest in-band amplitude.
    deep_water : propagate with the deep-water k = ω²/g (the authors' choice) instead of the
        finite-depth dispersion relation; the validity window stays on finite-depth c_g.
    taper : "none" (rectangular, default) or "hann" — used only to select bins; see module docstring.
    oversample : frequencies fitted per kept DFT bin (1: the plain FFT components; e.g. 4: the
        oversampled ridge fit of the module docstring).
    ridge : relative ridge weight λ, used only when oversample > 1.
    now : time of prediction (vehicle clock); samples after it are ignored. Default: the last sample.
    source, seq : copied into the Forecast.
    horizon_s : None (default): valid until the predictable zone closes (t_e + D/c_g,max); a number:
        valid until t_e + ``horizon_s`` instead, a fixed horizon that may overstate the zone.
    allow_gaps : accept lost samples (NaN elevations on the uniform grid): bins are selected on the
        record with the gaps interpolated, the fit uses the present samples only; at least
        :data:`MIN_PRESENT` of the window must be present.

    Returns a :class:`Forecast` with x_ref = x_buoy, time_base = the newest used sample time,
    second_order = False, and valid_from/valid_until the predictable zone at x_vehicle.
    """
    _check_arguments(x_buoy, x_vehicle, water_depth, window_s, f_min, f_max, rel_threshold, g, taper,
                     oversample, ridge)
    oversample = int(oversample)
    distance = float(x_vehicle) - float(x_buoy)
    if horizon_s is not None and not (np.isfinite(horizon_s) and horizon_s > 0):
        raise ValueError(f"horizon_s must be positive and finite, got {horizon_s!r}")
    t, eta, dt = _check_record(t, eta, now, allow_gaps)

    # ------------------------------------------------------------------ window
    n = min(t.size, max(1, int(round(window_s / dt))))
    if n < _MIN_SAMPLES:
        raise ValueError(f"window_s = {window_s:g} s holds only {n} sample(s) at {1 / dt:g} Hz, "
                         f"need at least {_MIN_SAMPLES}")
    t, eta = t[-n:], eta[-n:]
    t_b = float(t[-1])
    # Sample times on the exact uniform grid ending at t_b (the check allowed tiny jitter)
    tau = (np.arange(n) - (n - 1)) * dt            # t − t_b, ≤ 0

    filled, present = _fill_gaps(eta)
    omega = _select_frequencies(filled, n, dt, f_min, f_max, rel_threshold, taper, oversample)
    omega, amplitude, phase = _fit_components(tau, eta, omega, n, dt, taper, oversample, ridge, rel_threshold,
                                              present)

    # ------------------------------------------------------------------ propagation and validity
    k = omega ** 2 / g if deep_water else wavenumber(omega, water_depth, g)
    cg = group_velocity(omega, water_depth, g=g)   # physical arrival: finite depth, whatever the k model
    cg_max, cg_min = float(np.max(cg)), float(np.min(cg))
    record_length = float((n - 1) * dt)
    valid_from, valid_until = predictable_zone(t_b, record_length, distance, cg_min, cg_max)
    if horizon_s is not None:
        valid_until = t_b + float(horizon_s)

    return Forecast(amplitude=amplitude, omega=omega, k=k, phase=phase, water_depth=float(water_depth),
                    x_ref=float(x_buoy), time_base=t_b, valid_from=valid_from, valid_until=valid_until,
                    second_order=False, source=source, seq=int(seq))
