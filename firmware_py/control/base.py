"""What the 20 Hz control task hands a controller, and what every controller answers.

C-PD (with its feed-forward and disturbance-observer terms) and the preview MPC are strategies behind
this one small interface (:class:`Controller`): the task builds a :class:`ControlInput` each tick and
flies the :class:`~firmware_py.control.cascaded_pd.ControlOutput` it gets back, whichever law made it. A new law is
a new module beside the others (registered in :mod:`firmware_py.control.laws`), not a branch in the tick.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from ..forecast.handoff import ActiveForecast
from .cascaded_pd import ControlOutput
from .feedforward import FeedForwardOutput

__all__ = ["ControlInput", "Controller"]


@dataclass(frozen=True)
class ControlInput:
    """One tick's inputs to a controller (SI units; NED pose, body FRD velocities and wrenches).

    ``x_hat`` is the estimate [x, z, θ, u, w, q] now; ``x_ahead`` the state the command will meet, at
    ``t_ahead`` (the estimate propagated over the commands still in flight, ``WK_OUT_DELAY``).
    ``setpoint`` is the mode's target [x, z, θ]. ``ff`` is this tick's feed-forward (its law, monitor,
    skill and weights; ``tau_ff`` None when off). ``forecast`` is the forecast in use while the
    feed-forward is on (None otherwise), ``trusted`` False while the FF monitor has set it aside.
    ``d_hat`` is the estimator's disturbance wrench, ``thrust`` the wrench the motors give now by the
    mixer's motor model (N, N, N m).
    """

    t: float
    t_ahead: float
    h: float
    x_hat: np.ndarray
    x_ahead: np.ndarray
    setpoint: np.ndarray
    ff: FeedForwardOutput
    forecast: ActiveForecast | None
    trusted: bool
    d_hat: np.ndarray
    thrust: np.ndarray


class Controller(Protocol):
    """A station-keeping law: one command per tick from a :class:`ControlInput`."""

    name: str

    @property
    def fallbacks(self) -> int:
        """Ticks this law could not compute its command and flew its fallback's (0 for a law without one)."""
        ...

    def reset(self) -> None:
        """Forget the law's memory (a mode change, an arming, a non-finite command)."""
        ...

    def update(self, c: ControlInput) -> ControlOutput:
        """The wrench to fly this tick, with what the law did (``solve``) and any target offset."""
        ...
