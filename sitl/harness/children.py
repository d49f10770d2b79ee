"""The launcher's child processes: started with their logs, waited for until ready, stopped so that each
finishes writing its log, and a Ctrl-C that leaves no half-written run folder behind.

Apart from :mod:`.launcher` so that ``wavekeep sim`` and ``sim --companion`` share them.
"""
from __future__ import annotations

import contextlib
import os
import shutil
import signal
import socket
import subprocess
import time
from pathlib import Path

from .ports import port_is_free

__all__ = ["Child", "LaunchError", "check_port", "interrupt_leaves_nothing", "stop_children", "wait_ready"]


class LaunchError(RuntimeError):
    def __init__(self, message: str, status: int = 1):
        super().__init__(message)
        self.status = status


def check_port(port: int, what: str, kind: int = socket.SOCK_DGRAM) -> None:
    """A clear error (exit status 2) if a loopback port the run needs is taken."""
    if not port_is_free(port, kind):
        proto = "TCP" if kind == socket.SOCK_STREAM else "UDP"
        raise LaunchError(f"{proto} port {port} ({what}) is in use: pick another with the --*-port options", 2)


class Child:
    """A child process whose stdout/stderr go to a log file; 'ready' is a line it prints."""

    def __init__(self, name: str, argv: list[str], log: Path, env: dict):
        self.name = name
        self.log_path = log
        self._log = open(log, "w")  # noqa: SIM115 — lives as long as the child; closed in stop()
        self.proc = subprocess.Popen(argv, stdout=self._log, stderr=subprocess.STDOUT, env=env,
                                     start_new_session=True)
        self.killed = False

    def ready(self) -> bool:
        try:
            return "ready" in self.log_path.read_text()
        except OSError:
            return False

    def alive(self) -> bool:
        return self.proc.poll() is None

    def stop(self, timeout: float = 120.0) -> int | None:
        """SIGTERM, then wait up to ``timeout`` (wall s) for the child to finish (it writes its log as it
        exits); only a child still running then is killed (``killed``: its log is not written)."""
        if self.alive():
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait(5)
                self.killed = True
        self._log.close()
        return self.proc.returncode

    def failure(self, timeout: float) -> str | None:
        """Why the stopped child counts as the run's failure (killed before its log was written, or a non-zero
        exit), or None."""
        if self.killed:
            return (f"{self.name} did not finish writing its log within {timeout:g} s of being told to stop "
                    "(a very busy machine?) and was killed: the run is incomplete")
        if self.proc.returncode != 0:
            return f"{self.name} exited with status {self.proc.returncode}:\n{self.tail()}"
        return None

    def tail(self, n: int = 8) -> str:
        try:
            return "\n".join(self.log_path.read_text().splitlines()[-n:])
        except OSError:
            return ""


def wait_ready(children: list[Child], timeout: float) -> None:
    end = time.monotonic() + timeout
    pending = list(children)
    while pending:
        for c in list(pending):
            if not c.alive():
                raise LaunchError(f"{c.name} exited with status {c.proc.returncode} before it was ready:\n{c.tail()}")
            if c.ready():
                pending.remove(c)
        if time.monotonic() > end:
            raise LaunchError(f"{', '.join(c.name for c in pending)} not ready after {timeout:g} s")
        time.sleep(0.05)


def stop_children(children: list[Child], timeout: float, interrupted: bool = False) -> dict[str, int | None]:
    """Stop every child (the last started first), each given ``timeout`` s to write its log and exit; their
    exit statuses. After a flight (not ``interrupted``), a child killed or failing is the run's failure: a
    :class:`LaunchError` naming it, never a short log found later."""
    statuses = {c.name: c.stop(timeout) for c in reversed(children)}
    if not interrupted:
        for c in children:
            why = c.failure(timeout)
            if why:
                raise LaunchError(why)
    return statuses


@contextlib.contextmanager
def interrupt_leaves_nothing(out: Path):
    """Ctrl-C (a :class:`LaunchError` with status 130, or a KeyboardInterrupt) removes what the run wrote
    in ``out`` — and ``out`` itself if the run created it — so no half-written folder is left; other
    failures keep their logs, for diagnosis."""
    created = not out.exists()
    before = set(out.iterdir()) if out.is_dir() else set()
    try:
        yield
    except (LaunchError, KeyboardInterrupt) as exc:
        if isinstance(exc, KeyboardInterrupt) or exc.status == 130:
            for f in set(out.iterdir()) - before if out.is_dir() else ():
                shutil.rmtree(f) if f.is_dir() else f.unlink(missing_ok=True)
            if created:
                with contextlib.suppress(OSError):
                    out.rmdir()
            raise LaunchError("interrupted", 130) from None
        raise
