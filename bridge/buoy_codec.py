"""Wire encoding of a wave buoy's elevation record, version 1.

Little-endian: magic ``b"WKBY"`` (4), version u16, reserved u16, sequence u64,
buoy position x_b f64 (m, NED north), sample interval dt f64 (s), time of the
first sample t0 f64 (s, the vehicle/simulation clock), N u32 (1 … 36000),
then N × f64 elevations ζ (m, up positive). The decoder checks every value and
raises :class:`BuoyDecodeError` with a reason.
"""
from __future__ import annotations

import math
import struct
from dataclasses import dataclass

import numpy as np

__all__ = ["BuoyDecodeError", "BuoyRecord", "decode_buoy", "encode_buoy"]

MAGIC = b"WKBY"
VERSION = 1
MAX_SAMPLES = 36000
_HEADER = struct.Struct("<4sHHQdddI")


class BuoyDecodeError(ValueError):
    def __init__(self, reason: str, detail: str = ""):
        self.reason = reason
        super().__init__(f"{reason}: {detail}" if detail else reason)


@dataclass(frozen=True)
class BuoyRecord:
    """ζ(x_b, t0 + i·dt) for i = 0 … N−1."""

    x: float
    dt: float
    t0: float
    eta: np.ndarray
    seq: int = 0

    @property
    def t(self) -> np.ndarray:
        return self.t0 + self.dt * np.arange(self.eta.size)


def encode_buoy(r: BuoyRecord) -> bytes:
    n = int(np.size(r.eta))
    if not 1 <= n <= MAX_SAMPLES:
        raise ValueError(f"a buoy record holds 1..{MAX_SAMPLES} samples, got {n}")
    return _HEADER.pack(MAGIC, VERSION, 0, int(r.seq), float(r.x), float(r.dt), float(r.t0), n) + \
        np.asarray(r.eta, dtype="<f8").tobytes()


def decode_buoy(payload) -> BuoyRecord:
    b = bytes(payload)
    if len(b) < _HEADER.size:
        raise BuoyDecodeError("truncated", f"{len(b)} bytes")
    magic, version, _, seq, x, dt, t0, n = _HEADER.unpack_from(b)
    if magic != MAGIC:
        raise BuoyDecodeError("bad_magic", repr(magic))
    if version != VERSION:
        raise BuoyDecodeError("bad_version", str(version))
    if not 1 <= n <= MAX_SAMPLES or len(b) != _HEADER.size + 8 * n:
        raise BuoyDecodeError("bad_length", f"{len(b)} bytes for {n} samples")
    if not (math.isfinite(x) and math.isfinite(t0) and math.isfinite(dt) and 0.0 < dt <= 60.0):
        raise BuoyDecodeError("bad_header", f"x={x}, dt={dt}, t0={t0}")
    eta = np.frombuffer(b, dtype="<f8", count=n, offset=_HEADER.size).copy()
    if not np.all(np.isfinite(eta)) or np.any(np.abs(eta) > 50.0):
        raise BuoyDecodeError("bad_values", "elevations must be finite and within ±50 m")
    return BuoyRecord(float(x), float(dt), float(t0), eta, int(seq))
