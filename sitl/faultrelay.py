"""A fault-injecting UDP relay for tests: drop, delay, duplicate and reorder datagrams at set rates.

Put it between two endpoints that talk UDP (firmware ↔ plant, firmware ↔ GCS):
the client sends to the relay's port, the relay forwards to the target, and
the target's answers go back to the client's last address. Faults are drawn
from a seeded generator, per direction, so a test is repeatable up to the
operating system's own timing. Loopback only by default.
"""
from __future__ import annotations

import heapq
import itertools
import select
import socket
import threading
import time
from dataclasses import dataclass

import numpy as np

__all__ = ["FaultRelay", "Faults"]


@dataclass(frozen=True)
class Faults:
    """Rates in [0, 1] per datagram; delay in seconds (fixed, plus uniform jitter)."""

    drop: float = 0.0
    duplicate: float = 0.0
    reorder: float = 0.0
    delay_s: float = 0.0
    jitter_s: float = 0.0

    def __post_init__(self) -> None:
        for name in ("drop", "duplicate", "reorder"):
            v = getattr(self, name)
            if not 0.0 <= v <= 1.0:
                raise ValueError(f"{name} must be in [0, 1], got {v}")
        if self.delay_s < 0 or self.jitter_s < 0:
            raise ValueError("delay_s and jitter_s must be >= 0")


@dataclass
class _Stats:
    forwarded: int = 0
    dropped: int = 0
    duplicated: int = 0
    reordered: int = 0

    def as_dict(self) -> dict:
        return dict(self.__dict__)


class FaultRelay:
    """``with FaultRelay(("127.0.0.1", 9002), Faults(drop=0.1)) as relay: connect to relay.port``."""

    def __init__(self, target: tuple[str, int], faults: Faults = Faults(), reverse: Faults | None = None,
                 listen_host: str = "127.0.0.1", listen_port: int = 0, seed: int = 0):
        self.target = target
        self.faults = {"up": faults, "down": reverse if reverse is not None else faults}
        self.rng = {"up": np.random.default_rng([seed, 1]), "down": np.random.default_rng([seed, 2])}
        self.stats = {"up": _Stats(), "down": _Stats()}
        self._front = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._front.bind((listen_host, listen_port))
        self._back = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self._back.bind((listen_host, 0))
        self.port = self._front.getsockname()[1]
        self._client: tuple[str, int] | None = None
        self._queue: list = []                 # (release time, tie-break, socket, data, address)
        self._tie = itertools.count()
        self._held: dict[str, tuple | None] = {"up": None, "down": None}
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    # ------------------------------------------------------------------ fault logic
    def _schedule(self, direction: str, data: bytes) -> None:
        f, rng, st = self.faults[direction], self.rng[direction], self.stats[direction]
        sock, dest = (self._back, self.target) if direction == "up" else (self._front, self._client)
        if dest is None:
            return
        u = rng.random(4)
        if u[0] < f.drop:
            st.dropped += 1
            return
        copies = 2 if u[1] < f.duplicate else 1
        st.duplicated += copies - 1
        now = time.monotonic()
        release = now + f.delay_s + f.jitter_s * u[2]
        if u[3] < f.reorder and self._held[direction] is None:
            # Hold this one back until the next datagram in this direction has gone
            self._held[direction] = (sock, data, dest, copies)
            st.reordered += 1
            return
        for _ in range(copies):
            heapq.heappush(self._queue, (release, next(self._tie), sock, data, dest))
        held = self._held[direction]
        if held is not None:
            self._held[direction] = None
            hsock, hdata, hdest, hcopies = held
            for _ in range(hcopies):
                heapq.heappush(self._queue, (release + 1e-6, next(self._tie), hsock, hdata, hdest))

    def _flush(self) -> None:
        now = time.monotonic()
        while self._queue and self._queue[0][0] <= now:
            _, _, sock, data, dest = heapq.heappop(self._queue)
            try:
                sock.sendto(data, dest)
                self.stats["up" if sock is self._back else "down"].forwarded += 1
            except OSError:
                pass

    # ------------------------------------------------------------------ loop
    def _run(self) -> None:
        socks = [self._front, self._back]
        while not self._stop.is_set():
            timeout = 0.01
            if self._queue:
                timeout = max(0.0, min(timeout, self._queue[0][0] - time.monotonic()))
            try:
                ready, _, _ = select.select(socks, [], [], timeout)
            except (OSError, ValueError):
                return
            for s in ready:
                try:
                    data, addr = s.recvfrom(65535)
                except OSError:
                    continue
                if s is self._front:
                    self._client = addr
                    self._schedule("up", data)
                else:
                    self._schedule("down", data)
            self._flush()

    def start(self) -> FaultRelay:
        self._thread = threading.Thread(target=self._run, name=f"fault-relay:{self.port}", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(2.0)
        self._front.close()
        self._back.close()

    def __enter__(self) -> FaultRelay:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()

    def counters(self) -> dict:
        return {d: s.as_dict() for d, s in self.stats.items()}
