"""A run as a Rerun recording: the 3-D scene and the time series of its ticks, from named columns.

One writer for every source: a finished run's time series (``recording.rrd`` in the run folder), a
batch of ticks while a live mission flies (:mod:`~sitl.harness.live_view`), and a tlog's telemetry
resampled to the same names (:mod:`~sitl.harness.tlog_view`). Columns are read by name
(:data:`~sitl.harness.results.TIMESERIES_COLUMNS`' names: ``t``, ``x``, ``x_hat``, ``sigma_x``,
``tau_X``, ``pwm1`` ...); what a source does not have is not drawn. All of it is sent with
``send_columns``: one call per entity for the whole batch, so a 600 s run records in about a second.

The scene (:mod:`~sitl.harness.view_layout`): the true sea and the forecast as ribbons along the
waves, the buoy, the vehicle at its true pose and its estimate as a ghost, the eight thrusters as
arrows scaled by their thrust (red when saturated), the station and the saturation preview's target.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bridge.models.thrusters import motor_lag_factors
from bridge.models.waves import elevation_grid

from .view_layout import DOFS, SEA_PERIOD_S, SEA_STEP, SEA_WIDTH, THRUST_SCALE, TIMELINE, SceneGeometry

__all__ = ["RECORDING", "Event", "columns_of", "replay_thrust", "save_run", "write_columns", "write_events"]

RECORDING = "recording.rrd"

Columns = Mapping[str, np.ndarray]


@dataclass(frozen=True)
class Event:
    """A mode, arming or failsafe event: vehicle time (s), MAV_SEVERITY, text."""

    t: float
    severity: int
    text: str


def columns_of(names, table: np.ndarray) -> dict[str, np.ndarray]:
    """A (rows × columns) table as name → column (a timeseries.csv, a tick log)."""
    table = np.asarray(table, dtype=float).reshape(-1, len(names))
    return {n: table[:, i] for i, n in enumerate(names)}


def _has(cols: Columns, *names: str) -> bool:
    return all(n in cols for n in names)


def _pitch_quaternions(theta: np.ndarray) -> np.ndarray:
    """Body pitch θ (rad, nose up) about the body y axis as Rerun's (x, y, z, w) quaternions."""
    h = 0.5 * np.asarray(theta, dtype=float)
    return np.column_stack([np.zeros_like(h), np.sin(h), np.zeros_like(h), np.cos(h)])


def _points(x: np.ndarray, z: np.ndarray) -> np.ndarray:
    return np.column_stack([x, np.zeros_like(x), z])


def write_columns(rr, rec, cols: Columns, geometry: SceneGeometry | None = None, *, lag: bool = True,
                  thrust0: np.ndarray | None = None) -> np.ndarray | None:
    """Send the ticks in ``cols`` (``t`` in s on the vehicle's clock) to ``rec``; the thrusters'
    last thrust (N), which the next batch of the same run starts from (``thrust0``)."""
    t = np.asarray(cols["t"], dtype=float)
    if t.size == 0:
        return thrust0
    tc = [rr.TimeColumn(TIMELINE, duration=t)]
    truth = _has(cols, "x", "z", "theta")
    for name, keys in (("true", ("x", "z", "theta")), ("estimate", ("x_hat", "z_hat", "theta_hat"))):
        if _has(cols, *keys):
            x, z, th = (cols[k] for k in keys)
            rec.send_columns(f"world/vehicle/{name}", indexes=tc, columns=rr.Transform3D.columns(
                translation=_points(x, z), quaternion=_pitch_quaternions(th)))
    _send_targets(rr, rec, tc, cols)
    last = thrust0
    if geometry is not None and _has(cols, *(f"pwm{i}" for i in range(1, 9))):
        pwm = np.column_stack([cols[f"pwm{i}"] for i in range(1, 9)])
        f, saturated, last = replay_thrust(geometry, pwm, t, thrust0 if lag else None, lag=lag)
        _send_thrusters(rr, rec, tc, geometry, f, saturated, "true" if truth else "estimate")
    if geometry is not None:
        _send_sea(rr, rec, cols, geometry)
    _send_series(rr, rec, tc, cols)
    return last


def _send_targets(rr, rec, tc, cols: Columns) -> None:
    """The station [x, depth] and the saturation preview's shifted target (it logs its offset)."""
    if not _has(cols, "sp_x", "sp_z"):
        return
    n = cols["sp_x"].size
    targets = {"station": (cols["sp_x"], cols["sp_z"], 0.06)}
    if _has(cols, "prv_x", "prv_z"):
        targets["preview"] = (cols["sp_x"] + cols["prv_x"], cols["sp_z"] + cols["prv_z"], 0.04)
    for name, (x, z, radius) in targets.items():
        rec.send_columns(f"world/target/{name}", indexes=tc, columns=rr.Points3D.columns(
            positions=_points(x, z), radii=np.full(n, radius)).partition(np.ones(n, dtype=int)))


def replay_thrust(g: SceneGeometry, pwm: np.ndarray, t: np.ndarray, f0: np.ndarray | None = None,
                  lag: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each thruster's thrust (N) at each tick from the PWM logged: the plant's T200 curve and motor lag.

    Row k's PWM is held over the tick's period, so the thrust at row k's time is the lag's exact
    solution f_k = f_cmd(k−1) + e^{−Δt/t_m} (f_{k−1} − f_cmd(k−1)) from the thrust at the row before
    (``f0`` before the first: idle). Without ``lag`` (a tlog's few servo messages a second) the thrust
    is the curve's steady thrust for the PWM. Saturated: the command at the per-thruster cap or at
    the end of the ESC range. Returns the thrusts (ticks × 8), saturated (ticks × 8) and the thrust
    the next tick starts from.
    """
    f_cmd = g.curve.thrust(pwm)
    saturated = (np.abs(f_cmd) >= g.thrust_max_n * (1 - 1e-6)) | (pwm <= g.curve.pwm_min) | (pwm >= g.curve.pwm_max)
    if not lag:
        return f_cmd, saturated, f_cmd[-1]
    f = np.empty_like(f_cmd)
    prev = np.zeros(f_cmd.shape[1]) if f0 is None else np.asarray(f0, dtype=float)
    dt = np.diff(t, prepend=t[0] - (t[1] - t[0] if t.size > 1 else 0.05))
    held = motor_lag_factors(g.time_constant_s, np.r_[dt[1:], dt[-1:]])     # row k's PWM held until row k+1
    for k in range(t.size):
        f[k] = prev
        prev = f_cmd[k] + held[k] * (prev - f_cmd[k])
    return f, saturated, prev


def _send_thrusters(rr, rec, tc, g: SceneGeometry, f: np.ndarray, saturated: np.ndarray, pose: str) -> None:
    n, m = f.shape
    origins = np.broadcast_to(g.layout.positions, (n, m, 3)).reshape(-1, 3)
    vectors = (f[:, :, None] * g.layout.directions[None, :, :] * THRUST_SCALE).reshape(-1, 3)
    colors = np.where(saturated.reshape(-1, 1), np.array([[235, 45, 45, 255]]), np.array([[80, 230, 140, 255]]))
    rec.send_columns(f"world/vehicle/{pose}/thrusters", indexes=tc, columns=rr.Arrows3D.columns(
        origins=origins, vectors=vectors, colors=colors.astype(np.uint8)).partition(np.full(n, m)))


def _forecast_at(g: SceneGeometry, t: float):
    """The forecast the vehicle had at time t (s): the oracle's, or the newest DSWP one by then."""
    if g.forecasts:
        valid = [c for t0, c in g.forecasts if t0 <= t]
        return valid[-1] if valid else None
    return g.forecast


def _send_sea(rr, rec, cols: Columns, g: SceneGeometry) -> None:
    """The sea along the waves every SEA_PERIOD_S: true on y ∈ [−w, 0], the forecast on [0, w]."""
    t_all = np.asarray(cols["t"], dtype=float)
    frame = np.floor(t_all / SEA_PERIOD_S + 1e-6)
    k = np.flatnonzero(np.diff(frame, prepend=-np.inf) > 0)     # the first tick of each frame period
    if k.size == 0:
        return
    t = t_all[k]
    lo, hi = g.x_range()
    xs = np.linspace(lo, hi, int(round((hi - lo) / SEA_STEP)) + 1)
    n = xs.size
    tc = [rr.TimeColumn(TIMELINE, duration=t)]
    for name, side in (("true", -SEA_WIDTH), ("forecast", SEA_WIDTH)):
        zeta = _surface(g, name, xs, t)
        if zeta is None:
            continue
        v = np.empty((t.size, 2, n, 3))
        v[:, :, :, 0] = xs
        v[:, 0, :, 1], v[:, 1, :, 1] = 0.0, side
        v[:, :, :, 2] = -zeta[:, None, :]          # NED: elevation up is −z
        rec.send_columns(f"world/sea/{name}", indexes=tc, columns=rr.Mesh3D.columns(
            vertex_positions=v.reshape(-1, 3)).partition(np.full(t.size, 2 * n)))
    if g.buoy_x is not None and g.sea is not None:
        zb = _elevations(g.sea, np.array([g.buoy_x]), t)[:, 0]
        rec.send_columns("world/sea/buoy", indexes=tc, columns=rr.Points3D.columns(
            positions=_points(np.full(t.size, g.buoy_x), -zb), radii=np.full(t.size, 0.5),
            colors=np.tile([[250, 220, 40, 255]], (t.size, 1)).astype(np.uint8)).partition(np.ones(t.size, dtype=int)))


def _surface(g: SceneGeometry, name: str, xs: np.ndarray, t: np.ndarray) -> np.ndarray | None:
    """ζ (m, up) on xs at each time of t (times × points), true or forecast; None if there is none."""
    if name == "true":
        return None if g.sea is None else _elevations(g.sea, xs, t)
    if g.forecasts:
        out = np.full((t.size, xs.size), np.nan)
        for i, ti in enumerate(t):
            c = _forecast_at(g, float(ti))
            if c is not None:
                out[i] = elevation_grid(c, xs, [ti])[0]
        return out
    return None if g.forecast is None else _elevations(g.forecast, xs, t)


def _elevations(c, xs: np.ndarray, t: np.ndarray, chunk: int = 4096) -> np.ndarray:
    """ζ (m) on xs at each time of t (times × points), a few thousand frames at a time."""
    return np.concatenate([elevation_grid(c, xs, t[i:i + chunk]) for i in range(0, t.size, chunk)])


def _series(cols: Columns) -> dict[str, np.ndarray]:
    """The time series drawn: entity path under plots/ → values (units of the column)."""
    out: dict[str, np.ndarray] = {}
    for pose, axis in DOFS:
        sp = cols.get(f"sp_{pose}")
        if sp is not None and pose in cols:
            out[f"error/{pose}/true"] = cols[pose] - sp
        if sp is not None and f"{pose}_hat" in cols:
            est = cols[f"{pose}_hat"] - sp
            out[f"error/{pose}/estimate"] = est
            if f"sigma_{pose}" in cols:
                out[f"error/{pose}/plus_2sigma"] = est + 2.0 * cols[f"sigma_{pose}"]
                out[f"error/{pose}/minus_2sigma"] = est - 2.0 * cols[f"sigma_{pose}"]
        if f"tau_{axis}" in cols:
            total = cols[f"tau_{axis}"]
            ff = cols.get(f"tau_ff_{axis}", np.zeros_like(total))
            out[f"wrench/{axis}/total"] = total
            out[f"wrench/{axis}/ff"] = ff
            out[f"wrench/{axis}/cpd"] = total - ff - cols.get(f"tau_dob_{axis}", 0.0)
        for src, dst in ((f"ff_w_{axis}", f"ff/weight_{axis}"), (f"ff_skill_{axis}", f"ff/skill_{axis}"),
                         (f"tauE_{axis}", f"wrench/{axis}/wave_load"),
                         (f"tauE_hat_{axis}", f"wrench/{axis}/predicted_load")):
            if src in cols:
                out[dst] = cols[src]
    for src, dst in (("wave_eta", "wave/true"), ("forecast_eta", "wave/forecast"), ("ff_active", "ff/active")):
        if src in cols:
            out[dst] = cols[src]
    if "nis" in cols:
        out["nis/nis"] = cols["nis"]
        if "nis_dof" in cols:
            with np.errstate(divide="ignore", invalid="ignore"):
                out["nis/per_dof"] = np.where(cols["nis_dof"] > 0, cols["nis"] / cols["nis_dof"], np.nan)
    out.update({k[len("plots/"):]: v for k, v in cols.items() if k.startswith("plots/")})   # a tlog's own
    return out


def _send_series(rr, rec, tc, cols: Columns) -> None:
    t = np.asarray(cols["t"], dtype=float)
    for path, values in _series(cols).items():
        v = np.asarray(values, dtype=float)
        keep = np.isfinite(v)
        if not keep.any():
            continue
        index = tc if keep.all() else [rr.TimeColumn(TIMELINE, duration=t[keep])]
        rec.send_columns(f"plots/{path}", indexes=index, columns=rr.Scalars.columns(scalars=v[keep]))
    sat = cols.get("saturated")
    if sat is not None:
        on = np.asarray(sat) > 0.5
        for _, axis in DOFS:
            if on.any() and f"tau_{axis}" in cols:
                rec.send_columns(f"plots/wrench/{axis}/saturated", indexes=[rr.TimeColumn(TIMELINE, duration=t[on])],
                                 columns=rr.Scalars.columns(scalars=np.asarray(cols[f"tau_{axis}"])[on]))


def write_events(rr, rec, events: list[Event]) -> None:
    """Mode, arming and failsafe events as text entries on the same timeline."""
    if not events:
        return
    levels = {0: "CRITICAL", 1: "CRITICAL", 2: "CRITICAL", 3: "ERROR", 4: "WARN", 5: "INFO", 6: "INFO", 7: "DEBUG"}
    rec.send_columns("events", indexes=[rr.TimeColumn(TIMELINE, duration=[e.t for e in events])],
                     columns=rr.TextLog.columns(text=[e.text for e in events],
                                                level=[levels.get(e.severity, "INFO") for e in events]))


def save_run(path: str | Path, cols: Columns, geometry: SceneGeometry | None, events: list[Event],
             name: str, lag: bool = True, grpc_url: str | None = None) -> Path:
    """Write ``path`` (a ``.rrd``): the static scene, the ticks, the events and the layout (``lag``:
    :func:`replay_thrust`'s); with ``grpc_url`` also to that viewer."""
    from .view_layout import blueprint, log_static, rerun_module
    rr = rerun_module("a recording")
    path = Path(path)
    rec = rr.RecordingStream("wavekeep", recording_id=name)
    sinks = [rr.FileSink(str(path))] + ([rr.GrpcSink(grpc_url)] if grpc_url else [])
    rec.set_sinks(*sinks, default_blueprint=blueprint(rr))
    try:
        rec.send_recording_name(name)
        log_static(rr, rec, geometry, truth="x" in cols)
        write_columns(rr, rec, cols, geometry, lag=lag)
        write_events(rr, rec, events)
    finally:
        rec.flush()
        rec.disconnect()
    return path
