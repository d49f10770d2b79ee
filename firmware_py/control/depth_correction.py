"""The depth reading less the waves' dynamic pressure, with the forecast (``WK_BARO_WAVE``).

A pressure sensor under waves reads p/(ρ g) = s + Σ A K_p cos θ (docs/sea-errors.md §5). With a valid
forecast the firmware takes the head out (:func:`~firmware_py.hal.sensors.wave_corrected_depth`) at the
estimated x. The reading changes meaning when the correction starts or stops (a forecast arrives or is
lost): then the EKF's depth is reset to the new reading, as ArduPilot's EKF resets its height when its
source changes, rather than left to see a step of up to the head as motion. The estimator starts from
the raw reading; the correction begins on the first tick after, at the same tick in process and across
processes (the forecast has arrived by then), so ``sim`` still equals ``run``.
"""
from __future__ import annotations

import math
from dataclasses import replace

from ..estimation.estimator import PlanarEKF
from ..forecast.handoff import ForecastHandoff
from ..hal.sensors import SensorFrame, wave_corrected_depth
from ..params.table import ParameterTable

__all__ = ["DepthCorrection"]


class DepthCorrection:
    """Per tick: the frame with its depth corrected while a forecast is valid (``WK_BARO_WAVE`` 1)."""

    def __init__(self, params: ParameterTable):
        self.params = params
        self.active = False      # the last depth reading passed on was corrected

    def apply(self, frame: SensorFrame, forecast: ForecastHandoff, ekf: PlanarEKF, t: float) -> SensorFrame:
        """``frame`` with ``depth`` less the forecast's head (m) at the estimate's x; as it came otherwise."""
        if not math.isfinite(frame.depth) or not ekf.initialised:
            return frame
        fc = forecast.current(t) if self.params["WK_BARO_WAVE"] else None
        if fc is not None:
            frame = replace(frame, depth=wave_corrected_depth(frame.depth, fc.components, float(ekf.x[0]), t))
        if (fc is not None) != self.active:
            self.active = fc is not None
            ekf.reset_channel("depth", frame.depth)
        return frame
