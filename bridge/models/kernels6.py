"""Compiled (numba) kernels of the six-DoF plant, with the numpy models as reference.

The reference is :mod:`bridge.models.strip_load6` (the flow at the strips, the strip load) and
:mod:`bridge.models.motion6` (the rates, one RK4 step); these kernels compute the same quantities
in loops over plain float arrays, and tests hold them to the reference to 1e-12 of the load's size
(tests/test_plant6.py). ``WAVEKEEP_NUMBA=0`` (or a missing numba) runs the kernels as plain Python,
as :mod:`bridge.models.kernels` does; the plant then uses the numpy reference instead.

Two things make a six-DoF step cost about what the planar one does, with 3 × 3 strips instead of 3:

* **The strip grid is separable.** A strip point r = (x_i, y_j, 0) of a body at p with attitude R
  sits at p + x_i R e_x + y_j R e_y, so each component's phase k·(p + R r) + ε and depth
  attenuation e^{−k z} split into a factor of the pose, one of x_i and one of y_j. The cosines,
  sines and exponentials are taken once per node (the Gauss–Legendre nodes are symmetric about
  the centre, so a mirrored node is the conjugate and the reciprocal, and a node at the centre is
  1) and multiplied out per point. A point above the still surface or below the seabed (its depth
  clipped) breaks the product; the flow is then taken point by point.
* **The sums over components are reassociated** (``fastmath`` reassociation and contraction only: no
  assumption about NaN or infinity), so they vectorise. The order of the additions is the only
  difference from the reference.

Parameter vector (:func:`kernel_params6`), float64::

    0 W   1 B   2 height   3..5 r_G   6..8 r_B   9..14 added mass (X_u̇, Y_v̇, Z_ẇ, K_ṗ, M_q̇, N_ṙ)
    15 X_q̇   16..21 linear damping   22..27 quadratic damping   28 fk_mass (ρ∇ or 0)
    29 1.0 for the complete load model (the Froude–Krylov lever and the X_q̇ coupling), else 0.0
    30..65 M_RB   66..101 M⁻¹   102..137 M_A  (row-major 6 × 6)
"""
from __future__ import annotations

import math

import numpy as np

from .kernels import ENABLED, njit
from .rigid_body6 import RigidBody6Params
from .waves import WaveComponents

__all__ = ["ENABLED", "body_flow6_arr", "hydro_load6_arr", "kernel_params6", "node_mirrors", "rates6_arr",
           "rk4_6_arr", "step_flow6", "warm_up6"]

_FAST = {"reassoc", "contract"}


def kernel_params6(p: RigidBody6Params) -> np.ndarray:
    """The parameter vector of the kernels (module docstring) for the six-DoF parameters ``p``."""
    head = [p.W, p.B, p.height, *p.r_G, *p.r_B, *p.added_mass, p.X_qdot, *p.linear_damping,
            *p.quadratic_damping, p.fk_mass, 1.0 if p.wave_load_model == "complete" else 0.0]
    return np.concatenate([np.array(head, dtype=float), p.M_RB.ravel(), p.M_inv.ravel(), p.M_A.ravel()])


def node_mirrors(nodes: np.ndarray) -> np.ndarray:
    """Per node (m): −1 to evaluate, −2 for the centre (0.0 exactly), or the index of an earlier node that is
    its exact negative (its phasor is that one's conjugate, its attenuation the reciprocal)."""
    out = np.full(nodes.size, -1, dtype=np.int64)
    for i, v in enumerate(nodes.tolist()):
        if v == 0.0:
            out[i] = -2
            continue
        for j in range(i):
            if nodes[j] == -v:
                out[i] = j
                break
    return out


@njit(cache=True)
def _node_factors(nodes, mirror, ka, kb, k, n):  # pragma: no cover - compiled
    """cos, sin of nodes·ka and e^{−k nodes kb} per node and component, (nodes, n) each."""
    m = nodes.size
    c, s, e = np.empty((m, n)), np.empty((m, n)), np.empty((m, n))
    for i in range(m):
        src = mirror[i]
        for j in range(n):
            if src == -2:
                c[i, j], s[i, j], e[i, j] = 1.0, 0.0, 1.0
            elif src >= 0:
                c[i, j], s[i, j], e[i, j] = c[src, j], -s[src, j], 1.0 / e[src, j]
            else:
                a = nodes[i] * ka[j]
                c[i, j], s[i, j], e[i, j] = math.cos(a), math.sin(a), math.exp(-k[j] * nodes[i] * kb[j])
    return c, s, e


@njit(cache=True)
def _point_factors(k, kx, ky, phase, d, eta, R, xs, ys, xm, ym):  # pragma: no cover - compiled
    """cos a, sin a and e^{−k z} (S, N) at the strip points (x-major): separable unless a depth is clipped."""
    n, nx, ny = k.size, xs.size, ys.size
    ca, sa, ea = np.empty((nx * ny, n)), np.empty((nx * ny, n)), np.empty((nx * ny, n))
    clipped = False
    for i in range(nx):
        for jy in range(ny):
            z = eta[2] + xs[i] * R[2, 0] + ys[jy] * R[2, 1]
            if z < 0.0 or z > d:
                clipped = True
    if clipped:
        for i in range(nx):
            for jy in range(ny):
                p = i * ny + jy
                ex = eta[0] + xs[i] * R[0, 0] + ys[jy] * R[0, 1]
                ey = eta[1] + xs[i] * R[1, 0] + ys[jy] * R[1, 1]
                z = min(max(eta[2] + xs[i] * R[2, 0] + ys[jy] * R[2, 1], 0.0), d)
                for j in range(n):
                    a = ex * kx[j] + ey * ky[j] + phase[j]
                    ca[p, j], sa[p, j], ea[p, j] = math.cos(a), math.sin(a), math.exp(-z * k[j])
        return ca, sa, ea
    a0c, a0s, e0 = np.empty(n), np.empty(n), np.empty(n)
    kxa, kxb, kya, kyb = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    for j in range(n):
        a0 = eta[0] * kx[j] + eta[1] * ky[j] + phase[j]
        a0c[j], a0s[j], e0[j] = math.cos(a0), math.sin(a0), math.exp(-eta[2] * k[j])
        kxa[j] = kx[j] * R[0, 0] + ky[j] * R[1, 0]
        kya[j] = kx[j] * R[0, 1] + ky[j] * R[1, 1]
        kxb[j], kyb[j] = R[2, 0], R[2, 1]
    cx, sx, exx = _node_factors(xs, xm, kxa, kxb, k, n)
    cy, sy, eyy = _node_factors(ys, ym, kya, kyb, k, n)
    for i in range(nx):
        for jy in range(ny):
            p = i * ny + jy
            for j in range(n):
                c1 = cx[i, j] * cy[jy, j] - sx[i, j] * sy[jy, j]
                s1 = sx[i, j] * cy[jy, j] + cx[i, j] * sy[jy, j]
                ca[p, j] = a0c[j] * c1 - a0s[j] * s1
                sa[p, j] = a0s[j] * c1 + a0c[j] * s1
                ea[p, j] = e0[j] * exx[i, j] * eyy[jy, j]
    return ca, sa, ea


@njit(cache=True, fastmath=_FAST)
def _point_sums(cb, sb, ca, sa, W, out_v, out_a, p):  # pragma: no cover - compiled
    """The six sums of one point over (orders × N) terms at each time: NED velocity and acceleration."""
    T, on = cb.shape
    for i in range(T):
        u = v = w = ud = vd = wd = 0.0
        for j in range(on):
            cc = ca[j] * cb[i, j] + sa[j] * sb[i, j]          # cos(a − ω t)
            ss = sa[j] * cb[i, j] - ca[j] * sb[i, j]          # sin(a − ω t)
            u += W[0, j] * cc
            v += W[1, j] * cc
            w -= W[2, j] * ss
            ud += W[3, j] * ss
            vd += W[4, j] * ss
            wd += W[5, j] * cc
        out_v[i, p, 0], out_v[i, p, 1], out_v[i, p, 2] = u, v, w
        out_a[i, p, 0], out_a[i, p, 1], out_a[i, p, 2] = ud, vd, wd


@njit(cache=True)
def body_flow6_arr(k, omega, phase, coef, rate, e2d, inv, inv4, d, cosb, sinb, eta, R, xs, ys, xm, ym, t,
                   current):  # pragma: no cover - compiled
    """The sea's flow at the strips, body frame: (velocity, acceleration), each (T, S, 3) in m/s and m/s².

    :func:`~bridge.models.strip_load6.body_flow6` over
    :func:`~bridge.models.directional_sea.kinematics_xyz`: components k (rad/m), ω (rad/s), ε (rad);
    ``coef``/``rate`` (orders, N) the series constants, ``e2d``, ``inv``, ``inv4`` the depth constants;
    d (m) the water depth; cos β, sin β the directions; η (6,) the pose and R its rotation (3, 3);
    ``xs``, ``ys`` the strip nodes (m) with their :func:`node_mirrors`; t (T,) s; ``current`` (3,) NED m/s.
    """
    orders, n = coef.shape
    T, S, on = t.size, xs.size * ys.size, orders * n
    kx, ky = k * cosb, k * sinb
    ca1, sa1, ea1 = _point_factors(k, kx, ky, phase, d, eta, R, xs, ys, xm, ym)
    cb, sb = np.empty((T, on)), np.empty((T, on))
    for i in range(T):
        for j in range(n):
            b = t[i] * omega[j]
            cb[i, j], sb[i, j] = math.cos(b), math.sin(b)
            if orders > 1:
                cb[i, n + j] = cb[i, j] ** 2 - sb[i, j] ** 2
                sb[i, n + j] = cb[i, j] * sb[i, j] * 2.0
    vel, acc = np.empty((T, S, 3)), np.empty((T, S, 3))
    W, ca, sa = np.empty((6, on)), np.empty(on), np.empty(on)
    for p in range(S):
        for j in range(n):
            ea = ea1[p, j]
            eb = e2d[j] / ea
            H, V = (ea + eb) * inv[j] * coef[0, j], (ea - eb) * inv[j] * coef[0, j]
            ca[j], sa[j] = ca1[p, j], sa1[p, j]
            W[0, j], W[1, j], W[2, j] = H * cosb[j], H * sinb[j], V
            W[3, j], W[4, j], W[5, j] = W[0, j] * rate[0, j], W[1, j] * rate[0, j], V * rate[0, j]
            if orders > 1:
                jj = n + j
                ea2, eb2 = ea * ea * e2d[j], eb * eb * e2d[j]
                H2, V2 = (ea2 + eb2) * inv4[j] * coef[1, j], (ea2 - eb2) * inv4[j] * coef[1, j]
                ca[jj], sa[jj] = ca[j] ** 2 - sa[j] ** 2, ca[j] * sa[j] * 2.0
                W[0, jj], W[1, jj], W[2, jj] = H2 * cosb[j], H2 * sinb[j], V2
                W[3, jj], W[4, jj], W[5, jj] = W[0, jj] * rate[1, j], W[1, jj] * rate[1, j], V2 * rate[1, j]
        _point_sums(cb, sb, ca, sa, W, vel, acc, p)
    for i in range(T):          # NED → body: vᵀ R = (Rᵀ v)ᵀ
        for p in range(S):
            v0, v1, v2 = vel[i, p, 0] + current[0], vel[i, p, 1] + current[1], vel[i, p, 2] + current[2]
            a0, a1, a2 = acc[i, p, 0], acc[i, p, 1], acc[i, p, 2]
            for c in range(3):
                vel[i, p, c] = v0 * R[0, c] + v1 * R[1, c] + v2 * R[2, c]
                acc[i, p, c] = a0 * R[0, c] + a1 * R[1, c] + a2 * R[2, c]
    return vel, acc


@njit(cache=True)
def _rotation(phi, th, psi):  # pragma: no cover - compiled
    """R(Θ) = R_z(ψ) R_y(θ) R_x(φ), body FRD → NED."""
    cf, sf, ct, st, cp, sp = math.cos(phi), math.sin(phi), math.cos(th), math.sin(th), math.cos(psi), math.sin(psi)
    R = np.empty((3, 3))
    R[0, 0], R[0, 1], R[0, 2] = cp * ct, -sp * cf + cp * st * sf, sp * sf + cp * cf * st
    R[1, 0], R[1, 1], R[1, 2] = sp * ct, cp * cf + sf * st * sp, -cp * sf + st * sp * cf
    R[2, 0], R[2, 1], R[2, 2] = -st, ct * sf, ct * cf
    return R


@njit(cache=True)
def _coriolis(pv, off, nu1, om):  # pragma: no cover - compiled
    """C(ν) ν of the mass matrix at pv[off:off + 36]: [ω × P₁; ν₁ × P₁ + ω × P₂], [P₁; P₂] = M ν."""
    P = np.zeros(6)
    for i in range(6):
        acc = 0.0
        for j in range(3):
            acc += pv[off + 6 * i + j] * nu1[j] + pv[off + 6 * i + 3 + j] * om[j]
        P[i] = acc
    out = np.empty(6)
    out[0] = om[1] * P[2] - om[2] * P[1]
    out[1] = om[2] * P[0] - om[0] * P[2]
    out[2] = om[0] * P[1] - om[1] * P[0]
    out[3] = nu1[1] * P[2] - nu1[2] * P[1] + om[1] * P[5] - om[2] * P[4]
    out[4] = nu1[2] * P[0] - nu1[0] * P[2] + om[2] * P[3] - om[0] * P[5]
    out[5] = nu1[0] * P[1] - nu1[1] * P[0] + om[0] * P[4] - om[1] * P[3]
    return out


@njit(cache=True)
def hydro_load6_arr(pv, nu, has_flow, pts, wts, vf, af):  # pragma: no cover - compiled
    """:func:`~bridge.models.strip_load6.hydrodynamic_load6` (6,): τ_h on the body moving with ν in the flow
    ``vf``, ``af`` (S, 3; body frame) at the strip points ``pts`` (S, 3) with weights ``wts``."""
    load = np.zeros(6)
    nr, om = np.empty(3), nu[3:6].copy()
    if has_flow:
        vbar, abar = np.zeros(3), np.zeros(3)
        for j in range(wts.size):
            dF = np.empty(3)
            for a in range(3):
                vr = nu[a] - vf[j, a]
                dF[a] = wts[j] * ((pv[28] + pv[9 + a]) * af[j, a] - (pv[16 + a] + pv[22 + a] * abs(vr)) * vr)
                load[a] += dF[a]
                vbar[a] += wts[j] * vf[j, a]
                abar[a] += wts[j] * af[j, a]
            load[3] += pts[j, 1] * dF[2] - pts[j, 2] * dF[1]
            load[4] += pts[j, 2] * dF[0] - pts[j, 0] * dF[2]
            load[5] += pts[j, 0] * dF[1] - pts[j, 1] * dF[0]
        if pv[29] > 0.5:     # the Froude–Krylov force's lever at z_b and the added-mass coupling M_A[3:, :3]
            z_fk = pv[8] * pv[28]
            load[3] -= z_fk * abar[1]
            load[4] += z_fk * abar[0]
            for i in range(3):
                for a in range(3):
                    load[3 + i] += pv[102 + 6 * (3 + i) + a] * abar[a]
        for a in range(3):
            nr[a] = nu[a] - vbar[a]
    else:
        for a in range(3):
            nr[a] = nu[a]
            load[a] = -(pv[16 + a] + pv[22 + a] * abs(nu[a])) * nu[a]
    for a in range(3):
        load[3 + a] -= (pv[19 + a] + pv[25 + a] * abs(om[a])) * om[a]
    ca = _coriolis(pv, 102, nr, om)
    for i in range(6):
        load[i] -= ca[i]
    return load


@njit(cache=True)
def rates6_arr(pv, x, tau, has_flow, pts, wts, vf, af):  # pragma: no cover - compiled
    """:func:`~bridge.models.motion6.state_derivative6`: ẋ (12,) for x = [η; ν] under τ (6,) in the flow."""
    phi, th, psi = x[3], x[4], x[5]
    nu = x[6:12]
    load = hydro_load6_arr(pv, nu, has_flow, pts, wts, vf, af)
    crb = _coriolis(pv, 30, nu[0:3], nu[3:6])
    z = x[2]
    B = pv[1] * min(1.0, max(0.0, z / pv[2] + 0.5))
    W = pv[0]
    sf, cf, st, ct = math.sin(phi), math.cos(phi), math.sin(th), math.cos(th)
    xg, yg, zg, xb, yb, zb = pv[3], pv[4], pv[5], pv[6], pv[7], pv[8]
    g = np.empty(6)
    g[0] = (W - B) * st
    g[1] = -(W - B) * ct * sf
    g[2] = -(W - B) * ct * cf
    g[3] = -(yg * W - yb * B) * ct * cf + (zg * W - zb * B) * ct * sf
    g[4] = (zg * W - zb * B) * st + (xg * W - xb * B) * ct * cf
    g[5] = -(xg * W - xb * B) * ct * sf - (yg * W - yb * B) * st
    rhs = np.empty(6)
    for i in range(6):
        rhs[i] = tau[i] + load[i] - crb[i] - g[i]
    R = _rotation(phi, th, psi)
    out = np.empty(12)
    for i in range(3):
        out[i] = R[i, 0] * nu[0] + R[i, 1] * nu[1] + R[i, 2] * nu[2]
    tt = st / ct
    out[3] = nu[3] + sf * tt * nu[4] + cf * tt * nu[5]
    out[4] = cf * nu[4] - sf * nu[5]
    out[5] = (sf * nu[4] + cf * nu[5]) / ct
    for i in range(6):
        acc = 0.0
        for j in range(6):
            acc += pv[66 + 6 * i + j] * rhs[j]
        out[6 + i] = acc
    return out


@njit(cache=True)
def rk4_6_arr(pv, x, h, tau_stages, has_flow, pts, wts, vf, af):  # pragma: no cover - compiled
    """:func:`~bridge.models.motion6.rk4_step6`; the flow arrays are (3, S, 3), one per stage time."""
    k1 = rates6_arr(pv, x, tau_stages[0], has_flow, pts, wts, vf[0], af[0])
    k2 = rates6_arr(pv, x + (0.5 * h) * k1, tau_stages[1], has_flow, pts, wts, vf[1], af[1])
    k3 = rates6_arr(pv, x + (0.5 * h) * k2, tau_stages[1], has_flow, pts, wts, vf[1], af[1])
    k4 = rates6_arr(pv, x + h * k3, tau_stages[2], has_flow, pts, wts, vf[2], af[2])
    return x + (h / 6.0) * (k1 + 2.0 * (k2 + k3) + k4)


def step_flow6(waves: WaveComponents, eta: np.ndarray, t: np.ndarray, grid: tuple, current: np.ndarray):
    """(velocity, acceleration) (T, S, 3), body frame, at the strips of ``grid`` = (xs, ys, x mirrors,
    y mirrors) for a body at pose η (6,), at times t (s): :func:`body_flow6_arr` on a component set."""
    xs, ys, xm, ym = grid
    e2d, _, inv, inv4 = waves._depth_constants
    coef, rate = waves._series_constants
    beta = np.zeros(waves.n) if waves.direction is None else np.asarray(waves.direction, dtype=float)
    R = _rotation(float(eta[3]), float(eta[4]), float(eta[5]))
    return body_flow6_arr(waves.k, waves.omega, waves.phase, coef, rate, e2d, inv, inv4, waves.water_depth,
                          np.cos(beta), np.sin(beta), eta, R, xs, ys, xm, ym, t, current)


_warm = False


def warm_up6() -> None:
    """Load (or compile) the six-DoF kernels once per process, with tiny inputs (as ``kernels.warm_up``)."""
    global _warm
    if _warm or not ENABLED:
        return
    _warm = True
    one, z1 = np.ones(1), np.zeros(1)
    nodes, mir = np.array([-0.1, 0.0, 0.1]), np.array([-1, -2, 0])
    body_flow6_arr(one, one, z1, np.ones((2, 1)), np.ones((2, 1)), z1, one, one, 10.0, one, z1,
                   np.array([0.0, 0.0, 1.0, 0.0, 0.0, 0.0]), np.eye(3), nodes, nodes, mir, mir, np.zeros(3),
                   np.zeros(3))
    pv = np.ones(138)
    pts, wts, f = np.zeros((1, 3)), np.ones(1), np.zeros((3, 1, 3))
    for has in (True, False):
        rk4_6_arr(pv, np.zeros(12), 0.05, np.zeros((3, 6)), has, pts, wts, f, f)
