"""Motor mixer: body wrench → eight thruster thrusts → PWM (paper Eq. 13).

* Allocation by the Moore–Penrose pseudo-inverse of the matrix derived from
  the thruster layout, within ±``WK_THR_MAX`` per thruster, with attitude
  first: the pitch moment is allocated, then heave, then surge, each scaled
  down only as far as the thrust the previous ones left requires. Clipping
  each thruster alone would let a saturated heave demand (the vertical
  thrusters serve both) wipe out the pitch moment; ArduSub's Motors6DOF
  likewise gives roll/pitch/yaw priority over throttle. A vertical-plane
  wrench [X, Z, M] is allocated through the 3×8 matrix; a six-DoF one
  [X, Y, Z, K, M, N] (the firmware holding sway, roll and heading too) through
  the 6×8 matrix, roll, pitch and yaw first, then heave, then surge and sway
  together, scaled as one (ArduSub's Motors6DOF scales its linear demands
  together too): a sea's surge and sway loads then keep their direction on
  the four vectored thrusters when they saturate, whichever way the waves come.
* Motor-lag compensation: the motors follow their command with a first-order
  lag t_m, so over one period h the thrust moves a fraction 1 − e^{−h/t_m} of
  the way. The command that makes each motor *reach* its demand f_d by the end
  of the period is f_cmd = (f_d − e^{−h/t_m} f̂) / (1 − e^{−h/t_m}), where f̂ is the
  firmware's model of the motor's present thrust.
  The boost can exceed a thruster's range; clipping each thruster alone would
  again lose the pitch moment, so with ``WK_MOT_LIM`` 1 the command's wrench
  B f_cmd is re-allocated pitch first within ±``WK_THR_MAX`` (the rc companion:
  an autopilot's sticks reach no further, ``docs/companion.md``).
* Thrust → PWM through the inverse T200 curve (nominal), rounded to whole µs
  as an ESC takes them, 1100–1900 µs.

The mixer also reports the thrust it expects over the coming period (at t,
t + h/2, t + h) so the estimator's prediction uses the same motor model.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from bridge.models import kernels
from bridge.models.thrusters import T200Curve, ThrusterLayout, motor_lag_factors

from ..params.table import ParameterTable

__all__ = ["MixerOutput", "MotorMixer"]


@dataclass(frozen=True)
class MixerOutput:
    pwm: np.ndarray            # (8,) int µs
    thrust_demand: np.ndarray  # (8,) N, after allocation and clipping
    thrust_cmd: np.ndarray     # (8,) N, the steady-state thrust of the PWM sent
    tau_stages: np.ndarray     # (3, 3) expected thruster wrench [X, Z, M] at t, t + h/2, t + h
    tau6_stages: np.ndarray    # (3, 6) the same, all six DoF [X, Y, Z, K, M, N]


class _Settings(NamedTuple):
    """The mixer's parameters and what derives from them, for one ``ParameterTable.version``."""

    f_max: float            # WK_THR_MAX (N)
    f_min: float            # WK_THR_MIN (N)
    comp: bool              # WK_MOT_COMP
    lim: bool               # WK_MOT_LIM
    keep: float             # e^{−h/t_m}: the fraction of the old thrust left after one period
    gain: float             # 1 − e^{−h/t_m}
    lag: np.ndarray         # (3, 1): e^{−s/t_m} at the stage offsets s = 0, h/2, h


class _Allocation(NamedTuple):
    """A wrench's allocation: B (m × n), B⁺ (n × m), the axes' groups in priority order (``order``, group k
    its entries ``bounds[k]:bounds[k + 1]``), and B⁺'s columns as floats for the Python reference: per axis,
    (thruster indices, coefficients), all of them and only the non-zero ones. An exact zero of B⁺ adds ±0.0
    to a thrust, which is never −0.0 (every thrust starts at +0.0), so leaving it out changes no bit for a
    finite demand."""

    B: np.ndarray
    pinv: np.ndarray
    groups: tuple[tuple[int, ...], ...]
    order: np.ndarray
    bounds: np.ndarray
    cols_all: tuple[tuple[tuple[int, ...], tuple[float, ...]], ...]
    cols_nonzero: tuple[tuple[tuple[int, ...], tuple[float, ...]], ...]

    @classmethod
    def of(cls, B: np.ndarray, groups: tuple[tuple[int, ...], ...]) -> _Allocation:
        pinv = np.ascontiguousarray(np.linalg.pinv(B))   # C order: the kernel's compiled layout
        cols = [pinv[:, axis].tolist() for axis in range(B.shape[0])]
        n = B.shape[1]
        bounds = np.cumsum([0] + [len(g) for g in groups])
        return cls(B, pinv, groups, np.array([a for g in groups for a in g], dtype=np.int64), bounds.astype(np.int64),
                   tuple((tuple(range(n)), tuple(col)) for col in cols),
                   tuple((tuple(i for i, b in enumerate(col) if b != 0.0), tuple(b for b in col if b != 0.0))
                         for col in cols))


PRIORITY_PLANAR = ((2,), (1,), (0,))
"""[X, Z, M]'s allocation order: pitch, heave, surge."""
PRIORITY_SIX = ((3,), (4,), (5,), (2,), (0, 1))
"""[X, Y, Z, K, M, N]'s allocation order: roll, pitch, yaw, then heave, then surge and sway together."""


class MotorMixer:
    def __init__(self, layout: ThrusterLayout, curve: T200Curve, params: ParameterTable, h: float):
        self.layout = layout
        self.curve = curve
        self.params = params
        self.h = float(h)
        self._planar = _Allocation.of(layout.allocation_matrix(), PRIORITY_PLANAR)
        self._six = _Allocation.of(layout.wrench_matrix(), PRIORITY_SIX)
        self.B = self._planar.B
        self.B_pinv = self._planar.pinv
        self.B6 = self._six.B
        self.f_hat = np.zeros(layout.n)
        self._stage_offsets = np.array([0.0, 0.5 * self.h, self.h])

    def reset(self) -> None:
        self.f_hat = np.zeros(self.layout.n)

    def wrench(self) -> np.ndarray:
        """The body wrench [X, Z, M] (N, N, N m) the motors give now, by the motor model: B f̂."""
        return self.B @ self.f_hat

    def wrench6(self) -> np.ndarray:
        """The six-DoF body wrench [X, Y, Z, K, M, N] (N, N m) the motors give now, by the motor model."""
        return self.B6 @ self.f_hat

    def settings(self) -> _Settings:
        """The mixer's parameters, read from the table again only when it has changed (its ``version``)."""
        return self.params.derived(self._read_settings)

    def _read_settings(self, p: ParameterTable) -> _Settings:
        t_m = p["WK_MOT_TC"]
        keep = math.exp(-self.h / t_m)
        # motor_lag_stages' factors (numpy's exp, which may differ from math.exp in the last bit)
        lag = motor_lag_factors(t_m, self._stage_offsets)
        return _Settings(p["WK_THR_MAX"], p["WK_THR_MIN"], bool(p["WK_MOT_COMP"]), bool(p["WK_MOT_LIM"]),
                         keep, 1.0 - keep, lag)

    def output(self, pwm: np.ndarray, f_d: np.ndarray | None = None) -> MixerOutput:
        """Send these PWM values (µs); keeps the firmware's motor model in step."""
        f_sent = self.curve.thrust(pwm)
        return self._output(pwm, f_sent.copy() if f_d is None else f_d, f_sent)

    def _output(self, pwm: np.ndarray, f_d: np.ndarray, f_sent: np.ndarray) -> MixerOutput:
        """:meth:`output` with the sent thrusts (N) known: the motor model's three stages, the wrenches."""
        # motor_lag_stages(f_sent, f̂, t_m, offsets): f + e^{−s/t_m} (f̂ − f), the lag factors kept as a column
        stages = f_sent + self.settings().lag * (self.f_hat - f_sent)
        self.f_hat = stages[-1]
        return MixerOutput(pwm, f_d, f_sent, stages @ self.B.T, stages @ self.B6.T)

    def mix(self, tau: np.ndarray) -> MixerOutput:
        """Allocate the body wrench τ, [X, Z, M] or all six DoF [X, Y, Z, K, M, N], and return the PWM to send."""
        st = self.settings()
        alloc = self._six if len(tau) == 6 else self._planar
        f_d = self._allocate(tau, st.f_max, alloc)
        if st.comp:
            keep, gain = st.keep, st.gain
            f_cmd = [(fd - keep * fh) / gain for fd, fh in zip(f_d, self.f_hat.tolist(), strict=True)]
            if st.lim:
                # The compensated command re-allocated attitude first: its boost never clips pitch away
                f_cmd = self._allocate(alloc.B @ np.array(f_cmd), st.f_max, alloc)
        else:
            f_cmd = f_d
        # Below WK_THR_MIN a thruster is sent neutral: the curve is flat at the dead band's edge,
        # so a residual of a few mN would otherwise hold it at 1472/1528 µs indefinitely.
        f_min = st.f_min
        pwm, f_sent = self.curve.command([0.0 if abs(f) < f_min else f for f in f_cmd])
        return self._output(pwm, np.array(f_d), f_sent)

    def allocate(self, tau: np.ndarray, f_max: float) -> np.ndarray:
        """Thrusts (N) for the wrench τ ([X, Z, M] or six DoF), attitude first, every thruster within ±f_max."""
        return np.array(self._allocate(tau, f_max, self._six if len(tau) == 6 else self._planar))

    def _allocate(self, tau: np.ndarray, f_max: float, alloc: _Allocation) -> list[float]:
        """:meth:`allocate` as floats.

        The same IEEE operations as the array form (B⁺ column times τ, the largest scale within
        ±f_max, f + scale g), in floats: eight thrusters and three axes cost a tenth of the time;
        compiled (:func:`~bridge.models.kernels.allocate_arr`, the same bits) a third of that again.
        """
        if kernels.ENABLED:
            return kernels.allocate_arr(alloc.pinv, np.ascontiguousarray(tau, dtype=float), alloc.order,
                                        alloc.bounds, float(f_max)).tolist()
        f = [0.0] * self.layout.n
        neg_max = -f_max
        for group in alloc.groups:
            if len(group) > 1:
                idx, g = self._group_push(tau, group, alloc)
            else:
                axis = group[0]
                ta = float(tau[axis])
                if ta == 0.0:
                    continue     # g = ±0.0 everywhere: no limit on the scale (1), f + 1·(±0.0) = f
                # 0 · ±inf = NaN reaches every thruster: then all of them
                idx, col = alloc.cols_nonzero[axis] if math.isfinite(ta) else alloc.cols_all[axis]
                g = [b * ta for b in col]
            # Largest s in [0, 1] with |f + s g| ≤ f_max for every thruster: min() and max() spelt
            # out, the same comparisons (NaN included) without the calls
            room = math.inf
            for i, gi in zip(idx, g, strict=True):
                if gi > 0:
                    r = (f_max - f[i]) / gi
                elif gi < 0:
                    r = (neg_max - f[i]) / gi
                else:
                    continue
                if r < room:
                    room = r
            if room >= 1.0:      # s = 1: 1 · g is g
                for i, gi in zip(idx, g, strict=True):
                    f[i] = f[i] + gi
            else:
                scale = room if room > 0.0 else 0.0
                for i, gi in zip(idx, g, strict=True):
                    f[i] = f[i] + scale * gi
        return f

    @staticmethod
    def _group_push(tau: np.ndarray, group: tuple[int, ...], alloc: _Allocation) -> tuple[tuple[int, ...], list[float]]:
        """A group's thrust direction g = Σ B⁺[:, axis] τ[axis] over every thruster, summed in the kernel's order."""
        idx, first = alloc.cols_all[group[0]]
        ta = float(tau[group[0]])
        g = [b * ta for b in first]
        for axis in group[1:]:
            ta = float(tau[axis])
            g = [gi + b * ta for gi, b in zip(g, alloc.cols_all[axis][1], strict=True)]
        return idx, g

    def neutral(self) -> MixerOutput:
        """Every thruster at the neutral pulse (disarmed, failsafe)."""
        pwm = np.full(self.layout.n, int(round(self.curve.pwm_neutral)), dtype=np.int64)
        return self.output(pwm, np.zeros(self.layout.n))
