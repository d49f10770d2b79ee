"""The estimator's per-tick helpers (:mod:`firmware_py.estimation.estimator`): its parameters read once per table
version, the fusion's constants per set of accepted channels, and the innovation-driven noise scales.

The filter runs 20 times a second on vectors of 4–9 elements, where a numpy call costs more than the
arithmetic it does; the gating and the noise adaptation therefore run on Python floats, with
:mod:`firmware_py.numerics.floats` where Python's edge cases differ from numpy's.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..numerics.floats import square_over
from ..params.table import ParameterTable

__all__ = ["Subset", "Tuning", "innovation_scales", "selection_rows"]


_Q_NAMES = ("WK_EKF_Q_POS", "WK_EKF_Q_POS", "WK_EKF_Q_ANG", "WK_EKF_Q_VEL", "WK_EKF_Q_VEL", "WK_EKF_Q_RATE")
_Q_NAMES_AIDED = ("WK_EKF_Q_POS_A", "WK_EKF_Q_POS_A", "WK_EKF_Q_ANG_A", "WK_EKF_Q_VEL_A", "WK_EKF_Q_VEL_A",
                  "WK_EKF_Q_RATE_A", "WK_EKF_QD_X", "WK_EKF_QD_Z", "WK_EKF_QD_P", "WK_EKF_D_TC")


@dataclass(frozen=True, slots=True)
class Tuning:
    """The parameters :meth:`PlanarEKF.update <firmware_py.estimation.estimator.PlanarEKF.update>` reads every tick,
    read once per parameter-table version (dictionary look-ups cost more than the arithmetic they feed)."""

    r: tuple[float, ...]      # R's diagonal, per channel (m², rad², (rad/s)², (m/s)², (m/s²)²)
    r_vec: np.ndarray         # the same as a read-only array
    gate2: float              # WK_EKF_GATE² (NIS gate, σ²)
    rst_t: float              # WK_EKF_RST_T (s)
    acc_th: bool              # WK_EKF_ACC_TH: the accelerometer may correct θ
    qi_adpt: bool             # WK_EKF_QI_ADPT
    qd_tc: float              # WK_EKF_QD_TC (s)
    qi_tc: float              # WK_EKF_QI_TC (s)
    qi_tc_th: float           # WK_EKF_QI_TC_TH (s)
    qi_blk: float             # WK_EKF_QI_BLK (ticks)
    qi_max: float             # WK_EKF_QI_MAX
    q: tuple[float, ...]      # the process noise's WK_EKF_Q*_ (and, aided, QD_* and D_TC) values, in Q's order
    qd_adpt: bool             # WK_EKF_QD_ADPT
    qd_k: float               # WK_EKF_QD_K
    subsets: dict[int, Subset] = field(default_factory=dict, compare=False, repr=False)  # per accepted-channel mask

    @classmethod
    def of(cls, p: ParameterTable, r: np.ndarray, aided: bool) -> Tuning:
        """From the table, with R's diagonal ``r`` (which it keeps, read-only). The aided mode's parameters are
        read only when ``aided``; the paper's mode never uses them, and gets neutral values (no adaptation,
        the accelerometer free to correct θ)."""
        r.flags.writeable = False
        return cls(
            r=tuple(r.tolist()),
            r_vec=r,
            gate2=p["WK_EKF_GATE"] ** 2,
            rst_t=p["WK_EKF_RST_T"],
            acc_th=bool(p["WK_EKF_ACC_TH"]) if aided else True,
            qi_adpt=bool(p["WK_EKF_QI_ADPT"]) if aided else False,
            qd_tc=p["WK_EKF_QD_TC"] if aided else 1.0,
            qi_tc=p["WK_EKF_QI_TC"] if aided else 1.0,
            qi_tc_th=p["WK_EKF_QI_TC_TH"] if aided else 1.0,
            qi_blk=p["WK_EKF_QI_BLK"] if aided else 1.0,
            qi_max=p["WK_EKF_QI_MAX"] if aided else 1.0,
            q=tuple(p[n] for n in (_Q_NAMES_AIDED if aided else _Q_NAMES)),
            qd_adpt=bool(p["WK_EKF_QD_ADPT"]) if aided else False,
            qd_k=p["WK_EKF_QD_K"] if aided else 0.0,
        )


def selection_rows(states: tuple[int, ...], m: int, n: int) -> np.ndarray:
    """The (m, n) rows of H that do not depend on the state (read-only): a 1 at each directly measured
    channel's state (``states``, in channel order), zero elsewhere and in the further channels' rows."""
    H0 = np.zeros((m, n))
    for i, j in enumerate(states):
        H0[i, j] = 1.0
    H0.flags.writeable = False
    return H0


@dataclass(frozen=True, slots=True)
class Subset:
    """The fusion's constant inputs for one set of accepted channels (read-only arrays: they are handed to
    the filterpy object, kf.R, and shared between ticks)."""

    rows: tuple[int, ...]     # the accepted channels' indices, ascending
    index: np.ndarray         # the same as an index array (for the accelerometer's rows of H)
    H: np.ndarray | None      # their rows of H (k, n) when H is constant (no accelerometer row), else None
    R: np.ndarray             # diag of their noise variances (k, k)
    blind: tuple[int, ...]    # positions (within the accepted) of the channels whose gain on θ is held at 0

    @classmethod
    def of(cls, mask: int, H0: np.ndarray, r: tuple[float, ...], accel_channels: tuple[int, ...],
           acc_th: bool) -> Subset:
        """For the channels whose bits are set in ``mask``: ``H0`` the state-independent rows of H (all
        channels), ``r`` R's diagonal, ``accel_channels`` the accelerometer's (H rows that depend on the
        state, whose gain on θ is held at 0 unless ``acc_th``)."""
        rows = tuple(i for i in range(H0.shape[0]) if mask >> i & 1)
        index = np.array(rows, dtype=np.intp)
        accel = tuple(pos for pos, i in enumerate(rows) if i in accel_channels)
        H = None
        if not accel:                              # only state-selecting rows: H is a constant
            H = H0[index]
            H.flags.writeable = False
        R = np.diag(np.array(r)[index])
        R.flags.writeable = False
        index.flags.writeable = False
        return cls(rows, index, H, R, () if acc_th else accel)


def innovation_scales(lam: list[float], blk: list[float], y: list[float], S: list[float], avail: list[bool],
                      tune: Tuning, h: float, channels: tuple[int, int, int, int]) -> list[float]:
    """Innovation-driven scales λ on the process noise (``WK_EKF_QI_*``), from the channel's normalised
    innovation squared r, which a consistent filter keeps at E[r] = 1:
    λ ← clip(λ exp(a (r − 1)), 1, ``WK_EKF_QI_MAX``), r clipped at the gate's square.

    * The disturbance's variance per axis X, Z, M, from the channel that sees that axis' load at every
      tick (f_x, f_z, gyro), a = h / ``WK_EKF_QI_TC``: λ rests at 1 (the covariance-matched Q_d) and
      grows within a few ticks when the load changes faster than Q_d allows (a wave group).
    * The pitch's random walk, from the pitch sensor's innovations summed over blocks of
      ``WK_EKF_QI_BLK`` ticks, r = (Σ y)² / Σ S, a = block / ``WK_EKF_QI_TC_TH``. A consistent filter's
      innovations are white, so r is χ²(1) whatever the block; a slow pitch error the model does not
      explain (it follows the pitch motion: 3 % and a 15 ms lag of θ without a forecast) adds block² e²
      to (Σ y)², where one tick's e² is lost in the sensor's noise.

    ``lam`` [λ_X, λ_Z, λ_M, λ_θ] and ``channels`` the channel that drives each; ``blk`` the pitch
    innovations' block [Σ y, Σ S, ticks], updated in place; ``y``, ``S``: every channel's innovation and
    its variance this tick; ``avail``: which channels read; ``h`` (s) the period. Returns the new λ."""
    gate2 = tune.gate2
    lam = list(lam)
    for i, ch in enumerate(channels[:3]):
        if avail[ch]:
            r = min(square_over(y[ch], S[ch]), gate2)
            lam[i] = lam[i] * math.exp(h / tune.qi_tc * (r - 1.0))
    ch = channels[3]
    if avail[ch]:
        blk[0] += y[ch]
        blk[1] += S[ch]
        blk[2] += 1
        if blk[2] >= tune.qi_blk:
            r = min(square_over(blk[0], blk[1]), gate2)
            lam[3] *= math.exp(blk[2] * h / tune.qi_tc_th * (r - 1.0))
            blk[:] = [0.0, 0.0, 0.0]
    # np.clip's arithmetic (max with the floor, then min with the cap; NaN stays NaN) on 4 scalars
    return [min(max(v, 1.0), tune.qi_max) for v in lam]
