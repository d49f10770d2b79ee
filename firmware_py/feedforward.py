"""Wave feed-forward: the forecast's flow at the body → the feed-forward wrench τ_FF.

Paper Eq. 12 adds τ_FF = −τ̂_E to the cascaded PD's command, with τ̂_E the wave
load of Eq. 11 predicted from the forecast. τ̂_E is the plant's own load model
(:func:`~bridge.models.vehicle.hydrodynamic_load`) with the firmware's nominal
parameters, evaluated for the vehicle *holding station* (ν = 0) at the
estimated pose, at the end of the control period (when the mixer has the
motors at their demand).

A forecast that evaluates to a non-finite load (e.g. at a diverged pose) is
no forecast: it is counted in :attr:`WaveFeedForward.faults` and the tick runs
without feed-forward.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bridge.models.vehicle import BodyFlow, VehicleParams, hydrodynamic_load

from .params import ParameterTable

__all__ = ["FeedForwardOutput", "WaveFeedForward"]


@dataclass(frozen=True)
class FeedForwardOutput:
    """One tick's feed-forward, body frame [X (N), Z (N), M (N m)].

    ``tau_e_hat`` is the predicted wave load, ``tau_ff`` the wrench handed to
    the controller (before its ``WK_FF_GAIN``), ``active`` whether there is one.
    """

    tau_e_hat: np.ndarray
    tau_ff: np.ndarray | None
    active: bool


class WaveFeedForward:
    """Turns the forecast's flow at the body's strips into the feed-forward wrench, and counts faults."""

    def __init__(self, vehicle: VehicleParams, params: ParameterTable):
        self.vehicle = vehicle
        self.params = params
        self.faults = 0                 # forecasts that evaluated to non-finite loads

    def reset(self) -> None:
        """Forget any state carried between ticks (none in the paper's law)."""

    def update(self, flow: BodyFlow | None, x_hat: np.ndarray) -> FeedForwardOutput:
        """The feed-forward for this tick from ``flow`` (stage 2: the end of the period) at the estimate x̂.

        ``flow`` None (no forecast, or FF not wanted this tick) gives an inactive output.
        """
        if flow is None:
            return FeedForwardOutput(np.zeros(3), None, False)
        # τ̂_E on the vehicle holding station (ν = 0) at the end of the period. The load's
        # dependence on the vehicle's own motion is left to the feedback: through the quadratic
        # drag it would turn velocity-estimate noise into feed-forward noise (≈ 300 N per m/s in W2).
        tau_e_hat = np.array(hydrodynamic_load(self.vehicle, 0.0, 0.0, 0.0, flow.stage(2)))
        if not np.all(np.isfinite(tau_e_hat)):
            self.faults += 1
            return FeedForwardOutput(np.zeros(3), None, False)
        return FeedForwardOutput(tau_e_hat, -tau_e_hat, True)
