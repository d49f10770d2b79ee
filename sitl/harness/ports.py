"""Loopback ports for runs, tests and benchmarks."""
from __future__ import annotations

import socket

__all__ = ["free_port"]


def free_port(kind: int = socket.SOCK_DGRAM) -> int:
    """A port on 127.0.0.1 that is free now for ``kind`` (UDP by default; ``socket.SOCK_STREAM`` for TCP).

    The OS picks it; another process could take it before it is used, which on
    loopback in a test is rare enough to accept.
    """
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])
