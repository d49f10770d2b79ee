"""One campaign mission as a worker runs it, and the flat row it leaves in the campaign table.

:func:`run_task` is what a Dask worker executes: it imports the installed
package, flies :func:`~sitl.harness.run.run_mission` on the task's RunSpec and
returns one flat row — the spec's fields, every scalar of ``results.json``
flattened (``rmse_surge``, ``max_abs_error_pitch``, ``ekf_rms_error_x``, …),
its wall time and the worker's name. The per-tick time series stays on the
worker (unless a task asks for it: ``wavekeep reproduce``'s figures). A
mission that raises comes back as a row with ``status = "failed"`` and the
error, so the campaign goes on.
"""
from __future__ import annotations

import json
import socket
import time
import traceback
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from firmware_py.params.table import load_params

from .campaign_spec import CampaignTask
from .run import run_mission

__all__ = ["NONDETERMINISTIC", "SPEC_COLUMNS", "TaskOutcome", "flatten_results", "run_task", "spec_columns"]

SPEC_COLUMNS = ("mission_id", "spec_hash", "variant", "case", "controller", "forecast", "snr_db", "seed",
                "duration", "mission", "vehicle", "overrides")
"""The columns that describe the mission (before any result)."""

RUN_COLUMNS = ("status", "error", "worker", "task_wall_s", "finished_at")
"""How the mission went: ``ok``/``failed``, the error, where and how long (s), when (Unix time)."""

NONDETERMINISTIC = ("wall_time_s", "speed_x_realtime", "control_tick_p50_us", "control_tick_p99_us",
                    "control_tick_max_us", "control_tick_mean_us", "task_wall_s", "worker", "finished_at")
"""Columns that measure the machine, not the mission: everything else is bit-for-bit reproducible."""


@dataclass
class TaskOutcome:
    """What comes back over the wire: the flat row, the results.json document (a few kB; None if the
    mission failed) and the per-tick time series only if the task asked for it."""

    row: dict[str, Any]
    results: dict[str, Any] | None = None
    timeseries: np.ndarray | None = None


def spec_columns(task: CampaignTask) -> dict[str, Any]:
    """The row's description of the mission (overrides as a JSON object text)."""
    s = task.spec
    return {"mission_id": task.mission_id, "spec_hash": task.spec_hash, "variant": task.variant, "case": s.case,
            "controller": s.controller, "forecast": s.forecast, "snr_db": s.snr_db, "seed": s.seed,
            "duration": s.duration, "mission": s.mission, "vehicle": s.vehicle,
            "overrides": json.dumps(dict(sorted(s.overrides.items())))}


def flatten_results(results: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """Every scalar of a results document, nested keys joined by ``_`` (lists and arrays are left out).

    A top-level key that is also a spec column (``case``, ``controller``, ``forecast``, ``seed``)
    is prefixed ``result_``: the spec says what was asked, the results what the run resolved it to.
    """
    out: dict[str, Any] = {}
    for key, value in results.items():
        name = f"{prefix}{key}"
        if not prefix and name in SPEC_COLUMNS + RUN_COLUMNS:
            name = f"result_{name}"
        if isinstance(value, Mapping):
            out.update(flatten_results(value, f"{name}_"))
        elif value is None or isinstance(value, (bool, int, float, str)):
            out[name] = value
        elif isinstance(value, np.generic):
            out[name] = value.item()
    return out


def _check_overrides(task: CampaignTask) -> None:
    """Refuse a mission whose parameter overrides the firmware's table would not accept."""
    params = load_params()
    for name, value in task.spec.overrides.items():
        why = params.set(name, value)
        if why:
            raise ValueError(f"parameter override {name} = {value:g} refused: {why}")


def _worker_name() -> str:
    try:
        from distributed import get_worker
        return str(get_worker().name)
    except (ImportError, ValueError):
        return f"local@{socket.gethostname()}"


def run_task(task: CampaignTask) -> TaskOutcome:
    """Fly one mission and return its row (``status`` ``ok``, or ``failed`` with the error); never raises
    for a mission's own failure."""
    t0 = time.perf_counter()
    row: dict[str, Any] = spec_columns(task)
    series = results = None
    try:
        _check_overrides(task)
        result = run_mission(task.spec)
        row.update(status="ok", error=None)
        results = result.results
        row.update(flatten_results(results))
        if task.keep_timeseries:
            series = result.timeseries
    except Exception as exc:   # a mission's failure is data: recorded, and the campaign goes on
        tb = traceback.format_exception_only(type(exc), exc)[-1].strip()
        row.update(status="failed", error=tb)
    row.update(worker=_worker_name(), task_wall_s=time.perf_counter() - t0, finished_at=time.time())
    return TaskOutcome(row, results, series)

