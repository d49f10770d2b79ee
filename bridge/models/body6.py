"""The plant's six-DoF body: the flow at its strips, one RK4 step, and its loads after the step.

The equations are :mod:`bridge.models.motion6` and :mod:`bridge.models.strip_load6` (Fossen's
M ν̇ + C(ν)ν + D(ν)ν + g(η) = τ + τ_wave in η = [x, y, z, φ, θ, ψ] NED, ν = [u, v, w, p, q, r] body
FRD, the complete linear wave load on an n_x × n_y strip grid over the length and the beam). This
module evaluates them through the compiled kernels of :mod:`bridge.models.kernels6`, or, with
``WAVEKEEP_NUMBA=0``, through the numpy reference itself; tests hold the two to each other.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import kernels, kernels6
from .motion6 import rk4_step6, state_derivative6
from .rigid_body6 import RigidBody6Params
from .strip_load6 import BodyFlow6, body_flow6, hydrodynamic_load6, strip_grid
from .vehicle import strip_nodes
from .waves import WaveComponents

__all__ = ["Body6", "Flow6"]


@dataclass(frozen=True)
class Flow6:
    """The fluid's velocity ``vel`` and local acceleration ``acc`` (T, S, 3; body frame, m/s and m/s²) at the
    strip points at T instants."""

    vel: np.ndarray
    acc: np.ndarray


@dataclass
class Body6:
    """The six-DoF vehicle ``params`` cut into ``n_x`` × ``n_y`` strips (Gauss–Legendre over length × beam);
    ``compiled`` None follows :data:`bridge.models.kernels.ENABLED` when the body is built."""

    params: RigidBody6Params
    n_x: int = 3
    n_y: int = 3
    compiled: bool | None = None

    def __post_init__(self) -> None:
        if self.n_x < 1 or self.n_y < 1:
            raise ValueError(f"need at least one strip each way, got {self.n_x} × {self.n_y}")
        if self.compiled is None:
            self.compiled = bool(kernels.ENABLED)
        p = self.params
        self.strips = strip_grid(p.length, p.beam, self.n_x, self.n_y)
        xs, _ = strip_nodes(p.length, self.n_x)
        ys, _ = strip_nodes(p.beam, self.n_y)
        self._grid = (xs, ys, kernels6.node_mirrors(xs), kernels6.node_mirrors(ys))
        self._pv = kernels6.kernel_params6(p)
        if self.compiled:
            kernels6.warm_up6()

    def flow(self, waves: WaveComponents, eta: np.ndarray, t: np.ndarray, current: np.ndarray) -> Flow6:
        """The flow at the strips of the body at pose η (6,) at the times t (T,; s of sea time), with a steady
        NED ``current`` (3,; m/s)."""
        if self.compiled:
            vel, acc = kernels6.step_flow6(waves, eta, t, self._grid, current)
            return Flow6(vel, acc)
        f = body_flow6(waves, eta, t, self.strips, current)
        return Flow6(f.nu_f, f.a_f)

    def _ref_flow(self, flow: Flow6 | None) -> BodyFlow6 | None:
        return None if flow is None else BodyFlow6(self.strips[0], self.strips[1], flow.vel, flow.acc)

    def rk4(self, x: np.ndarray, h: float, tau_stages: np.ndarray, flow: Flow6 | None) -> np.ndarray:
        """One RK4 step of x = [η; ν] (12,) over h s with τ (3, 6) at t, t + h/2, t + h and the flow at those
        instants (None: still water)."""
        if self.compiled:
            vf, af = (self._still, self._still) if flow is None else (flow.vel, flow.acc)
            return kernels6.rk4_6_arr(self._pv, x, h, tau_stages, flow is not None, self.strips[0],
                                      self.strips[1], vf, af)
        return rk4_step6(self.params, x, h, tau_stages, self._ref_flow(flow))

    @property
    def _still(self) -> np.ndarray:
        return np.zeros((3, self.strips[1].size, 3))

    def load(self, nu: np.ndarray, flow: Flow6 | None, i: int = 0) -> np.ndarray:
        """τ_h (6,): the hydrodynamic load on the body moving with ν (6,) in the flow at its instant i."""
        if self.compiled:
            if flow is None:
                z = np.zeros((self.strips[1].size, 3))
                return kernels6.hydro_load6_arr(self._pv, nu, False, self.strips[0], self.strips[1], z, z)
            return kernels6.hydro_load6_arr(self._pv, nu, True, self.strips[0], self.strips[1], flow.vel[i],
                                            flow.acc[i])
        return hydrodynamic_load6(self.params, nu, self._ref_flow(flow), i)

    def rates(self, x: np.ndarray, tau: np.ndarray, flow: Flow6 | None, i: int = 0) -> np.ndarray:
        """ẋ (12,) of x = [η; ν] under τ (6,) in the flow at its instant i."""
        if self.compiled:
            S = self.strips[1].size
            vf, af = (np.zeros((S, 3)), np.zeros((S, 3))) if flow is None else (flow.vel[i], flow.acc[i])
            return kernels6.rates6_arr(self._pv, x, tau, flow is not None, self.strips[0], self.strips[1], vf, af)
        return state_derivative6(self.params, x, tau, self._ref_flow(flow), i)
