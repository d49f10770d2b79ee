"""Planar extended Kalman filter (paper §III-A), built on filterpy's ExtendedKalmanFilter.

State x = [x, z, θ, u, w, q] (NED position m, depth m, pitch rad; body velocities
m/s and pitch rate rad/s). Prediction runs the shared vehicle model
(:func:`~bridge.models.vehicle.rk4_step`, nominal parameters) driven by
the thrust the firmware commanded (through its motor-lag model) plus, when a
forecast is in use, the predicted wave load. Its Jacobian F is taken from the
continuous model by finite differences, F ≈ I + A h + (A h)²/2.

Measurements z = [x, depth, θ, q]; any may be missing on a tick (the position
fix runs slower than the loop). Each available channel is gated on its
normalised innovation |y_i| / √S_ii against ``WK_EKF_GATE``; rejected
readings are counted per channel and never reach the state. A channel whose
readings have all been rejected for ``WK_EKF_RST_T`` seconds is reset to its
measurement (state set, its covariance row cleared to the measurement noise),
as ArduPilot's EKF resets to GPS after a timeout: a gate must not lock a good
sensor out for ever once the model has been wrong for a while.
"""
from __future__ import annotations

import numpy as np
import scipy.linalg as linalg  # filterpy's EKF inverts S with it; so does _fuse (same bits)

from bridge.models.vehicle import BodyFlow, VehicleParams, rates_jacobian, rk4_step

from .filterpy_ekf import ExtendedKalmanFilter
from .params import ParameterTable
from .sensors import SensorFrame

__all__ = ["CHANNELS", "MEASURED_STATES", "PlanarEKF"]

MEASURED_STATES = (0, 1, 2, 5)
"""State index of each measurement channel: x, depth, pitch, pitch rate."""

CHANNELS = ("position", "depth", "pitch", "pitch_rate")


class _ModelEKF(ExtendedKalmanFilter):
    """filterpy EKF whose prediction integrates the nonlinear vehicle model.

    (filterpy: override ``predict_x`` and set ``F``; see docs/platform-notes.md.)
    """

    def __init__(self, vehicle: VehicleParams, h: float):
        super().__init__(dim_x=6, dim_z=4)
        self.vehicle = vehicle
        self.h = h
        self.tau_stages = np.zeros((3, 3))
        self.flow: BodyFlow | None = None

    def predict_x(self, u=0):
        self.x = rk4_step(self.vehicle, self.x[:, 0], self.h, self.tau_stages, self.flow).reshape(6, 1)


class PlanarEKF:
    """The estimator of the control task: ``predict(τ stages)`` then ``update(frame)`` once per tick."""

    def __init__(self, vehicle: VehicleParams, params: ParameterTable, h: float):
        self.params = params
        self.h = float(h)
        self.kf = _ModelEKF(vehicle, self.h)
        self.initialised = False
        self.rejected = dict.fromkeys(CHANNELS, 0)
        self.accepted = dict.fromkeys(CHANNELS, 0)
        self.resets = dict.fromkeys(CHANNELS, 0)
        self.last_nis = np.full(4, np.nan)   # normalised innovation squared per channel, last tick
        self._last_accept_t = np.full(4, -np.inf)
        self._q_key: tuple | None = None
        self._q = np.zeros((6, 6))
        self._H: dict[tuple, np.ndarray] = {}   # measurement matrices by accepted-channel pattern

    # ------------------------------------------------------------------ state
    @property
    def x(self) -> np.ndarray:
        return self.kf.x[:, 0]

    @property
    def P(self) -> np.ndarray:
        return self.kf.P

    def sigma(self) -> np.ndarray:
        return np.sqrt(np.diag(self.kf.P))

    def converged(self) -> bool:
        """Initialised, finite, and position 1-σ below ``WK_EKF_CONV``."""
        if not self.initialised:
            return False
        s = self.sigma()
        return bool(np.all(np.isfinite(self.kf.x)) and s[0] < self.params["WK_EKF_CONV"]
                    and s[1] < self.params["WK_EKF_CONV"])

    def initialise(self, frame: SensorFrame, x_fallback: float = 0.0) -> None:
        """Start from a sensor frame: measured states from it, velocities zero with 0.5 m/s 1-σ."""
        p = self.params
        x = frame.x if np.isfinite(frame.x) else x_fallback
        self.kf.x = np.array([[x], [frame.depth], [frame.pitch], [0.0], [0.0], [frame.pitch_rate]])
        pos_var = p["WK_EKF_R_POS"] ** 2 if np.isfinite(frame.x) else 100.0
        self.kf.P = np.diag([pos_var, p["WK_EKF_R_DEPTH"] ** 2, p["WK_EKF_R_PITCH"] ** 2,
                             0.25, 0.25, p["WK_EKF_R_GYRO"] ** 2])
        self._last_accept_t[:] = frame.t
        self.initialised = True

    # ------------------------------------------------------------------ predict
    def _jacobian(self, x: np.ndarray, tau: np.ndarray, flow: BodyFlow | None) -> np.ndarray:
        """F ≈ I + A h + (A h)²/2 with A the model's Jacobian at x under τ in the flow's first instant."""
        A = rates_jacobian(self.kf.vehicle, x, tau, flow, 0)
        Ah = A * self.h
        return np.eye(6) + Ah + 0.5 * Ah @ Ah

    def _process_noise(self) -> np.ndarray:
        """Q = diag(q² h) from the WK_EKF_Q_* parameters; rebuilt only when one of them changes."""
        p, h = self.params, self.h
        key = (p["WK_EKF_Q_POS"], p["WK_EKF_Q_ANG"], p["WK_EKF_Q_VEL"], p["WK_EKF_Q_RATE"])
        if key != self._q_key:
            q = np.array([p["WK_EKF_Q_POS"], p["WK_EKF_Q_POS"], p["WK_EKF_Q_ANG"],
                          p["WK_EKF_Q_VEL"], p["WK_EKF_Q_VEL"], p["WK_EKF_Q_RATE"]])
            self._q, self._q_key = np.diag(q**2 * h), key
        return self._q

    def predict(self, tau_stages: np.ndarray, flow: BodyFlow | None = None) -> None:
        """Propagate one period under the thruster load τ at t, t + h/2, t + h (rows of ``tau_stages``),
        in the predicted flow (None: still water, i.e. no forecast in use)."""
        if not self.initialised:
            return
        self.kf.tau_stages = np.asarray(tau_stages, dtype=float)
        self.kf.flow = flow
        self.kf.F = self._jacobian(self.x.copy(), self.kf.tau_stages[0], flow)
        self.kf.Q = self._process_noise()
        self.kf.predict()

    # ------------------------------------------------------------------ update
    def measurement_noise(self) -> np.ndarray:
        p = self.params
        return np.array([p["WK_EKF_R_POS"], p["WK_EKF_R_DEPTH"], p["WK_EKF_R_PITCH"], p["WK_EKF_R_GYRO"]]) ** 2

    def update(self, frame: SensorFrame) -> np.ndarray:
        """Fuse the frame's available readings; returns the per-channel accepted mask."""
        z = frame.as_vector()
        if not self.initialised:
            if np.all(np.isfinite(z[1:])):
                self.initialise(frame)
            return np.isfinite(z)
        idx = np.asarray(MEASURED_STATES)
        r = self.measurement_noise()
        x, P = self.x, self.kf.P
        y = z - x[idx]
        S = P[idx, idx] + r
        with np.errstate(invalid="ignore"):
            nis = y * y / S
        self.last_nis = nis
        avail = np.isfinite(z)
        gate = self.params["WK_EKF_GATE"] ** 2
        accept = avail & (nis <= gate)
        reset = avail & ~accept & (frame.t - self._last_accept_t > self.params["WK_EKF_RST_T"])
        for i, name in enumerate(CHANNELS):
            if avail[i]:
                if accept[i]:
                    self.accepted[name] += 1
                else:
                    self.rejected[name] += 1
        self._last_accept_t[accept | reset] = frame.t
        for k in np.flatnonzero(reset).tolist():
            j = int(idx[k])
            self.kf.x[j, 0] = z[k]
            self.kf.P[j, :] = 0.0
            self.kf.P[:, j] = 0.0
            self.kf.P[j, j] = r[k]
            self.resets[CHANNELS[k]] += 1
        if accept.any():
            key = tuple(accept.tolist())
            H = self._H.get(key)
            if H is None:
                rows = idx[accept]
                H = np.zeros((rows.size, 6))
                H[np.arange(rows.size), rows] = 1.0
                self._H[key] = H
            self._fuse(z[accept].reshape(-1, 1), H, np.diag(r[accept]))
        return accept

    def _fuse(self, z: np.ndarray, H: np.ndarray, R: np.ndarray) -> None:
        """filterpy's ``ExtendedKalmanFilter.update(z, HJacobian=H, Hx=H x, R)``, term by term and in its
        arithmetic (Joseph form, scipy's inverse), without its per-call deep copies and closures."""
        kf = self.kf
        PHT = np.dot(kf.P, H.T)
        kf.S = np.dot(H, PHT) + R
        kf.SI = linalg.inv(kf.S)
        kf.K = PHT.dot(kf.SI)
        kf.y = np.subtract(z, H @ kf.x)
        kf.x = kf.x + np.dot(kf.K, kf.y)
        I_KH = kf._I - np.dot(kf.K, H)
        kf.P = np.dot(I_KH, kf.P).dot(I_KH.T) + np.dot(kf.K, R).dot(kf.K.T)
        kf._log_likelihood = kf._likelihood = kf._mahalanobis = None
        kf.z, kf.R = z, R
        kf.x_post, kf.P_post = kf.x.copy(), kf.P.copy()
