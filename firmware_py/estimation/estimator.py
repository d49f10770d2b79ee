"""Planar extended Kalman filter (paper §III-A), built on filterpy's ExtendedKalmanFilter.

State x = [x, z, θ, u, w, q] (NED position m, depth m, pitch rad; body velocities
m/s and pitch rate rad/s) and, in the aided mode (``WK_EKF_MODE`` 1, read at boot),
a disturbance wrench d = [d_X, d_Z, d_M] (N, N, N m, body frame): everything the
model does not predict — the wave load when there is no forecast, the forecast's
error when there is one — as a random walk (or a first-order Gauss–Markov process,
``WK_EKF_D_TC``) driven by ``WK_EKF_QD_*``. Prediction runs the shared vehicle model
(:func:`~bridge.models.vehicle.rk4_step`, nominal parameters) driven by the thrust the
firmware commanded (through its motor-lag model) plus d, plus, when a forecast is in
use, the predicted wave load. Its Jacobian F is taken from the continuous model by
finite differences, F ≈ I + A h + (A h)²/2 (with d: the block B h + A B h²/2, B = [0; M⁻¹]).

Measurements z = [x, depth, θ, q] and, aided, [u, w] from the DVL and the
accelerometer's specific force [f_x, f_z] = ν̇(x, τ + d) + ω × v − g_body, whose
model is the vehicle's own acceleration: the accelerometer sees the disturbance
through M⁻¹ d at every tick. Any reading may be missing on a tick. Each
available channel is gated on its normalised innovation |y_i| / √S_ii against
``WK_EKF_GATE``; rejected readings are counted per channel and never reach the
state. A directly measured channel whose readings have all been rejected for
``WK_EKF_RST_T`` seconds is reset to its measurement (state set, its covariance
row cleared to the measurement noise), as ArduPilot's EKF resets to GPS after a
timeout: a gate must not lock a good sensor out for ever once the model has been
wrong for a while. docs/estimator.md has the design and its consistency checks.

Aided, the process noise follows what the model leaves unexplained (``WK_EKF_QD_ADPT``,
``WK_EKF_QI_*``): the disturbance's density by covariance matching on its estimate's change,
scaled per axis by the accelerometer's and gyro's normalised innovations, and the pitch's random
walk by the pitch sensor's innovations summed over blocks. The accelerometer does not correct θ
(``WK_EKF_ACC_TH`` 0): its g sin θ term is a "consider" quantity (Schmidt update; S still carries θ's
uncertainty), because a surge disturbance the random walk lags behind would otherwise leak into θ.
"""
from __future__ import annotations

import math

import numpy as np
import scipy.linalg as linalg  # filterpy's EKF inverts S with it; so does _fuse (same bits)

from bridge.models.vehicle import BodyFlow, VehicleParams, rates_jacobian, rk4_step, state_rates_at

from ..hal.sensors import SensorFrame
from ..numerics.floats import ratio, sqrt
from ..params.table import ParameterTable
from .filterpy_ekf import ExtendedKalmanFilter
from .support import Subset, Tuning, innovation_scales, selection_rows

__all__ = ["CHANNELS", "MEASURED_STATES", "PlanarEKF"]

MEASURED_STATES = (0, 1, 2, 5, 3, 4)
"""State index of each directly measured channel: x, depth, pitch, pitch rate, DVL u, DVL w."""

CHANNELS = ("position", "depth", "pitch", "pitch_rate", "dvl_u", "dvl_w", "accel_x", "accel_z")
"""Measurement channels; the paper's mode uses the first four."""

_ACCEL_CHANNELS = (6, 7)
_EYE6 = np.eye(6)
_EYE6.flags.writeable = False
_QI_CHANNELS = (6, 7, 3, 2)
"""The channel whose innovations scale each adapted noise: the disturbance's X (f_x), Z (f_z), M (pitch rate)
and the pitch's random walk (pitch)."""


class _ModelEKF(ExtendedKalmanFilter):
    """filterpy EKF whose prediction integrates the nonlinear vehicle model (+ the disturbance states).

    (filterpy: override ``predict_x`` and set ``F``; see docs/platform-notes.md.)
    """

    def __init__(self, vehicle: VehicleParams, h: float, dim_x: int = 6):
        super().__init__(dim_x=dim_x, dim_z=len(CHANNELS) if dim_x > 6 else 4)
        self.vehicle = vehicle
        self.h = h
        self.tau_stages = np.zeros((3, 3))
        self.flow: BodyFlow | None = None
        self.d_decay = 1.0

    def predict_x(self, u=0):
        if self.dim_x == 6:
            self.x = rk4_step(self.vehicle, self.x[:, 0], self.h, self.tau_stages, self.flow).reshape(6, 1)
            return
        d = self.x[6:, 0]
        x6 = rk4_step(self.vehicle, self.x[:6, 0], self.h, self.tau_stages + d, self.flow)
        self.x = np.concatenate([x6, self.d_decay * d]).reshape(-1, 1)


class PlanarEKF:
    """The estimator of the control task: ``predict(τ stages)`` then ``update(frame)`` once per tick."""

    def __init__(self, vehicle: VehicleParams, params: ParameterTable, h: float):
        self.params = params
        self.h = float(h)
        self.aided = int(params.get("WK_EKF_MODE", 0)) == 1
        self.n = 9 if self.aided else 6
        self.channels = CHANNELS if self.aided else CHANNELS[:4]
        self.kf = _ModelEKF(vehicle, self.h, self.n)
        self.initialised = False
        self.rejected = dict.fromkeys(self.channels, 0)
        self.accepted = dict.fromkeys(self.channels, 0)
        self.resets = dict.fromkeys(self.channels, 0)
        self.restarts = 0                    # times the estimate stopped being finite and started again
        m = len(self.channels)
        self.last_nis = np.full(m, np.nan)   # normalised innovation squared per channel, last tick
        self.nis_total = (0.0, 0)            # the accepted readings' joint NIS yᵀS⁻¹y and its dof, last tick
        self._last_accept_t = np.full(m, -np.inf)
        self._q_key: tuple | None = None
        self._q = np.zeros((self.n, self.n))
        self._qd_param = [0.0, 0.0, 0.0]             # WK_EKF_QD_* (aided)
        self._dd_var: list[float] | None = None      # mean square change of d̂ per tick (adaptive Q_d)
        self._d_prev: list[float] | None = None
        self._meas_states = MEASURED_STATES[:min(m, 6)]
        # aided: B = ∂ẋ/∂d = [0; M⁻¹] and B h (constant); F's template: I with the disturbance's decay
        self._B = np.zeros((6, 3))
        self._B[3:, :] = vehicle.M_inv
        self._Bh = self._B * self.h
        self._h2_2, self._h3_3 = self.h * self.h / 2.0, self.h**3 / 3.0     # Van Loan's h²/2, h³/3
        self._F0_decay: float | None = None
        self._F0 = np.eye(9)
        self._lam = [1.0] * 4                        # innovation-driven scales on Q_d (X, Z, M) and Q_θ
        self._blk = [0.0, 0.0, 0.0]                  # pitch innovations' block: Σ y, Σ S, ticks
        self._H0 = selection_rows(self._meas_states, m, self.n)    # H's rows that do not depend on the state
        # aided, with an accelerometer reading: the template of H with its constant block ∂f/∂d = M⁻¹'s rows
        self._H0_acc = self._H0.copy()
        if self.aided:
            self._H0_acc[6:8, 6:] = vehicle.M_inv[:2, :]

    # ------------------------------------------------------------------ state
    @property
    def x(self) -> np.ndarray:
        """[x, z, θ, u, w, q] (the disturbance, aided, is :attr:`disturbance`)."""
        return self.kf.x[:6, 0]

    @property
    def disturbance(self) -> np.ndarray:
        """The estimated disturbance wrench [X, Z, M] (N, N, N m, body); zeros in the paper's mode."""
        return self.kf.x[6:, 0].copy() if self.aided else np.zeros(3)

    @property
    def P(self) -> np.ndarray:
        return self.kf.P

    def sigma(self) -> np.ndarray:
        """1-σ of every state (6, or 9 aided)."""
        return np.sqrt(self.kf.P.diagonal())

    def converged(self) -> bool:
        """Initialised, finite, and position 1-σ below ``WK_EKF_CONV``."""
        if not self.initialised:
            return False
        s = self.sigma()
        return bool(np.all(np.isfinite(self.kf.x)) and s[0] < self.params["WK_EKF_CONV"]
                    and s[1] < self.params["WK_EKF_CONV"])

    def initialise(self, frame: SensorFrame, x_fallback: float = 0.0) -> None:
        """Start from a sensor frame: measured states from it, velocities zero with 0.5 m/s 1-σ
        (aided: the DVL's when it has a reading; the disturbance zero with 50 N, 50 N, 5 N m 1-σ, its noise
        scales λ at ``WK_EKF_QI_INIT``, from which the innovations bring them down within seconds)."""
        p = self.params
        x = frame.x if np.isfinite(frame.x) else x_fallback
        pos_var = p["WK_EKF_R_POS"] ** 2 if np.isfinite(frame.x) else 100.0
        x0 = [x, frame.depth, frame.pitch, 0.0, 0.0, frame.pitch_rate]
        var = [pos_var, p["WK_EKF_R_DEPTH"] ** 2, p["WK_EKF_R_PITCH"] ** 2, 0.25, 0.25, p["WK_EKF_R_GYRO"] ** 2]
        if self.aided:
            if np.isfinite(frame.dvl_u) and np.isfinite(frame.dvl_w):
                x0[3:5] = [frame.dvl_u, frame.dvl_w]
                var[3:5] = [p["WK_EKF_R_DVL"] ** 2] * 2
            x0 += [0.0, 0.0, 0.0]
            var += [50.0**2, 50.0**2, 5.0**2]
        self.kf.x = np.array(x0, dtype=float).reshape(-1, 1)
        self.kf.P = np.diag(var)
        lam0 = p["WK_EKF_QI_INIT"] if p["WK_EKF_QI_ADPT"] else 1.0
        self._lam = [float(lam0)] * 3 + [1.0]        # start loose: the start-up transient
        self._blk = [0.0, 0.0, 0.0]
        self._last_accept_t[:] = frame.t
        self.initialised = True

    # ------------------------------------------------------------------ predict
    def _jacobian(self, x: np.ndarray, tau: np.ndarray, flow: BodyFlow | None) -> np.ndarray:
        """F ≈ I + A h + (A h)²/2 with A the model's Jacobian at x under τ in the flow's first instant
        (aided: with the disturbance's block B h + A B h²/2, B = ∂ẋ/∂d = [0; M⁻¹], and its decay)."""
        A = rates_jacobian(self.kf.vehicle, x[:6], tau, flow, 0)
        Ah = A * self.h
        F6 = _EYE6 + Ah + 0.5 * Ah @ Ah
        if not self.aided:
            return F6
        if self._F0_decay != self.kf.d_decay:     # I with the decay on the disturbance's block
            F0 = np.eye(9)
            F0[6:, 6:] *= self.kf.d_decay
            self._F0, self._F0_decay = F0, self.kf.d_decay
        F = self._F0.copy()
        F[:6, :6] = F6
        np.add(self._Bh, 0.5 * self.h * (Ah @ self._B), out=F[:6, 6:])
        return F

    def _process_noise(self) -> np.ndarray:
        """Q = diag(q² h) from the WK_EKF_Q_* parameters, rebuilt only when one of them changes (looked at
        when the table's version moves); aided, the disturbance's density is adapted (``WK_EKF_QD_ADPT``,
        :meth:`_adapt`) and it and the pitch's variance are scaled by the innovation-driven λ
        (``WK_EKF_QI_ADPT``, :meth:`_adapt_to_innovations`)."""
        h, tune = self.h, self._tuning()
        key = tune.q
        if key != self._q_key:
            q = np.array(key[:self.n])
            self._q, self._q_key = np.diag(q**2 * h), key
            tc = key[9] if self.aided else 0.0
            self.kf.d_decay = math.exp(-h / tc) if tc > 0 else 1.0
            if self.aided:
                self._qd_param = q[6:].tolist()
                if self._dd_var is None:
                    self._dd_var = (q[6:] ** 2 * h).tolist()
        if not self.aided:
            return self._q
        qd = self._qd_param
        if tune.qd_adpt and self._dd_var is not None:
            # np.maximum(k √(var/h), q_d) per axis, on scalars (NaN stays NaN as in numpy)
            k = tune.qd_k
            qd = [max(k * sqrt(v / h), qp) for v, qp in zip(self._dd_var, self._qd_param, strict=True)]
        lam = self._lam
        # the disturbance's white-noise density integrated over the period into d and, through M⁻¹, into ν
        # (Van Loan's series to h³): Q_dd = Qc h, Q_νd = M⁻¹ Qc h²/2, Q_νν = M⁻¹ Qc M⁻ᵀ h³/3
        c0, c1, c2 = (q * q * li for q, li in zip(qd, lam[:3], strict=True))
        Qc, Mi = np.array([[c0, 0.0, 0.0], [0.0, c1, 0.0], [0.0, 0.0, c2]]), self.kf.vehicle.M_inv
        Q = self._q.copy()
        Q[2, 2] *= lam[3]
        Q[6, 6], Q[7, 7], Q[8, 8] = c0 * h, c1 * h, c2 * h    # Q_dd = Qc h (its zeros are _q's already)
        MiQc = Mi @ Qc
        np.multiply(MiQc, self._h2_2, out=Q[3:6, 6:])
        Q[6:, 3:6] = Q[3:6, 6:].T
        np.add(self._q[3:6, 3:6], MiQc @ Mi.T * self._h3_3, out=Q[3:6, 3:6])
        return Q

    def _adapt(self) -> None:
        """Covariance matching for the disturbance's random walk (Mohamed & Schwarz 1999): q_d² h tracks the
        mean square of the estimate's change per tick (time constant ``WK_EKF_QD_TC``), so the disturbance's
        process noise follows the sea — small when a good forecast leaves little to explain, large without."""
        d = self.kf.x[6:, 0].tolist()
        if self._d_prev is not None and self._dd_var is not None:
            a = min(1.0, self.h / self._tuning().qd_tc)
            self._dd_var = [v + a * ((di - dp) * (di - dp) - v)
                            for v, di, dp in zip(self._dd_var, d, self._d_prev, strict=True)]
        self._d_prev = d

    def _adapt_to_innovations(self, y: list[float], S: list[float], avail: list[bool]) -> None:
        """The innovation-driven scales λ on the process noise (``WK_EKF_QI_*``,
        :func:`~firmware_py.estimation.support.innovation_scales`) after this tick's innovations."""
        self._lam = innovation_scales(self._lam, self._blk, y, S, avail, self._tuning(), self.h, _QI_CHANNELS)

    def predict(self, tau_stages: np.ndarray, flow: BodyFlow | None = None) -> None:
        """Propagate one period under the thruster load τ at t, t + h/2, t + h (rows of ``tau_stages``),
        in the predicted flow (None: still water, i.e. no forecast in use)."""
        if not self.initialised:
            return
        self.kf.tau_stages = np.asarray(tau_stages, dtype=float)
        self.kf.flow = flow
        self.kf.Q = self._process_noise()
        tau0 = self.kf.tau_stages[0] + (self.kf.x[6:, 0] if self.aided else 0.0)
        self.kf.F = self._jacobian(self.kf.x[:, 0].copy(), tau0, flow)
        self.kf.predict()

    # ------------------------------------------------------------------ update
    def measurement_noise(self) -> np.ndarray:
        """R's diagonal: each channel's noise variance (m², rad², (rad/s)², (m/s)², (m/s²)²), recomputed
        only when the parameter table has changed; a fresh array each call (callers may modify it)."""
        return self.params.derived(self._read_noise).copy()

    def _read_noise(self, p: ParameterTable) -> np.ndarray:
        r = [p["WK_EKF_R_POS"], p["WK_EKF_R_DEPTH"], p["WK_EKF_R_PITCH"], p["WK_EKF_R_GYRO"]]
        if self.aided:
            r += [p["WK_EKF_R_DVL"]] * 2 + [p["WK_EKF_R_ACC"]] * 2
        return np.array(r) ** 2

    def _tuning(self) -> Tuning:
        """The update's parameters (:class:`Tuning`), re-read only when the table has changed."""
        return self.params.derived(self._read_tuning)

    def _read_tuning(self, p: ParameterTable) -> Tuning:
        return Tuning.of(p, self.measurement_noise(), self.aided)

    def _subset(self, mask: int) -> Subset:
        """The fusion's constant inputs for the accepted channels whose bits are set in ``mask``
        (built once per set of channels and parameter version: kept with the :class:`Tuning`)."""
        tune = self._tuning()
        sub = tune.subsets.get(mask)
        if sub is None:
            sub = tune.subsets[mask] = Subset.of(mask, self._H0, tune.r, _ACCEL_CHANNELS, tune.acc_th)
        return sub

    def _accel_model(self, H: np.ndarray) -> list[float]:
        """The accelerometer's predicted specific force [f_x, f_z] at the state, under the thrust the mixer
        expected at the end of the period, + d, in the flow's last instant; its Jacobian (2, 9) goes into
        H's rows 6 and 7 (on entry: zero but for the constant block ∂f/∂d = M⁻¹'s rows)."""
        veh, kf = self.kf.vehicle, self.kf
        x6, d = kf.x[:6, 0], kf.x[6:, 0]
        tau = kf.tau_stages[2] + d
        rates = state_rates_at(veh, x6, tau, kf.flow, 2)
        A = rates_jacobian(veh, x6, tau, kf.flow, 2)
        _, _, th, u, w, q = x6.tolist()
        r_u, r_w = rates[3], rates[4]
        g, c, s = veh.g, math.cos(th), math.sin(th)
        # ∂f/∂x: the model's ν̇ rows plus ω × v − g_body's terms, on floats, written in one assignment
        row_x, row_z = A[3:5, :].tolist()
        row_x[2] += g * c
        row_x[4] += q
        row_x[5] += w
        row_z[2] += g * s
        row_z[3] -= q
        row_z[5] -= u
        H[6:8, :6] = [row_x, row_z]
        return [r_u + q * w + g * s, r_w - q * u - g * c]

    def _model(self, accel: bool) -> tuple[list[float], np.ndarray]:
        """Predicted measurements h(x) (a list, NaN where a channel has no model this tick) and the full
        Jacobian H (channels × states): the constant selection rows (read-only) unless ``accel`` asks for
        the accelerometer's model (aided), whose rows then fill a copy."""
        xs = self.kf.x[:, 0].tolist()
        hx = [xs[j] for j in self._meas_states]
        H = self._H0
        if self.aided:
            if accel:
                H = self._H0_acc.copy()
                hx += self._accel_model(H)
            else:
                hx += [math.nan, math.nan]
        return hx, H

    def _innovation_variance(self, H: np.ndarray, tune: Tuning) -> list[float]:
        """Each channel's innovation variance S_ii = (H P Hᵀ)_ii + R_ii.

        With only selection rows (the paper's mode) and a finite P this is P_jj + R_ii, what the general
        sum Σ_jk H_ij P_jk H_ik gives too (its other terms are exact zeros); otherwise that sum (einsum),
        whose zeros times a non-finite P are NaN."""
        P = self.kf.P
        if not self.aided:
            p = P.ravel().tolist()
            if math.isfinite(sum(p)):              # every entry finite (a NaN or ±inf makes the sum so)
                d = p[::self.n + 1]
                return [d[j] + ri for j, ri in zip(self._meas_states, tune.r, strict=True)]
        return (np.einsum("ij,jk,ik->i", H, P, H) + tune.r_vec).tolist()

    def update(self, frame: SensorFrame) -> np.ndarray:
        """Fuse the frame's available readings; returns the per-channel accepted mask.

        Per channel i: innovation y_i = z_i − h_i(x), variance S_ii, NIS y_i²/S_ii; a reading is fused when
        the NIS is within ``WK_EKF_GATE``², else counted rejected (and, for a directly measured state, reset
        to the reading once rejected for ``WK_EKF_RST_T`` s). The gating runs on Python floats (scalar IEEE
        arithmetic, the same bits as numpy's elementwise ops) and the fusion on the accepted subset."""
        z = frame.readings(self.aided)
        avail = list(map(math.isfinite, z))
        if not self.initialised:
            if all(avail[1:4]):
                self.initialise(frame)
            return np.array(avail)
        tune = self._tuning()
        accel = self.aided and (avail[6] or avail[7])
        hx, H = self._model(accel)
        S = self._innovation_variance(H, tune)
        t, gate2, rst_t, last_t = frame.t, tune.gate2, tune.rst_t, self._last_accept_t
        y: list[float] = []
        nis: list[float] = []
        accept = [False] * len(z)
        mask = 0
        resets: list[int] = []
        for i, name in enumerate(self.channels):
            yi = z[i] - hx[i]
            ni = ratio(yi * yi, S[i])
            y.append(yi)
            nis.append(ni)
            if not avail[i]:
                continue
            if ni <= gate2:
                accept[i] = True
                mask |= 1 << i
                self.accepted[name] += 1
                last_t[i] = t
            else:
                self.rejected[name] += 1
                if i < 6 and t - last_t[i] > rst_t:     # no state to reset to an acceleration
                    resets.append(i)
                    last_t[i] = t
        self.last_nis = np.array(nis)
        for k in resets:
            self._reset_channel(k, float(z[k]), tune.r[k])
        self.nis_total = (0.0, 0)
        if mask:
            if resets:                            # a reset moved the state: predict the others again
                hx, H = self._model(accel)
            sub = self._subset(mask)
            rows = sub.rows
            self._fuse(np.array([z[i] for i in rows], dtype=float).reshape(-1, 1),
                       np.array([z[i] - hx[i] for i in rows]).reshape(-1, 1),
                       sub.H if sub.H is not None else H[sub.index], sub.R, sub.blind)
        if self.aided:
            self._adapt()
            if tune.qi_adpt:
                self._adapt_to_innovations(y, S, avail)
        if not (np.isfinite(self.kf.x).all() and np.isfinite(self.kf.P).all()):
            # A diverged estimate is no estimate: start again from the next readings (the control task
            # is neutral meanwhile), as ArduPilot's EKF resets a lane rather than fly on NaN
            self.initialised = False
            self.restarts += 1
        return np.array(accept)

    def _reset_channel(self, k: int, value: float, noise_var: float) -> None:
        """Set the state channel k measures to ``value``, its covariance row and column cleared to the
        measurement's noise variance (ArduPilot's EKF resets to a source this way)."""
        j = int(MEASURED_STATES[k])
        self.kf.x[j, 0] = value
        self.kf.P[j, :] = 0.0
        self.kf.P[:, j] = 0.0
        self.kf.P[j, j] = noise_var
        self.resets[self.channels[k]] += 1

    def reset_channel(self, name: str, value: float) -> None:
        """Reset channel ``name``'s state to a reading that changed meaning (e.g. a depth now corrected
        for the waves' dynamic pressure), rather than let the filter see a step it would take as motion."""
        k = self.channels.index(name)
        self._reset_channel(k, value, float(self.measurement_noise()[k]))

    def _fuse(self, z: np.ndarray, y: np.ndarray, H: np.ndarray, R: np.ndarray,
              pitch_blind: tuple[int, ...] = ()) -> None:
        """filterpy's ``ExtendedKalmanFilter.update(z, HJacobian=H, Hx=h(x), R)``, term by term and in its
        arithmetic (Joseph form, scipy's inverse), without its per-call deep copies and closures.

        ``z`` (k, 1) the accepted readings, ``y`` (k, 1) their innovations z − h(x), ``H`` (k, n), ``R`` (k, k).
        ``pitch_blind`` (aided, ``WK_EKF_ACC_TH`` 0) lists the positions of the channels whose gain on θ is
        set to zero: a Schmidt ("consider") update. S keeps θ's share of their innovation (H is unchanged),
        and the Joseph form P⁺ = (I − KH) P (I − KH)ᵀ + K R Kᵀ is the true covariance for any gain, so P
        stays honest."""
        kf = self.kf
        PHT = np.dot(kf.P, H.T)
        kf.S = np.dot(H, PHT) + R
        kf.SI = linalg.inv(kf.S)
        kf.K = PHT.dot(kf.SI)
        for c in pitch_blind:
            kf.K[2, c] = 0.0
        kf.y = y
        kf.x = kf.x + np.dot(kf.K, kf.y)
        I_KH = kf._I - np.dot(kf.K, H)
        kf.P = np.dot(I_KH, kf.P).dot(I_KH.T) + np.dot(kf.K, R).dot(kf.K.T)
        kf._log_likelihood = kf._likelihood = kf._mahalanobis = None
        kf.z, kf.R = z, R
        kf.x_post, kf.P_post = kf.x.copy(), kf.P.copy()
        # yᵀ S⁻¹ y: ndarray.dot rather than @ on the 1-D views (a third of the time; the same BLAS gemv and
        # dot, checked bit for bit on random S and y of every size 1–8)
        y1 = y[:, 0]
        self.nis_total = (float(y1.dot(kf.SI).dot(y1)), int(z.shape[0]))

