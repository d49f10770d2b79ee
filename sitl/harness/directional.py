"""A directional estimate from a small wave-gauge array: the check of a short-crested sea's spreading.

Three gauges on a small triangle (radius R ≪ the wavelengths) give the elevation ζ and, from the
plane through them, its slopes ζ_x, ζ_y: a pitch-roll buoy's three signals. Longuet-Higgins,
Cartwright & Smith (1963) give the first directional Fourier coefficients per frequency from their
cross-spectra, with C the co- and Q the quadrature spectrum (numpy's FFT sign convention):

    a₁ = −Q(ζ, ζ_x) / √(C(ζ,ζ) (C(ζ_x,ζ_x) + C(ζ_y,ζ_y))),   b₁ likewise with ζ_y,

which for a single wave at β are cos β and sin β. Averaged over a band with the energy as weight,
the mean direction is atan2(b₁, a₁) and r₁ = √(a₁² + b₁²) = E[cos(β − β_m)], which is s/(s + 1)
for a cos-2s spreading: the estimate of s is r₁/(1 − r₁). (A sea of one direction per frequency,
as Wavekeep's, shows its spreading over a band, not within one bin.)
"""
from __future__ import annotations

import numpy as np

__all__ = ["directional_moments", "triangle_array"]


def triangle_array(x: float, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Gauge positions (x (m), y (m)) of an equilateral triangle of ``radius`` (m) centred on (x, 0)."""
    ang = np.radians([0.0, 120.0, 240.0])
    return x + radius * np.cos(ang), radius * np.sin(ang)


def directional_moments(eta: np.ndarray, gx: np.ndarray, gy: np.ndarray, dt: float,
                        band: tuple[float, float]) -> dict[str, float]:
    """Mean direction (deg from +x), r₁ and the cos-2s exponent s ≈ r₁/(1 − r₁) of the band (Hz).

    ``eta`` has shape (T, G): the records of G ≥ 3 gauges at (gx, gy) (m), sampled every ``dt`` s.
    """
    eta = np.asarray(eta, dtype=float)
    design = np.column_stack([np.ones(len(gx)), np.asarray(gx) - np.mean(gx), np.asarray(gy) - np.mean(gy)])
    coef = np.linalg.lstsq(design, eta.T, rcond=None)[0]              # (3, T): ζ, ζ_x, ζ_y at the centre
    spec = np.fft.rfft(coef - coef.mean(axis=1, keepdims=True), axis=1)
    f = np.fft.rfftfreq(eta.shape[0], dt)
    sel = (f >= band[0]) & (f <= band[1])
    z, zx, zy = spec[:, sel]
    c11 = np.abs(z) ** 2
    norm = np.sqrt(c11 * (np.abs(zx) ** 2 + np.abs(zy) ** 2))
    ok = norm > 0
    a1 = -np.imag(np.conj(z[ok]) * zx[ok]) / norm[ok]
    b1 = -np.imag(np.conj(z[ok]) * zy[ok]) / norm[ok]
    w = c11[ok] / c11[ok].sum()
    a, b = float(w @ a1), float(w @ b1)
    r1 = float(np.hypot(a, b))
    return {"mean_direction_deg": float(np.degrees(np.arctan2(b, a))), "r1": r1,
            "s": r1 / (1.0 - r1) if r1 < 1.0 else float("inf")}
