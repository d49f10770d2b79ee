"""Real components for the BlueOS extension's tests: its entry point as the container starts it, BlueOS's
router as the extension sees it, a vehicle, and a wave forecast over zenoh.

* :class:`Extension` — ``python -m blueos.main`` in a subprocess on loopback (its own data folder), driven
  over HTTP as the page drives it;
* :class:`RouterStandIn` — BlueOS's MAVLink router for one extension endpoint: a UDP server the extension
  sends to (``udpout``, the endpoint type it registers) relaying to and from a vehicle's UDP client link, and
  a record of what the companion said (STATUSTEXT);
* :class:`StandIn` — the plant and Wavekeep's firmware as the ArduSub stand-in, in real time, with a
  pymavlink ground station (the pilot);
* :class:`ForecastPublisher` — a zenoh peer (multicast scouting off) that listens on a loopback endpoint and
  publishes a forecast of the W1 sea twice a second.
"""
from __future__ import annotations

import http.server
import json
import os
import select
import signal
import socket
import subprocess
import sys
import threading
import time
import urllib.error
import urllib.request
from pathlib import Path
from typing import Any, ClassVar

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from sitl.harness.companion_launch import stand_in_args
from sitl.harness.ports import free_port

__all__ = ["CLI", "BlueOSStub", "Extension", "ForecastPublisher", "RouterStandIn", "StandIn"]

CLI = [sys.executable, "-m", "sitl.harness.cli"]
ENV = dict(os.environ, PYTHONUNBUFFERED="1")


def _start(argv: list[str], log: Path, ready: str | None, timeout: float = 90.0) -> subprocess.Popen:
    f = open(log, "w")  # noqa: SIM115 — closed with the process
    p = subprocess.Popen(argv, stdout=f, stderr=subprocess.STDOUT, env=ENV, start_new_session=True)
    end = time.monotonic() + timeout
    while ready is not None and ready not in log.read_text():
        assert p.poll() is None and time.monotonic() < end, log.read_text()
        time.sleep(0.05)
    return p


def _stop(p: subprocess.Popen, timeout: float = 20.0) -> int | None:
    if p.poll() is None:
        p.send_signal(signal.SIGTERM)
        try:
            p.wait(timeout)
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)
            p.wait(5)
    return p.returncode


class Extension:
    """The extension's entry point on loopback; ``mavlink`` is its ``--mavlink``."""

    def __init__(self, tmp: Path, mavlink: str, *args: str, data: Path | None = None):
        self.port, self.tmp = free_port(socket.SOCK_STREAM), tmp
        self.data = data or tmp / "data"
        self.log_path = tmp / f"extension-{self.port}.log"
        self.proc = _start([sys.executable, "-m", "blueos.main", "--host", "127.0.0.1", "--port", str(self.port),
                            "--data", str(self.data), "--mavlink", mavlink, *args], self.log_path, "serving")
        self.url = f"http://127.0.0.1:{self.port}/"

    def log(self) -> str:
        return self.log_path.read_text()

    def call(self, method: str, path: str, doc: Any = None) -> tuple[int, Any]:
        data = None if doc is None else json.dumps(doc).encode()
        req = urllib.request.Request(self.url + path, data=data, method=method,
                                     headers={"Content-Type": "application/json"})
        try:
            with urllib.request.urlopen(req, timeout=10) as r:
                body = r.read().decode()
                return r.status, json.loads(body) if "json" in r.headers.get("Content-Type", "") else body
        except urllib.error.HTTPError as exc:
            return exc.code, json.loads(exc.read().decode())

    def status(self) -> dict:
        return self.call("GET", "v1/status")[1]

    def wait(self, pred, timeout: float, what: str = "") -> dict:
        """Poll the status (as the page does, twice a second) until ``pred(status)``."""
        end = time.monotonic() + timeout
        while True:
            s = self.status()
            if pred(s):
                return s
            assert time.monotonic() < end, f"{what}: {json.dumps(s)}\n{self.log()[-3000:]}"
            time.sleep(0.5)

    def stop(self) -> int | None:
        return _stop(self.proc)


class RouterStandIn:
    """BlueOS's router for one UDP server endpoint: the extension sends to :attr:`port`; the vehicle's UDP client
    link sends to :attr:`vehicle_port`. Each side's datagrams go to the other's last address."""

    def __init__(self, vehicle_port: int = 0):
        self.front = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.front.bind(("127.0.0.1", 0))
        self.back = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.back.bind(("127.0.0.1", vehicle_port))
        self.port, self.vehicle_port = self.front.getsockname()[1], self.back.getsockname()[1]
        self.peers: dict[socket.socket, tuple | None] = {self.front: None, self.back: None}
        self.parser = mavlink.MAVLink(None)
        self.parser.robust_parsing = True
        self.texts: list[str] = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._relay, daemon=True)
        self._thread.start()

    def _relay(self) -> None:
        while not self._stop.is_set():
            ready, _, _ = select.select([self.front, self.back], [], [], 0.1)
            for sock in ready:
                data, addr = sock.recvfrom(65535)
                self.peers[sock] = addr
                other = self.back if sock is self.front else self.front
                if self.peers[other] is not None:
                    other.sendto(data, self.peers[other])
                if sock is self.front:
                    self._read(data)

    def _read(self, data: bytes) -> None:
        for m in self.parser.parse_buffer(data) or []:
            if m.get_type() == "STATUSTEXT":
                self.texts.append(m.text)

    def said(self, match, timeout: float = 5.0) -> bool:
        """Has a STATUSTEXT the extension sent matched ``match`` (a predicate on its text), waiting up to
        ``timeout`` s of wall time for it (it is relayed by this stand-in's thread, after the call that caused it)?"""
        end = time.monotonic() + timeout
        while True:
            if any(match(text) for text in list(self.texts)):
                return True
            if time.monotonic() > end:
                return False
            time.sleep(0.05)

    def close(self) -> None:
        self._stop.set()
        self._thread.join(2)
        self.front.close()
        self.back.close()


class StandIn:
    """The plant and the ArduSub stand-in (Wavekeep's firmware, real time) with a ground station on it; the
    stand-in's second MAVLink link sends to ``companion_port`` (a UDP client, as ArduSub's SERIAL1)."""

    def __init__(self, tmp: Path, companion_port: int, method: str = "rc"):
        plant, gcs = free_port(), free_port()
        self.procs = [_start([*CLI, "plant", "--case", "W1", "--port", str(plant)], tmp / "plant.log", "ready")]
        args = [a for a in stand_in_args(method) if a != "--companion-lockstep"]
        self.procs.append(_start([*CLI, "firmware", "--hal", f"sitl:127.0.0.1:{plant}", "--speedup", "1",
                                  "--mavlink", f"udpout:127.0.0.1:{gcs}", "--mavlink",
                                  f"udpout:127.0.0.1:{companion_port}", *args], tmp / "ardusub.log", "ready"))
        self.gcs = mavutil.mavlink_connection(f"udpin:127.0.0.1:{gcs}", source_system=255, source_component=190,
                                              dialect="ardupilotmega")
        assert self.gcs.wait_heartbeat(timeout=30) is not None

    def command(self, cmd: int, *p: float) -> int | None:
        self.gcs.mav.command_long_send(1, 1, cmd, 0, *(list(p) + [0] * (7 - len(p))))
        end = time.monotonic() + 5
        while time.monotonic() < end:
            m = self.gcs.recv_match(type="COMMAND_ACK", blocking=True, timeout=0.1)
            if m is not None and m.command == cmd:
                return m.result
        return None

    def arm(self, on: bool = True) -> None:
        assert self.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1 if on else 0) == 0

    def mode(self, mode: int) -> None:
        assert self.command(mavlink.MAV_CMD_DO_SET_MODE, 1, mode) == 0

    def close(self) -> None:
        for p in reversed(self.procs):
            _stop(p, 10)
        self.gcs.close()


class ForecastPublisher:
    """A zenoh peer on a free loopback endpoint publishing the W1 sea's own components (valid for ever)."""

    def __init__(self, endpoint: str | None = None, site: str = "moray"):
        import zenoh

        from bridge.forecast import oracle_forecast
        from bridge.forecast_codec import encode_forecast
        from bridge.keys import forecast_key
        from sitl.sea import Sea
        self.endpoint = endpoint or f"tcp/127.0.0.1:{free_port(socket.SOCK_STREAM)}"
        c = zenoh.Config()
        c.insert_json5("mode", '"peer"')
        c.insert_json5("listen/endpoints", json.dumps([self.endpoint]))
        c.insert_json5("scouting/multicast/enabled", "false")
        self.session = zenoh.open(c)
        self.payload = encode_forecast(oracle_forecast(Sea.load("W1").components, None, None, valid_until=1e6))
        self.key = forecast_key(site)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._publish, daemon=True)
        self._thread.start()

    def _publish(self) -> None:
        while not self._stop.wait(0.5):
            self.session.put(self.key, self.payload)

    def close(self) -> None:
        self._stop.set()
        self._thread.join(2)
        self.session.close()


class _ArduPilotManager(http.server.BaseHTTPRequestHandler):
    """BlueOS's ArduPilot manager, as far as its endpoints list goes (GET lists, POST adds)."""

    endpoints: ClassVar[list] = []

    def do_GET(self):
        self._reply(200, json.dumps(self.endpoints))

    def do_POST(self):
        body = json.loads(self.rfile.read(int(self.headers["Content-Length"])))
        type(self).endpoints = [*self.endpoints, *body]
        self._reply(201, "null")

    def _reply(self, code: int, text: str) -> None:
        self.send_response(code)
        self.send_header("Content-Type", "application/json")
        self.end_headers()
        self.wfile.write(text.encode())

    def log_message(self, *args):
        pass


class BlueOSStub:
    """A real HTTP server on loopback answering ``/ardupilot-manager/v1.0/endpoints``; :attr:`endpoints`."""

    def __init__(self):
        self.handler = type("Manager", (_ArduPilotManager,), {"endpoints": []})
        self.server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), self.handler)
        threading.Thread(target=self.server.serve_forever, daemon=True).start()
        self.url = f"http://127.0.0.1:{self.server.server_address[1]}/ardupilot-manager/v1.0/endpoints"

    @property
    def endpoints(self) -> list:
        return self.handler.endpoints

    def close(self) -> None:
        self.server.shutdown()
        self.server.server_close()
