"""The station-keeping laws, side by side behind one interface (:mod:`.base`), chosen by ``WK_CTRL_LAW``.

* 0, :class:`~.cpd.CascadedPD`: the paper's cascaded PD with its terms — the wave feed-forward
  (``WK_FF_ENABLE``, law ``WK_FF_MODE``), the disturbance observer (``WK_DOB_ENABLE``) and the
  saturation preview (``WK_PRV_ENABLE``): C-PD, C-PD+FF, C-PD+DOB.
* 1, :class:`~.mpc.PreviewMPC`: the preview MPC on the forecast's horizon, falling back to the
  C-PD+FF command.

``WK_CTRL_LAW`` is read at boot, as ArduPilot reads the parameters that pick a vehicle's structure.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from bridge.models.thrusters import ThrusterLayout
from bridge.models.vehicle import VehicleParams

from ..params.table import ParameterTable
from .base import ControlInput, Controller
from .cpd import CascadedPD
from .mpc import PreviewMPC

__all__ = ["CONTROL_LAWS", "ControlInput", "Controller", "ControllerEnv", "build_controller"]


@dataclass(frozen=True)
class ControllerEnv:
    """What a law is built from: the table, the nominal vehicle, the thrusters, the strips, the period (s),
    the STATUSTEXT queue, and whether the firmware runs on the wall clock."""

    params: ParameterTable
    vehicle: VehicleParams
    layout: ThrusterLayout
    strips: tuple[np.ndarray, np.ndarray]
    h: float
    say: Callable[[int, str], None]
    wall_clock: bool = False


CONTROL_LAWS: dict[int, tuple[str, Callable[[ControllerEnv], Controller]]] = {
    0: ("cpd", lambda env: CascadedPD(env.params, env.vehicle, env.strips, env.h)),
    1: ("mpc", lambda env: PreviewMPC(env.params, env.vehicle, env.layout, env.strips, env.h, env.say,
                                      env.wall_clock)),
}
"""``WK_CTRL_LAW`` → (name, builder)."""


def build_controller(env: ControllerEnv) -> Controller:
    """The law ``WK_CTRL_LAW`` names."""
    return CONTROL_LAWS[int(env.params["WK_CTRL_LAW"])][1](env)
