"""One station-keeping mission in-process: the firmware flying the simulated vehicle in lockstep.

This is the composition root of an in-process SITL run. It builds the world
(sea, plant) and the firmware as a whole (:class:`firmware_py.firmware.Firmware`
behind its in-process HAL), feeds the forecast hand-off as the shore service
would, steps the firmware's scheduler on simulated time and records truth,
estimate and commands every tick. It reaches the firmware only through the
firmware's public entry points, never its estimator or controllers directly.
"""
from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bridge.forecast import Forecast, derive_seeds, oracle_forecast
from bridge.schemas import load_mission_config, load_vehicle_config
from firmware_py.firmware import TICK_COLUMNS, Firmware, tick_row
from firmware_py.hal import InProcessSITLHAL
from firmware_py.modes import Mode
from firmware_py.params import ParameterTable, load_params
from bridge.models.thrusters import T200Curve, ThrusterLayout
from bridge.models.vehicle import VehicleParams
from firmware_py.scheduler import Clock

from .metrics import station_keeping_metrics
from sitl.plant import Plant
from .progress import ProgressBar
from sitl.sea import Sea

__all__ = ["CONTROLLERS", "MissionSetup", "build_mission", "RunResult", "run_mission", "write_run", "TIMESERIES_COLUMNS", "run_label",
           "mission_results"]

CONTROLLERS = ("cpd", "cpd_ff")

TIMESERIES_COLUMNS = tuple(
    ["t", "x", "z", "theta", "u", "w", "q"]          # truth at the tick
    + TICK_COLUMNS                                     # what the firmware's tick saw and did
    + ["tauE_X", "tauE_Z", "tauE_M"]                   # true wave load at the end of the tick's period
    + ["wave_eta", "forecast_eta"]                     # elevations at the vehicle's x
)
"""Columns of ``timeseries.csv``: one row per control tick."""


def run_label(controller: str, snr_db: float | None) -> str:
    if controller == "cpd":
        return "C-PD"
    return "C-PD+FF exact" if snr_db is None else f"C-PD+FF {snr_db:g} dB"


@dataclass
class RunResult:
    results: dict
    timeseries: np.ndarray      # (ticks, len(TIMESERIES_COLUMNS))


def elevation_along(components, x: np.ndarray, t: np.ndarray, chunk: int = 2048) -> np.ndarray:
    from bridge.models.waves import elevation
    return np.concatenate([elevation(components, x[i:i + chunk], t[i:i + chunk]) for i in range(0, x.size, chunk)])


@dataclass
class MissionSetup:
    """The world and the firmware, wired together and not yet flying."""

    sea: Sea
    plant: Plant
    hal: InProcessSITLHAL
    firmware: Firmware
    forecast: Forecast | None
    setpoint: np.ndarray
    rate_hz: float
    duration_s: float
    seed: int
    feeder: "DSWPFeeder | None" = None


class DSWPFeeder:
    """The forecast service's DSWP mode, in process: every ``period_s`` of simulated time, predict
    the waves at the vehicle from the buoy's last ``window_s`` of record and hand the forecast to
    the firmware — what ``wavekeep forecast --mode dswp`` does over zenoh, without the network's
    timing, so the result is deterministic. (The buoy has been recording before t = 0.)"""

    def __init__(self, sea: Sea, fw: Firmware, x_vehicle: float, period_s: float = 0.5, window_s: float = 120.0):
        from bridge.dswp import predict_from_buoy
        self._predict = predict_from_buoy
        self.sea, self.fw, self.x = sea, fw, float(x_vehicle)
        self.buoy = sea.buoy()
        self.period, self.window = float(period_s), float(window_s)
        self._next = 0.0
        self.seq = 0

    def advance(self, t: float) -> None:
        if t + 1e-9 < self._next:
            return
        self._next = t + self.period
        t_last = np.floor(t * self.buoy.sample_rate + 1e-9) / self.buoy.sample_rate   # newest sample
        tb, eta = self.buoy.record(t_last - self.window, t_last)
        self.seq += 1
        self.fw.forecast.offer(self._predict(tb, eta, self.buoy.x, self.x, self.sea.water_depth,
                                             window_s=self.window, oversample=2, seq=self.seq))


def build_mission(case: str = "W3", controller: str = "cpd_ff", snr_db: float | None = None, seed: int | None = None,
                  duration: float | None = None, mission: str = "station_keeping", vehicle: str = "bluerov2_heavy",
                  params: ParameterTable | None = None, initial_eta=None, clock: Clock | None = None,
                  forecast_mode: str = "oracle") -> MissionSetup:
    """Build sea, plant, in-process HAL and firmware for one mission (see :func:`run_mission`).

    ``clock`` paces the firmware (default: lockstep simulated time).
    """
    if controller not in CONTROLLERS:
        raise ValueError(f"controller must be one of {CONTROLLERS}, got {controller!r}")
    sea = Sea.load(case, seed=seed)
    mcfg = load_mission_config(mission)
    vcfg = load_vehicle_config(vehicle)
    params = (params or load_params()).copy()
    params.set("WK_FF_ENABLE", 1 if controller == "cpd_ff" else 0)
    rate = mcfg["control_rate"]
    sp = mcfg["setpoint"]
    setpoint = np.array([sp["x"], sp["depth"], sp["pitch"]])
    plant = Plant.from_configs(sea, vehicle, mission)
    if initial_eta is not None:
        plant.reset(eta=initial_eta)
    sensor_seed, forecast_seed = derive_seeds(sea.seed)
    hal = InProcessSITLHAL(plant, params, 1.0 / rate, sensor_seed, clock)
    fw = Firmware(hal, params, VehicleParams.from_config(vcfg), ThrusterLayout.from_config(vcfg["thrusters"]),
                  T200Curve.from_config(vcfg["thrusters"]), setpoint, rate, mcfg["plant"]["strips"])
    forecast = None
    feeder = None
    if controller == "cpd_ff" and forecast_mode == "oracle":
        forecast = oracle_forecast(sea.components, snr_db, np.random.default_rng(forecast_seed))
        fw.forecast.offer(forecast)
    elif controller == "cpd_ff":
        feeder = DSWPFeeder(sea, fw, setpoint[0])
        feeder.advance(0.0)
    elif forecast_mode not in ("oracle", "dswp"):
        raise ValueError(f"forecast_mode must be 'oracle' or 'dswp', got {forecast_mode!r}")
    return MissionSetup(sea, plant, hal, fw, forecast, setpoint, rate,
                        mcfg["duration"] if duration is None else float(duration), sea.seed, feeder)


def run_mission(case: str = "W3", controller: str = "cpd_ff", snr_db: float | None = None, seed: int | None = None,
                duration: float | None = None, mission: str = "station_keeping", vehicle: str = "bluerov2_heavy",
                params: ParameterTable | None = None, progress: bool = False,
                initial_eta=None, forecast_mode: str = "oracle") -> RunResult:
    """Fly one mission and return its results and per-tick time series.

    ``controller`` is ``cpd`` or ``cpd_ff``; ``snr_db`` injects the paper's
    forecast error (None: the exact forecast). ``seed`` sets the sea
    realisation (default: the sea config's) and, through it, the sensor noise
    and forecast error streams. ``initial_eta`` starts the vehicle at another pose
    [x, z, θ] than the setpoint (a setpoint step).
    """
    m = build_mission(case, controller, snr_db, seed, duration, mission, vehicle, params, initial_eta,
                      forecast_mode=forecast_mode)
    sea, plant, hal, fw, forecast, setpoint, rate = m.sea, m.plant, m.hal, m.firmware, m.forecast, m.setpoint, m.rate_hz
    seed, duration = m.seed, m.duration_s
    n = int(round(duration * rate))
    # Take off as a ground station would: the first tick initialises the estimator; then
    # GUIDED to the mission's station, and arm.
    fw.scheduler.run_tick()
    hal.step_world()
    fw.request_mode(Mode.GUIDED)
    fw.set_target(*setpoint)
    result, why = fw.request_arm(True)
    if result != 0:
        raise RuntimeError(f"the firmware refused to arm: {why}")
    fw.refresh_prediction()   # as the networked firmware does when its hold ends
    n -= 1
    log = np.zeros((n, len(TIMESERIES_COLUMNS)))
    wall0 = time.perf_counter()
    with ProgressBar(n, f"{sea.name} {run_label(controller, snr_db)}", enabled=None if progress else False) as bar:
        for k in range(n):
            truth = plant.state
            if m.feeder is not None:
                m.feeder.advance(truth.t)
            fw.scheduler.run_tick()
            hal.step_world()
            r = fw.last
            if r is None:
                raise RuntimeError(f"the control task produced no output at t = {truth.t:.2f} s: "
                                   f"{fw.scheduler.stats()['tasks']['control']}")
            log[k] = [truth.t, *truth.eta, *truth.nu, *tick_row(r), *plant.tau_E, np.nan, np.nan]
            bar.update(k + 1)
    wall = time.perf_counter() - wall0
    # Elevations at the vehicle's x, for the record (after the run: one vectorised pass)
    col = {c: i for i, c in enumerate(TIMESERIES_COLUMNS)}
    log[:, col["wave_eta"]] = elevation_along(sea.components, log[:, 1], log[:, 0])
    if forecast is not None:
        log[:, col["forecast_eta"]] = elevation_along(forecast.components(), log[:, 1], log[:, 0])
    stats = fw.scheduler.stats()
    errors = stats["tasks"]["control"].get("errors", 0)
    if errors:
        raise RuntimeError(f"control task raised {errors} time(s): {stats['tasks']['control'].get('last_error')}")

    ekf = fw.ekf
    results = {
        **mission_results(sea, controller, snr_db, duration, rate, setpoint, log, stats["overruns"]),
        "label": "C-PD+FF DSWP" if m.feeder is not None else run_label(controller, snr_db),
        "forecast": None if controller != "cpd_ff" else forecast_mode,
        "hs_target_m": sea.hs_target,
        "hs_realised_m": float(4.0 * np.std(elevation_along(sea.components, np.full(n, setpoint[0]), log[:, 0]))),
        "ekf": {"rejected": dict(ekf.rejected), "accepted": dict(ekf.accepted),
                "rms_error": dict(zip(("x", "z", "theta", "u", "w", "q"),
                                      np.sqrt(np.mean((log[:, col["x_hat"]:col["q_hat"] + 1] - log[:, 1:7]) ** 2,
                                                      axis=0)).tolist()))},
        "ff_active_fraction": float(np.mean(log[:, col["ff_active"]])),
        "control_tick": stats["tasks"]["control"]["compute"],
        "wall_time_s": wall,
        "speed_x_realtime": duration / wall if wall > 0 else None,
    }
    return RunResult(results, log)


def mission_results(sea: Sea, controller: str, snr_db: float | None, duration: float, rate: float,
                    setpoint: np.ndarray, log: np.ndarray, tick_overruns: int) -> dict:
    """The ``results.json`` fields every mission reports, from its time series (in-process or launched)."""
    col = {c: i for i, c in enumerate(TIMESERIES_COLUMNS)}
    metrics = station_keeping_metrics(log[:, 0], log[:, 1:4], setpoint, log[:, col["tau_X"]:col["tau_M"] + 1])
    return {
        "case": sea.name,
        "controller": controller,
        "forecast_snr_db": snr_db if controller == "cpd_ff" else None,
        "seed": sea.seed,
        "duration_s": duration,
        "rate_hz": rate,
        **metrics,
        "tick_overruns": tick_overruns,
        "label": run_label(controller, snr_db),
    }


def write_run(result: RunResult, out: str | Path, plots: bool = True) -> Path:
    """DIR/results.json, DIR/timeseries.csv and (optionally) DIR/time_history.png."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "results.json").write_text(json.dumps(result.results, indent=2))
    np.savetxt(out / "timeseries.csv", result.timeseries, delimiter=",", header=",".join(TIMESERIES_COLUMNS),
               comments="", fmt="%.6g")
    if plots:
        from .plots import plot_run
        plot_run(result, out / "time_history.png")
    return out
