"""What a run leaves behind: its results document, its per-tick time series, and how they are written.

Shared by the in-process run, the launcher, reproduce, campaigns and the
figures, so that every transport writes the same ``results.json`` schema and
the same ``timeseries.csv`` columns.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from bridge.models.waves import WaveComponents, elevation, elevation_xy
from firmware_py.logger.tick_columns import TICK_COLUMNS, SolveStatus
from sitl.sea import Sea

from .metrics import six_dof_metrics, station_keeping_metrics
from .spec import RunSpec

__all__ = ["TIMESERIES_COLUMNS", "RunResult", "controller_summary", "ekf_consistency", "ekf_lapses", "elevation_along",
           "lapse_lines",
           "mission_results", "write_results"]

TIMESERIES_COLUMNS = (
    "t", "x", "z", "theta", "u", "w", "q",             # truth at the tick
    *TICK_COLUMNS,                                     # what the firmware's tick saw and did
    "tauE_X", "tauE_Z", "tauE_M",                      # true wave load at the end of the tick's period
    "wave_eta", "forecast_eta",                        # elevations at the vehicle's x
    "y", "phi", "psi",                                 # truth out of the plane: east (m), roll, yaw (rad)
)
"""Columns of ``timeseries.csv``: one row per control tick."""

COLUMN = {c: i for i, c in enumerate(TIMESERIES_COLUMNS)}
"""Index of each column of :data:`TIMESERIES_COLUMNS`."""


@dataclass
class RunResult:
    results: dict[str, Any]     # the results.json document
    timeseries: np.ndarray      # (ticks, len(TIMESERIES_COLUMNS))
    events: list[tuple[float, int, str]] = field(default_factory=list)   # (t s, MAV_SEVERITY, text): in-process
    forecasts: list[tuple[float, Any]] | None = None    # (t s, WaveComponents) as handed over: DSWP in-process


def elevation_along(components: WaveComponents, x: np.ndarray, t: np.ndarray, chunk: int = 2048,
                    y: np.ndarray | None = None) -> np.ndarray:
    """Wave elevation ζ (m) at the points (x[i], t[i]) (and y[i], m east, in a sea with directions), in chunks to
    bound the (points × components) memory."""
    if y is None or components.direction is None:
        return np.concatenate([elevation(components, x[i:i + chunk], t[i:i + chunk])
                               for i in range(0, x.size, chunk)])
    return np.concatenate([elevation_xy(components, x[i:i + chunk], y[i:i + chunk], t[i:i + chunk])
                           for i in range(0, x.size, chunk)])


STATES = ("x", "z", "theta", "u", "w", "q")
CONSISTENCY_SKIP_S = 5.0
"""Consistency statistics leave out the first seconds (initial transient), as docs/estimator.md's figures do."""


def ekf_consistency(log: np.ndarray, skip_s: float = CONSISTENCY_SKIP_S) -> dict[str, Any]:
    """The estimator against the truth after ``skip_s``: per state the mean NEES e²/σ² and the share of
    errors within 2σ, the velocity error's RMS over the true velocity's, and the mean joint NIS per dof."""
    c = COLUMN
    k = log[:, 0] > skip_s
    if not np.any(k):
        return {}
    err = log[k, c["x_hat"]:c["q_hat"] + 1] - log[k, 1:7]
    sig = log[k][:, [c[f"sigma_{n}"] for n in STATES]]
    with np.errstate(divide="ignore", invalid="ignore"):
        nees = np.mean((err / sig) ** 2, axis=0)
        within = np.mean(np.abs(err) <= 2.0 * sig, axis=0)
        vel = np.sqrt(np.mean(err[:, 3:] ** 2, axis=0)) / np.sqrt(np.mean(log[k, 4:7] ** 2, axis=0))
    dof = float(np.sum(log[k, c["nis_dof"]]))
    return {"nees": dict(zip(STATES, nees.tolist(), strict=True)),
            "within_2sigma": dict(zip(STATES, within.tolist(), strict=True)),
            "vel_error_ratio": dict(zip(STATES[3:], vel.tolist(), strict=True)),
            "nis_per_dof": float(np.sum(log[k, c["nis"]]) / dof) if dof > 0 else None}


LAPSE_SIGMAS = 6.0
"""An estimate this many of its own σ from the truth is no longer the estimator's (NEES 36 against about 1)."""
LAPSE_FLOOR = {"x": 0.25, "z": 0.25, "theta": float(np.radians(5.0))}
"""... and at least this far (m, m, rad), so a tiny σ does not make noise a lapse."""
LAPSE_MIN_S = 0.25
"""Shortest lapse reported (s); lapses closer than this are one."""


def ekf_lapses(log: np.ndarray, rate_hz: float) -> list[dict[str, Any]]:
    """Spans where the EKF's position or pitch estimate left the truth by more than :data:`LAPSE_SIGMAS` of
    its own σ (and :data:`LAPSE_FLOOR`) for at least :data:`LAPSE_MIN_S`: per span the state, its start
    ``t_s`` and ``duration_s`` (s), the largest error (m or rad) and the σ the estimator claimed there."""
    c = COLUMN
    out: list[dict[str, Any]] = []
    gap = max(1, int(round(LAPSE_MIN_S * rate_hz)))
    for state in ("x", "z", "theta"):
        err = np.abs(log[:, c[f"{state}_hat"]] - log[:, c[state]])
        sig = log[:, c[f"sigma_{state}"]]
        with np.errstate(invalid="ignore"):
            off = np.flatnonzero((err > LAPSE_SIGMAS * sig) & (err > LAPSE_FLOOR[state]))
        if off.size == 0:
            continue
        breaks = np.flatnonzero(np.diff(off) > gap)
        for a, b in zip(np.r_[0, breaks + 1], np.r_[breaks, off.size - 1], strict=True):
            i, j = off[a], off[b]
            if (j - i + 1) / rate_hz < LAPSE_MIN_S:
                continue
            k = i + int(np.argmax(err[i:j + 1]))
            out.append({"state": state, "t_s": float(log[i, 0]), "duration_s": float((j - i + 1) / rate_hz),
                        "max_error": float(err[k]), "sigma": float(sig[k])})
    return sorted(out, key=lambda d: d["t_s"])


def lapse_lines(results: dict[str, Any], most: int = 3) -> list[str]:
    """The EKF lapses of a results document as printed lines (m; pitch in degrees): a count, then the
    ``most`` largest."""
    laps = (results.get("ekf") or {}).get("lapses") or []
    if not laps:
        return []
    lines = [f"EKF lapses: {len(laps)} span(s) where the estimate left the truth by more than "
             f"{LAPSE_SIGMAS:g} of its own σ (results.json ekf.lapses); the largest:"]
    for lap in sorted(laps, key=lambda d: -d["max_error"] / LAPSE_FLOOR[d["state"]])[:most]:
        unit, scale = ("°", float(np.degrees(1.0))) if lap["state"] == "theta" else (" m", 1.0)
        lines.append(f"  {lap['state']} estimate off by up to {lap['max_error'] * scale:.3g}{unit} (its σ "
                     f"{lap['sigma'] * scale:.2g}{unit}) for {lap['duration_s']:.2f} s from t = {lap['t_s']:.2f} s")
    return lines


def mission_results(sea: Sea, spec: RunSpec, duration: float, rate: float, setpoint: np.ndarray,
                    log: np.ndarray, control_stats: dict[str, Any]) -> dict[str, Any]:
    """The ``results.json`` fields every mission reports, from its time series (in-process or launched).

    ``control_stats`` is the scheduler's statistics document (``overruns`` and the
    control task's ``compute`` timing).
    """
    c = COLUMN
    metrics = station_keeping_metrics(log[:, 0], log[:, 1:4], setpoint, log[:, c["tau_X"]:c["tau_M"] + 1])
    eta6 = log[:, [c["x"], c["y"], c["z"], c["phi"], c["theta"], c["psi"]]]
    station6 = np.array([setpoint[0], 0.0, setpoint[1], 0.0, setpoint[2], 0.0])
    estimate_error = log[:, c["x_hat"]:c["q_hat"] + 1] - log[:, 1:7]
    return {
        "case": sea.name,
        "controller": spec.controller,
        "forecast": spec.forecast_source,
        "forecast_snr_db": spec.snr_db if spec.ff else None,
        "seed": sea.seed,
        "duration_s": duration,
        "rate_hz": rate,
        **metrics,
        "six_dof": six_dof_metrics(eta6, station6, sea.dof),
        "tick_overruns": control_stats.get("overruns", 0),
        "label": spec.label,
        "ff_law": spec.ff_law,
        "estimator": spec.estimator,
        "changed_parameters": spec.changed_params,
        "hs_target_m": sea.hs_target,
        "hs_realised_m": float(4.0 * np.std(elevation_along(sea.components, np.full(len(log), setpoint[0]),
                                                            log[:, 0]))),
        "ekf": {"rms_error": dict(zip(("x", "z", "theta", "u", "w", "q"),
                                      np.sqrt(np.mean(estimate_error**2, axis=0)).tolist(), strict=True)),
                **ekf_consistency(log), "lapses": ekf_lapses(log, rate)},
        "ff_active_fraction": float(np.mean(log[:, c["ff_active"]])),
        "saturated_fraction": float(np.mean(log[:, c["saturated"]] > 0.5)),   # ticks with an axis at ±τ_max
        "solver": controller_summary(spec.controller, log),
        "control_tick": control_stats.get("tasks", {}).get("control", {}).get("compute"),
        "faults": control_stats.get("faults"),
    }


def controller_summary(law: str, log: np.ndarray) -> dict[str, Any]:
    """The law's solver over the mission, from the ``ctrl_*`` columns: ticks per status (fallbacks with their
    reason), their share, and the iterations' and compute time's p50, p99 and largest (of ticks it solved in)."""
    c = COLUMN
    status = log[:, c["ctrl_status"]].astype(int)
    counts = {s.name.lower(): int(np.sum(status == s)) for s in SolveStatus if s != SolveStatus.NONE}
    out: dict[str, Any] = {"law": law}
    ran = status != SolveStatus.NONE
    if not ran.any():
        return out
    fallbacks = {k: v for k, v in counts.items() if k != "solved"}
    stat = lambda v: {"p50": float(np.percentile(v, 50)), "p99": float(np.percentile(v, 99)),  # noqa: E731
                      "max": float(np.max(v))}
    out.update(ticks=int(ran.sum()), solved=counts["solved"], fallbacks=fallbacks,
               fallback_share=float(sum(fallbacks.values()) / ran.sum()),
               iterations=stat(log[ran, c["ctrl_iter"]]), solve_ms=stat(log[ran, c["ctrl_ms"]]))
    return out


def write_results(result: RunResult, out: str | Path) -> Path:
    """DIR/results.json and DIR/timeseries.csv."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "results.json").write_text(json.dumps(result.results, indent=2))
    np.savetxt(out / "timeseries.csv", result.timeseries, delimiter=",", header=",".join(TIMESERIES_COLUMNS),
               comments="", fmt="%.6g")
    return out
