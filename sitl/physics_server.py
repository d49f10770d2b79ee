"""The simulated world as an ArduPilot JSON SITL physics server (UDP, lockstep).

The autopilot (Wavekeep's :class:`firmware_py.hal_json.JSONSITLHAL`, or real
ArduSub SITL started with ``--model JSON:127.0.0.1``) sends binary servo
packets; the server answers each with one line of JSON holding the vehicle's
state. The wire format is ArduPilot's (``libraries/SITL/SIM_JSON.cpp``,
``libraries/SITL/examples/JSON/readme.md``); see ``docs/json_sitl.md``.

Servo packet, little endian::

    <HHI16H   magic 18458, frame_rate (Hz), frame_count, pwm[16] (µs)   40 bytes
    <HHI32H   magic 29569, frame_rate (Hz), frame_count, pwm[32] (µs)   72 bytes

Channels 1–8 drive the eight thrusters in ArduSub motor order; 0 ("no
output") is taken as neutral, 1500 µs.

Lockstep
--------
* The first packet of a session (the first the server receives, or one that
  restarts the world) is a *hello*: it is answered with the state at t = 0 and
  the world is not stepped; its PWM is not applied.
* Every later packet with a higher frame_count holds its PWM for
  1/frame_rate s, advances the world once, and is answered with the new state.
  A jump of more than one counts the frames in between as missed (the world
  still steps once).
* The same frame_count again (a retransmission) re-sends the last reply
  without stepping.
* A frame_count that goes backwards, or a change of frame_rate, restarts the
  world: a new plant from the factory, at t = 0, and the packet is a hello.
* Malformed packets (size, magic, frame_rate outside 1…``MAX_FRAME_RATE_HZ``,
  a thruster channel that is neither 0 nor within ``PWM_RANGE_US``) are
  counted and dropped: no reply, no change to the world.

The server does no real-time pacing: the autopilot paces, the world follows.
"""
from __future__ import annotations

import argparse
import errno
import json
import math
import signal
import socket
import struct
import sys
import threading
import time
from dataclasses import asdict, dataclass
from typing import Callable, Sequence

import numpy as np

__all__ = [
    "PhysicsServer",
    "ServerCounters",
    "PortInUseError",
    "MAGIC_16",
    "MAGIC_32",
    "SERVO_16",
    "SERVO_32",
    "MAX_FRAME_RATE_HZ",
    "PWM_RANGE_US",
    "state_message",
    "main",
]

MAGIC_16 = 18458
MAGIC_32 = 29569
SERVO_16 = struct.Struct("<HHI16H")     # 40 bytes
SERVO_32 = struct.Struct("<HHI32H")     # 72 bytes
THRUSTER_CHANNELS = 8
NEUTRAL_PWM = 1500
MAX_FRAME_RATE_HZ = 10000               # ArduPilot's SIM_RATE_HZ is typically 400–1200 Hz
PWM_RANGE_US = (500, 2500)              # a thruster channel must be 0 (no output) or within this
DEFAULT_PORT = 9002
_RECV_BYTES = 2048


class PortInUseError(OSError):
    """The UDP port is already bound by another process (or server)."""


@dataclass
class ServerCounters:
    """What the server has seen since it was created."""

    packets: int = 0        # datagrams received (valid or not)
    replies: int = 0        # JSON lines sent (including re-sent duplicates)
    restarts: int = 0       # world restarts (frame_count backwards or frame_rate change)
    duplicates: int = 0     # packets with the last frame_count again (reply re-sent, no step)
    missed: int = 0         # frame_counts skipped over (gaps)
    malformed: int = 0      # dropped: size, magic, rate or PWM range
    errors: int = 0         # packets the plant could not step or report (dropped, no reply)
    steps: int = 0          # world steps taken
    stale: int = 0          # late (reordered) packets older than the newest one: dropped, no reply

    def as_dict(self) -> dict:
        return asdict(self)


def _floats(values) -> list[float]:
    return [float(v) for v in values]


def state_message(plant, frame_count: int | None = None) -> dict:
    """The JSON SITL state of a plant: ArduPilot's fields plus Wavekeep's exact planar state.

    ``imu.accel_body`` is the specific force in body FRD,
    [u̇ + q w + g sin θ, 0, ẇ − q u − g cos θ] (≈ [0, 0, −g] at rest), with ν̇
    from ``plant.nu_dot`` (zero right after a reset). ``velocity`` is J(η)ν in
    NED. ``wavekeep`` carries η, ν and the thrusts as exact floats, and the
    frame_count the message answers.
    """
    s = plant.state
    x, z, theta = (float(v) for v in s.eta)
    u, w, q = (float(v) for v in s.nu)
    du, dw, _dq = (float(v) for v in plant.nu_dot)
    g = float(plant.vehicle.g)
    st, ct = math.sin(theta), math.cos(theta)
    msg = {
        "timestamp": float(s.t),
        "imu": {
            "gyro": [0.0, q, 0.0],
            "accel_body": [du + q * w + g * st, 0.0, dw - q * u - g * ct],
        },
        "position": [x, 0.0, z],
        "velocity": [u * ct + w * st, 0.0, -u * st + w * ct],
        "attitude": [0.0, theta, 0.0],
        # Last, and with no key that ArduPilot's substring parser looks for
        # (timestamp, gyro, accel_body, position, attitude, quaternion, velocity, rng_N, ...).
        "wavekeep": {"eta": [x, z, theta], "nu": [u, w, q], "thrust": _floats(s.thrust)},
    }
    if frame_count is not None:
        msg["wavekeep"]["frame_count"] = int(frame_count)
    return msg


def encode_message(msg: dict) -> bytes:
    """One JSON line, preceded and terminated by a newline as ArduPilot's reader expects.

    Compact separators: older ArduPilot parsers read vectors with
    ``sscanf("[%f, %f, %f]")`` right after ``"key":``, so there must be no space
    before the ``[``. Python's float repr round-trips exactly.
    """
    return b"\n" + json.dumps(msg, separators=(",", ":"), allow_nan=False).encode("ascii") + b"\n"


def decode_servo_packet(data: bytes) -> tuple[int, int, np.ndarray] | None:
    """(frame_rate, frame_count, pwm[8] as float µs) of a valid servo packet, or None."""
    if len(data) == SERVO_16.size:
        fields = SERVO_16.unpack(data)
        magic = MAGIC_16
    elif len(data) == SERVO_32.size:
        fields = SERVO_32.unpack(data)
        magic = MAGIC_32
    else:
        return None
    if fields[0] != magic:
        return None
    rate, count = fields[1], fields[2]
    if not 1 <= rate <= MAX_FRAME_RATE_HZ:
        return None
    pwm = np.array(fields[3:3 + THRUSTER_CHANNELS], dtype=float)
    lo, hi = PWM_RANGE_US
    if np.any((pwm != 0) & ((pwm < lo) | (pwm > hi))):
        return None
    pwm[pwm == 0] = NEUTRAL_PWM
    return rate, count, pwm


MAX_CATCH_UP = 100
"""At most this many steps to catch up on a gap in frame_count (2 s at 50 Hz)."""

RESTART_MAX_COUNT = 10
"""A frame_count that goes backwards to at most this restarts the world; one that goes backwards
but stays above it is a late (reordered) datagram and is dropped (``stale``)."""


class _Stale(Exception):
    """A reordered servo packet older than the newest one."""


class PhysicsServer:
    """A plant behind ArduPilot's JSON SITL protocol.

    ``plant_factory()`` returns a fresh plant (``state``, ``nu_dot``,
    ``vehicle.g``, ``step(pwm[8], dt)``); it is called once here and again on
    every restart. The socket is bound at construction (``port=0`` picks a free
    port, read it back from :attr:`port`). Serve with :meth:`serve_forever` in
    the calling thread, or :meth:`start` / :meth:`stop` (also a context
    manager) in a background thread.
    """

    def __init__(self, plant_factory: Callable[[], object], host: str = "127.0.0.1", port: int = DEFAULT_PORT,
                 poll_s: float = 0.1):
        self.plant_factory = plant_factory
        self.host = host
        self.poll_s = float(poll_s)
        self.counters = ServerCounters()
        self._lock = threading.Lock()           # guards the world against concurrent readers
        self.plant = plant_factory()
        self._session = False                   # a hello has been answered for the current plant
        self._rate = 0
        self._last_count = 0
        self._last_reply: bytes | None = None
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            self._sock.bind((host, int(port)))
        except OSError as exc:
            self._sock.close()
            if exc.errno == errno.EADDRINUSE:
                raise PortInUseError(exc.errno, f"port {port} is in use: {exc.strerror} "
                                                f"(is another physics server or simulator running?)") from exc
            raise
        self._sock.settimeout(self.poll_s)
        self.port: int = self._sock.getsockname()[1]
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()

    # ------------------------------------------------------------------ protocol
    def handle(self, data: bytes, addr) -> bytes | None:
        """Process one datagram; returns the reply sent to ``addr`` (None if dropped)."""
        c = self.counters
        c.packets += 1
        pkt = decode_servo_packet(data)
        if pkt is None:
            c.malformed += 1
            return None
        rate, count, pwm = pkt
        with self._lock:
            try:
                reply = self._advance(rate, count, pwm)
            except _Stale:
                return None
            except Exception:   # a plant failure must not take the server down
                c.errors += 1
                return None
        c.replies += 1          # counted before sending, so a client that has the reply sees the count
        try:
            self._sock.sendto(reply, addr)
        except OSError:
            c.replies -= 1
            c.errors += 1
            return None
        return reply

    def _advance(self, rate: int, count: int, pwm: np.ndarray) -> bytes:
        c = self.counters
        if self._session and count < self._last_count and count > RESTART_MAX_COUNT and rate == self._rate:
            # Older than the newest frame but not a restart (an autopilot restarts counting from 0):
            # a late, reordered datagram. Stepping or restarting on it would corrupt the world.
            c.stale += 1
            raise _Stale
        if self._session and (rate != self._rate or count < self._last_count):
            self.plant = self.plant_factory()
            self._session = False
            c.restarts += 1
        if not self._session:
            # hello: the state at t = 0, not stepped; this packet's PWM is not applied
            self._session, self._rate = True, rate
        elif count == self._last_count:
            c.duplicates += 1
            return self._last_reply
        else:
            # Lockstep time is frame_count / frame_rate: frames lost on the way still passed on
            # the autopilot's clock, so the world catches up (under this packet's PWM, the
            # newest known) instead of falling behind the autopilot for good.
            gap = count - self._last_count
            c.missed += gap - 1
            for _ in range(min(gap, MAX_CATCH_UP)):
                self.plant.step(pwm, 1.0 / rate)
                c.steps += 1
        reply = encode_message(state_message(self.plant, count))
        self._last_count = count
        self._last_reply = reply
        return reply

    # ------------------------------------------------------------------ serving
    def serve_forever(self, stop_event: threading.Event | None = None) -> None:
        """Answer servo packets until ``stop_event`` is set (checked every ``poll_s``)."""
        stop = stop_event if stop_event is not None else self._stop
        sock = self._sock
        while not stop.is_set():
            try:
                data, addr = sock.recvfrom(_RECV_BYTES)
            except (socket.timeout, BlockingIOError, InterruptedError):
                continue
            except ConnectionError:     # ICMP unreachable from an earlier reply (some platforms)
                continue
            except OSError:
                if sock.fileno() < 0:   # closed under us
                    return
                raise
            self.handle(data, addr)

    def start(self) -> "PhysicsServer":
        """Serve in a daemon thread."""
        if self._thread is not None and self._thread.is_alive():
            return self
        self._stop.clear()
        self._thread = threading.Thread(target=self.serve_forever, args=(self._stop,),
                                        name=f"physics-server:{self.port}", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        """Stop the thread (if any) and release the port."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
            self._thread = None
        self.close()

    def close(self) -> None:
        self._sock.close()

    def __enter__(self) -> "PhysicsServer":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()

    # ------------------------------------------------------------------ inspection
    def snapshot(self):
        """A copy of the world's current state (thread-safe)."""
        with self._lock:
            return self.plant.state.copy()

    @property
    def address(self) -> tuple[str, int]:
        return (self.host, self.port)


# ---------------------------------------------------------------------- command line
class _RecordingPlant:
    """A plant that logs its truth after every step and drives the buoy publisher (``wavekeep plant``)."""

    def __init__(self, plant, rows: list | None, buoy):
        self._plant, self._rows, self._buoy = plant, rows, buoy
        self._record()

    def __getattr__(self, name):
        return getattr(self._plant, name)

    def _record(self) -> None:
        s = self._plant.state
        if self._rows is not None:
            # wall_s: when the plant was asked for this state — an outside observer of the firmware's timing
            self._rows.append([s.t, *s.eta, *s.nu, *self._plant.tau_E, time.monotonic()])
        if self._buoy is not None:
            self._buoy.advance(s.t)

    def step(self, pwm, dt):
        out = self._plant.step(pwm, dt)
        self._record()
        return out



def main(argv: Sequence[str] | None = None) -> int:
    """``wavekeep plant --case W3 [--seed N] [--port 9002] [--host 127.0.0.1]``."""
    from bridge.configfile import ConfigError

    from .plant import Plant
    from .sea import Sea

    ap = argparse.ArgumentParser(prog="wavekeep plant",
                                 description="Serve the simulated sea and vehicle over ArduPilot's JSON SITL "
                                             "protocol (UDP, lockstep).")
    ap.add_argument("--case", default="W3", help="sea state: a name in configs/sea/ (W1, W2, W3) or a YAML path")
    ap.add_argument("--seed", type=int, default=None, help="override the sea config's seed")
    ap.add_argument("--mission", default="station_keeping", help="mission config name or path")
    ap.add_argument("--vehicle", default="bluerov2_heavy", help="vehicle config name or path")
    ap.add_argument("--host", default="127.0.0.1", help="address to listen on")
    ap.add_argument("--port", type=int, default=DEFAULT_PORT, help="UDP port to listen on (0: any free port)")
    ap.add_argument("--log", default=None, help="write the truth (t, η, ν, τ_E) after every step to this CSV at exit")
    ap.add_argument("--buoy-network", default=None,
                    help="publish the wave buoy's record on zenoh (network config name or path)")
    args = ap.parse_args(argv)

    rows: list[list[float]] = []
    session = buoy = None
    try:
        sea = Sea.load(args.case, seed=args.seed)
        if args.buoy_network:
            from bridge.zenoh_net import load_network_config, open_session
            from .buoy_publisher import BuoyPublisher
            net = load_network_config(args.buoy_network)
            session = open_session(net, "plant")
            buoy = BuoyPublisher(session, net["site"], sea)

        def factory():
            plant = Plant.from_configs(sea, args.vehicle, args.mission)
            if not (args.log or buoy):
                return plant
            rows.clear()
            if buoy is not None:
                buoy.reset()
            return _RecordingPlant(plant, rows if args.log else None, buoy)

        server = PhysicsServer(factory, args.host, args.port)
    except (ConfigError, FileNotFoundError, ValueError) as exc:
        print(f"wavekeep plant: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"wavekeep plant: {exc.strerror if isinstance(exc, PortInUseError) else exc}", file=sys.stderr)
        return 2

    stop = threading.Event()
    previous = {}

    def _on_signal(signum, _frame):
        stop.set()

    for sig in (signal.SIGINT, signal.SIGTERM):
        previous[sig] = signal.signal(sig, _on_signal)
    try:
        print(f"wavekeep plant: ready on udp {args.host}:{server.port} (case {sea.name}, seed {sea.seed})",
              flush=True)
        server.serve_forever(stop)
    finally:
        server.close()
        if buoy is not None:
            buoy.close()
        if session is not None:
            session.close()
        if args.log:
            header = "t,x,z,theta,u,w,q,tauE_X,tauE_Z,tauE_M,wall_s"
            np.savetxt(args.log, np.array(rows).reshape(-1, 11), delimiter=",", header=header, comments="",
                       fmt="%.17g")
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    counts = " ".join(f"{k}={v}" for k, v in server.counters.as_dict().items())
    print(f"wavekeep plant: stopped; {counts}", flush=True)
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
