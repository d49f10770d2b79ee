"""Read a MAVLink telemetry log (``.tlog``): Wavekeep's own, or one QGroundControl or MAVProxy recorded
from a real ArduSub.

One reader serves ``wavekeep tlog`` (figures and a CSV) and ``wavekeep view x.tlog`` (the 3-D view).
pymavlink's log reader does the parsing; this module keeps what a station-keeping engineer reads —
attitude, local and global position, the HUD, the eight servo outputs, the RC inputs, named floats,
status texts and the vehicle's mode and arming — as columns on the vehicle's clock.

Time: each message is put on the vehicle's clock (s since boot) by its own ``time_boot_ms`` (or
``time_usec``) where it has one; a message without one (HEARTBEAT, VFR_HUD, STATUSTEXT) takes the
log's stamp shifted by the offset between the two clocks seen last. Only the vehicle's messages are
kept: the system that sent the first non-GCS HEARTBEAT (a ground station's own messages, sysid 255 in
Wavekeep's logs, are in the file too).
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["FIELDS", "TlogCollector", "TlogData", "TlogEvent", "read_tlog"]

FIELDS: dict[str, tuple[str, ...]] = {
    "ATTITUDE": ("roll", "pitch", "yaw", "rollspeed", "pitchspeed", "yawspeed"),          # rad, rad/s
    "LOCAL_POSITION_NED": ("x", "y", "z", "vx", "vy", "vz"),                               # m, m/s, NED
    "GLOBAL_POSITION_INT": ("lat", "lon", "alt", "relative_alt", "vx", "vy", "vz", "hdg"),  # degE7, mm, cm/s
    "VFR_HUD": ("airspeed", "groundspeed", "heading", "throttle", "alt", "climb"),         # m/s, deg, %, m
    "SERVO_OUTPUT_RAW": tuple(f"servo{i}_raw" for i in range(1, 9)),                       # µs
    "RC_CHANNELS": tuple(f"chan{i}_raw" for i in range(1, 9)),                             # µs
}
"""The fields kept per message type (units as MAVLink defines them)."""

_CLOCKED = ("time_boot_ms", "time_usec")
_GCS_TYPE = 6            # MAV_TYPE_GCS
_ARMED = 128             # MAV_MODE_FLAG_SAFETY_ARMED


@dataclass
class TlogEvent:
    t: float             # vehicle time (s)
    kind: str            # "mode", "armed", "disarmed" or "text"
    text: str
    severity: int = 6    # MAV_SEVERITY (INFO for mode and arming changes)


@dataclass
class TlogData:
    """What :func:`read_tlog` keeps: per message type its columns (``t`` first, s on the vehicle's clock),
    the named floats by name (``t``, ``value``), and the events in time order."""

    path: Path
    sysid: int | None
    tables: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)
    named: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)
    events: list[TlogEvent] = field(default_factory=list)
    messages: int = 0    # vehicle messages read

    def span(self) -> tuple[float, float]:
        """First and last vehicle time (s) of any kept message; (0, 0) for an empty log."""
        ts = [c["t"] for c in (*self.tables.values(), *self.named.values()) if c["t"].size]
        ts += [np.array([e.t for e in self.events])] if self.events else []
        if not ts:
            return 0.0, 0.0
        return float(min(a.min() for a in ts)), float(max(a.max() for a in ts))


class _Clock:
    """The vehicle's clock for every message: its own stamp where it has one, else the log's, shifted."""

    def __init__(self) -> None:
        self.offset: float | None = None    # vehicle time − log stamp (s), from the last clocked message
        self.t0: float | None = None        # first log stamp, while no clocked message has been seen

    def __call__(self, m) -> float:
        stamp = float(getattr(m, "_timestamp", 0.0))
        if self.t0 is None:
            self.t0 = stamp
        ms = getattr(m, "time_boot_ms", None)
        t = ms / 1000.0 if isinstance(ms, int) else None
        us = getattr(m, "time_usec", None)
        if t is None and isinstance(us, int) and us < 10**12:   # µs since boot (not a Unix time)
            t = us / 1e6
        if t is not None:
            self.offset = t - stamp
            return t
        return stamp + self.offset if self.offset is not None else stamp - self.t0


class TlogCollector:
    """Messages in, :class:`TlogData` out: what :func:`read_tlog` does with a file, and what a live view
    does with the messages a ground station hears (:meth:`add` each one, :meth:`take` the batch)."""

    def __init__(self, path: Path | None = None):
        self.data = TlogData(Path(path or "-"), None)
        self.clock = _Clock()
        self.mode: tuple[str, bool] | None = None
        self._rows: dict[str, list[list[float]]] = {k: [] for k in FIELDS}
        self._named: dict[str, list[tuple[float, float]]] = {}

    def add(self, m) -> None:
        """Keep one pymavlink message if it is the vehicle's and of a kind kept."""
        from pymavlink import mavutil

        kind = m.get_type()
        data = self.data
        if kind == "BAD_DATA":
            return
        if data.sysid is None:
            if kind != "HEARTBEAT" or m.type == _GCS_TYPE:
                return
            data.sysid = m.get_srcSystem()
        if m.get_srcSystem() != data.sysid:
            return
        data.messages += 1
        t = self.clock(m)
        if kind in FIELDS:
            self._rows[kind].append([t, *(float(getattr(m, f, np.nan)) for f in FIELDS[kind])])
        elif kind == "NAMED_VALUE_FLOAT":
            self._named.setdefault(_text(m.name), []).append((t, float(m.value)))
        elif kind == "STATUSTEXT":
            data.events.append(TlogEvent(t, "text", _text(m.text), int(m.severity)))
        elif kind == "HEARTBEAT" and m.type != _GCS_TYPE:
            self.mode = _mode_events(data.events, t, self.mode, (mavutil.mode_string_v10(m),
                                                                 bool(m.base_mode & _ARMED)))

    def take(self) -> TlogData:
        """What was added since the last take, as columns (events in time order)."""
        data = self.data
        for kind, r in self._rows.items():
            a = np.array(r, dtype=float).reshape(-1, len(FIELDS[kind]) + 1)
            data.tables[kind] = {"t": a[:, 0], **{f: a[:, i + 1] for i, f in enumerate(FIELDS[kind])}}
            r.clear()
        for name, pairs in self._named.items():
            a = np.array(pairs, dtype=float).reshape(-1, 2)
            data.named[name] = {"t": a[:, 0], "value": a[:, 1]}
            pairs.clear()
        data.events.sort(key=lambda e: e.t)
        self.data = TlogData(data.path, data.sysid)
        return data


def read_tlog(path: str | Path) -> TlogData:
    """Read ``path`` (a ``.tlog``) with pymavlink; ValueError if it holds no vehicle message."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"{path}: no such file")
    os.environ.setdefault("MAVLINK20", "1")
    from pymavlink import mavutil

    try:
        log = mavutil.mavlink_connection(str(path), dialect="ardupilotmega", notimestamps=False)
    except Exception as exc:   # pymavlink raises what the file's first bytes give it
        raise ValueError(f"{path}: not a MAVLink log ({exc})") from None
    collector = TlogCollector(path)
    try:
        while (m := log.recv_msg()) is not None:
            collector.add(m)
    finally:
        log.close()
    if collector.data.sysid is None:
        raise ValueError(f"{path}: no vehicle HEARTBEAT in the log (is it a MAVLink .tlog?)")
    return collector.take()


def _mode_events(events: list[TlogEvent], t: float, was: tuple[str, bool] | None,
                 now: tuple[str, bool]) -> tuple[str, bool]:
    """Append the mode and arming changes between two heartbeats; the new state."""
    if was is None or now[0] != was[0]:
        events.append(TlogEvent(t, "mode", f"mode {now[0]}"))
    if (was is None and now[1]) or (was is not None and now[1] != was[1]):
        events.append(TlogEvent(t, "armed" if now[1] else "disarmed", "armed" if now[1] else "disarmed"))
    return now


def _text(value) -> str:
    """A MAVLink char array as text (pymavlink gives str or bytes, NUL-padded)."""
    if isinstance(value, bytes):
        value = value.decode("utf-8", "replace")
    return str(value).rstrip("\x00").strip()
