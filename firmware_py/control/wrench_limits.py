"""The body wrenches the thrusters can give: the allocation's limits as linear inequalities.

With thrusts f_i in [lo_i, hi_i] and the 3×n allocation matrix B ([X, Z, M] rows), the reachable
wrenches {B f} form a zonotope: the centre c = B (lo + hi)/2 plus Σ s_i g_i with s_i ∈ [−1, 1] and the
generators g_i = B[:, i] (hi_i − lo_i)/2. In three dimensions each facet of a zonotope is parallel to a
pair of generators, so its facet normals are the cross products of the pairs and

    |nᵀ (τ − c)| ≤ Σ_i |nᵀ g_i|   for each normal n

is its exact H-representation (McMullen, "On zonotopes", 1971). The mixer allocates with the
pseudo-inverse (pitch first, :mod:`firmware_py.motors.mixer`), which for a general layout need not reach
every wrench of the zonotope; :meth:`WrenchPolytope.from_allocation` checks the zonotope's vertices
through B⁺ and shrinks the bounds until every wrench inside maps to thrusts within their limits. For
the BlueROV2 Heavy it needs no shrinking: the horizontal thrusters give surge alone and the vertical
pairs heave and pitch, so the limits are |X| ≤ 4 f cos 45° and |Z ± M / l_x| ≤ 4 f.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

__all__ = ["WrenchPolytope"]


@dataclass(frozen=True)
class WrenchPolytope:
    """``normals`` (F, 3) unit facet normals, ``centre`` (3,) and ``half`` (F,): |n_fᵀ (τ − c)| ≤ half_f."""

    normals: np.ndarray
    centre: np.ndarray
    half: np.ndarray

    @classmethod
    def from_allocation(cls, B: np.ndarray, lo, hi) -> WrenchPolytope:
        """The wrenches of thrusts in [lo, hi] (N; scalars or per thruster) that the pseudo-inverse reaches."""
        B = np.asarray(B, dtype=float)
        n = B.shape[1]
        lo, hi = np.broadcast_to(np.asarray(lo, dtype=float), n), np.broadcast_to(np.asarray(hi, dtype=float), n)
        mid, rad = 0.5 * (lo + hi), 0.5 * (hi - lo)
        gens = B * rad                       # (3, n) generators
        centre = B @ mid
        normals: list[np.ndarray] = []
        for i, j in itertools.combinations(range(n), 2):
            c = np.cross(gens[:, i], gens[:, j])
            norm = np.linalg.norm(c)
            if norm < 1e-12 * (1.0 + np.linalg.norm(gens[:, i]) * np.linalg.norm(gens[:, j])):
                continue                     # parallel generators span no facet
            c = c / norm
            c = c if c[np.argmax(np.abs(c))] > 0 else -c   # one sign per facet pair
            if not any(np.allclose(c, m, atol=1e-9) for m in normals):
                normals.append(c)
        if not normals:                      # generators on one line or none: the axes bound each component
            normals = [np.eye(3)[k] for k in range(3)]
        N = np.array(normals)
        half = np.abs(N @ gens).sum(axis=1)
        poly = cls(N, centre, half)
        return poly.scaled(poly._reachable_share(B, lo, hi, gens))

    def scaled(self, s: float) -> WrenchPolytope:
        """The polytope shrunk about its centre by the factor s ∈ (0, 1]."""
        return self if s >= 1.0 else WrenchPolytope(self.normals, self.centre, self.half * s)

    def _reachable_share(self, B: np.ndarray, lo: np.ndarray, hi: np.ndarray, gens: np.ndarray) -> float:
        """The largest s ≤ 1 such that every vertex of the shrunk zonotope maps through B⁺ within [lo, hi]."""
        pinv = np.linalg.pinv(B)
        n = gens.shape[1]
        share = 1.0
        signs = itertools.product((-1.0, 1.0), repeat=n) if n <= 12 else iter(())
        for s in signs:
            tau = self.centre + gens @ np.array(s)
            f_c, f_d = pinv @ self.centre, pinv @ (tau - self.centre)
            for i in range(n):
                room = (hi[i] - f_c[i]) if f_d[i] > 0 else (f_c[i] - lo[i])
                if abs(f_d[i]) > 1e-12:
                    share = min(share, max(0.0, room / abs(f_d[i])))
        return share

    def contains(self, tau, tol: float = 1e-9) -> bool:
        """Is the wrench τ (N, N, N m) within the limits?"""
        return bool((np.abs(self.normals @ (np.asarray(tau, dtype=float) - self.centre)) <= self.half + tol).all())
