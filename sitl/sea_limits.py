"""How steep a sea the model can fly: the limit on a sea state's significant steepness.

A sea state's significant steepness is S_p = 2π H_s / (g T_p²), the significant wave height
over the deep-water length of the peak wave. Real seas do not exceed about 1/15 at T_p ≤ 8 s
and 1/25 at T_p ≥ 15 s (linearly between): steeper waves break, which the linear + 2nd-order
Stokes sea does not model. Beyond that limit the plant also stops holding: at 5 m depth the
particle velocities reach several m/s, the quadratic drag's stiffness 2 X_u|u| |u_r| / (m − X_u̇)
grows past what the 20 Hz RK4 step can integrate, and the state blows up within a few steps
(Hs 25 m at Tp 8 s, S_p = 0.25: 1e30 in 0.15 s). At the limit itself every T_p from 3 s to 20 s
flies 300 s with finite state, so the schema refuses what lies beyond it (docs/models.md).
"""
from __future__ import annotations

import math

from bridge.models.waves import G

__all__ = ["max_hs", "max_steepness", "steepness"]


def max_steepness(tp: float) -> float:
    """Largest significant steepness of a real sea with peak period ``tp`` (s): 1/15 up to 8 s, 1/25 from 15 s."""
    if tp <= 8.0:
        return 1.0 / 15.0
    if tp >= 15.0:
        return 1.0 / 25.0
    return 1.0 / 15.0 + (1.0 / 25.0 - 1.0 / 15.0) * (tp - 8.0) / 7.0


def steepness(hs: float, tp: float) -> float:
    """Significant steepness S_p = 2π H_s / (g T_p²) of H_s (m) at T_p (s)."""
    return 2.0 * math.pi * hs / (G * tp * tp)


def max_hs(tp: float) -> float:
    """Largest H_s (m) the model flies at peak period ``tp`` (s)."""
    return max_steepness(tp) * G * tp * tp / (2.0 * math.pi)
