"""ArduPilot's JSON SITL wire format: one codec for both ends.

The autopilot (the firmware's :class:`firmware_py.hal.json_sitl.JSONSITLHAL`, or real
ArduSub SITL with ``--model JSON``) sends binary servo packets; the physics
side (:class:`sitl.physics_server.PhysicsServer`) answers each with one line of
JSON holding the vehicle's state. ``docs/json_sitl.md`` describes the protocol.

Servo packet, little endian::

    <HHI16H   magic 18458, frame_rate (Hz), frame_count, pwm[16] (µs)   40 bytes
    <HHI32H   magic 29569, frame_rate (Hz), frame_count, pwm[32] (µs)   72 bytes

State reply: ``timestamp`` (s), ``imu.gyro`` (rad/s, body), ``imu.accel_body``
(m/s², specific force, body FRD), ``position`` (NED m), ``velocity`` (NED m/s),
``attitude`` [roll, pitch, yaw] (rad) of the whole six-DoF motion, plus a ``wavekeep``
object with the exact planar state η = [x, z, θ], ν = [u, w, q] (what Wavekeep's firmware
reads), in a six-DoF world its lateral-directional part [y, φ, ψ, v, p, r] too, the thrusts (N)
and the frame_count the reply answers.
"""
from __future__ import annotations

import json
import math
import struct
from dataclasses import dataclass
from typing import Any

import numpy as np

try:    # orjson: exact shortest round-trip floats both ways, ~5x faster than json on a state line
    import orjson as _orjson
except ImportError:  # pragma: no cover - orjson is a dependency; json is the same wire format
    _orjson = None  # type: ignore[assignment]

from bridge.models.motion6 import specific_force6
from bridge.models.thrusters import NEUTRAL_PWM_US
from bridge.models.vehicle import body_to_ned, ned_to_body

__all__ = [
    "MAGIC_16",
    "MAGIC_32",
    "MAX_FRAME_RATE_HZ",
    "PWM_RANGE_US",
    "SERVO_16",
    "SERVO_32",
    "THRUSTER_CHANNELS",
    "ServoPacket",
    "StateReply",
    "decode_servo_packet",
    "decode_state",
    "encode_state",
    "servo_packet",
    "state_message",
]

MAGIC_16 = 18458
MAGIC_32 = 29569
SERVO_16 = struct.Struct("<HHI16H")     # 40 bytes
SERVO_32 = struct.Struct("<HHI32H")     # 72 bytes
THRUSTER_CHANNELS = 8
MAX_FRAME_RATE_HZ = 10000               # ArduPilot's SIM_RATE_HZ is typically 400–1200 Hz
PWM_RANGE_US = (500, 2500)              # a thruster channel must be 0 (no output) or within this
_NO_OUTPUT = (0,) * 16                  # the channels a servo packet does not drive


@dataclass(frozen=True)
class ServoPacket:
    """A decoded servo packet: the autopilot's frame and its thruster PWM (µs, 0 read as neutral)."""

    frame_rate: int
    frame_count: int
    pwm: np.ndarray


@dataclass(frozen=True)
class StateReply:
    """A decoded state reply, in the planar frame (η NED/pitch, ν body FRD)."""

    timestamp: float             # physics time (s)
    eta: np.ndarray              # [x, z, θ] (m, m, rad)
    nu: np.ndarray               # [u, w, q] (m/s, m/s, rad/s)
    thrust: np.ndarray | None    # per-thruster thrust (N), when the server sends it
    frame_count: int | None      # the servo frame it answers, when the server says
    accel: np.ndarray | None = None   # specific force [f_x, f_z] (m/s², body FRD) from imu.accel_body, if sent
    pressure_depth: float | None = None   # what the depth sensor reads, p/(ρ g) (m), when the world models it
    lateral: np.ndarray | None = None     # a six-DoF world's [y, φ, ψ, v, p, r] (m, rad, m/s, rad/s)


def servo_packet(frame_rate: int, frame_count: int, pwm: np.ndarray | list[int]) -> bytes:
    """The 16-channel servo packet for ``pwm`` (µs; missing channels are 0, values clipped to uint16)."""
    # clipped on the ints: ndarray.clip's per-call cost was most of the packet's
    ch = [0 if v < 0 else 65535 if v > 65535 else v for v in np.asarray(pwm, dtype=np.int64)[:16].tolist()]
    return SERVO_16.pack(MAGIC_16, int(frame_rate), int(frame_count) & 0xFFFFFFFF, *ch, *_NO_OUTPUT[len(ch):])


def decode_servo_packet(data: bytes) -> ServoPacket | None:
    """A valid servo packet's frame and thruster PWM (float µs), or None for anything malformed.

    Malformed: wrong size or magic, a frame rate outside 1…``MAX_FRAME_RATE_HZ``,
    or a thruster channel that is neither 0 ("no output", taken as neutral) nor
    within ``PWM_RANGE_US``.
    """
    if len(data) == SERVO_16.size:
        fields, magic = SERVO_16.unpack(data), MAGIC_16
    elif len(data) == SERVO_32.size:
        fields, magic = SERVO_32.unpack(data), MAGIC_32
    else:
        return None
    if fields[0] != magic:
        return None
    rate, count = fields[1], fields[2]
    if not 1 <= rate <= MAX_FRAME_RATE_HZ:
        return None
    # Eight small ints: checked in Python, one array made at the end (numpy's per-call cost dominated)
    channels = fields[3:3 + THRUSTER_CHANNELS]
    lo, hi = PWM_RANGE_US
    for v in channels:
        if v and not lo <= v <= hi:
            return None
    return ServoPacket(rate, count, np.array([v or NEUTRAL_PWM_US for v in channels], dtype=float))


def _plain_floats(values) -> list[float]:
    """``[float(v) for v in values]``; a float64 vector (a plant's state) in one ``tolist``, the same floats."""
    if type(values) is np.ndarray and values.dtype == np.float64 and values.ndim == 1:
        return values.tolist()
    return [float(v) for v in values]


def state_message(t: float, eta: np.ndarray, nu: np.ndarray, nu_dot: np.ndarray, thrust: np.ndarray,
                  g: float, frame_count: int | None = None, pressure_depth: float | None = None,
                  six: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None) -> dict[str, Any]:
    """The JSON SITL state of the vehicle: ArduPilot's fields plus Wavekeep's exact planar state.

    ``eta``, ``nu``, ``nu_dot`` are the planar [x, z, θ], [u, w, q] and [u̇, ẇ, q̇] (what Wavekeep's HAL
    reads, in ``wavekeep``). ``six``, for a world that moves in all six DoF, is (η, ν, ν̇) with
    η = [x, y, z, φ, θ, ψ] (NED m, zyx Euler rad), ν = [u, v, w, p, q, r] (body FRD) and ν̇ its rate;
    ArduPilot's fields are then the whole motion and ``wavekeep.lateral`` its [y, φ, ψ, v, p, r]. Without it
    the vehicle is planar (y, φ, ψ, v, p, r = 0, and no ``wavekeep.lateral``: a planar world has no lateral
    sensors to read).

    ``imu.accel_body`` is the specific force in body FRD, ν̇₁ + ω × ν₁ − Rᵀ [0, 0, g] (≈ [0, 0, −g] at rest);
    ``velocity`` is R(Θ) ν₁ in NED; ``gyro`` the body rates [p, q, r]. ``pressure_depth`` (m), when the world
    models the waves' dynamic pressure at the depth sensor, goes in ``wavekeep.pressure_depth``: ArduPilot's
    protocol has no pressure field (its barometer follows ``position``), so only Wavekeep's HAL reads it.
    """
    x, z, theta = _plain_floats(eta)
    u, w, q = _plain_floats(nu)
    if six is None:
        du, dw = float(nu_dot[0]), float(nu_dot[1])
        st, ct = math.sin(theta), math.cos(theta)
        vn, vd = body_to_ned(theta, u, w)
        y = phi = psi = v = p = r = ve = 0.0
        accel = [du + q * w + g * st, 0.0, dw - q * u - g * ct]
    else:
        x, y, z, phi, theta, psi = _plain_floats(six[0])
        u, v, w, p, q, r = _plain_floats(six[1])
        sf, cf, st, ct, sp, cp = (math.sin(phi), math.cos(phi), math.sin(theta), math.cos(theta), math.sin(psi),
                                  math.cos(psi))
        vn = cp * ct * u + (cp * st * sf - sp * cf) * v + (sp * sf + cp * cf * st) * w
        ve = sp * ct * u + (cp * cf + sf * st * sp) * v + (st * sp * cf - cp * sf) * w
        vd = -st * u + ct * sf * v + ct * cf * w
        accel = specific_force6(six[0], six[1], six[2], g)
    msg: dict[str, Any] = {
        "timestamp": float(t),
        "imu": {
            "gyro": [p, q, r],
            "accel_body": accel,
        },
        "position": [x, y, z],
        "velocity": [vn, ve, vd],
        "attitude": [phi, theta, psi],
        # Last, and with no key that ArduPilot's substring parser looks for
        # (timestamp, gyro, accel_body, position, attitude, quaternion, velocity, rng_N, ...).
        "wavekeep": {"eta": [x, z, theta], "nu": [u, w, q], "thrust": _plain_floats(thrust)},
    }
    if frame_count is not None:
        msg["wavekeep"]["frame_count"] = int(frame_count)
    if pressure_depth is not None:
        msg["wavekeep"]["pressure_depth"] = float(pressure_depth)
    if six is not None:
        msg["wavekeep"]["lateral"] = [y, phi, psi, v, p, r]
    return msg


def encode_state(msg: dict[str, Any]) -> bytes:
    """One JSON line, preceded and terminated by a newline as ArduPilot's reader expects.

    Compact separators: older ArduPilot parsers read vectors with
    ``sscanf("[%f, %f, %f]")`` right after ``"key":``, so there must be no space
    before the ``[``. Python's float repr round-trips exactly; NaN is refused.
    """
    if _orjson is None:
        return b"\n" + json.dumps(msg, separators=(",", ":"), allow_nan=False).encode("ascii") + b"\n"
    out = _orjson.dumps(msg)   # compact; writes NaN/inf as null, which no state message holds otherwise
    if b"null" in out:
        raise ValueError("Out of range float values are not JSON compliant")
    return b"\n" + out + b"\n"


def _finite_floats(obj: dict[str, Any], key: str, n: int) -> list[float] | np.ndarray:
    """``obj[key]`` as ``n`` finite numbers; ValueError (or TypeError) if it is not that.

    What a JSON parser makes of a vector is a list of floats: that case is checked on the floats
    (numpy's per-call cost was most of a reply's decoding); anything else (ints, strings numpy would
    convert, nested lists) goes through the array, as before.
    """
    v = obj[key]
    if type(v) is list and len(v) == n and all(type(x) is float for x in v):
        if not all(map(math.isfinite, v)):
            raise ValueError(f"{key}: expected {n} finite numbers")
        return v
    return _vec(obj, key, n)


def _vec(obj: dict[str, Any], key: str, n: int) -> np.ndarray:
    v = np.array(obj[key], dtype=float)
    if v.shape != (n,) or not np.isfinite(v).all():
        raise ValueError(f"{key}: expected {n} finite numbers")
    return v


def _body_uw(phi: float, theta: float, psi: float, vn: float, ve: float, vd: float) -> tuple[float, float]:
    """The body FRD u and w (m/s) of the NED velocity under zyx Euler angles (rad): rows 1 and 3 of Rᵀ(Θ) v."""
    sf, cf, st, ct = math.sin(phi), math.cos(phi), math.sin(theta), math.cos(theta)
    sp, cp = math.sin(psi), math.cos(psi)
    u = cp * ct * vn + sp * ct * ve - st * vd
    w = (sp * sf + cp * cf * st) * vn + (st * sp * cf - cp * sf) * ve + ct * cf * vd
    return u, w


def decode_state(line: bytes | str) -> StateReply:
    """The planar state in one JSON SITL reply; ValueError (or KeyError/TypeError) if it is not one.

    Uses ``wavekeep.eta`` / ``wavekeep.nu`` when present (exact), else derives
    the planar state from ArduPilot's standard fields: η = [N, D, pitch],
    [u, w] = the NED velocity rotated into the body by the attitude, q = gyro y.
    """
    msg = json.loads(line) if _orjson is None else _orjson.loads(line)
    if not isinstance(msg, dict):
        raise ValueError("not a JSON object")
    ts = float(msg["timestamp"])
    if not math.isfinite(ts):
        raise ValueError("timestamp is not finite")
    wk = msg.get("wavekeep")
    thrust = None
    count = None
    pressure_depth = None
    lateral = None
    if isinstance(wk, dict) and "lateral" in wk:
        lateral = np.array(_finite_floats(wk, "lateral", 6), dtype=float)
    if isinstance(wk, dict) and "pressure_depth" in wk:
        pressure_depth = float(wk["pressure_depth"])
        if not math.isfinite(pressure_depth):
            raise ValueError("wavekeep.pressure_depth is not finite")
    if isinstance(wk, dict) and "eta" in wk and "nu" in wk:
        eta, nu = np.array(_finite_floats(wk, "eta", 3)), np.array(_finite_floats(wk, "nu", 3))
        if "thrust" in wk:
            thrust = np.array(wk["thrust"], dtype=float)
        if "frame_count" in wk:
            count = int(wk["frame_count"])
    else:
        pos, vel = _vec(msg, "position", 3), _vec(msg, "velocity", 3)
        gyro = _vec(msg["imu"], "gyro", 3)
        if "quaternion" in msg:
            qw, qx, qy, qz = _vec(msg, "quaternion", 4)
            theta = math.asin(max(-1.0, min(1.0, 2.0 * (qw * qy - qz * qx))))
            phi = math.atan2(2.0 * (qw * qx + qy * qz), 1.0 - 2.0 * (qx * qx + qy * qy))
            psi = math.atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))
        else:
            phi, theta, psi = (float(a) for a in _vec(msg, "attitude", 3))
        if phi == 0.0 and psi == 0.0:       # a planar vehicle: the pitch rotation alone, as a planar world sends
            u, w = ned_to_body(theta, float(vel[0]), float(vel[2]))
        else:                               # the body's u and w of Rᵀ(Θ) v_NED
            u, w = _body_uw(phi, theta, psi, float(vel[0]), float(vel[1]), float(vel[2]))
        eta = np.array([pos[0], pos[2], theta])
        nu = np.array([u, w, gyro[1]])
    accel = None
    imu = msg.get("imu")
    if isinstance(imu, dict) and "accel_body" in imu:
        a = _finite_floats(imu, "accel_body", 3)
        accel = np.array([a[0], a[2]], dtype=float)
    return StateReply(ts, eta, nu, thrust, count, accel, pressure_depth, lateral)
