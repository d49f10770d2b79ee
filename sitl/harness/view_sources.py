"""What a recording is made from: a run (its spec and time series), a run folder, or a tlog.

``wavekeep run``, ``sim`` (and ``sim --companion``) call :func:`record_run` after their files are
written; ``wavekeep view`` and ``wavekeep tlog`` call :func:`rrd_for` / :func:`tlog_to_rrd`.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np

from .recording import RECORDING, Columns, Event, columns_of, save_run
from .spec import RunSpec
from .view_layout import SceneGeometry, ViewUnavailable

__all__ = ["geometry_for", "read_timeseries", "record_run", "rrd_for", "spec_of_folder", "tlog_to_rrd"]


def geometry_for(spec: RunSpec, seed: int | None, forecasts=None) -> SceneGeometry:
    """The scene of a mission: its sea (seeded), its oracle forecast or DSWP forecasts and buoy, its
    vehicle's thrusters and its station."""
    from bridge.forecast import derive_seeds, oracle_forecast
    from bridge.schemas import load_mission_config
    from sitl.sea import Sea

    sea = Sea.load(spec.case, seed=seed if seed is not None else spec.seed, overrides=spec.sea)
    station_x = float(load_mission_config(spec.mission)["setpoint"]["x"])
    forecast, buoy_x = None, None
    if spec.forecast_source == "oracle":
        _, forecast_seed = derive_seeds(sea.seed)
        forecast = oracle_forecast(sea.components, spec.snr_db, np.random.default_rng(forecast_seed)).components()
    elif spec.forecast_source == "dswp":
        buoy_x = float(sea.buoy().x)
    return SceneGeometry.from_configs(spec.vehicle, sea.components, station_x, forecast=forecast,
                                      forecasts=forecasts, buoy_x=buoy_x)


def read_timeseries(path: str | Path) -> dict[str, np.ndarray]:
    """A ``timeseries.csv`` (or any CSV with a header of names) as name → column."""
    path = Path(path)
    with path.open() as fh:
        names = fh.readline().strip().split(",")
    return columns_of(names, np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2))


def _events_of_tlog(folder: Path) -> list[Event]:
    tlog = folder / "mission.tlog"
    if not tlog.is_file():
        return []
    from .tlog import read_tlog
    from .tlog_view import tlog_events
    try:
        return tlog_events(read_tlog(tlog))
    except ValueError:
        return []


def record_run(out: str | Path, spec: RunSpec, seed: int | None, cols: Columns | None = None,
               events: list[Event] | None = None, forecasts=None, quiet: bool = False,
               grpc_url: str | None = None) -> Path | None:
    """DIR/recording.rrd of a finished run (the time series ``cols``, default DIR/timeseries.csv; the
    events, default the STATUSTEXTs and modes of DIR/mission.tlog). None, with one line on stderr,
    when Rerun is not installed: the run itself has succeeded. ``grpc_url``: also send it to that viewer."""
    out = Path(out)
    try:
        cols = read_timeseries(out / "timeseries.csv") if cols is None else cols
        events = _events_of_tlog(out) if events is None else events
        return save_run(out / RECORDING, cols, geometry_for(spec, seed, forecasts), events, out.name,
                        grpc_url=grpc_url)
    except ViewUnavailable as exc:
        if not quiet:
            print(f"no {RECORDING}: {exc}", file=sys.stderr)
        return None


def spec_of_folder(folder: Path) -> tuple[RunSpec, int | None] | None:
    """The spec and seed a run folder's run.json records, or None (no run.json, or not a mission's)."""
    try:
        doc = json.loads((folder / "run.json").read_text())
        spec = doc.get("spec") or {}
        return RunSpec(**{k: v for k, v in spec.items() if k in RunSpec.__dataclass_fields__}), doc.get("seed")
    except (OSError, ValueError, TypeError):
        return None


def rrd_for(path: Path, out: Path) -> Path:
    """A recording of ``path`` (a run folder, a ``.rrd`` or a ``.tlog``) at ``out``, or the ``.rrd``
    itself when nothing needs converting and ``out`` is that file. ValueError with the reason."""
    if path.is_dir():
        rrd = path / RECORDING
        if rrd.is_file():
            return _copy(rrd, out)
        if (path / "timeseries.csv").is_file():
            found = spec_of_folder(path)
            if found is None:
                raise ValueError(f"{path}: a time series but no run.json to say which sea and vehicle it flew")
            spec, seed = found
            return save_run(out, read_timeseries(path / "timeseries.csv"), geometry_for(spec, seed),
                            _events_of_tlog(path), path.name)
        if (path / "mission.tlog").is_file():
            return tlog_to_rrd(path / "mission.tlog", out)
        raise ValueError(f"{path}: not a run folder (no {RECORDING}, timeseries.csv or mission.tlog)")
    if path.suffix == ".rrd":
        if not path.is_file():
            raise ValueError(f"{path}: no such file")
        return _copy(path, out)
    if path.suffix == ".tlog" or path.is_file():
        return tlog_to_rrd(path, out)
    raise ValueError(f"{path}: no such file or folder")


def _copy(src: Path, out: Path) -> Path:
    if src.resolve() != out.resolve():
        import shutil
        shutil.copyfile(src, out)
    return out


def tlog_to_rrd(tlog: Path, out: Path, vehicle: str = "bluerov2_heavy") -> Path:
    """A tlog's telemetry (:func:`~sitl.harness.tlog_view.tlog_columns`) as a recording, its thrusters
    those of the vehicle config ``vehicle``; no sea (a tlog does not carry it)."""
    from .tlog import read_tlog
    from .tlog_view import tlog_columns, tlog_events
    data = read_tlog(tlog)
    geometry = SceneGeometry.from_configs(vehicle, None, 0.0)
    return save_run(out, tlog_columns(data), geometry, tlog_events(data), Path(tlog).stem, lag=False)
