"""The view of a run in Rerun: where each thing lives (entity paths), the static scene and the layout.

Rerun (``rerun-sdk``) is an optional extra, ``pip install 'wavekeep[view]'``: :func:`rerun_module`
imports it or raises :class:`ViewUnavailable` with the one line that says how to install it.

The 3-D scene is in the earth frame NED (x north along the waves' travel, y east, z down, m), as the
plant's η = [x, z, θ]; the vehicle is a box in body FRD, pitched by θ about its y axis. Every time
series is on the ``sim_time`` timeline (the vehicle's clock, s), so the scene and the plots scrub together.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from bridge.models.thrusters import T200Curve, ThrusterLayout
from bridge.models.waves import WaveComponents

__all__ = ["DOFS", "INSTALL_HINT", "TIMELINE", "SceneGeometry", "ViewUnavailable", "blueprint", "log_static",
           "rerun_module"]

INSTALL_HINT = "pip install 'wavekeep[view]'"
TIMELINE = "sim_time"
DOFS = (("x", "X"), ("z", "Z"), ("theta", "M"))
"""The planar DoF: (pose name, wrench axis)."""

VEHICLE_HALF_SIZE = (0.229, 0.288, 0.127)   # m: half of a BlueROV2 Heavy's 0.457 × 0.575 × 0.254 m frame
THRUST_SCALE = 1.0 / 50.0                   # m of arrow per N of thrust (35 N → 0.7 m)
SEA_HALF_LENGTH = 60.0                       # m of sea either side of the station, along the waves
SEA_STEP = 2.0                               # m between the surface's samples along x
SEA_WIDTH = 4.0                              # m: the true sea on y ∈ [−w, 0], the forecast on [0, w]
SEA_PERIOD_S = 0.1                           # s between the surfaces drawn (10 Hz)


class ViewUnavailable(RuntimeError):
    """Rerun is not installed."""


def rerun_module(what: str = "the view") -> Any:
    """``import rerun``, or :class:`ViewUnavailable` saying how to install it."""
    try:
        import rerun
    except ImportError:
        raise ViewUnavailable(f"{what} needs Rerun: {INSTALL_HINT}") from None
    return rerun


@dataclass
class SceneGeometry:
    """What the 3-D scene is drawn from besides the time series: the true sea, the forecast, the buoy,
    the thrusters (layout, T200 curve, motor lag t_m (s), per-thruster cap (N)) and the station x (m)."""

    sea: WaveComponents | None
    layout: ThrusterLayout
    curve: T200Curve
    time_constant_s: float
    thrust_max_n: float
    station_x: float = 0.0
    forecast: WaveComponents | None = None
    forecasts: list[tuple[float, WaveComponents]] | None = None   # (valid from, s) → components: DSWP
    buoy_x: float | None = None

    @classmethod
    def from_configs(cls, vehicle: str, sea: WaveComponents | None, station_x: float, **kw) -> SceneGeometry:
        """The thrusters of the vehicle config ``vehicle`` (a name in configs/vehicle/ or a path)."""
        from bridge.schemas import load_vehicle_config
        th = load_vehicle_config(vehicle)["thrusters"]
        return cls(sea, ThrusterLayout.from_config(th), T200Curve.from_config(th), float(th["time_constant"]),
                   float(th["thrust_max"]), station_x, **kw)

    def x_range(self) -> tuple[float, float]:
        """The stretch of sea drawn (m): ±60 m about the station, widened to take the buoy in."""
        lo, hi = self.station_x - SEA_HALF_LENGTH, self.station_x + SEA_HALF_LENGTH
        if self.buoy_x is not None:
            lo, hi = min(lo, self.buoy_x - 5.0), max(hi, self.buoy_x + 5.0)
        return lo, hi


def log_static(rr, rec, geometry: SceneGeometry | None, truth: bool = True) -> None:
    """The static scene: the NED frame, the vehicle's box (true) and its ghost (estimate), the sea's
    triangles, and how each series is drawn (``truth``: the source has the true pose; a tlog has not)."""
    rec.log("world", rr.ViewCoordinates.FRD, static=True)    # NED: x forward (north), y right (east), z down
    if truth:
        rec.log("world/vehicle/true/body", rr.Boxes3D(half_sizes=[VEHICLE_HALF_SIZE], colors=[(230, 200, 40)],
                                                      fill_mode="solid"), static=True)
    rec.log("world/vehicle/estimate/body", rr.Boxes3D(half_sizes=[VEHICLE_HALF_SIZE], colors=[(120, 230, 120, 70)],
                                                      fill_mode="solid"), static=True)
    if geometry is not None:
        n = _sea_samples(geometry)
        tri = np.array([[i, i + 1, n + i] for i in range(n - 1)] + [[i + 1, n + i + 1, n + i] for i in range(n - 1)],
                       dtype=np.uint32)
        rec.log("world/sea/true", rr.Mesh3D.from_fields(triangle_indices=tri, albedo_factor=(40, 110, 220, 200)),
                static=True)
        rec.log("world/sea/forecast", rr.Mesh3D.from_fields(triangle_indices=tri, albedo_factor=(240, 140, 40, 170)),
                static=True)
    for path, (color, name) in _series_styles().items():
        rec.log(f"plots/{path}", rr.SeriesLines(colors=color, names=name, widths=0.5 if "sigma" in path else 1.0),
                static=True)
    for _, axis in DOFS:
        rec.log(f"plots/wrench/{axis}/saturated", rr.SeriesPoints(colors=(230, 40, 40), names="saturated",
                                                                  marker_sizes=2.0), static=True)


_TRUE, _ESTIMATE, _FORECAST, _GREY = (70, 140, 255), (120, 230, 120), (245, 150, 50), (150, 150, 150)


def _series_styles() -> dict[str, tuple[tuple[int, ...], str]]:
    """Colour and legend of each series: truth blue, estimate green, forecast and FF orange."""
    styles: dict[str, tuple[tuple[int, ...], str]] = {
              "wave/true": (_TRUE, "true ζ"), "wave/forecast": (_FORECAST, "forecast ζ"),
              "nis/nis": ((200, 120, 230), "NIS"), "nis/per_dof": ((240, 240, 240), "NIS / dof"),
              "ff/active": ((240, 240, 240), "FF on")}
    for pose, axis in DOFS:
        styles |= {f"error/{pose}/true": (_TRUE, "true − station"),
                   f"error/{pose}/estimate": (_ESTIMATE, "estimate − station"),
                   f"error/{pose}/plus_2sigma": (_GREY, "estimate + 2σ"),
                   f"error/{pose}/minus_2sigma": (_GREY, "estimate − 2σ"),
                   f"wrench/{axis}/cpd": ((170, 170, 170), "C-PD"), f"wrench/{axis}/ff": (_FORECAST, "FF"),
                   f"wrench/{axis}/total": ((250, 250, 250), "total"),
                   f"ff/weight_{axis}": (_AXIS_COLORS[axis], f"weight {axis}"),
                   f"ff/skill_{axis}": (tuple(c // 2 for c in _AXIS_COLORS[axis]), f"skill {axis}"),
                   f"wrench/{axis}/wave_load": (_TRUE, "wave load τ_E (true)"),
                   f"wrench/{axis}/predicted_load": ((250, 200, 120), "wave load predicted")}
    return styles


_AXIS_COLORS = {"X": (255, 110, 110), "Z": (110, 200, 255), "M": (255, 220, 90)}


def _sea_samples(geometry: SceneGeometry) -> int:
    lo, hi = geometry.x_range()
    return int(round((hi - lo) / SEA_STEP)) + 1


def blueprint(rr):
    """The layout a recording opens on: the 3-D scene and the events on the left; the station error
    with the EKF's ±2σ, the wave at the vehicle, the wrench, the feed-forward and NIS on the right; the
    raw telemetry of a tlog in a second tab."""
    rrb = rr.blueprint
    scene = rrb.Spatial3DView(origin="world", name="sea, vehicle, thrust", contents=["+ /world/**"],
                              background=(12, 20, 34),
                              eye_controls=rrb.EyeControls3D(position=(-3.0, -8.5, 3.0), look_target=(0.0, 0.0, 2.8),
                                                             eye_up=(0.0, 0.0, -1.0)))
    error = [rrb.TimeSeriesView(origin=f"plots/error/{p}", name=f"error {label}")
             for p, label in (("x", "x (m)"), ("z", "z (m, +down)"), ("theta", "θ (rad)"))]
    wrench = [rrb.TimeSeriesView(origin=f"plots/wrench/{a}", name=f"wrench {a} ({'N m' if a == 'M' else 'N'})")
              for _, a in DOFS]
    right = rrb.Grid(*error, rrb.TimeSeriesView(origin="plots/wave", name="wave at the vehicle (m, up)"), *wrench,
                     rrb.TimeSeriesView(origin="plots/ff", name="FF weight and skill"),
                     rrb.TimeSeriesView(origin="plots/nis", name="NIS"), grid_columns=3)
    left = rrb.Vertical(scene, rrb.TextLogView(origin="events", name="mode, arming, failsafes"), row_shares=[3, 1])
    station = rrb.Horizontal(left, right, column_shares=[2, 3], name="station keeping")
    telemetry = rrb.Grid(*(rrb.TimeSeriesView(origin=f"plots/tlog/{g}", name=g)
                           for g in ("attitude", "position", "hud", "servo", "rc", "named")), name="telemetry")
    return rrb.Blueprint(rrb.Tabs(station, telemetry), rrb.TimePanel(state="expanded"), collapse_panels=True)
