"""Shared options and input checks of the ``wavekeep`` command line.

Every bad input is a :class:`UsageError` — one line ``wavekeep CMD: …`` on stderr, exit 2 —
found before anything is simulated or written: option types (:func:`seed`, :func:`duration`,
:func:`port`, ...), the output path (:func:`check_out`), the run options and their
parameter overrides (:func:`run_spec`). Only the standard library is imported here, so
``wavekeep --help`` stays fast.
"""
from __future__ import annotations

import argparse
import math
import os
import shutil
import tempfile
from pathlib import Path
from typing import Any

__all__ = ["MAX_DURATION_S", "Parser", "UsageError", "check_duration", "check_out", "run_spec"]

MAX_SEED = 2**63 - 1
MAX_DURATION_S = 86400.0
"""Longest mission or record a command accepts (one day of simulated time)."""

RUN_FILES = ("results.json", "run.json", "timeseries.csv", "*.png", "*.log", "mission.tlog", "reproduce.json",
             "firmware_ticks.*", "companion_ticks.*", "plant_truth.csv", "network.yaml", "*.rrd")
"""What a run leaves in its folder: with ``--force`` these are removed before the new run writes."""

RUN_FOLDERS = ("ardusub",)
"""Sub-folders a run writes (the real ArduSub's working folder: its logs and parameters), removed likewise."""


class UsageError(Exception):
    """A bad option or combination of options: reported in one line, exit status 2."""


class HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Shows an option's default once: appended as ``(default: X)`` only where the help text does not already
    say it, and never for options without one (None, False)."""

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        if "default" in text or action.default in (None, False, argparse.SUPPRESS) or not action.option_strings:
            return text
        return super()._get_help_string(action) or text


class Parser(argparse.ArgumentParser):
    """An argument parser whose errors are one line (``wavekeep CMD: message``) and whose help shows defaults."""

    def __init__(self, *a: Any, **kw: Any):
        kw.setdefault("formatter_class", HelpFormatter)
        super().__init__(*a, **kw)

    def error(self, message: str):
        raise UsageError(message)


# ---------------------------------------------------------------------------- option types

def _number(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not math.isfinite(v):
        raise argparse.ArgumentTypeError(f"must be a finite number, got {text}")
    return v


def positive(text: str) -> float:
    v = _number(text)
    if v <= 0:
        raise argparse.ArgumentTypeError(f"must be a positive number, got {text}")
    return v


def duration(text: str) -> float:
    """Seconds in (0, one day]; the lower bound of one control period is :func:`check_duration`'s."""
    v = positive(text)
    if v > MAX_DURATION_S:
        raise argparse.ArgumentTypeError(f"must be at most {MAX_DURATION_S:g} s (one day), got {text}")
    return v


def seed(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be an integer, got {text!r}") from None
    if not 0 <= v <= MAX_SEED:
        raise argparse.ArgumentTypeError(f"must be an integer in [0, 2^63 - 1], got {text}")
    return v


def snr_db(text: str) -> float:
    v = _number(text)
    if not -20.0 <= v <= 80.0:
        raise argparse.ArgumentTypeError(f"must be a number of dB in [-20, 80], got {text}")
    return v


def port(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a port number, got {text!r}") from None
    if not 1 <= v <= 65535:
        raise argparse.ArgumentTypeError(f"must be a port in 1-65535, got {text}")
    return v


def count(text: str) -> int:
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be an integer, got {text!r}") from None
    if v < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {text}")
    return v


# ---------------------------------------------------------------------------- checks

def check_duration(value: float | None, mission: str, option: str = "--duration") -> None:
    """Refuse a duration shorter than two control periods of ``mission`` (nothing to fly or report)."""
    if value is None:
        return
    from bridge.schemas import load_mission_config

    rate = load_mission_config(mission)["control_rate"]
    if value < 2.0 / rate:
        raise UsageError(f"{option} {value:g} s is shorter than two control periods ({2.0 / rate:g} s at "
                         f"{rate:g} Hz)")


def check_out(path: str | Path, kind: str = "dir", force: bool = False, option: str = "--out") -> Path:
    """Refuse an output path that cannot be written, before anything runs; nothing is created here.

    ``kind`` "dir": a run folder — not a file, not under a file, writable, and empty unless
    ``force`` (then the files a previous run left, :data:`RUN_FILES`, are removed so stale files
    never mix with new ones). ``kind`` "campaign": a folder a rerun resumes (its files are kept).
    ``kind`` "file": a file to (over)write.
    """
    p = Path(path)
    if kind in ("dir", "campaign") and p.exists() and not p.is_dir():
        raise UsageError(f"{option} {path}: is a file, not a folder")
    if kind == "file" and p.is_dir():
        raise UsageError(f"{option} {path}: is a folder, not a file")
    anc = p if p.is_dir() else p.parent
    while not anc.exists() and anc != anc.parent:
        anc = anc.parent
    if not anc.is_dir():
        raise UsageError(f"{option} {path}: {anc} is a file, not a folder")
    try:
        os.rmdir(tempfile.mkdtemp(dir=anc, prefix=".wavekeep-"))
    except OSError as exc:
        raise UsageError(f"{option} {path}: cannot write in {anc} ({exc.strerror or exc})") from None
    if kind == "dir" and p.is_dir() and any(p.iterdir()):
        if not force:
            raise UsageError(f"{option} {path}: folder is not empty (a previous run?); choose a new folder "
                             "or pass --force to replace the previous run's files")
        for pattern in RUN_FILES:
            for f in p.glob(pattern):
                if f.is_file():
                    f.unlink()
        for name in RUN_FOLDERS:
            if (p / name).is_dir():
                shutil.rmtree(p / name)
    return p


def endpoint(url: str, option: str = "--mavlink", bind: bool = False) -> str:
    """A MAVLink endpoint ``udpout|udpin|tcp|tcpin:HOST:PORT``; with ``bind``, a listening one must be free."""
    import socket

    kind, _, rest = url.partition(":")
    host, sep, port_text = rest.rpartition(":")
    if kind not in ("udpout", "udpin", "tcp", "tcpin") or not sep or not host:
        raise UsageError(f"{option} {url}: expected udpout:HOST:PORT, udpin:HOST:PORT, tcp:HOST:PORT "
                         "or tcpin:HOST:PORT")
    try:
        n = port("1" if port_text == "0" and kind in ("udpin", "tcpin") else port_text) and int(port_text)
    except (argparse.ArgumentTypeError, ValueError) as exc:
        raise UsageError(f"{option} {url}: {exc}") from None
    if bind and kind in ("udpin", "tcpin"):
        kind_sock = socket.SOCK_DGRAM if kind == "udpin" else socket.SOCK_STREAM
        with socket.socket(socket.AF_INET, kind_sock) as s:
            try:
                s.bind((host, n))
            except OSError as exc:
                raise UsageError(f"{option} {url}: cannot listen on {host}:{n} ({exc.strerror or exc}); "
                                 "is another program using the port?") from None
    return url


# ---------------------------------------------------------------------------- run options

def overrides(args: argparse.Namespace) -> dict[str, float]:
    """Parameter overrides from ``--params FILE`` (NAME: value, only what changes) then ``--set NAME=VALUE``,
    each checked against the parameter table; a bad one is blamed on the option or file it came from."""
    from bridge.configfile import ConfigError, read_yaml
    from firmware_py.params.table import load_params

    table = load_params()
    out: dict[str, float] = {}
    params_file = getattr(args, "params", None)
    if params_file:
        try:
            doc = read_yaml(params_file)
        except (OSError, ConfigError) as exc:
            raise UsageError(f"--params {params_file}: {exc}") from None
        if not isinstance(doc, dict):
            raise UsageError(f"--params {params_file}: expected NAME: value lines")
        for name, value in doc.items():
            why = table.set(str(name), value) if isinstance(value, int | float) else f"{value!r} is not a number"
            if why:
                raise UsageError(f"--params {params_file}: {name}: {why}")
            out[str(name)] = float(value)
    for item in getattr(args, "set", None) or []:
        name, eq, text = item.partition("=")
        try:
            value = float(text)
        except ValueError:
            value = None
        why = ("expected NAME=VALUE" if not eq else f"{text!r} is not a number" if value is None
               else table.set(name.strip(), value))
        if why:
            raise UsageError(f"--set {item}: {why}")
        out[name.strip()] = float(text)
    return out


_SPEC_OPTIONS = (("controller", "--controller"), ("forecast SNR", "--forecast-snr-db"), ("forecast", "--forecast"),
                 ("seed", "--seed"), ("duration", "--duration"), ("DSWP options", "--dswp-set: DSWP options"),
                 ("dswp.", "--dswp-set "))


def run_spec(args: argparse.Namespace) -> Any:
    """The :class:`~sitl.harness.spec.RunSpec` a run command's options describe, checked by option name."""
    from ..spec import RunSpec

    forecast = getattr(args, "forecast", "oracle")
    snr = getattr(args, "forecast_snr_db", None)
    if snr is not None and (args.controller not in ("cpd_ff", "cpd_ff_dob", "mpc") or forecast != "oracle"):
        raise UsageError("--forecast-snr-db applies only to --controller cpd_ff(_dob) or mpc with --forecast oracle "
                         f"(got --controller {args.controller} --forecast {forecast})")
    check_duration(getattr(args, "duration", None), args.mission)
    world = world_options(args)
    try:
        return RunSpec(case=args.case, controller=args.controller, snr_db=snr, seed=args.seed,
                       duration=getattr(args, "duration", None), mission=args.mission, vehicle=args.vehicle,
                       forecast=forecast, overrides=overrides(args), **world)
    except ValueError as exc:
        msg = str(exc)
        for key, option in _SPEC_OPTIONS:
            if msg.startswith(key):
                msg = option + msg[len(key):]
                break
        raise UsageError(msg) from None


def check_configs(args: argparse.Namespace, spec: Any) -> None:
    """Load the sea (with the spec's overrides), mission and vehicle configs a run will fly, so a bad one is
    refused (a ConfigError: one line, exit 2) before the command prints or writes anything; the true vehicle
    too, when one is given."""
    from ..provenance import configs_record

    configs_record(spec.case, spec.mission, spec.vehicle, spec.sea, spec.true_vehicle)


def _key_values(items: list[str] | None, option: str) -> dict[str, Any]:
    """``KEY=VALUE`` items, each value read as YAML (``10``, ``0.3``, ``true``); a usage error names ``option``."""
    from bridge.configfile import parse_key_values

    try:
        return parse_key_values(items)
    except ValueError as exc:
        raise UsageError(f"{option} {exc}") from None


def world_options(args: argparse.Namespace) -> dict[str, Any]:
    """The errors of docs/sea-errors.md a command's options ask for: ``sea``, ``true_vehicle``, ``dswp``
    (checked here, so a bad one is a usage error naming the option)."""
    from bridge.configfile import ConfigError
    from bridge.schemas import load_true_vehicle
    from sitl.sea import load_sea_config

    sea = _key_values(getattr(args, "sea_set", None), "--sea-set")
    dswp = _key_values(getattr(args, "dswp_set", None), "--dswp-set")
    true_vehicle = getattr(args, "true_vehicle", None)
    try:
        if sea:
            load_sea_config(args.case, sea)
        if true_vehicle:
            load_true_vehicle(true_vehicle)
    except ConfigError as exc:
        raise UsageError(f"{'--sea-set' if sea and exc.key else '--true-vehicle'}: {exc}") from None
    return {"sea": sea, "true_vehicle": true_vehicle, "dswp": dswp}


def add_world(p: argparse.ArgumentParser, vehicle: bool = True) -> None:
    """--sea-set KEY=VALUE (and --true-vehicle, --dswp-set): the errors of docs/sea-errors.md."""
    p.add_argument("--sea-set", action="append", default=None, metavar="KEY=VALUE",
                   help="set one sea config key for this run (repeatable), e.g. buoy.noise_snr_db=10, "
                   "current.speed=0.3, spreading.s=10, depth_sensor.dynamic_pressure=true (docs/sea-errors.md)")
    if vehicle:
        p.add_argument("--true-vehicle", default=None, metavar="NAME",
                       help="plant-only vehicle override: a name in configs/vehicle/true/ or a path")
        p.add_argument("--dswp-set", action="append", default=None, metavar="KEY=VALUE",
                       help="one DSWP forecaster option (repeatable; --forecast dswp), e.g. window_s=60, "
                       "deep_water=true")


def add_common(p: argparse.ArgumentParser, vehicle: bool = True) -> None:
    """--case, --seed, --mission and (for commands that fly the vehicle) --vehicle."""
    p.add_argument("--case", default="W3", help="sea state: a name in configs/sea/ (W1, W2, W3) or a sea YAML path")
    p.add_argument("--seed", type=seed, default=None,
                   help="sea realisation (and, from it, sensor noise and forecast error), integer in [0, 2^63 - 1]; "
                   "default: the sea config's")
    p.add_argument("--mission", default="station_keeping", help="mission config: a name in configs/mission/ or a path")
    if vehicle:
        p.add_argument("--vehicle", default="bluerov2_heavy",
                       help="vehicle config: a name in configs/vehicle/ or a path")


def add_controller(p: argparse.ArgumentParser, forecast_help: str = "forecast source") -> None:
    """--controller, --forecast, --forecast-snr-db."""
    from ..spec import CONTROLLERS

    p.add_argument("--controller", choices=CONTROLLERS, default="cpd_ff",
                   help="cpd: cascaded PD feedback; cpd_ff: with the wave feed-forward; *_dob: + the estimated "
                   "disturbance fed back (disturbance observer); mpc: the preview MPC on the forecast's horizon "
                   "(docs/mpc.md)")
    p.add_argument("--forecast", choices=("oracle", "dswp"), default="oracle",
                   help=f"{forecast_help}: oracle (the sea's own components) or dswp (predicted from the up-wave buoy)")
    p.add_argument("--forecast-snr-db", type=snr_db, default=None,
                   help="oracle forecast error: the paper's injected error at this SNR (dB, in [-20, 80]); "
                   "default: the exact forecast")


def add_params(p: argparse.ArgumentParser) -> None:
    """--params FILE and --set NAME=VALUE."""
    p.add_argument("--params", default=None, metavar="FILE",
                   help="YAML of firmware parameters to change (NAME: value; only what differs from "
                   "configs/firmware/params.yaml)")
    p.add_argument("--set", action="append", default=None, metavar="NAME=VALUE",
                   help="set one firmware parameter (repeatable; after --params)")


def add_out(p: argparse.ArgumentParser, required: bool = True, default: str | None = None,
            what: str = "run folder") -> None:
    p.add_argument("--out", required=required, default=default, help=f"{what} (created; must be new or empty)")
    p.add_argument("--force", action="store_true",
                   help="write into a non-empty --out, first removing the files a previous run left there")
