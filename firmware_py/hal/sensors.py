"""Sensor frames and the simulated sensors of the SITL HAL.

As in ArduPilot's SITL, the simulator reports the true state and the
firmware's HAL turns it into sensor readings with noise (``SIM_*``
parameters), so the noise is the same whichever transport carries the state.

Sensors (paper §IV: sensor noise on, EKF in the loop; the paper gives no values):

* horizontal position fix x (m), at ``SIM_POS_RATE`` Hz — an acoustic
  positioning system (USBL class);
* depth (m) from a Bar30-like pressure sensor, every tick; reported also as
  absolute pressure (Pa) for telemetry. It reads the true depth unless the plant
  gives the pressure depth p/(ρ g) with the waves' dynamic pressure in it (the
  sea config's ``depth_sensor.dynamic_pressure``, docs/sea-errors.md; in-process SITL);
* pitch (rad) and pitch rate (rad/s) from the IMU/AHRS, every tick;
* body velocity [u, w] (m/s) from a DVL with bottom lock (Water Linked A50 class) at
  ``SIM_DVL_RATE`` Hz, only while the altitude ``SIM_WATER_DEPTH`` − depth is within
  [``SIM_DVL_ALT_MIN``, ``SIM_DVL_ALT_MAX``], and a ping lost with probability ``SIM_DVL_DROP``;
* the accelerometer's specific force [f_x, f_z] (m/s², body FRD) every tick, when the
  HAL knows the body's acceleration (the in-process plant's ν̇; JSON SITL's ``imu.accel_body``);
* in a world that moves in all six DoF, the lateral-directional channels: the position fix's
  east y (m, with x), the AHRS's roll φ and heading ψ (rad) and the gyro's roll and yaw rates
  p, r (rad/s), every tick. A planar world has none (NaN): the firmware then holds the vertical
  plane only.

The DVL and accelerometer draw their noise from a second stream seeded from the same
seed, and the lateral channels from a third, so the first four channels' noise is the same
as without them.
docs/estimator.md gives each sensor's source.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bridge.models.waves import WaveComponents, pressure_head

from ..params.table import ParameterTable

__all__ = ["ATM_PA", "RHO_SEAWATER", "SensorFrame", "SimulatedSensors", "depth_to_pressure", "specific_force",
           "wave_corrected_depth", "wrap_angle"]

ATM_PA = 101325.0          # Pa at the surface
RHO_SEAWATER = 1025.0      # kg/m³
G0 = 9.80665               # m/s², as pressure-to-depth conversions use


def wrap_angle(a: float) -> float:
    """An angle (rad) wrapped to (−π, π]."""
    w = math.remainder(a, 2.0 * math.pi)
    return math.pi if w == -math.pi else w


def depth_to_pressure(depth_m: float) -> float:
    """Absolute pressure (Pa) at a depth (m) in sea water."""
    return ATM_PA + RHO_SEAWATER * G0 * depth_m


def specific_force(eta, nu, nu_dot, g: float = G0) -> np.ndarray:
    """What a body-fixed accelerometer reads, [f_x, f_z] (m/s², FRD): ν̇ + ω × v − g in the body frame
    (the JSON SITL state's ``imu.accel_body``, :func:`bridge.json_sitl.state_message`)."""
    th = float(eta[2])
    # a float64 state as Python floats: the same IEEE arithmetic as on numpy's scalars, faster
    u, w, q = nu.tolist() if isinstance(nu, np.ndarray) and nu.dtype == np.float64 else nu
    du, dw = nu_dot[0], nu_dot[1]
    return np.array([du + q * w + g * math.sin(th), dw - q * u - g * math.cos(th)])


def wave_corrected_depth(pressure_depth: float, components: WaveComponents, x: float, t: float) -> float:
    """The depth (m, down) under forecast waves, from a pressure sensor's reading p/(ρ g) (m).

    Under linear waves the reading is s + Σ A K_p(k, s) cos θ (:func:`bridge.models.waves.pressure_head`),
    so the depth s solves s = p/(ρ g) − head(s). The fixed-point iteration from s = p/(ρ g) contracts by
    |∂head/∂s| ≈ k·|head|, a few per cent in the seas of interest: it stops when a step moves s by less
    than 0.1 mm (two or three steps), or after six. ``x`` (m, the wave frame's x, the estimated pose)
    and ``t`` (s) place the forecast's phases.
    """
    s = pressure_depth
    for _ in range(6):
        s_next = pressure_depth - float(pressure_head(components, x, s, t))
        if abs(s_next - s) < 1e-4:
            return s_next
        s = s_next
    return s


@dataclass(frozen=True)
class SensorFrame:
    """One tick's sensor readings. A reading not available this tick is NaN."""

    t: float            # s, vehicle clock
    x: float            # m, NED north (position fix)
    depth: float        # m
    pitch: float        # rad
    pitch_rate: float   # rad/s
    healthy: bool = True
    dvl_u: float = math.nan    # m/s, body surge velocity over ground (DVL bottom lock)
    dvl_w: float = math.nan    # m/s, body heave velocity over ground
    acc_x: float = math.nan    # m/s², specific force, body x (forward)
    acc_z: float = math.nan    # m/s², specific force, body z (down)
    y: float = math.nan          # m, NED east (the position fix's other coordinate; six-DoF world)
    roll: float = math.nan       # rad, AHRS roll φ
    roll_rate: float = math.nan  # rad/s, gyro p
    yaw: float = math.nan        # rad, AHRS heading ψ, in (−π, π]
    yaw_rate: float = math.nan   # rad/s, gyro r

    def lateral_readings(self) -> list[float]:
        """The lateral-directional estimator's channels in its order: [y, φ, ψ, p, r] (NaN where missing)."""
        return [self.y, self.roll, self.yaw, self.roll_rate, self.yaw_rate]

    def readings(self, aided: bool = False) -> list[float]:
        """The estimator's channels in its order: [x, depth, θ, q] and, ``aided``, the DVL's and the
        accelerometer's [u, w, f_x, f_z] (NaN where the frame has no reading)."""
        z = [self.x, self.depth, self.pitch, self.pitch_rate]
        if aided:
            z += [self.dvl_u, self.dvl_w, self.acc_x, self.acc_z]
        return z


@dataclass(frozen=True, slots=True)
class _SimParams:
    """The ``SIM_*`` parameters :meth:`SimulatedSensors.read` uses every tick (read once per table version)."""

    pos_rate: float      # Hz
    depth_rate: float    # Hz
    dvl_rate: float      # Hz
    dvl_alt_min: float   # m
    dvl_alt_max: float   # m
    water_depth: float   # m
    dvl_drop: float      # probability
    pos_rnd: float       # m
    depth_rnd: float     # m
    pitch_rnd: float     # rad
    gyro_rnd: float      # rad/s
    dvl_rnd: float       # m/s
    acc_rnd: float       # m/s²
    yaw_rnd: float       # rad

    @classmethod
    def of(cls, p: ParameterTable) -> _SimParams:
        return cls(p["SIM_POS_RATE"], p["SIM_DEPTH_RATE"], p["SIM_DVL_RATE"], p["SIM_DVL_ALT_MIN"],
                   p["SIM_DVL_ALT_MAX"], p["SIM_WATER_DEPTH"], p["SIM_DVL_DROP"], p["SIM_POS_RND"],
                   p["SIM_DEPTH_RND"], p["SIM_PITCH_RND"], p["SIM_GYRO_RND"], p["SIM_DVL_RND"], p["SIM_ACC_RND"],
                   p["SIM_YAW_RND"])


class SimulatedSensors:
    """Truth → noisy readings, seeded for reproducibility."""

    def __init__(self, params: ParameterTable, seed: int):
        self.params = params
        self.rng = np.random.default_rng(seed)
        self.rng_aid = np.random.default_rng([int(seed) % 2**63, 0xD71])   # DVL and accelerometer
        self.rng_lat = np.random.default_rng([int(seed) % 2**63, 0x1A7])   # the lateral-directional channels
        self._last_slot = {"pos": -1, "depth": -1, "dvl": -1}

    def _sim_params(self) -> _SimParams:
        """The SIM_* values, re-read only when the parameter table (or its version) changes."""
        return self.params.derived(_SimParams.of)

    def _due(self, name: str, t: float, rate: float) -> bool:
        """Is a new reading of the sensor at ``rate`` Hz due at t (its slot changed since the last read)?"""
        if rate <= 0.0:
            return False
        slot = math.floor(t * rate + 1e-9)
        due = slot != self._last_slot[name]
        self._last_slot[name] = slot
        return due

    def dvl_in_range(self, depth: float) -> bool:
        """Bottom lock possible at this depth: the altitude within the DVL's range."""
        p = self._sim_params()
        return p.dvl_alt_min <= p.water_depth - depth <= p.dvl_alt_max

    def read(self, t: float, eta, nu, accel=None, pressure_depth: float | None = None,
             lateral=None) -> SensorFrame:
        """Sample the sensors at time t (s) for truth η = [x, z, θ], ν = [u, w, q] and, when known,
        the specific force ``accel`` = [f_x, f_z] (m/s², :func:`specific_force`). ``pressure_depth``
        (m), when given, is what the pressure sensor sees instead of the true depth z (dynamic pressure).
        ``lateral``, in a six-DoF world, is the truth's lateral-directional part [y, φ, ψ, v, p, r]
        (m, rad, m/s, rad/s; :data:`bridge.models.motion6.LATERAL_DOFS`); None leaves those channels NaN."""
        p = self._sim_params()
        # Draw every channel every tick so the noise sequence is independent of rates. The arithmetic runs
        # on Python floats (the same IEEE operations as on numpy's scalars, at a fraction of the cost).
        n0, n1, n2, n3 = self.rng.standard_normal(4).tolist()
        a0, a1, a2, a3, a4 = self.rng_aid.standard_normal(5).tolist()
        fix = self._due("pos", t, p.pos_rate)
        baro = self._due("depth", t, p.depth_rate)
        dvl = (self._due("dvl", t, p.dvl_rate) and self.dvl_in_range(float(eta[1]))
               and 0.5 * (1.0 + math.erf(a4 / math.sqrt(2.0))) >= p.dvl_drop)
        acc = accel is not None and all(map(math.isfinite, accel))
        y, roll, yaw, roll_rate, yaw_rate = (self._lateral(p, fix, lateral) if lateral is not None
                                             else (math.nan,) * 5)
        return SensorFrame(
            t=t,
            x=float(eta[0] + p.pos_rnd * n0) if fix else math.nan,
            depth=float((eta[1] if pressure_depth is None else pressure_depth) + p.depth_rnd * n1)
            if baro else math.nan,
            pitch=float(eta[2] + p.pitch_rnd * n2),
            pitch_rate=float(nu[2] + p.gyro_rnd * n3),
            dvl_u=float(nu[0] + p.dvl_rnd * a0) if dvl else math.nan,
            dvl_w=float(nu[1] + p.dvl_rnd * a1) if dvl else math.nan,
            acc_x=float(accel[0] + p.acc_rnd * a2) if acc else math.nan,
            acc_z=float(accel[1] + p.acc_rnd * a3) if acc else math.nan,
            y=y, roll=roll, roll_rate=roll_rate, yaw=yaw, yaw_rate=yaw_rate,
        )

    def _lateral(self, p: _SimParams, fix: bool, lateral) -> tuple[float, float, float, float, float]:
        """The lateral channels' readings [y, φ, ψ, p, r] of the truth [y, φ, ψ, v, p, r]: y with the position fix,
        the rest every tick; the heading wrapped to (−π, π] as an AHRS reports it."""
        m0, m1, m2, m3, m4 = self.rng_lat.standard_normal(5).tolist()
        y, phi, psi, _, p_rate, r_rate = (float(v) for v in lateral)
        return (y + p.pos_rnd * m0 if fix else math.nan, phi + p.pitch_rnd * m1, wrap_angle(psi + p.yaw_rnd * m2),
                p_rate + p.gyro_rnd * m3, r_rate + p.gyro_rnd * m4)
