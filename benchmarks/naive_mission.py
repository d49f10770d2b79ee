"""A naive station-keeping mission in one file: the yardstick Wavekeep's mission time is measured against.

    python benchmarks/naive_mission.py [--duration 600] [--seed 103]

What a researcher writes in an afternoon, in plain Python on ``math`` and lists, with no project code and
no numpy: sea state W3 (Tp 11.1 s, Hs 3.24 m) as 200 JONSWAP components with random phases, deep-water
linear kinematics at six strips along the body (as the world's plant), the paper's planar BlueROV2
(Table II: surge, heave, pitch, added mass, linear and quadratic damping on each strip's relative velocity,
the wave's added-mass load, restoring), one classical RK4 step per 20 Hz control period, and the authors'
cascaded PD (K_p, K_d, inner-loop gain, normalised effort clipped to ±1 and scaled by τ_max). No estimator, no
thrusters' curve or lag, no I/O during the mission. It prints one JSON line: the mission's wall time (s) and its
RMSE, so a run can be checked for a sensible flight.

Its time is the yardstick: machine-independent ratios (``benchmarks/bench_mission_time.py``) say how
many times faster than this script a Wavekeep mission of the same length flies.
"""
from __future__ import annotations

import argparse
import json
import math
import random
import time

G = 9.81
RHO = 1025.0
DT = 0.05                      # s, the control period (20 Hz)
HS, TP, GAMMA = 3.24, 11.1, 3.3  # W3, DNV JONSWAP
N_COMPONENTS = 200
W, B = 112.8, 114.8            # N
M_RB = W / G                   # kg
IY, ZB = 0.253, 0.028          # kg m², m (buoyancy above the CG)
XUD, ZWD, MQD = 6.36, 18.68, 0.135
XU, ZW, MQ = 13.7, 33.0, 0.80
XUU, ZWW, MQQ = 141.0, 190.0, 0.47
DEPTH = 5.0                    # m, the station's depth
KP, KD, KV = (1.2, 1.2, 0.5), (3.0, 3.0, 1.0), 1.2
C45 = math.cos(math.radians(45.0))
TAU_MAX = (2 * 35.0 * (C45 + C45), 4 * 35.0, 4 * 35.0 * 0.12)
LENGTH, N_STRIPS = 0.457, 6    # m: the body's length cut into strips, each with its share of the load
STRIPS = [LENGTH * ((i + 0.5) / N_STRIPS - 0.5) for i in range(N_STRIPS)]


def jonswap_components(seed: int) -> list[tuple[float, float, float, float]]:
    """(amplitude m, ω rad/s, k 1/m, phase rad) per component, the spectrum scaled to Hs (DNV form)."""
    rng = random.Random(seed)
    wp = 2 * math.pi / TP
    w_lo, w_hi = 0.3 * wp, 4.0 * wp
    dw = (w_hi - w_lo) / N_COMPONENTS
    out = []
    for i in range(N_COMPONENTS):
        w = w_lo + (i + 0.5) * dw
        sigma = 0.07 if w <= wp else 0.09
        peak = GAMMA ** math.exp(-((w - wp) ** 2) / (2 * sigma**2 * wp**2))
        s = (1 - 0.287 * math.log(GAMMA)) * 5 / 16 * HS**2 * wp**4 * w**-5 * math.exp(-1.25 * (wp / w) ** 4) * peak
        out.append((math.sqrt(2 * s * dw), w, w * w / G, rng.uniform(0, 2 * math.pi)))
    return out


def flow(comps, x: float, z: float, t: float) -> tuple[float, float, float, float]:
    """Deep-water particle velocity and acceleration (u, w, a_x, a_z) at (x, depth z) at time t, earth frame."""
    u = w = ax = az = 0.0
    for a, om, k, eps in comps:
        ph = k * x - om * t + eps
        e = a * om * math.exp(-k * z)
        c, s = math.cos(ph), math.sin(ph)
        u += e * c
        w -= e * s             # depth positive down: the upward velocity's sign flipped
        ax += e * om * s
        az += e * om * c
    return u, w, ax, az


def rates(comps, state: list[float], tau: tuple[float, float, float], t: float) -> list[float]:
    """d/dt [x, z, θ, u, w, q] of the planar vehicle in the wave's flow, the load summed over the strips."""
    x, z, th, u, w, q = state
    c, s = math.cos(th), math.sin(th)
    fx, fz, mq = tau[0] - (W - B) * s, tau[1] + (W - B) * c, tau[2] - ZB * B * s - (MQ + MQQ * abs(q)) * q
    for r in STRIPS:
        fu, fw, fax, faz = flow(comps, x + r * c, z - r * s, t)
        ur, wr = u - (c * fu - s * fw), w - q * r - (s * fu + c * fw)
        dx = -(XU + XUU * abs(ur)) * ur + XUD * (c * fax - s * faz)
        dz = -(ZW + ZWW * abs(wr)) * wr + ZWD * (s * fax + c * faz)
        fx += dx / len(STRIPS)
        fz += dz / len(STRIPS)
        mq -= r * dz / len(STRIPS)
    return [c * u + s * w, -s * u + c * w, q, fx / (M_RB + XUD), fz / (M_RB + ZWD), mq / (IY + MQD)]


def rk4(comps, state: list[float], tau, t: float) -> list[float]:
    k1 = rates(comps, state, tau, t)
    k2 = rates(comps, [s + 0.5 * DT * k for s, k in zip(state, k1, strict=True)], tau, t + 0.5 * DT)
    k3 = rates(comps, [s + 0.5 * DT * k for s, k in zip(state, k2, strict=True)], tau, t + 0.5 * DT)
    k4 = rates(comps, [s + DT * k for s, k in zip(state, k3, strict=True)], tau, t + DT)
    return [s + DT / 6 * (a + 2 * b + 2 * c + d) for s, a, b, c, d in zip(state, k1, k2, k3, k4, strict=True)]


def cpd(state: list[float], prev_err: list[float]) -> tuple[tuple[float, float, float], list[float]]:
    """The cascaded PD on the true state (no estimator): the wrench (N, N, N m) and this tick's error."""
    x, z, th, u, w, q = state
    c, s = math.cos(th), math.sin(th)
    ex, ez = -x, DEPTH - z
    err = [c * ex - s * ez, s * ex + c * ez, -th]
    vel = (u, w, q)
    tau = []
    for i in range(3):
        demand = max(-1.0, min(1.0, KP[i] * err[i] + KD[i] * (err[i] - prev_err[i]) / DT))
        tau.append(TAU_MAX[i] * max(-1.0, min(1.0, KV * (demand - vel[i]))))
    return (tau[0], tau[1], tau[2]), err


def mission(duration: float, seed: int) -> dict:
    comps = jonswap_components(seed)
    state = [0.0, DEPTH, 0.0, 0.0, 0.0, 0.0]
    err = [0.0, 0.0, 0.0]
    sq = [0.0, 0.0, 0.0]
    n = int(round(duration / DT))
    t0 = time.perf_counter()
    for i in range(n):
        tau, err = cpd(state, err)
        state = rk4(comps, state, tau, i * DT)
        sq[0] += state[0] ** 2
        sq[1] += (state[1] - DEPTH) ** 2
        sq[2] += state[2] ** 2
    wall = time.perf_counter() - t0
    return {"wall_s": wall, "ticks": n, "rmse": [math.sqrt(v / n) for v in sq]}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=600.0)
    ap.add_argument("--seed", type=int, default=103)
    a = ap.parse_args()
    print(json.dumps(mission(a.duration, a.seed)))


if __name__ == "__main__":
    main()
