"""The live view: Rerun's web viewer served on loopback, fed while a mission flies.

:class:`ViewServer` runs Rerun's own server (the ``rerun`` program that ``rerun-sdk`` installs) as
a child process: the web viewer over HTTP and a gRPC proxy, both bound to 127.0.0.1 (the SDK's
in-process servers listen on every interface), and optionally a ``.rrd`` it serves. A recording
stream in the mission's process connects to it as a client.

Off the 20 Hz tick's critical path: the tick hands its row (or the ground station its MAVLink frame)
to :class:`LiveRecorder`, which only appends it to a list; a background thread takes the list every
``period_s`` and sends it as one batch with the same writer as a finished run's recording
(:func:`~sitl.harness.recording.write_columns`), so the serialisation and the sockets cost the tick
nothing but an append.
"""
from __future__ import annotations

import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from urllib.parse import quote

import numpy as np

from .ports import port_or_free
from .recording import Event, columns_of, write_columns, write_events
from .view_layout import SceneGeometry, blueprint, log_static, rerun_module

__all__ = ["LiveRecorder", "MavlinkFeed", "ViewServer"]

WEB_PORT, GRPC_PORT = 9090, 9876     # Rerun's defaults


class ViewServer:
    """``with ViewServer() as v: print(v.url)`` — Rerun's web viewer and gRPC proxy on loopback."""

    def __init__(self, rrd: Path | None = None, web_port: int | None = None, grpc_port: int | None = None,
                 log: Path | None = None):
        rerun_module("the view")
        self.web_port = web_port or port_or_free(WEB_PORT, socket.SOCK_STREAM)
        self.grpc_port = grpc_port or port_or_free(GRPC_PORT, socket.SOCK_STREAM)
        if self.grpc_port == self.web_port:
            self.grpc_port = port_or_free(self.web_port + 1, socket.SOCK_STREAM)
        self.rrd = rrd
        self.log_path = log
        self.proc: subprocess.Popen | None = None

    @property
    def grpc_url(self) -> str:
        return f"rerun+http://127.0.0.1:{self.grpc_port}/proxy"

    @property
    def url(self) -> str:
        """The address to open in a browser."""
        return f"http://127.0.0.1:{self.web_port}/?url={quote(self.grpc_url, safe='')}"

    def start(self, timeout_s: float = 30.0) -> ViewServer:
        argv = [sys.executable, "-m", "rerun_cli", "--serve-web", "--bind", "127.0.0.1", "--port",
                str(self.grpc_port), "--web-viewer-port", str(self.web_port), "--hide-welcome-screen"]
        if self.rrd is not None:
            argv.append(str(Path(self.rrd).resolve()))
        if self.log_path:
            with open(self.log_path, "w") as out:
                self.proc = subprocess.Popen(argv, stdout=out, stderr=subprocess.STDOUT, start_new_session=True)
        else:
            self.proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT,
                                         start_new_session=True)
        end = time.monotonic() + timeout_s
        while not (_listening(self.web_port) and _listening(self.grpc_port)):
            if self.proc.poll() is not None:
                raise RuntimeError(f"the Rerun viewer server exited with status {self.proc.returncode}")
            if time.monotonic() > end:
                self.stop()
                raise RuntimeError(f"the Rerun viewer server did not listen within {timeout_s:g} s")
            time.sleep(0.1)
        return self

    def stop(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(5)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(5)

    def __enter__(self) -> ViewServer:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()


def _listening(port: int) -> bool:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.settimeout(0.2)
        return s.connect_ex(("127.0.0.1", port)) == 0


class LiveRecorder:
    """A recording stream fed in batches from a background thread.

    ``push(row)`` (a tick's values in ``names`` order) and ``event(t, severity, text)`` only append;
    every ``period_s`` the thread sends what was appended. Sinks: a ``.rrd`` file and/or a
    :class:`ViewServer`'s gRPC address. ``convert`` turns a batch of raw items into columns (default:
    rows in ``names`` order).
    """

    def __init__(self, names: Sequence[str], geometry: SceneGeometry | None, *, rrd: Path | None = None,
                 grpc_url: str | None = None, name: str = "live", period_s: float = 0.25,
                 convert: Callable[[list], dict[str, np.ndarray]] | None = None, lag: bool = True,
                 truth: bool = True):
        rr = rerun_module("the view")
        self.rr, self.names, self.geometry, self.period, self.lag = rr, tuple(names), geometry, period_s, lag
        self.rec = rr.RecordingStream("wavekeep", recording_id=f"{name}-{time.time_ns()}")
        sinks = ([rr.FileSink(str(rrd))] if rrd is not None else []) + ([rr.GrpcSink(grpc_url)] if grpc_url else [])
        self.rec.set_sinks(*sinks, default_blueprint=blueprint(rr))
        self.rec.send_recording_name(name)
        log_static(rr, self.rec, geometry, truth)
        self.convert = convert or (lambda rows: columns_of(self.names, np.asarray(rows, dtype=float)))
        self._rows: list = []
        self._events: list[Event] = []
        self._thrust: np.ndarray | None = None
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="wavekeep-view", daemon=True)
        self._thread.start()

    def push(self, row) -> None:
        """Called by the tick (or the ground station): one append, nothing else."""
        self._rows.append(row)

    def event(self, t: float, severity: int, text: str) -> None:
        self._events.append(Event(t, severity, text))

    def _flush(self) -> None:
        rows, self._rows = self._rows, []          # a swap: the tick appends to the new list meanwhile
        if rows:
            cols = self.convert(rows)
            if cols.get("t") is not None and np.size(cols["t"]):
                _add_elevations(cols, self.geometry)
                self._thrust = write_columns(self.rr, self.rec, cols, self.geometry, lag=self.lag,
                                             thrust0=self._thrust)
        events, self._events = self._events, []     # (after convert, which may add some)
        write_events(self.rr, self.rec, events)

    def _run(self) -> None:
        while not self._stop.wait(self.period):
            self._flush()

    def close(self) -> None:
        """Send what is left and close the sinks (the ``.rrd`` is complete after this)."""
        self._stop.set()
        self._thread.join(timeout=10.0)
        self._flush()
        self.rec.flush()
        self.rec.disconnect()


def _add_elevations(cols: dict[str, np.ndarray], g: SceneGeometry | None) -> None:
    """The wave at the vehicle, true and forecast (m, up), as a finished run's time series has them."""
    x = cols.get("x", cols.get("x_hat"))
    if g is None or g.sea is None or x is None or "wave_eta" in cols:
        return
    from bridge.models.waves import elevation
    x = np.nan_to_num(np.asarray(x, dtype=float), nan=g.station_x)
    cols["wave_eta"] = elevation(g.sea, x, cols["t"])
    if g.forecast is not None:
        cols["forecast_eta"] = elevation(g.forecast, x, cols["t"])


class MavlinkFeed:
    """The ground station's downlink as a live view: frames in (``push(buf)``, from the station's
    hot loop), decoded by pymavlink on the recorder's thread and drawn as a tlog is
    (:func:`~sitl.harness.tlog_view.tlog_columns`), with the sea at the vehicle's time."""

    def __init__(self, geometry: SceneGeometry | None, grpc_url: str, station: Sequence[float] | None = None,
                 name: str = "sim (live, MAVLink)"):
        import os
        os.environ.setdefault("MAVLINK20", "1")
        from pymavlink.dialects.v20 import ardupilotmega as mavlink

        from .tlog import TlogCollector
        self.parser = mavlink.MAVLink(None)
        self.parser.robust_parsing = True
        self.collector = TlogCollector()
        self.station = None if station is None else [float(v) for v in station]   # [x, depth, θ] (m, m, rad)
        self.recorder = LiveRecorder((), geometry, grpc_url=grpc_url, name=name, convert=self._columns, lag=False,
                                     truth=False)
        self.push = self.recorder.push

    def _columns(self, frames: list[bytes]) -> dict[str, np.ndarray]:
        from .tlog_view import tlog_columns, tlog_events
        for buf in frames:
            for m in self.parser.parse_buffer(buf) or ():
                m._timestamp = time.time()
                self.collector.add(m)
        data = self.collector.take()
        for e in tlog_events(data):
            self.recorder.event(e.t, e.severity, e.text)
        cols = tlog_columns(data)
        if self.station is not None:
            for name, value in zip(("sp_x", "sp_z", "sp_theta"), self.station, strict=True):
                cols[name] = np.full(cols["t"].size, value)
        return cols

    def close(self) -> None:
        self.recorder.close()
