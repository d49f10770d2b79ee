"""One station-keeping mission in-process: the firmware flying the simulated vehicle in lockstep.

This is the composition root of an in-process SITL run. It builds the world
(sea, plant) and the firmware as a whole (:class:`firmware_py.firmware.Firmware`
behind its in-process HAL), feeds the forecast hand-off as the shore service
would, steps the firmware's scheduler on simulated time and records truth,
estimate and commands every tick. It reaches the firmware only through the
firmware's public entry points, never its estimator or controllers directly.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from bridge.dswp import predict_from_buoy
from bridge.forecast import Forecast, derive_seeds, oracle_forecast
from bridge.schemas import load_mission_config, load_vehicle_config
from firmware_py.firmware import Firmware, tick_row
from firmware_py.hal.base import InProcessSITLHAL
from firmware_py.hal.clocks import Clock
from firmware_py.modes import Mode
from firmware_py.params.table import ParameterTable, load_params
from sitl.buoy import BuoyTape
from sitl.plant import Plant, PlantDiverged
from sitl.sea import Sea

from .progress import ProgressBar
from .results import COLUMN, TIMESERIES_COLUMNS, RunResult, elevation_along, mission_results
from .run_files import write_run
from .spec import RunSpec

__all__ = ["DSWPFeeder", "MissionDiverged", "MissionSetup", "build_mission", "run_mission", "write_run"]


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
    feeder: DSWPFeeder | None = None


class DSWPFeeder:
    """The forecast service's DSWP mode, in process: every ``period_s`` of simulated time, predict
    the waves at the vehicle from the buoy's last ``window_s`` of record and hand the forecast to
    the firmware — what ``wavekeep forecast --mode dswp`` does over zenoh, without the network's
    timing, so the result is deterministic. (The buoy has been recording before t = 0.)

    The other keywords are :func:`~bridge.dswp.predict_from_buoy`'s (``RunSpec.dswp``, defaults in
    :data:`~sitl.harness.spec.DSWP_SCHEMA`). Lost buoy samples are fitted around; a window that
    cannot be predicted from (too many lost) hands nothing over and is counted in ``failed``."""

    def __init__(self, sea: Sea, fw: Firmware, x_vehicle: float, period_s: float = 0.5, window_s: float = 120.0,
                 f_min: float = 0.05, f_max: float = 0.5, rel_threshold: float = 0.05, deep_water: bool = False,
                 oversample: int = 2, horizon_s: float | None = None):
        self.sea, self.fw, self.x = sea, fw, float(x_vehicle)
        self.buoy = sea.buoy()
        self.tape = BuoyTape(self.buoy)       # each buoy sample measured once, not once per window
        self.period, self.window = float(period_s), float(window_s)
        self.fit: dict[str, Any] = {"f_min": f_min, "f_max": f_max, "rel_threshold": rel_threshold,
                                    "deep_water": deep_water, "oversample": int(oversample), "horizon_s": horizon_s}
        self._next = 0.0
        self.seq = 0
        self.failed = 0
        self.history: list[tuple[float, Any]] = []   # (t, the forecast's components) as handed over: the view's

    def advance(self, t: float) -> None:
        if t + 1e-9 < self._next:
            return
        self._next = t + self.period
        t_last = self.buoy.newest_stamp(t)    # the newest sample measured by now, on the buoy's clock
        tb, eta = self.tape.record(t_last - self.window, t_last)
        self.seq += 1
        try:
            f = predict_from_buoy(tb, eta, self.buoy.x, self.x, self.sea.water_depth, window_s=self.window,
                                  seq=self.seq, allow_gaps=True, **self.fit)
        except ValueError:
            self.failed += 1
            return
        self.fw.forecast.offer(f)
        self.history.append((t, f.components()))


def build_mission(spec: RunSpec, params: ParameterTable | None = None, initial_eta=None,
                  clock: Clock | None = None, sea: Sea | None = None) -> MissionSetup:
    """Build sea, plant, in-process HAL and firmware for one mission (see :func:`run_mission`).

    ``params`` is the parameter table to start from (default: ``configs/firmware/params.yaml``);
    the spec's overrides go on top. ``clock`` paces the firmware (default: lockstep simulated time).
    ``sea`` flies a sea built by the caller (a regular wave, still water) instead of the spec's case.
    """
    sea = Sea.load(spec.case, seed=spec.seed, overrides=spec.sea) if sea is None else sea
    mcfg = load_mission_config(spec.mission)
    vcfg = load_vehicle_config(spec.vehicle)
    params = (params or load_params()).copy()
    for name, value in spec.overrides.items():
        why = params.set(name, value)
        if why:
            raise ValueError(f"parameter override {name}={value!r}: {why}")
    for name, value in spec.implied_params().items():
        params.set(name, value)
    params.set("SIM_WATER_DEPTH", sea.water_depth)    # the site's depth reaches the DVL model as a SIM_ parameter
    rate = mcfg["control_rate"]
    sp = mcfg["setpoint"]
    setpoint = np.array([sp["x"], sp["depth"], sp["pitch"]])
    plant = Plant.from_configs(sea, spec.vehicle, spec.mission, spec.true_vehicle)
    if initial_eta is not None:
        plant.reset(eta=initial_eta)
    sensor_seed, forecast_seed = derive_seeds(sea.seed)
    hal = InProcessSITLHAL(plant, params, 1.0 / rate, sensor_seed, clock)
    fw = Firmware.from_configs(hal, params, vcfg, mcfg)
    forecast = None
    feeder = None
    if spec.forecast_source == "oracle":
        forecast = oracle_forecast(sea.components, spec.snr_db, np.random.default_rng(forecast_seed))
        fw.forecast.offer(forecast)
    elif spec.forecast_source == "dswp":
        feeder = DSWPFeeder(sea, fw, setpoint[0], **spec.dswp_options())
        feeder.advance(0.0)
    return MissionSetup(sea, plant, hal, fw, forecast, setpoint, rate,
                        mcfg["duration"] if spec.duration is None else float(spec.duration), sea.seed, feeder)


def take_off(m: MissionSetup) -> None:
    """Take off as a ground station would: the first tick initialises the estimator; then GUIDED to
    the mission's station, and arm (RuntimeError if the firmware refuses either)."""
    fw = m.firmware
    fw.scheduler.run_tick()
    m.hal.step_world()
    if fw.request_mode(Mode.GUIDED) != 0:     # refused: the mission would fly MANUAL, which is no mission
        said = fw.events[-1][1] if fw.events else ""
        raise RuntimeError(f"the firmware refused GUIDED ({'EKF not converged' if not fw.ekf.converged() else said})"
                           f": {said}")
    fw.set_target(*m.setpoint)
    result, why = fw.request_arm(True)
    if result != 0:
        raise RuntimeError(f"the firmware refused to arm: {why}")
    fw.refresh_prediction()   # as the networked firmware does when its hold ends


def run_mission(spec: RunSpec, params: ParameterTable | None = None, progress: bool = False,
                initial_eta=None, sea: Sea | None = None) -> RunResult:
    """Fly one mission and return its results and per-tick time series.

    The spec's ``seed`` sets the sea realisation (default: the sea config's)
    and, through it, the sensor noise and forecast error streams.
    ``initial_eta`` starts the vehicle at another pose [x, z, θ] than the
    setpoint (a setpoint step); ``sea`` as in :func:`build_mission`.
    """
    m = build_mission(spec, params, initial_eta, sea=sea)
    sea, plant, hal, fw, forecast, setpoint, rate = m.sea, m.plant, m.hal, m.firmware, m.forecast, m.setpoint, m.rate_hz
    duration = m.duration_s
    n = int(round(duration * rate))
    take_off(m)
    n -= 1
    log = np.zeros((n, len(TIMESERIES_COLUMNS)))
    events: list[tuple[float, int, str]] = []   # the firmware's STATUSTEXTs (mode, arming, failsafes), for the view
    wall0 = time.perf_counter()
    diverged: PlantDiverged | None = None
    with ProgressBar(n, f"{sea.name} {spec.label}", enabled=None if progress else False) as bar:
        for k in range(n):
            truth = plant.state
            if m.feeder is not None:
                m.feeder.advance(truth.t)
            fw.scheduler.run_tick()
            try:
                hal.step_world()
            except PlantDiverged as exc:
                diverged, log, duration = exc, log[:k], k / rate
                break
            r = fw.last
            if r is None:
                raise RuntimeError(f"the control task produced no output at t = {truth.t:.2f} s: "
                                   f"{fw.scheduler.stats()['tasks']['control']}")
            e6 = truth.eta6
            log[k] = [truth.t, *truth.eta, *truth.nu, *tick_row(r), *plant.tau_E, np.nan, np.nan, e6[1], e6[3], e6[5]]
            for queue in (fw.notes, fw.events):       # log-only notes (mode changes...), then STATUSTEXTs
                if queue:
                    events.extend((truth.t, severity, text) for severity, text in queue)
                    queue.clear()
            bar.update(k + 1)
    wall = time.perf_counter() - wall0
    if diverged is not None and len(log) < 2:
        raise MissionDiverged(str(diverged), None)
    # Elevations at the vehicle's x, for the record (after the run: one vectorised pass)
    y = log[:, COLUMN["y"]]
    log[:, COLUMN["wave_eta"]] = elevation_along(sea.components, log[:, 1], log[:, 0], y=y)
    if forecast is not None:
        log[:, COLUMN["forecast_eta"]] = elevation_along(forecast.components(), log[:, 1], log[:, 0], y=y)
    stats = {**fw.scheduler.stats(), "faults": fw.fault_counts()}
    errors = stats["tasks"]["control"].get("errors", 0)
    if errors:
        raise RuntimeError(f"control task raised {errors} time(s): {stats['tasks']['control'].get('last_error')}")

    results = mission_results(sea, spec, duration, rate, setpoint, log, stats)
    results["ekf"].update(rejected=dict(fw.ekf.rejected), accepted=dict(fw.ekf.accepted))
    results.update(wall_time_s=wall, speed_x_realtime=duration / wall if wall > 0 else None)
    result = RunResult(results, log, events, m.feeder.history if m.feeder is not None else None)
    if diverged is not None:
        results.update(status="diverged", error=str(diverged))
        raise MissionDiverged(str(diverged), result)
    return result


class MissionDiverged(RuntimeError):
    """The world left the physical range mid-mission (:class:`~sitl.plant.PlantDiverged`); ``result`` holds the
    time series up to the last physical state (None if it diverged at once), for diagnosis."""

    def __init__(self, message: str, result: RunResult | None):
        super().__init__(message)
        self.result = result

