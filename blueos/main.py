"""``python -m blueos.main``: the extension's entry point, as its container starts it.

One process: the web server (uvicorn, in a thread) and the companion's control task (in its own thread, as
``wavekeep companion`` runs it), on BlueOS's MAVLink router (a UDP endpoint the extension registers through
BlueOS's ArduPilot manager) and the forecast over zenoh. Every option has an environment variable, so the
Extensions Manager's settings can change them; the defaults are the container's. SIGTERM (``docker stop``)
releases the vehicle, then exits 0. Bad options: one line and exit 2; a web port that cannot be bound: exit 1.
"""
from __future__ import annotations

import argparse
import logging
import logging.handlers
import os
import signal
import sys
import threading
from pathlib import Path

__all__ = ["build_parser", "main"]

PROG = "wavekeep-blueos"
DEFAULT_REGISTER = "http://host.docker.internal/ardupilot-manager/v1.0/endpoints"
LOG_BYTES, LOG_FILES = 1_000_000, 3
"""The event log in the data folder (``logs/wavekeep.log``): rotated at 1 MB, three kept."""


def _env(name: str, default: str) -> str:
    return os.environ.get(name, default)


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog=PROG, description=__doc__.split("\n")[0].replace("``", ""))
    p.add_argument("--host", default=_env("WAVEKEEP_HOST", "0.0.0.0"), help="web server address ($WAVEKEEP_HOST)")
    p.add_argument("--port", default=_env("WAVEKEEP_PORT", "8000"), help="web server port ($WAVEKEEP_PORT)")
    p.add_argument("--data", default=_env("WAVEKEEP_DATA", "/app/data"),
                   help="settings and logs: the folder BlueOS bind-mounts ($WAVEKEEP_DATA)")
    p.add_argument("--mavlink", default=_env("WAVEKEEP_MAVLINK", "udpout:host.docker.internal:14771"),
                   help="the companion's MAVLink endpoint on BlueOS's router ($WAVEKEEP_MAVLINK)")
    p.add_argument("--register-endpoint", default=_env("WAVEKEEP_REGISTER", DEFAULT_REGISTER), metavar="URL",
                   help="BlueOS's ArduPilot-manager endpoints URL to register the router's UDP endpoint at, or "
                        "'none' ($WAVEKEEP_REGISTER)")
    p.add_argument("--target-system", default=_env("MAV_SYSTEM_ID", "1"), help="ArduSub's system id ($MAV_SYSTEM_ID)")
    p.add_argument("--gcs-sysid", default=_env("MAV_GCS_SYSID", "255"),
                   help="the companion's system id, ArduSub's MAV_GCS_SYSID ($MAV_GCS_SYSID)")
    p.add_argument("--stale", default=_env("WAVEKEEP_STALE", "0.5"),
                   help="s of wall time without telemetry before the companion releases ($WAVEKEEP_STALE)")
    p.add_argument("--identity-timeout", default="5", help="s to wait for ArduSub's heartbeat per attempt")
    return p


def _options(args):
    """The service's options from the parsed strings; ValueError with the option's name when one is bad."""
    from .router import mavlink_port
    from .service import ServiceOptions

    def number(name: str, kind, lo: float, hi: float):
        text = getattr(args, name.replace("-", "_"))
        try:
            v = kind(text)
        except ValueError:
            raise ValueError(f"--{name} {text}: not a number") from None
        if not lo <= v <= hi:
            raise ValueError(f"--{name} {text}: must be in [{lo:g}, {hi:g}]")
        return v
    port = number("port", int, 1, 65535)
    options = ServiceOptions(data=Path(args.data), mavlink=args.mavlink,
                             target_system=number("target-system", int, 1, 255),
                             gcs_sysid=number("gcs-sysid", int, 1, 255), stale_s=number("stale", float, 0.05, 10.0),
                             identity_timeout_s=number("identity-timeout", float, 0.5, 60.0))
    if ":" not in args.mavlink:
        raise ValueError(f"--mavlink {args.mavlink}: give a pymavlink URL, e.g. udpout:host.docker.internal:14771")
    register = None if args.register_endpoint == "none" else args.register_endpoint
    if register is not None:
        mavlink_port(args.mavlink)      # the endpoint registered is the one the companion sends to
    return port, options, register


def _logger(data: Path):
    """Events to stdout (the container's log) and to ``logs/wavekeep.log`` in the data folder."""
    (data / "logs").mkdir(parents=True, exist_ok=True)
    log = logging.getLogger("wavekeep.blueos")
    log.setLevel(logging.INFO)
    handler = logging.handlers.RotatingFileHandler(data / "logs" / "wavekeep.log", maxBytes=LOG_BYTES,
                                                   backupCount=LOG_FILES)
    handler.setFormatter(logging.Formatter("%(asctime)s %(message)s"))
    log.addHandler(handler)

    def say(text: str) -> None:
        print(text, flush=True)
        log.info(text)
    return say


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        port, options, register = _options(args)
        say = _logger(options.data)
    except (ValueError, OSError) as exc:
        print(f"{PROG}: {exc}", file=sys.stderr)
        return 2
    import uvicorn

    from .router import mavlink_port, register_endpoint
    from .service import CompanionService
    from .settings import SettingsStore
    from .web import create_app

    service = CompanionService(options, SettingsStore(options.data), say)
    if register is not None:
        def before_session() -> None:        # until the router has the endpoint (BlueOS may boot after us)
            service.endpoint = register_endpoint(register, mavlink_port(options.mavlink))
            say(f"wavekeep blueos: {service.endpoint}")
            if "registered" in service.endpoint or "present" in service.endpoint:
                service.before_session = None
        service.before_session = before_session
    server = uvicorn.Server(uvicorn.Config(create_app(service), host=args.host, port=port, log_level="warning",
                                           lifespan="off"))
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    web = threading.Thread(target=server.run, name="web", daemon=True)
    web.start()
    while not server.started and web.is_alive() and not stop.wait(0.05):
        pass
    if not server.started:
        print(f"{PROG}: the web server did not start on {args.host}:{port}", file=sys.stderr)
        return 1
    say(f"wavekeep blueos: serving http://{args.host}:{port}/ ; companion on {options.mavlink}")
    service.start()
    while not stop.wait(0.5) and web.is_alive():
        pass
    say("wavekeep blueos: stopping (the companion releases the vehicle)")
    service.stop()
    server.should_exit = True
    web.join(5.0)
    return 0


if __name__ == "__main__":
    sys.exit(main())
