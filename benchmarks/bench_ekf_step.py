"""EKF step cost (issue #13): the firmware's filterpy covariance path against a hand-written numba step.

    python -m benchmarks.bench_ekf_step          # writes benchmarks/results/ekf_step.json
    python -m benchmarks.bench_ekf_step --duration 2 --repeat 1 --no-write    # a quick check

The estimator stays filterpy's ``ExtendedKalmanFilter`` (:class:`firmware_py.estimation.estimator.PlanarEKF`);
this measures what a hand-written fixed-size step would reach, on real inputs rather than an estimate:

1. **Recording.** An in-process mission (default: 60 s, W3, C-PD+FF, the paper's estimator
   ``WK_EKF_MODE`` 0: 6 states, 4 channels) flies with its ``PlanarEKF``'s ``predict``,
   ``update`` and ``_fuse`` wrapped on the instance. Per tick: x and P before predict, F, Q, the
   predicted x (the model's RK4 step is shared and not timed here), filterpy's P⁻; then, when
   readings are fused, the state and P entering ``_fuse`` (a channel reset may have moved them), the
   accepted readings z, their innovations y, H's rows, R, and x⁺, P⁺, NIS from the real filter.
   A second, identical mission times the whole ``PlanarEKF.predict`` + ``update`` per tick as
   the firmware calls them (nothing else wrapped; for context).
2. **Timing on the recorded inputs**, each call by ``time.perf_counter_ns``, gc off, after a
   warm-up pass, ``--repeat`` rounds of one pass over all ticks per variant, the variants in turn (so
   that they see the same load); the pass with the lowest median is reported:

   * firmware predict: filterpy's ``ExtendedKalmanFilter.predict`` (``P = dot(F, P).dot(F.T) + Q``
     and its prior copies) with ``predict_x`` replaced by handing over the recorded predicted x;
   * firmware update: ``PlanarEKF._fuse`` (filterpy's update term by term: Joseph form,
     ``scipy.linalg.inv``), called with the arguments the firmware gave it;
   * numba predict / update / both: :func:`cov_predict`, :func:`fuse_step`, :func:`ekf_step` below
     (``@njit(cache=True)``, preallocated outputs): P⁻ = F P Fᵀ + Q; S = H P Hᵀ + R; K = P Hᵀ S⁻¹
     by a **Cholesky factorisation of S and two triangular solves per row of K (no inverse)**;
     x⁺ = x + K y; NIS = |L⁻¹ y|²; Joseph P⁺ = (I − K H) P (I − K H)ᵀ + K R Kᵀ. General H and R
     (the paper mode's H is selection rows and R diagonal; the step does not exploit it);
   * the whole ``PlanarEKF.predict`` + ``update`` replayed on a fresh filter from the recorded
     τ stages, flows and sensor frames (RK4, Jacobian, gating included), for context.
3. **Agreement** of the numba step with the firmware's: per tick ‖Δ‖∞ / ‖firmware‖∞ of x⁺, P⁺,
   P⁻ (and |Δ NIS| / NIS), maxima over ticks; the firmware path replayed must equal the recording bit
   for bit (checked). The numba step lives here only: it is a measurement, not a production path.
"""
from __future__ import annotations

import argparse
import copy
import gc
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg as linalg
from numba import njit

from benchmarks.common import write
from firmware_py.estimation.estimator import PlanarEKF
from firmware_py.estimation.filterpy_ekf import ExtendedKalmanFilter
from firmware_py.hal.sensors import SensorFrame
from sitl.harness.run import MissionSetup, build_mission, take_off
from sitl.harness.spec import RunSpec


# --------------------------------------------------------------------------- the hand-written step
@njit(cache=True)
def _product(A, B, b_transposed):  # pragma: no cover - compiled
    """A B, or A Bᵀ with ``b_transposed``, each sum taken left to right (fixed sizes: no BLAS call)."""
    n, inner = A.shape
    p = B.shape[0] if b_transposed else B.shape[1]
    out = np.empty((n, p))
    for i in range(n):
        for j in range(p):
            s = 0.0
            for k in range(inner):
                s += A[i, k] * (B[j, k] if b_transposed else B[k, j])
            out[i, j] = s
    return out


@njit(cache=True)
def cov_predict(F, P, Q, out):  # pragma: no cover - compiled
    """out = F P Fᵀ + Q (n × n), sums left to right as ``dot(F, P).dot(F.T) + Q``."""
    out[:, :] = _product(_product(F, P, False), F, True) + Q


@njit(cache=True)
def fuse_step(x, P, H, R, y, x_out, P_out):  # pragma: no cover - compiled
    """One measurement update on the accepted readings; writes x⁺ (n,) and P⁺ (n, n), returns yᵀ S⁻¹ y.

    ``x`` (n,) and ``P`` the predicted state and covariance, ``H`` (m, n), ``R`` (m, m), ``y`` (m,) the
    innovations z − h(x). K = P Hᵀ S⁻¹ by Cholesky (S = L Lᵀ) and forward/back substitution, no inverse."""
    n, m = P.shape[0], H.shape[0]
    PHT = _product(P, H, True)
    # S = H P Hᵀ + R, lower triangle only, factorised in place: L
    L = np.zeros((m, m))
    for i in range(m):
        for j in range(i + 1):
            s = 0.0
            for k in range(n):
                s += H[i, k] * PHT[k, j]
            L[i, j] = s + R[i, j]
    for j in range(m):
        d = L[j, j]
        for k in range(j):
            d -= L[j, k] * L[j, k]
        d = np.sqrt(d)
        L[j, j] = d
        for i in range(j + 1, m):
            s = L[i, j]
            for k in range(j):
                s -= L[i, k] * L[j, k]
            L[i, j] = s / d
    # K's rows: S kᵀ = (P Hᵀ)'s row (S symmetric), L v = b then Lᵀ k = v
    K = np.empty((n, m))
    for r in range(n):
        for i in range(m):
            s = PHT[r, i]
            for k in range(i):
                s -= L[i, k] * K[r, k]
            K[r, i] = s / L[i, i]
        for i in range(m - 1, -1, -1):
            s = K[r, i]
            for k in range(i + 1, m):
                s -= L[k, i] * K[r, k]
            K[r, i] = s / L[i, i]
    nis = 0.0
    w = np.empty(m)
    for i in range(m):
        s = y[i]
        for k in range(i):
            s -= L[i, k] * w[k]
        w[i] = s / L[i, i]
        nis += w[i] * w[i]
    for i in range(n):
        s = 0.0
        for j in range(m):
            s += K[i, j] * y[j]
        x_out[i] = x[i] + s
    # Joseph form: A = I − K H; P⁺ = (A P) Aᵀ + (K R) Kᵀ
    A = np.eye(n) - _product(K, H, False)
    P_out[:, :] = _product(_product(A, P, False), A, True) + _product(_product(K, R, False), K, True)
    return nis


@njit(cache=True)
def ekf_step(F, P, Q, x_pred, H, R, y, P_pred, x_out, P_out):  # pragma: no cover - compiled
    """:func:`cov_predict` then :func:`fuse_step` in one call (P⁻ into ``P_pred``); returns the NIS."""
    cov_predict(F, P, Q, P_pred)
    return fuse_step(x_pred, P_pred, H, R, y, x_out, P_out)


@njit(cache=True)
def _empty4(a, b, c, d):  # pragma: no cover - compiled
    """A compiled call with cov_predict's arguments doing nothing: the dispatch cost from Python."""
    return 0.0


@njit(cache=True)
def _empty7(a, b, c, d, e, f, g):  # pragma: no cover - compiled
    """The same with fuse_step's arguments."""
    return 0.0


# --------------------------------------------------------------------------- recording
@dataclass
class Fused:
    """One ``_fuse`` call: its arguments, the state it started from and what it left."""

    x_in: np.ndarray
    P_in: np.ndarray
    z: np.ndarray
    y: np.ndarray
    H: np.ndarray
    R: np.ndarray
    blind: tuple[int, ...]
    x_out: np.ndarray
    P_out: np.ndarray
    nis: float


@dataclass
class Tick:
    """One tick of the filter: predict's inputs and outputs, the frame ``update`` saw, its fusion."""

    tau_stages: np.ndarray
    flow: Any
    x0: np.ndarray
    P0: np.ndarray
    F: np.ndarray
    Q: np.ndarray
    x_pred: np.ndarray
    P_pred: np.ndarray
    frame: SensorFrame | None = None
    fused: Fused | None = None
    x_post: np.ndarray | None = None
    P_post: np.ndarray | None = None


@dataclass
class Recording:
    ekf: PlanarEKF            # the mission's filter (for its vehicle, parameters and period)
    first_frame: SensorFrame  # the frame that initialised it
    ticks: list[Tick]


def _spec(args: argparse.Namespace) -> RunSpec:
    return RunSpec(case=args.case, controller=args.controller, seed=args.seed, duration=args.duration,
                   overrides={"WK_EKF_MODE": args.mode})


def _fly(m: MissionSetup) -> None:
    """The loop of :func:`sitl.harness.run.run_mission`, without its log."""
    n = int(round(m.duration_s * m.rate_hz)) - 1
    take_off(m)
    for _ in range(n):
        if m.feeder is not None:
            m.feeder.advance(m.plant.state.t)
        m.firmware.scheduler.run_tick()
        m.hal.step_world()


def record(spec: RunSpec) -> Recording:
    """Fly ``spec`` with the filter's predict, update and _fuse wrapped on the instance; see the module doc."""
    m = build_mission(spec)
    ekf = m.firmware.ekf
    predict, update, fuse = ekf.predict, ekf.update, ekf._fuse
    ticks: list[Tick] = []
    first: list[SensorFrame] = []

    def rec_predict(tau_stages, flow=None):
        if not ekf.initialised:
            raise RuntimeError("predict before the filter was initialised")
        x0, P0 = ekf.kf.x.copy(), ekf.kf.P.copy()
        predict(tau_stages, flow)
        ticks.append(Tick(np.array(tau_stages, dtype=float), copy.deepcopy(flow), x0, P0, ekf.kf.F.copy(),
                          ekf.kf.Q.copy(), ekf.kf.x.copy(), ekf.kf.P.copy()))

    def rec_update(frame):
        if not ekf.initialised:
            out = update(frame)
            if ekf.initialised:
                first.append(frame)
            return out
        if not ticks or ticks[-1].frame is not None:
            raise RuntimeError("update without its predict")
        ticks[-1].frame = frame
        out = update(frame)
        ticks[-1].x_post, ticks[-1].P_post = ekf.kf.x.copy(), ekf.kf.P.copy()
        return out

    def rec_fuse(z, y, H, R, pitch_blind=()):
        x_in, P_in = ekf.kf.x.copy(), ekf.kf.P.copy()
        fuse(z, y, H, R, pitch_blind)
        ticks[-1].fused = Fused(x_in, P_in, z.copy(), y.copy(), np.array(H), np.array(R), tuple(pitch_blind),
                                ekf.kf.x.copy(), ekf.kf.P.copy(), ekf.nis_total[0])

    ekf.predict, ekf.update, ekf._fuse = rec_predict, rec_update, rec_fuse  # type: ignore[method-assign]
    _fly(m)
    if len(first) != 1:
        raise RuntimeError("the filter was not initialised exactly once")
    return Recording(ekf, first[0], ticks)


def mission_cost(spec: RunSpec) -> np.ndarray:
    """ns of ``PlanarEKF.predict`` + ``update`` per tick (ticks with both) in a mission, only those wrapped."""
    m = build_mission(spec)
    ekf = m.firmware.ekf
    predict, update = ekf.predict, ekf.update
    t_pred: list[int] = []
    out: list[int] = []

    def timed_predict(tau_stages, flow=None):
        t0 = time.perf_counter_ns()
        predict(tau_stages, flow)
        t_pred.append(time.perf_counter_ns() - t0)

    def timed_update(frame):
        t0 = time.perf_counter_ns()
        r = update(frame)
        dt = time.perf_counter_ns() - t0
        if t_pred:
            out.append(t_pred.pop() + dt)
        return r

    ekf.predict, ekf.update = timed_predict, timed_update  # type: ignore[method-assign]
    _fly(m)
    return np.array(out, dtype=float)


# --------------------------------------------------------------------------- timing
class _HandOver(ExtendedKalmanFilter):
    """filterpy's EKF whose ``predict_x`` hands over the recorded predicted x (the RK4 step is not timed)."""

    x_next: np.ndarray

    def predict_x(self, u=0):
        self.x = self.x_next


def _passes(runs: dict[str, Callable[[], list[int]]], repeat: int) -> dict[str, tuple[np.ndarray, list[float]]]:
    """A warm-up pass of each, then ``repeat`` rounds of one timed pass of each in turn (so that all see
    the same machine load), gc off. Per name: the pass (ns per call) with the lowest median, and every
    pass's median (µs)."""
    for fn in runs.values():
        fn()
    passes: dict[str, list[np.ndarray]] = {name: [] for name in runs}
    gc.disable()
    try:
        for _ in range(repeat):
            for name, fn in runs.items():
                passes[name].append(np.array(fn(), dtype=float))
    finally:
        gc.enable()
    out = {}
    for name, ps in passes.items():
        meds = [float(np.median(p)) / 1e3 for p in ps]
        out[name] = (ps[int(np.argmin(meds))], meds)
    return out


def _stats(ns: np.ndarray, meds: list[float] | None = None) -> dict:
    us = ns / 1e3
    out: dict[str, Any] = {"p50_us": float(np.median(us)), "p99_us": float(np.percentile(us, 99)),
                           "max_us": float(us.max()), "mean_us": float(us.mean()), "n": int(us.size)}
    if meds is not None:
        out["pass_p50_us"] = [round(v, 3) for v in meds]
    return out


def _prepared(rec: Recording) -> list[dict]:
    """Per tick, the numba step's inputs as contiguous arrays (1-D x and y) and its output buffers."""
    out = []
    for t in rec.ticks:
        d: dict[str, Any] = {"F": np.ascontiguousarray(t.F), "P": np.ascontiguousarray(t.P0),
                             "Q": np.ascontiguousarray(t.Q), "P_pred": np.empty_like(t.P0)}
        f = t.fused
        if f is not None:
            d.update(x=np.ascontiguousarray(f.x_in[:, 0]), P_in=np.ascontiguousarray(f.P_in),
                     H=np.ascontiguousarray(f.H, dtype=float), R=np.ascontiguousarray(f.R, dtype=float),
                     y=np.ascontiguousarray(f.y[:, 0]), x_pred=np.ascontiguousarray(t.x_pred[:, 0]),
                     x_out=np.empty(f.x_in.shape[0]), P_out=np.empty_like(f.P_in),
                     x_out2=np.empty(f.x_in.shape[0]), P_out2=np.empty_like(f.P_in), P_pred2=np.empty_like(t.P0))
        out.append(d)
    return out


def measure(rec: Recording, repeat: int) -> dict:
    """Every timing and the agreement on a recording (see the module doc)."""
    ticks = rec.ticks
    fused = [t for t in ticks if t.fused is not None]
    if any(t.fused.blind for t in fused if t.fused is not None):
        raise RuntimeError("a Schmidt (pitch-blind) update: the numba step does not do it (aided mode)")
    n = rec.ekf.n
    prep = _prepared(rec)
    prep_f = [p for p in prep if "y" in p]

    # (a) the firmware's path: filterpy's predict (P only), PlanarEKF._fuse
    kf = _HandOver(dim_x=n, dim_z=len(rec.ekf.channels))
    pe = PlanarEKF(rec.ekf.kf.vehicle, rec.ekf.params, rec.ekf.h)
    pe.initialise(rec.first_frame)

    def fw_predict() -> list[int]:
        out = []
        for t in ticks:
            kf.x_next, kf.P, kf.F, kf.Q = t.x_pred, t.P0, t.F, t.Q
            t0 = time.perf_counter_ns()
            kf.predict()
            out.append(time.perf_counter_ns() - t0)
            if not (np.array_equal(kf.P, t.P_pred) and np.array_equal(kf.x, t.x_pred)):
                raise RuntimeError("filterpy's predict replayed differs from the recording")
        return out

    def fw_update() -> list[int]:
        out = []
        for t in fused:
            f = t.fused
            assert f is not None
            pe.kf.x, pe.kf.P = f.x_in.copy(), f.P_in.copy()
            t0 = time.perf_counter_ns()
            pe._fuse(f.z, f.y, f.H, f.R, f.blind)
            out.append(time.perf_counter_ns() - t0)
            if not (np.array_equal(pe.kf.x, f.x_out) and np.array_equal(pe.kf.P, f.P_out)
                    and pe.nis_total[0] == f.nis):
                raise RuntimeError("PlanarEKF._fuse replayed differs from the recording")
        return out

    # (b) the numba step: each call's arguments unpacked before the clock starts
    def timed(fn, calls: list[tuple]) -> tuple[list[int], list]:
        """ns per call of fn(*args) for each args in ``calls``, and the results."""
        out, results = [], []
        for args in calls:
            t0 = time.perf_counter_ns()
            r = fn(*args)
            out.append(time.perf_counter_ns() - t0)
            results.append(r)
        return out, results

    predict_args = [(p["F"], p["P"], p["Q"], p["P_pred"]) for p in prep]
    update_args = [(p["x"], p["P_in"], p["H"], p["R"], p["y"], p["x_out"], p["P_out"]) for p in prep_f]
    both_args = [(p["F"], p["P"], p["Q"], p["x_pred"], p["H"], p["R"], p["y"], p["P_pred2"], p["x_out2"],
                  p["P_out2"]) for p in prep_f]

    def nb_predict() -> list[int]:
        return timed(cov_predict, predict_args)[0]

    def nb_update() -> list[int]:
        out, nis = timed(fuse_step, update_args)
        for p, v in zip(prep_f, nis, strict=True):
            p["nis"] = v
        return out

    def nb_both() -> list[int]:
        return timed(ekf_step, both_args)[0]

    def dispatch4() -> list[int]:
        return timed(_empty4, predict_args)[0]

    def dispatch7() -> list[int]:
        return timed(_empty7, update_args)[0]

    S_all = [np.dot(t.fused.H, np.dot(t.fused.P_in, t.fused.H.T)) + t.fused.R for t in fused if t.fused is not None]

    def inv_only() -> list[int]:
        out = []
        for S in S_all:
            t0 = time.perf_counter_ns()
            linalg.inv(S)
            out.append(time.perf_counter_ns() - t0)
        return out

    def timer() -> list[int]:
        out = []
        for _ in ticks:
            t0 = time.perf_counter_ns()
            out.append(time.perf_counter_ns() - t0)
        return out

    # the whole PlanarEKF, replayed from the recorded inputs on a fresh filter: both calls, or one of them
    def replay(which: str) -> list[int]:
        ekf = PlanarEKF(rec.ekf.kf.vehicle, rec.ekf.params, rec.ekf.h)
        ekf.update(rec.first_frame)
        out = []
        clock = time.perf_counter_ns
        for t in ticks:
            frame = t.frame
            assert frame is not None
            t0 = clock()
            ekf.predict(t.tau_stages, t.flow)
            t1 = clock()
            ekf.update(frame)
            t2 = clock()
            out.append(t2 - t0 if which == "both" else t1 - t0 if which == "predict" else t2 - t1)
        last = ticks[-1]
        assert last.x_post is not None and last.P_post is not None
        if not (np.array_equal(ekf.kf.x, last.x_post) and np.array_equal(ekf.kf.P, last.P_post)):
            raise RuntimeError("the replayed PlanarEKF differs from the mission's")
        return out

    timings: dict[str, dict] = {}
    runs = {"firmware_predict_P": fw_predict, "firmware_update_fuse": fw_update, "numba_predict_P": nb_predict,
            "numba_update": nb_update, "numba_step_one_call": nb_both, "numba_dispatch_4_args": dispatch4,
            "numba_dispatch_7_args": dispatch7, "scipy_linalg_inv_S": inv_only, "perf_counter_ns_pair": timer,
            "planar_ekf_whole_replayed": lambda: replay("both"),
            "planar_ekf_predict_replayed": lambda: replay("predict"),
            "planar_ekf_update_replayed": lambda: replay("update")}
    for name, (best, meds) in _passes(runs, repeat).items():
        timings[name] = _stats(best, meds)

    # agreement of (b) with (a) (the recording, which (a) reproduces bit for bit)
    def rel(a: np.ndarray, b: np.ndarray) -> float:
        return float(np.max(np.abs(b - a)) / np.max(np.abs(a)))

    agree = {"x_post": 0.0, "P_post": 0.0, "P_pred": 0.0, "nis": 0.0, "x_correction": 0.0,
             "P_post_diag_elementwise": 0.0, "one_call_x_post": 0.0, "one_call_P_post": 0.0}
    for t, p in zip(ticks, prep, strict=True):
        agree["P_pred"] = max(agree["P_pred"], rel(t.P_pred, p["P_pred"]))
        f = t.fused
        if f is None:
            continue
        xa, xb = f.x_out[:, 0], p["x_out"]
        agree["x_post"] = max(agree["x_post"], rel(xa, xb))
        dx = xa - f.x_in[:, 0]
        if np.max(np.abs(dx)) > 0:
            agree["x_correction"] = max(agree["x_correction"], float(np.max(np.abs(xb - xa)) / np.max(np.abs(dx))))
        agree["P_post"] = max(agree["P_post"], rel(f.P_out, p["P_out"]))
        da, db = np.diag(f.P_out), np.diag(p["P_out"])
        agree["P_post_diag_elementwise"] = max(agree["P_post_diag_elementwise"], float(np.max(np.abs(db - da) / da)))
        agree["nis"] = max(agree["nis"], abs(p["nis"] - f.nis) / f.nis)
        if np.array_equal(f.x_in, t.x_pred) and np.array_equal(f.P_in, t.P_pred):   # no reset on this tick
            agree["one_call_x_post"] = max(agree["one_call_x_post"], rel(xa, p["x_out2"]))
            agree["one_call_P_post"] = max(agree["one_call_P_post"], rel(f.P_out, p["P_out2"]))

    sizes: dict[str, int] = {}
    for t in fused:
        assert t.fused is not None
        k = str(t.fused.z.shape[0])
        sizes[k] = sizes.get(k, 0) + 1
    return {"timings": timings, "agreement_max_rel": agree,
            "ticks": len(ticks), "ticks_fused": len(fused), "fused_channels_count": sizes}


def _row(label: str, s: dict) -> str:
    return f"  {label:<44} {s['p50_us']:8.2f} {s['p99_us']:8.2f}"


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", default="W3")
    ap.add_argument("--controller", default="cpd_ff")
    ap.add_argument("--seed", type=int, default=None)
    ap.add_argument("--duration", type=float, default=60.0, help="mission length, s (default 60)")
    ap.add_argument("--mode", type=int, default=0, choices=(0,), help="WK_EKF_MODE (the paper's, 0, only)")
    ap.add_argument("--repeat", type=int, default=15, help="timed passes over the recording, each (default 15)")
    ap.add_argument("--no-write", action="store_true", help="print only, do not write results/ekf_step.json")
    args = ap.parse_args(argv)
    spec = _spec(args)
    rec = record(spec)
    fig = measure(rec, args.repeat)
    mission_ns = mission_cost(spec)
    fig["timings"]["planar_ekf_whole_in_mission"] = _stats(mission_ns)
    fig["mission"] = {"case": spec.case, "controller": spec.controller, "seed": spec.seed,
                      "duration_s": spec.duration, "WK_EKF_MODE": args.mode, "states": rec.ekf.n,
                      "channels": len(rec.ekf.channels)}
    fig["method"] = {
        "timer": "time.perf_counter_ns around each call; gc off; a warm-up pass of each, then --repeat rounds "
                 "of one pass over all recorded ticks of each in turn; the pass with the lowest median reported "
                 "(pass_p50_us: every pass's median)",
        "repeat": args.repeat,
        "firmware_predict_P": "filterpy ExtendedKalmanFilter.predict with predict_x handing over the recorded "
                              "predicted x: P = dot(F, P).dot(F.T) + Q and its x_prior/P_prior copies",
        "firmware_update_fuse": "PlanarEKF._fuse as the firmware called it (Joseph form, scipy.linalg.inv)",
        "scipy_linalg_inv_S": "scipy.linalg.inv alone on each tick's S = H P H^T + R (part of _fuse)",
        "numba": "@njit(cache=True), preallocated outputs, general H (m x n) and R (m x m); K = P H^T S^-1 by "
                 "Cholesky of S and forward/back substitution (no inverse); NIS = |L^-1 y|^2; Joseph P+",
        "planar_ekf_whole_replayed": "PlanarEKF.predict + update on a fresh filter from the recorded tau "
                                     "stages, flows and frames (bit for bit the mission's), RK4 and gating "
                                     "included",
        "planar_ekf_predict_replayed": "PlanarEKF.predict alone in that replay (RK4, Jacobian, Q, filterpy "
                                       "predict)",
        "planar_ekf_update_replayed": "PlanarEKF.update alone in that replay (gating, _fuse)",
        "planar_ekf_whole_in_mission": "the same calls timed inside a second identical mission, one pass",
        "agreement": "per tick max|numba - firmware| / max|firmware| (x_correction: over max|x+ - x-|); "
                     "maxima over ticks",
    }
    path = None if args.no_write else write("ekf_step", fig)
    t = fig["timings"]
    print(f"EKF step, {spec.case} {spec.controller} {spec.duration:g} s, WK_EKF_MODE {args.mode} "
          f"({rec.ekf.n} states, {len(rec.ekf.channels)} channels): {fig['ticks']} ticks, "
          f"{fig['ticks_fused']} fused {fig['fused_channels_count']}")
    print(f"  {'(µs)':<44} {'p50':>8} {'p99':>8}")
    print(_row("firmware predict: filterpy P = F P Fᵀ + Q", t["firmware_predict_P"]))
    print(_row("firmware update: PlanarEKF._fuse", t["firmware_update_fuse"]))
    print(_row("  of which scipy.linalg.inv(S) alone", t["scipy_linalg_inv_S"]))
    print(_row("numba predict: cov_predict", t["numba_predict_P"]))
    print(_row("numba update: fuse_step (Cholesky solve)", t["numba_update"]))
    print(_row("numba both, one call: ekf_step", t["numba_step_one_call"]))
    print(_row("  numba dispatch alone (4 / 7 array args)", t["numba_dispatch_4_args"])
          + f"  / {t['numba_dispatch_7_args']['p50_us']:.2f}")
    print(_row("  perf_counter_ns pair alone", t["perf_counter_ns_pair"]))
    print(_row("whole PlanarEKF predict + update (replayed)", t["planar_ekf_whole_replayed"]))
    print(_row("  PlanarEKF.predict alone (replayed)", t["planar_ekf_predict_replayed"]))
    print(_row("  PlanarEKF.update alone (replayed)", t["planar_ekf_update_replayed"]))
    print(_row("whole PlanarEKF predict + update (in mission)", t["planar_ekf_whole_in_mission"]))
    a = fig["agreement_max_rel"]
    print(f"  numba vs firmware, max rel: x⁺ {a['x_post']:.1e}  P⁺ {a['P_post']:.1e}  P⁻ {a['P_pred']:.1e}  "
          f"NIS {a['nis']:.1e}  (x⁺ vs the correction {a['x_correction']:.1e})")
    if path is not None:
        print(f"wrote {path}")
    return fig


if __name__ == "__main__":
    main()
