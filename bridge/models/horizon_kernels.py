"""The MPC horizon's rollout with the analytic linearisation of each RK4 step, compiled (numba).

For x_{k+1} = F(x_k, v_{k−1}, v_k), one classical RK4 step of the rates ẋ = f(x, τ) of paper Eq. 2
(:func:`~bridge.models.kernels.state_rates_arr`) under the stage wrenches τ_1 = v_{k−1} + d,
τ_2 = τ_3 = v_{k−1} + α(v_k − v_{k−1}) + d, τ_4 = v_k + d (:mod:`bridge.models.horizon`), the chain rule
through the four stages gives the Jacobians exactly:

    D_1 = J_1,  D_2 = J_2 (I + h/2 D_1),  D_3 = J_3 (I + h/2 D_2),  D_4 = J_4 (I + h D_3)
    ∂F/∂x = I + h/6 (D_1 + 2 D_2 + 2 D_3 + D_4)

with J_i = ∂f/∂x at stage i's state (:func:`rates_jacobian_arr`), and for an input v with stage
sensitivities σ_i = ∂τ_i/∂v (the same for each of its three axes) and G = ∂f/∂τ = [0; M⁻¹]:

    Γ_1 = G σ_1,  Γ_2 = J_2 (h/2 Γ_1) + G σ_2,  Γ_3 = J_3 (h/2 Γ_2) + G σ_3,  Γ_4 = J_4 (h Γ_3) + G σ_4
    ∂F/∂v = h/6 (Γ_1 + 2 Γ_2 + 2 Γ_3 + Γ_4).

One RK4 step and four 6 × 6 Jacobians of f a horizon step, where forward differences took thirteen RK4
steps. The flow at the strips is sampled at the horizon's pose, so it does not depend on the state. The
rollout is :func:`~bridge.models.kernels.rk4_arr`'s arithmetic (the same bits). The forward-difference
reference (:func:`~bridge.models.horizon.linearise_horizon` with the kernels off) checks it.
"""
from __future__ import annotations

import math

import numpy as np

from . import kernels
from .kernels import njit, state_rates_arr

__all__ = ["horizon_lin_arr", "rates_jacobian_arr", "rk4_linearised_arr", "warm_up"]


@njit(cache=True)
def _hydro_jacobian(pv, u, w, q, has_flow, xs, wts, up, wp):  # pragma: no cover - compiled
    """∂(X, Z, M)/∂(u, w, q) of :func:`~bridge.models.kernels.hydro_load` (3, 3): drag on each strip's
    relative velocity (d(v|v|)/dv = 2|v|), the added-mass Coriolis terms on the mean relative velocity and
    the rotational damping. The flow's accelerations enter linearly and drop out."""
    X_udot, Z_wdot, X_qdot = pv[7], pv[8], pv[9]
    X_u, Z_w, M_q, X_uu, Z_ww, M_qq = pv[10], pv[11], pv[12], pv[13], pv[14], pv[15]
    if not has_flow:
        dX_u = -(X_u + 2.0 * X_uu * abs(u))
        dZ_w = -(Z_w + 2.0 * Z_ww * abs(w))
        dM_w = 0.0
        ur, wr = u, w
    else:
        dX_u = dZ_w = dM_w = ub = wb = 0.0
        for j in range(xs.size):
            dfz = -(Z_w + 2.0 * Z_ww * abs(w - wp[j]))
            dX_u += wts[j] * -(X_u + 2.0 * X_uu * abs(u - up[j]))
            dZ_w += wts[j] * dfz
            dM_w -= wts[j] * xs[j] * dfz
            ub += wts[j] * up[j]
            wb += wts[j] * wp[j]
        ur, wr = u - ub, w - wb
    pAx, pAz = X_udot * ur + X_qdot * q, Z_wdot * wr
    H = np.zeros((3, 3))
    # X −= pAz q;  Z += pAx q;  M += pAz u_r − pAx w_r − (M_q + M_q|q| |q|) q
    H[0, 0], H[0, 1], H[0, 2] = dX_u, -Z_wdot * q, -pAz
    H[1, 0], H[1, 1], H[1, 2] = X_udot * q, dZ_w, pAx + X_qdot * q
    H[2, 0] = pAz - X_udot * wr
    H[2, 1] = dM_w + Z_wdot * ur - pAx
    H[2, 2] = -X_qdot * wr - (M_q + 2.0 * M_qq * abs(q))
    return H


@njit(cache=True)
def rates_jacobian_arr(pv, x, has_flow, xs, wts, up, wp):  # pragma: no cover - compiled
    """J = ∂ẋ/∂x (6, 6) of :func:`~bridge.models.kernels.state_rates_arr` at x = [x, z, θ, u, w, q], exact.

    The kinematics' rotation by θ, the restoring terms' θ and the buoyancy's fade in z near the surface,
    the rigid-body Coriolis terms and the hydrodynamic load (:func:`_hydro_jacobian`), through M⁻¹."""
    z, th, u, w, q = x[1], x[2], x[3], x[4], x[5]
    c, s = math.cos(th), math.sin(th)
    m11, m13, m22, m23 = pv[16], pv[17], pv[18], pv[19]
    p_x, p_z = m11 * u + m13 * q, m22 * w + m23 * q
    W, B0, height = pv[0], pv[1], pv[2]
    B, dB = B0, 0.0
    if not z >= 0.5 * height:
        frac = z / height + 0.5
        B = B0 * min(1.0, max(0.0, frac))
        if 0.0 < frac < 1.0:
            dB = B0 / height
    WB = W - B
    BG_z, BG_x = pv[4] * W - pv[6] * B, pv[3] * W - pv[5] * B
    H = _hydro_jacobian(pv, u, w, q, has_flow, xs, wts, up, wp)
    # ∂r/∂x_j for r = [r0, r1, r2] of state_rates_arr, columns z, θ, u, w, q (x does not enter)
    dr = np.zeros((3, 6))
    dr[0, 1], dr[1, 1], dr[2, 1] = dB * s, -dB * c, pv[6] * dB * s + pv[5] * dB * c
    dr[0, 2], dr[1, 2], dr[2, 2] = -WB * c, -WB * s, -BG_z * c + BG_x * s
    dr[0, 3], dr[1, 3], dr[2, 3] = H[0, 0], H[1, 0] + m11 * q, H[2, 0] + p_z - m11 * w
    dr[0, 4], dr[1, 4], dr[2, 4] = H[0, 1] - m22 * q, H[1, 1], H[2, 1] + m22 * u - p_x
    dr[0, 5], dr[1, 5], dr[2, 5] = H[0, 2] - (p_z + m23 * q), H[1, 2] + p_x + m13 * q, H[2, 2] + m23 * u - m13 * w
    J = np.zeros((6, 6))
    J[0, 2], J[0, 3], J[0, 4] = -s * u + c * w, c, s
    J[1, 2], J[1, 3], J[1, 4] = -c * u - s * w, -s, c
    J[2, 5] = 1.0
    for i in range(3):
        for j in range(1, 6):
            J[3 + i, j] = pv[20 + 3 * i] * dr[0, j] + pv[21 + 3 * i] * dr[1, j] + pv[22 + 3 * i] * dr[2, j]
    return J


@njit(cache=True)
def _input_stage(pv, J, h_prev, G_prev, sigma):  # pragma: no cover - compiled
    """Γ_i = J (h_prev Γ_{i−1}) + G σ_i (6, 3), G = [0; M⁻¹]; Γ_{i−1} None-like when h_prev is 0."""
    out = np.zeros((6, 3))
    if h_prev != 0.0:
        for i in range(6):
            for j in range(3):
                acc = 0.0
                for m in range(6):
                    acc += J[i, m] * G_prev[m, j]
                out[i, j] = h_prev * acc
    for i in range(3):
        for j in range(3):
            out[3 + i, j] += pv[20 + 3 * i + j] * sigma
    return out


@njit(cache=True)
def rk4_linearised_arr(pv, x, h, tau_stages, sig_v, sig_p, has_flow, xs, wts, up, wp, ax, az):  # pragma: no cover
    """One RK4 step (:func:`~bridge.models.kernels.rk4_arr`'s arithmetic) and its Jacobians: (x_next (6,),
    ∂F/∂x (6, 6), ∂F/∂v (6, 3), ∂F/∂v_prev (6, 3)); ``sig_v``, ``sig_p`` (4,) the stage wrenches' sensitivities
    to v and v_prev; the flow arrays (3, S), one row per stage time (the module docstring)."""
    rows = (0, 1, 1, 2)
    gains = (0.0, 0.5 * h, 0.5 * h, h)        # stage i's state is x + gains[i] k_{i−1}
    k = np.zeros((4, 6))
    D = np.zeros((4, 6, 6))
    Gv = np.zeros((4, 6, 3))
    Gp = np.zeros((4, 6, 3))
    for i in range(4):
        r = rows[i]
        xi = x if i == 0 else x + gains[i] * k[i - 1]
        k[i] = state_rates_arr(pv, xi, tau_stages[r], has_flow, xs, wts, up[r], wp[r], ax[r], az[r])
        J = rates_jacobian_arr(pv, xi, has_flow, xs, wts, up[r], wp[r])
        if i == 0:
            D[0] = J
        else:
            # D_i = J (I + g D_{i−1})
            for a in range(6):
                for b in range(6):
                    acc = J[a, b]
                    for m in range(6):
                        acc += gains[i] * J[a, m] * D[i - 1, m, b]
                    D[i, a, b] = acc
        Gv[i] = _input_stage(pv, J, gains[i], Gv[i - 1] if i else Gv[0], sig_v[i])
        Gp[i] = _input_stage(pv, J, gains[i], Gp[i - 1] if i else Gp[0], sig_p[i])
    x_next = x + (h / 6.0) * (k[0] + 2.0 * (k[1] + k[2]) + k[3])
    F = np.eye(6) + (h / 6.0) * (D[0] + 2.0 * (D[1] + D[2]) + D[3])
    Bv = (h / 6.0) * (Gv[0] + 2.0 * (Gv[1] + Gv[2]) + Gv[3])
    Ep = (h / 6.0) * (Gp[0] + 2.0 * (Gp[1] + Gp[2]) + Gp[3])
    return x_next, F, Bv, Ep


@njit(cache=True)
def horizon_lin_arr(pv, x0, tau0, V, dt, a_mid, d, has_flow, xs, wts, up, wp, ax, az):  # pragma: no cover
    """:func:`~bridge.models.horizon.linearise_horizon`, analytic: rollout X (N+1, 6) and the Jacobians
    A (N, 6, 6), B (N, 6, 3), E (N, 6, 3); the flow arrays are (3N, S), step k's stages at rows 3k..3k+2."""
    n = V.shape[0]
    X = np.empty((n + 1, 6))
    A = np.empty((n, 6, 6))
    B = np.empty((n, 6, 3))
    E = np.empty((n, 6, 3))
    X[0] = x0
    st = np.empty((3, 3))
    for k in range(n):
        r = 3 * k
        vp = tau0 if k == 0 else V[k - 1]
        vk = V[k]
        for c in range(3):
            st[0, c] = vp[c] + d[c]
            st[1, c] = vp[c] + a_mid[k] * (vk[c] - vp[c]) + d[c]
            st[2, c] = vk[c] + d[c]
        am = a_mid[k]
        sig_v = np.array([0.0, am, am, 1.0])
        sig_p = np.array([1.0, 1.0 - am, 1.0 - am, 0.0])
        xn, Ak, Bk, Ek = rk4_linearised_arr(pv, X[k].copy(), dt[k], st, sig_v, sig_p, has_flow, xs, wts,
                                            up[r:r + 3], wp[r:r + 3], ax[r:r + 3], az[r:r + 3])
        X[k + 1] = xn
        A[k] = Ak
        B[k] = Bk
        E[k] = Ek
    return X, A, B, E


def warm_up() -> None:
    """Load (or compile) the horizon's kernel now, with tiny inputs (a law that uses it calls this at boot)."""
    if not kernels.ENABLED:
        return
    one, z1, z3 = np.ones(1), np.zeros(1), np.zeros((3, 1))
    pv = np.ones(31)
    for has in (True, False):
        horizon_lin_arr(pv, np.zeros(6), np.zeros(3), np.zeros((1, 3)), np.full(1, 0.05), np.full(1, 0.5),
                        np.zeros(3), has, z1, one, z3, z3, z3, z3)
