"""Wire encoding of :class:`~bridge.forecast.Forecast`, versions 1 and 2 (docs/forecast.md).

A compact, language-neutral binary layout, all little-endian:

=======  ===========  ==========================================================
offset   type         field
=======  ===========  ==========================================================
0        4 bytes      magic ``b"WKFC"``
4        u16          schema version (1, or 2 when the components carry their directions)
6        u16          flags: bit 0 = the sender evaluates Stokes 2nd order; bit 1 = directions follow (v2)
8        u64          sequence number
16       u32          N, number of components (1 … 4096)
20       f64          water depth d (m)
28       f64          reference position x_ref (m, NED north)
36       f64          time base t_b (s, vehicle clock)
44       f64          valid_from (s, vehicle clock)
52       f64          valid_until (s, vehicle clock)
60       u8           L, length of the source name
61       L bytes      source name, UTF-8
61+L     N × f64      amplitude A_i (m)
…        N × f64      angular frequency ω_i (rad/s)
…        N × f64      wavenumber k_i (rad/m)
…        N × f64      phase φ_i (rad) at (x_ref, t_b)
…        N × u8       order of each component (1 linear; 2 with its Stokes self-interaction)
…        N × f64      version 2 with flag bit 1 only: direction of travel β_i (rad, from north towards east)
=======  ===========  ==========================================================

A forecast without directions (every component along north, the long-crested head sea) is sent as
version 1, byte for byte what a version-1 sender wrote; one with directions as version 2.

The decoder accepts only this exact length and checks every value; anything
else raises :class:`ForecastDecodeError` with a reason (the subscriber counts
the reasons). The control task therefore never sees a malformed forecast.
"""
from __future__ import annotations

import math
import struct

import numpy as np

from .forecast import Forecast

__all__ = [
    "MAGIC",
    "MAX_COMPONENTS",
    "MAX_PAYLOAD",
    "VERSION",
    "VERSIONS",
    "ForecastDecodeError",
    "decode_forecast",
    "encode_forecast",
]

MAGIC = b"WKFC"
VERSION = 2
VERSIONS = (1, 2)
MAX_COMPONENTS = 4096
_HEADER = struct.Struct("<4sHHQIdddddB")
MAX_PAYLOAD = _HEADER.size + 255 + MAX_COMPONENTS * (5 * 8 + 1)
FLAG_SECOND_ORDER = 1
FLAG_DIRECTION = 2

# Physical plausibility limits a forecast must meet
MAX_AMPLITUDE_M = 30.0
MAX_OMEGA = 20.0                 # rad/s (0.3 s waves)
MAX_ABS_TIME = 1.0e9             # s


class ForecastDecodeError(ValueError):
    """A forecast payload was rejected; ``reason`` is a short machine-friendly tag."""

    def __init__(self, reason: str, detail: str = ""):
        self.reason = reason
        super().__init__(f"{reason}: {detail}" if detail else reason)


def encode_forecast(f: Forecast) -> bytes:
    """Forecast → bytes (version 1, or 2 with the components' directions)."""
    n = int(np.size(f.amplitude))
    if not 1 <= n <= MAX_COMPONENTS:
        raise ValueError(f"a forecast needs 1..{MAX_COMPONENTS} components, got {n}")
    src = f.source.encode("utf-8")[:255]
    order = np.full(n, 2 if f.second_order else 1, dtype="<u1")
    directed = f.direction is not None
    flags = (FLAG_SECOND_ORDER if f.second_order else 0) | (FLAG_DIRECTION if directed else 0)
    head = _HEADER.pack(MAGIC, 2 if directed else 1, flags, int(f.seq), n,
                        float(f.water_depth), float(f.x_ref), float(f.time_base), float(f.valid_from),
                        float(f.valid_until), len(src))
    arrays = np.concatenate([np.asarray(a, dtype="<f8").ravel() for a in (f.amplitude, f.omega, f.k, f.phase)])
    tail = np.asarray(f.direction, dtype="<f8").ravel().tobytes() if directed else b""
    return head + src + arrays.tobytes() + order.tobytes() + tail


def decode_forecast(payload: bytes | bytearray | memoryview) -> Forecast:
    """bytes → Forecast, or :class:`ForecastDecodeError` naming what is wrong."""
    b = bytes(payload)
    if len(b) > MAX_PAYLOAD:
        raise ForecastDecodeError("oversized", f"{len(b)} bytes > {MAX_PAYLOAD}")
    if len(b) < _HEADER.size:
        raise ForecastDecodeError("truncated", f"{len(b)} bytes, header needs {_HEADER.size}")
    magic, version, flags, seq, n, d, x_ref, t_b, v0, v1, src_len = _HEADER.unpack_from(b)
    if magic != MAGIC:
        raise ForecastDecodeError("bad_magic", repr(magic))
    if version not in VERSIONS:
        raise ForecastDecodeError("bad_version", f"version {version}, this decoder reads {VERSIONS}")
    directed = bool(flags & FLAG_DIRECTION)
    if directed != (version == 2):
        raise ForecastDecodeError("bad_version", f"version {version} with direction flag {int(directed)}")
    if not 1 <= n <= MAX_COMPONENTS:
        raise ForecastDecodeError("bad_count", f"{n} components")
    expected = _HEADER.size + src_len + n * (4 * 8 + 1 + (8 if directed else 0))
    if len(b) != expected:
        raise ForecastDecodeError("bad_length", f"{len(b)} bytes, expected {expected} for {n} components")
    try:
        source = b[_HEADER.size:_HEADER.size + src_len].decode("utf-8")
    except UnicodeDecodeError:
        raise ForecastDecodeError("bad_source", "source name is not UTF-8") from None
    off = _HEADER.size + src_len
    arr = np.frombuffer(b, dtype="<f8", count=4 * n, offset=off).reshape(4, n)
    order = np.frombuffer(b, dtype="<u1", count=n, offset=off + 32 * n)
    direction = np.frombuffer(b, dtype="<f8", count=n, offset=off + 33 * n).copy() if directed else None
    if direction is not None and not np.all(np.isfinite(direction) & (np.abs(direction) <= 4.0 * math.pi)):
        raise ForecastDecodeError("bad_direction", "directions must be finite, within ±4π rad")
    scalars = (d, x_ref, t_b, v0, v1)
    if not all(math.isfinite(v) for v in scalars[:3]) or math.isnan(v0) or math.isnan(v1):
        raise ForecastDecodeError("non_finite", "depth, reference position, time base or validity")
    if not np.all(np.isfinite(arr)):
        raise ForecastDecodeError("non_finite", "component values")
    amp, omega, k, phase = arr
    if not 0.0 < d <= 1.0e4:
        raise ForecastDecodeError("bad_depth", f"{d} m")
    if abs(x_ref) > 1.0e6 or abs(t_b) > MAX_ABS_TIME:
        raise ForecastDecodeError("out_of_range", "reference position or time base")
    if not v0 <= v1:
        raise ForecastDecodeError("bad_validity", f"valid_from {v0} > valid_until {v1}")
    if np.any(amp < 0.0) or np.any(amp > MAX_AMPLITUDE_M):
        raise ForecastDecodeError("absurd_amplitude", f"amplitudes must be in [0, {MAX_AMPLITUDE_M}] m")
    if np.any(omega <= 0.0) or np.any(omega > MAX_OMEGA):
        raise ForecastDecodeError("bad_frequency", f"ω must be in (0, {MAX_OMEGA}] rad/s")
    if np.any(k <= 0.0):
        raise ForecastDecodeError("bad_wavenumber", "k must be positive")
    # The wavenumbers must sit on the finite-depth dispersion relation ω² = g k tanh(k d), or on its
    # deep-water form ω² = g k (a predictor may choose it), within 5 %
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        finite = np.abs(omega**2 / (9.81 * k * np.tanh(k * d)) - 1.0) <= 0.05
        deep = np.abs(omega**2 / (9.81 * k) - 1.0) <= 0.05
    if not np.all(finite | deep):
        raise ForecastDecodeError("off_dispersion", "(ω, k) pairs off the dispersion relation by more than 5 %")
    if not np.all((order == 1) | (order == 2)):
        raise ForecastDecodeError("bad_order", "component order must be 1 or 2")
    second = bool(flags & FLAG_SECOND_ORDER)
    if second != bool(np.all(order == 2)):
        raise ForecastDecodeError("bad_order", "flags and per-component orders disagree")
    return Forecast(amp.copy(), omega.copy(), k.copy(), phase.copy(), float(d), float(x_ref), float(t_b),
                    float(v0), float(v1), second, source, int(seq), direction)
