"""Blue Robotics T200 thrusters and the BlueROV2 Heavy thruster layout.

* :class:`T200Curve` — PWM (µs) ↔ steady-state thrust (N) at 16 V through the
  published samples (docs/reference.md §5): monotone cubic (PCHIP) interpolation, flat
  zero in the dead band, asymmetric forward/reverse limits.
* :class:`ThrusterLayout` — positions and positive-thrust directions in the body
  FRD frame; the allocation matrix B (τ = B f) is derived from them as
  [f; r × f], never typed in.
* :func:`power_per_dof` — the paper's T200 power polynomial applied to |τ|.
* :func:`motor_lag_stages`, :func:`motor_lag_factors` — the motors' first-order lag under a held command.
"""
from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from . import kernels
from .pchip import Pchip

__all__ = ["KGF", "NEUTRAL_PWM_US", "WRENCH_AXES", "T200Curve", "ThrusterLayout", "motor_lag_factors",
           "motor_lag_stages", "power_per_dof"]

KGF = 9.80665
"""Newtons per kilogram-force."""

NEUTRAL_PWM_US = 1500
"""The ESC's stop pulse (µs): ArduSub's neutral output and an RC stick at centre."""

WRENCH_AXES = ("X", "Y", "Z", "K", "M", "N")
"""Rows of the 6-DoF wrench matrix: forces along body x, y, z; moments about x, y, z."""


_FEW = 16
"""Up to this many values (one vehicle's thrusters), thrust() and pwm() work in Python floats."""

_MEMO = 4096
"""thrust_values() keeps the thrust of this many distinct PWM values (the 801 whole µs of 1100–1900 fit)."""


class T200Curve:
    """Steady-state T200 thrust as a function of PWM pulse width.

    pwm_us and thrust_n are the published samples (µs, N), increasing in PWM,
    with two zero-thrust samples bounding the dead band.
    """

    def __init__(self, pwm_us, thrust_n, pwm_min: float = 1100.0, pwm_max: float = 1900.0,
                 pwm_neutral: float = NEUTRAL_PWM_US):
        pwm = np.asarray(pwm_us, dtype=float)
        f = np.asarray(thrust_n, dtype=float)
        if pwm.shape != f.shape or pwm.size < 4:
            raise ValueError("T200 curve needs matching PWM and thrust samples (at least 4)")
        if np.any(np.diff(pwm) <= 0) or np.any(np.diff(f) < 0):
            raise ValueError("T200 curve samples must increase with PWM")
        zero = np.flatnonzero(f == 0.0)
        if zero.size != 2 or zero[1] != zero[0] + 1:
            raise ValueError("T200 curve needs exactly two zero-thrust samples bounding the dead band")
        self.pwm_samples, self.thrust_samples = pwm, f
        # floats whatever the caller passed: an integer neutral made pwm()'s output integer (np.full's dtype)
        self.pwm_min, self.pwm_max, self.pwm_neutral = float(pwm_min), float(pwm_max), float(pwm_neutral)
        self.deadband = (pwm[zero[0]], pwm[zero[1]])
        self._fwd = Pchip(pwm, f)   # SciPy's PchipInterpolator to the last bit, without importing SciPy
        self.thrust_min, self.thrust_max = float(self._fwd(pwm_min)), float(self._fwd(pwm_max))
        # Exact inverse of the forward curve on each strictly monotone branch (beyond the
        # dead band), tabulated every 0.05 µs: thrust(pwm(f)) = f to ~1e-6 N.
        lo, hi = self.deadband
        self._rev_pwm = np.linspace(pwm_min, lo, int(round((lo - pwm_min) / 0.05)) + 1)
        self._fwd_pwm = np.linspace(hi, pwm_max, int(round((pwm_max - hi) / 0.05)) + 1)
        self._rev_f = self._fwd(self._rev_pwm)
        self._fwd_f = self._fwd(self._fwd_pwm)
        self._thrust_memo: dict[float, float] = {}

    def thrust(self, pwm) -> np.ndarray:
        """Thrust (N, positive along the thruster's direction) for PWM (µs), clipped to 1100–1900 µs."""
        p = np.asarray(pwm, dtype=float)
        if p.ndim == 1 and p.size <= _FEW:
            return np.array(self.thrust_values(p.tolist()))
        p = np.minimum(np.maximum(p, self.pwm_min), self.pwm_max)   # np.clip, cheaper
        return self._fwd(p)

    def thrust_values(self, pwm: Iterable[float]) -> list[float]:
        """:meth:`thrust` of a few PWM values (µs), as floats (N): the same bits, a fraction of the time.

        ESCs take whole microseconds, so the same few hundred pulses recur: each value's thrust is
        kept (up to ``_MEMO`` of them) and looked up the next time.
        """
        memo, lo, hi = self._thrust_memo, self.pwm_min, self.pwm_max
        out = []
        for p in pwm:
            f = memo.get(p)
            if f is None:
                p = float(p)
                # np.minimum(np.maximum(p, lo), hi): NaN passes through as numpy's does
                f = self._fwd.values((lo if p < lo else (hi if p > hi else p),))[0]
                if p == p and len(memo) < _MEMO:
                    memo[p] = f
            out.append(f)
        return out

    def command(self, thrust: list[float]) -> tuple[np.ndarray, np.ndarray]:
        """The whole-µs PWM (int64, as an ESC takes them) for each thrust (N), and the thrust (N) it gives.

        ``rint(pwm(f))`` and ``thrust`` of that, bit for bit; compiled
        (:func:`~bridge.models.kernels.t200_command_arr`) when the kernels are on.
        """
        if kernels.ENABLED:
            return kernels.t200_command_arr(np.array(thrust, dtype=float), self.thrust_min, self.thrust_max,
                                            self.pwm_neutral, self._rev_f, self._rev_pwm, self._fwd_f,
                                            self._fwd_pwm, self.pwm_min, self.pwm_max,
                                            self._fwd.x, self._fwd.c)
        # round() is np.rint's half-to-even; the PWM is finite (pwm_values maps NaN to neutral)
        pwm = [round(v) for v in self.pwm_values(thrust)]
        return np.array(pwm, dtype=np.int64), np.array(self.thrust_values(pwm))

    def pwm(self, thrust) -> np.ndarray:
        """PWM (µs) that gives ``thrust`` (N); zero maps to neutral, out-of-range thrust saturates."""
        f = np.asarray(thrust, dtype=float)
        if f.ndim == 1 and f.size <= _FEW:
            return np.array(self.pwm_values(f.tolist()))
        f = np.minimum(np.maximum(f, self.thrust_min), self.thrust_max)
        out = np.full(f.shape, self.pwm_neutral)
        pos, neg = f > 0.0, f < 0.0
        out[pos] = np.interp(f[pos], self._fwd_f, self._fwd_pwm)
        out[neg] = np.interp(f[neg], self._rev_f, self._rev_pwm)
        return out if out.ndim else float(out)  # type: ignore[return-value]  # a scalar in, a scalar out

    def pwm_values(self, thrust: Iterable[float]) -> list[float]:
        """:meth:`pwm` of a few thrusts (N), as floats (µs): the same bits, a fraction of the time.

        The clip and the sign test in floats, then one ``np.interp`` per branch on the thrusts that
        take it (numpy's own loop: its binary search over the contiguous table stays in cache,
        where a bisect over the table as Python floats would not).
        """
        values = [float(v) for v in thrust]
        lo, hi = self.thrust_min, self.thrust_max
        out = [self.pwm_neutral] * len(values)   # zero, and NaN (neither > 0 nor < 0), as pwm()'s masks
        pos: list[int] = []
        neg: list[int] = []
        for i, f in enumerate(values):
            f = lo if f < lo else (hi if f > hi else f)     # np.minimum(np.maximum(f, lo), hi): NaN passes
            values[i] = f
            if f > 0.0:
                pos.append(i)
            elif f < 0.0:
                neg.append(i)
        for idx, xp, fp in ((pos, self._fwd_f, self._fwd_pwm), (neg, self._rev_f, self._rev_pwm)):
            if idx:
                for i, v in zip(idx, np.interp([values[i] for i in idx], xp, fp).tolist(), strict=True):
                    out[i] = v
        return out

    @classmethod
    def from_config(cls, cfg: dict) -> T200Curve:
        """From the ``thrusters`` section of a vehicle config (PWM µs and thrust in kgf)."""
        curve = cfg["curve"]
        return cls(curve["pwm_us"], np.asarray(curve["thrust_kgf"]) * KGF,
                   cfg["pwm_min"], cfg["pwm_max"], cfg["pwm_neutral"])


@dataclass(frozen=True)
class ThrusterLayout:
    """Thruster positions r_i (m) and unit thrust directions d_i in body FRD, one row each."""

    positions: np.ndarray
    directions: np.ndarray
    names: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        r = np.asarray(self.positions, dtype=float)
        d = np.asarray(self.directions, dtype=float)
        if r.shape != d.shape or r.ndim != 2 or r.shape[1] != 3:
            raise ValueError("thruster positions and directions must both be (n, 3)")
        norms = np.linalg.norm(d, axis=1)
        if np.any(norms < 1e-9):
            raise ValueError("a thruster direction is zero")
        object.__setattr__(self, "positions", r)
        object.__setattr__(self, "directions", d / norms[:, None])

    @property
    def n(self) -> int:
        return self.positions.shape[0]

    def wrench_matrix(self) -> np.ndarray:
        """6×n matrix: unit thrust of each thruster → [X, Y, Z, K, M, N] about the body origin."""
        f = self.directions
        m = np.cross(self.positions, f)
        return np.vstack([f.T, m.T])

    def allocation_matrix(self) -> np.ndarray:
        """3×n planar allocation B_μ: thrusts (N) → [X, Z, M] (surge, heave, pitch)."""
        W = self.wrench_matrix()
        return W[[0, 2, 4], :]

    @classmethod
    def from_config(cls, cfg: dict) -> ThrusterLayout:
        items = cfg["layout"]
        return cls(np.array([t["position"] for t in items]), np.array([t["direction"] for t in items]),
                   tuple(t["name"] for t in items))


def power_per_dof(tau) -> np.ndarray:
    """Electrical power (W) per DoF from the paper's T200 fit, P = 0.0011|τ|³ + 0.02078|τ|² + 0.297|τ|.

    Applied element-wise to |τ| with τ in N (or N m for pitch, as the paper does).
    """
    a = np.abs(np.asarray(tau, dtype=float))
    return ((0.0011 * a + 0.02078) * a + 0.297) * a


def motor_lag_stages(f_cmd: np.ndarray, f0: np.ndarray, t_m: float, offsets) -> np.ndarray:
    """Thrust of first-order motors at time offsets s after a command step: f_cmd + (f₀ − f_cmd) e^{−s/t_m}.

    ``offsets`` (S,) in s; returns (S, n) thrusts (N).
    """
    return f_cmd + motor_lag_factors(t_m, offsets) * (f0 - f_cmd)


def motor_lag_factors(t_m: float, offsets) -> np.ndarray:
    """e^{−s/t_m} at the time offsets s (S,), as a column (S, 1): the share of a thrust step still to come.

    For callers that step at fixed offsets and keep them: :func:`motor_lag_stages` is
    ``f_cmd + motor_lag_factors(t_m, offsets) * (f0 − f_cmd)``.
    """
    return np.exp(-np.asarray(offsets, dtype=float) / t_m)[:, None]
