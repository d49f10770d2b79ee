"""A tlog's telemetry as the columns of a run: what ``wavekeep view x.tlog`` draws and ``wavekeep tlog`` writes.

:func:`tlog_columns` puts every kept message (:mod:`~sitl.harness.tlog`) on one clock, the
ATTITUDE messages' (10 Hz from ArduSub and Wavekeep), each other message held at its latest value,
and names what a run's time series also has by the run's names, so one writer
(:func:`~sitl.harness.recording.write_columns`) draws both:

========================  ======================================================
run column                from the tlog
========================  ======================================================
``x_hat``, ``z_hat``       LOCAL_POSITION_NED x, z (m, NED); without it GLOBAL_POSITION_INT:
                           metres north of the first fix and depth −relative_alt
``theta_hat``              ATTITUDE pitch (rad)
``u_hat``, ``w_hat``       LOCAL_POSITION_NED vx, vz (m/s; earth frame)
``q_hat``                  ATTITUDE pitchspeed (rad/s)
``pwm1`` … ``pwm8``        SERVO_OUTPUT_RAW servo1 … servo8 (µs)
``tauE_hat_X/Z/M``         NAMED_VALUE_FLOAT FF_X, FF_Z, FF_M (Wavekeep's predicted wave load)
``ff_active``              NAMED_VALUE_FLOAT FF_ON
========================  ======================================================

and under ``plots/tlog/``: attitude (deg), position (m), HUD (heading deg, speeds m/s, depth m,
throttle %), servo and RC channels (µs) and every named float by its name. The vehicle's mode,
arming and status texts are the events.
"""
from __future__ import annotations

import csv
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .recording import Event
from .tlog import FIELDS, TlogData

__all__ = ["tlog_columns", "tlog_events", "write_tlog_csv"]

_EARTH_RADIUS_M = 6378137.0


def _held(t_src: np.ndarray, values: np.ndarray, t: np.ndarray) -> np.ndarray:
    """``values`` sampled at t_src, held at their latest value on the clock t (NaN before the first)."""
    i = np.searchsorted(t_src, t, side="right") - 1
    out = np.where(i >= 0, values[np.clip(i, 0, None)], np.nan) if t_src.size else np.full(t.size, np.nan)
    return out.astype(float)


def _clock(data: TlogData) -> np.ndarray:
    att = data.tables.get("ATTITUDE", {}).get("t", np.empty(0))
    if att.size:
        return att
    ts = [c["t"] for c in data.tables.values() if c["t"].size]
    return np.unique(np.concatenate(ts)) if ts else np.empty(0)


def tlog_columns(data: TlogData) -> dict[str, np.ndarray]:
    """The tlog's telemetry as named columns on one clock (``t``, s on the vehicle's clock)."""
    t = _clock(data)
    cols: dict[str, np.ndarray] = {"t": t}
    if t.size == 0:
        return cols

    def held(kind: str, name: str) -> np.ndarray | None:
        table = data.tables.get(kind)
        if table is None or table["t"].size == 0:
            return None
        order = np.argsort(table["t"], kind="stable")
        return _held(table["t"][order], table[name][order], t)

    att: dict[str, Any] = {f: held("ATTITUDE", f) for f in FIELDS["ATTITUDE"]}
    if att["pitch"] is not None:
        cols["theta_hat"], cols["q_hat"] = att["pitch"], att["pitchspeed"]
        for f in ("roll", "pitch", "yaw"):
            cols[f"plots/tlog/attitude/{f}"] = np.degrees(att[f])
    local: dict[str, Any] = {f: held("LOCAL_POSITION_NED", f) for f in FIELDS["LOCAL_POSITION_NED"]}
    if local["x"] is not None:
        cols["x_hat"], cols["z_hat"], cols["u_hat"], cols["w_hat"] = local["x"], local["z"], local["vx"], local["vz"]
        for f in ("x", "y", "z"):
            cols[f"plots/tlog/position/{f}"] = local[f]
    else:
        _global_position(cols, held)
    for f in ("heading", "groundspeed", "climb", "throttle", "alt"):
        v = held("VFR_HUD", f)
        if v is not None:
            cols[f"plots/tlog/hud/{'depth' if f == 'alt' else f}"] = -v if f == "alt" else v
    for i in range(1, 9):
        pwm, rc = held("SERVO_OUTPUT_RAW", f"servo{i}_raw"), held("RC_CHANNELS", f"chan{i}_raw")
        if pwm is not None:
            cols[f"pwm{i}"] = cols[f"plots/tlog/servo/servo{i}"] = pwm
        if rc is not None:
            cols[f"plots/tlog/rc/chan{i}"] = rc
    for name, table in data.named.items():
        order = np.argsort(table["t"], kind="stable")
        v = _held(table["t"][order], table["value"][order], t)
        cols[f"plots/tlog/named/{name}"] = v
        run_name = {"FF_X": "tauE_hat_X", "FF_Z": "tauE_hat_Z", "FF_M": "tauE_hat_M", "FF_ON": "ff_active"}.get(name)
        if run_name:
            cols[run_name] = v
    return cols


def _global_position(cols: dict[str, np.ndarray], held) -> None:
    """x_hat (m north of the first fix) and z_hat (depth, m) from GLOBAL_POSITION_INT, where there is
    no LOCAL_POSITION_NED (a vehicle without a local origin)."""
    lat, lon, rel = held("GLOBAL_POSITION_INT", "lat"), held("GLOBAL_POSITION_INT", "lon"), held(
        "GLOBAL_POSITION_INT", "relative_alt")
    if lat is None:
        return
    first = np.flatnonzero(np.isfinite(lat))
    if first.size == 0:
        return
    lat0, lon0 = lat[first[0]] * 1e-7, lon[first[0]] * 1e-7
    north = np.radians(lat * 1e-7 - lat0) * _EARTH_RADIUS_M
    east = np.radians(lon * 1e-7 - lon0) * _EARTH_RADIUS_M * np.cos(np.radians(lat0))
    cols["x_hat"], cols["z_hat"] = north, -rel / 1000.0
    cols["plots/tlog/position/x"], cols["plots/tlog/position/y"], cols["plots/tlog/position/z"] = north, east, \
        -rel / 1000.0


def tlog_events(data: TlogData) -> list[Event]:
    """The vehicle's mode and arming changes and its status texts, as a run's events."""
    return [Event(e.t, e.severity, e.text) for e in data.events]


def write_tlog_csv(cols: dict[str, np.ndarray], data: TlogData, path: str | Path) -> Path:
    """One row per clock tick: t (s), the vehicle's mode and arming, then every telemetry column
    (``attitude.pitch`` in deg, ``servo.servo1`` in µs, ``named.FF_X`` ...; units as in the module doc)."""
    path = Path(path)
    t = cols["t"]
    names = [k for k in cols if k.startswith("plots/tlog/")]
    modes = [(e.t, e.text[len("mode "):]) for e in data.events if e.kind == "mode"]
    arming = [(e.t, e.kind == "armed") for e in data.events if e.kind in ("armed", "disarmed")]
    mode_at = _labels(modes, t, "")
    armed_at = _labels(arming, t, False)
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["t", "mode", "armed", *(n[len("plots/tlog/"):].replace("/", ".") for n in names)])
        for i in range(t.size):
            w.writerow([f"{t[i]:.3f}", mode_at[i], int(bool(armed_at[i])), *(_fmt(cols[n][i]) for n in names)])
    return path


def _labels(changes: Sequence[tuple[float, object]], t: np.ndarray, before) -> list:
    """The value in force at each time of t, from a list of (time, new value)."""
    times = np.array([c[0] for c in changes])
    i = np.searchsorted(times, t, side="right") - 1
    return [changes[j][1] if j >= 0 else before for j in i]


def _fmt(v: float) -> str:
    return "" if not np.isfinite(v) else f"{v:.6g}"
