"""The preview MPC's quadratic programme: condensed on the linearised horizon, solved by DAQP.

Around a nominal plan V̄ (N, 3) (the last plan, shifted by a tick) and its rollout X̄ (N+1, 6), the
horizon's linearisation (:func:`~bridge.models.horizon.linearise_horizon`) gives
δx_{k+1} = A_k δx_k + B_k δv_k + E_k δv_{k−1}, with δx_0 = 0 (the estimate is the estimate) and
δv_{−1} = 0 (the thrust now is the thrust now). Stacking it, δX = S δV with S (6N × 3N) lower block
triangular. In normalised inputs u = v / τ_max (per axis) and z = δU, the cost

    Σ_k Δ_{k−1} ‖x_k − r‖²_Q + q_T ‖x_N − r‖²_Q + Σ_k Δ_k ‖u_k − u_trim‖²_R + Σ_k ‖u_k − u_{k−1}‖²_{R_Δ} / Δ_k

(each term ½ ×) is ½ zᵀ P z + qᵀ z + const with P = S̃ᵀ W S̃ + R̄ + Dᵀ R̄_Δ D, S̃ = S diag(τ_max), W the
state weights, D the first difference. The constraints are the thrusters' limits on each step's
command, c_k = (v_k − e_k v_{k−1}) / (1 − e_k) in the :class:`~firmware_py.control.wrench_limits.WrenchPolytope`
(the wrench the mixer sends to make the motors reach v_k; v_k, a convex combination of commands and the
thrust now, then lies within them too). Their matrix is the same every tick; only P, q and the bounds
change. One QP a tick: a real-time iteration of sequential quadratic programming (Diehl et al., 2005).

The solver is DAQP (Arnström, Bemporad & Axehill, "A dual active-set solver for embedded quadratic
programming using recursive LDLᵀ updates", IEEE TAC 2022), a dense dual active-set method written for
MPC: it solves the QP exactly, in a handful of iterations when warm-started with the last active set,
and deterministically (no timing enters it; the budget is its iteration limit). docs/mpc.md gives the
measurements against OSQP (ADMM), qpOASES and DAQP through CasADi.
"""
from __future__ import annotations

from dataclasses import dataclass

import daqp
import numpy as np

from bridge.models import kernels

from .cascaded_pd import SolveStatus
from .wrench_limits import WrenchPolytope

__all__ = ["CondensedQP", "HorizonCost", "QPResult", "block_expansion", "prediction_matrix"]

_STATUS = {1: SolveStatus.SOLVED, 2: SolveStatus.SOLVED,      # DAQP's exit flags: optimal, soft optimal
           -1: SolveStatus.INFEASIBLE, -4: SolveStatus.TIMEOUT}  # infeasible, iteration limit
_ACTIVE_UPPER, _ACTIVE_LOWER = 1, 3   # DAQP's constraint sense: active (1), at its lower bound (+2)


@dataclass(frozen=True)
class HorizonCost:
    """The cost's weights: ``q`` (6,) per second on [x, z, θ, u, w, q] errors, ``q_terminal`` (s) the last state's
    extra weight, ``r`` (3,) per second on the normalised effort off trim, ``rd`` (3,) s on its change."""

    q: np.ndarray
    q_terminal: float
    r: np.ndarray
    rd: np.ndarray
    near_pitch: float = 1.0    # × the pitch weight over the first ``near_s`` s (attitude first, as the mixer)
    near_s: float = 0.0


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


def block_expansion(n: int, block: int) -> np.ndarray:
    """T (3n, 3B): per-step inputs from per-block ones, the first step alone and then ``block`` steps a block
    (move blocking: the optimiser chooses B ≪ n demands, each held over its steps)."""
    owner = np.concatenate([[0], 1 + (np.arange(n - 1) // max(1, block))]) if n > 0 else np.zeros(0, int)
    T = np.zeros((3 * n, 3 * (int(owner.max()) + 1 if n else 0)))
    for k, b in enumerate(owner):
        T[3 * k:3 * k + 3, 3 * b:3 * b + 3] = np.eye(3)
    return T


class CondensedQP:
    """The QP of one horizon and cost: N steps of ``dt`` s with lag factors ``e``, inputs normalised by ``scale``
    and held over blocks of ``block`` steps after the first, within the wrench limits ``poly``, weighed by ``cost``.

    What does not change from tick to tick is built here once: the block expansion, the effort and rate
    terms of P, the state weights and the constraint matrix.
    """

    def __init__(self, dt: np.ndarray, e: np.ndarray, scale: np.ndarray, poly: WrenchPolytope, max_iter: int,
                 block: int, cost: HorizonCost):
        self.dt, self.e = np.asarray(dt, dtype=float), np.asarray(e, dtype=float)
        self.n = n = self.dt.size
        self.scale = np.asarray(scale, dtype=float)
        self.poly = poly
        self._T = T = block_expansion(n, block)
        nb = T.shape[1] // 3
        # each block's first step k_b: the steps a block's demand starts at (reduceat's indices)
        self._firsts = np.flatnonzero(np.concatenate([[True], np.diff(T[::3].argmax(axis=1)) != 0]))
        DT = (np.eye(3 * n) - np.eye(3 * n, k=-3)) @ T          # the change of per-step inputs, per block
        self._DT = DT
        w = np.outer(self.dt, cost.q)                            # Δ_{k−1} Q on x_k, k = 1..N
        near = np.cumsum(self.dt) <= cost.near_s + 1e-9           # the attitude's priority, near term
        w[near, 2] *= cost.near_pitch
        w[-1] += cost.q_terminal * cost.q
        self._w = w.ravel()
        self._r = np.outer(self.dt, cost.r).ravel()
        self._rd = np.outer(1.0 / self.dt, cost.rd).ravel()
        self._P_inputs = T.T @ (T * self._r[:, None]) + DT.T @ (DT * self._rd[:, None])
        # The commands' constraint rows, at each block's first step (within a block the demand is held, so the
        # command is the demand there): N_f diag(s) (z_b − e_k z_{b−1}) / (1 − e_k)
        nf = poly.normals.shape[0]
        Ns = poly.normals * self.scale        # (F, 3)
        Ac = np.zeros((nf * nb, 3 * nb))
        for b, k in enumerate(self._firsts):
            g = 1.0 / (1.0 - self.e[k])
            Ac[b * nf:(b + 1) * nf, 3 * b:3 * b + 3] = g * Ns
            if b:
                Ac[b * nf:(b + 1) * nf, 3 * (b - 1):3 * b] = -g * self.e[k] * Ns
        self._Ac = np.ascontiguousarray(Ac)
        self._max_iter = int(max_iter)
        self._sense: np.ndarray | None = None      # the last active set (DAQP's warm start)

    def forget(self) -> None:
        """Drop the warm start (a reset)."""
        self._sense = None

    def solve(self, X: np.ndarray, S: np.ndarray, V: np.ndarray, tau0: np.ndarray, ref: np.ndarray,
              u_trim: np.ndarray) -> QPResult:
        """The demands that minimise the cost about the nominal ``V`` (rollout ``X``, prediction matrix ``S``)."""
        n, s, T = self.n, self.scale, self._T
        # per block, in normalised input: the columns of the steps of a block summed
        St = np.add.reduceat(S.reshape(6 * n, n, 3) * s, self._firsts, axis=1).reshape(6 * n, -1)
        w = self._w
        P = St.T @ (St * w[:, None]) + self._P_inputs
        U = (V / s).ravel()
        dU = U - np.roll(U, 3)
        dU[:3] = U[:3] - tau0 / s
        err = (X[1:] - ref).ravel()
        q = St.T @ (w * err) + T.T @ (self._r * (U - np.tile(u_trim, n))) + self._DT.T @ (self._rd * dU)
        C = self._nominal_commands(V, tau0)[self._firsts]
        lim = self.poly.half[None, :]
        offset = (C - self.poly.centre) @ self.poly.normals.T       # (B, F)
        lo, hi = (-lim - offset).ravel(), (lim - offset).ravel()
        if not (np.isfinite(P).all() and np.isfinite(q).all() and np.isfinite(lo).all()):
            return QPResult(SolveStatus.NONFINITE, None, 0)
        kw = {} if self._sense is None else {"sense": self._sense}
        z, _, flag, info = daqp.solve(P, q, self._Ac, hi, lo, iter_limit=self._max_iter, **kw)
        iterations = int(info["iterations"])
        status = _STATUS.get(int(flag), SolveStatus.FAILED)
        z = np.asarray(z, dtype=float)
        if status == SolveStatus.SOLVED and not np.isfinite(z).all():
            status = SolveStatus.NONFINITE
        if status != SolveStatus.SOLVED:
            self._sense = None
            return QPResult(status, None, iterations)
        lam = np.asarray(info["lam"], dtype=float)
        self._sense = np.where(lam > 0.0, _ACTIVE_UPPER, np.where(lam < 0.0, _ACTIVE_LOWER, 0)).astype(np.int32)
        return QPResult(SolveStatus.SOLVED, V + (T @ z).reshape(n, 3) * s, iterations)

    def _nominal_commands(self, V: np.ndarray, tau0: np.ndarray) -> np.ndarray:
        """c_k = (v_k − e_k v_{k−1}) / (1 − e_k) of the nominal plan (N, 3), v_{−1} = the thrust now."""
        prev = np.vstack([tau0[None, :], V[:-1]])
        e = self.e[:, None]
        return (V - e * prev) / (1.0 - e)
