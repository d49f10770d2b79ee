"""The real ArduSub and Wavekeep's firmware side by side, for the differential conformance suite.

:func:`start_pair` starts two vehicles, each in Wavekeep's still-water plant (``wavekeep plant
--case still``) on its own free ports, each flown over real UDP by its own pymavlink ground station
(:class:`mavlink_gcs.GroundStation`, sysid 255):

* **ArduSub**: the SITL binary named by ``WAVEKEEP_ARDUSUB`` (``--model JSON``, ``-I N`` on free
  ports, ``--speedup``), booted with a BlueROV2 Heavy's frame and power module (:data:`ARDUSUB_DEFAULTS`)
  at Wavekeep's origin at the sea surface, its MAVLink on ``--serial0 udpclient``;
* **Wavekeep**: ``wavekeep firmware`` on the same kind of plant, ``udpout`` to its ground station.

A test asks both the same thing (:meth:`Pair.ask`: a probe run on each vehicle at once, returning
``{item: answer}``) and :meth:`Pair.conform` compares the answers item by item against
:data:`conformance_differences.DIFFERENCES`, the documented list of deliberate differences. The
tally of items compared and items the same is printed at the end of the module (and written as JSON
to ``$WAVEKEEP_CONFORMANCE_REPORT`` when that is set).

``python tests/ardusub_pair.py --dump-params FILE`` boots the binary once and writes its whole
parameter list (less SITL's ``SIM_*``) as the reference table Wavekeep serves
(``configs/firmware/ardusub_params.csv``).
"""
from __future__ import annotations

import concurrent.futures
import contextlib
import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import pytest

os.environ["MAVLINK20"] = "1"
from conformance_differences import DIFFERENCES
from mavlink_gcs import GroundStation
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sitl.harness.ardusub import free_instance, home
from sitl.harness.ports import free_port

__all__ = ["ARDUSUB_DEFAULTS", "ENV", "SPEEDUP", "Pair", "Vehicle", "ardusub_binary", "start_pair"]

ENV = "WAVEKEEP_ARDUSUB"
SPEEDUP = 8.0
"""Simulated seconds per wall second, both vehicles (ArduSub paces itself on the plant's replies)."""
ARDUSUB_RATE_HZ = 400
"""ArduSub's physics rate here (its main loop's rate): what MAVLink shows does not depend on it."""
ARDUSUB_DEFAULTS = "FRAME_CONFIG 2\nBATT_MONITOR 4\n"
"""ArduSub's defaults file: its own compiled defaults, with a BlueROV2 Heavy's frame (vectored 6-DoF)
and its Power Sense Module (analog voltage and current), as every BlueROV2 Heavy is set up."""
ROOT = Path(__file__).resolve().parent.parent


def ardusub_binary() -> str:
    """The binary's path from ``WAVEKEEP_ARDUSUB``; the test is skipped, with the reason, without one."""
    path = os.environ.get(ENV)
    if not path:
        pytest.skip(f"{ENV} is not set: no real ArduSub SITL binary here")
    if not os.access(path, os.X_OK):
        pytest.skip(f"{ENV}={path} is not an executable file")
    return path


@dataclass
class Child:
    """A process of a vehicle, its output in a log file."""

    name: str
    proc: subprocess.Popen
    log: Path

    def tail(self, n: int = 15) -> str:
        with contextlib.suppress(OSError):
            return "\n".join(self.log.read_text(errors="replace").splitlines()[-n:])
        return ""

    def stop(self, sig: int = signal.SIGTERM) -> None:
        if self.proc.poll() is None:
            self.proc.send_signal(sig)
            try:
                self.proc.wait(10.0)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(5.0)


def _spawn(name: str, argv: list[str], folder: Path, env: dict | None = None) -> Child:
    log = folder / f"{name}.log"
    proc = subprocess.Popen(argv, stdout=log.open("w"), stderr=subprocess.STDOUT, cwd=folder,
                            env=env, start_new_session=True)
    return Child(name, proc, log)


def _wait_line(child: Child, text: str, timeout: float) -> None:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if text in child.log.read_text(errors="replace"):
            return
        if child.proc.poll() is not None:
            break
        time.sleep(0.05)
    raise RuntimeError(f"{child.name}: no {text!r} within {timeout} s:\n{child.tail()}")


def _plant(folder: Path) -> tuple[Child, int]:
    port = free_port()
    plant = _spawn("plant", [sys.executable, "-m", "sitl.harness.cli", "plant", "--case", "still", "--port",
                             str(port)], folder, _env())
    return plant, port


def _env() -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT), env.get("PYTHONPATH", "")])
    return env


@dataclass
class Vehicle:
    """One vehicle: its processes and its ground station (sysid 255, heartbeats at 2 Hz of vehicle time)."""

    name: str
    gs: GroundStation
    children: list[Child]
    speedup: float
    boot_log_end: int = 0          # messages in gs.log before the first test (the boot)
    notes: dict = field(default_factory=dict)

    def wait(self, sim_s: float) -> list:
        """Listen for ``sim_s`` of vehicle time (by the time_boot_ms the vehicle sends: a loaded machine may run it
        slower than its speed-up); the messages heard."""
        gs = self.gs
        start = gs.drain()
        t0 = self.clock(start)
        end = time.monotonic() + self.wall(sim_s) + 10.0
        while time.monotonic() < end:
            gs._pump(0.05)
            t = self.clock(len(gs.log))
            if t0 is None:
                t0 = t
            elif t is not None and t - t0 >= sim_s:
                break
        return gs.log[start:]

    def clock(self, upto: int) -> float | None:
        """The vehicle's latest time_boot_ms (s) in the first ``upto`` messages of the log."""
        for m in reversed(self.gs.log[max(0, upto - 200):upto]):
            if m.get_srcSystem() == 1 and isinstance(getattr(m, "time_boot_ms", None), int):
                return m.time_boot_ms / 1000.0
        return None

    def wall(self, sim_s: float) -> float:
        """Wall seconds for ``sim_s`` simulated seconds, with room for a loaded machine."""
        return 2.0 + 3.0 * sim_s / self.speedup

    def alive(self) -> None:
        for c in self.children:
            if c.proc.poll() is not None:
                raise RuntimeError(f"{self.name}: {c.name} died (status {c.proc.returncode}):\n{c.tail()}")

    def stop(self) -> None:
        self.gs.close()
        for c in self.children:        # ArduSub first (it ignores SIGTERM while waiting for physics)
            c.stop(signal.SIGKILL if c.name == "ardusub" else signal.SIGTERM)


def _ground_station(port: int, speedup: float) -> GroundStation:
    gs = GroundStation(f"udpin:127.0.0.1:{port}", hb_period=0.5 / speedup)
    gs.heartbeats(True)
    return gs


def start_ardusub(folder: Path, binary: str, speedup: float = SPEEDUP) -> Vehicle:
    """The real ArduSub SITL in a still-water plant, its MAVLink to a fresh ground station."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "defaults.parm").write_text(ARDUSUB_DEFAULTS)
    plant, plant_port = _plant(folder)
    children = [plant]
    try:
        _wait_line(plant, "ready on udp", 60.0)
        gcs = free_port()
        gs = _ground_station(gcs, speedup)
        n = free_instance(20, 256)          # -I N: ArduPilot's uint8, its ports free on loopback
        client = {"mavsdk": f"tcpout://127.0.0.1:{5762 + 10 * n}", "dronekit": f"tcp:127.0.0.1:{5763 + 10 * n}"}
        argv = [binary, "--model", "JSON:127.0.0.1", "--sim-port-out", str(plant_port),
                "--sim-port-in", str(free_port()), "--defaults", str(folder / "defaults.parm"), "-I", str(n),
                "-w", "--speedup", f"{speedup:g}", "--rate", str(ARDUSUB_RATE_HZ),
                "--serial0", f"udpclient:127.0.0.1:{gcs}", "--home", home()]   # the firmware's origin, at the surface
        children.insert(0, _spawn("ardusub", argv, folder))
        v = Vehicle("ArduSub", gs, children, speedup, notes=client)
        _first_heartbeat(v, 120.0)
        return v
    except BaseException:
        for c in children:
            c.stop(signal.SIGKILL)
        raise


def start_wavekeep(folder: Path, speedup: float = SPEEDUP) -> Vehicle:
    """``wavekeep firmware`` in a still-water plant, as ``wavekeep sim`` starts it, over real UDP."""
    folder.mkdir(parents=True, exist_ok=True)
    plant, plant_port = _plant(folder)
    children = [plant]
    try:
        gcs, clients = free_port(), free_port()
        gs = _ground_station(gcs, speedup)
        argv = [sys.executable, "-m", "sitl.harness.cli", "firmware", "--hal", f"sitl:127.0.0.1:{plant_port}",
                "--hal-wait", "60", "--mavlink", f"udpout:127.0.0.1:{gcs}", "--mavlink", f"udpin:127.0.0.1:{clients}",
                "--speedup", f"{speedup:g}", "--no-forecast", "--realtime", "off"]
        # (no SCHED_FIFO: it would keep the firmware's clock going while the ground station, at normal
        # priority like ArduSub, waits for a core, and the GCS failsafe would trip on a loaded machine)
        children.insert(0, _spawn("firmware", argv, folder, _env()))
        client = {"mavsdk": f"udpout://127.0.0.1:{clients}", "dronekit": f"udpout:127.0.0.1:{clients}"}
        v = Vehicle("Wavekeep", gs, children, speedup, notes=client)
        _first_heartbeat(v, 120.0)
        return v
    except BaseException:
        for c in children:
            c.stop()
        raise


def _first_heartbeat(v: Vehicle, timeout: float) -> None:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if v.gs.heartbeat(timeout=1.0) is not None:
            return
        v.alive()
    raise RuntimeError(f"{v.name}: no heartbeat within {timeout} s:\n" + "\n".join(c.tail() for c in v.children))


# --------------------------------------------------------------------------- comparing


def documented(item: str) -> str | None:
    """The documented reason an item differs (:data:`DIFFERENCES`; a key ending in ``*`` is a prefix)."""
    for key, (topic, why) in DIFFERENCES.items():
        if key == item or (key.endswith("*") and item.startswith(key[:-1])):
            return f"{topic}: {why}"
    return None


@dataclass
class Pair:
    """The two vehicles, and the tally of what was compared."""

    ardusub: Vehicle
    wavekeep: Vehicle
    items: dict[str, dict] = field(default_factory=dict)

    @property
    def vehicles(self) -> tuple[Vehicle, Vehicle]:
        return self.ardusub, self.wavekeep

    def ask(self, probe: Callable[[Vehicle], dict]) -> tuple[dict, dict]:
        """``probe`` on both vehicles at once; their answers ``({item: answer}, {item: answer})``."""
        with concurrent.futures.ThreadPoolExecutor(2) as pool:
            a, w = pool.map(probe, self.vehicles)
        return a, w

    def conform(self, ardusub: dict, wavekeep: dict) -> None:
        """Each item the same, or different as documented; else an AssertionError naming every item that is not.

        A documented difference that has become the same fails too: the list must say what is true.
        """
        problems = []
        for item in sorted(set(ardusub) | set(wavekeep)):
            a, w = ardusub.get(item, "<none>"), wavekeep.get(item, "<none>")
            same = _norm(a) == _norm(w)
            why = documented(item)
            self.items[item] = {"same": same, "documented": why is not None, "ardusub": a, "wavekeep": w}
            if not same and why is None:
                problems.append(f"{item}: ArduSub {a!r}, Wavekeep {w!r}")
            elif same and why is not None:
                problems.append(f"{item}: documented as a difference ({why}) but both answer {a!r}")
        assert not problems, "differences from the real ArduSub:\n  " + "\n  ".join(problems)

    def report(self) -> dict:
        same = sum(1 for r in self.items.values() if r["same"])
        return {"items": len(self.items), "same": same,
                "documented_differences": sorted(k for k, r in self.items.items() if not r["same"] and r["documented"]),
                "undocumented_differences": sorted(k for k, r in self.items.items()
                                                   if not r["same"] and not r["documented"]),
                "answers": self.items}

    def stop(self) -> None:
        for v in self.vehicles:
            v.stop()


def _norm(v):
    if isinstance(v, float):
        return round(v, 4)
    if isinstance(v, (list, tuple)):
        return [_norm(x) for x in v]
    if isinstance(v, dict):
        return {k: _norm(x) for k, x in sorted(v.items())}
    return v


def start_pair(folder: Path) -> Pair:
    """Both vehicles, started at once (each a still-water plant and an autopilot on free ports)."""
    binary = ardusub_binary()
    with concurrent.futures.ThreadPoolExecutor(2) as pool:
        fa = pool.submit(start_ardusub, folder / "ardusub", binary)
        fw = pool.submit(start_wavekeep, folder / "wavekeep")
        started = []
        try:
            a, w = fa.result(), fw.result()
        except BaseException:
            for f in (fa, fw):
                with contextlib.suppress(BaseException):
                    started.append(f.result())
            for v in started:
                v.stop()
            raise
    return Pair(a, w)


def write_report(pair: Pair) -> dict:
    """The tally, printed; and written as JSON to ``$WAVEKEEP_CONFORMANCE_REPORT`` when that is set."""
    rep = pair.report()
    print(f"\nArduSub conformance: {rep['items']} items compared, {rep['same']} the same, "
          f"{len(rep['documented_differences'])} documented differences, "
          f"{len(rep['undocumented_differences'])} undocumented")
    path = os.environ.get("WAVEKEEP_CONFORMANCE_REPORT")
    if path:
        Path(path).write_text(json.dumps(rep, indent=1, default=repr))
    return rep


# --------------------------------------------------------------------------- the reference parameter table

PARAM_TYPE_NAMES = {mavlink.MAV_PARAM_TYPE_INT8: "INT8", mavlink.MAV_PARAM_TYPE_INT16: "INT16",
                    mavlink.MAV_PARAM_TYPE_INT32: "INT32", mavlink.MAV_PARAM_TYPE_REAL32: "REAL32"}


def read_param_list(v: Vehicle, timeout: float = 60.0) -> dict[str, tuple[float, str]]:
    """PARAM_REQUEST_LIST, then PARAM_REQUEST_READ by index of whatever did not come (a burst may lose
    datagrams), 20 at a time, until all have: ``{name: (value, type)}``."""
    gs = v.gs
    got: dict[str, tuple[float, str]] = {}
    seen: set[int] = set()
    count = 0
    i = gs.mark()
    gs.send(mavlink.MAVLink_param_request_list_message(1, 1))
    end = time.monotonic() + timeout
    quiet_until = time.monotonic() + 10.0
    while time.monotonic() < end:
        gs._pump(0.1)
        for m in gs.log[i:]:
            if m.get_type() == "PARAM_VALUE":
                got[m.param_id] = (float(m.param_value), PARAM_TYPE_NAMES.get(m.param_type, str(m.param_type)))
                seen.add(m.param_index)
                count = m.param_count
                quiet_until = min(quiet_until, time.monotonic() + 1.0) if count and len(seen) >= count else \
                    time.monotonic() + 1.0
        i = len(gs.log)
        missing = [k for k in range(count) if k not in seen]
        if count and not missing:
            break
        if time.monotonic() > quiet_until:        # the list is over: ask for the rest, 20 at a time
            for k in missing[:20]:
                gs.send(mavlink.MAVLink_param_request_read_message(1, 1, b"", k))
            quiet_until = time.monotonic() + 0.5
    return got


def dump_params(out: Path) -> None:
    """Boot the binary once and write its parameter table, with its provenance, as CSV."""
    import tempfile
    binary = os.environ.get(ENV)
    if not binary:
        raise SystemExit(f"set {ENV} to the ArduSub SITL binary")
    with tempfile.TemporaryDirectory() as tmp:
        v = start_ardusub(Path(tmp), binary)
        try:
            version = ""
            v.gs.wait_type("STATUSTEXT", lambda m: "is using GPS" in m.text, v.wall(60.0), since=0)
            since = v.gs.mark()
            table = read_param_list(v)
            for m in v.gs.log[since:]:
                if m.get_type() == "STATUSTEXT" and m.text.startswith("ArduSub V"):
                    version = m.text
        finally:
            v.stop()
    rows = sorted((n, val, t) for n, (val, t) in table.items() if not n.startswith(("SIM_", "STAT_")))
    stats = sorted(n for n in table if n.startswith("STAT_"))
    lines = [
        f"# ArduSub's parameter table as the real binary serves it: {version}",
        "# (ArduPilot master of 2025-07-21, 90700977c5, built as SITL for Linux), booted with its compiled",
        f"# defaults and a defaults file of {ARDUSUB_DEFAULTS.strip().replace(chr(10), ', ')} (a BlueROV2",
        "# Heavy with its Power Sense Module), read over MAVLink (PARAM_REQUEST_LIST) by",
        "# `python tests/ardusub_pair.py --dump-params FILE`. Left out: SIM_* (ArduPilot's own simulator).",
        f"# The statistics counters ({', '.join(stats)}) are given as 0 (a new vehicle's).",
        f"# {len(rows) + len(stats)} parameters: ArduSub's {len(table)}"
        f" less {len(table) - len(rows) - len(stats)} SIM_*.",
        "name,value,type",
    ]
    lines += [f"{n},{val!r},{t}" for n, val, t in rows]
    lines += [f"{n},0.0,{table[n][1]}" for n in stats]
    out.write_text("\n".join(lines) + "\n")
    print(f"wrote {out}: {len(rows) + len(stats)} parameters")


if __name__ == "__main__":   # python tests/ardusub_pair.py --dump-params configs/firmware/ardusub_params.csv
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    if len(sys.argv) != 3 or sys.argv[1] != "--dump-params":
        raise SystemExit("usage: python tests/ardusub_pair.py --dump-params FILE")
    dump_params(Path(sys.argv[2]))
