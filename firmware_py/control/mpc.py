"""The preview MPC: the forecast's wave loads along a horizon, the thrusters' limits and lag, one QP a tick.

Each tick (docs/mpc.md has the equations and the measurements behind the choices):

1. **The horizon.** N steps: the control period h first (the command being sent), then ``WK_MPC_DT``
   each. The forecast's flow at the body's strips is taken at every step's RK4 stage times, at the pose
   the command meets (:func:`~bridge.models.horizon.horizon_flow`: the forecast's time phases at the
   horizon's instants built once per forecast), weighted per axis by the feed-forward's
   monitor and skill (:func:`~firmware_py.control.feedforward.skill_weighted_flow`) and zero past the
   forecast's validity; with no forecast, or one set aside, the horizon sees still water.
2. **The nominal plan** is the last plan shifted by a tick (interpolated onto the new step times), or
   the fallback's command held when there is none. It is rolled out through the firmware's own model
   (paper Eq. 2 with the relative-velocity wave loads, the motors' first-order lag, the estimator's
   disturbance wrench when ``WK_MPC_DIST`` is 1) and linearised about that rollout
   (:func:`~bridge.models.horizon.linearise_horizon`): a linear time-varying model.
3. **The QP** (:mod:`.mpc_qp`): the state error, the effort off trim and its change, subject to the
   thrusters' limits on every step's command (the allocation's wrench polytope at ``WK_THR_MAX``,
   :mod:`firmware_py.control.wrench_limits`), solved by DAQP warm-started on the last active set. Pitch keeps its
   priority through its weight: the optimiser gives up heave before pitch when they compete for the
   vertical thrusters, and the first demand lies inside the limits, so the mixer never has to choose.
4. **The firmware's discipline.** The robust feed-forward's command (:class:`~.cpd.CascadedPD`) is
   computed every tick. When the solve runs out of budget (``WK_MPC_ITER`` iterations; on a wall clock
   also ``WK_MPC_BUDGET`` ms), finds no feasible command, or meets a non-finite number, that command
   flies instead: never a non-finite one. The episode is counted and announced once by STATUSTEXT.
"""
from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import NamedTuple

import numpy as np

from bridge.models.horizon import (
    OffsetPhases,
    horizon_flow,
    horizon_grid,
    lag_profile,
    linearise_horizon,
    stage_times,
    warm_up,
)
from bridge.models.thrusters import ThrusterLayout
from bridge.models.vehicle import BodyFlow, VehicleParams, restoring_terms

from ..modes import MAV_SEVERITY
from ..params.table import ParameterTable
from .base import ControlInput
from .cascaded_pd import ControlOutput, SolveInfo, SolveStatus
from .cpd import CascadedPD
from .feedforward import skill_weighted_flow
from .mpc_qp import CondensedQP, HorizonCost, prediction_matrix
from .wrench_limits import WrenchPolytope

__all__ = ["MPCSettings", "PreviewMPC", "mpc_settings"]

_REASON = {SolveStatus.TIMEOUT: "out of budget", SolveStatus.INFEASIBLE: "no feasible command",
           SolveStatus.NONFINITE: "non-finite model", SolveStatus.FAILED: "solver failed"}


class MPCSettings(NamedTuple):
    """The MPC's parameters and what derives from them, for one ``ParameterTable.version``."""

    dt: np.ndarray            # (N,) step lengths (s)
    a_mid: np.ndarray         # (N,) the motors' share of a step's thrust change reached at its middle
    e: np.ndarray             # (N,) e^{−Δ_k/t_m}
    offsets: np.ndarray       # the instants the flow is evaluated at (s after the command starts)
    stage_a: np.ndarray       # (3N,) step k's stages (rows 3k..3k+2) are the mean of offsets[a] and [b]
    stage_b: np.ndarray
    knots: np.ndarray         # (N,) step ends (s after the command starts)
    cost: HorizonCost
    scale: np.ndarray         # (3,) τ_max per axis: the inputs' normalisation (N, N, N m)
    max_iter: int
    budget_ms: float
    disturbance: bool
    vel_blend: float          # the estimate's share of the initial u, w: 1 − e^{−h/WK_MPC_VEL_TC} (1: no blend)
    block: int                # steps a demand is held over after the first
    e_max: float              # m: the largest position error the plan is asked to correct
    sqp: int                  # QPs a tick, each about the last one's plan (1: the real-time iteration)


def _blend(h: float, tc: float) -> float:
    """A first-order low-pass's gain per step h (s) for time constant tc (s); 1 (no filtering) when tc is 0."""
    return float(1.0 - np.exp(-h / tc)) if tc > 0.0 else 1.0


def mpc_settings(p: ParameterTable, h: float) -> MPCSettings:
    """:class:`MPCSettings` from the table (``h`` the control period, s)."""
    n = int(p["WK_MPC_N"])
    dt = horizon_grid(h, p["WK_MPC_DT"], n)
    a_mid, e = lag_profile(dt, p["WK_MOT_TC"])
    q = np.array([*p.axes("WK_MPC_Q"), *p.axes("WK_MPC_QV")])
    cost = HorizonCost(q, p["WK_MPC_QT"], np.array(p.axes("WK_MPC_R")), np.array(p.axes("WK_MPC_RD")),
                       p["WK_MPC_QP_K"], p["WK_MPC_QP_T"])
    scale = np.array(p.axes("WK_TAU_MAX"))
    offsets, a, b = stage_times(dt, exact_steps=1)      # the command's own step exactly, the rest interpolated
    return MPCSettings(dt, a_mid, e, offsets, a, b, np.cumsum(dt), cost, scale, int(p["WK_MPC_ITER"]),
                       float(p["WK_MPC_BUDGET"]), bool(p["WK_MPC_DIST"]), _blend(h, float(p["WK_MPC_VEL_TC"])),
                       int(p["WK_MPC_BLK"]), float(p["WK_MPC_EMAX"]), int(p["WK_MPC_SQP"]))


@dataclass
class MPCStats:
    """Counts over the flight: ticks solved, fallbacks per status, fallback episodes."""

    solved: int = 0
    fallbacks: dict[str, int] = field(default_factory=lambda: {s.name.lower(): 0 for s in _REASON})
    episodes: int = 0


class PreviewMPC:
    """The preview MPC strategy (module docstring). ``say`` queues a STATUSTEXT; ``wall_clock`` True when the
    firmware runs on the wall clock, where the millisecond budget applies (in lockstep SITL the budget is
    counted in iterations alone, so a run is the same at any speed and on any machine)."""

    name = "mpc"

    def __init__(self, params: ParameterTable, vehicle: VehicleParams, layout: ThrusterLayout,
                 strips: tuple[np.ndarray, np.ndarray], h: float, say: Callable[[int, str], None],
                 wall_clock: bool = False):
        self.params = params
        self.vehicle = vehicle
        self.strips = strips
        self.h = float(h)
        self.say = say
        self.wall_clock = wall_clock
        self.fallback = CascadedPD(params, vehicle, strips, h)
        self.B = layout.allocation_matrix()
        self.stats = MPCStats()
        self._qp: CondensedQP | None = None
        self._qp_settings: MPCSettings | None = None
        self._qp_key: tuple | None = None                # the values the QP was built from
        self._poly: WrenchPolytope | None = None
        self._plan: tuple[float, np.ndarray] | None = None     # (time the plan's command started, V (N, 3))
        self._falling_back = False
        self._predicted_uw: tuple[float, float] | None = None   # [u, w] (m/s) the last plan predicted for now
        self._phases: OffsetPhases | None = None    # the forecast's time phases at the horizon's instants
        warm_up()        # the horizon's kernel loaded now, not on a real-time loop's first ticks

    def reset(self) -> None:
        self.fallback.reset()
        self._plan = None
        self._predicted_uw = None
        if self._qp is not None:
            self._qp.forget()

    def settings(self) -> MPCSettings:
        return self.params.derived(self._settings)

    def _settings(self, p: ParameterTable) -> MPCSettings:
        return mpc_settings(p, self.h)

    def update(self, c: ControlInput) -> ControlOutput:
        fb = self.fallback.update(c)
        wall0 = time.perf_counter()
        st = self.settings()
        status, V, iters = self._solve(c, st, fb.tau)
        ms = (time.perf_counter() - wall0) * 1e3
        if status == SolveStatus.SOLVED and self.wall_clock and ms > st.budget_ms:
            status = SolveStatus.TIMEOUT          # a command this late is no command for this tick
        info = SolveInfo(status, iters, ms)
        self._account(status)
        if status != SolveStatus.SOLVED or V is None:
            self._plan = None
            return replace(fb, solve=info)
        self._plan = (c.t_ahead, V)
        v0 = V[0]
        return ControlOutput(tau=v0.copy(), tau_ff=np.zeros(3), saturated=self._on_limits(v0, c.thrust, st),
                             solve=info)

    # ------------------------------------------------------------------ the solve
    def _solve(self, c: ControlInput, st: MPCSettings, held: np.ndarray) -> tuple[SolveStatus, np.ndarray | None, int]:
        x0, tau0 = self._initial_state(c.x_ahead, st), np.asarray(c.thrust, dtype=float)
        d = np.asarray(c.d_hat, dtype=float) if st.disturbance else np.zeros(3)
        if not (np.isfinite(x0).all() and np.isfinite(tau0).all() and np.isfinite(d).all()
                and np.isfinite(held).all()):
            return SolveStatus.NONFINITE, None, 0
        qp = self._qp_for(st)
        V = self._nominal(c.t_ahead, st, held)
        flow = self._flow(c, st)
        sp = np.asarray(c.setpoint, dtype=float)
        # The position error the plan answers is bounded (WK_MPC_EMAX), as C-PD bounds its velocity demand: an
        # estimate that jumps by a metre (a lapse of the estimator) is chased at a bounded pace, not flat out
        e = st.e_max
        ref = np.array([x0[0] + min(max(sp[0] - x0[0], -e), e), x0[1] + min(max(sp[1] - x0[1], -e), e), sp[2],
                        0.0, 0.0, 0.0])
        g = restoring_terms(self.vehicle, float(sp[1]), float(sp[2]))
        u_trim = (np.array(g) - d) / st.scale      # the wrench that holds the target in still water
        iterations, status = 0, SolveStatus.FAILED
        for _ in range(st.sqp):     # sequential QPs about the newest plan: 1 is the real-time iteration
            X, A, B, E = linearise_horizon(self.vehicle, x0, tau0, V, st.dt, st.a_mid, d, flow)
            if not (np.isfinite(X).all() and np.isfinite(A).all() and np.isfinite(B).all()
                    and np.isfinite(E).all()):
                self._predicted_uw = None
                return SolveStatus.NONFINITE, None, iterations
            S = prediction_matrix(A, B, E)
            res = qp.solve(X, S, V, tau0, ref, u_trim)
            iterations += res.iterations
            status = res.status
            if res.V is None:
                self._predicted_uw = None
                return status, None, iterations
            x1 = X[1] + S[:6] @ (res.V - V).ravel()   # the plan's state one tick ahead: the next prediction
            V = res.V
        self._predicted_uw = (float(x1[3]), float(x1[4]))
        return status, V, iterations

    def _initial_state(self, x_ahead: np.ndarray, st: MPCSettings) -> np.ndarray:
        """The horizon's first state: the estimate, with its surge and heave velocity blended into the last
        plan's prediction of them (time constant ``WK_MPC_VEL_TC``).

        The paper's estimator differentiates 2 cm position fixes at 10 Hz: its u and w carry ≈ 0.3 m/s of
        noise (up to 0.7 m/s), and the relative-velocity loads turn that into hundreds of newtons of
        predicted heave load that is not there. A plain low-pass would lag the vehicle's commanded motion
        and the loop would oscillate in surge; the last plan's rollout already carries that motion (the
        command sent, the forecast's loads), so only the estimate's disagreement with it is low-passed.
        The pitch rate comes from the gyro and is kept as it is.
        """
        x = np.array(x_ahead, dtype=float)
        pred = self._predicted_uw
        if pred is not None and st.vel_blend < 1.0 and np.isfinite(x[3:5]).all():
            a = st.vel_blend
            x[3], x[4] = pred[0] + a * (x[3] - pred[0]), pred[1] + a * (x[4] - pred[1])
        return x

    def _qp_for(self, st: MPCSettings) -> CondensedQP:
        """The QP of these settings, built again (and its warm start dropped) only when a value it is built
        from has changed: any parameter change makes new settings, most leave the QP as it is."""
        if self._qp is not None and self._qp_settings is st:
            return self._qp
        f_max = float(self.params["WK_THR_MAX"])
        key = (st.dt.tobytes(), st.e.tobytes(), st.scale.tobytes(), st.max_iter, st.block, f_max,
               st.cost.q.tobytes(), st.cost.q_terminal, st.cost.r.tobytes(), st.cost.rd.tobytes(),
               st.cost.near_pitch, st.cost.near_s)
        if self._qp is None or key != self._qp_key:
            self._poly = WrenchPolytope.from_allocation(self.B, -f_max, f_max)
            self._qp = CondensedQP(st.dt, st.e, st.scale, self._poly, st.max_iter, st.block, st.cost)
            self._qp_key = key
        self._qp_settings = st
        return self._qp

    def _nominal(self, t: float, st: MPCSettings, held: np.ndarray) -> np.ndarray:
        """The plan to linearise about: the last one at the new step ends (held at its last value beyond
        it), or ``held`` (the fallback's command) at every step when there is none."""
        if self._plan is None:
            return np.tile(held, (st.dt.size, 1))
        t_prev, V_prev = self._plan
        knots_prev = t_prev + st.knots
        if V_prev.shape != (st.dt.size, 3):
            return np.tile(held, (st.dt.size, 1))
        knots = t + st.knots
        return np.stack([np.interp(knots, knots_prev, V_prev[:, a]) for a in range(3)], axis=1)

    def _flow(self, c: ControlInput, st: MPCSettings) -> BodyFlow | None:
        """The forecast's flow at the strips over the horizon (3N instants), or None (still water)."""
        if c.forecast is None or not c.trusted or not c.ff.active:
            return None
        weight = np.asarray(c.ff.weight, dtype=float)
        if not (weight > 0.0).any():
            return None
        times = c.t_ahead + st.offsets
        waves = c.forecast.components
        if self._phases is None or not self._phases.fits(waves, st.offsets):   # once per forecast and horizon
            self._phases = OffsetPhases(waves, st.offsets)
        f = horizon_flow(self._phases, np.asarray(c.x_ahead[:3], dtype=float), c.t_ahead, self.strips)
        a, b = st.stage_a, st.stage_b
        keep = 0.5 * (times <= c.forecast.forecast.valid_until)[:, None]   # past its window: still water
        u, w, ax, az = (vk[a] + vk[b] for vk in (v * keep for v in (f.u, f.w, f.ax, f.az)))
        return skill_weighted_flow(BodyFlow(f.xs, f.wts, u, w, ax, az), weight)

    # ------------------------------------------------------------------ bookkeeping
    def _on_limits(self, v0: np.ndarray, tau0: np.ndarray, st: MPCSettings) -> bool:
        """Does this tick's command reach the thrusters' limits (within 0.5 %)?"""
        e0 = float(st.e[0])
        cmd = (v0 - e0 * np.asarray(tau0, dtype=float)) / (1.0 - e0)
        poly = self._poly
        if poly is None:
            return False
        return bool((np.abs(poly.normals @ (cmd - poly.centre)) >= 0.995 * poly.half).any())

    def _account(self, status: SolveStatus) -> None:
        """Count the tick; a STATUSTEXT when a fallback episode starts and when it ends."""
        if status == SolveStatus.SOLVED:
            self.stats.solved += 1
            if self._falling_back:
                self._falling_back = False
                self.say(MAV_SEVERITY.INFO, "MPC: solving again")
            return
        key = status.name.lower()
        self.stats.fallbacks[key] = self.stats.fallbacks.get(key, 0) + 1
        if not self._falling_back:
            self._falling_back = True
            self.stats.episodes += 1
            self.say(MAV_SEVERITY.WARNING, f"MPC: flying FF, {_REASON.get(status, 'solver failed')}")

    @property
    def fallbacks(self) -> int:
        """Ticks that flew the FF command (every reason)."""
        return sum(self.stats.fallbacks.values())
