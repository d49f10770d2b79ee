"""The vehicle's lateral-directional plane: sway, roll and heading, estimated and held beside the vertical plane.

A six-DoF vehicle is the vertical plane (x, depth, pitch: :class:`~firmware_py.estimation.estimator.PlanarEKF`
and the law behind :mod:`firmware_py.control.laws`) and this plane: its estimate
(:class:`~firmware_py.estimation.lateral.LateralEKF`, predicted by the six-DoF model on the whole state) and its
hold (:class:`~firmware_py.control.lateral_hold.LateralHold`, the same cascade, with the feed-forward of the
forecast's sway force and roll and yaw moments). The plane switches itself on with the first sensor frame that
reads roll (a planar world's never does) when ``WK_LAT_HOLD`` is 1 and the vehicle config has a lateral section;
until then the firmware is the planar vehicle, to the bit.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from bridge.models.body6 import Body6, Flow6
from bridge.models.rigid_body6 import RigidBody6Params

from .control.lateral_hold import LateralHold
from .estimation.lateral import LateralEKF
from .forecast.handoff import ActiveForecast
from .hal.sensors import SensorFrame
from .params.table import ParameterTable

__all__ = ["LateralPlane", "LateralRecord", "weighted_flow6"]

STRIPS_ACROSS = 3
"""Gauss–Legendre strips across the beam of the nominal six-DoF body (as the six-DoF world's)."""


def weighted_flow6(flow: Flow6, weight: float) -> Flow6:
    """The flow's velocity and acceleration × ``weight`` (the same object at 1: a trusted forecast's flow is
    used as it comes, to the bit).

    The lateral plane has no skill measure of its own: its sway, roll and yaw loads come from the same wave
    components whose surge, heave and pitch loads the feed-forward's skill weighs. The weight is the heave
    axis's skill weight: a sea from any direction loads heave, where surge and pitch carry no load in a beam
    sea (their skill there is the correlation of noise, near 0, whatever the forecast). Not the monitor's
    weight: it fades heave for a few ticks now and then with an exact forecast too (13–26 % of ticks in W3),
    and the sway hold lost a quarter of its gain to it. A −10 dB forecast flown at full weight sideways
    rolled a head-sea vehicle past 70° while its vertical feed-forward had faded out; weighed, 3°."""
    if weight >= 1.0:
        return flow
    return Flow6(flow.vel * weight, flow.acc * weight)


@dataclass(frozen=True)
class LateralRecord:
    """The lateral-directional plane's tick: estimate [y, φ, ψ, v, p, r], target [y, ψ] (m, rad), the wrench
    [Y, K, N] flown and its feed-forward part (N, N m)."""

    x_hat: np.ndarray
    target: np.ndarray
    tau: np.ndarray
    tau_ff: np.ndarray


class LateralPlane:
    """Sway, roll and heading: estimate, target and hold.

    ``body6``: the vehicle's nominal six-DoF parameters (None: a vehicle without a lateral model, which stays
    planar); ``load_model`` the vertical plane's nominal wave-load model, which this plane's shares; ``strips``
    the strips along the length; ``target`` the station's [y (m, NED east), ψ (rad)].
    """

    def __init__(self, params: ParameterTable, h: float, body6: RigidBody6Params | None, load_model: str,
                 strips: int, target=(0.0, 0.0)):
        self.params = params
        self.h = float(h)
        self._body6 = None if body6 is None else replace(body6, wave_load_model=load_model)
        self._strips = int(strips)
        self.body: Body6 | None = None
        self.ekf: LateralEKF | None = None
        self.hold = LateralHold(params)
        self.target = np.asarray(target, dtype=float)
        self._offsets = np.array([0.0, 0.5 * self.h, self.h])

    @property
    def estimating(self) -> bool:
        """The plane has an estimate and is held (``WK_LAT_HOLD``)."""
        return self.ekf is not None and self.ekf.initialised and bool(self.params["WK_LAT_HOLD"])

    @property
    def restarts(self) -> int:
        return 0 if self.ekf is None else self.ekf.restarts

    def reset(self) -> None:
        """Forget the hold's memory (a mode change, an arming)."""
        self.hold.reset()

    def hold_where_entered(self) -> None:
        """A mode entered that holds where it was entered: the sway and heading targets become the estimate's."""
        if self.ekf is not None and self.ekf.initialised:
            self.target = self.ekf.x[[0, 2]].copy()

    # ------------------------------------------------------------------ estimate
    def _estimator(self, frame: SensorFrame) -> LateralEKF | None:
        """The estimator, built on the first frame with a roll reading (WK_LAT_HOLD on, a six-DoF model known)."""
        if self.ekf is None:
            if self._body6 is None or not self.params["WK_LAT_HOLD"] or not math.isfinite(frame.roll):
                return None
            self.body = Body6(self._body6, self._strips, STRIPS_ACROSS)
            self.ekf = LateralEKF(self.body, self.params, self.h)
        return self.ekf

    def predict(self, frame: SensorFrame, x_planar: np.ndarray, tau6_stages: np.ndarray | None,
                flow: Flow6 | None) -> None:
        """The period's prediction, the vertical plane held at its estimate at the period's start ``x_planar``,
        under the six-DoF wrench (3, 6) the mixer expected (None: the plane was not held last tick)."""
        ekf = self._estimator(frame)
        if ekf is not None and tau6_stages is not None:
            ekf.predict(x_planar, tau6_stages, flow)

    def update(self, frame: SensorFrame) -> None:
        ekf = self._estimator(frame)
        if ekf is not None:
            ekf.update(frame)

    # ------------------------------------------------------------------ flow and hold
    def pose(self, x_planar: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The six-DoF estimate η̂ (6,), ν̂ (6,) of both planes (the vertical one's [x, z, θ, u, w, q])."""
        assert self.ekf is not None
        xl = self.ekf.x
        xp = x_planar
        eta = np.array([xp[0], xl[0], xp[1], xl[1], xp[2], xl[2]])
        nu = np.array([xp[3], xl[3], xp[4], xl[4], xp[5], xl[5]])
        return eta, nu

    def flow(self, active: ActiveForecast | None, x_planar: np.ndarray, t: float,
             weight: float = 1.0) -> Flow6 | None:
        """The forecast's flow at the strips at t, t + h/2, t + h at the estimated pose, scaled by ``weight``
        (:func:`weighted_flow6`; None without a forecast, or at weight 0)."""
        if active is None or self.body is None or not self.estimating or weight <= 0.0:
            return None
        eta, _ = self.pose(x_planar)
        return weighted_flow6(self.body.flow(active.components, eta, t + self._offsets, np.zeros(3)), weight)

    def control(self, x_planar: np.ndarray, x_target: float, active: ActiveForecast | None,
                t_ahead: float, weight: float = 1.0) -> LateralRecord | None:
        """This tick's hold (None while the plane is not estimated): the wrench [Y, K, N] and, with a forecast in
        use (``active``), its feed-forward: the predicted sway force and roll and yaw moments at the end of the
        period that starts at ``t_ahead`` on the body moving with its estimated ν, in the forecast's flow scaled
        by ``weight`` (in [0, 1]: the forecast's skill weight in heave). ``x_target`` (m, north) is the
        vertical plane's x target (the sway error is the horizontal one's body-frame part)."""
        if not self.estimating:
            return None
        assert self.ekf is not None and self.body is not None
        tau_wave = None
        flow = self.flow(active, x_planar, t_ahead, weight)
        if flow is not None:
            _, nu = self.pose(x_planar)
            load = self.body.load(nu, flow, 2) - self.body.load(nu, None)
            tau_wave = load[[1, 3, 5]] if np.isfinite(load).all() else None
        target = np.array([x_target, self.target[0], self.target[1]])
        tau, tau_ff, _ = self.hold.update(x_planar, self.ekf.x, target, tau_wave, self.h)
        return LateralRecord(self.ekf.x.copy(), self.target.copy(), tau, tau_ff)
