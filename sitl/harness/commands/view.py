"""``wavekeep view`` (a run folder, a recording or a tlog in Rerun's viewer) and ``wavekeep tlog`` (a tlog's
figures and CSV); the ``--view`` / ``--no-record`` options of ``run``, ``sim`` and ``live``."""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

from . import options as o

__all__ = ["add_parsers", "add_record_options", "record", "require_view"]


def add_record_options(p: argparse.ArgumentParser, live: bool = False) -> None:
    """``--no-record`` (and with ``live``: ``--view``, ``--view-port``)."""
    p.add_argument("--no-record", action="store_true",
                   help="write no recording.rrd (the run's 3-D scene and time series for `wavekeep view`)")
    if live:
        p.add_argument("--view", action="store_true",
                       help="serve the live 3-D view on loopback while the mission flies and print its URL "
                            "(needs pip install 'wavekeep[view]')")
        p.add_argument("--view-port", type=o.port, default=None,
                       help="HTTP port of the view; default 9090, or a free one if that is taken")
        p.add_argument("--view-linger", type=o.positive, default=None, metavar="S",
                       help="keep the view up S seconds after the mission; default: until Ctrl-C when run "
                            "from a terminal, else 0")


def require_view(args: argparse.Namespace) -> None:
    """A one-line usage error for ``--view`` when Rerun is not installed (before anything starts)."""
    if getattr(args, "view", False):
        from ..view_layout import ViewUnavailable, rerun_module
        try:
            rerun_module("--view")
        except ViewUnavailable as exc:
            raise o.UsageError(str(exc)) from None


class SimView:
    """``sim --view``: the viewer server, the ground station's downlink drawn live, and after the mission
    the full recording sent to the same viewer; it stays up for ``--view-linger`` s (default: until
    Ctrl-C when stdin is a terminal, else not at all)."""

    def __init__(self, args: argparse.Namespace, spec):
        from bridge.schemas import load_mission_config

        from ..live_view import MavlinkFeed, ViewServer
        from ..view_sources import geometry_for
        self.linger_s = args.view_linger
        self.server = ViewServer(web_port=args.view_port).start()
        sp = load_mission_config(spec.mission)["setpoint"]
        try:
            self.feed = MavlinkFeed(geometry_for(spec, spec.seed), self.server.grpc_url,
                                    station=(sp["x"], sp["depth"], sp["pitch"]))
        except Exception:
            self.server.stop()
            raise
        print(f"wavekeep sim: the live view is at {self.server.url} (loopback)", flush=True)

    @property
    def tap(self):
        return self.feed.push

    def close(self) -> None:
        self.feed.close()

    def linger(self) -> None:
        """Keep the view up after the mission (Ctrl-C ends it; the run is complete either way)."""
        wait = self.linger_s if self.linger_s is not None else (float("inf") if sys.stdin.isatty() else 0.0)
        if wait > 0:
            print(f"wavekeep sim: the mission is done; the view stays up at {self.server.url}"
                  + (" until Ctrl-C" if wait == float("inf") else f" for {wait:g} s (Ctrl-C ends it)"), flush=True)
            end = time.monotonic() + wait
            try:
                while time.monotonic() < end and self.server.proc is not None and self.server.proc.poll() is None:
                    time.sleep(0.2)
            except KeyboardInterrupt:
                print("wavekeep sim: view closed", file=sys.stderr)

    def stop(self) -> None:
        self.server.stop()


def live_recording(args: argparse.Namespace, sim, spec, log_path: Path, recorder: list, say):
    """``live``: the flight recorded to LOG.rrd (unless --no-record) and, with --view, served live.
    Appends the :class:`~sitl.harness.live_view.LiveRecorder` to ``recorder``; the server or None."""
    from firmware_py.logger.tick_columns import TICK_COLUMNS

    from ..live_view import LiveRecorder, ViewServer
    from ..view_layout import SceneGeometry, ViewUnavailable

    m = sim.setup
    forecast = m.forecast.components() if m.forecast is not None else None
    names = ("t", "x", "z", "theta", "u", "w", "q", *TICK_COLUMNS)   # truth at the slot, then the tick's record
    server = None
    try:       # without Rerun (and without --view, which requires it) the flight goes on unrecorded
        server = ViewServer(web_port=args.view_port).start() if args.view else None
        geometry = SceneGeometry.from_configs(spec.vehicle, m.sea.components, float(m.setpoint[0]),
                                              forecast=forecast)
        rec = LiveRecorder(names, geometry, rrd=None if args.no_record else log_path.with_suffix(".rrd"),
                           grpc_url=server.grpc_url if server else None, name=log_path.stem)
    except ViewUnavailable as exc:
        if server is not None:
            server.stop()
        say(f"no recording: {exc}")
        return None
    from firmware_py.firmware import tick_row
    sim.on_slot = lambda s, r: rec.push([s.t, *s.eta, *s.nu, *tick_row(r)])
    recorder.append(rec)
    if server is not None:
        say(f"live view: {server.url} (loopback)")
    return server


def record(args: argparse.Namespace, out: Path, spec, seed: int | None, result=None,
           grpc_url: str | None = None) -> None:
    """After a run's files: DIR/recording.rrd unless ``--no-record`` (one line on stderr without Rerun)."""
    if getattr(args, "no_record", False):
        return
    from ..recording import Event
    from ..view_sources import record_run
    cols = events = None
    if result is not None:
        from ..recording import columns_of
        from ..results import TIMESERIES_COLUMNS
        cols = columns_of(TIMESERIES_COLUMNS, result.timeseries)
        events = [Event(*e) for e in result.events]
    path = record_run(out, spec, seed, cols, events, getattr(result, "forecasts", None), grpc_url=grpc_url)
    if path is not None:
        print(f"wrote {path}: the 3-D view of the run (wavekeep view {out})")


def add_parsers(sub) -> None:
    p = sub.add_parser("view", help="open a run folder, a recording (.rrd) or a MAVLink .tlog in the 3-D viewer",
                       description="Open a run folder, a Rerun recording (.rrd) or a MAVLink .tlog (Wavekeep's, "
                       "or one QGroundControl or MAVProxy recorded from a real ArduSub) in Rerun's web viewer on "
                       "loopback, until Ctrl-C; or, with --out, convert it to a .rrd. Needs pip install "
                       "'wavekeep[view]'.")
    p.add_argument("path", help="run folder, .rrd or .tlog")
    p.add_argument("--out", default=None, metavar="F.rrd", help="write the recording to this file and exit")
    p.add_argument("--port", type=o.port, default=None,
                   help="HTTP port of the viewer; default 9090, or a free one if that is taken")
    p.add_argument("--duration", type=o.positive, default=None,
                   help="serve for this many seconds, then exit; default: until Ctrl-C")
    p.set_defaults(func=cmd_view)

    p = sub.add_parser("tlog", help="a MAVLink .tlog's figures and CSV (Wavekeep's, ArduSub's, QGroundControl's)",
                       description="Read a MAVLink .tlog with pymavlink and write DIR/tlog.csv (one row per "
                       "ATTITUDE, every telemetry field held at its latest value, with the mode and arming) and "
                       "DIR/tlog.png (position, attitude, thrusters, feed-forward, modes).")
    p.add_argument("path", help="the .tlog (or a run folder with mission.tlog)")
    o.add_out(p, what="folder for tlog.csv and tlog.png")
    p.set_defaults(func=cmd_tlog)


def _source(path: str) -> Path:
    p = Path(path)
    if not p.exists():
        raise o.UsageError(f"{path}: no such file or folder")
    if p.is_file() and p.suffix not in (".rrd", ".tlog"):
        raise o.UsageError(f"{path}: not a .rrd or .tlog (nor a run folder)")
    return p


def cmd_view(args: argparse.Namespace) -> int:
    """Convert PATH to a recording and serve it (or write it to --out)."""
    from ..view_layout import ViewUnavailable, rerun_module
    from ..view_sources import rrd_for

    src = _source(args.path)
    try:
        rerun_module("wavekeep view")
    except ViewUnavailable as exc:
        raise o.UsageError(str(exc)) from None
    if args.out is not None:
        out = o.check_out(args.out, kind="file")
        if out.suffix != ".rrd":
            raise o.UsageError(f"--out {args.out}: a recording's name ends in .rrd")
        try:
            rrd_for(src, out)
        except ValueError as exc:
            raise o.UsageError(str(exc)) from None
        print(f"wrote {out}")
        return 0
    with tempfile.TemporaryDirectory(prefix="wavekeep-view-") as tmp:
        target = src if src.suffix == ".rrd" else Path(tmp) / "view.rrd"
        try:
            rrd = rrd_for(src, target) if target != src else src
        except ValueError as exc:
            raise o.UsageError(str(exc)) from None
        return _serve(rrd, args.port, args.duration)


def _serve(rrd: Path, port: int | None, duration: float | None) -> int:
    from ..live_view import ViewServer
    with ViewServer(rrd, web_port=port) as server:
        print(f"wavekeep view: {rrd.name} at {server.url} (loopback; Ctrl-C stops)", flush=True)
        end = None if duration is None else time.monotonic() + duration
        try:
            while end is None or time.monotonic() < end:
                if server.proc is not None and server.proc.poll() is not None:
                    print("wavekeep view: the viewer server stopped", file=sys.stderr)
                    return 1
                time.sleep(0.2)
        except KeyboardInterrupt:
            print("wavekeep view: stopped", file=sys.stderr)
            return 130
    return 0


def cmd_tlog(args: argparse.Namespace) -> int:
    """A tlog's CSV and figure."""
    from ..tlog import read_tlog
    from ..tlog_plots import plot_tlog
    from ..tlog_view import tlog_columns, write_tlog_csv

    src = _source(args.path)
    if src.is_dir():
        src = src / "mission.tlog"
        if not src.is_file():
            raise o.UsageError(f"{args.path}: a folder without mission.tlog")
    out = o.check_out(args.out, force=args.force)
    try:
        data = read_tlog(src)
    except ValueError as exc:
        raise o.UsageError(str(exc)) from None
    out.mkdir(parents=True, exist_ok=True)
    cols = tlog_columns(data)
    write_tlog_csv(cols, data, out / "tlog.csv")
    plot_tlog(cols, data, out / "tlog.png")
    t0, t1 = data.span()
    modes = sorted({e.text[len('mode '):] for e in data.events if e.kind == "mode"})
    print(f"{src}: {data.messages} messages from system {data.sysid}, {t1 - t0:.1f} s, {cols['t'].size} rows; "
          f"modes {', '.join(modes) or 'none'}")
    print(f"wrote {out}: tlog.csv, tlog.png")
    return 0
