"""The simulated world as an ArduPilot JSON SITL physics server (UDP, lockstep).

The autopilot (Wavekeep's :class:`firmware_py.hal.json_sitl.JSONSITLHAL`, or real
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
import signal
import socket
import sys
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from bridge.json_sitl import decode_servo_packet, encode_state

from .physics_rate import PhysicsHold, plant_state_message

__all__ = [
    "PhysicsServer",
    "PortInUseError",
    "ServerCounters",
    "main",
    "plant_state_message",
]

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
    manager) in a background thread. ``physics_rate_hz`` steps the plant at that rate when the autopilot's
    frames come faster (:class:`~sitl.physics_rate.PhysicsHold`); None: one step per frame.
    """

    def __init__(self, plant_factory: Callable[[], Any], host: str = "127.0.0.1", port: int = DEFAULT_PORT,
                 poll_s: float = 0.1, physics_rate_hz: float | None = None):
        self.plant_factory = plant_factory
        self.hold = PhysicsHold(physics_rate_hz)
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
        rate, count, pwm = pkt.frame_rate, pkt.frame_count, pkt.pwm
        with self._lock:
            try:
                reply = self._advance(rate, count, pwm)
            except _Stale:
                return None
            except Exception as exc:   # a plant failure must not take the server down …
                from .plant import PlantDiverged
                if isinstance(exc, PlantDiverged):
                    raise              # … unless the world itself has left physics: the run is over
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
            self.hold.start(rate)
        elif count == self._last_count and self._last_reply is not None:
            c.duplicates += 1
            return self._last_reply
        else:
            # Lockstep time is frame_count / frame_rate: frames lost on the way still passed on
            # the autopilot's clock, so the world catches up (under this packet's PWM, the
            # newest known) instead of falling behind the autopilot for good.
            gap = count - self._last_count
            c.missed += gap - 1
            for _ in range(min(gap, MAX_CATCH_UP)):
                c.steps += self.hold.frame(self.plant, pwm, rate)
        reply = encode_state(self.hold.message(self.plant, count))
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
            except (TimeoutError, BlockingIOError, InterruptedError):
                continue
            except ConnectionError:     # ICMP unreachable from an earlier reply (some platforms)
                continue
            except OSError:
                if sock.fileno() < 0:   # closed under us
                    return
                raise
            self.handle(data, addr)

    def start(self) -> PhysicsServer:
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

    def __enter__(self) -> PhysicsServer:
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
TRUTH_COLUMNS = ("t", "x", "z", "theta", "u", "w", "q", "tauE_X", "tauE_Z", "tauE_M", "wall_s",
                 "tau_X", "tau_Z", "tau_M", "y", "phi", "psi")
"""``wavekeep plant --log``'s columns: plant time (s), η, ν, the wave load, the wall clock (s, monotonic), the
thrusters' wrench [X, Z, M] (N, N m) and east (m), roll and yaw (rad; 0 in a planar world)."""


class _RecordingPlant:
    """A plant that logs its truth after every step (or every 1/``log_rate`` s) and drives the buoy publisher."""

    def __init__(self, plant, rows: list | None, buoy, log_rate: float | None = None):
        self._plant, self._rows, self._buoy, self._log_rate = plant, rows, buoy, log_rate
        self._record()

    def __getattr__(self, name):
        return getattr(self._plant, name)

    def _record(self) -> None:
        s = self._plant.state
        if self._rows is not None and self._on_log_grid(s.t):
            eta6 = self._plant.state.eta6
            lat = [float(eta6[1]), float(eta6[3]), float(eta6[5])]
            # wall_s: when the plant was asked for this state — an outside observer of the firmware's timing
            self._rows.append([s.t, *s.eta, *s.nu, *self._plant.tau_E, time.monotonic(), *self._plant.tau, *lat])
        if self._buoy is not None:
            self._buoy.advance(s.t - self._plant.sea_start)

    def _on_log_grid(self, t: float) -> bool:
        if self._log_rate is None:
            return True
        k = t * self._log_rate
        return abs(k - round(k)) < 1e-6

    def step(self, pwm, dt):
        out = self._plant.step(pwm, dt)
        self._record()
        return out



def _parser() -> argparse.ArgumentParser:
    """``wavekeep plant``'s options."""
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
    ap.add_argument("--sea-set", action="append", default=None, metavar="KEY=VALUE",
                    help="set one sea config key (repeatable), e.g. current.speed=0.3 (docs/sea-errors.md)")
    ap.add_argument("--true-vehicle", default=None, metavar="NAME",
                    help="plant-only vehicle override: a name in configs/vehicle/true/ or a path")
    # A foreign autopilot (real ArduSub SITL): docs/json_sitl.md
    ap.add_argument("--start", choices=("station", "surface"), default="station",
                    help="station: at the mission's station; surface: at rest at depth 0, held until the thrusters "
                         "run (an autopilot that zeroes its depth at boot, as ArduSub does, must boot there)")
    ap.add_argument("--sea-start", type=float, default=0.0, metavar="S",
                    help="still water until S s of plant time, then the sea from its t = 0 (time to boot and dive)")
    ap.add_argument("--six-dof", action="store_true",
                    help="the six-DoF world whatever the sea config's dof (an autopilot that holds heading and "
                         "position, as ArduSub)")
    ap.add_argument("--physics-rate", type=float, default=None, metavar="HZ",
                    help="step the plant at this rate when the autopilot's frames come faster (ArduSub: 1200 Hz); "
                         "default: once per frame")
    ap.add_argument("--log-rate", type=float, default=None, metavar="HZ",
                    help="--log only every 1/HZ s of plant time; default: every step")
    return ap


def main(argv: Sequence[str] | None = None) -> int:
    """``wavekeep plant --case W3 [--seed N] [--port 9002] [--host 127.0.0.1]``."""
    from bridge.configfile import ConfigError, parse_key_values
    from bridge.schemas import load_true_vehicle

    from .plant import Plant, PlantDiverged
    from .sea import Sea

    args = _parser().parse_args(argv)

    rows: list[list[float]] = []
    session = buoy = None
    try:
        sea = Sea.load(args.case, seed=args.seed, overrides=parse_key_values(args.sea_set))
        if args.true_vehicle:
            load_true_vehicle(args.true_vehicle)       # a bad override fails here, not at the first hello
        if args.buoy_network:
            from bridge.zenoh_net import load_network_config, open_session

            from .buoy_publisher import BuoyPublisher
            net = load_network_config(args.buoy_network)
            session = open_session(net, "plant")
            buoy = BuoyPublisher(session, net["site"], sea, clock_offset_s=args.sea_start)

        def factory():
            plant = Plant.from_configs(sea, args.vehicle, args.mission, args.true_vehicle, args.start,
                                       args.sea_start, "six" if args.six_dof else None)
            if not (args.log or buoy):
                return plant
            rows.clear()
            if buoy is not None:
                buoy.reset()
            return _RecordingPlant(plant, rows if args.log else None, buoy, args.log_rate)

        factory()          # a bad option fails here, not at the first hello
        server = PhysicsServer(factory, args.host, args.port, physics_rate_hz=args.physics_rate)
    except (ConfigError, FileNotFoundError, ValueError) as exc:
        print(f"wavekeep plant: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"wavekeep plant: {exc.strerror if isinstance(exc, PortInUseError) else exc}", file=sys.stderr)
        return 2

    stop = threading.Event()
    previous = {}
    status = 0

    def _on_signal(signum, _frame):
        stop.set()

    for sig in (signal.SIGINT, signal.SIGTERM):
        previous[sig] = signal.signal(sig, _on_signal)
    try:
        print(f"wavekeep plant: ready on udp {args.host}:{server.port} (case {sea.name}, seed {sea.seed})",
              flush=True)
        server.serve_forever(stop)
    except PlantDiverged as exc:
        print(f"wavekeep plant: {exc}", file=sys.stderr, flush=True)
        status = 3
    finally:
        server.close()
        if buoy is not None:
            buoy.close()
        if session is not None:
            session.close()
        if args.log:
            from bridge.logfile import save_csv_whole
            save_csv_whole(args.log, np.array(rows).reshape(-1, len(TRUTH_COLUMNS)), ",".join(TRUTH_COLUMNS))
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    counts = " ".join(f"{k}={v}" for k, v in server.counters.as_dict().items())
    print(f"wavekeep plant: stopped; {counts}", flush=True)
    return status


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
