"""MAVLink endpoints: one class per kind, behind one small interface the link's I/O thread uses.

The endpoint syntax is pymavlink's: ``udpout:HOST:PORT`` (send to a GCS from an
ephemeral port, hear its replies there), ``udpin:HOST:PORT`` (listen; reply to
the peers heard from), ``tcp:HOST:PORT`` (client; reconnects every second) and
``tcpin:HOST:PORT`` (serve one client; a new connection replaces the old).

Every transport is owned by the I/O thread once the link has started. UDP
datagrams are parsed one at a time (a truncated frame cannot eat the next
datagram: :attr:`Transport.datagram`); TCP is a byte stream.
"""
from __future__ import annotations

import contextlib
import errno
import socket
import time
from abc import ABC, abstractmethod
from collections import OrderedDict
from collections.abc import Callable, MutableMapping

from .wire import mavlink

__all__ = ["KINDS", "TcpClient", "TcpServer", "Transport", "UdpIn", "UdpOut", "make_transport"]

Feed = Callable[["Transport", bytes], None]
"""Where a transport hands the bytes it read: ``feed(transport, data)``."""


def _reset_parser(mav: mavlink.MAVLink) -> None:
    """Forget any partial frame in a pymavlink parser (after a reconnect or a bad datagram)."""
    mav.buf = bytearray()
    mav.buf_index = 0
    mav.expected_length = mavlink.HEADER_LEN_V1 + 2
    mav.have_prefix_error = False


class Transport(ABC):
    """What every endpoint kind provides to the link.

    Parameters
    ----------
    url : str
        The endpoint as given (for messages).
    host : str
        Host name or address.
    port : int
        Port number.
    index : int
        Position of the endpoint in the link (its MAVLink 2 signing link id).
    counters : dict
        The link's counters; a transport increments ``io_errors``, ``tx_errors``, ``tx_dropped``.
    """

    datagram = False                   # True: each read is one datagram, parsed on its own
    MAX_PENDING = 256 * 1024           # bytes queued on a slow TCP peer before messages are dropped

    def __init__(self, url: str, host: str, port: int, index: int, counters: MutableMapping[str, int]):
        self.url, self.host, self.port, self.index = url, host, port, index
        self.counters = counters
        self.mav: mavlink.MAVLink | None = None   # set by the link: parser, sequence numbers, signing
        self.error: str | None = None

    def reset_parser(self) -> None:
        """Drop any partial frame from this endpoint's parser."""
        if self.mav is not None:
            _reset_parser(self.mav)

    @abstractmethod
    def open(self) -> None:
        """Open the socket(s); raises OSError (e.g. a port in use)."""

    @abstractmethod
    def close(self) -> None:
        """Close every socket. Idempotent."""

    @abstractmethod
    def read_sockets(self) -> list[socket.socket]:
        """Sockets to wait on for reading."""

    def write_sockets(self) -> list[socket.socket]:
        """Sockets with queued bytes to wait on for writing (TCP only)."""
        return []

    @abstractmethod
    def on_readable(self, sock: socket.socket, feed: Feed) -> None:
        """Read what ``sock`` holds and hand it to ``feed``."""

    def on_writable(self, sock: socket.socket) -> None:  # noqa: B027 (a hook: only TCP has queued bytes)
        """Write queued bytes (TCP only)."""

    def housekeeping(self, now: float) -> None:  # noqa: B027 (a hook: most transports have none)
        """Once a second (monotonic s): reconnect, expire peers."""

    @abstractmethod
    def can_send(self) -> bool:
        """True when a message sent now has somewhere to go."""

    @abstractmethod
    def send(self, buf: bytes) -> bool:
        """Send one packed frame; False if it could not be sent (counted)."""


def _close(*socks: socket.socket | None) -> None:
    for s in socks:
        if s is not None:
            with contextlib.suppress(OSError):
                s.close()


class _Udp(Transport):
    datagram = True

    def __init__(self, *args, **kw):
        super().__init__(*args, **kw)
        self.sock: socket.socket | None = None

    def _socket(self) -> tuple[socket.socket, tuple]:
        addr = socket.getaddrinfo(self.host, self.port, socket.AF_INET, socket.SOCK_DGRAM)[0][4]
        s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        s.setblocking(False)
        return s, addr

    def close(self) -> None:
        _close(self.sock)
        self.sock = None

    def read_sockets(self) -> list[socket.socket]:
        return [self.sock] if self.sock is not None else []

    def heard(self, addr: tuple) -> None:
        """A datagram came from ``addr``."""

    def on_readable(self, sock: socket.socket, feed: Feed) -> None:
        for _ in range(256):
            try:
                data, addr = sock.recvfrom(65536)
            except (BlockingIOError, InterruptedError):
                return
            except OSError as exc:      # e.g. ECONNREFUSED from an earlier send: not fatal
                if exc.errno not in (errno.ECONNREFUSED, errno.ECONNRESET):
                    self.counters["io_errors"] += 1
                continue
            self.heard(addr)
            feed(self, data)

    def _sendto(self, buf: bytes, addr: tuple) -> bool:
        if self.sock is None:
            return False
        try:
            self.sock.sendto(buf, addr)
            return True
        except OSError:
            self.counters["tx_errors"] += 1
            return False


class UdpOut(_Udp):
    """``udpout:HOST:PORT``: sends to the GCS from an ephemeral port and hears its replies there."""

    def open(self) -> None:
        self.sock, self.dest = self._socket()

    def can_send(self) -> bool:
        return self.sock is not None

    def send(self, buf: bytes) -> bool:
        return self._sendto(buf, self.dest)


class UdpIn(_Udp):
    """``udpin:HOST:PORT``: listens, and replies to the last :attr:`MAX_PEERS` peers it heard from."""

    MAX_PEERS = 8

    def __init__(self, *args, **kw):
        super().__init__(*args, **kw)
        self.peers: OrderedDict = OrderedDict()       # address → last heard (monotonic s)

    def open(self) -> None:
        s, addr = self._socket()
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind(addr)
        except OSError:
            s.close()
            raise
        self.sock = s

    def heard(self, addr: tuple) -> None:
        self.peers[addr] = time.monotonic()
        self.peers.move_to_end(addr)
        while len(self.peers) > self.MAX_PEERS:
            self.peers.popitem(last=False)

    def can_send(self) -> bool:
        return self.sock is not None and bool(self.peers)

    def send(self, buf: bytes) -> bool:
        ok = False
        for addr in list(self.peers):
            ok = self._sendto(buf, addr) or ok
        return ok


class _Tcp(Transport, ABC):
    """A TCP byte stream with a bounded queue of bytes the peer has not taken yet."""

    def __init__(self, *args, **kw):
        super().__init__(*args, **kw)
        self.pending = bytearray()

    @abstractmethod
    def stream(self) -> socket.socket | None:
        """The connected socket, if any."""

    @abstractmethod
    def drop_stream(self) -> None:
        """Close the connection (the peer left or failed)."""

    def can_send(self) -> bool:
        return self.stream() is not None

    def write_sockets(self) -> list[socket.socket]:
        s = self.stream()
        return [s] if self.pending and s is not None else []

    def on_writable(self, sock: socket.socket) -> None:
        self.send(b"")

    def _recv(self, sock: socket.socket, feed: Feed) -> None:
        for _ in range(64):
            try:
                data = sock.recv(65536)
            except (BlockingIOError, InterruptedError):
                return
            except OSError:
                self.drop_stream()
                return
            if not data:                    # EOF
                self.drop_stream()
                self.reset_parser()
                return
            feed(self, data)

    def send(self, buf: bytes) -> bool:
        s = self.stream()
        if s is None:
            return False
        if len(self.pending) + len(buf) > self.MAX_PENDING:
            self.counters["tx_dropped"] += 1
            return False
        self.pending += buf
        try:
            n = s.send(self.pending)
        except (BlockingIOError, InterruptedError):
            return True
        except OSError:
            self.drop_stream()
            return False
        del self.pending[:n]
        return True


def _tune(s: socket.socket) -> socket.socket:
    s.setblocking(False)
    s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    return s


class TcpClient(_Tcp):
    """``tcp:HOST:PORT``: connects to a server; while it is away, tries again every second."""

    RETRY_S = 1.0

    def __init__(self, *args, **kw):
        super().__init__(*args, **kw)
        self.sock: socket.socket | None = None
        self.next_retry = 0.0

    def open(self) -> None:
        self.try_connect()

    def try_connect(self) -> bool:
        """One connection attempt (≤ 0.5 s); False and a retry in :attr:`RETRY_S` if it fails."""
        self.next_retry = time.monotonic() + self.RETRY_S
        try:
            s = socket.create_connection((self.host, self.port), timeout=0.5)
        except OSError as exc:
            self.error = repr(exc)
            return False
        self.sock = _tune(s)
        self.pending.clear()
        self.error = None
        self.reset_parser()
        return True

    def housekeeping(self, now: float) -> None:
        if self.sock is None and now >= self.next_retry:
            self.try_connect()

    def stream(self) -> socket.socket | None:
        return self.sock

    def drop_stream(self) -> None:
        _close(self.sock)
        self.sock = None
        self.next_retry = time.monotonic() + self.RETRY_S
        self.pending.clear()

    def close(self) -> None:
        _close(self.sock)
        self.sock = None

    def read_sockets(self) -> list[socket.socket]:
        return [self.sock] if self.sock is not None else []

    def on_readable(self, sock: socket.socket, feed: Feed) -> None:
        self._recv(sock, feed)


class TcpServer(_Tcp):
    """``tcpin:HOST:PORT``: serves one client; the newest connection wins (a GCS that reconnects)."""

    def __init__(self, *args, **kw):
        super().__init__(*args, **kw)
        self.listener: socket.socket | None = None
        self.client: socket.socket | None = None

    def open(self) -> None:
        s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        try:
            s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            s.bind((self.host, self.port))
            s.listen(1)
        except OSError:
            s.close()
            raise
        s.setblocking(False)
        self.listener = s

    def stream(self) -> socket.socket | None:
        return self.client

    def drop_stream(self) -> None:
        _close(self.client)
        self.client = None
        self.pending.clear()

    def close(self) -> None:
        _close(self.client, self.listener)
        self.client = self.listener = None

    def read_sockets(self) -> list[socket.socket]:
        return [s for s in (self.listener, self.client) if s is not None]

    def on_readable(self, sock: socket.socket, feed: Feed) -> None:
        if sock is not self.listener:
            self._recv(sock, feed)
            return
        try:
            conn, _addr = sock.accept()
        except OSError:
            return
        self.drop_stream()
        self.client = _tune(conn)
        self.reset_parser()


KINDS: dict[str, type[Transport]] = {"udpout": UdpOut, "udpin": UdpIn, "tcp": TcpClient, "tcpin": TcpServer}
"""Endpoint kind (the URL's scheme) → its transport class."""


def make_transport(url: str, index: int, counters: MutableMapping[str, int]) -> Transport:
    """The transport for one endpoint URL; ``ValueError`` saying what is wrong with a bad one.

    Parameters
    ----------
    url : str
        ``KIND:HOST:PORT`` with KIND one of :data:`KINDS`.
    index : int
        Position of the endpoint in the link.
    counters : dict
        The link's counters (shared).
    """
    kind, sep, rest = url.partition(":")
    host, sep2, port = rest.rpartition(":")
    if kind not in KINDS or not sep or not sep2 or not host:
        raise ValueError(f"MAVLink endpoint {url!r}: expected udpout:HOST:PORT, udpin:HOST:PORT, "
                         f"tcp:HOST:PORT or tcpin:HOST:PORT")
    try:
        port_n = int(port)
    except ValueError:
        raise ValueError(f"MAVLink endpoint {url!r}: port {port!r} is not a number") from None
    if not 0 <= port_n <= 65535 or (kind in ("udpout", "tcp") and port_n == 0):
        raise ValueError(f"MAVLink endpoint {url!r}: port out of range")
    return KINDS[kind](url, host, port_n, index, counters)
