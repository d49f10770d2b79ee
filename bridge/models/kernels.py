"""Compiled (numba) kernels for the models' hot paths, with the pure-numpy code as reference.

The wave kinematics at a body's strips (:func:`body_flow_arrays`), the
relative-velocity load (:func:`hydro_load`), the rates of paper Eq. 2
(:func:`state_rates_arr`), one RK4 step (:func:`rk4_arr`), the
estimator's finite-difference Jacobian (:func:`jacobian_arr`) and the
saturation preview's simulation (:func:`preview_worst_arr`) are written
here once, in loops over plain float arrays, in the same arithmetic order as
the reference code in :mod:`bridge.models.waves` and
:mod:`bridge.models.vehicle` (tests assert agreement to 1e-12). The motor
mixer's allocation (:func:`allocate_arr`) and the T200 curve's whole-µs
command (:func:`t200_command_arr`) are their references' operations one
for one: the same bits. The MPC horizon's rollout and its analytic linearisation build on these in
:mod:`bridge.models.horizon_kernels`.

``WAVEKEEP_NUMBA=0`` in the environment (read at import) selects the
reference numpy/Python path everywhere; so does a missing numba. The
kernels are compiled with ``cache=True`` (to ``__pycache__`` beside this
file, or ``NUMBA_CACHE_DIR``): the first run on a machine pays the compile
(a few seconds), later processes load the machine code.

Parameter vector (``VehicleParams.kernel_params``), float64, in this order::

    0 W   1 B   2 height   3 r_G[0]   4 r_G[2]   5 r_B[0]   6 r_B[2]
    7 X_udot   8 Z_wdot   9 X_qdot   10 X_u   11 Z_w   12 M_q   13 X_uu   14 Z_ww   15 M_qq
    16 M_RB[0,0]   17 M_RB[0,2]   18 M_RB[1,1]   19 M_RB[1,2]   20..28 M⁻¹ row-major
    29 fk_mass (ρ∇, or 0 in the paper's load model)   30 fluid_pitch_coupling (M_u̇ + ρ∇ z_B, or 0)
"""
from __future__ import annotations

import math
import os

import numpy as np

__all__ = ["ENABLED", "allocate_arr", "body_flow_arrays", "body_flow_at_phases", "hydro_load", "jacobian_arr",
           "prediction_matrix_arr", "preview_worst_arr",
           "rk4_arr", "shifted_time_phases", "state_rates_arr", "t200_command_arr", "time_phases", "warm_up"]


def _wanted() -> bool:
    """True unless WAVEKEEP_NUMBA is 0/false/no/off."""
    return os.environ.get("WAVEKEEP_NUMBA", "1").strip().lower() not in ("0", "false", "no", "off")


try:
    if not _wanted():
        raise ImportError("WAVEKEEP_NUMBA=0")
    from numba import njit
    ENABLED = True
except ImportError:   # the reference path only: the kernels below run as plain Python (tests call them so)
    ENABLED = False

    def njit(*args, **kwargs):  # type: ignore[no-redef]
        """Stand-in for numba.njit: returns the function unchanged."""
        return args[0] if args and callable(args[0]) else (lambda f: f)


@njit(cache=True)
def body_flow_arrays(k, omega, phase, coef, rate, x_e2d, inv, inv4, water_depth,
                     eta0, eta1, th, xs, t, kx, hx):  # pragma: no cover - compiled
    """Fluid velocity and local acceleration at a body's strips, body frame: out[4, T, S] = u, w, u̇, ẇ.

    Components k (rad/m), ω (rad/s), ε (rad); ``coef``/``rate`` the (orders, N) series
    constants of :class:`~bridge.models.waves.WaveComponents`; ``x_e2d`` = e^{−2kd}, ``inv`` =
    1/(1 − e^{−2kd}), ``inv4`` = 8 inv⁴; pose (η0 m, η1 m depth, θ rad); strip x' (m); times t (s); ``kx``,
    ``hx``: k cos β and cos β (``WaveComponents.kx``, ``in_plane_or_ones``). The arithmetic of
    :func:`~bridge.models.vehicle.body_flow` over
    :func:`~bridge.models.waves.particle_kinematics_grid`, summed per component in order.
    """
    cb, sb = time_phases(omega, t, coef.shape[0])
    return body_flow_at_phases(k, phase, coef, rate, x_e2d, inv, inv4, water_depth, eta0, eta1, th, xs, cb, sb,
                               kx, hx)


@njit(cache=True)
def time_phases(omega, t, orders):  # pragma: no cover - compiled
    """cos and sin of ω t per time and order (order 2 by the double angle), laid out (T, orders·N) each."""
    n, T = omega.size, t.size
    cb = np.empty((T, orders * n))
    sb = np.empty((T, orders * n))
    for i in range(T):
        for j in range(n):
            b = t[i] * omega[j]
            cb[i, j] = math.cos(b)
            sb[i, j] = math.sin(b)
            if orders > 1:
                cb[i, n + j] = cb[i, j] ** 2 - sb[i, j] ** 2
                sb[i, n + j] = cb[i, j] * sb[i, j] * 2.0
    return cb, sb


@njit(cache=True)
def shifted_time_phases(omega, t0, cos_o, sin_o, orders):  # pragma: no cover - compiled
    """:func:`time_phases` at the times t0 + o_i from cos(ω o_i), sin(ω o_i) (T, N), by angle addition: N sines
    and cosines instead of T·N, equal to :func:`time_phases`' to rounding (≈ 1e-16 a phase)."""
    n, T = omega.size, cos_o.shape[0]
    cb = np.empty((T, orders * n))
    sb = np.empty((T, orders * n))
    for j in range(n):
        c0, s0 = math.cos(t0 * omega[j]), math.sin(t0 * omega[j])
        for i in range(T):
            cb[i, j] = c0 * cos_o[i, j] - s0 * sin_o[i, j]
            sb[i, j] = s0 * cos_o[i, j] + c0 * sin_o[i, j]
            if orders > 1:
                cb[i, n + j] = cb[i, j] ** 2 - sb[i, j] ** 2
                sb[i, n + j] = cb[i, j] * sb[i, j] * 2.0
    return cb, sb


@njit(cache=True)
def body_flow_at_phases(k, phase, coef, rate, x_e2d, inv, inv4, water_depth,
                        eta0, eta1, th, xs, cb, sb, kx, hx):  # pragma: no cover - compiled
    """:func:`body_flow_arrays` with the time phases given (:func:`time_phases` or :func:`shifted_time_phases`)."""
    orders, n = coef.shape
    S, T = xs.size, cb.shape[0]
    c, s = math.cos(th), math.sin(th)
    on = orders * n
    out = np.empty((4, T, S))
    W = np.empty((4, on))
    Wc = np.empty((4, on))
    Ws = np.empty((4, on))
    for p in range(S):
        xe = eta0 + xs[p] * c
        dep = min(max(eta1 - xs[p] * s, 0.0), water_depth)
        for j in range(n):
            a = xe * kx[j] + phase[j]
            ca1, sa1 = math.cos(a), math.sin(a)
            ea = math.exp(-dep * k[j])
            eb = x_e2d[j] / ea
            W[0, j] = (ea + eb) * inv[j] * coef[0, j] * hx[j]
            W[1, j] = (ea - eb) * inv[j] * coef[0, j]
            W[2, j] = W[0, j] * rate[0, j]
            W[3, j] = W[1, j] * rate[0, j]
            for m in range(4):
                Wc[m, j] = W[m, j] * ca1
                Ws[m, j] = W[m, j] * sa1
            if orders > 1:
                ca2, sa2 = ca1 ** 2 - sa1 ** 2, ca1 * sa1 * 2.0
                ea2 = ea * ea * x_e2d[j]
                eb2 = eb * eb * x_e2d[j]
                jj = n + j
                W[0, jj] = (ea2 + eb2) * inv4[j] * coef[1, j] * hx[j]
                W[1, jj] = (ea2 - eb2) * inv4[j] * coef[1, j]
                W[2, jj] = W[0, jj] * rate[1, j]
                W[3, jj] = W[1, jj] * rate[1, j]
                for m in range(4):
                    Wc[m, jj] = W[m, jj] * ca2
                    Ws[m, jj] = W[m, jj] * sa2
        for i in range(T):
            # Σ W cos θ = Σ (W cos a) cos b + Σ (W sin a) sin b; Σ W sin θ = Σ (W sin a) cos b − Σ (W cos a) sin b
            # eight independent sums in one pass (each in index order): latency, not one chain, bounds it
            c0 = s0 = c1 = s1 = c2 = s2 = c3 = s3 = 0.0
            for j in range(on):
                cbj, sbj = cb[i, j], sb[i, j]
                c0 += Wc[0, j] * cbj
                s0 += Ws[0, j] * sbj
                c1 += Ws[1, j] * cbj
                s1 += Wc[1, j] * sbj
                c2 += Ws[2, j] * cbj
                s2 += Wc[2, j] * sbj
                c3 += Wc[3, j] * cbj
                s3 += Ws[3, j] * sbj
            u = c0 + s0
            w = -(c1 - s1)
            ud = c2 - s2
            wd = c3 + s3
            out[0, i, p] = c * u - s * w
            out[1, i, p] = s * u + c * w
            out[2, i, p] = c * ud - s * wd
            out[3, i, p] = s * ud + c * wd
    return out


@njit(cache=True)
def hydro_load(pv, u, w, q, has_flow, xs, wts, up, wp, ax, az):  # pragma: no cover - compiled
    """:func:`~bridge.models.vehicle.hydrodynamic_load` (N, N, N m) with the flow as arrays (S,)."""
    X_udot, Z_wdot, X_qdot = pv[7], pv[8], pv[9]
    X_u, Z_w, M_q, X_uu, Z_ww, M_qq = pv[10], pv[11], pv[12], pv[13], pv[14], pv[15]
    if not has_flow:
        ur, wr = u, w
        X = -(X_u + X_uu * abs(u)) * u
        Z = -(Z_w + Z_ww * abs(w)) * w
        Mh = 0.0
    else:
        m_x, m_z = X_udot + pv[29], Z_wdot + pv[29]
        X = Z = Mh = ub = wb = axb = 0.0
        for j in range(xs.size):
            urj, wrj = u - up[j], w - wp[j]
            fz = m_z * az[j] - (Z_w + Z_ww * abs(wrj)) * wrj
            X += wts[j] * (m_x * ax[j] - (X_u + X_uu * abs(urj)) * urj)
            Z += wts[j] * fz
            Mh -= wts[j] * xs[j] * fz
            ub += wts[j] * up[j]
            wb += wts[j] * wp[j]
            axb += wts[j] * ax[j]
        Mh += pv[30] * axb
        ur, wr = u - ub, w - wb
    pAx, pAz = X_udot * ur + X_qdot * q, Z_wdot * wr
    X -= pAz * q
    Z += pAx * q
    Mh += pAz * ur - pAx * wr - (M_q + M_qq * abs(q)) * q
    return X, Z, Mh


@njit(cache=True)
def state_rates_arr(pv, x, tau, has_flow, xs, wts, up, wp, ax, az):  # pragma: no cover - compiled
    """:func:`~bridge.models.vehicle.state_rates`: ẋ (6,) for x = [η, ν] under τ in the flow (arrays (S,))."""
    z, th, u, w, q = x[1], x[2], x[3], x[4], x[5]
    c, s = math.cos(th), math.sin(th)
    p_x, p_z = pv[16] * u + pv[17] * q, pv[18] * w + pv[19] * q
    Xh, Zh, Mh = hydro_load(pv, u, w, q, has_flow, xs, wts, up, wp, ax, az)
    W, B = pv[0], pv[1]
    if not z >= 0.5 * pv[2]:
        B = B * min(1.0, max(0.0, z / pv[2] + 0.5))
    WB = W - B
    BG_z = pv[4] * W - pv[6] * B
    BG_x = pv[3] * W - pv[5] * B
    r0 = tau[0] + Xh - p_z * q - WB * s
    r1 = tau[1] + Zh + p_x * q + WB * c
    r2 = tau[2] + Mh + p_z * u - p_x * w - BG_z * s - BG_x * c
    out = np.empty(6)
    out[0] = c * u + s * w
    out[1] = -s * u + c * w
    out[2] = q
    for i in range(3):
        out[3 + i] = pv[20 + 3 * i] * r0 + pv[21 + 3 * i] * r1 + pv[22 + 3 * i] * r2
    return out


@njit(cache=True)
def rk4_arr(pv, x, h, tau_stages, has_flow, xs, wts, up, wp, ax, az):  # pragma: no cover - compiled
    """:func:`~bridge.models.vehicle.rk4_step`; the flow arrays are (3, S), one row per stage time."""
    k1 = state_rates_arr(pv, x, tau_stages[0], has_flow, xs, wts, up[0], wp[0], ax[0], az[0])
    k2 = state_rates_arr(pv, x + (0.5 * h) * k1, tau_stages[1], has_flow, xs, wts, up[1], wp[1], ax[1], az[1])
    k3 = state_rates_arr(pv, x + (0.5 * h) * k2, tau_stages[1], has_flow, xs, wts, up[1], wp[1], ax[1], az[1])
    k4 = state_rates_arr(pv, x + h * k3, tau_stages[2], has_flow, xs, wts, up[2], wp[2], ax[2], az[2])
    return x + (h / 6.0) * (k1 + 2.0 * (k2 + k3) + k4)


@njit(cache=True)
def jacobian_arr(pv, x, tau, has_flow, xs, wts, up, wp, ax, az):  # pragma: no cover - compiled
    """A = ∂ẋ/∂x (6, 6) by forward differences, step 1e-6·max(1, |x_j|) (the estimator's F)."""
    f0 = state_rates_arr(pv, x, tau, has_flow, xs, wts, up, wp, ax, az)
    A = np.empty((6, 6))
    for j in range(6):
        d = 1e-6 * max(1.0, abs(x[j]))
        xp = x.copy()
        xp[j] += d
        fj = state_rates_arr(pv, xp, tau, has_flow, xs, wts, up, wp, ax, az)
        for i in range(6):
            A[i, j] = (fj[i] - f0[i]) / d
    return A


@njit(cache=True)
def prediction_matrix_arr(A, B, E):  # pragma: no cover - compiled
    """:func:`~firmware_py.control.mpc_qp.prediction_matrix`: S (6N, 3N) with δX = S δV for
    δx_{k+1} = A_k δx_k + B_k δv_k + E_k δv_{k−1}; block row k is x_{k+1}, and only its columns ≤ k fill."""
    n = A.shape[0]
    S = np.zeros((6 * n, 3 * n))
    for k in range(n):
        r = 6 * k
        if k:
            for i in range(6):
                for c in range(3 * k):
                    acc = 0.0
                    for j in range(6):
                        acc += A[k, i, j] * S[r - 6 + j, c]
                    S[r + i, c] = acc
            for i in range(6):
                for c in range(3):
                    S[r + i, 3 * (k - 1) + c] += E[k, i, c]
        for i in range(6):
            for c in range(3):
                S[r + i, 3 * k + c] += B[k, i, c]
    return S


@njit(cache=True)
def preview_worst_arr(pv, gains, xs, wts, up, wp, ax, az, cands, e0, v0, s0, dt, step):  # pragma: no cover
    """:func:`~firmware_py.control.preview.preview_excursions`'s simulation: largest |e| (C, 2) per candidate.

    ``gains`` (6, 2) rows K_p, K_d, K_v, ν_max, τ_max, FF limit (N) for [X, Z]; the flow arrays
    are (N, S), one row per step; ``cands`` (C, 2); ``e0``, ``v0``, ``s0`` (2,).
    """
    n, nc = up.shape[0], cands.shape[0]
    mass = (pv[16] + pv[7], pv[18] + pv[8])
    lin, quad = (pv[10], pv[11]), (pv[13], pv[14])
    worst = np.empty((nc, 2))
    for c in range(nc):
        e = [e0[0], e0[1]]
        v = [v0[0], v0[1]]
        s = [s0[0], s0[1]]
        worst[c, 0], worst[c, 1] = abs(e[0]), abs(e[1])
        for j in range(n):
            f = hydro_load(pv, v[0], v[1], 0.0, True, xs, wts, up[j], wp[j], ax[j], az[j])
            for a in range(2):
                tau_ff = -min(max(f[a] + (lin[a] + quad[a] * abs(v[a])) * v[a], -gains[5, a]), gains[5, a])
                v_d = min(max(gains[0, a] * (s[a] - e[a]) - gains[1, a] * v[a], -gains[3, a]), gains[3, a])
                u_n = min(max(gains[2, a] * (v_d - v[a]) + tau_ff / gains[4, a], -1.0), 1.0)
                v[a] = v[a] + dt * (f[a] + gains[4, a] * u_n) / mass[a]
                e[a] = e[a] + dt * v[a]
                s[a] = s[a] + min(max(cands[c, a] - s[a], -step), step)
                worst[c, a] = max(worst[c, a], abs(e[a]))
    return worst


@njit(cache=True)
def allocate_arr(pinv, tau, order, bounds, f_max):  # pragma: no cover - compiled
    """:meth:`~firmware_py.motors.mixer.MotorMixer.allocate`: thrusts (n,) N for the wrench τ (m,), its axes
    taken in groups, attitude first, within ±f_max.

    ``pinv`` (n, m) is B⁺; group k is the axes ``order[bounds[k]:bounds[k + 1]]``. Per group
    g = Σ B⁺[:, axis] τ[axis] (one axis: that product alone) and the largest s in [0, 1] with
    |f + s g| ≤ f_max; f += s g: a group's axes are scaled together, keeping their ratio. The
    reference's operations one for one, every thruster included (its skipped exact zeros add
    nothing): the same bits.
    """
    n = pinv.shape[0]
    f = np.zeros(n)
    g = np.empty(n)
    for k in range(bounds.size - 1):
        a0 = order[bounds[k]]
        for i in range(n):
            g[i] = pinv[i, a0] * tau[a0]
        for j in range(bounds[k] + 1, bounds[k + 1]):
            a = order[j]
            for i in range(n):
                g[i] = g[i] + pinv[i, a] * tau[a]
        room = math.inf
        for i in range(n):
            gi = g[i]
            if gi > 0:
                r = (f_max - f[i]) / gi
            elif gi < 0:
                r = (-f_max - f[i]) / gi
            else:
                continue
            if r < room:
                room = r
        scale = 1.0 if room >= 1.0 else (room if room > 0.0 else 0.0)
        for i in range(n):
            f[i] = f[i] + scale * g[i]
    return f


@njit(cache=True)
def _interp_one(x, xp, fp):  # pragma: no cover - compiled
    """``np.interp(x, xp, fp)`` for one finite x and strictly increasing xp: numpy's loop (``arr_interp``).

    The piece j with xp[j] ≤ x < xp[j+1]; the end values beyond either end and at the last knot,
    fp[j] on a knot, else (fp[j+1] − fp[j]) / (xp[j+1] − xp[j]) · (x − xp[j]) + fp[j].
    """
    n = xp.size
    if x < xp[0]:
        return fp[0]
    if x >= xp[n - 1]:
        return fp[n - 1]
    lo, hi = 0, n - 1            # xp[lo] ≤ x < xp[hi]
    while hi - lo > 1:
        mid = (lo + hi) >> 1
        if xp[mid] <= x:
            lo = mid
        else:
            hi = mid
    if xp[lo] == x:
        return fp[lo]
    slope = (fp[lo + 1] - fp[lo]) / (xp[lo + 1] - xp[lo])
    return slope * (x - xp[lo]) + fp[lo]


@njit(cache=True)
def t200_command_arr(f, f_lo, f_hi, neutral, rev_f, rev_pwm, fwd_f, fwd_pwm, p_lo, p_hi, knots, coef):
    """:meth:`~bridge.models.thrusters.T200Curve.command`: whole-µs PWM (int64) for thrusts f (N), and their thrust.

    Inverse curve: f clipped to [f_lo, f_hi], interpolated in the (rev_f → rev_pwm) table below zero
    and (fwd_f → fwd_pwm) above, ``neutral`` at zero and NaN, rounded half to even. Forward curve:
    the PWM clipped to [p_lo, p_hi], the PCHIP piece (``knots``, ``coef`` highest power first) by
    ``searchsorted(side="right") − 1`` and c₃ + c₂ s + c₁ s² + c₀ s³ in that order.
    """
    n = f.size
    pwm = np.empty(n, np.int64)
    thrust = np.empty(n)
    last = knots.size - 2
    for i in range(n):
        x = f[i]
        x = f_lo if x < f_lo else (f_hi if x > f_hi else x)
        if x > 0.0:
            p = _interp_one(x, fwd_f, fwd_pwm)
        elif x < 0.0:
            p = _interp_one(x, rev_f, rev_pwm)
        else:
            p = neutral
        pwm[i] = np.int64(np.rint(p))
        q = float(pwm[i])
        q = p_lo if q < p_lo else (p_hi if q > p_hi else q)
        j = np.searchsorted(knots, q, side="right") - 1
        j = 0 if j < 0 else (last if j > last else j)
        s = q - knots[j]
        z = s * s
        thrust[i] = coef[3, j] + coef[2, j] * s + coef[1, j] * z + coef[0, j] * (z * s)
    return pwm, thrust


_warm = False


def warm_up() -> None:
    """Load (or compile) every kernel now, once per process, with tiny inputs.

    numba resolves and loads a kernel's cached machine code on its first call (≈ 0.1–0.3 s
    in all); a real-time loop must not pay that on its first ticks, so the models call this
    when they are built (:class:`~bridge.models.vehicle.VehicleParams`).
    """
    global _warm
    if _warm or not ENABLED:
        return
    _warm = True
    one, z1, z3 = np.ones(1), np.zeros(1), np.zeros((3, 1))
    pv = np.ones(31)
    body_flow_arrays(one, one, z1, np.ones((2, 1)), np.ones((2, 1)), z1, one, one, 10.0, 0.0, 1.0, 0.0, z1,
                     np.zeros(3), one, one)
    shifted_time_phases(one, 0.0, np.ones((1, 1)), np.zeros((1, 1)), 2)
    x, tau = np.zeros(6), np.zeros((3, 3))
    for has in (True, False):
        hydro_load(pv, 0.0, 0.0, 0.0, has, z1, one, z1, z1, z1, z1)
        state_rates_arr(pv, x, tau[0], has, z1, one, z1, z1, z1, z1)
        rk4_arr(pv, x, 0.05, tau, has, z1, one, z3, z3, z3, z3)
        jacobian_arr(pv, x, tau[0], has, z1, one, z1, z1, z1, z1)
    z2, g = np.zeros(2), np.ones((6, 2))
    preview_worst_arr(pv, g, z1, one, z3, z3, z3, z3, np.zeros((1, 2)), z2, z2, z2, 0.1, 0.1)
    prediction_matrix_arr(np.zeros((1, 6, 6)), np.zeros((1, 6, 3)), np.zeros((1, 6, 3)))
    allocate_arr(np.ones((8, 3)), np.zeros(3), np.array([2, 1, 0]), np.array([0, 1, 2, 3]), 1.0)
    tab, knots = np.array([-1.0, 0.0]), np.array([0.0, 1.0, 2.0])
    t200_command_arr(np.zeros(8), -1.0, 1.0, 1.5, tab, tab, tab, tab, 0.0, 2.0, knots, np.ones((4, 2)))
