"""The lateral-directional plane's hold: sway (east position), roll level and heading.

The vertical plane's laws (C-PD with its FF and DOB, the preview MPC) hold x, depth and pitch; in a
six-DoF world the same cascade (:func:`~firmware_py.control.cascaded_pd.cascade`) holds the other three,
with every law: the errors are

* sway: the horizontal position error rotated into the body by the heading,
  e_v = −sin ψ (x_r − x̂) + cos ψ (y_r − ŷ);
* roll: 0 − φ̂ (level; the hydrostatic stiffness z_b B is kept, as the pitch's about its setpoint);
* heading: ψ_r − ψ̂, wrapped to (−π, π];

with the body rates v, p, r as the inner loop's velocities and the gains ``WK_*_Y``, ``_R``, ``_H``.
Feed-forward (``WK_FF_ENABLE``, while the vertical plane's is on): −g_ff · τ_wave of the sway force and
the roll and yaw moments the forecast predicts at the end of the period on the body moving with its
estimated ν (the vertical plane's robust monitor and skill weights are not applied here).
"""
from __future__ import annotations

import math

import numpy as np

from ..hal.sensors import wrap_angle
from ..params.table import ParameterTable
from .cascaded_pd import Gains, cascade

__all__ = ["LateralHold"]

_FAMILIES = ("WK_PD_KP", "WK_PD_KD", "WK_VEL_MAX", "WK_VEL_KP", "WK_TAU_MAX")


def _gains(p: ParameterTable) -> Gains:
    kp, kd, vmax, kv, tau_max = (p.lateral_axes(name) for name in _FAMILIES)
    return kp, kd, vmax, kv, tau_max


class LateralHold:
    """Sway, roll and heading by the cascaded PD, one tick at a time (its memory: the last errors)."""

    def __init__(self, params: ParameterTable):
        self.params = params
        self._prev: tuple[float, float, float] | None = None

    def reset(self) -> None:
        self._prev = None

    def errors(self, x_hat: np.ndarray, x_lat: np.ndarray, target: np.ndarray) -> tuple[float, float, float]:
        """[e_v (m, body), e_φ, e_ψ (rad)] for the vertical plane's estimate [x, z, θ, …], the lateral one
        [y, φ, ψ, …] and the target [x_r, y_r, ψ_r] (NED m, rad)."""
        x, y, phi, psi = float(x_hat[0]), float(x_lat[0]), float(x_lat[1]), float(x_lat[2])
        e_n, e_e = float(target[0]) - x, float(target[1]) - y
        return (-math.sin(psi) * e_n + math.cos(psi) * e_e, -phi, wrap_angle(float(target[2]) - psi))

    def update(self, x_hat: np.ndarray, x_lat: np.ndarray, target: np.ndarray, tau_wave: np.ndarray | None,
               dt: float) -> tuple[np.ndarray, np.ndarray, bool]:
        """τ_L = [Y, K, N] for this tick, its feed-forward part and whether an axis saturated.

        ``tau_wave``: the predicted lateral wave load [Y, K, N] (None: no feed-forward)."""
        e = self.errors(x_hat, x_lat, target)
        prev = self._prev
        de = (0.0, 0.0, 0.0) if prev is None else tuple((ei - pi) / dt for ei, pi in zip(e, prev, strict=True))
        if prev is not None:     # a heading error crossing ±π is a small step, not a 2π one
            de = (de[0], de[1], wrap_angle(e[2] - prev[2]) / dt)
        self._prev = e
        ff = [0.0, 0.0, 0.0] if tau_wave is None else [-self.params["WK_FF_GAIN"] * float(t) for t in tau_wave]
        nu = (float(x_lat[3]), float(x_lat[4]), float(x_lat[5]))
        tau, saturated = cascade(e, de, nu, self.params.derived(_gains), ff, None)
        return np.array(tau), np.array(ff), saturated
