"""Loopback ports for runs, tests and benchmarks."""
from __future__ import annotations

import socket

__all__ = ["free_port", "port_is_free", "port_or_free"]


def free_port(kind: int = socket.SOCK_DGRAM) -> int:
    """A port on 127.0.0.1 that is free now for ``kind`` (UDP by default; ``socket.SOCK_STREAM`` for TCP).

    The OS picks it; another process could take it before it is used, which on
    loopback in a test is rare enough to accept.
    """
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def port_is_free(port: int, kind: int = socket.SOCK_DGRAM) -> bool:
    """Whether 127.0.0.1:``port`` can be bound now (UDP, or TCP with ``socket.SOCK_STREAM``)."""
    with socket.socket(socket.AF_INET, kind) as s:
        if kind == socket.SOCK_STREAM:
            s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind(("127.0.0.1", port))
        except OSError:
            return False
    return True


def port_or_free(port: int, kind: int = socket.SOCK_DGRAM) -> int:
    """``port`` if it is free now, else a free one the OS picks (a default port another program holds)."""
    return port if port_is_free(port, kind) else free_port(kind)
