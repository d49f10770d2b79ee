"""The preview MPC's quadratic programme: condensed on the linearised horizon, solved by OSQP.

Around a nominal plan V̄ (N, 3) (the last plan, shifted by a tick) and its rollout X̄ (N+1, 6), the
horizon's linearisation (:func:`~bridge.models.horizon.linearise_horizon`) gives
δx_{k+1} = A_k δx_k + B_k δv_k + E_k δv_{k−1}, with δx_0 = 0 (the estimate is the estimate) and
δv_{−1} = 0 (the thrust now is the thrust now). Stacking it, δX = S δV with S (6N × 3N) lower block
triangular. In normalised inputs u = v / τ_max (per axis) and z = δU, the cost

    Σ_k Δ_{k−1} ‖x_k − r‖²_Q + q_T ‖x_N − r‖²_Q + Σ_k Δ_k ‖u_k − u_trim‖²_R + Σ_k ‖u_k − u_{k−1}‖²_{R_Δ} / Δ_k

(each term ½ ×) is ½ zᵀ P z + qᵀ z + const with P = S̃ᵀ W S̃ + R̄ + Dᵀ R̄_Δ D, S̃ = S diag(τ_max), W the
state weights, D the first difference. The constraints are the thrusters' limits on each step's
command, c_k = (v_k − e_k v_{k−1}) / (1 − e_k) in the :class:`~firmware_py.wrench_limits.WrenchPolytope`
(the wrench the mixer sends to make the motors reach v_k; v_k, a convex combination of commands and the
thrust now, then lies within them too). Their matrix is the same every tick; only P, q and the bounds
change, so OSQP keeps its sparsity pattern and is warm-started with the last duals. One QP a tick: a
real-time iteration of sequential quadratic programming (Diehl et al., 2005).

OSQP is set up for repeatable results: a fixed ``adaptive_rho_interval`` (its default adapts on the
measured setup time, which would make a run depend on the machine), no time limit (the budget is
counted in iterations, ``max_iter``), no polishing.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import osqp
import scipy.sparse as sp

from bridge.models import kernels

from ..control import SolveStatus
from ..wrench_limits import WrenchPolytope

__all__ = ["CondensedQP", "HorizonCost", "QPResult", "prediction_matrix"]

_STATUS = {osqp.constant("OSQP_SOLVED"): SolveStatus.SOLVED,
           osqp.constant("OSQP_SOLVED_INACCURATE"): SolveStatus.SOLVED,
           osqp.constant("OSQP_MAX_ITER_REACHED"): SolveStatus.TIMEOUT,
           osqp.constant("OSQP_TIME_LIMIT_REACHED"): SolveStatus.TIMEOUT,
           osqp.constant("OSQP_PRIMAL_INFEASIBLE"): SolveStatus.INFEASIBLE,
           osqp.constant("OSQP_PRIMAL_INFEASIBLE_INACCURATE"): SolveStatus.INFEASIBLE}


@dataclass(frozen=True)
class HorizonCost:
    """The cost's weights: ``q`` (6,) per second on [x, z, θ, u, w, q] errors, ``q_terminal`` (s) the last state's
    extra weight, ``r`` (3,) per second on the normalised effort off trim, ``rd`` (3,) s on its change."""

    q: np.ndarray
    q_terminal: float
    r: np.ndarray
    rd: np.ndarray


@dataclass(frozen=True)
class QPResult:
    status: SolveStatus
    V: np.ndarray | None       # (N, 3) the optimal demands (N, N, N m), None unless solved
    iterations: int


def prediction_matrix(A: np.ndarray, B: np.ndarray, E: np.ndarray) -> np.ndarray:
    """S (6N, 3N): δX = S δV for δx_{k+1} = A_k δx_k + B_k δv_k + E_k δv_{k−1}, δx_0 = 0, δv_{−1} = 0.

    The compiled kernel (:func:`~bridge.models.kernels.prediction_matrix_arr`) when enabled, else this reference."""
    if kernels.ENABLED:
        return kernels.prediction_matrix_arr(np.ascontiguousarray(A), np.ascontiguousarray(B), np.ascontiguousarray(E))
    n = A.shape[0]
    S = np.zeros((n, 6, n, 3))
    prev = np.zeros((6, n, 3))
    for k in range(n):
        cur = np.tensordot(A[k], prev, axes=(1, 0))
        cur[:, k, :] += B[k]
        if k:
            cur[:, k - 1, :] += E[k]
        S[k] = cur
        prev = cur
    return S.reshape(6 * n, 3 * n)


class CondensedQP:
    """The QP of one horizon shape (N steps of ``dt`` s, lag factors ``e``, input scale ``scale``, limits ``poly``)."""

    def __init__(self, dt: np.ndarray, e: np.ndarray, scale: np.ndarray, poly: WrenchPolytope, max_iter: int):
        self.dt, self.e = np.asarray(dt, dtype=float), np.asarray(e, dtype=float)
        self.n = n = self.dt.size
        self.scale = np.asarray(scale, dtype=float)
        self.poly = poly
        m = 3 * n
        D = np.eye(m) - np.eye(m, k=-3)
        self._D = D
        # The command's constraint rows: N_f diag(s) (z_k − e_k z_{k−1}) / (1 − e_k), per step and facet
        nf = poly.normals.shape[0]
        Ns = poly.normals * self.scale        # (F, 3)
        Ac = np.zeros((nf * n, m))
        for k in range(n):
            g = 1.0 / (1.0 - self.e[k])
            Ac[k * nf:(k + 1) * nf, 3 * k:3 * k + 3] = g * Ns
            if k:
                Ac[k * nf:(k + 1) * nf, 3 * (k - 1):3 * k] = -g * self.e[k] * Ns
        self._Ac = Ac
        rows, cols = np.triu_indices(m)
        order = np.lexsort((rows, cols))        # CSC order of the upper triangle: by column, then row
        self._tri = rows[order], cols[order]
        pattern = sp.csc_matrix((np.ones(rows.size), (self._tri[0], self._tri[1])), shape=(m, m))
        self._solver = osqp.OSQP()
        self._solver.setup(pattern, np.zeros(m), sp.csc_matrix(Ac), -np.ones(nf * n), np.ones(nf * n),
                           verbose=False, warm_starting=True, polishing=False, adaptive_rho=True,
                           adaptive_rho_interval=25, max_iter=int(max_iter), eps_abs=1e-4, eps_rel=1e-4,
                           check_termination=5)
        self._y: np.ndarray | None = None

    def set_max_iter(self, max_iter: int) -> None:
        self._solver.update_settings(max_iter=int(max_iter))

    def forget(self) -> None:
        """Drop the warm start (a reset)."""
        self._y = None

    def solve(self, X: np.ndarray, S: np.ndarray, V: np.ndarray, tau0: np.ndarray, ref: np.ndarray,
              u_trim: np.ndarray, cost: HorizonCost) -> QPResult:
        """The demands that minimise the cost about the nominal ``V`` (rollout ``X``, prediction matrix ``S``)."""
        n, s = self.n, self.scale
        St = S * np.tile(s, n)                                  # columns in normalised input
        w = np.outer(self.dt, cost.q)                            # Δ_{k−1} Q on x_k, k = 1..N
        w[-1] += cost.q_terminal * cost.q
        w = w.ravel()
        U = (V / s).ravel()
        u_prev = np.zeros(3 * n)
        u_prev[:3] = tau0 / s
        r_diag = (np.outer(self.dt, cost.r)).ravel()
        rd_diag = (np.outer(1.0 / self.dt, cost.rd)).ravel()
        D = self._D
        P = St.T @ (St * w[:, None]) + np.diag(r_diag) + D.T @ (D * rd_diag[:, None])
        err = (X[1:] - ref).ravel()
        q = St.T @ (w * err) + r_diag * (U - np.tile(u_trim, n)) + D.T @ (rd_diag * (D @ U - u_prev))
        C = self._nominal_commands(V, tau0)
        lim = self.poly.half[None, :]
        offset = (C - self.poly.centre) @ self.poly.normals.T       # (N, F)
        lo, hi = (-lim - offset).ravel(), (lim - offset).ravel()
        if not (np.isfinite(P).all() and np.isfinite(q).all() and np.isfinite(lo).all()):
            return QPResult(SolveStatus.NONFINITE, None, 0)
        solver = self._solver
        solver.update(Px=P[self._tri], q=q, l=lo, u=hi)
        solver.warm_start(x=np.zeros(3 * n), y=self._y if self._y is not None else np.zeros(lo.size))
        res = solver.solve(raise_error=False)
        status = _STATUS.get(res.info.status_val, SolveStatus.FAILED)
        if status != SolveStatus.SOLVED:
            self._y = None
            return QPResult(status, None, int(res.info.iter))
        z = np.asarray(res.x, dtype=float)
        if not np.isfinite(z).all():
            self._y = None
            return QPResult(SolveStatus.NONFINITE, None, int(res.info.iter))
        self._y = np.asarray(res.y, dtype=float).copy()
        return QPResult(SolveStatus.SOLVED, V + z.reshape(n, 3) * s, int(res.info.iter))

    def _nominal_commands(self, V: np.ndarray, tau0: np.ndarray) -> np.ndarray:
        """c_k = (v_k − e_k v_{k−1}) / (1 − e_k) of the nominal plan (N, 3), v_{−1} = the thrust now."""
        prev = np.vstack([tau0[None, :], V[:-1]])
        e = self.e[:, None]
        return (V - e * prev) / (1.0 - e)
