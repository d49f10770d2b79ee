"""The six-DoF estimate's lateral-directional block: sway, roll and heading.

State x_L = [y, φ, ψ, v, p, r] (NED east m, roll and heading rad; body sway m/s, roll and yaw rates rad/s).
The vertical plane's estimate [x, z, θ, u, w, q] is :class:`~firmware_py.estimation.estimator.PlanarEKF`'s;
together they are the six-DoF pose η and velocity ν. For a body symmetric port to starboard, level and
near rest, the linearised six-DoF motion splits exactly into the two planes (their cross terms are
products of lateral and longitudinal motion, second order), so the filter keeps their cross-covariance
at zero and each block its own update. The prediction is not split: it runs the six-DoF model
(:class:`~bridge.models.body6.Body6`, nominal parameters: the world's equations) on the whole state, the
vertical plane's estimate held, under the six-DoF thruster wrench the mixer expected and, when a forecast
is in use, the forecast's flow at the strips, so that an oblique sea's predicted sway force, roll and yaw
moments drive it as the head sea's drive the vertical plane. Its Jacobian is the model's own, by forward
differences on the lateral states, F ≈ I + A h + (A h)²/2.

Measurements z = [y, φ, ψ, p, r]: the position fix's east coordinate (with the north one, at its rate),
the AHRS's roll and heading and the gyro's roll and yaw rates. The heading's innovation is wrapped to
(−π, π]. The position fix is gated on its normalised innovation against ``WK_EKF_GATE`` (an acoustic
fix's outliers are what a gate is for), and reset to its reading once its readings have all been
rejected for ``WK_EKF_RST_T`` s, as the vertical plane's are. The AHRS's attitude and the gyro's rates
are fused ungated: they are what ArduPilot's EKF drives its prediction with, and a gate on them turns a
model that is briefly wrong (a saturated thruster's lag, a breaking sea) into a lost roll: the filter
rejects the rolling it does not predict until the vehicle has capsized.

Process noise: the block has no disturbance states, so its velocities carry the load the model does not
predict. Without a forecast in the prediction that is the whole wave load, and the densities are the
paper mode's (``WK_EKF_Q_VEL``, ``_RATE``: a sea's unmodelled forces); with one, the model's one-step
error from the true state is under 1 mm/s in sway (W3, beam sea), and ``WK_EKF_QL_VEL`` and ``_RATE``
are far smaller: the sway velocity is then known to a few per cent of its motion from the position fix
alone, where the paper's densities leave it at 60 %. Positions and angles take ``WK_EKF_Q_POS`` and
``_ANG`` either way.
"""
from __future__ import annotations

import math

import numpy as np

from bridge.models.body6 import Body6, Flow6
from bridge.models.motion6 import from_planes, to_lateral

from ..hal.sensors import SensorFrame, wrap_angle
from ..params.table import ParameterTable
from .filterpy_ekf import ExtendedKalmanFilter

__all__ = ["LATERAL_CHANNELS", "LateralEKF"]

LATERAL_CHANNELS = ("position_y", "roll", "yaw", "roll_rate", "yaw_rate")
"""The lateral block's measurement channels, in the order of
:meth:`~firmware_py.hal.sensors.SensorFrame.lateral_readings`."""

_MEASURED = (0, 1, 2, 4, 5)     # the state each channel reads: y, φ, ψ, p, r
_YAW = 2                        # the channel (and state) whose innovation wraps
_GATED = (0,)                   # the channels gated on their innovation: the position fix
_EPS = 1e-6                     # forward-difference step on each lateral state (m, rad, m/s, rad/s)
_H = np.zeros((5, 6))
_H[range(5), _MEASURED] = 1.0
_H.flags.writeable = False


class LateralEKF:
    """The lateral block of the control task's estimate: ``predict`` then ``update(frame)`` once per tick.

    ``body`` is the six-DoF vehicle with nominal parameters; ``params`` the firmware's table; ``h`` the
    control period (s). Not :attr:`initialised` until a frame has every lateral reading but the fix's
    (a planar world has none: the block then stays off and the firmware holds the vertical plane only).
    """

    def __init__(self, body: Body6, params: ParameterTable, h: float):
        self.body = body
        self.params = params
        self.h = float(h)
        self.kf = ExtendedKalmanFilter(dim_x=6, dim_z=5)
        self.initialised = False
        self.restarts = 0
        self.accepted = dict.fromkeys(LATERAL_CHANNELS, 0)
        self.rejected = dict.fromkeys(LATERAL_CHANNELS, 0)
        self.resets = dict.fromkeys(LATERAL_CHANNELS, 0)
        self.last_nis = np.full(5, np.nan)
        self._last_accept_t = np.full(5, -np.inf)

    # ------------------------------------------------------------------ state
    @property
    def x(self) -> np.ndarray:
        """[y, φ, ψ, v, p, r]."""
        return self.kf.x[:, 0]

    def sigma(self) -> np.ndarray:
        """1-σ of every state (6,)."""
        return np.sqrt(self.kf.P.diagonal())

    def _noise(self, p: ParameterTable) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(R's diagonal (5,), Q's diagonal (6,) without a forecast in the model and with one) from the table
        (read again only when it changes)."""
        r = np.array([p["WK_EKF_R_POS"], p["WK_EKF_R_PITCH"], p["WK_EKF_R_YAW"], p["WK_EKF_R_GYRO"],
                      p["WK_EKF_R_GYRO"]]) ** 2
        pose = [p["WK_EKF_Q_POS"], p["WK_EKF_Q_ANG"], p["WK_EKF_Q_ANG"]]
        q_sea = np.array([*pose, p["WK_EKF_QL_VEL_S"], p["WK_EKF_QL_RATE_S"], p["WK_EKF_QL_RATE_S"]]) ** 2 * self.h
        q_model = np.array([*pose, p["WK_EKF_QL_VEL"], p["WK_EKF_QL_RATE"], p["WK_EKF_QL_RATE"]]) ** 2 * self.h
        return r, q_sea, q_model

    def initialise(self, frame: SensorFrame) -> None:
        """Start from a frame: the measured states from it (y at 10 m 1-σ without a fix), v zero at 0.5 m/s."""
        r = self.params.derived(self._noise)[0]
        z = frame.lateral_readings()
        has_fix = math.isfinite(z[0])
        self.kf.x = np.array([z[0] if has_fix else 0.0, z[1], z[2], 0.0, z[3], z[4]]).reshape(6, 1)
        self.kf.P = np.diag([r[0] if has_fix else 100.0, r[1], r[2], 0.25, r[3], r[4]])
        self._last_accept_t[:] = frame.t
        self.initialised = True

    # ------------------------------------------------------------------ predict
    def predict(self, x_planar: np.ndarray, tau6_stages: np.ndarray, flow: Flow6 | None) -> None:
        """Propagate one period with the vertical plane at ``x_planar`` = [x, z, θ, u, w, q] (its estimate at the
        period's start), under the thruster wrench (3, 6) at t, t + h/2, t + h, in the predicted flow (None:
        still water)."""
        if not self.initialised:
            return
        body, h = self.body, self.h
        x12 = from_planes(x_planar, self.x)
        tau6_stages = np.asarray(tau6_stages, dtype=float)
        x_next = to_lateral(body.rk4(x12, h, tau6_stages, flow))
        A = self._jacobian(x12, tau6_stages[0], flow)
        Ah = A * h
        F = np.eye(6) + Ah + 0.5 * Ah @ Ah
        if not (np.isfinite(x_next).all() and np.isfinite(F).all()):
            self._restart()           # a pose the model cannot take (e.g. θ at ±90°): start again from readings
            return
        self.kf.x, self.kf.F = x_next.reshape(6, 1), F
        self.kf.Q = np.diag(self.params.derived(self._noise)[1 if flow is None else 2])
        self.kf.P = F @ self.kf.P @ F.T + self.kf.Q

    def _jacobian(self, x12: np.ndarray, tau: np.ndarray, flow: Flow6 | None) -> np.ndarray:
        """A = ∂ẋ_L/∂x_L (6, 6) of the six-DoF model at x (12,) under τ (6,) in the flow's first instant."""
        f0 = to_lateral(self.body.rates(x12, tau, flow, 0))
        A = np.empty((6, 6))
        for j, k in enumerate((1, 3, 5, 7, 9, 11)):
            xp = x12.copy()
            xp[k] += _EPS
            A[:, j] = (to_lateral(self.body.rates(xp, tau, flow, 0)) - f0) / _EPS
        return A

    # ------------------------------------------------------------------ update
    def update(self, frame: SensorFrame) -> np.ndarray:
        """Fuse the frame's lateral readings; returns the per-channel accepted mask (5,).

        Per channel: innovation y_i (the heading's wrapped), variance S_ii = P_jj + R_ii; the fix is fused when
        y_i² / S_ii ≤ ``WK_EKF_GATE``², else rejected (and reset to the reading after ``WK_EKF_RST_T`` s); the
        attitude and rates always."""
        z = frame.lateral_readings()
        avail = [math.isfinite(v) for v in z]
        if not self.initialised:
            if all(avail[1:]):
                self.initialise(frame)
            return np.array(avail)
        p = self.params
        r = p.derived(self._noise)[0]
        gate2, rst_t = p["WK_EKF_GATE"] ** 2, p["WK_EKF_RST_T"]
        x, P = self.x, self.kf.P
        accept = [False] * 5
        nis = np.full(5, np.nan)
        for i, j in enumerate(_MEASURED):
            if not avail[i]:
                continue
            y = z[i] - x[j]
            if i == _YAW:
                y = wrap_angle(y)
            nis[i] = y * y / (P[j, j] + r[i])
            name = LATERAL_CHANNELS[i]
            if i not in _GATED or nis[i] <= gate2:
                accept[i] = True
                self.accepted[name] += 1
                self._last_accept_t[i] = frame.t
            else:
                self.rejected[name] += 1
                if frame.t - self._last_accept_t[i] > rst_t:
                    self._reset(i, z[i], r[i], frame.t)
        self.last_nis = nis
        rows = [i for i in range(5) if accept[i]]
        if not (np.isfinite(self.kf.x).all() and np.isfinite(self.kf.P).all()):
            rows = []                 # nothing to fuse into a diverged estimate: restarted below
        if rows:
            zk = np.array([z[i] for i in rows]).reshape(-1, 1)
            Hk = _H[rows]
            yaw_row = rows.index(_YAW) if _YAW in rows else None

            def residual(za: np.ndarray, hx: np.ndarray) -> np.ndarray:
                y = za - hx
                if yaw_row is not None:
                    y[yaw_row, 0] = wrap_angle(float(y[yaw_row, 0]))
                return y

            self.kf.update(zk, lambda _x: Hk, lambda xs: Hk @ xs, R=np.diag(r[rows]), residual=residual)
            self.kf.x[2, 0] = wrap_angle(float(self.kf.x[2, 0]))
        if not (np.isfinite(self.kf.x).all() and np.isfinite(self.kf.P).all()):
            self._restart()
        return np.array(accept)

    def _restart(self) -> None:
        """A diverged estimate is no estimate: start again from the next readings, as the vertical plane does
        (the lateral hold is off meanwhile)."""
        self.initialised = False
        self.restarts += 1

    def _reset(self, i: int, value: float, noise_var: float, t: float) -> None:
        """Set the state channel i reads to ``value``, its covariance row and column cleared to the reading's noise."""
        j = _MEASURED[i]
        self.kf.x[j, 0] = value
        self.kf.P[j, :] = 0.0
        self.kf.P[:, j] = 0.0
        self.kf.P[j, j] = noise_var
        self.resets[LATERAL_CHANNELS[i]] += 1
        self._last_accept_t[i] = t
