"""The real ArduSub SITL binary as one of ``wavekeep sim``'s processes (``--autopilot ardusub:PATH``).

What ``sim_vehicle.py -v ArduSub -f vectored_6dof --model JSON`` does, for the
one binary: the vectored-6DOF defaults (``configs/autopilot/``), the JSON
physics on the plant's port, MAVLink on UDP to the launcher (SERIAL0) and, for a
companion, a second UDP link (SERIAL1), home at sea level, a free instance
number for its own TCP ports, its own folder for ``eeprom.bin`` and logs, and a
wiped parameter store (every run starts from the same defaults). The binary
reads nothing else; the path is the user's (``docs/ardusub.md``).
"""
from __future__ import annotations

import os
import signal
import socket
import subprocess
from pathlib import Path

from bridge.configfile import ConfigError, Field, read_yaml, resolve_config, validate

from .ports import port_is_free

__all__ = ["AUTOPILOT_SCHEMA", "ArduSubProcess", "free_instance", "load_ardusub_config", "parse_autopilot"]

AUTOPILOT_SCHEMA = {
    "name": Field("str"),
    "defaults": Field("str", doc="parameter file beside this config, given to ArduSub with --defaults"),
    "sea_start_s": Field("float", lo=10.0, hi=600.0, doc="s of still water to boot and dive in"),
    "physics_rate_hz": Field("float", lo=20.0, hi=1200.0, doc="the plant's step under ArduSub's frames"),
    "speedup": Field("float", lo=1.0, hi=1000.0, doc="ArduSub's --speedup when the run gives none"),
    "boot_timeout_s": Field("float", lo=10.0, hi=3600.0, doc="wall s until GUIDED is accepted"),
}
"""``configs/autopilot/ardusub.yaml``, less ``params`` (NAME: number, set over MAVLink before arming)."""


def load_ardusub_config(name_or_path: str | Path = "ardusub") -> dict:
    """``configs/autopilot/NAME.yaml``, validated; ``defaults`` resolved to a path beside it."""
    path = resolve_config(name_or_path, "autopilot")
    doc = read_yaml(path)
    params = doc.pop("params", None) if isinstance(doc, dict) else None
    cfg = validate(doc, AUTOPILOT_SCHEMA, path)
    params = {} if params is None else params
    if not isinstance(params, dict) or not all(isinstance(k, str) and isinstance(v, int | float)
                                               and not isinstance(v, bool) for k, v in params.items()):
        raise ConfigError(path, "params", "expected NAME: number lines")
    cfg["params"] = {k: float(v) for k, v in params.items()}
    defaults = Path(path).parent / cfg["defaults"]
    if not defaults.is_file():
        raise ConfigError(path, "defaults", f"no such file beside the config: {defaults.name}")
    cfg["defaults"] = str(defaults)
    return cfg


def parse_autopilot(text: str) -> Path:
    """``ardusub:PATH`` → the binary's path; ValueError (one line) for anything else or a missing binary."""
    kind, sep, path = text.partition(":")
    if kind != "ardusub" or not sep or not path:
        raise ValueError(f"--autopilot {text}: expected ardusub:PATH (the ArduSub SITL binary)")
    p = Path(path).expanduser()
    if not p.is_file():
        raise ValueError(f"--autopilot {text}: no such file")
    if not os.access(p, os.X_OK):
        raise ValueError(f"--autopilot {text}: not executable")
    return p.resolve()


_TCP_PORTS = (5760, 5762, 5763)     # SERIAL0-2 as SITL binds them, + 10 per instance
_UDP_PORTS = (5501, 9005)           # RC input and the IR-lock simulator, + 10 per instance


def free_instance(first: int = 10, last: int = 200) -> int:
    """An instance number ``-I N`` whose ports (+10·N) are all free now on loopback."""
    for n in range(first, last):
        if all(port_is_free(p + 10 * n, socket.SOCK_STREAM) for p in _TCP_PORTS) and \
                all(port_is_free(p + 10 * n) for p in _UDP_PORTS):
            return n
    raise RuntimeError(f"no free ArduSub SITL instance between {first} and {last}")


def home() -> str:
    """``--home``: the firmware's NED origin (WK_ORIGIN_LAT/LON, the site) at altitude 0, heading north.
    SITL's barometer computes water pressure from the height above sea level: at any other altitude the
    depth ArduSub reads is offset (at its default 584 m, dead)."""
    from firmware_py.params.table import load_params

    p = load_params()
    return f"{p['WK_ORIGIN_LAT']:.7f},{p['WK_ORIGIN_LON']:.7f},0,0"


class ArduSubProcess:
    """The binary, started in ``folder`` with its output in ``log``; stopped with SIGKILL (it ignores SIGTERM
    while it waits for physics, and keeps no state worth a clean exit: its parameters are wiped each run)."""

    def __init__(self, binary: Path, cfg: dict, folder: Path, plant_port: int, gcs_port: int,
                 companion_port: int | None = None, speedup: float | None = None, instance: int | None = None):
        self.name = "ardusub"
        folder.mkdir(parents=True, exist_ok=True)
        self.instance = free_instance() if instance is None else instance
        # -I first: it offsets the ports given before it (the physics port too) by 10·N
        self.argv = [str(binary), "-I", str(self.instance), "--model", "JSON:127.0.0.1", "--sim-port-out",
                     str(plant_port), "--defaults", cfg["defaults"], "-w",
                     "--speedup", f"{cfg['speedup'] if speedup is None else speedup:g}",
                     "--home", home(),
                     "--serial0", f"udpclient:127.0.0.1:{gcs_port}"]
        if companion_port is not None:
            self.argv += ["--serial1", f"udpclient:127.0.0.1:{companion_port}"]
        self.log_path = folder.parent / "ardusub.log"
        self._log = open(self.log_path, "w")  # noqa: SIM115 — lives as long as the process; closed in stop()
        self.proc = subprocess.Popen(self.argv, cwd=folder, stdout=self._log, stderr=subprocess.STDOUT,
                                     start_new_session=True)

    def ready(self) -> bool:
        return True             # it is ready when its heartbeat arrives (the launcher waits for that)

    def alive(self) -> bool:
        return self.proc.poll() is None

    def stop(self, timeout: float = 5.0) -> int | None:
        if self.alive():
            os.killpg(self.proc.pid, signal.SIGKILL)
            self.proc.wait(timeout)
        self._log.close()
        return 0 if self.proc.returncode == -signal.SIGKILL else self.proc.returncode

    def failure(self, timeout: float) -> str | None:
        """Why it counts as the run's failure: it exited by itself (the SIGKILL that stops it does not count)."""
        code = self.proc.returncode
        if code in (0, -signal.SIGKILL):
            return None
        return f"{self.name} exited with status {code}:\n{self.tail()}"

    def tail(self, n: int = 8) -> str:
        try:
            return "\n".join(self.log_path.read_text(errors="replace").splitlines()[-n:])
        except OSError:
            return ""

