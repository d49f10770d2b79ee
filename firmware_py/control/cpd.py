"""C-PD with its terms: the cascaded PD, the wave feed-forward, the disturbance observer, the preview.

The paper's law (:class:`~firmware_py.control.cascaded_pd.StationKeepingController`) with the feed-forward wrench
of :mod:`firmware_py.control.feedforward` (``WK_FF_ENABLE``), the estimated disturbance fed back
(``WK_DOB_ENABLE``) and, with the robust feed-forward (``WK_FF_MODE`` 1), the saturation preview
(:mod:`firmware_py.control.preview`) moving the target ahead of a forecast wave group the thrusters cannot hold.
C-PD, C-PD+FF and C-PD+DOB are this one strategy with those terms on or off.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from bridge.models.vehicle import VehicleParams

from ..params.table import ParameterTable
from .base import ControlInput
from .cascaded_pd import ControlOutput, StationKeepingController
from .preview import SaturationPreview

__all__ = ["CascadedPD"]


class CascadedPD:
    """The cascaded PD controller and its feed-forward, observer and preview terms (module docstring)."""

    name = "cpd"
    fallbacks = 0            # a closed-form law: it always has its command

    def __init__(self, params: ParameterTable, vehicle: VehicleParams, strips: tuple[np.ndarray, np.ndarray],
                 h: float):
        self.params = params
        self.law = StationKeepingController(params, vehicle)
        self.preview = SaturationPreview(vehicle, params, strips, h)

    def reset(self) -> None:
        self.law.reset()

    def update(self, c: ControlInput) -> ControlOutput:
        active = c.forecast if int(self.params["WK_FF_MODE"]) == 1 else None   # the preview: robust FF only
        target = c.setpoint + self.preview.update(None if active is None else active.components, c.x_hat,
                                                  c.setpoint, c.t, c.trusted)
        out = self.law.update(c.x_ahead, target, c.ff.tau_ff, c.h, c.d_hat)
        return replace(out, target_offset=target - c.setpoint)
