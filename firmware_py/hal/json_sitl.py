"""The SITL HAL over ArduPilot's JSON SITL protocol: the firmware talks to a physics server by UDP.

The autopilot side of ``docs/json_sitl.md``. :meth:`JSONSITLHAL.write_pwm`
sends the eight thruster PWMs as an ArduPilot servo packet and waits for the
physics server's JSON state reply (lockstep, as ArduPilot's SITL does);
:meth:`JSONSITLHAL.read_sensors` turns the newest state into a
:class:`~firmware_py.hal.sensors.SensorFrame` through the same
:class:`~firmware_py.hal.sensors.SimulatedSensors` (same seed, same noise
sequence) as the in-process HAL. This module never imports the simulator.

Packet sequence (frame_count n, period h)::

    start():        hello   n = 0, neutral PWM  → state at t = 0 (not stepped)
    tick k (t = kh): read_sensors()              → state at kh (from the last reply)
                    write_pwm(PWM_k)  n = k + 1  → the world holds PWM_k over [kh, (k+1)h],
                                                   replies with the state at (k+1)h

Silent plant: a reply that does not come within ``timeout_s`` (wall time)
makes the following frames unhealthy (``healthy=False``, readings NaN), so the
firmware goes neutral; the HAL keeps sending at the loop rate and recovers on
the first fresh reply. If the physics time goes backwards (the server
restarted), the vehicle's time carries on from where it was, as ArduPilot's
SITL does.
"""
from __future__ import annotations

import math
import select
import socket
import time
from dataclasses import dataclass

import numpy as np

from bridge.json_sitl import decode_state, servo_packet
from bridge.models.thrusters import NEUTRAL_PWM_US

from ..params.table import ParameterTable
from .base import HAL, PWM_CHANNELS
from .clocks import Clock, LockstepPacedClock, SimClock
from .sensors import SensorFrame, SimulatedSensors

__all__ = ["DEFAULT_TIMEOUT_S", "JSONSITLHAL", "HALCounters", "JSONState"]

DEFAULT_TIMEOUT_S = 0.5          # wall seconds without a reply before the plant counts as silent
TIMEOUT_PARAM = "SIM_JSON_TMO"   # used instead of the default if the parameter table defines it
_RECV_BYTES = 65536
_REFUSED_RETRY_S = 0.005         # wall seconds between tries while nothing listens at the plant's port


@dataclass(frozen=True)
class JSONState:
    """One decoded reply: the physics state and the vehicle time it maps to."""

    t: float                     # vehicle time (s): physics timestamp + offset after physics resets
    timestamp: float             # physics time (s) as sent
    eta: np.ndarray              # [x, z, θ]
    nu: np.ndarray               # [u, w, q]
    thrust: np.ndarray | None    # per-thruster thrust (N) when the server sends it
    frame_count: int | None      # the servo frame this answers, when the server says
    accel: np.ndarray | None = None   # specific force [f_x, f_z] (m/s², body FRD): the IMU's imu.accel_body
    pressure_depth: float | None = None   # p/(ρ g) (m) the depth sensor reads, when the world models it
    lateral: np.ndarray | None = None     # a six-DoF world's [y, φ, ψ, v, p, r] (m, rad, m/s, rad/s)


@dataclass
class HALCounters:
    sent: int = 0                # servo packets sent (hello included)
    replies: int = 0             # fresh replies used
    timeouts: int = 0            # packets whose reply did not come within the wait
    malformed: int = 0           # replies that were not valid JSON state
    stale: int = 0               # valid replies to an older packet (dropped)
    physics_resets: int = 0      # physics time went backwards
    send_errors: int = 0         # sendto failed (e.g. nothing listening)
    silences: int = 0            # times the plant went silent (healthy → unhealthy)


class JSONSITLHAL(HAL):
    """Lockstep HAL over UDP to an ArduPilot JSON SITL physics server.

    Parameters
    ----------
    address : (host, port)
        The physics server (ArduPilot's default is 127.0.0.1:9002).
    params : ParameterTable
        For the simulated sensors' ``SIM_*`` noise (and ``SIM_JSON_TMO`` if defined).
    period_s : float
        Control period; the servo packets carry ``frame_rate = round(1/period_s)`` Hz,
        which must be a whole number of Hz.
    sensor_seed : int
        Seed of the sensor noise (the in-process HAL's, for identical runs).
    clock : Clock, optional
        Default: a :class:`SimClock` moved to each reply's time (runs as fast as the
        plant answers). A clock given here is used as is: the caller keeps its
        time equal to the plant's (see ``speedup``).
    speedup : float, optional
        Pace on the wall clock, ``speedup`` times real time, with a
        :class:`~firmware_py.hal.scheduler.LockstepPacedClock` (ignored if ``clock`` is given):
        lockstep time, moved by the replies, its slots waited for on the wall clock.
    timeout_s : float, optional
        Wall seconds to wait for a reply before the plant counts as silent
        (default ``SIM_JSON_TMO`` if the table has it, else 0.5 s).
    """

    def __init__(self, address: tuple[str, int] = ("127.0.0.1", 9002), params: ParameterTable | None = None,
                 period_s: float = 0.05, sensor_seed: int = 0, clock: Clock | None = None,
                 timeout_s: float | None = None, speedup: float | None = None):
        if params is None:
            raise ValueError("params is required (the simulated sensors' SIM_* noise)")
        if not (period_s > 0 and math.isfinite(period_s)):
            raise ValueError(f"period_s must be positive, got {period_s}")
        rate = 1.0 / period_s
        self.frame_rate = int(round(rate))
        if not 1 <= self.frame_rate <= 65535 or abs(rate - self.frame_rate) > 1e-6 * rate:
            raise ValueError(f"the loop rate must be a whole number of Hz for the JSON SITL frame_rate, "
                             f"got {rate:g} Hz")
        if timeout_s is None:
            timeout_s = params.get(TIMEOUT_PARAM, DEFAULT_TIMEOUT_S)
        if not timeout_s > 0:
            raise ValueError(f"timeout_s must be positive, got {timeout_s}")
        self.address = (address[0], int(address[1]))
        self.params = params
        self.period_s = float(period_s)
        self.timeout_s = float(timeout_s)
        if clock is None:
            clock = SimClock(0) if speedup is None else LockstepPacedClock(speedup)
        self.clock = clock
        self.sensors = SimulatedSensors(params, sensor_seed)
        self.counters = HALCounters()
        self.frame_count = 0
        self.last_pwm = np.full(PWM_CHANNELS, NEUTRAL_PWM_US, dtype=np.int64)
        self.state: JSONState | None = None      # newest fresh state
        self.silent = True                        # no fresh state for the last packet
        self._offset = 0.0                        # vehicle time − physics time (changes on physics resets)
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._sock.bind(("0.0.0.0" if self.address[0] not in ("127.0.0.1", "localhost") else "127.0.0.1", 0))
        self._sock.connect(self.address)
        self._sock.setblocking(False)
        self._readable = select.poll()
        self._readable.register(self._sock, select.POLLIN)
        self._closed = False

    # ------------------------------------------------------------------ lifecycle
    def start(self, timeout_s: float | None = None) -> JSONState:
        """Say hello (frame 0, neutral PWM) and wait for the state at t = 0.

        The hello is re-sent every ``self.timeout_s`` until ``timeout_s``
        (default: the larger of 2 s and 4 × ``self.timeout_s``) has passed;
        then :class:`TimeoutError`. A hello refused outright (nothing listening
        yet: a plant still starting) is re-sent after a few ms rather than after
        ``self.timeout_s``, so the first state comes as soon as the plant is up.
        """
        total = max(2.0, 4.0 * self.timeout_s) if timeout_s is None else float(timeout_s)
        deadline = time.monotonic() + total
        self.frame_count = 0
        while True:
            self._send(np.full(PWM_CHANNELS, NEUTRAL_PWM_US))
            wait = min(self.timeout_s, deadline - time.monotonic())
            if wait > 0 and self._await_reply(wait, until_refused=True) and self.state is not None:
                return self.state
            if time.monotonic() >= deadline:
                raise TimeoutError(f"no JSON SITL physics server answered at udp {self.address[0]}:"
                                   f"{self.address[1]} within {total:g} s (start it with `wavekeep plant`)")

    def close(self) -> None:
        if not self._closed:
            self._closed = True
            self._sock.close()

    def __enter__(self) -> JSONSITLHAL:
        self.start()
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # ------------------------------------------------------------------ HAL
    def read_sensors(self) -> SensorFrame:
        """Sensor readings from the newest state; unhealthy (NaN) while the plant is silent."""
        self._drain()
        s = self.state
        if self.silent or s is None:
            t = self.clock.now_ns() * 1e-9
            nan = math.nan
            return SensorFrame(t, nan, nan, nan, nan, healthy=False)
        return self.sensors.read(s.t, s.eta, s.nu, s.accel, s.pressure_depth, s.lateral)

    def write_pwm(self, pwm: np.ndarray) -> None:
        """Send the next servo frame and wait for the world to answer it (bounded)."""
        self.last_pwm = np.array(pwm, dtype=np.int64)
        self.frame_count += 1
        self._send(self.last_pwm)
        if not self.silent:
            wait = self.timeout_s
        elif self._simulated_clock():
            wait = min(self.timeout_s, self.period_s)   # pace a dead link at about the loop rate (wall)
        else:
            wait = 0.0                                  # the paced scheduler keeps the rate; poll next tick
        if not self._await_reply(wait):
            self.counters.timeouts += 1
            if not self.silent:
                self.counters.silences += 1
            self.silent = True

    # ------------------------------------------------------------------ internals
    def _simulated_clock(self) -> bool:
        """Lockstep time (moved by the replies) or a real clock? Checked each time: the clock may be swapped."""
        return bool(getattr(self.clock, "simulated", False))

    def _send(self, pwm) -> None:
        pkt = servo_packet(self.frame_rate, self.frame_count, np.asarray(pwm)[:PWM_CHANNELS])
        try:
            self._sock.send(pkt)
            self.counters.sent += 1
        except OSError:          # ECONNREFUSED from an earlier ICMP unreachable, or no route
            self.counters.send_errors += 1

    def _await_reply(self, wait_s: float, until_refused: bool = False) -> bool:
        """Wait up to ``wait_s`` (wall) for the reply to the current frame; True if it came.

        ``until_refused``: give up (after ``_REFUSED_RETRY_S``) if the packet was refused (ICMP port
        unreachable), instead of waiting out ``wait_s`` for a reply that cannot come.

        The socket stays non-blocking and the wait is one ``poll``: switching the socket's
        timeout for every wait cost two ``fcntl`` calls each time, twice a tick.
        """
        deadline = time.monotonic() + wait_s
        while True:
            remaining = deadline - time.monotonic()
            try:
                if remaining > 0 and not self._readable.poll(remaining * 1e3):
                    return False
                data = self._sock.recv(_RECV_BYTES)
            except (BlockingIOError, InterruptedError):
                if remaining > 0:            # woken without a datagram: wait out the rest
                    continue
                return False
            except ConnectionRefusedError:   # nothing listening (ICMP port unreachable): keep waiting
                if remaining <= 0:
                    return False
                time.sleep(min(remaining, _REFUSED_RETRY_S))
                if until_refused:
                    return False
                continue
            if self._accept(data):
                return True

    def _drain(self) -> None:
        """Take any replies already queued (a late answer ends a silence)."""
        while self._await_reply(0.0):
            pass

    def _accept(self, data: bytes) -> bool:
        """Decode one datagram; True if it is the fresh reply to the current frame (then it is the state)."""
        try:
            reply = decode_state(data)
        except (ValueError, KeyError, TypeError, IndexError):
            self.counters.malformed += 1
            return False
        ts, count = reply.timestamp, reply.frame_count
        if count is not None and count != self.frame_count:
            self.counters.stale += 1
            return False
        prev = self.state
        if prev is not None and ts + self._offset < prev.t:
            # the physics restarted: the vehicle's time carries on (ArduPilot: delta 0)
            self._offset = prev.t - ts
            self.counters.physics_resets += 1
        t = ts + self._offset
        self.state = JSONState(t, ts, reply.eta, reply.nu, reply.thrust, count, reply.accel, reply.pressure_depth,
                               reply.lateral)
        self.silent = False
        self.counters.replies += 1
        if self._simulated_clock():
            # floor: never past the slot the reply belongs to, so float round-off cannot fake an overrun
            # advance_to: move lockstep time without the pacing wait a paced clock's sleep_until does
            getattr(self.clock, "advance_to", self.clock.sleep_until)(math.floor(t * 1e9))
        return True
