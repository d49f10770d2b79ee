"""Design waves embedded in a random sea: NewWave and the constrained NewWave (docs/models.md, *Design waves*).

The long-crested sea's components along north (+x); a design wave is refused in a sea from another
direction (the sea config's check).
"""
from __future__ import annotations

import numpy as np

from bridge.models.waves import WaveComponents, elevation

__all__ = ["constrained_newwave", "newwave"]


def newwave(components: WaveComponents, crest: float, x0: float, t0: float) -> WaveComponents:
    """The linear NewWave of a crest ``crest`` (m) at (x0 (m), t0 (s)) on the components' frequencies.

    NewWave (Tromans, Anaturk & Hagemeijer 1991) is the most probable shape of
    a large linear crest: component i carries α σ_i²/σ² with σ_i² = A_i²/2 its
    variance and σ² = Σ σ_i², all in phase at the focus, so the elevation at x0
    is α R(τ)/R(0), R the autocorrelation of the sea's spectrum.
    """
    var = 0.5 * components.amplitude**2
    amp = crest * var / var.sum()
    phase = -components.k * x0 + components.omega * t0
    return WaveComponents(amp, components.omega.copy(), components.k.copy(), phase, components.water_depth,
                          components.second_order)


def _constrain_linear(c: WaveComponents, alpha: float, x0: float, t0: float, slope: float = 0.0) -> WaveComponents:
    """Gaussian conditioning of the linear components on ζ₁(x0, t0) = α and ∂ζ₁/∂t (x0, t0) = ``slope`` (m/s).

    With φ_i the phase at the focus, a_i = A_i cos φ_i and b_i = A_i sin φ_i (variance σ_i² each):
    ζ₁(x0, t0) = Σ a_i and ∂ζ₁/∂t = Σ ω_i b_i. The constrained coefficients are
    a_i + (α − Σ a_j) σ_i²/Σσ_j² and b_i − (Σ ω_j b_j) ω_i σ_i²/Σ ω_j² σ_j² (Taylor et al. 1997):
    the random sea plus a NewWave of the missing crest, minus the record's own slope there
    (a ``slope`` other than 0 lets :func:`constrained_newwave` cancel the 2nd-order terms' slope).
    """
    var = 0.5 * c.amplitude**2
    phi = c.k * x0 - c.omega * t0 + c.phase
    a, b = c.amplitude * np.cos(phi), c.amplitude * np.sin(phi)
    a = a + (alpha - a.sum()) * var / var.sum()
    b = b - (c.omega @ b - slope) * c.omega * var / (c.omega**2 @ var)
    phase = np.arctan2(b, a) - c.k * x0 + c.omega * t0
    return WaveComponents(np.hypot(a, b), c.omega.copy(), c.k.copy(), phase, c.water_depth, c.second_order)


def _with_amplitudes(c: WaveComponents, amplitude: np.ndarray) -> WaveComponents:
    return WaveComponents(amplitude, c.omega, c.k, c.phase, c.water_depth, c.second_order)


def constrained_newwave(components: WaveComponents, crest: float, x0: float, t0: float) -> WaveComponents:
    """The random sea ``components`` re-phased so that its elevation at (x0, t0) is a crest of ``crest`` m.

    Constrained NewWave (Taylor, Jonathan & Harland 1997) conditions the random
    linear coefficients on the crest and a zero time slope
    (:func:`_constrain_linear`). Here the phases are taken from that
    conditioned sea and the amplitudes stay the spectrum's √(2 S(ω_i) Δω): with
    fixed amplitudes and the ≈ 25 components that carry a JONSWAP sea's energy,
    full conditioning would add the group's energy to every component and
    raise the realised Hs by 10–30 % for a 4 m crest in W2; re-phasing keeps Hs
    exactly while the group near the focus keeps NewWave's shape (correlation
    ≈ 0.9 over ±20 s). The conditioning crest λ is solved (Brent, to 1e-13 m) so
    that the total elevation ζ(x0, t0), Stokes 2nd-order terms included, is
    ``crest``. Raises ValueError if the components cannot reach it (at most
    Σ A_i when all are in phase).
    """
    from scipy.optimize import brentq  # imported on first use

    if not crest > 0:
        raise ValueError(f"the focused crest must be positive, got {crest}")
    amp = components.amplitude
    excess = lambda lam: float(  # noqa: E731
        elevation(_with_amplitudes(_constrain_linear(components, lam, x0, t0), amp), x0, t0)) - crest
    lo, hi = 0.0, crest
    while excess(hi) < 0.0:
        lo, hi = hi, 2.0 * hi
        if hi > 1e3 * crest:
            raise ValueError(f"a crest of {crest} m is out of reach of these components (Σ A = {amp.sum():.2f} m)")
    lam = brentq(excess, lo, hi, xtol=1e-13, rtol=4 * np.finfo(float).eps)
    # Then the crest (ζ = crest) and the zero time slope of the total elevation together (Newton)
    focused = lambda v: _with_amplitudes(_constrain_linear(components, v[0], x0, t0, v[1]), amp)  # noqa: E731
    dt = 1e-4   # s: central difference for ∂ζ/∂t, error O(dt² ω³ A) < 1e-9 m/s

    def residual(v: np.ndarray) -> np.ndarray:
        z = elevation(focused(v), x0, np.array([t0 - dt, t0, t0 + dt]))
        return np.array([z[1] - crest, (z[2] - z[0]) / (2.0 * dt)])

    v = np.array([lam, 0.0])
    for _ in range(30):
        r = residual(v)
        if abs(r[0]) < 1e-11 and abs(r[1]) < 1e-9:
            break
        jac = np.column_stack([(residual(v + e) - r) / 1e-6 for e in np.eye(2) * 1e-6])
        v = v - np.linalg.solve(jac, r)
    else:
        raise ValueError(f"could not focus a crest of {crest} m at x = {x0} m, t = {t0} s")
    return _with_amplitudes(_constrain_linear(components, v[0], x0, t0, v[1]), amp.copy())
